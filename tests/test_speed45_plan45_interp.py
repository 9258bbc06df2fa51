"""Issue 8, round 45 (plan45): _curvecore.c interp_rows finds each point's knot from the
last point's (knot_at: that knot and the next two, else a binary search of the knots on
the side of it the point lies), not by a binary search of every knot a point.  The knot
is the last with xp[j] <= x, one knot whatever finds it, so the values must be
np.interp's bit for bit: on random rows whose points go forward, backward, jitter, hit
knots exactly, fall outside the knots or are NaN, and through _kappa_rows on a sample's
curve geometries."""
import numpy as np
import pytest

from gcode_opt import curves

try:
    from numpy._core.multiarray import interp as _np_interp
except ImportError:                                    # numpy < 2
    from numpy.core.multiarray import interp as _np_interp

pytestmark = pytest.mark.skipif(curves._INTERP_ROWS is None, reason="curve core not built")


def _rows(rng, nr, m, order):
    cnts = rng.integers(2, 40, nr)
    off = np.concatenate([[0], np.cumsum(cnts)[:-1]]).astype(np.int64)
    xs = np.concatenate([np.cumsum(rng.uniform(0.01, 2.0, c)) - rng.uniform(0.0, 3.0) for c in cnts])
    ys = rng.normal(size=xs.size)
    s = np.empty((nr, m))
    for r in range(nr):
        xp = xs[off[r]:off[r] + cnts[r]]
        v = rng.uniform(xp[0] - 1.0, xp[-1] + 1.0, m)
        if order == "forward":
            v = np.sort(v)
        elif order == "backward":
            v = np.sort(v)[::-1]
        elif order == "jitter":
            v = np.sort(v) + rng.normal(0.0, 0.3, m)
        elif order == "dense":              # many points a knot interval
            v = np.linspace(xp[0], xp[-1], m)
        hit = rng.random(m) < 0.2
        v[hit] = rng.choice(xp, int(hit.sum()))
        if rng.random() < 0.2:
            v[rng.integers(m)] = np.nan
        s[r] = v
    return s, off, cnts.astype(np.int64), xs, ys


@pytest.mark.parametrize("order", ["forward", "backward", "jitter", "random", "dense"])
def test_interp_rows_is_np_interp(order):
    rng = np.random.default_rng(45)
    for _ in range(300):
        nr, m = int(rng.integers(1, 6)), int(rng.integers(1, 60))
        s, off, cnt, xs, ys = _rows(rng, nr, m, order)
        out = np.empty_like(s)
        curves._INTERP_ROWS(s, off, cnt, xs, ys, nr, m, xs.size, out)
        for r in range(nr):
            ref = _np_interp(s[r], xs[off[r]:off[r] + cnt[r]], ys[off[r]:off[r] + cnt[r]], None, None)
            assert np.array_equal(ref.view(np.int64), out[r].view(np.int64))


@pytest.mark.parametrize("name", ["prusa_gyroid.gcode", "prusa_concentric.gcode"])
def test_kappa_rows_on_sample_curves(name):
    """_kappa_rows by the core (knots laid out) against its np.interp path, on a sample's
    curve geometries at points along each (forward, backward, beyond the ends)."""
    from gcode_opt import schedule as sc
    from gcode_opt.pipeline import Options, analyse
    from gcode_opt.profile import load_profile
    from gcode_opt.strokes import K_CURVE
    prof, opts = load_profile("prusa-mk3s"), Options()
    strokes, _ = analyse("sample_gcode/" + name, prof, opts)
    rows = sc._rows_by_kind(strokes)[K_CURVE]
    geos = [curves.geom(strokes[i], prof) for i in rows.tolist()]
    assert len(geos) > 20
    length = np.array([g.s_v[-1] for g in geos])
    rng = np.random.default_rng(8)
    u = np.linspace(-0.05, 1.05, 97)
    for s in (length[:, None] * u[None, :], length[:, None] * u[None, ::-1],
              length[:, None] * rng.uniform(-0.05, 1.05, (len(geos), 97))):
        knots = curves._Knots.of(geos)
        assert knots is not None and knots.ok.any()
        got = curves._kappa_rows(geos, s, knots)
        want = curves._kappa_rows(geos, s)
        assert np.array_equal(got.view(np.int64), want.view(np.int64))
