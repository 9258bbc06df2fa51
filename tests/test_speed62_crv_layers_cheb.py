"""Round 62 (crv): two compiled steps of the curve candidates' circle solves.

* circle._solve_layers_batch's iteration with the curve core (_layers_iterate_c): each step's
  residual sums, slope, bracket, step, bisection, test and the packing of the live arcs in one
  pass (_curvecore.c lay_step), around the same lay_pre / np.exp / lay_mid / np.arcsinh.  It
  must give the numpy loop's w_c (the same function without the core) bit for bit, also where
  the steps run out (_LAYERS_ITER lowered) and on degenerate arcs (zero, huge, NaN, inf).
* _curvecore.c cheb_der_int's rows 4 at a time with AVX: the scalar rows' bits (simd(0)), and
  numpy.polynomial's, whatever the number of rows (a multiple of 4 or not) and coefficients."""
import numpy as np
import pytest

from gcode_opt.laws import circle

CORE = circle.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "lay_step"), reason="no compiled curve core")


def _same(a, b):
    """The same doubles bit for bit; NaN where NaN (a NaN's sign aside: see
    test_speed21_curvegeo_layers._bits)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    na, nb = np.isnan(a), np.isnan(b)
    return a.shape == b.shape and np.array_equal(na, nb) and np.array_equal(a[~na].view(np.int64),
                                                                          b[~nb].view(np.int64))


def _arcs(seed, n):
    rng = np.random.default_rng(seed)
    phi = rng.uniform(0.0, 30.0, n) * rng.choice([1.0, 1e-6, 40.0], n)
    gam2 = np.exp(rng.uniform(-6.0, 9.0, n))
    u0 = phi * rng.uniform(0.0, 1.6, n) * rng.choice([1.0, 0.0, 5.0], n)
    u1 = phi * rng.uniform(0.0, 1.6, n) * rng.choice([1.0, 0.0, 5.0], n)
    u0[:5] = u1[:5] = phi[:5]                   # flat layers: w_c = phi at once
    if n > 8:
        phi[5], u0[6], u1[7], gam2[8] = 0.0, 0.0, 1e6, 1e-12
    return phi, gam2, u0, u1


def _numpy_loop(monkeypatch, *args):
    with monkeypatch.context() as m:
        m.setattr(circle, "CORE_MOD", None)
        return circle._solve_layers_batch(*args)


@pytest.mark.parametrize("seed, n", [(1, 1), (2, 3), (3, 64), (4, 2000)])
def test_layer_iteration_core_as_the_numpy_loop(monkeypatch, seed, n):
    args = _arcs(seed, n)
    with np.errstate(all="ignore"):
        got = circle._solve_layers_batch(*args)
        want = _numpy_loop(monkeypatch, *args)
    assert _same(got, want) and np.isfinite(got).all()


@pytest.mark.parametrize("steps", [1, 2, 3, 5])
def test_layer_iteration_core_as_the_numpy_loop_when_the_steps_run_out(monkeypatch, steps):
    args = _arcs(9, 500)
    monkeypatch.setattr(circle, "_LAYERS_ITER", steps)
    with np.errstate(all="ignore"):
        got = circle._solve_layers_batch(*args)
        want = _numpy_loop(monkeypatch, *args)
    assert _same(got, want)
    # (some arcs still live when the steps ran out: the test reaches that path)
    monkeypatch.setattr(circle, "_LAYERS_ITER", 100)
    assert not _same(got, circle._solve_layers_batch(*args))


def test_layer_iteration_core_on_non_finite_arcs(monkeypatch):
    phi, gam2, u0, u1 = _arcs(11, 300)
    phi[10], gam2[11], u0[12], u1[13] = np.nan, np.inf, -np.inf, np.nan
    gam2[14] = 0.0
    with np.errstate(all="ignore"):
        got = circle._solve_layers_batch(phi, gam2, u0, u1)
        want = _numpy_loop(monkeypatch, phi, gam2, u0, u1)
    assert _same(got, want)


def test_layer_regime_the_same_with_and_without_the_core(monkeypatch):
    """The whole first step of solve_circles (w_c, regime, and the numbers after)."""
    rng = np.random.default_rng(5)
    n = 1000
    phi, T = rng.uniform(0.01, 20.0, n), rng.uniform(0.01, 2.0, n)
    beta = 10.0 ** rng.uniform(-6.0, -1.0, n)
    w0, w1 = phi / T * rng.uniform(0.0, 1.5, n), phi / T * rng.uniform(0.0, 1.5, n)
    got = circle._layer_regime(phi, T, beta, w0, w1)
    with monkeypatch.context() as m:
        m.setattr(circle, "CORE_MOD", None)
        want = circle._layer_regime(phi, T, beta, w0, w1)
    assert all(_same(a, b) for a, b in zip(got, want))
    assert got[1].any() and not got[1].all()        # (both regimes met)


@pytest.mark.parametrize("K", [2, 3, 4, 17, 21, 33, 256, 257])
def test_cheb_der_int_avx_rows_as_the_scalar_rows(K):
    if not CORE.simd():
        pytest.skip("no AVX")
    rng = np.random.default_rng(K)
    for nb in (1, 3, 4, 5, 8, 13, 64):
        c = rng.normal(size=(nb, K)) * rng.choice([1.0, 1e-3, 1e5, 0.0], (nb, K))
        if nb > 4:
            c[4, -1] = -0.0
            c[nb - 1, 0] = np.nan
        with np.errstate(all="ignore"):
            try:
                CORE.simd(0)
                want = circle._cheb_der_int(c)
            finally:
                CORE.simd(1)
            got = circle._cheb_der_int(c)
        assert all(x.tobytes() == y.tobytes() and x.strides == y.strides for x, y in zip(got, want)), (K, nb)


# ---------------------------------------------------------------- round 62: the lean probe
from pathlib import Path  # noqa: E402

from gcode_opt import curves  # noqa: E402
from gcode_opt.pipeline import Options, process  # noqa: E402
from gcode_opt.profile import load_profile  # noqa: E402

S = Path(__file__).resolve().parent.parent / "sample_gcode"


def test_cheb_der_int_either_alone_as_both():
    rng = np.random.default_rng(7)
    for K in (2, 5, 21, 300):
        c = rng.normal(size=(9, K))
        der, itg = circle._cheb_der_int(c)
        d1, none1 = circle._cheb_der_int(c, itg=False)
        none2, i2 = circle._cheb_der_int(c, der=False)
        assert none1 is None and none2 is None
        assert d1.tobytes() == der.tobytes() and i2.tobytes() == itg.tobytes()


def test_eval_tau_leaves_out_what_is_not_asked_the_rest_the_same():
    rng = np.random.default_rng(3)
    n = 40
    phi, T = rng.uniform(0.1, 9.0, n), rng.uniform(0.05, 1.0, n)
    law = circle.solve_circles(phi, T, 10.0 ** rng.uniform(-5, -2, n), phi / T * 0.7, phi / T * 0.9, 2.0)
    tau = np.broadcast_to(np.linspace(0.0, 1.0, 17)[None, :], (n, 17))
    full = law.eval_tau(tau, w2=False)
    for kw in (dict(phi=False), dict(w=False), dict(w=False, w1=False), dict(phi=False, w1=False)):
        got = law.eval_tau(tau, w2=False, **kw)
        for g, f, name in zip(got, full, ("phi", "w", "w1", "w2")):
            if kw.get(name, True) and name != "w2":
                assert g.tobytes() == f.tobytes(), (kw, name)
            else:
                assert g is None, (kw, name)
    idx = np.array([3, 7, 8, 30])
    assert law.eval_tau(tau[:4], idx, w2=False, w1=False, w=False)[0].tobytes() == full[0][idx].tobytes()


@pytest.fixture(scope="module")
def probes(tmp_path_factory):
    """surely_over's calls of the curve planner on the bundled gyroid and concentric files
    (arguments as given: the laws, R, geometries, limits, knots)."""
    got = []
    f = curves.surely_over
    mp = pytest.MonkeyPatch()

    def rec(law, R, geos, v_lim, a_lim, memo=None, why=None):
        got.append((law, R.copy(), list(geos), v_lim.copy(), a_lim.copy(), memo))
        return f(law, R, geos, v_lim, a_lim, memo, why)
    try:
        mp.setattr(curves, "surely_over", rec)
        d = tmp_path_factory.mktemp("probe62")
        for name in ("prusa_gyroid.gcode", "prusa_concentric.gcode"):
            process(str(S / name), str(d / name), load_profile("prusa-mk3s"), Options())
    finally:
        mp.undo()
    assert sum(len(a[2]) for a in got) > 500
    return got


def _surely_over_ref(law, R, geos, v_lim, a_lim, memo=None, why=None):
    """The start commit's (9769440) surely_over, verbatim: φ, κ(s) and |a| of every law."""
    _PROBE_TAU, _row_scale, _kappa_rows, _rows_of = (curves._PROBE_TAU, curves._row_scale, curves._kappa_rows,
                                                     curves._rows_of)
    PROBE_MARGIN_R = curves.PROBE_MARGIN_R
    over = np.zeros(len(geos), bool)
    a_only = np.zeros(len(geos), bool)
    for sl in law.row_chunks():
        sub = law.rows(sl)
        phi, w, w1, _ = sub.eval_tau(np.broadcast_to(_PROBE_TAU[None, :], (len(sub), _PROBE_TAU.size)),
                                     w2=False)
        T, Rr = sub.T_t, R[sl]
        v = _row_scale(w, Rr, T, 1)
        at = _row_scale(w1, Rr, T, 2)
        kv2 = _kappa_rows(geos[sl], _row_scale(phi, Rr), _rows_of(memo, sl)) * (v * v)
        a2 = at * at + kv2 * kv2
        over_v = np.max(v, axis=1) > v_lim[sl] * (1.0 + PROBE_MARGIN_R)
        over_a = np.sqrt(np.max(a2, axis=1)) > a_lim[sl] * (1.0 + PROBE_MARGIN_R)
        over[sl] = over_v | over_a
        a_only[sl] = over_a & ~over_v
    if why is not None:
        why.append(a_only)
    return over


def _probe_both(law, R, geos, v_lim, a_lim, memo):
    lean, full = [], []
    with np.errstate(all="ignore"):
        got = curves.surely_over(law, R, geos, v_lim, a_lim, memo, lean)
        want = _surely_over_ref(law, R, geos, v_lim, a_lim, memo, full)
    return (got, lean[0]), (want, full[0])


def test_lean_probe_as_the_full_one_on_the_pipelines_calls(probes):
    if not isinstance(probes[0][5], curves._Knots):
        pytest.skip("no compiled knots")
    lean_rows = 0
    for law, R, geos, v_lim, a_lim, memo in probes:
        for scale_v, scale_a in ((1.0, 1.0), (1.0, 0.2), (0.3, 1.0), (1.0, 5.0)):
            (got, why), (want, why_w) = _probe_both(law, R, geos, v_lim * scale_v, a_lim * scale_a, memo)
            assert np.array_equal(got, want) and np.array_equal(why, why_w)
        lean_rows += int(memo.tame.sum())
    assert lean_rows > 500


def test_lean_probe_on_wild_rows(probes):
    """Rows the shortcut must leave to the full |a|: NaN and huge coefficients, huge κ at a
    knot, NaN R: the same decisions as the full probe."""
    law, R, geos, v_lim, a_lim, memo = max(probes, key=lambda a: len(a[2]))
    if not isinstance(memo, curves._Knots):
        pytest.skip("no compiled knots")
    n = len(geos)
    law = law.take(np.arange(n))                     # (a copy: its arrays written below)
    law.coef[0, :] = np.nan
    law.coef[1, 0] = 1e200
    R = R.copy()
    R[2] = np.nan
    ys = memo.ys.copy()
    ys[memo.off[3]] = 1e300
    far = [i for i in range(n) if memo.off[i] != memo.off[3]][-1]      # (a row of another geometry)
    ys[memo.off[far]:memo.off[far] + memo.cnt[far]] = np.nan           # κ NaN: |a|² NaN, not over
    kn = curves._Knots(memo.xs, ys, memo.off, memo.cnt, memo.ok, memo.tame.copy())
    kn.tame[memo.off == memo.off[3]] = False         # (as _Knots.of marks such rows)
    kn.tame[memo.off == memo.off[far]] = False
    for a_scale in (1.0, 0.1, 1e-6):
        (got, why), (want, why_w) = _probe_both(law, R, geos, v_lim, a_lim * a_scale, kn)
        assert np.array_equal(got, want) and np.array_equal(why, why_w)


class _G:
    def __init__(self, s_v, kappa_v):
        self.s_v, self.kappa_v = np.asarray(s_v, float), np.asarray(kappa_v, float)


def test_knots_tame_marks_the_rows_whose_kappa_may_not_be_finite():
    gs = [_G([0, 1, 2], [0.1, 0.2, 0.3]),               # tame
          _G([0, 1, 2], [0.1, np.nan, 0.3]),            # NaN κ
          _G([0, 1, 2], [0.1, 2e30, 0.3]),              # |κ| over TAME_KAPPA
          _G([0, 1e-300, 2], [0.1, 0.2, 0.3]),          # knots closer than TAME_GAP
          _G([0, 1, 1], [0.1, 0.2, 0.3]),               # not increasing (not ok either)
          _G([0], [0.5]),                               # one knot (np.interp's)
          _G([0, 3], [-1e30, 1e30])]                    # at the bounds: tame
    kn = curves._Knots.of(gs)
    assert kn.tame.tolist() == [True, False, False, False, False, False, True]
    assert kn.ok.tolist() == [True, True, True, True, False, False, True]
    assert kn.sub(np.array([6, 0, 1])).tame.tolist() == [True, True, False]


def test_probe_rows_as_numpy():
    """_curvecore.c probe_rows: numpy's row maxima (NaN propagating) compared with the caps."""
    rng = np.random.default_rng(62)
    nb, m = 300, 17
    v = rng.normal(size=(nb, m)) * rng.choice([1.0, 1e3, 1e152], (nb, 1))
    at = rng.normal(size=(nb, m)) * rng.choice([1.0, 1e3, 1e200], (nb, 1))
    v[5, 3], at[6, 4], v[7, 0], at[8, 16] = np.nan, np.nan, np.inf, -np.inf
    v[9], at[10] = -0.0, 0.0
    v_cap, a_cap = rng.uniform(0.5, 2.0, nb), rng.uniform(0.5, 2.0, nb)
    v_cap[11], a_cap[12] = np.nan, np.inf
    for flag in (1, 0):                              # (AVX rows, scalar rows)
        for cols in (m, 3, 6):                       # (a row of 17: 4 x 4 + 1; 3: no AVX; 6: 4 + 2)
            vv, aa = np.ascontiguousarray(v[:, :cols]), np.ascontiguousarray(at[:, :cols])
            over_v, by_at, v_ok = np.empty((3, nb), bool)
            try:
                CORE.simd(flag)
                CORE.probe_rows(vv, aa, nb, cols, v_cap, a_cap, over_v, by_at, v_ok)
            finally:
                CORE.simd(1)
            with np.errstate(all="ignore"):
                assert np.array_equal(over_v, np.max(vv, axis=1) > v_cap)
                assert np.array_equal(by_at, np.sqrt(np.max(aa * aa, axis=1)) > a_cap)
                assert np.array_equal(v_ok, (np.abs(vv) <= 1e150).all(axis=1))
            assert over_v.any() and not over_v.all() and by_at.any() and not by_at.all() and not v_ok.all()
