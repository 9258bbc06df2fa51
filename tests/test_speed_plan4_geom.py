"""Issue 8, stop 19 (D9): curves.build_geoms reads each limits object once and the strokes'
first and last directions from the directions end to end (_flat_inputs, _ends_rows), and
curves._parts_block makes the curvature kernel exp(-0.5 (z2 - min
z2)) in place in one array (the same operations: x ** 2 is np.square, -0.5 x is x (-0.5))
instead of a new array per step.  Every output must be the same bits as ddecd40's
_parts_block and build_geoms (with _caps_flat_rows and _ends_rows), copied below, on real curves of every vertex count and on random and
degenerate points."""
import math
import os

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_CURVE

S = "sample_gcode/"
CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus/")


# ---------------------------------------------------------------- ddecd40's form
def _old_parts_block(pts):
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
    smooth_d = curves._pmax(med, curves.SMOOTH_MIN_D)
    # curvature_from_polyline(pts, smooth_d): its one window covers every interior vertex
    heading = np.arctan2(seg[..., 1], seg[..., 0])
    turn = np.angle(np.exp(1j * np.diff(heading, axis=1)))
    s_i = s_v[:, 1:-1]
    ell = 0.5 * (d[:, :-1] + d[:, 1:])
    z2 = ((s_v[:, :, None] - s_i[:, None, :]) / smooth_d[:, None, None]) ** 2
    kern = np.exp(-0.5 * (z2 - z2.min(axis=2, keepdims=True)))
    # matrix-vector products stacked: numpy makes the same BLAS gemv call per stroke as the
    # per-stroke path's kern @ turn (same shapes and strides), so the same bits
    kappa_v = (kern @ turn[:, :, None])[..., 0] / (kern @ ell[:, :, None])[..., 0]
    good &= np.isfinite(kappa_v).all(axis=1)
    # np.interp(s_v, s_d, kappa_v) at its own nodes is kappa_v itself
    S = s_v[:, -1]
    mid = 0.5 * (kappa_v[:, :-1] ** 2 + kappa_v[:, 1:] ** 2)
    k2 = np.sum(mid * d, axis=1) / S
    kappa_eff = curves._pmax(np.sqrt(k2), 1.0 / (curves.MAX_R_OVER_S * S))
    return d, u, cos_turn, s_v, kappa_v, kappa_eff.tolist(), good


def _old_caps_flat_rows(strokes, profile, us, ds, jerk_r):
    """batch_caps' caps as one flat array and each stroke's first cap in it (a list of
    ints), or None."""
    n = np.array([x.size for x in ds], int)
    u, d = np.concatenate(us), np.concatenate(ds)
    if not (np.isfinite(u).all() and np.isfinite(d).all()) or u.shape[0] < 2 or (n < 1).any():
        return None
    p = {f: np.repeat(np.array([getattr(st.lim, f) for st in strokes], float), n)[:-1] for f in curves._LIM_FIELDS}
    p["accel"] = np.repeat(np.array([st.accel for st in strokes], float), n)[:-1]
    caps = curves._caps_flat(profile, p, u, d, jerk_r)
    if caps is None:
        return None
    keep = np.ones(caps.size, bool)
    keep[np.cumsum(n)[:-1] - 1] = False            # the vertex between two strokes
    caps = caps[keep]
    ends = np.cumsum(np.maximum(n - 1, 0)).tolist()
    return caps, [0] + ends[:-1]


def _old_build_geoms(strokes, profile, jerk1=False):
    """geom() of every stroke in `strokes` (those without one), their vertex caps computed
    in vectorised passes (per stroke they cost ~50 µs of numpy calls for ~14 vertices)
    and their segments and curvature batched over strokes of one vertex count
    (_batch_parts); jerk1: classic jerk's caps at the whole jerk too (chains.vertex_caps).
    A stroke whose geometry raises raises here, as geom() would (the strokes before it
    keep theirs)."""
    todo = [st for st in strokes if st.curv is None]
    if not todo:
        return
    parts = curves._batch_parts(todo)
    segs = [None if p is not None else curves._segments(st) for st, p in zip(todo, parts)]
    caps, caps1 = [None] * len(todo), [None] * len(todo)
    cap, ends = [None] * len(todo), [None] * len(todo)      # CurveGeom's cap and cos_end, in batches
    # the caps by chunks of strokes (curves.CAPS_CHUNK vertices): their temporaries, ~20 arrays
    # of a double per vertex, were ~40 MB at once on the gyroid plate; elementwise, so the
    # same bits (a chunk whose input the vectorised form does not take: stroke by stroke)
    nv = np.cumsum([s[1].size if p is None else p[0][0].shape[1] for p, s in zip(parts, segs)])
    cut = np.flatnonzero(np.diff(nv // curves.CAPS_CHUNK)) + 1
    for lo, hi in zip([0] + cut.tolist(), cut.tolist() + [len(todo)]):
        sts = todo[lo:hi]
        us = [curves._part(parts[k], 1) if parts[k] is not None else segs[k][2] for k in range(lo, hi)]
        ds = [curves._part(parts[k], 0) if parts[k] is not None else segs[k][1] for k in range(lo, hi)]
        got = _old_caps_flat_rows(sts, profile, us, ds, 1.0 - curves.JERK_F_STEP_R)
        if got is None:
            continue
        caps[lo:hi] = [(got[0], a) for a in got[1]]
        cap[lo:hi] = curves._cap_rows(got[0], got[1], [x.size for x in ds])
        ends[lo:hi] = _old_ends_rows(sts, us)
        if jerk1 and profile.junction == "jerk":
            got = _old_caps_flat_rows(sts, profile, us, ds, 1.0)
            if got is not None:
                caps1[lo:hi] = [(got[0], a) for a in got[1]]
    for st, sg, pa, c, c1, cp, ce in zip(todo, segs, parts, caps, caps1, cap, ends):
        st.curv = curves.CurveGeom(st, profile, sg, c, c1, pa, cp, ce)


def _old_ends_rows(sts, us):
    """CurveGeom.cos_end of the strokes sts (unit directions us): the same products and
    sums as CurveGeom's per stroke (each a numpy float64), in arrays."""
    m = len(sts)
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
        e0 = x if a is not None and x >= curves.CORNER_COS else None
        e1 = y if b is not None and y >= curves.CORNER_COS else None
        out.append(curves._NO_ENDS if e0 is None and e1 is None else (e0, e1))
    return out


# ---------------------------------------------------------------- comparisons
def _same(got, want):
    assert len(got) == len(want) == 7
    for x, y in zip(got, want):
        if isinstance(y, list):
            assert type(x) is list and len(x) == len(y)
            assert all(type(a) is type(b) and np.float64(a).tobytes() == np.float64(b).tobytes() for a, b in zip(x, y))
        else:
            assert type(x) is type(y) and x.dtype == y.dtype and x.shape == y.shape
            assert x.tobytes() == y.tobytes()


def _blocks(path):
    strokes, _ = analyse(path, load_profile("prusa-mk3s"), Options())
    by_n = {}
    for st in strokes:
        if st.kind == K_CURVE and 3 <= len(st.pts) <= curves._GEOM_MAX_PTS:
            by_n.setdefault(len(st.pts), []).append(curves._xy(st))
    return {n: np.concatenate(v).reshape(len(v), n, 2) for n, v in by_n.items()}


@pytest.mark.parametrize("path", [S + "prusa_gyroid.gcode", S + "prusa_concentric.gcode",
                                  S + "prusa_gyroid_fullspeed.gcode", CORPUS + "gyroid_fwretract.gcode"])
def test_parts_block_same_as_ddecd40(path):
    if not os.path.exists(path):
        pytest.skip("corpus file not present")
    blocks = _blocks(path)
    assert len(blocks) > 5
    for n, pts in blocks.items():
        with np.errstate(all="ignore"):
            _same(curves._parts_block(pts), _old_parts_block(pts))


def test_parts_block_random_and_degenerate():
    rng = np.random.default_rng(19)
    for npt in (3, 4, 5, 9, 17, 60, 200):
        m = 40
        steps = rng.uniform(0.05, 3.0, (m, npt - 1, 1)) * np.stack(
            [np.cos(np.cumsum(rng.uniform(-0.5, 0.5, (m, npt - 1)), axis=1)),
             np.sin(np.cumsum(rng.uniform(-0.5, 0.5, (m, npt - 1)), axis=1))], axis=2)
        pts = np.concatenate([rng.uniform(-100, 100, (m, 1, 2)), steps], axis=1).cumsum(axis=1)
        pts[1, 2] = pts[1, 1]                       # a duplicate point
        pts[2, 0, 0] = np.nan
        pts[3, -1, 1] = np.inf
        pts[4] *= 1e-7                              # tiny segments
        pts[5] *= 1e5                               # kernels that underflow to 0
        with np.errstate(all="ignore"):
            got, want = curves._parts_block(pts), _old_parts_block(pts)
        _same(got, want)
        assert not got[-1][1] and not got[-1][2] and got[-1][0]


def _geom_fields(g):
    out = [g.cap, g.cos_end, g.kappa_eff]
    for a in (g.caps, g.caps_jerk1, g.d, g.u, g.cos_turn, g.s_v, g.kappa_v):
        out.append(None if a is None else (a.dtype.str, a.shape, a.tobytes()))
    return out


@pytest.mark.parametrize("path,profile", [(S + "prusa_gyroid.gcode", "prusa-mk3s"), (S + "prusa_gyroid.gcode", "voron24"),
                                          (S + "prusa_concentric.gcode", "ender3"),
                                          (S + "prusa_gyroid_fullspeed.gcode", "prusa-mk4"),
                                          (CORPUS + "gyroid_fwretract.gcode", "prusa-mk3s")])
def test_build_geoms_same_as_ddecd40(path, profile, monkeypatch):
    if not os.path.exists(path):
        pytest.skip("corpus file not present")
    prof = load_profile(profile)
    strokes, _ = analyse(path, prof, Options())
    todo = [st for st in strokes if st.kind == K_CURVE]
    assert len(todo) > 30
    monkeypatch.setattr(curves, "CAPS_CHUNK", 256)         # several chunks
    for jerk1 in (False, True):
        for st in todo:
            st.curv = None
        _old_build_geoms(todo, prof, jerk1=jerk1)
        want = [_geom_fields(st.curv) for st in todo]
        for st in todo:
            st.curv = None
        curves.build_geoms(todo, prof, jerk1=jerk1)
        got = [_geom_fields(st.curv) for st in todo]
        for a, b in zip(got, want):
            assert a == b


def test_flat_inputs_shared_limits():
    """Strokes sharing a limits object and strokes with their own: the same per-segment
    limits as read stroke by stroke."""
    class Lim:
        def __init__(self, k):
            self.ax_max, self.ay_max, self.scv, self.jd, self.jerk_x, self.jerk_y = (k + 1.0, k + 2.0, k + 3.0,
                                                                                    k + 4.0, k + 5.0, k + 6.0)

    class St:
        def __init__(self, lim, accel):
            self.lim, self.accel = lim, accel
    shared = Lim(10.0)
    sts = [St(shared if k % 3 else Lim(float(k)), 100.0 + k) for k in range(40)]
    rng = np.random.default_rng(1)
    ds = [rng.uniform(0.1, 1.0, int(rng.integers(1, 6))) for _ in sts]
    us = [rng.uniform(-1, 1, (d.size, 2)) for d in ds]
    n, u, d, p = curves._flat_inputs(sts, us, ds)
    for f in curves._LIM_FIELDS:
        want = np.repeat(np.array([getattr(st.lim, f) for st in sts], float), n)[:-1]
        assert p[f].tobytes() == want.tobytes()
    assert p["accel"].tobytes() == np.repeat(np.array([st.accel for st in sts], float), n)[:-1].tobytes()
