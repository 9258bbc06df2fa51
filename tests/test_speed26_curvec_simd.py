"""Round 26 (curvec): the curve core's elementwise loops (laws/_curvecore.c: kern_args,
pc_res, pc_step, pc_update, lay_mid) have a 4-wide AVX form, chosen at run time.  It must
give the scalar loops' bits, NaN rows included (a row with a NaN square or step is redone
by the scalar loop).  References, independent of the AVX code: the scalar loops of the
same core (simd(0)), and numpy's own expressions (curves._parts_block's numpy kernel,
circle._precond_cheb_np, circle._layers_total); on the curve planner's real inputs (the
bundled gyroid and, when the corpus is there, a slice of the gyroid plate) and on random
and degenerate ones."""
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt.laws import circle
from gcode_opt.pipeline import Options, process
from gcode_opt.profile import load_profile

CORE = circle.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "simd"), reason="no compiled curve core")
S = Path(__file__).resolve().parent.parent / "sample_gcode"
PLATE = Path.home() / ".cache/gcode-opt-corpus/plate_gyroid.gcode"


def _bits(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


@pytest.fixture
def both():
    """call(f, *args) -> (scalar loops' result, AVX loops' result); AVX back on after."""
    def call(f, *args):
        out = []
        for flag in (0, 1):
            CORE.simd(flag)
            with np.errstate(all="ignore"):
                out.append(f(*args))
        return out
    yield call
    CORE.simd(1)


def _kern(s_v, sd):
    m, n1 = s_v.shape
    k = np.empty((m, n1, n1 - 2))
    CORE.kern_args(s_v, sd, m, n1, k)
    return k


def _kern_numpy(s_v, sd):
    """curves._parts_block's numpy kernel (its path without the core)."""
    kern = np.subtract(s_v[:, :, None], s_v[:, None, 1:-1])
    np.divide(kern, sd[:, None, None], out=kern)
    np.square(kern, out=kern)
    np.subtract(kern, kern.min(axis=2, keepdims=True), out=kern)
    np.multiply(kern, -0.5, out=kern)
    return kern


def test_avx_is_used_where_the_cpu_has_it():
    CORE.simd(1)
    on = CORE.simd()
    assert CORE.simd(0) is False
    CORE.simd(1)
    assert CORE.simd() is on


def test_kern_args_scalar_and_avx_on_random_and_degenerate_rows(both):
    rng = np.random.default_rng(26)
    for n1 in (3, 5, 6, 7, 9, 12, 30, 61):
        m = 40
        d = rng.uniform(0.01, 2.0, (m, n1 - 1)) * rng.choice([1.0, 1e-6, 1e3], (m, 1))
        s_v = np.zeros((m, n1))
        np.cumsum(d, axis=1, out=s_v[:, 1:])
        sd = np.maximum(np.median(d, axis=1), 0.2)
        s_v[1, n1 // 2] = np.nan              # a NaN square in the middle of a row
        s_v[2, -1] = np.inf
        s_v[3, 1] = -np.inf                   # inf - inf
        sd[4], sd[5], sd[6] = 0.0, np.nan, -0.0
        s_v[7] = 0.0                          # every square +0.0
        a, b = both(_kern, s_v, sd)
        assert _bits(a, b), n1
        with np.errstate(all="ignore"):
            want = _kern_numpy(s_v, sd)
        ok = np.isfinite(s_v).all(axis=1) & np.isfinite(sd) & (sd != 0)
        assert _bits(b[ok], want[ok]), n1
        assert np.array_equal(np.isnan(b), np.isnan(want))


def test_precond_scalar_and_avx_and_numpy(both):
    rng = np.random.default_rng(261)
    for n in (16, 20, 24, 32, 64, 128):
        nb = 90
        phi = rng.uniform(0.05, 20.0, nb) * rng.choice([1.0, 1e-3, 40.0], nb)
        gam2 = np.exp(rng.uniform(-3.0, 6.0, nb))
        u0, u1 = phi * rng.uniform(0.0, 1.5, nb), phi * rng.uniform(0.0, 1.5, nb)
        phi[3], gam2[5], u0[7], u1[9] = 0.0, np.nan, np.inf, np.nan
        u0[8] = u1[8] = phi[8] = 0.0
        w0 = np.repeat(phi[:, None], n + 1, axis=1)
        a, b = both(circle._precond_cheb_c, n, phi, gam2, u0, u1, w0)
        assert all(_bits(x, y) for x, y in zip(a, b)), n
        with np.errstate(all="ignore"):
            want = circle._precond_cheb_np(n, phi, gam2, u0, u1, w0)
        fin = np.isfinite(b[0]).all(axis=1)          # NaN rows: numpy's NaN payloads may differ
        assert _bits(b[2], want[2]) and _bits(b[0][fin], want[0][fin]) and _bits(b[1][fin], want[1][fin]), n
        assert fin.sum() > nb - 10


def test_layers_scalar_and_avx_and_numpy(both):
    rng = np.random.default_rng(262)
    for n in (1, 3, 4, 5, 8, 203):
        phi = rng.uniform(-3.0, 30.0, n)
        gam2 = np.exp(rng.uniform(-5.0, 8.0, n))
        u0, u1 = rng.uniform(-5.0, 40.0, n), rng.uniform(-5.0, 40.0, n)
        if n > 100:
            u0[:20] = u1[:20] = phi[:20]        # d0 = 0: both layers flat
            gam2[30:35] = 0.0
            u0[40:43], u1[50:53], phi[60:63] = np.nan, np.inf, -np.inf
        xs = [rng.uniform(-50.0, 50.0, n), phi.copy(), phi + 1e-9, -phi]
        a, b = both(circle._layers_totals, xs, phi, gam2, u0, u1)
        assert all(_bits(x, y) for x, y in zip(a, b)), n
        with np.errstate(all="ignore"):
            want = [circle._layers_total(x, phi, gam2, u0, u1) for x in xs]
        assert all(_bits(x, y) for x, y in zip(b, want)), n


def _curve_run(path, prof, monkeypatch):
    """The curve planner's kernels' inputs on a real file: every _kappa_block (the curvature
    kernels of _parts_block and of κ made when read), _precond_cheb and _layers_totals call,
    and _layers_args (the layer iteration's steps with the core: lay_pre, lay_mid) (arguments
    copied)."""
    calls = {"pb": [], "pc": [], "lay": [], "lay_args": []}
    for mod, name, key in ((curves, "_kappa_block", "pb"), (circle, "_precond_cheb", "pc"),
                           (circle, "_layers_totals", "lay"), (circle, "_layers_args", "lay_args")):
        f = getattr(mod, name)

        def rec(*args, _f=f, _k=key):
            calls[_k].append(tuple(a.copy() if isinstance(a, np.ndarray) else
                                   [x.copy() for x in a] if isinstance(a, tuple) else a for a in args))
            return _f(*args)
        monkeypatch.setattr(mod, name, rec)
    return calls


def _check_calls(calls, both, limit):
    assert calls["pb"] and calls["pc"] and (calls["lay"] or calls["lay_args"])
    for args in calls["pb"][:limit]:
        a, b = both(curves._kappa_block, *args)
        assert all(_bits(x, y) for x, y in zip(a, b))
    for args in calls["pc"][:limit]:
        a, b = both(circle._precond_cheb, *args)
        assert all(_bits(x, y) for x, y in zip(a, b))
    for args in calls["lay"][:limit]:
        a, b = both(circle._layers_totals, *args)
        assert all(_bits(x, y) for x, y in zip(a, b))
    for args in calls["lay_args"][:limit]:
        a, b = both(circle._layers_args, *args)
        assert _bits(a, b)


def test_scalar_and_avx_on_the_pipelines_calls(both, tmp_path, monkeypatch):
    calls = _curve_run(None, None, monkeypatch)
    process(str(S / "prusa_gyroid.gcode"), str(tmp_path / "out.gcode"), load_profile("prusa-mk3s"), Options())
    monkeypatch.undo()
    _check_calls(calls, both, 10 ** 6)


@pytest.mark.skipif(not PLATE.exists(), reason="corpus plate not downloaded")
def test_scalar_and_avx_on_the_gyroid_plate(both, tmp_path, monkeypatch):
    lines = PLATE.read_text().splitlines(keepends=True)[:60000]      # its first layers
    src = tmp_path / "plate_head.gcode"
    src.write_text("".join(lines))
    calls = _curve_run(None, None, monkeypatch)
    process(str(src), str(tmp_path / "out.gcode"), load_profile("prusa-mk3s"), Options())
    monkeypatch.undo()
    _check_calls(calls, both, 40)


def test_output_bytes_the_same_without_avx(tmp_path):
    """The whole command's G-code with the AVX loops and with the scalar ones."""
    outs = []
    try:
        for flag in (1, 0):
            CORE.simd(flag)
            out = tmp_path / f"o{flag}.gcode"
            process(str(S / "prusa_gyroid.gcode"), str(out), load_profile("prusa-mk3s"), Options())
            outs.append(out.read_bytes())
    finally:
        CORE.simd(1)
    assert outs[0] == outs[1]


class _Prof:
    junction = "jerk"
    default_accel_a = 1000.0


def test_jerk_caps_core_as_numpy():
    """curves._jerk_caps_block (_curvecore.c jerk_caps) against _caps_core's numpy law of
    classic jerk, on unit directions of every quadrant, axis-aligned and reversing ones,
    zeros, NaN and inf, with per-row jerks (some 0, some huge) and both jerk shares."""
    if not hasattr(CORE, "jerk_caps"):
        pytest.skip("no jerk_caps")
    rng = np.random.default_rng(263)
    for m, n in ((1, 2), (5, 3), (60, 9), (300, 24)):
        ang = rng.uniform(-np.pi, np.pi, (m, n)).cumsum(axis=1) * rng.choice([0.05, 0.5, 1.0], (m, 1))
        u = np.stack([np.cos(ang), np.sin(ang)], axis=2)
        if m > 50:
            u[0] = [1.0, 0.0]
            u[1, ::2] = [0.0, -1.0]
            u[1, 1::2] = [0.0, 1.0]
            u[2, 1] = [-0.0, 0.0]
            u[3, 2] = [np.nan, 0.5]
            u[4, 1] = [np.inf, -np.inf]
            u[5] = -u[5]
        jx = rng.uniform(0.0, 20.0, (m, 1))
        jy = rng.uniform(0.0, 20.0, (m, 1))
        jx[::11] = 0.0
        jy[::13] = 1e9
        p = {"jerk_x": jx, "jerk_y": jy}
        for jerk_r in (1.0 - curves.JERK_F_STEP_R, 1.0):
            got = curves._jerk_caps_block(u, p, jerk_r)
            want = curves._caps_core(_Prof, p, u[:, :-1, 0], u[:, :-1, 1], u[:, 1:, 0], u[:, 1:, 1],
                                     None, None, jerk_r)
            assert _bits(got, np.ascontiguousarray(want)), (m, n, jerk_r)
