"""Round 64 (crv): the curve plans' and figures' laws by series length, and two compiled steps.

* curves._knot_speeds and curves.true_figures take their laws in the order of their own
  number of Chebyshev coefficients (_by_series_length), so that a chunk's BLAS calls of 32
  rows of one length are whole blocks; each law's numbers are its own, so the same knots
  (against 882d7e9's curve_knots, test_speed47_bud47_knots.old_curve_knots, and against
  the laws' own order) and the same figures, bit for bit.
* _curvecore.c row_scale p=3: np.maximum(R x / T, 0.0), numpy's maximum (NaN, -0.0).
* interp_rows' slope made once for a run of points at one knot: np.interp's numbers."""
import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt.laws import circle
from test_speed47_bud47_knots import _curve_laws, _same_knots, old_curve_knots  # noqa: E402

CORE = circle.CORE_MOD


@pytest.fixture(scope="module")
def laws():
    """The bundled gyroid's finite curve candidates (strokes, T, beta, profile) and their
    circle laws (law, R, geometries)."""
    sts, T, beta, prof, _ = _curve_laws("prusa_gyroid.gcode", "prusa-mk3s")
    geos = [curves.geom(st, prof) for st in sts]
    S, v0, v1 = (np.array([getattr(st, f) for st in sts]) for f in ("length_d", "v0", "v1"))
    law, R = curves._solve(None, geos, S, T, beta, v0, v1)
    return sts, T, beta, prof, law, R, geos


def test_laws_of_mixed_lengths_are_taken_by_length(laws):
    law = laws[4]
    order = curves._by_series_length(law.coef)
    if not circle.rows_invariant():
        assert order is None
        pytest.skip("this BLAS does not give rows their own bits: the laws' own order")
    length = circle._row_lengths(law.coef)
    assert order is not None and len(set(length.tolist())) > 1
    assert (np.diff(length[order]) >= 0).all() and sorted(order.tolist()) == list(range(len(law)))
    same = np.sort(length)                            # (already in order: none)
    assert curves._by_series_length(np.eye(same.max())[same - 1]) is None


def test_knot_speeds_by_length_as_in_order(laws, monkeypatch):
    sts, T, beta, prof = laws[:4]
    got = curves.curve_knots(sts, T, beta, prof)
    _same_knots(got, old_curve_knots(sts, T, beta, prof))
    monkeypatch.setattr(curves, "_by_series_length", lambda coef: None)
    _same_knots(got, curves.curve_knots(sts, T, beta, prof))


def test_knot_speeds_by_length_without_interp_rows(laws, monkeypatch):
    sts, T, beta, prof = laws[:4]
    want = curves.curve_knots(sts, T, beta, prof)
    monkeypatch.setattr(curves, "_INTERP_ROWS", None)
    _same_knots(curves.curve_knots(sts, T, beta, prof), want)


def test_true_figures_by_length_as_in_order(laws, monkeypatch):
    law, R, geos = laws[4:]
    law.grid_levels = 6
    memo = curves._Knots.of(geos) if curves._INTERP_ROWS is not None else {}
    got = curves.true_figures(law, R, geos, None, memo)
    monkeypatch.setattr(curves, "_by_series_length", lambda coef: None)
    want = curves.true_figures(law, R, geos, None, memo)
    assert all(np.asarray(g).tobytes() == np.asarray(w).tobytes() for g, w in zip(got, want))
    assert np.isfinite(np.asarray(got)).all()


@pytest.mark.skipif(CORE is None, reason="no compiled curve core")
def test_row_scale_clamp_as_numpy():
    rng = np.random.default_rng(64)
    x = rng.normal(size=(37, 19))
    x[0, :6] = [-0.0, 0.0, np.nan, -np.inf, np.inf, 1e-320]
    x[1] = -0.0
    R, T = rng.uniform(0.5, 2.0, 37), rng.uniform(0.1, 1.0, 37)
    R[2], T[3] = np.nan, 0.0
    with np.errstate(all="ignore"):
        want = np.maximum(R[:, None] * x / T[:, None], 0.0)
        for flag in (1, 0):
            try:
                CORE.simd(flag)
                got = curves._row_scale(x, R, T, 3)
            finally:
                CORE.simd(1)
            assert got.tobytes() == want.tobytes()
    assert np.signbit(want[1]).any() is np.False_ and np.isnan(want[2]).all()


@pytest.mark.skipif(CORE is None, reason="no compiled curve core")
def test_interp_rows_runs_of_points_at_a_knot():
    """Rows of many points a knot, going forward and jumping back (the figures' quadrature
    grid then the uniform one), at knots exactly, outside, NaN: np.interp's numbers."""
    rng = np.random.default_rng(65)
    nr, m = 40, 300
    xs, ys, off, cnt = [], [], [], []
    for r in range(nr):
        n = int(rng.integers(2, 12))
        off.append(sum(cnt))
        cnt.append(n)
        xs.append(np.cumsum(rng.uniform(0.1, 2.0, n)) - 0.1)
        ys.append(rng.normal(size=n) * rng.choice([1.0, 1e-300, 1e300]))
    s = np.empty((nr, m))
    for r in range(nr):
        lo, hi = xs[r][0] - 0.5, xs[r][-1] + 0.5
        s[r] = np.concatenate([np.sort(rng.uniform(lo, hi, m // 2)), np.sort(rng.uniform(lo, hi, m - m // 2))])
        s[r, :3] = xs[r][:3] if cnt[r] >= 3 else s[r, :3]
    s[5, 10] = np.nan
    X, Y = np.concatenate(xs), np.concatenate(ys)
    out = np.empty_like(s)
    CORE.interp_rows(s, np.array(off, np.int64), np.array(cnt, np.int64), X, Y, nr, m, X.size, out)
    for r in range(nr):
        want = np.interp(s[r], xs[r], ys[r])
        assert out[r].tobytes() == want.tobytes(), r
