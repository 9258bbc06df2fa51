"""Round 36 (curvemat): the curvature kernel's symmetric interior block exp'd once.

_parts_block's kernel exp(-0.5 (z_ji - min_i z_ji)), z_ji = ((s_j - s_i) / d)^2, has in its
interior rows (j an interior vertex) the minimum +0.0 at the diagonal and z_ji = z_ij bit
for bit, so kern_pack (laws/_curvecore.c, sym_row) packs those rows' arguments from the
diagonal on only and kern_unpack copies the others from the column above: np.exp takes
~half the arguments.  Against the split kernel (kern_args + _exp_inplace, tested against
numpy's expression in tests/test_speed21_curvegeo_geom.py and test_speed31_geoms.py) bit
for bit, with the AVX forms and without, on random strokes and on the sample's blocks;
without the mirror (a machine whose np.exp depends on the argument's place: the probe
_exp_place_ok) the same kernel from all arguments.
"""
import os

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt.laws import circle

S = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "sample_gcode")
CORE = circle.CORE_MOD
needs_core = pytest.mark.skipif(CORE is None or not hasattr(CORE, "kern_pack"), reason="no compiled curve core")


def _bits(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def _split_kernel(s_v, smooth_d, n):
    """The kernel as kern_args then _exp_inplace make it (every argument packed as is)."""
    kern = np.empty((s_v.shape[0], n + 1, n - 1))
    CORE.kern_args(s_v, smooth_d, s_v.shape[0], n + 1, kern)
    curves._exp_inplace(kern)
    return kern


def _packed_count(s_v, smooth_d, n, mirror):
    """(how many arguments kern_pack packs for np.exp, its sym flags)."""
    m = s_v.shape[0]
    buf = np.empty(m * (n + 1) * (n - 1))
    rng = np.empty(m * (n + 1) * 2, np.int64)
    sym = np.empty(m, np.int64)
    cnt = CORE.kern_pack(s_v, smooth_d, m, n + 1, curves.EXP_ZERO_BELOW, mirror, buf, rng, sym)
    return cnt, sym


def _strokes(rng, m, n, lo=0.05, hi=0.4):
    return np.concatenate([np.zeros((m, 1)), np.cumsum(rng.uniform(lo, hi, (m, n)), axis=1)], axis=1)


@pytest.fixture
def split_kernel_here():
    if not curves._exp_zero_ok() or not curves._exp_place_ok():
        pytest.skip("np.exp here: the kernel is not split, or not mirrored")


@needs_core
@pytest.mark.parametrize("simd", [1, 0])
def test_mirrored_kernel_is_the_split_one(split_kernel_here, simd):
    rng = np.random.default_rng(36)
    was = CORE.simd()
    CORE.simd(simd)
    try:
        for n in (3, 4, 5, 6, 9, 17, 33, 64, 130):
            s_v = _strokes(rng, 7, n)
            sd = np.array([0.2, 0.05, 1e-3, 1e3, 0.5, 3.0, 0.01])  # some rows all kept, some mostly dropped
            s_v[1, 3:6] = s_v[1, 3]                                 # repeated vertices (still in order)
            with np.errstate(all="ignore"):
                got = curves._kern_packed(s_v, sd, n)
                want = _split_kernel(s_v, sd, n)
            assert got is not None and _bits(got, want), n
            cnt, sym = _packed_count(s_v, sd, n, True)
            full, nosym = _packed_count(s_v, sd, n, False)
            assert sym.tolist() == [1] * 7 and nosym.tolist() == [0] * 7
            assert cnt < full or n == 3          # (n = 3: one interior vertex, nothing to mirror)
    finally:
        CORE.simd(was)


@needs_core
def test_mirror_only_where_the_rows_are_known_runs(split_kernel_here):
    """Strokes kern_pack cannot know are one run a row (an unsorted interior, a non-finite
    vertex or width) are packed whole, next to mirrored ones in the same block; the
    kernel is the split one either way."""
    rng = np.random.default_rng(7)
    n = 12
    s_v = _strokes(rng, 5, n)
    sd = np.array([0.2, 0.3, 0.25, np.inf, 0.2])
    s_v[2, -1] = np.inf                          # an end vertex not finite
    s_v[4, 1] = -np.inf                          # an interior vertex not finite
    with np.errstate(all="ignore"):
        got = curves._kern_packed(s_v, sd, n)
        assert got is not None and _bits(got, _split_kernel(s_v, sd, n))
    _, sym = _packed_count(s_v, sd, n, True)
    assert sym.tolist() == [1, 1, 0, 0, 0]


@needs_core
def test_without_the_mirror_the_same_kernel(split_kernel_here, monkeypatch):
    rng = np.random.default_rng(3)
    n = 20
    s_v = _strokes(rng, 9, n)
    sd = np.full(9, 0.3)
    with_mirror = curves._kern_packed(s_v, sd, n)
    monkeypatch.setattr(curves, "_EXP_PLACE_OK", [False])
    assert _bits(curves._kern_packed(s_v, sd, n), with_mirror)


@needs_core
def test_sample_blocks_mirrored(split_kernel_here, monkeypatch):
    """The sample's curve blocks: under 60 % of the arguments go through np.exp, and the
    kernel and every _parts_block figure are those of the unmirrored kernel."""
    from gcode_opt.pipeline import Options, analyse
    from gcode_opt.profile import load_profile
    from gcode_opt.strokes import K_CURVE
    strokes, _ = analyse(os.path.join(S, "prusa_gyroid.gcode"), load_profile("prusa-mk3s"), Options())
    sts = [st for st in strokes if st.kind == K_CURVE]
    inputs = []
    orig = curves._kern_packed

    def spy(s_v, smooth_d, n):
        inputs.append((s_v.copy(), smooth_d.copy(), n))
        return orig(s_v, smooth_d, n)
    monkeypatch.setattr(curves, "_kern_packed", spy)
    got = [b for _, b in curves._part_blocks(sts)]
    monkeypatch.setattr(curves, "_kern_packed", orig)
    assert len(inputs) > 3
    packed = full = 0
    for s_v, sd, n in inputs:
        with np.errstate(all="ignore"):
            assert _bits(curves._kern_packed(s_v, sd, n), _split_kernel(s_v, sd, n))
        packed += _packed_count(s_v, sd, n, True)[0]
        full += _packed_count(s_v, sd, n, False)[0]
    assert packed < 0.6 * full
    monkeypatch.setattr(curves, "_EXP_PLACE_OK", [False])
    ref = [b for _, b in curves._part_blocks(sts)]
    assert len(ref) == len(got)
    for a, b in zip(got, ref):
        for x, y in zip(a, b):
            assert _bits(x, y)


def test_place_probe_catches_a_place_dependent_exp():
    """_same_at_every_place: np.exp passes here (or the mirror is off); a function whose
    last element differs by one unit in the last place from its value elsewhere fails."""
    def tail_off(x):
        y = np.exp(x)
        if np.ndim(y) and y.size > 1:
            y[-1] = np.nextafter(y[-1], np.inf)
        return y
    assert curves._same_at_every_place(np.exp) == curves._exp_place_ok()
    assert not curves._same_at_every_place(tail_off)
