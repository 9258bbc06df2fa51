"""Round 22 (curves): the curve geometry kept smaller, built with fewer numpy calls.

* curves.build_geoms keeps each geometry as a row of one block (_Blk) per batch of
  strokes of one vertex count: d, u, κ at the vertices, κ_eff, the vertex caps (and classic
  jerk's at the whole jerk), cap, cos_end; cos_turn and s_v are made from u and d when
  read (einsum of the row, cumsum: the operations that made them).  The caps are the law
  of _caps_flat on (m, n - 1) blocks (the limits as (m, 1)), not on the strokes' segments
  end to end (no flat copy, no first-cap index per stroke).  CurveGeom has 5 slots.
* Every field (value bits and type) is compared with 479aedb's code kept verbatim below
  (build_geoms, CurveGeom, the caps' flat pass, _batch_parts), on real files' curves,
  under Marlin jerk / JD and Klipper profiles, with and without the compiled kernel.
"""
import math
import os

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt.curves import (CAP_MARGIN, CORNER_COS, JERK_F_STEP_R, MAX_R_OVER_S, SMOOTH_MIN_D, _GEOM_BLOCK,
                              _GEOM_MAX_PTS, _LIM_FIELDS, _NO_ENDS, _accel_in_force_v, _exp_inplace, _jerk_caps,
                              _klipper_v2, _lim_fields, _marlin_jd_v2, _median, _neighbour_dirs, _part, _pmax,
                              _segments, _xy_block, vertex_cap, SQRT2_M1)
from gcode_opt.laws import circle
from gcode_opt.laws.curve import curvature_from_polyline
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_CURVE

S = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "sample_gcode")
CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus/")
HAVE_CORE = circle.CORE_MOD is not None
CAPS_CHUNK = 1 << 15


# ---------------------------------------------------------------- 479aedb's code, verbatim (names prefixed R)
def Rvertex_caps(profile, lim, accel, u, d, jerk_r=1.0 - JERK_F_STEP_R):
    """vertex_cap at every interior vertex of a polyline with unit directions u (n, 2)
    and segment lengths d (n,), as an array (n - 1,): the same arithmetic elementwise in
    the same order, so the same bits (tests/test_speed_plan_caps.py).  An input the
    vectorised form does not take as the scalar one does (non-finite, a negative square)
    takes the scalar loop (its exceptions and NaN handling are the reference)."""
    u = np.asarray(u, float)
    d = np.asarray(d, float)
    caps = None
    if np.isfinite(u).all() and np.isfinite(d).all():
        caps = _R_caps_flat(profile, _lim_fields(lim, accel), u, d, jerk_r)
    if caps is None:
        return np.array([vertex_cap(profile, lim, accel, tuple(u[k]), tuple(u[k + 1]), d[k], d[k + 1], jerk_r)
                         for k in range(len(d) - 1)], float)
    return caps


def _R_caps_flat(profile, p, u, d, jerk_r):
    """The caps at the vertices between u[k] and u[k + 1]; p: the limits (and the stroke's
    acceleration) per vertex or scalars.  None where the scalar law would raise (a negative
    squared speed: math.sqrt raises)."""
    pux, puy, ux, uy = u[:-1, 0], u[:-1, 1], u[1:, 0], u[1:, 1]
    with np.errstate(all="ignore"):
        if profile.junction == "jerk":
            return _jerk_caps(pux, puy, ux, uy, jerk_r * p["jerk_x"], jerk_r * p["jerk_y"])
        accel = p["accel"]
        a0 = np.where(accel > 0, accel, profile.default_accel_a)
        ap = _accel_in_force_v(a0, p["ax_max"], p["ay_max"], pux, puy)
        a = _accel_in_force_v(a0, p["ax_max"], p["ay_max"], ux, uy)
        if profile.junction == "scv":
            v2 = _klipper_v2(pux, puy, p["scv"] * p["scv"] * SQRT2_M1 / a0, ap, 2.0 * d[:-1] * ap,
                             ux, uy, a, 2.0 * d[1:] * a)
        else:
            v2 = _marlin_jd_v2(pux, puy, ux, uy, d[1:], a, p["jd"], p["ax_max"], p["ay_max"])
        if (v2 < 0.0).any():
            return None
        return np.where(np.isfinite(v2), np.sqrt(v2), math.inf)


def _R_caps_flat_rows(strokes, profile, us, ds, jerk_r, flat=None):
    """batch_caps' caps as one flat array and each stroke's first cap in it (a list of
    ints), or None.  flat: (n, u, d, p) as _R_flat_inputs gives them for these strokes."""
    n, u, d, p = _R_flat_inputs(strokes, us, ds) if flat is None else flat
    if not (np.isfinite(u).all() and np.isfinite(d).all()) or u.shape[0] < 2 or (n < 1).any():
        return None
    caps = _R_caps_flat(profile, p, u, d, jerk_r)
    if caps is None:
        return None
    keep = np.ones(caps.size, bool)
    keep[np.cumsum(n)[:-1] - 1] = False            # the vertex between two strokes
    caps = caps[keep]
    ends = np.cumsum(np.maximum(n - 1, 0)).tolist()
    return caps, [0] + ends[:-1]


def _R_flat_inputs(strokes, us, ds):
    """(segment counts, directions and lengths end to end, the limits and acceleration of
    each stroke repeated per segment but the last) of _R_caps_flat_rows.  The limits are
    read once per limits object the strokes share (the same numbers as stroke by stroke)."""
    n = np.array([x.size for x in ds], int)
    u, d = np.concatenate(us), np.concatenate(ds)
    seen = {}
    which = [seen.setdefault(id(st.lim), (len(seen), st.lim))[0] for st in strokes]
    lims = [lim for _, lim in seen.values()]
    p = {f: np.repeat(np.array([getattr(lim, f) for lim in lims], float)[which], n)[:-1] for f in _LIM_FIELDS}
    p["accel"] = np.repeat(np.array([st.accel for st in strokes], float), n)[:-1]
    return n, u, d, p


class RCurveGeom:
    """Per-curve arrays: vertices, segment lengths/directions, turns, κ(s).

    Compact: the arrays are rows of blocks shared by many strokes (_R_batch_parts' blocks,
    Rbuild_geoms' flat caps), each made into a view when read.  A view kept per field and
    stroke cost ~110 bytes, ~0.8 kB a curve in all (~16 MB on the gyroid plate), more
    than its numbers."""
    __slots__ = ("_pts", "_b", "_k", "_cb", "_c0", "_cb1", "_c1", "kappa_eff", "cap", "cos_end",
                 "chain_caps")

    def __init__(self, st, profile, seg=None, caps=None, caps_jerk1=None, parts=None, cap=None, cos_end=None):
        """seg: (pts, d, u) from _segments; parts: (block, row) of _R_batch_parts (the same
        bits for many strokes at once); caps, caps_jerk1: the vertex caps (classic jerk's
        at the whole jerk: chains.Rvertex_caps), an array or (flat array, first cap) as
        Rbuild_geoms computes them for many strokes at once; caps None: computed here.
        cap, cos_end: those fields as Rbuild_geoms computes them for many strokes (the
        same numbers, _R_ends_rows); None: computed here."""
        self._pts = st.pts                # the stroke's own vertices: pts is read by tests only
        if parts is not None:
            self._b, self._k = parts
            self.kappa_eff = self._b[5][self._k]
        else:
            self._own_parts(st, seg)
        if caps is None:
            caps = Rvertex_caps(profile, st.lim, st.accel, self.u, self.d)
        self._cb, self._c0 = caps if isinstance(caps, tuple) else (caps, 0)
        self._cb1, self._c1 = caps_jerk1 if isinstance(caps_jerk1, tuple) else (caps_jerk1, 0)
        self.chain_caps = None                    # chains.py: the caps a chain's law meets
        if cap is None:
            caps = self.caps
            cap = CAP_MARGIN * min(caps.tolist()) if caps.size else math.inf
        self.cap = cap
        if cos_end is not None:
            self.cos_end = cos_end
            return
        # turns at the two ends (None: a stop or a corner): the firmware model counts half
        # of each end junction's normal term in the stroke, as it did for the original
        u = self.u
        cos_end = [None, None]
        for j, (a, b) in enumerate(((st.prev_u, tuple(u[0])), (tuple(u[-1]), st.next_u))):
            if a is not None and b is not None:
                c = a[0] * b[0] + a[1] * b[1]
                cos_end[j] = c if c >= CORNER_COS else None
        self.cos_end = _NO_ENDS if cos_end == [None, None] else tuple(cos_end)

    d = property(lambda self: self._b[0][self._k], doc="segment lengths (n,)")
    u = property(lambda self: self._b[1][self._k], doc="segment unit directions (n, 2)")
    cos_turn = property(lambda self: self._b[2][self._k], doc="cosine of each interior vertex's turn (n - 1,)")
    s_v = property(lambda self: self._b[3][self._k], doc="arc length at each vertex (n + 1,)")
    kappa_v = property(lambda self: self._b[4][self._k], doc="smoothed curvature at each vertex (n + 1,)")

    @property
    def caps(self):
        """The vertex speed caps (mm/s), per interior vertex."""
        c0 = self._c0
        return self._cb[c0:c0 + self._b[0].shape[1] - 1]

    @property
    def caps_jerk1(self):
        """Classic jerk's caps at the whole jerk, if Rbuild_geoms computed them (chains)."""
        c1 = self._c1
        return None if self._cb1 is None else self._cb1[c1:c1 + self._b[0].shape[1] - 1]

    @caps_jerk1.setter
    def caps_jerk1(self, caps):
        self._cb1, self._c1 = caps, 0

    def _own_parts(self, st, seg):
        pts, d, u = seg if seg is not None else _segments(st)
        cos_turn = np.einsum("ij,ij->i", u[:-1], u[1:])
        s_v = np.concatenate([[0.0], np.cumsum(d)])
        # smoothing over one median segment: wider kernels flatten the gyroid's curvature
        # peaks (3 segments lose half of ∫κ²ds, which the firmware model's vertex terms keep);
        # the slicer's 0.001 mm rounding is ±0.1 deg on ~10 deg turns, averaged over ~5 vertices
        pc = curvature_from_polyline(pts, smooth_d=max(_median(d), SMOOTH_MIN_D))
        kappa_v = np.interp(s_v, pc.s_d, pc.kappa_v)
        S = s_v[-1]
        mid = 0.5 * (kappa_v[:-1] ** 2 + kappa_v[1:] ** 2)
        k2 = float(np.sum(mid * d) / S)
        self.kappa_eff = max(math.sqrt(k2), 1.0 / (MAX_R_OVER_S * S))
        self._b = (d[None], u[None], cos_turn[None], s_v[None], kappa_v[None])   # a block of one row
        self._k = 0

    @property
    def pts(self):
        """The vertices as _segments takes them, (n+1, 2) (an array per curve held ~10 MB on a plate)."""
        return np.asarray(self._pts, float)

    def end_terms(self, v0, v1):
        """Half the normal term of the two end junctions, at the end speeds: (1-cos) v³/d."""
        out = 0.0
        for c, v, d in ((self.cos_end[0], v0, self.d[0]), (self.cos_end[1], v1, self.d[-1])):
            if c is not None:
                out += (1.0 - c) * v ** 3 / d
        return out

    def kappa(self, s):
        return np.interp(s, self.s_v, self.kappa_v)


def Rbuild_geoms(strokes, profile, jerk1=False):
    """geom() of every stroke in `strokes` (those without one), their vertex caps computed
    in vectorised passes (per stroke they cost ~50 µs of numpy calls for ~14 vertices)
    and their segments and curvature batched over strokes of one vertex count
    (_R_batch_parts); jerk1: classic jerk's caps at the whole jerk too (chains.Rvertex_caps).
    A stroke whose geometry raises raises here, as geom() would (the strokes before it
    keep theirs)."""
    todo = [st for st in strokes if st.curv is None]
    if not todo:
        return
    parts = _R_batch_parts(todo)
    segs = [None if p is not None else _segments(st) for st, p in zip(todo, parts)]
    m = len(todo)
    cbs, c0s, cb1s, c1s = [None] * m, [0] * m, [None] * m, [0] * m      # the caps: flat array, first cap
    cap, ends = [None] * m, [None] * m      # RCurveGeom's cap and cos_end, in batches
    # the caps by chunks of strokes (CAPS_CHUNK vertices): their temporaries, ~20 arrays
    # of a double per vertex, were ~40 MB at once on the gyroid plate; elementwise, so the
    # same bits (a chunk whose input the vectorised form does not take: stroke by stroke)
    nv = np.cumsum([s[1].size if p is None else p[0][0].shape[1] for p, s in zip(parts, segs)])
    cut = np.flatnonzero(np.diff(nv // CAPS_CHUNK)) + 1
    for lo, hi in zip([0] + cut.tolist(), cut.tolist() + [m]):
        sts = todo[lo:hi]
        us = [_part(parts[k], 1) if parts[k] is not None else segs[k][2] for k in range(lo, hi)]
        ds = [_part(parts[k], 0) if parts[k] is not None else segs[k][1] for k in range(lo, hi)]
        flat = _R_flat_inputs(sts, us, ds)
        got = _R_caps_flat_rows(sts, profile, us, ds, 1.0 - JERK_F_STEP_R, flat)
        if got is None:
            continue
        cbs[lo:hi], c0s[lo:hi] = [got[0]] * (hi - lo), got[1]
        cap[lo:hi] = _R_cap_rows(got[0], got[1], flat[0].tolist())
        ends[lo:hi] = _R_ends_rows(sts, us, flat)
        if jerk1 and profile.junction == "jerk":
            got = _R_caps_flat_rows(sts, profile, us, ds, 1.0, flat)
            if got is not None:
                cb1s[lo:hi], c1s[lo:hi] = [got[0]] * (hi - lo), got[1]
    new = RCurveGeom.__new__
    for st, sg, pa, cb, c0, cb1, c1, cp, ce in zip(todo, segs, parts, cbs, c0s, cb1s, c1s, cap, ends):
        if pa is None or cb is None or cp is None:
            st.curv = RCurveGeom(st, profile, sg, None if cb is None else (cb, c0),
                                None if cb1 is None else (cb1, c1), pa, cp, ce)
            continue
        # RCurveGeom.__init__'s fields, as it sets them from these arguments (its checks
        # and tuples skipped: ~21 k strokes on the gyroid plate)
        g = new(RCurveGeom)
        g._pts = st.pts
        g._b, g._k = pa
        g.kappa_eff = pa[0][5][pa[1]]
        g._cb, g._c0, g._cb1, g._c1 = cb, c0, cb1, c1
        g.chain_caps = None
        g.cap, g.cos_end = cp, ce
        st.curv = g


def _R_cap_rows(flat, starts, n_seg):
    """RCurveGeom.cap of strokes whose caps are flat[starts[k]:][:n_seg[k] - 1]: CAP_MARGIN x
    their least (inf if none), or [None] * len(starts) (computed per stroke) when a cap is
    NaN (Python's min skips it where np.minimum does not) or <= 0 (the sign of a zero)."""
    if not (flat > 0.0).all():
        return [None] * len(starts)
    nv = np.maximum(np.asarray(n_seg, int) - 1, 0)
    has = nv > 0
    least = [math.inf] * len(starts)
    if has.any():
        got = np.minimum.reduceat(flat, np.asarray(starts, int)[has]).tolist() if flat.size else []
        for k, m in zip(np.flatnonzero(has).tolist(), got):
            least[k] = CAP_MARGIN * m
    return least


def _R_ends_rows(sts, us, flat=None):
    """RCurveGeom.cos_end of the strokes sts (unit directions us): the same products and
    sums as RCurveGeom's per stroke (each a numpy float64), in arrays.  flat: _R_flat_inputs
    of these strokes (their first and last directions read from the directions end to end).
    The neighbours' directions are read as the strokes keep them (four floats or None,
    NaN in the arrays: a NaN's cosine is not >= CORNER_COS, as a missing one is not), and
    only the strokes with an end turn get a tuple of their own."""
    m = len(sts)
    if flat is not None:
        n, u = flat[0], flat[1]
        ends = np.cumsum(n)
        first = u[ends - n].reshape(m, 2)
        last = u[ends - 1].reshape(m, 2)
    else:
        first = np.array([u[0] for u in us], float).reshape(m, 2)
        last = np.array([u[-1] for u in us], float).reshape(m, 2)
    p, q = _neighbour_dirs(sts)
    c0 = p[0] * first[:, 0] + p[1] * first[:, 1]
    c1 = last[:, 0] * q[0] + last[:, 1] * q[1]
    m0, m1 = c0 >= CORNER_COS, c1 >= CORNER_COS
    out = [_NO_ENDS] * m
    for k, a, b in zip(np.flatnonzero(m0 | m1).tolist(), m0[m0 | m1].tolist(), m1[m0 | m1].tolist()):
        out[k] = (c0[k] if a else None, c1[k] if b else None)
    return out


def _R_batch_parts(todo):
    """RCurveGeom's (d, u, cos_turn, s_v, kappa_v, kappa_eff) of the strokes `todo`, computed
    for all strokes of one vertex count at once with RCurveGeom's arithmetic elementwise in
    the same order (the same bits: tests/test_speed_curve3_geom.py): per stroke (block,
    row), block those six for a block of strokes (row k of each is this stroke's), or
    None for a stroke this form does not take as the per-stroke path does (a duplicate
    point, non-finite numbers, fewer than 3 or more than _GEOM_MAX_PTS vertices:
    RCurveGeom's own path, which raises where it raises).  ~10x faster than stroke by
    stroke on a gyroid plate."""
    parts = [None] * len(todo)
    npts = np.array([len(st.pts) for st in todo], int)
    order = np.argsort(npts, kind="stable")
    for grp in np.split(order, np.flatnonzero(np.diff(npts[order])) + 1):
        npt = int(npts[grp[0]]) if grp.size else 0
        if npt < 3 or npt > _GEOM_MAX_PTS:
            continue
        step = max(1, _GEOM_BLOCK // (npt * npt))
        for a in range(0, grp.size, step):
            idx = grp[a:a + step]
            with np.errstate(all="ignore"):
                block = _R_parts_block(_xy_block(todo, idx).reshape(idx.size, npt, 2))
            good, block = block[-1].tolist(), block[:-1]
            for k, i in enumerate(idx.tolist()):
                if good[k]:
                    parts[i] = (block, k)
    return parts


def _R_parts_block(pts):
    """_R_batch_parts on one block of strokes with the same vertex count: pts (m, n + 1, 2)."""
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
    _exp_inplace(kern)
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


# ---------------------------------------------------------------- helpers
def _fields(g):
    """Every field of a geometry with its type: floats as their bytes, arrays as (dtype,
    shape, bytes), cos_end as (type, bytes) per end, whether it is the shared _NO_ENDS."""
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
    out.append(f(g.end_terms(3.0, 7.0)))
    out.append(f(g.kappa(np.linspace(-1.0, float(g.s_v[-1]) + 1.0, 9))))
    return out


def _curves_of(path, profile):
    prof = load_profile(profile)
    strokes, _ = analyse(path, prof, Options())
    return prof, [st for st in strokes if st.kind == K_CURVE]


def _ref(todo, prof, jerk1):
    for st in todo:
        st.curv = None
    Rbuild_geoms(todo, prof, jerk1=jerk1)
    out = [_fields(st.curv) for st in todo]
    for st in todo:
        st.curv = None
    return out


def _new(todo, prof, jerk1):
    for st in todo:
        st.curv = None
    curves.build_geoms(todo, prof, jerk1=jerk1)
    assert all(type(st.curv) is curves.CurveGeom for st in todo)
    out = [_fields(st.curv) for st in todo]
    for st in todo:
        st.curv = None
    return out


CASES = [(os.path.join(S, "prusa_gyroid.gcode"), "prusa-mk3s"), (os.path.join(S, "prusa_gyroid.gcode"), "voron24"),
         (os.path.join(S, "prusa_concentric.gcode"), "ender3"),
         (os.path.join(S, "prusa_gyroid_fullspeed.gcode"), "prusa-mk4"),
         (CORPUS + "gyroid_fwretract.gcode", "voron24"),
         (CORPUS + "bridges_klipper.gcode", "generic-klipper")]


# ---------------------------------------------------------------- tests
@pytest.mark.parametrize("path,profile", CASES)
@pytest.mark.parametrize("core", [True, False])
def test_build_geoms_same_as_479aedb(path, profile, core, monkeypatch):
    if not os.path.exists(path):
        pytest.skip("corpus file not present")
    if core and not HAVE_CORE:
        pytest.skip("curve core not built")
    prof, todo = _curves_of(path, profile)
    if len(todo) < 5:
        pytest.skip("too few curves")
    if not core:
        monkeypatch.setattr(curves, "_CURVE_CORE", None)
    for jerk1 in (False, True):
        assert _new(todo, prof, jerk1) == _ref(todo, prof, jerk1)


def test_build_geoms_same_as_479aedb_on_the_gyroid_plates_curves():
    path = CORPUS + "plate_gyroid.gcode"
    if not os.path.exists(path):
        pytest.skip("corpus file not present")
    prof, todo = _curves_of(path, "prusa-mk3s")
    todo = todo[::3]                       # a third of its ~21 k curves (time)
    assert _new(todo, prof, True) == _ref(todo, prof, True)


def test_chain_marks_and_planning_figures_as_479aedb(monkeypatch):
    """classify's chain marks (it reads cap where the block's caps are all > 0) and a
    curve's candidates on the new geometry are those of the old one."""
    from gcode_opt import chains
    prof, todo = _curves_of(os.path.join(S, "prusa_gyroid.gcode"), "prusa-mk3s")
    rows = list(range(len(todo)))

    def marks():
        for st in todo:
            st.curv, st.chain_T = None, None
        chains.classify(todo, rows, prof)
        return [st.chain_T is not None for st in todo]
    got = marks()
    # (kappa: build_geoms' later argument, κ left to be made; 479aedb's made it)
    monkeypatch.setattr(curves, "build_geoms", lambda sts, prof, jerk1=False, kappa=True, **k: Rbuild_geoms(sts, prof, jerk1))
    monkeypatch.setattr(curves, "geom", lambda st, profile: st.curv)
    monkeypatch.setattr(curves, "drop_jerk1", lambda sts: None)
    want = marks()
    assert got == want and any(got) and not all(got)


def test_degenerate_and_random_strokes_same_as_479aedb():
    """Strokes the batch declines (one segment, a duplicate point, NaN, tiny segments,
    long runs past _GEOM_MAX_PTS) next to good ones; neighbours' directions missing, NaN,
    or turning: every field as 479aedb's, or the same exception."""
    rng = np.random.default_rng(22)
    for profile in ("prusa-mk3s", "voron24", "prusa-mk4"):
        prof, todo = _curves_of(os.path.join(S, "prusa_gyroid.gcode"), profile)
        todo = todo[:60]
        from gcode_opt.strokes import Points
        for k, st in enumerate(todo):
            pts = np.array(st.pts, float)
            if k % 11 == 3:
                pts = pts[:2]
            elif k % 11 == 4:
                pts = pts * 1e-4
            elif k % 11 == 5:
                pts = np.vstack([pts[:2], pts[1:]])                  # a duplicate point
            elif k % 11 == 6:
                pts = np.vstack([pts, pts[-1] + np.cumsum(rng.uniform(0.1, 0.3, (600, 2)), axis=0)])
            st.pts = Points(pts.ravel().tolist()) if k % 2 else [tuple(v) for v in pts.tolist()]
            if k % 5 == 0:
                st.prev_u = None
            elif k % 5 == 2:
                st.prev_u = (1.0, 0.0)
                st.next_u = tuple(rng.normal(size=2))
        good = [st for k, st in enumerate(todo) if k % 11 != 5]
        for jerk1 in (False, True):
            assert _new(good, prof, jerk1) == _ref(good, prof, jerk1)
        got, want = _run(curves.build_geoms, todo, prof), _run(Rbuild_geoms, todo, prof)
        if isinstance(want, tuple) or isinstance(got, tuple):
            assert got == want
            continue
        # caps_jerk1 (field 6): 479aedb left it None for every stroke of a caps chunk the
        # flat pass declined (here: the duplicate point's); it is made where the stroke's
        # own segments allow, the numbers chains.vertex_caps makes when it is None
        for st, a, b in zip(todo, got, want):
            if b[6] is None and a[6] is not None:
                g = Rbuild_geoms.__globals__["RCurveGeom"](st, prof)
                ref = Rvertex_caps(prof, st.lim, st.accel, g.u, g.d, jerk_r=1.0)
                assert a[6] == ("<f8", ref.shape, ref.tobytes())
                a = a[:6] + [None] + a[7:]
            assert a == b


def _run(build, todo, prof):
    """build's fields of todo, or its exception's type and which strokes got a geometry."""
    for st in todo:
        st.curv = None
    try:
        build(todo, prof, jerk1=True)
    except Exception as e:                  # noqa: BLE001
        return type(e), [st.curv is not None for st in todo]
    out = [_fields(st.curv) for st in todo]
    for st in todo:
        st.curv = None
    return out


def test_geometry_memory_is_smaller():
    import gc
    import tracemalloc
    prof, todo = _curves_of(os.path.join(S, "prusa_gyroid.gcode"), "prusa-mk3s")
    held = []
    for build in (Rbuild_geoms, curves.build_geoms):
        for st in todo:
            st.curv = None
        gc.collect()
        tracemalloc.start()
        try:
            build(todo, prof, jerk1=True)
            held.append(tracemalloc.get_traced_memory()[0])
        finally:
            tracemalloc.stop()
    assert held[1] < 0.8 * held[0], held

