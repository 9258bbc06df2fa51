"""Round 21 (curvegeo): build_geoms and the curve candidates' series made cheaper.

* curves._parts_block's np.exp of the curvature kernel goes through _exp_inplace: with the
  curve core, the arguments below EXP_ZERO_BELOW (a quarter on the gyroid plate, which
  libm's exp takes ~3x longer over: they underflow) are set to +0.0 and the others packed
  for one np.exp (only where np.exp gave +0.0 on _exp_zero_ok's probe);
* curves._ends_rows reads the neighbours' directions as the strokes keep them (no tuple per
  stroke) and makes a tuple only for strokes with an end turn;
* curves.build_geoms makes its CurveGeoms with __init__'s fields set directly (no tuple a
  stroke for the caps);
* laws/circle._series_values keeps the Chebyshev values of a grid that recurs (_vander_t)
  and gathers no rows when every row shares the grid.

The start commit's (d3559db) functions are kept here verbatim as the references (but
for reading CAPS_CHUNK and _CURVE_CORE from curves, so that tests can set them); every
field must be the same bits (and types) on the bundled curve files under several profiles,
the corpus files when present, and random and degenerate input."""
import math
import os

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt.curves import (CAPS_CHUNK, CORNER_COS, JERK_F_STEP_R, MAX_R_OVER_S, SMOOTH_MIN_D,
                              CurveGeom, _NO_ENDS, _cap_rows, _caps_flat_rows, _flat_inputs, _part, _pmax,
                              _segments)
from gcode_opt.laws import circle
from gcode_opt.laws.circle import _clenshaw_rows, _gemm_rows_invariant, _row_lengths, _rows_matmul
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_CURVE

S = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "sample_gcode")
CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus/")
HAVE_CORE = circle.CORE_MOD is not None


# ---------------------------------------------------------------- references (d3559db, verbatim)
def _batch_parts(todo):
    return curves._batch_parts(todo)


def _parts_block_ref(pts):
    """_batch_parts on one block of strokes with the same vertex count: pts (m, n + 1, 2)."""
    seg = pts[:, 1:] - pts[:, :-1]                           # _segments
    d = np.hypot(seg[..., 0], seg[..., 1])
    u = seg / d[..., None]
    cos_turn = np.einsum("bij,bij->bi", u[:, :-1], u[:, 1:])
    s_v = np.empty(d.shape[:1] + (d.shape[1] + 1,))
    s_v[:, 0] = 0.0
    np.cumsum(d, axis=1, out=s_v[:, 1:])
    good = np.isfinite(pts).all(axis=(1, 2)) & (d > 1e-9).all(axis=1) & (np.diff(s_v, axis=1) > 0.0).all(axis=1)
    n = d.shape[1]                                          # _median
    k = n // 2
    if n % 2:
        med = np.partition(d, k, axis=1)[:, k]
    else:
        p = np.partition(d, [k - 1, k], axis=1)
        med = (p[:, k - 1] + p[:, k]) / 2.0
    smooth_d = _pmax(med, SMOOTH_MIN_D)
    # curvature_from_polyline(pts, smooth_d): its one window covers every interior vertex
    heading = np.arctan2(seg[..., 1], seg[..., 0])
    turn = np.angle(np.exp(1j * np.diff(heading, axis=1)))
    s_i = s_v[:, 1:-1]
    ell = 0.5 * (d[:, :-1] + d[:, 1:])
    # kern = exp(-0.5 (z2 - min z2)), z2 = ((s_v - s_i) / smooth_d)^2: the same operations
    # in place in one array (x ** 2 is np.square; -0.5 x = x (-0.5)), not one new array of
    # m (n+1)(n-1) doubles per step
    if curves._CURVE_CORE is not None:     # the same five steps in one compiled pass (_curvecore.c)
        kern = np.empty((s_v.shape[0], n + 1, n - 1))
        curves._CURVE_CORE.kern_args(s_v, smooth_d, s_v.shape[0], n + 1, kern)
    else:
        kern = np.subtract(s_v[:, :, None], s_i[:, None, :])
        np.divide(kern, smooth_d[:, None, None], out=kern)
        np.square(kern, out=kern)
        np.subtract(kern, kern.min(axis=2, keepdims=True), out=kern)
        np.multiply(kern, -0.5, out=kern)
    np.exp(kern, out=kern)
    # matrix-vector products stacked: numpy makes the same BLAS gemv call per stroke as the
    # per-stroke path's kern @ turn (same shapes and strides), so the same bits
    kappa_v = (kern @ turn[:, :, None])[..., 0] / (kern @ ell[:, :, None])[..., 0]
    good &= np.isfinite(kappa_v).all(axis=1)
    # np.interp(s_v, s_d, kappa_v) at its own nodes is kappa_v itself
    S = s_v[:, -1]
    mid = 0.5 * (kappa_v[:, :-1] ** 2 + kappa_v[:, 1:] ** 2)
    k2 = np.sum(mid * d, axis=1) / S
    kappa_eff = _pmax(np.sqrt(k2), 1.0 / (MAX_R_OVER_S * S))
    return d, u, cos_turn, s_v, kappa_v, kappa_eff.tolist(), good


def _build_geoms_ref(strokes, profile, jerk1=False):
    """geom() of every stroke in `strokes` (those without one), their vertex caps computed
    in vectorised passes (per stroke they cost ~50 µs of numpy calls for ~14 vertices)
    and their segments and curvature batched over strokes of one vertex count
    (_batch_parts); jerk1: classic jerk's caps at the whole jerk too (chains.vertex_caps).
    A stroke whose geometry raises raises here, as geom() would (the strokes before it
    keep theirs)."""
    todo = [st for st in strokes if st.curv is None]
    if not todo:
        return
    parts = _batch_parts(todo)
    segs = [None if p is not None else _segments(st) for st, p in zip(todo, parts)]
    caps, caps1 = [None] * len(todo), [None] * len(todo)
    cap, ends = [None] * len(todo), [None] * len(todo)      # CurveGeom's cap and cos_end, in batches
    # the caps by chunks of strokes (CAPS_CHUNK vertices): their temporaries, ~20 arrays
    # of a double per vertex, were ~40 MB at once on the gyroid plate; elementwise, so the
    # same bits (a chunk whose input the vectorised form does not take: stroke by stroke)
    nv = np.cumsum([s[1].size if p is None else p[0][0].shape[1] for p, s in zip(parts, segs)])
    cut = np.flatnonzero(np.diff(nv // curves.CAPS_CHUNK)) + 1
    for lo, hi in zip([0] + cut.tolist(), cut.tolist() + [len(todo)]):
        sts = todo[lo:hi]
        us = [_part(parts[k], 1) if parts[k] is not None else segs[k][2] for k in range(lo, hi)]
        ds = [_part(parts[k], 0) if parts[k] is not None else segs[k][1] for k in range(lo, hi)]
        flat = _flat_inputs(sts, us, ds)
        got = _caps_flat_rows(sts, profile, us, ds, 1.0 - JERK_F_STEP_R, flat)
        if got is None:
            continue
        caps[lo:hi] = [(got[0], a) for a in got[1]]
        cap[lo:hi] = _cap_rows(got[0], got[1], flat[0].tolist())
        ends[lo:hi] = _ends_rows_ref(sts, us, flat)
        if jerk1 and profile.junction == "jerk":
            got = _caps_flat_rows(sts, profile, us, ds, 1.0, flat)
            if got is not None:
                caps1[lo:hi] = [(got[0], a) for a in got[1]]
    for st, sg, pa, c, c1, cp, ce in zip(todo, segs, parts, caps, caps1, cap, ends):
        st.curv = CurveGeom(st, profile, sg, c, c1, pa, cp, ce)


def _ends_rows_ref(sts, us, flat=None):
    """CurveGeom.cos_end of the strokes sts (unit directions us): the same products and
    sums as CurveGeom's per stroke (each a numpy float64), in arrays.  flat: _flat_inputs
    of these strokes (their first and last directions read from the directions end to end)."""
    m = len(sts)
    if flat is not None:
        n, u = flat[0], flat[1]
        ends = np.cumsum(n)
        first = u[ends - n].reshape(m, 2)
        last = u[ends - 1].reshape(m, 2)
    else:
        first = np.array([u[0] for u in us], float).reshape(m, 2)
        last = np.array([u[-1] for u in us], float).reshape(m, 2)
    nan2 = (math.nan, math.nan)
    pu = [st.prev_u for st in sts]
    nu = [st.next_u for st in sts]
    p = np.array([nan2 if x is None else x for x in pu], float).reshape(m, 2)
    q = np.array([nan2 if x is None else x for x in nu], float).reshape(m, 2)
    c0 = p[:, 0] * first[:, 0] + p[:, 1] * first[:, 1]
    c1 = last[:, 0] * q[:, 0] + last[:, 1] * q[:, 1]
    out = []
    for a, b, x, y in zip(pu, nu, c0, c1):
        e0 = x if a is not None and x >= CORNER_COS else None
        e1 = y if b is not None and y >= CORNER_COS else None
        out.append(_NO_ENDS if e0 is None and e1 is None else (e0, e1))
    return out


def _series_values_ref(coefs, x):
    """[_clenshaw_rows(c, x) for c in coefs], Chebyshev series c (B, K_c) at x (B, M).
    Rows of x that are one grid (the usual case: a batch's quadrature or uniform grid is
    the same for every arc whose layers are wider than the arc) are evaluated as matrix
    products with the Chebyshev values at that grid (BLAS, ~5x faster than the
    recurrence; the same sums in another order, ~1e-16 relative).  Each row goes through
    BLAS calls of a fixed shape (_GEMM_ROWS rows of its own number of coefficients), so
    its bits do not depend on which rows share its chunk (chunked evaluation gives the
    same figures); if this BLAS does not give a row the same bits at every position of
    such a call, everything goes by Clenshaw."""
    if not _gemm_rows_invariant() or x.shape[0] == 0:
        return [_clenshaw_rows(c, x) for c in coefs]
    if (x == x[:1]).all():
        groups = [np.arange(x.shape[0])]
    else:
        by_grid: dict[bytes, list] = {}
        for i in range(x.shape[0]):
            by_grid.setdefault(x[i].tobytes(), []).append(i)
        groups = [np.array(r) for r in by_grid.values()]
    out = [np.empty(x.shape) for _ in coefs]
    kmax = max(c.shape[1] for c in coefs)
    for r in groups:
        vand_t = np.ascontiguousarray(np.polynomial.chebyshev.chebvander(x[r[0]], kmax - 1).T)   # (K, M)
        for o, c in zip(out, coefs):
            cr = c[r]
            length = _row_lengths(cr)
            for k in np.unique(length):
                rk = np.flatnonzero(length == k)
                o[r[rk]] = _rows_matmul(cr[rk, :k], vand_t[:k])
    return out



# ---------------------------------------------------------------- helpers
def _geom_fields(g):
    """Every field of a CurveGeom, with its type: floats as their bytes, arrays as (dtype,
    shape, bytes), cos_end as (type, bytes) per end."""
    def f(x):
        if x is None:
            return None
        if isinstance(x, np.ndarray):
            return (x.dtype.str, x.shape, x.tobytes())
        return (type(x).__name__, np.float64(x).tobytes())
    out = [f(g.cap), f(g.kappa_eff), g.cos_end is _NO_ENDS, g.chain_caps,
           None if g.cos_end is None else tuple(f(c) for c in g.cos_end)]
    for a in (g.caps, g.caps_jerk1, g.d, g.u, g.cos_turn, g.s_v, g.kappa_v, g.pts):
        out.append(f(a))
    return out


def _curves_of(path, profile):
    prof = load_profile(profile)
    strokes, _ = analyse(path, prof, Options())
    return prof, [st for st in strokes if st.kind == K_CURVE]


def _ref_geoms(todo, prof, jerk1, monkeypatch):
    for st in todo:
        st.curv = None
    with monkeypatch.context() as m:
        m.setattr(curves, "_parts_block", _parts_block_ref)
        _build_geoms_ref(todo, prof, jerk1=jerk1)
    return [_geom_fields(st.curv) for st in todo]


def _new_geoms(todo, prof, jerk1):
    for st in todo:
        st.curv = None
    curves.build_geoms(todo, prof, jerk1=jerk1)
    return [_geom_fields(st.curv) for st in todo]


CASES = [(os.path.join(S, "prusa_gyroid.gcode"), "prusa-mk3s"), (os.path.join(S, "prusa_gyroid.gcode"), "voron24"),
         (os.path.join(S, "prusa_concentric.gcode"), "ender3"),
         (os.path.join(S, "prusa_gyroid_fullspeed.gcode"), "prusa-mk4"),
         (CORPUS + "gyroid_fwretract.gcode", "prusa-mk3s")]


# ---------------------------------------------------------------- tests
@pytest.mark.parametrize("path,profile", CASES)
@pytest.mark.parametrize("core", [True, False])
def test_build_geoms_same_as_d3559db(path, profile, core, monkeypatch):
    if not os.path.exists(path):
        pytest.skip("corpus file not present")
    if core and not HAVE_CORE:
        pytest.skip("curve core not built")
    prof, todo = _curves_of(path, profile)
    assert len(todo) > 30
    if not core:
        monkeypatch.setattr(curves, "_CURVE_CORE", None)
    for chunk in (CAPS_CHUNK, 256):                      # one chunk, several
        monkeypatch.setattr(curves, "CAPS_CHUNK", chunk)
        for jerk1 in (False, True):
            want = _ref_geoms(todo, prof, jerk1, monkeypatch)
            got = _new_geoms(todo, prof, jerk1)
            assert got == want


def test_build_geoms_degenerate_strokes(monkeypatch):
    """Strokes the batched forms decline (two vertices): CurveGeom's own path, as before;
    tiny segments; neighbours None, NaN, random; a stroke whose geometry raises (a NaN
    vertex) raises in both."""
    prof, todo = _curves_of(os.path.join(S, "prusa_gyroid.gcode"), "prusa-mk3s")
    todo = todo[:60]
    from gcode_opt.strokes import Points
    rng = np.random.default_rng(4)
    for k, st in enumerate(todo):
        pts = np.array(st.pts, float)
        if k % 7 == 3:
            pts = pts[:2]                          # one segment: CurveGeom's own path
        elif k % 7 == 4:
            pts = pts * 1e-4                       # tiny segments
        st.pts = Points(pts.ravel().tolist()) if k % 2 else [tuple(v) for v in pts.tolist()]
        if k % 5 == 0:
            st.prev_u = None
        elif k % 5 == 1:
            st.next_u = (math.nan, 0.0)
        elif k % 5 == 2:
            st.prev_u = (1.0, 0.0)
            st.next_u = tuple(rng.normal(size=2))
    want = _ref_geoms(todo, prof, True, monkeypatch)
    got = _new_geoms(todo, prof, True)
    for a, b in zip(got, want):
        assert repr(a) == repr(b)
    bad = todo[:5]
    pts = np.array(bad[3].pts, float)
    pts[-1, 0] = np.nan
    bad[3].pts = pts
    with pytest.raises(ValueError):
        _ref_geoms(bad, prof, True, monkeypatch)
    with pytest.raises(ValueError):
        _new_geoms(bad, prof, True)


@pytest.mark.skipif(not os.path.exists(CORPUS + "plate_gyroid.gcode"), reason="corpus plate not there")
def test_parts_block_same_as_d3559db_on_the_gyroid_plate():
    prof, todo = _curves_of(CORPUS + "plate_gyroid.gcode", "prusa-mk3s")
    by = {}
    for st in todo:
        if 3 <= len(st.pts) <= curves._GEOM_MAX_PTS:
            by.setdefault(len(st.pts), []).append(curves._xy(st))
    assert sum(len(v) for v in by.values()) > 10000
    for npt, xs in by.items():
        step = max(1, curves._GEOM_BLOCK // (npt * npt))
        for a in range(0, len(xs), 4 * step):
            pts = np.concatenate(xs[a:a + step]).reshape(-1, npt, 2)
            with np.errstate(all="ignore"):
                _same_parts(curves._parts_block(pts), _parts_block_ref(pts))


def _same_parts(got, want):
    assert len(got) == len(want) == 7
    for x, y in zip(got, want):
        if isinstance(y, list):
            assert [float(v).hex() for v in x] == [float(v).hex() for v in y]
        else:
            assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes()


def test_parts_block_random_and_degenerate():
    rng = np.random.default_rng(21)
    for npt in (3, 4, 9, 40, 120, 300):
        m = 24
        steps = rng.uniform(0.05, 3.0, (m, npt - 1, 1)) * np.stack(
            [np.cos(np.cumsum(rng.uniform(-0.5, 0.5, (m, npt - 1)), axis=1)),
             np.sin(np.cumsum(rng.uniform(-0.5, 0.5, (m, npt - 1)), axis=1))], axis=2)
        pts = np.concatenate([rng.uniform(-100, 100, (m, 1, 2)), steps], axis=1).cumsum(axis=1)
        pts[1, 2] = pts[1, 1]
        pts[2, 0, 0] = np.nan
        pts[3, -1, 1] = np.inf
        pts[4] *= 1e-7
        pts[5] *= 1e5                               # kernels that underflow
        pts[6, 1:] = pts[6, :1] + np.cumsum(np.full((npt - 1, 2), [0.2, 0.0]), axis=0)  # straight, equal segments
        pts[7, npt // 2:] *= 1e3                   # a long tail: arguments around the threshold
        for core in ([None, curves._CURVE_CORE] if HAVE_CORE else [None]):
            saved = curves._CURVE_CORE
            curves._CURVE_CORE = core
            try:
                with np.errstate(all="ignore"):
                    _same_parts(curves._parts_block(pts), _parts_block_ref(pts))
            finally:
                curves._CURVE_CORE = saved


def test_exp_inplace_is_np_exp():
    """Around the threshold (both sides, by one ulp), -inf, NaN, subnormal results,
    overflow, and a non-contiguous array (numpy's own)."""
    rng = np.random.default_rng(2)
    t = curves.EXP_ZERO_BELOW
    x = np.concatenate([rng.uniform(-800.0, 10.0, 20000), [t, np.nextafter(t, 0), np.nextafter(t, -np.inf),
                        -745.13321910194122, -745.1332191019411, -744.44, -708.4, -np.inf, np.inf, np.nan, -np.nan,
                        0.0, -0.0, 709.8, 710.0, -1e308, 5e-324]],)
    x = x.reshape(-1, 7, 3) if x.size % 21 == 0 else np.concatenate([x, np.zeros(21 - x.size % 21)]).reshape(-1, 7, 3)
    with np.errstate(all="ignore"):
        want = np.exp(x)
        for core in ([None, curves._CURVE_CORE] if HAVE_CORE else [None]):
            saved = curves._CURVE_CORE
            curves._CURVE_CORE = core
            try:
                got = x.copy()
                curves._exp_inplace(got)
                assert np.array_equal(got.view(np.int64), want.view(np.int64))
                nc = x.copy()[:, ::2]                # not contiguous: np.exp itself
                curves._exp_inplace(nc)
                assert np.array_equal(nc.view(np.int64), np.exp(x[:, ::2]).view(np.int64))
            finally:
                curves._CURVE_CORE = saved


def test_exp_inplace_without_the_probe_is_np_exp(monkeypatch):
    monkeypatch.setattr(curves, "_EXP_ZERO_OK", [False])
    x = np.linspace(-900.0, 1.0, 4001)
    got = x.copy()
    curves._exp_inplace(got)
    assert np.array_equal(got.view(np.int64), np.exp(x).view(np.int64))
    assert curves._exp_zero_ok() is False


def test_exp_zero_probe_holds_here():
    """numpy's exp here gives +0.0 below the threshold (else the core's split is unused)."""
    assert curves._exp_zero_ok() is True or not HAVE_CORE


def test_ends_rows_same_as_d3559db():
    prof, todo = _curves_of(os.path.join(S, "prusa_gyroid.gcode"), "prusa-mk3s")
    curves.build_geoms(todo, prof)
    us = [st.curv.u for st in todo]
    ds = [st.curv.d for st in todo]
    rng = np.random.default_rng(3)
    for k, st in enumerate(todo[:200]):
        r = k % 6
        if r == 0:
            st.prev_u = None
        elif r == 1:
            st.next_u = (math.nan, 1.0)
        elif r == 2:
            st.prev_u = tuple(-np.asarray(us[k][0]))            # reversed: cos -1
        elif r == 3:
            st.next_u = tuple(us[k][-1])                        # straight on: cos 1
        elif r == 4:
            st.prev_u = tuple(rng.normal(size=2))
    flat = _flat_inputs(todo, us, ds)
    want = _ends_rows_ref(todo, us, flat)
    for got in (curves._ends_rows(todo, us, flat), curves._ends_rows(todo, us)):
        assert len(got) == len(want)
        for a, b in zip(got, want):
            assert (a is _NO_ENDS) == (b is _NO_ENDS)
            assert [None if c is None else (type(c), np.float64(c).tobytes()) for c in a] == \
                   [None if c is None else (type(c), np.float64(c).tobytes()) for c in b]


def _series_cases():
    rng = np.random.default_rng(11)
    for nb, K in ((1, 3), (40, 21), (517, 33), (70, 65)):
        coef = rng.normal(size=(nb, K))
        coef[::3, K // 2:] = 0.0                 # rows of their own lengths
        coef[1::5, -1] = 0.0
        if nb > 4:
            coef[4] = 0.0
        for grid in ("one", "rows", "some"):
            if grid == "one":
                x = np.broadcast_to(np.linspace(-1.0, 1.0, 17)[None, :], (nb, 17)).copy()
            elif grid == "rows":
                x = rng.uniform(-1.0, 1.0, (nb, 9))
            else:
                x = np.broadcast_to(np.linspace(-1.0, 1.0, 9)[None, :], (nb, 9)).copy()
                x[::4] = np.cos(np.linspace(0.0, 3.0, 9))
            yield (coef, coef[:, :max(K - 1, 1)], np.ascontiguousarray(coef[:, 1:]), coef[:, :K - 2 or 1]), x


def test_series_values_same_as_d3559db():
    circle._VANDER.clear()
    for coefs, x in _series_cases():
        want = _series_values_ref(coefs, x)
        for _ in range(2):                       # the second time from _vander_t's store
            got = circle._series_values(coefs, x)
            assert len(got) == len(want)
            for a, b in zip(got, want):
                assert a.shape == b.shape and a.tobytes() == b.tobytes()


def test_vander_store_is_bounded_and_read_only(monkeypatch):
    monkeypatch.setattr(circle, "_VANDER_MAX", 3)
    circle._VANDER.clear()
    for k in range(10):
        v = circle._vander_t(np.linspace(-1.0, 1.0, 5 + k), 4)
        assert not v.flags.writeable and v.shape == (4, 5 + k)
        assert len(circle._VANDER) <= 3
    circle._VANDER.clear()
