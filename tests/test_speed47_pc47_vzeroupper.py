"""Round 47 (pc47): the compiled preconditioned iteration's AVX form (_curvecore.c pc_row_avx)
clears the upper halves of the YMM registers (vzeroupper) before it calls np_pairwise_sum,
which is built for any x86-64 (SSE code).  Reached with the upper halves dirty, SSE
instructions pay an AVX-SSE transition (or a merge per instruction, by CPU): the iteration
took ~90 ms of CPU on the rectilinear plate's arcs, ~29 ms with the upper halves cleared
(the same instructions, the same bits).

* the bits: the AVX form, the scalar form and the numpy form give the same (w, C, ok) on
  random arcs at the ladder's N (tests/test_speed26_curvec_simd.py and
  tests/test_speed20_curves_core.py check every call of the pipeline on the samples);
* the instructions: in pc_row_avx's machine code, no call of np_pairwise_sum is reached
  with a YMM register written since the last vzeroupper (objdump; skipped without it).
  Without the two _mm256_zeroupper() calls this fails (checked: the first call, r2's sum,
  came right after the AVX loop of w q)."""
import re
import shutil
import subprocess

import numpy as np
import pytest

from gcode_opt.laws import circle
from test_speed46_cheb46_circle import _random_rows     # (random circle-law rows, the same draws)

CORE = circle.CORE_MOD


def _bits(a, b):
    return a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.mark.skipif(CORE is None, reason="no compiled core")
@pytest.mark.parametrize("n", [16, 20, 24, 32, 48])
def test_avx_scalar_and_numpy_forms_same_bits(n):
    phi, gam2, u0, u1 = _random_rows(n, 300)
    w0 = np.repeat(phi[:, None], n + 1, axis=1)
    want = circle._precond_cheb_np(n, phi, gam2, u0, u1, w0)
    assert want[2].mean() > 0.9
    for flag in (1, 0):
        CORE.simd(flag)
        try:
            got = circle._precond_cheb_c(n, phi, gam2, u0, u1, w0)
        finally:
            CORE.simd(1)
        assert all(_bits(x, y) for x, y in zip(got, want)), flag


def _function_lines(name):
    so = getattr(CORE, "__file__", None)
    objdump = shutil.which("objdump")
    if so is None or objdump is None:
        pytest.skip("no objdump or no core file")
    out = subprocess.run([objdump, "-d", "--no-show-raw-insn", so], capture_output=True, text=True).stdout
    m = re.search(r"^[0-9a-f]+ <%s>:\n(.*?)\n\n" % re.escape(name), out, re.S | re.M)
    if m is None:
        pytest.skip(f"{name} not in the core's symbols (stripped, or built without AVX)")
    return m.group(1).splitlines()


def _sse_calls_with_dirty_upper(lines, callee):
    """Calls of callee reached, in the code's layout order, with a YMM register written since
    the last vzeroupper (a call returns clean: its callees are SSE code or end with one)."""
    dirty, bad = False, []
    for ln in lines:
        if "vzeroupper" in ln:
            dirty = False
        elif "call" in ln.split("\t")[-1][:6]:
            if f"<{callee}>" in ln and dirty:
                bad.append(ln.strip())
            dirty = False
        elif "%ymm" in ln:
            dirty = True
    return bad


@pytest.mark.skipif(CORE is None, reason="no compiled core")
def test_pairwise_sums_called_with_the_upper_halves_clear():
    lines = _function_lines("pc_row_avx")
    calls = [ln for ln in lines if "<np_pairwise_sum>" in ln]
    if not calls:
        pytest.skip("np_pairwise_sum inlined: no call to check")
    assert _sse_calls_with_dirty_upper(lines, "np_pairwise_sum") == []


def test_the_check_sees_a_dirty_call():
    """The scan itself: a call right after a YMM write is found, one after vzeroupper is not."""
    lines = ["  1:\tvmulpd %ymm1,%ymm2,%ymm3", "  2:\tcall   3f70 <np_pairwise_sum>",
             "  3:\tvaddpd %ymm1,%ymm2,%ymm3", "  4:\tvzeroupper", "  5:\tcall   3f70 <np_pairwise_sum>",
             "  6:\tvaddsd %xmm1,%xmm2,%xmm3", "  7:\tcall   3f70 <np_pairwise_sum>"]
    assert _sse_calls_with_dirty_upper(lines, "np_pairwise_sum") == ["2:\tcall   3f70 <np_pairwise_sum>"]
