"""Curve strokes: re-time a chain of short G1 segments that is one smooth curve.

A curve stroke (strokes.py, kind K_CURVE) is a run of adjacent G1 lines of one feature,
feed, acceleration and Z whose every vertex turns by <= max_turn_deg (30 deg, the firmware
model's corner threshold) and at least one by more than the collinear tolerance.  Gyroid and
concentric infill, curved walls.

Law.  The optimal law on a curve obeys the arc-length Euler-Lagrange equation with κ(s)
(MATH.md; laws/curve.py solves it exactly, but at 0.05-1.4 s per curve).  Here the law is
the circle law (laws/circle.py, batched, < 1 ms) at the curve's effective constant
curvature κ_eff = sqrt(mean κ²) (κ(s) from curvature_from_polyline): it has the right
mean normal term 6κ²ṡ²s̈ and drops only 3κκ'ṡ⁴ (the pull to go slower where the curve
tightens).  Its figures are then computed on the TRUE κ(s): ∫|a|² = ∫(s̈² + κ(s)²ṡ⁴)dt and
peak |a| = max sqrt(s̈² + κ²ṡ⁴); tests/test_curve_strokes.py compares its J with the exact
optimum of solve_curve on real chains (the gap is well under 1 %).

Firmware facts at a vertex turning by θ (firmware/junction.py):
  * caps no acceleration lifts: classic jerk (v 2 sin(θ/2) per axis <= jerk) and Klipper's
    square-corner velocity (v² <= R_jd scv² (√2-1));
  * caps that scale with the segments' acceleration (Klipper's centripetal term 2 d a qt,
    Marlin JD a jd R_jd and d a / θ below 1 mm): met by raising the segment's acceleration,
    up to the acceleration in force, beyond which they are caps too.
A vertex whose cap (x CAP_MARGIN) is below the feed splits the chain (vertex_splitter):
the original slows there too, and both pieces start/end at the original's speed.  Inside a
curve the law's peak speed stays under the lowest vertex cap (adjust_plan_inputs).

Emission: every original vertex is a knot (no new points), each G1 gets the ramp
acceleration |v_k² - v_{k-1}²| / (2 d_k) raised to what the junction law needs at its
vertices and to the finite-buffer floor of a Marlin planner (as arcs.py), and its own F.
"""
from __future__ import annotations

import math
import weakref
from array import array
from itertools import count, repeat
from operator import attrgetter, itemgetter

import numpy as np

from . import objfields
from .distinct import unique_first_inverse
from .probe_rng import ProbeRng
from .firmware.junction import (MINIMUM_PLANNER_SPEED, SQRT2_M1, accel_to_pass_junction,
                                accel_to_pass_junction_rows, klipper_corner_v2, marlin_jd_v2, marlin_jerk_junction_v)
from .firmware.simulate import CORNER_COS, FULL_STOP_V
from .laws import chain as _chain_law
from .laws import circle as _circle
from .laws.circle import solve_circles
from .plan import SPEED_TOL_R, T_RATIOS, candidate_table, take_shortest_feasible
from .segments import (MIN_FEED_V, SegmentPlan, _row_plans, fine_rows, hold_cruise_accels, hold_cruise_accels_rows,
                       segment_feeds, segment_times, tent_feeds_rows)
from .strokes import Points, stroke_fields

try:                       # np.interp's compiled core (np.interp checks and converts, then calls it)
    from numpy._core.multiarray import interp as _interp
except ImportError:        # pragma: no cover -- numpy < 2
    from numpy.core.multiarray import interp as _interp

# the compiled kernel of _parts_block (laws/_curvecore.c, loaded by laws/circle.py), or None
_CURVE_CORE = _circle.CORE_MOD

CURVE_T_RATIOS = (0.90, 0.96, 1.0, 1.02, 1.05, 1.10, 1.20)
CURVE_COLS = np.array([int(np.argmin(np.abs(T_RATIOS - r))) for r in CURVE_T_RATIOS])
GAMMA_MIN = 0.1            # beta <= (T/GAMMA_MIN)^2: the circle solver needs a finite beta
CAP_MARGIN = 0.95          # on every vertex speed cap
ACCEL_MARGIN = 1.05        # segment accel >= margin x what its junctions need
JERK_F_STEP_R = 0.15       # classic jerk: feeds of neighbouring segments differ by <= this x jerk,
                           # and the vertex caps are computed with the rest of the jerk budget
SMOOTH_MIN_D = 0.2         # mm: the smallest curvature smoothing width
MAX_R_OVER_S = 1e3         # κ_eff floor: R_eff <= this x S (a nearly straight chain)


# ------------------------------------------------------------------ vertex caps
def accel_in_force(profile, lim, accel, u):
    """The move's acceleration after the per-axis caps (as simulate.py)."""
    a0 = accel if accel > 0 else profile.default_accel_a
    a = a0
    if abs(u[0]) > 0 and a * abs(u[0]) > lim.ax_max:
        a = lim.ax_max / abs(u[0])
    if abs(u[1]) > 0 and a * abs(u[1]) > lim.ay_max:
        a = lim.ay_max / abs(u[1])
    return a0, a


def accel_in_force_rows(default_a, accel, ux, uy, ax_max, ay_max):
    """accel_in_force's acceleration in force (its second value) on arrays that broadcast
    (default_a: the profile's default_accel_a; the caps one value or one a row): the same
    comparisons and quotients, elementwise."""
    with np.errstate(all="ignore"):
        a = np.where(accel > 0, accel, default_a)
        for u, cap in ((np.abs(ux), ax_max), (np.abs(uy), ay_max)):
            a = np.where((u > 0) & (a * u > cap), cap / u, a)
    return a


def vertex_cap(profile, lim, accel, pu, u, d_prev, d_next, jerk_r=1.0 - JERK_F_STEP_R):
    """Highest speed (mm/s) the firmware allows at the vertex between a move along pu
    (length d_prev) and one along u (d_next), both at the acceleration in force (the most
    a re-timed segment may carry).  Exact firmware junction laws; classic jerk with the
    share jerk_r of the jerk (the rest is for the change of F between the two moves)."""
    junction = profile.junction
    if junction == "jerk":
        big = 1e6
        j = jerk_r
        return marlin_jerk_junction_v(pu[0], pu[1], 0.0, big, 0.0, u[0], u[1], 0.0, big, 0.0,
                                      j * lim.jerk_x, j * lim.jerk_y, 1.0)
    a0p, ap = accel_in_force(profile, lim, accel, pu)
    a0, a = accel_in_force(profile, lim, accel, u)
    if junction == "scv":
        jdp = lim.scv * lim.scv * SQRT2_M1 / a0p
        jd = lim.scv * lim.scv * SQRT2_M1 / a0
        v2 = klipper_corner_v2(pu[0], pu[1], 0.0, jdp, ap, 2.0 * d_prev * ap,
                               u[0], u[1], 0.0, jd, a, 2.0 * d_next * a)
    else:
        v2 = marlin_jd_v2(pu[0], pu[1], 0.0, u[0], u[1], 0.0, d_next, a, lim.jd,
                          lim.ax_max, lim.ay_max, 1e9)
    return math.sqrt(v2) if math.isfinite(v2) else math.inf


def vertex_caps(profile, lim, accel, u, d, jerk_r=1.0 - JERK_F_STEP_R):
    """vertex_cap at every interior vertex of a polyline with unit directions u (n, 2)
    and segment lengths d (n,), as an array (n - 1,): the same arithmetic elementwise in
    the same order, so the same bits (tests/test_speed_plan_caps.py).  An input the
    vectorised form does not take as the scalar one does (non-finite, a negative square)
    takes the scalar loop (its exceptions and NaN handling are the reference)."""
    u = np.asarray(u, float)
    d = np.asarray(d, float)
    caps = None
    if np.isfinite(u).all() and np.isfinite(d).all():
        caps = _caps_flat(profile, _lim_fields(lim, accel), u, d, jerk_r)
    if caps is None:
        return np.array([vertex_cap(profile, lim, accel, tuple(u[k]), tuple(u[k + 1]), d[k], d[k + 1], jerk_r)
                         for k in range(len(d) - 1)], float)
    return caps


_LIM_FIELDS = ("ax_max", "ay_max", "scv", "jd", "jerk_x", "jerk_y")


def _lim_fields(lim, accel):
    return {**{f: getattr(lim, f) for f in _LIM_FIELDS}, "accel": accel}


def _caps_flat(profile, p, u, d, jerk_r):
    """The caps at the vertices between u[k] and u[k + 1]; p: the limits (and the stroke's
    acceleration) per vertex or scalars.  None where the scalar law would raise (a negative
    squared speed: math.sqrt raises)."""
    return _caps_core(profile, p, u[:-1, 0], u[:-1, 1], u[1:, 0], u[1:, 1], d[:-1], d[1:], jerk_r)


def _caps_core(profile, p, pux, puy, ux, uy, dp, dn, jerk_r):
    """_caps_flat's elementwise law on the two directions and lengths of every vertex
    (any shapes that broadcast: _caps_flat's flat rows or _block_caps' (m, n - 1) blocks
    with the limits per row as (m, 1): the same operations on each element)."""
    with np.errstate(all="ignore"):
        if profile.junction == "jerk":
            return _jerk_caps(pux, puy, ux, uy, jerk_r * p["jerk_x"], jerk_r * p["jerk_y"])
        accel = p["accel"]
        a0 = np.where(accel > 0, accel, profile.default_accel_a)
        ap = _accel_in_force_v(a0, p["ax_max"], p["ay_max"], pux, puy)
        a = _accel_in_force_v(a0, p["ax_max"], p["ay_max"], ux, uy)
        if profile.junction == "scv":
            v2 = _klipper_v2(pux, puy, p["scv"] * p["scv"] * SQRT2_M1 / a0, ap, 2.0 * dp * ap,
                             ux, uy, a, 2.0 * dn * a)
        else:
            v2 = _marlin_jd_v2(pux, puy, ux, uy, dn, a, p["jd"], p["ax_max"], p["ay_max"])
        if (v2 < 0.0).any():
            return None
        return np.where(np.isfinite(v2), np.sqrt(v2), math.inf)


def batch_caps(strokes, profile, us, ds, jerk_r):
    """vertex_caps of several strokes (directions us[i], lengths ds[i]) in one vectorised
    pass over all their vertices (the same bits as stroke by stroke); None if an input
    is not finite (then stroke by stroke)."""
    got = _caps_flat_rows(strokes, profile, us, ds, jerk_r)
    if got is None:
        return None
    caps, starts = got
    n = [x.size for x in ds]
    return [caps[a:a + max(k - 1, 0)] for a, k in zip(starts, n)]     # np.split's views, less overhead


def _caps_flat_rows(strokes, profile, us, ds, jerk_r, flat=None):
    """batch_caps' caps as one flat array and each stroke's first cap in it (a list of
    ints), or None.  flat: (n, u, d, p) as _flat_inputs gives them for these strokes."""
    n, u, d, p = _flat_inputs(strokes, us, ds) if flat is None else flat
    if not (np.isfinite(u).all() and np.isfinite(d).all()) or u.shape[0] < 2 or (n < 1).any():
        return None
    caps = _caps_flat(profile, p, u, d, jerk_r)
    if caps is None:
        return None
    keep = np.ones(caps.size, bool)
    keep[np.cumsum(n)[:-1] - 1] = False            # the vertex between two strokes
    caps = caps[keep]
    ends = np.cumsum(np.maximum(n - 1, 0)).tolist()
    return caps, [0] + ends[:-1]


def _flat_inputs(strokes, us, ds):
    """(segment counts, directions and lengths end to end, the limits and acceleration of
    each stroke repeated per segment but the last) of _caps_flat_rows.  The limits are
    read once per limits object the strokes share (the same numbers as stroke by stroke)."""
    n = np.array([x.size for x in ds], int)
    u, d = np.concatenate(us), np.concatenate(ds)
    seen = {}
    which = [seen.setdefault(id(st.lim), (len(seen), st.lim))[0] for st in strokes]
    lims = [lim for _, lim in seen.values()]
    p = {f: np.repeat(np.array([getattr(lim, f) for lim in lims], float)[which], n)[:-1] for f in _LIM_FIELDS}
    p["accel"] = np.repeat(np.array([st.accel for st in strokes], float), n)[:-1]
    return n, u, d, p


def _pmax(a, b):
    """Python's max(a, b) elementwise (b if b > a else a)."""
    return np.where(b > a, b, a)


def _jerk_caps(pux, puy, ux, uy, jx, jy):
    """marlin_jerk_junction_v with nominal = p_nominal = big, no safe speeds, z = 0."""
    big = 1e6

    def axis_jerk(v_exit, v_entry):
        return np.where(v_exit > v_entry,
                        np.where((v_entry > 0.0) | (v_exit < 0.0), v_exit - v_entry, _pmax(v_exit, -v_entry)),
                        np.where((v_entry < 0.0) | (v_exit > 0.0), v_entry - v_exit, _pmax(-v_exit, v_entry)))
    jerk = axis_jerk(pux * big * 1.0, ux * big)
    lim_x = jerk > jx
    vf = np.where(lim_x, 1.0 * (jx / jerk), 1.0)
    ex, en = puy * big * 1.0, uy * big
    ex, en = np.where(lim_x, ex * vf, ex), np.where(lim_x, en * vf, en)
    jerk = axis_jerk(ex, en)
    lim_y = jerk > jy
    vf = np.where(lim_y, vf * (jy / jerk), vf)
    return np.where(lim_x | lim_y, big * vf, big)    # the z axis moves 0: no limit, and
                                                      # p_safe = 0 never is "not coasting"


def _accel_in_force_v(a0, ax_max, ay_max, ux, uy):
    a = np.broadcast_to(a0, ux.shape)
    ax, ay = np.abs(ux), np.abs(uy)
    a = np.where((ax > 0) & (a * ax > ax_max), ax_max / ax, a)
    return np.where((ay > 0) & (a * ay > ay_max), ay_max / ay, a)


def _klipper_v2(pux, puy, jd, p_accel, p_delta_v2, ux, uy, accel, delta_v2):
    """klipper_corner_v2 with z = 0 and p_jd = jd (one acceleration in force)."""
    cos_theta = -(ux * pux + uy * puy + 0.0 * 0.0)
    s2, c2 = 0.5 * (1.0 - cos_theta), 0.5 * (1.0 + cos_theta)
    sin_d2 = np.where(s2 > 0.0, np.sqrt(s2), 0.0)
    cos_d2 = np.where(c2 > 0.0, np.sqrt(c2), 0.0)
    one_m = 1.0 - sin_d2
    r_jd = sin_d2 / one_m
    v2 = r_jd * jd * accel
    v2 = np.where(r_jd * jd * p_accel < v2, r_jd * jd * p_accel, v2)
    qt = 0.25 * sin_d2 / cos_d2
    v2 = np.where(delta_v2 * qt < v2, delta_v2 * qt, v2)
    v2 = np.where(p_delta_v2 * qt < v2, p_delta_v2 * qt, v2)
    return np.where((one_m > 0.0) & (cos_d2 > 0.0), v2, math.inf)


def _marlin_jd_v2(pux, puy, ux, uy, d, accel, jd, cx, cy):
    """marlin_jd_v2 with z = 0 and cz = 1e9."""
    cos_theta = -(pux * ux + puy * uy + 0.0 * 0.0)
    jx, jy = ux - pux, uy - puy
    jn = np.sqrt(jx * jx + jy * jy + 0.0 * 0.0)
    ax, ay = np.abs(jx / jn), np.abs(jy / jn)
    ja = np.where((ax > 0.0) & (accel * ax > cx), cx / ax, accel)
    ja = np.where((ay > 0.0) & (ja * ay > cy), cy / ay, ja)
    ja = np.where(jn > 0.0, ja, accel)
    s = 0.5 * (1.0 - cos_theta)
    sin_d2 = np.where(s > 0.0, np.sqrt(s), 0.0)
    one_m = 1.0 - sin_d2
    v2 = np.where(one_m > 0.0, ja * jd * sin_d2 / one_m, math.inf)
    neg = np.where(cos_theta < 0.0, -1.0, 1.0)
    t = neg * cos_theta
    asinx = (0.032843707 + t * (-1.451838349 + t * (29.66153956 + t * (-131.1123477
             + t * (262.8130562 + t * (-242.7199627 + t * 84.31466202))))))
    lim = d * ja / (math.pi / 2.0 + neg * asinx)
    v2 = np.where((d < 1.0) & (cos_theta < -0.7071067812) & (lim < v2), lim, v2)
    return np.where(cos_theta > 0.999999, MINIMUM_PLANNER_SPEED * MINIMUM_PLANNER_SPEED, v2)


CHAIN_SEG_D = 2.0          # mm: a capped vertex next to a longer segment cuts the run


def vertex_splitter(profile):
    """split(prev_move, move) for strokes.group_strokes: True where the vertex's speed cap
    (x CAP_MARGIN) is below the feed -- the firmware slows there whatever we do -- and one
    of its two segments is longer than CHAIN_SEG_D: the pieces are then re-timed on their
    own (a long straight segment as a line, many knots), better than one firmware move per
    segment.  A capped vertex between short segments stays inside: that run is a chain
    (chains.py: gyroid, honeycomb at full speed)."""
    def split(pm, m, dp=None, dn=None, pu=None, u=None):
        # dp, dn, pu, u: the two moves' lengths and unit directions when the caller has
        # them (strokes.group_lines, the same hypot and divisions as _d and _u)
        try:       # plain floats: a zero length or a bad root raises here, inf/NaN compare False below
            if dp is None:
                dp, dn, pu, u = _d(pm), _d(m), _u(pm), _u(m)
            cap = vertex_cap(profile, m.lim, m.accel, pu, u, dp, dn)
        except (ArithmeticError, ValueError):   # a degenerate vertex: end the curve there
            return True
        if not cap > 0.0:                       # NaN or a stop
            return True
        return CAP_MARGIN * cap < m.v and max(dp, dn) > CHAIN_SEG_D
    return split


def _u(m):
    dx, dy = m.x1 - m.x0, m.y1 - m.y0
    d = math.hypot(dx, dy)
    return dx / d, dy / d


def _d(m):
    return math.hypot(m.x1 - m.x0, m.y1 - m.y0)


# ------------------------------------------------------------------ geometry
class CurveGeom:
    """Per-curve arrays: vertices, segment lengths/directions, turns, κ(s).

    Compact: a geometry is one row of a block shared by the strokes of one vertex count
    (build_geoms: _block_geoms), every field read from the block when asked.  The block
    (_Blk) keeps only what later steps read and cannot make cheaply: the lengths d, κ at
    the vertices, κ_eff, the vertex caps (and classic jerk's at the whole jerk), cap and
    cos_end; the directions u are made from the strokes' own vertices and d when read
    (_Blk.u_rows), the turns' cosines (cos_turn) and the arc lengths at the vertices (s_v)
    from u and d, by the same operations as when they were kept (the difference over d;
    einsum of the row; cumsum, a sequential sum: the same bits).  Four slots: the
    vertices are the block's (a fifth slot put a geometry in pymalloc's 80-byte class, not
    the 64-byte one: ~0.3 MB on the gyroid plate's 21 k curves)."""
    __slots__ = ("_b", "_k", "chain_caps", "_j1")

    def __init__(self, st, profile, seg=None, caps=None, caps_jerk1=None, parts=None, cap=None, cos_end=None):
        """seg: (pts, d, u) from _segments; parts: (block, row) of _batch_parts (the same
        bits for many strokes at once); caps, caps_jerk1: the vertex caps (classic jerk's
        at the whole jerk: chains.vertex_caps), an array or (flat array, first cap) as
        build_geoms computed them for many strokes at once; caps None: computed here.
        cap, cos_end: those fields as computed for many strokes (the same numbers,
        _ends_rows); None: computed here.  The geometry is a block of one row."""
        if parts is not None:
            pb, pk = parts
            d, u, kappa_v, kappa_eff = pb[0][pk], pb[1][pk], pb[4][pk], pb[5][pk]
        else:
            d, u, kappa_v, kappa_eff = _own_parts(st, seg)
        if caps is None:
            caps = vertex_caps(profile, st.lim, st.accel, u, d)
        elif isinstance(caps, tuple):
            caps = caps[0][caps[1]:caps[1] + d.shape[0] - 1]
        if isinstance(caps_jerk1, tuple):
            caps_jerk1 = caps_jerk1[0][caps_jerk1[1]:caps_jerk1[1] + d.shape[0] - 1]
        if cap is None:
            cap = CAP_MARGIN * min(caps.tolist()) if caps.size else math.inf
        if cos_end is None:
            # turns at the two ends (None: a stop or a corner): the firmware model counts half
            # of each end junction's normal term in the stroke, as it did for the original
            cos_end = [None, None]
            for j, (a, b) in enumerate(((st.prev_u, tuple(u[0])), (tuple(u[-1]), st.next_u))):
                if a is not None and b is not None:
                    c = a[0] * b[0] + a[1] * b[1]
                    cos_end[j] = c if c >= CORNER_COS else None
            cos_end = _NO_ENDS if cos_end == [None, None] else tuple(cos_end)
        self._b = _Blk(d[None], u[None], kappa_v[None], [kappa_eff], caps[None],
                       None if caps_jerk1 is None else caps_jerk1[None], [cap], [cos_end], False, pts=[st.pts])
        self._k = 0
        self.chain_caps = None                    # chains.py: the caps a chain's law meets
        self._j1 = _FROM_BLOCK

    d = property(lambda self: self._b.d[self._k], doc="segment lengths (n,)")
    u = property(lambda self: self._b.u_row(self._k), doc="segment unit directions (n, 2)")
    kappa_v = property(lambda self: self._b.kappa_row(self._k), doc="smoothed curvature at each vertex (n + 1,)")
    caps = property(lambda self: self._b.caps[self._k], doc="the vertex speed caps (mm/s), per interior vertex")
    cap = property(lambda self: float(self._b.cap[self._k]), doc="CAP_MARGIN x the least vertex cap (a float; inf if none)")

    @property
    def kappa_eff(self):
        """The effective constant curvature: a float (a block's array element), or as
        CurveGeom's own path made it (a list of one: a float or a numpy float64).  Made
        first where its block has not (build_geoms' kappa False)."""
        b, k = self._b, self._k
        ke = b._ke
        if ke is None or (b._ke_miss is not None and b._ke_miss[k]):
            b.make_kappa([k])
            ke = b._ke
        return ke[k] if type(ke) is list else float(ke[k])

    @property
    def cos_turn(self):
        """cosine of each interior vertex's turn (n - 1,)"""
        u = self._b.u_row(self._k)
        return np.einsum("ij,ij->i", u[:-1], u[1:])

    @property
    def s_v(self):
        """arc length at each vertex (n + 1,)"""
        d = self._b.d[self._k]
        s = np.empty(d.shape[0] + 1)
        s[0] = 0.0
        np.cumsum(d, out=s[1:])
        return s

    @property
    def cos_end(self):
        """The cosines of the turns at the two ends (None where a stop or a corner)."""
        return self._b.cos_end[self._k]

    @cos_end.setter
    def cos_end(self, c):
        self._b.cos_end[self._k] = c

    @property
    def caps_jerk1(self):
        """Classic jerk's caps at the whole jerk, if build_geoms computed them (chains)."""
        j1 = self._j1
        if j1 is not _FROM_BLOCK:
            return j1
        c1 = self._b.caps_jerk1
        return None if c1 is None else c1[self._k]

    @caps_jerk1.setter
    def caps_jerk1(self, caps):
        self._j1 = caps

    @property
    def pts(self):
        """The vertices as _segments takes them, (n+1, 2) (an array per curve held ~10 MB on a
        plate): the stroke's own, its block's row (read by tests only)."""
        return np.asarray(self._b._pts[self._k], float)

    def end_terms(self, v0, v1):
        """Half the normal term of the two end junctions, at the end speeds: (1-cos) v³/d."""
        out = 0.0
        cos_end = self.cos_end
        if cos_end is _NO_ENDS:
            return out
        d = self.d
        for c, v, dd in ((cos_end[0], v0, d[0]), (cos_end[1], v1, d[-1])):
            if c is not None:
                out += (1.0 - c) * v ** 3 / dd
        return out

    def kappa(self, s):
        return np.interp(s, self.s_v, self.kappa_v)


_GEOM_B, _GEOM_D_SHAPE, _AXIS1 = attrgetter("_b"), attrgetter("_b.d.shape"), itemgetter(1)


def seg_counts(gs):
    """[g.d.size for g in gs]: each geometry's number of segments, read as its block's
    row length (build_geoms' _Blk: rows of one (m, n) array; each block checked once)
    by C-level maps instead of a view of its row made per geometry (~17 k chains a
    plate's chain replay); g.d.size itself where a block is not of that shape or a
    geometry is of another make."""
    try:
        blocks = set(map(_GEOM_B, gs))
    except AttributeError:
        return [g.d.size for g in gs]
    if not all(type(b.d) is np.ndarray and b.d.ndim == 2 for b in blocks):
        return [g.d.size for g in gs]
    return list(map(_AXIS1, map(_GEOM_D_SHAPE, gs)))


def _stacked_runs(gs):
    """(D, runs, ks) of the geometries gs: D their lengths stacked, each run of rows of one
    block (build_geoms' _Blk) taken by one fancy index of its lengths (the same doubles),
    runs the (block, first, end) of each, ks the rows' indices in their blocks; None for
    geometries of another make, or blocks whose rows do not stack."""
    try:
        bs = [g._b for g in gs]
        ks = [g._k for g in gs]
    except AttributeError:
        return None
    if not bs:
        return None
    ds, runs = [], []
    a, m = 0, len(bs)
    while a < m:                    # runs of one block
        b = bs[a]
        z = a + 1
        while z < m and bs[z] is b:
            z += 1
        ds.append(_run_rows(np.asarray(b.d, float), ks, a, z, True))     # (np.take: the same rows)
        runs.append((b, a, z))
        a = z
    if not all(x.ndim == 2 and x.shape[1:] == ds[0].shape[1:] for x in ds):
        return None
    return _joined(ds, runs), runs, ks


def _run_rows(x, ks, a, z, take=False):
    """The rows ks[a:z] of a block's array x (x.take(..., axis=0) if take, else x[...]):
    x itself where it is the block's one row (a curve on CurveGeom's own path: ~2.5 k
    such blocks on the rectilinear plate, a take and a u_rows call each); _joined copies it."""
    if z - a == 1 and x.shape[0] == 1 and type(x) is np.ndarray and x.dtype == np.float64:
        return x
    return x.take(ks[a:z], axis=0) if take else x[ks[a:z]]


def _joined(xs, runs):
    """The runs' rows xs (_run_rows) stacked: a new array (a lone block row copied)."""
    if len(xs) > 1:
        return np.concatenate(xs)
    b, a, z = runs[0]
    return xs[0].copy() if z - a == 1 and xs[0].shape[0] == 1 else xs[0]


def stack_d(gs):
    """stack_du(gs)'s lengths D alone (the same doubles), without the directions."""
    got = _stacked_core(gs, False)
    if got is not None:
        return got[0]
    got = _stacked_runs(gs)
    return got[0] if got is not None else np.array([g.d for g in gs], float)


def stack_du(gs):
    """(np.array([g.d for g in gs], float), np.array([g.u for g in gs], float)): the
    geometries' segment lengths and directions stacked (_stacked_runs: not a view and a
    copy a geometry, ~1 us each, ~34 k geometries a plate's chain finishing), the
    directions made from the stacked lengths and the strokes' vertices in one pass
    (_stack_u).  Geometries of another make, or blocks whose rows do not stack: row by
    row."""
    got = _stacked_core(gs, True)
    if got is not None:
        return got
    got = _stacked_runs(gs)
    if got is not None:
        D, runs, ks = got
        return D, _stack_u(gs, runs, ks, D)
    return np.array([g.d for g in gs], float), np.array([g.u for g in gs], float)


def _stacked_core(gs, with_u):
    """(D, U) of stack_du (U None unless with_u) by the compiled core in one pass over the
    geometries (_curvecore.c stack_rows: the rows copied, U made as _Blk.u_rows makes it;
    the chains' finishing calls it ~1.8 k times on the windowed gyroid plate, ~20 rows
    each, where _stacked_runs' and _stack_u's set-up was ~20 us a call), or None where the
    core is not built or declines them (then _stacked_runs' path)."""
    if _STACK_ROWS is None or type(gs) is not list or not gs:
        return None
    try:
        n = gs[0]._b.d.shape[1]
    except (AttributeError, IndexError, TypeError):
        return None
    if type(n) is not int:
        return None
    m = len(gs)
    D = np.empty((m, n))
    U = np.empty((m, n, 2)) if with_u else None
    return (D, U) if _STACK_ROWS(gs, n, D, U) else None


def stack_du_into(gs, n, D, U):
    """stack_du(gs) written into D (m, n) and U (m, n, 2), C-contiguous float64 (a ragged
    finishing call's stretches of its flat inputs, chains._finish_ragged): by the core's
    stack_rows into them where it takes the geometries (the rows _stacked_core copies and
    makes), else stack_du's own arrays copied in.  False where those are not (m, n) and
    (m, n, 2) float64 (the caller declines)."""
    if _STACK_ROWS is not None and type(gs) is list and gs and _STACK_ROWS(gs, n, D, U):
        return True
    got_d, got_u = stack_du(gs)
    if (got_d.shape != D.shape or got_u.shape != U.shape or got_d.dtype != np.float64
            or got_u.dtype != np.float64):
        return False
    D[...], U[...] = got_d, got_u
    return True


def _stack_u(gs, runs, ks, D):
    """stack_du's directions: the rows of the runs (block, first, end) of gs, whose
    lengths D holds stacked.  Blocks that keep no u (build_geoms'): one pass of the
    compiled core over every row (the rows' vertices gathered from their blocks: the
    same operations as _Blk.u_rows); else run by run."""
    if _U_ROWS is not None and all(b._u is None for b, _, _ in runs):
        m, n = D.shape
        out = np.empty((m, n, 2))
        pts = []
        for b, a, z in runs:
            pts += map(b._pts.__getitem__, ks[a:z])
        try:
            _U_ROWS(pts, None, 0, D, m, n, out)
            return out
        except (TypeError, ValueError, AttributeError, BufferError):
            pass
    us = [b.u_rows(ks[a:z]) if b._u is None else _run_rows(np.asarray(b._u, float), ks, a, z) for b, a, z in runs]
    return _joined(us, runs)


def drop_jerk1(sts):
    """Let go of the blocks' caps at the whole jerk of the strokes sts' geometries (chains
    have made their own caps from them: chains.classify); a stroke that reads them later
    finds None and makes them (chains.vertex_caps: the same numbers).  Under classic jerk
    (chains.classify calls this then) the caps at jerk's share go too: classify is their
    one reader (curves read cap); a block of build_geoms makes them again if asked."""
    try:                                # each block once (~21 k strokes, ~120 blocks a plate)
        blocks = set(map(_CURV_B, sts))
    except AttributeError:              # a stroke without a geometry
        blocks = {g._b for g in [st.curv for st in sts] if g is not None}
    drop_blocks_jerk1(blocks)


def drop_blocks_jerk1(blocks):
    """drop_jerk1 of strokes whose geometries are the rows of these blocks."""
    for b in blocks:
        b.caps_jerk1 = None
        if b._lim is not None:          # the caps at jerk's share too: chains.classify alone reads
            b._caps = None              # them under classic jerk (made again if read: _Blk.caps)


_CURV_B = attrgetter("curv._b")


class _Blk:
    """The fields of a block of curve geometries, row k each stroke's: d (m, n), u (m, n, 2),
    kappa_v (m, n + 1), kappa_eff (m floats), caps (m, n - 1), caps_jerk1 (m, n - 1) or None,
    cap (m floats), cos_end (a list of m), cap_min: every cap of the block is > 0 (then
    cap is CAP_MARGIN x the least cap as np.minimum takes it).

    pts: the rows' own vertices (the strokes' pts, which they hold anyway).  u None
    (build_geoms' blocks): not kept (~5 MB on the gyroid plate at planning's peak) but made
    again from pts when read, by _parts_block's operations (the difference of the
    vertices over the kept lengths d: the same bits).  lim: (profile, the limits objects,
    which one each row's, each row's acceleration): then the caps, read by chains.classify
    alone under classic jerk, may be let go (drop_jerk1) and are made again when read.
    Without u, κ at the vertices too may be let go (drop_kappa, once the curves' candidates
    are made: their one reader) and is made again by _parts_block when read.  κ at the
    vertices and κ_eff None (build_geoms' kappa False): made for the rows read, when read
    (make_kappa; _kv_miss, _ke_miss: the rows not made yet, None if none)."""
    __slots__ = ("d", "_u", "_pts", "_kv", "_ke", "_kv_miss", "_ke_miss", "_caps", "_lim", "caps_jerk1", "cap",
                 "cos_end", "cap_min", "_ux2", "_end2", "__weakref__")

    def __init__(self, d, u, kappa_v, kappa_eff, caps, caps_jerk1, cap, cos_end, cap_min, pts=None, lim=None):
        self.d, self._kv, self._ke = d, kappa_v, kappa_eff
        self._kv_miss = self._ke_miss = None
        self._u, self._pts = u, pts
        self._caps, self._lim = caps, lim
        self.caps_jerk1, self.cap, self.cos_end, self.cap_min = caps_jerk1, cap, cos_end, cap_min
        self._ux2 = None            # adjust_plan_inputs' direction weights of every row, once made
        # cos_end's cosines as (2, m) doubles, NaN where None (build_geoms' end_cols: made with
        # cos_end, for geom_keep.put, which writes them so), or None; cos_end is not changed after
        self._end2 = None

    @property
    def u(self):
        """The directions of every row, (m, n, 2)."""
        return self.u_rows(list(range(self.d.shape[0]))) if self._u is None else self._u

    def u_rows(self, ks):
        """u[ks] (ks a list of rows): _parts_block's seg / d[..., None] of those rows' vertices."""
        if self._u is not None:
            return np.asarray(self._u, float)[ks]
        m, n = len(ks), self.d.shape[1]
        if _U_ROWS is not None:
            out = np.empty((m, n, 2))
            if self._core_u(np.asarray(ks, np.int64), 0, m, out):
                return out
        xy = _pts_xy(list(map(self._pts.__getitem__, ks))).reshape(m, n + 1, 2)
        with np.errstate(all="ignore"):
            u = np.subtract(xy[:, 1:], xy[:, :-1])
            return np.divide(u, self.d[ks][..., None], out=u)

    def u_row(self, k):
        """u[k], (n, 2): u_rows of one row, as 2-D arrays (the same operations)."""
        if self._u is not None:
            return self._u[k]
        if _U_ROWS is not None:
            out = np.empty((self.d.shape[1], 2))
            if self._core_u(None, k, 1, out):
                return out
        xy = _pts_xy([self._pts[k]]).reshape(-1, 2)
        with np.errstate(all="ignore"):
            u = np.subtract(xy[1:], xy[:-1])
            return np.divide(u, self.d[k][:, None], out=u)

    def _core_u(self, ks, k0, m, out):
        """u_rows by the compiled core (_curvecore.c u_rows: the same two operations per
        element) into out; False where it does not take the rows (vertices not Points)."""
        try:
            _U_ROWS(self._pts, ks, k0, self.d, m, self.d.shape[1], out)
        except (TypeError, ValueError, AttributeError, BufferError):
            return False
        return True

    @property
    def caps(self):
        c = self._caps
        if c is None and self._lim is not None:      # let go by drop_jerk1: made again, kept
            c = self._caps = _block_caps(self._lim, self.u, self.d, 1.0 - JERK_F_STEP_R)
        return c

    @caps.setter
    def caps(self, c):
        self._caps = c

    @property
    def kappa_v(self):
        """κ at the vertices of every row, (m, n + 1) (let go by drop_kappa, or not made
        yet: made now, kept)."""
        if self._kv is None or self._kv_miss is not None:
            self.make_kappa(range(self.d.shape[0]))
        return self._kv

    @kappa_v.setter
    def kappa_v(self, kv):
        self._kv, self._kv_miss = kv, None

    @property
    def kappa_eff(self):
        """κ_eff of every row (m,) (made now where not made yet)."""
        if self._ke is None or self._ke_miss is not None:
            self.make_kappa(range(self.d.shape[0]))
        return self._ke

    def kappa_row(self, k):
        """kappa_v[k], made first if not made yet."""
        if self._kv is None or (self._kv_miss is not None and self._kv_miss[k]):
            self.make_kappa([k])
        return self._kv[k]

    def kappa_rows(self, ks):
        """kappa_v[ks] (ks a list of rows), those rows made first where not made yet."""
        if self._kv is None or self._kv_miss is not None:
            self.make_kappa(ks)
        return np.asarray(self._kv, float)[ks]

    def make_kappa(self, ks):
        """Make κ at the vertices and κ_eff of the rows ks (a list or range) where not made
        yet: _parts_block's operations on those rows' own vertices (_kappa_block: row by
        row the same bits as the block's _parts_block)."""
        m, n = self.d.shape
        if self._kv is None:
            self._kv, self._kv_miss = np.empty((m, n + 1)), np.ones(m, bool)
        if self._ke is None:
            self._ke, self._ke_miss = np.empty(m), np.ones(m, bool)
        ks = np.asarray(ks, np.int64)
        miss = np.zeros(ks.size, bool)
        for mask in (self._kv_miss, self._ke_miss):
            if mask is not None:
                miss |= mask[ks]
        todo = ks[miss]
        if todo.size:
            xy = _pts_xy(list(map(self._pts.__getitem__, todo.tolist()))).reshape(todo.size, n + 1, 2)
            with np.errstate(all="ignore"):
                seg, d, _, _, s_v, _ = _parts_base(xy)
                self._kv[todo], self._ke[todo] = _kappa_block(seg, d, s_v)
        for name in ("_kv_miss", "_ke_miss"):
            mask = getattr(self, name)
            if mask is not None:
                mask[todo] = False
                if not mask.any():
                    setattr(self, name, None)


_XY = attrgetter("xy")
_U_ROWS = getattr(_CURVE_CORE, "u_rows", None)      # _Blk.u_rows compiled (or None)
_STACK_ROWS = getattr(_CURVE_CORE, "stack_rows", None)      # stack_du's rows compiled (or None)
_PUT_GEOMS = getattr(_CURVE_CORE, "put_geoms", None)        # put_rows compiled (or None)
_BLOCKS = weakref.WeakSet()     # build_geoms' blocks alive (drop_kappa)


def drop_kappa():
    """Let go of κ at the vertices of every block of build_geoms alive (~2.7 MB on the
    gyroid plate through planning's budget runs): the curves' candidates (candidates_curve)
    are its one reader in a run, made once; a later reader makes it again (_Blk.kappa_v)."""
    for b in list(_BLOCKS):
        b._kv = None


def _pts_xy(ps):
    """The vertices of the point lists ps end to end, flat (x0, y0, x1, ...): _xy_block's."""
    try:                # Points: their packed doubles joined (an array("d") each)
        return np.frombuffer(b"".join(map(_XY, ps)), float)
    except (AttributeError, TypeError):
        pass
    return np.concatenate([np.frombuffer(p.xy, float) if isinstance(p, Points) else np.asarray(p, float).ravel()
                           for p in ps])


_FROM_BLOCK = object()      # CurveGeom._j1: caps_jerk1 is the block's row


def _own_parts(st, seg):
    """CurveGeom's own path: (d, u, kappa_v, kappa_eff) of one stroke."""
    pts, d, u = seg if seg is not None else _segments(st)
    s_v = np.concatenate([[0.0], np.cumsum(d)])
    # smoothing over one median segment: wider kernels flatten the gyroid's curvature
    # peaks (3 segments lose half of ∫κ²ds, which the firmware model's vertex terms keep);
    # the slicer's 0.001 mm rounding is ±0.1 deg on ~10 deg turns, averaged over ~5 vertices
    from .laws.curve import curvature_from_polyline      # (here: a plate's run never needs laws/curve.py)
    pc = curvature_from_polyline(pts, smooth_d=max(_median(d), SMOOTH_MIN_D))
    kappa_v = np.interp(s_v, pc.s_d, pc.kappa_v)
    S = s_v[-1]
    mid = 0.5 * (kappa_v[:-1] ** 2 + kappa_v[1:] ** 2)
    k2 = float(np.sum(mid * d) / S)
    return d, u, kappa_v, max(math.sqrt(k2), 1.0 / (MAX_R_OVER_S * S))

_NO_ENDS = (None, None)     # CurveGeom.cos_end of a curve between stops or corners (shared)


def _median(x):
    """float(np.median(x)) for finite x, by one partition (np.median's own steps: the
    middle element, or the mean of the two middle ones; tests/test_speed_plan_caps.py)."""
    n = x.size
    if n == 0 or not np.isfinite(x).all():
        return float(np.median(x))
    k = n // 2
    if n % 2:
        return float(np.partition(x, k)[k])
    p = np.partition(x, [k - 1, k])
    return float((p[k - 1] + p[k]) / 2.0)


def _segments(st):
    pts = np.asarray(st.pts, float)
    seg = np.diff(pts, axis=0)
    d = np.hypot(seg[:, 0], seg[:, 1])
    return pts, d, seg / d[:, None]


def geom(st, profile):
    if st.curv is None:
        st.curv = CurveGeom(st, profile)
    return st.curv


def build_geoms(strokes, profile, jerk1=False, kappa=True, end_cols=False, weights=False, put=True):
    """geom() of every stroke in `strokes` (those without one): their segments, curvature
    and vertex caps computed for all strokes of one vertex count at once (_part_blocks,
    _block_geoms: the same elementwise arithmetic as stroke by stroke, so the same bits),
    each geometry a row of its block; jerk1: classic jerk's caps at the whole jerk too
    (chains.vertex_caps).  A stroke the batched forms do not take (a degenerate or
    non-finite one, too few or too many vertices, caps the vectorised law declines) takes
    CurveGeom's own path, in the strokes' order: one whose geometry raises raises here,
    as geom() would (the strokes before it keep theirs).  Returns the blocks it made, each
    as (its _Blk, its strokes in row order): chains.classify reads them by block.  kappa
    False: κ at the vertices and κ_eff of the blocks' rows are made when read, or by
    make_kappa (_parts_lazy: a chain never reads them); a function want(sts, cap) (a
    block's strokes and their cap): made now for the rows where it is True (a bool
    array), the others when read.  end_cols: the blocks keep their rows' end turns as
    columns too (_Blk._end2: geom_keep.put's, the windowed pipeline's).  weights: the
    blocks' adjust_plan_inputs weights made with them (_flat_ux2; plan_inputs' blocks, not
    those of the later passes, which do not read them).  put False: where every stroke
    (of all strokes, none with a geometry before) is a row of a block, the geometries are
    not put on them: the caller puts them (put_rows; chains.classify, with the chains'
    caps)."""
    todo = [st for st in strokes if st.curv is None]
    if not todo:
        return []
    j1 = jerk1 and profile.junction == "jerk"
    pts = list(map(_PTS, todo))
    made = []                           # (block, its strokes, their indices into todo)
    want = None if isinstance(kappa, bool) else kappa
    fields = _stroke_fields_once(todo)
    for idx, block, bfields, pre in _flat_blocks(todo, pts, kappa is True, want is not None, profile, j1, fields,
                                                 end_cols, weights):
        ii = idx.tolist()
        # (the block's strokes and their vertices by objfields' compiled take, not a Python step a row)
        got = _block_geoms(objfields.items(todo, idx), block, profile, j1, pts=objfields.items(pts, idx), want=want,
                           fields=bfields, pre=pre)
        if got is None:
            continue
        blk, keep, sts = got
        made.append((blk, sts, ii if keep is None else [i for i, g in zip(ii, keep.tolist()) if g]))
    if sum(len(m[1]) for m in made) == len(todo):
        if put or len(todo) != len(strokes):
            for blk, sts, _ in made:        # every stroke a row of a block: the order is not seen
                _put_rows(blk, sts)
        return [m[:2] for m in made]
    rows = [None] * len(todo)          # (block, row) per stroke; None: CurveGeom's own path
    for blk, _, ii in made:
        for k, i in enumerate(ii):
            rows[i] = (blk, k)
    for st, r in zip(todo, rows):
        st.curv = (CurveGeom(st, profile, caps_jerk1=_own_jerk1(st, profile) if j1 else None) if r is None
                   else row_geom(*r))
    return [m[:2] for m in made]


_PTS = attrgetter("pts")


def row_geom(blk, k, chain_caps=None):
    """The CurveGeom of row k of the block blk (its fields read from the block when asked;
    chain_caps: its chain's caps, kept as chains' _classify_block keeps them, or None)."""
    g = CurveGeom.__new__(CurveGeom)
    g._b = blk
    g._k = k
    g.chain_caps = chain_caps
    g._j1 = _FROM_BLOCK
    return g


def _put_rows(blk, sts):
    """CurveGeom's fields of the strokes sts, row k of blk the k-th's (~21 k strokes on the
    gyroid plate)."""
    put_rows(blk, sts, None, False)


def put_rows(blk, sts, chain=None, only_none=True):
    """row_geom(blk, k, chain[k]) (chain None: None) put on sts[k] (a list), where it has
    no geometry if only_none (else every one); how many were put.  One compiled pass where
    built (_curvecore.c put_geoms: ~63 k geometries on the windowed gyroid plate, given
    by geom_keep three passes over)."""
    if _PUT_GEOMS is not None and type(sts) is list and (chain is None or type(chain) is list):
        return _PUT_GEOMS(blk, sts, chain, CurveGeom, _FROM_BLOCK, only_none)
    given = 0
    for k, st, c in zip(count(), sts, repeat(None) if chain is None else chain):
        if not only_none or st.curv is None:
            st.curv = row_geom(blk, k, c)
            given += 1
    return given


def _own_jerk1(st, profile):
    """Classic jerk's caps at the whole jerk of a stroke on CurveGeom's own path, where
    the vectorised law takes its segments (else None: chains.vertex_caps makes them)."""
    try:
        _, d, u = _segments(st)
    except (ArithmeticError, ValueError):
        return None
    if d.size < 1 or not (np.isfinite(u).all() and np.isfinite(d).all()):
        return None
    return _caps_flat(profile, _lim_fields(st.lim, st.accel), u, d, 1.0)


def _stroke_fields_once(todo):
    """(limits objects, which one each stroke's, accel, (prev_u, next_u)) of the strokes
    todo, read once for all of build_geoms' blocks (a window's ~90 blocks, most of a few
    strokes, each read them again: benchmarks/wincpu54.md), or None where a read raises
    (then each block reads its own, raising where it did)."""
    try:
        return _lims_which(todo) + (_accels(todo), _neighbour_dirs(todo))
    except Exception:                   # noqa: BLE001 -- read again block by block
        return None


def _fields_at(fields, rows):
    """_stroke_fields_once's fields of the strokes rows (an int array): the same objects
    and floats as read from those strokes alone."""
    lims, which, accel, (p, q) = fields
    return lims, which[rows], accel[rows], (p[:, rows], q[:, rows])


def _block_geoms(sts, block, profile, j1, pts=None, want=None, fields=None, pre=None):
    """The _Blk of the strokes sts whose _parts_block (compact) is `block`, which of them
    it holds (a bool mask: the rows _parts_block takes; None: all) and those strokes, or
    None (CurveGeom's own path for all) when the vectorised caps decline one of them.  The
    caps are _caps_flat's law on (m, n - 1) arrays, the limits as (m, 1): each element the
    same operations.  pts: the strokes' vertices (their pts), if the caller has them.
    want: build_geoms' (κ of a block _parts_lazy left without it made for those rows).
    fields: _fields_at's of sts, if the caller read them (else read here).  pre:
    _flat_blocks' (caps, caps at the whole jerk, end turns, u and d finite, _blk_ux2's
    weights, each row's least cap) of every row of the block (caps None: made here; the
    weights None: made when read; the least caps None: taken here), made for many blocks
    at once (the same numbers)."""
    d, u, _, s_v, kappa_v, kappa_eff, good = block[:7]
    if kappa_eff is not None:                       # (None: made when read, _parts_lazy)
        kappa_eff = np.array(kappa_eff, float)      # the same floats, 8 bytes each
    caps = caps1 = ends = finite = ux2 = end2 = mins = None
    if pre is not None:
        caps, caps1, ends, finite, ux2, end2, mins = pre
    keep = None
    if pts is None:
        pts = list(map(_PTS, sts))
    if not good.all():
        if not good.any():
            return None
        keep = good
        d, u = d[good], u[good]
        if kappa_v is not None:
            kappa_v, kappa_eff = kappa_v[good], kappa_eff[good]
        g = good.tolist()
        sts = [st for st, x in zip(sts, g) if x]
        pts = [p for p, x in zip(pts, g) if x]
        if fields is not None:
            fields = _fields_at(fields, np.flatnonzero(good))
        if pre is not None:
            finite, ends = finite[good], [e for e, x in zip(ends, g) if x]
            ux2 = None if ux2 is None else ux2[good]
            end2 = None if end2 is None else end2[:, good]
            if caps is not None:
                caps, caps1 = caps[good], None if caps1 is None else caps1[good]
                mins = None if mins is None else mins[good]
    if not (finite.all() if finite is not None else np.isfinite(u).all() and np.isfinite(d).all()):
        return None
    if fields is None:
        fields = _lims_which(sts) + (_accels(sts), _neighbour_dirs(sts))
    lim = (profile,) + fields[:3]
    if caps is None:
        caps = _block_caps(lim, u, d, 1.0 - JERK_F_STEP_R)
        if caps is None:
            return None
        caps1 = _block_caps(lim, u, d, 1.0) if j1 else None
        mins = None
    if mins is None:
        mins = np.minimum.reduce(caps, axis=1)
    # (every cap > 0 where every row's least one is: a NaN is np.minimum's least; then the
    # least of each row is the one number in any order)
    cap_min = bool((mins > 0.0).all())
    if cap_min:
        cap = CAP_MARGIN * mins
    else:               # a NaN or <= 0: Python's min, as CurveGeom's own path takes it
        cap = np.array([CAP_MARGIN * min(r) if r else math.inf for r in caps.tolist()], float)
    if ends is None:
        ends = _ends_of(sts, u[:, 0], u[:, -1], fields[3])
    miss = None
    if kappa_v is None and want is not None:
        kappa_v, kappa_eff, miss = _kappa_wanted(block[7], d, s_v, keep, want(sts, cap))
    # u is not kept: made again from the strokes' own vertices when read (_Blk.u_rows)
    blk = _Blk(d, None, kappa_v, kappa_eff, caps, caps1, cap, ends, cap_min, pts=pts, lim=lim)
    if miss is not None:
        blk._kv_miss, blk._ke_miss = miss, miss.copy()
    blk._ux2 = ux2                  # (adjust_plan_inputs' weights, _flat_ux2's: None made when read)
    blk._end2 = end2                # (cos_end as columns, geom_keep's: None where not made)
    _BLOCKS.add(blk)
    return blk, keep, sts


def _kappa_wanted(seg, d, s_v, keep, want):
    """(kappa_v, kappa_eff, the rows not made (a bool array, None if none)) of a block's
    rows (_parts_lazy's segments seg and arc lengths s_v, or s_v None and seg _flat_parts'
    _Rows of them; the rows keep of them kept: lengths d) made for the rows want (a bool
    array): the same rows' _kappa_block (row by row the same bits); (None, None, None) if
    none is wanted."""
    if type(seg) is _Rows:
        return _kappa_wanted_rows(seg, d, keep, want)
    if keep is not None:
        seg, s_v = seg[keep], s_v[keep]
    if want.all():
        kv, ke = _kappa_block(seg, d, s_v)
        return kv, ke, None
    rows = np.flatnonzero(want)
    if not rows.size:
        return None, None, None
    kv, ke = np.empty(s_v.shape), np.empty(d.shape[0])
    kv[rows], ke[rows] = _kappa_block(seg[rows], d[rows], s_v[rows])
    return kv, ke, ~want


def _kappa_wanted_rows(parts, d, keep, want):
    """_kappa_wanted of a lazy block's _Rows parts: its segments and s_v taken for the
    rows wanted alone (none: nothing made)."""
    if want.all():
        seg, s_v = parts.take(keep, d)
        kv, ke = _kappa_block(seg, d, s_v)
        return kv, ke, None
    rows = np.flatnonzero(want)
    if not rows.size:
        return None, None, None
    seg, s_v = parts.take(rows if keep is None else np.flatnonzero(keep)[rows], d[rows])
    kv, ke = np.empty((d.shape[0], d.shape[1] + 1)), np.empty(d.shape[0])
    kv[rows], ke[rows] = _kappa_block(seg, d[rows], s_v)
    return kv, ke, ~want


_ACCEL = attrgetter("accel")


def _stroke_floats(sts, names):
    """The fields `names` of the strokes sts (a list) as a float array (len(sts),
    len(names)), read in one pass by the compiled core (strokes.stroke_fields) where each
    value is a float, None or a bool (their doubles: the floats np.array(..., float) and
    np.fromiter make of them), else None (no core, another object: read them yourself).
    Not ~200 instructions an attribute read (~250 k reads on the gyroid plate)."""
    got = stroke_fields(sts, names) if type(sts) is list else None
    if got is None or (got[1] > 2).any():
        return None
    return got[0]


def _accels(sts):
    """The strokes' accel as floats_of(map(_ACCEL, sts), len(sts)) makes them."""
    acc = _stroke_floats(sts, ("accel",))
    return floats_of(map(_ACCEL, sts), len(sts)) if acc is None else acc[:, 0].copy()


def floats_of(values, n):
    """np.array(list(values), float) of n numbers: by np.fromiter where each is a number,
    else (a None: NaN, as np.array takes it) np.array of the list."""
    vals = list(values)
    try:
        return np.fromiter(vals, float, n)
    except (TypeError, ValueError):
        return np.array(vals, float)


def _lims_which(sts):
    """(the limits objects of the strokes sts, each once in the order first met; which one
    each stroke's, an int32 array): the strokes mostly share one."""
    lims, which = objfields.by_identity(sts, "lim")
    return lims, which.astype(np.int32)


def _block_caps(lim, u, d, jerk_r):
    """The vertex caps of a block's rows (directions u (m, n, 2), lengths d (m, n)) at the
    share jerk_r of classic jerk: _caps_core's law on (m, n - 1) arrays with the limits as
    (m, 1), each element the same operations (or None where that law declines).  lim:
    (profile, the limits objects, which one each row's (int array), each row's acceleration)."""
    profile, lims, which, accel = lim

    def field(f):
        return np.array([getattr(x, f) for x in lims], float)[which][:, None]
    if profile.junction == "jerk" and _JERK_CAPS is not None:
        # _jerk_caps' choices and products per vertex in one compiled pass (_curvecore.c)
        return _jerk_caps_block(u, {f: field(f) for f in ("jerk_x", "jerk_y")}, jerk_r)
    p = {f: field(f) for f in _LIM_FIELDS}
    p["accel"] = accel[:, None]
    pux, puy, ux, uy = u[:, :-1, 0], u[:, :-1, 1], u[:, 1:, 0], u[:, 1:, 1]
    return _caps_core(profile, p, pux, puy, ux, uy, d[:, :-1], d[:, 1:], jerk_r)


_JERK_CAPS = getattr(_CURVE_CORE, "jerk_caps", None)


def _jerk_caps_block(u, p, jerk_r):
    """_caps_core's classic jerk caps of a block (u (m, n, 2), the limits p per row as
    (m, 1)) by the compiled core: jerk_r x each row's jerks, then _jerk_caps' operations."""
    m, n = u.shape[:2]
    out = np.empty((m, n - 1))
    # flat views go to the core: numpy keeps a buffer's format on the array the buffer was
    # asked of, and u and out live on in the geometry block (~150 bytes a block)
    _JERK_CAPS(np.ascontiguousarray(u, dtype=float).reshape(-1), np.ascontiguousarray(p["jerk_x"], dtype=float).ravel(),
               np.ascontiguousarray(p["jerk_y"], dtype=float).ravel(), jerk_r, m, n, out.reshape(-1))
    return out


def _cap_rows(flat, starts, n_seg):
    """CurveGeom.cap of strokes whose caps are flat[starts[k]:][:n_seg[k] - 1]: CAP_MARGIN x
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


def _ends_rows(sts, us, flat=None):
    """CurveGeom.cos_end of the strokes sts (unit directions us): the same products and
    sums as CurveGeom's per stroke (each a numpy float64), in arrays.  flat: _flat_inputs
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
    return _ends_of(sts, first, last)


def _ends_of(sts, first, last, dirs=None):
    """_ends_rows of strokes whose first and last unit directions are the rows of first
    and last, (m, 2) each; dirs: their _neighbour_dirs, if the caller has them."""
    return _ends_cols(sts, first, last, dirs, False)[0]


def _ends_cols(sts, first, last, dirs=None, cols=True):
    """(_ends_of's list, the same cosines as a (2, m) array, NaN where None: _Blk._end2; None
    where not cols)."""
    m = len(sts)
    p, q = _neighbour_dirs(sts) if dirs is None else dirs
    c0 = p[0] * first[:, 0] + p[1] * first[:, 1]
    c1 = last[:, 0] * q[0] + last[:, 1] * q[1]
    m0, m1 = c0 >= CORNER_COS, c1 >= CORNER_COS
    out = [_NO_ENDS] * m
    for k, a, b in zip(np.flatnonzero(m0 | m1).tolist(), m0[m0 | m1].tolist(), m1[m0 | m1].tolist()):
        out[k] = (c0[k] if a else None, c1[k] if b else None)
    if not cols:
        return out, None
    cols = np.full((2, m), np.nan)
    np.copyto(cols[0], c0, where=m0)
    np.copyto(cols[1], c1, where=m1)
    return out, cols


def _neighbour_dirs(sts):
    """(prev_u, next_u) of the strokes as (2, m) arrays each, NaN where None."""
    a = _stroke_floats(sts, _NDIR_NAMES)
    if a is not None:
        a = a.T                     # the same (4, m) view of an (m, 4) array as below
        return a[:2], a[2:]
    try:
        rows = list(map(_NDIRS, sts))
    except AttributeError:          # not strokes.Stroke: its prev_u / next_u
        nan2 = (math.nan, math.nan)
        pu = [nan2 if st.prev_u is None else st.prev_u for st in sts]
        nu = [nan2 if st.next_u is None else st.next_u for st in sts]
        return np.array(pu, float).reshape(-1, 2).T, np.array(nu, float).reshape(-1, 2).T
    a = np.array(rows, float).reshape(len(sts), 4).T      # None -> NaN
    return a[:2], a[2:]


_NDIR_NAMES = ("_pux", "_puy", "_nux", "_nuy")
_NDIRS = attrgetter(*_NDIR_NAMES)


CAPS_CHUNK = 1 << 15        # vertices of one batched caps pass (build_geoms)


def _part(part, j):
    """Field j of a stroke's row of a _batch_parts block."""
    block, k = part
    return block[j][k]


_GEOM_BLOCK = 1 << 18       # elements (strokes x vertices x vertices) of one batched kernel block (~2 MB)
_GEOM_MAX_PTS = 512         # curvature_from_polyline smooths in one window up to this many vertices


def _xy(st):
    p = st.pts
    return np.frombuffer(p.xy, float) if isinstance(p, Points) else np.asarray(p, float).ravel()


def _xy_block(todo, idx, pts=None):
    """np.concatenate([_xy(todo[i]) for i in idx]): the strokes' packed vertices joined
    as bytes and read once (the same doubles, one buffer read instead of one a stroke).
    pts: the strokes' vertices (todo[i].pts for every i), if the caller has them."""
    ps = [todo[i].pts for i in idx.tolist()] if pts is None else [pts[i] for i in idx.tolist()]
    if all(type(p) is Points for p in ps):
        return np.frombuffer(b"".join(map(_XY, ps)), float)
    return np.concatenate([_xy(todo[i]) for i in idx])


def _batch_parts(todo):
    """CurveGeom's (d, u, cos_turn, s_v, kappa_v, kappa_eff) of the strokes `todo`, computed
    for all strokes of one vertex count at once with CurveGeom's arithmetic elementwise in
    the same order (the same bits: tests/test_speed_curve3_geom.py): per stroke (block,
    row), block those six for a block of strokes (row k of each is this stroke's), or
    None for a stroke this form does not take as the per-stroke path does (a duplicate
    point, non-finite numbers, fewer than 3 or more than _GEOM_MAX_PTS vertices:
    CurveGeom's own path, which raises where it raises).  ~10x faster than stroke by
    stroke on a gyroid plate."""
    parts = [None] * len(todo)
    for idx, block in _part_blocks(todo):
        good, block = block[-1].tolist(), block[:-1]
        for k, i in enumerate(idx.tolist()):
            if good[k]:
                parts[i] = (block, k)
    return parts


def _part_blocks(todo, pts=None, kappa=True):
    """(indices into todo, _parts_block(their vertices)) for every block of strokes of one
    vertex count (3 to _GEOM_MAX_PTS vertices) that _batch_parts takes.  pts: the strokes'
    vertices (their pts), if the caller has them.  kappa False: _parts_lazy's (κ left to
    be made when read, where it is sure to be finite)."""
    parts = _parts_block if kappa else _parts_lazy
    if pts is None:
        pts = list(map(_PTS, todo))
    for idx, npt in _blocks_of(_npts_of(pts)):
        with np.errstate(all="ignore"):
            block = parts(_xy_block(todo, idx, pts).reshape(idx.size, npt, 2))
        yield idx, block


def _npts_of(pts):
    """The vertex counts of the point lists pts, an int array."""
    # len(Points) is its array's half length: read without the Python __len__ (~21 k strokes)
    return np.array([len(p.xy) >> 1 if type(p) is Points else len(p) for p in pts], int)


def _blocks_of(npts):
    """(indices, vertex count) of every block of _part_blocks: the strokes of one vertex
    count (3 to _GEOM_MAX_PTS) in their order, at most _GEOM_BLOCK // npt² a block."""
    order = np.argsort(npts, kind="stable")
    cuts = [0] + (np.flatnonzero(np.diff(npts[order])) + 1).tolist() + [order.size]
    for a0, z0 in zip(cuts[:-1], cuts[1:]):        # (np.split's groups, without its Python loop)
        grp = order[a0:z0]
        npt = int(npts[grp[0]]) if grp.size else 0
        if npt < 3 or npt > _GEOM_MAX_PTS:
            continue
        step = max(1, _GEOM_BLOCK // (npt * npt))
        for a in range(0, grp.size, step):
            yield grp[a:a + step], npt


_FLAT_PTS = 1 << 13         # vertices of one flat pass over blocks (build_geoms: ~0.6 MB of arrays)


def _flat_blocks(todo, pts, kappa, with_seg, profile, j1, fields, end_cols=False, weights=False):
    """build_geoms' blocks: (indices into todo, _parts_block / _parts_lazy's block of those
    strokes (cos_turn None: build_geoms does not read it; with_seg: the lazy block's
    segments for its want), their fields (_fields_at's, or None: fields None), pre (the
    rows' caps, caps at the whole jerk (j1), end turns, u and d finite and _blk_ux2's
    weights: _block_geoms' pre)).  The blocks' vertex differences, lengths, directions,
    finiteness, end turns, direction weights and classic jerk's caps (one limits object,
    compiled) are made for a chunk of blocks
    at once (_FLAT_PTS vertices), over their vertices end to end: elementwise, the same
    numbers as block by block, not ~60 numpy calls a block (a window's call of ~20
    blocks, most of a few strokes: benchmarks/geoms55.md).  Each block's lengths, arc
    lengths, good, κ and caps are its own arrays, as _parts_block makes them."""
    chunk, size = [], 0
    blocks = list(_blocks_of(_npts_of(pts)))
    for k, (idx, npt) in enumerate(blocks):
        chunk.append((idx, npt))
        size += idx.size * npt
        if size >= _FLAT_PTS or k == len(blocks) - 1:
            yield from _flat_chunk(todo, pts, chunk, kappa, with_seg, profile, j1, fields, end_cols, weights)
            chunk, size = [], 0


def _flat_chunk(todo, pts, chunk, kappa, with_seg, profile, j1, fields, end_cols=False, weights=False):
    """_flat_blocks of the blocks chunk [(indices, vertex count)]."""
    idx_all = np.concatenate([idx for idx, _ in chunk])
    n_pt = np.concatenate([np.full(idx.size, npt) for idx, npt in chunk])
    starts = np.zeros(n_pt.size, int)
    np.cumsum(n_pt[:-1], out=starts[1:])
    P = int(starts[-1] + n_pt[-1])
    xy = _pts_xy([pts[i] for i in idx_all.tolist()]).reshape(P, 2)
    seg = np.empty((P, 2))          # the row after a stroke's last vertex: not a segment (NaN)
    with np.errstate(all="ignore"):
        np.subtract(xy[1:], xy[:-1], out=seg[:-1])      # (_lag_rows' subtraction an element)
        seg[-1] = np.nan
        d = np.hypot(seg[:, 0], seg[:, 1])
        u = _div_pairs(seg, d)
        gap = starts + n_pt - 1     # each stroke's last row
        every = np.logical_and.reduceat       # (over the flat coordinates: not .all(axis=1) of pairs)
        pts_ok = every(np.isfinite(xy.reshape(-1)), 2 * starts)
        d_ok = d > 1e-9
        d_ok[gap] = True
        d_ok = every(d_ok, starts)
        finite = np.isfinite(u.reshape(-1))
        finite[2 * gap], finite[2 * gap + 1] = True, True
        d_fin = np.isfinite(d)
        d_fin[gap] = True
        finite = every(finite, 2 * starts) & every(d_fin, starts)
        caps, caps1 = _flat_jerk_caps(u, profile, j1, fields)
        arc = _flat_arcs(d, starts, gap)
        ux2 = _flat_ux2(d, u, starts, gap) if fields is not None and weights else None
    if fields is not None:
        lims, which, accel, (p, q) = _fields_at(fields, idx_all)
        # (the strokes' count: idx_all's; the columns only where asked: the later passes' none)
        ends, end2 = _ends_cols(idx_all, u[starts], u[gap - 1], (p, q), end_cols)
    # each block's parts under the chunk's one errstate (np.errstate's enter and exit: ~2 us a block)
    ok, a, blocks = pts_ok & d_ok, 0, []
    with np.errstate(all="ignore"):
        for idx, npt in chunk:
            m, z = idx.size, a + idx.size
            rows = slice(int(starts[a]), int(starts[a]) + m * npt)
            blocks.append(_flat_parts(seg[rows].reshape(m, npt, 2), d[rows].reshape(m, npt), u[rows].reshape(m, npt, 2),
                                      ok[a:z], kappa, with_seg,
                                      None if arc is None else (arc[0][rows].reshape(m, npt), arc[1][a:z], arc[2][a:z])))
            a = z
    # each row's least cap, np.minimum over its run of the flat caps (the blocks' rows' own
    # numbers: _block_geoms' cap where all are > 0), for the chunk at once, not a reduction a block
    mins = None
    if fields is not None and caps is not None:
        cut = np.empty(2 * starts.size, np.intp)
        cut[0::2], cut[1::2] = starts, starts + n_pt - 2
        mins = np.minimum.reduceat(caps, cut)[0::2]
    a = 0
    for (idx, npt), block in zip(chunk, blocks):
        m, z = idx.size, a + idx.size
        rows = slice(int(starts[a]), int(starts[a]) + m * npt)
        if fields is None:
            yield idx, block, None, None
        else:
            bcaps = None if caps is None else caps[rows].reshape(m, npt)[:, :-2].copy()
            bcaps1 = None if caps1 is None else caps1[rows].reshape(m, npt)[:, :-2].copy()
            yield idx, block, (lims, which[a:z], accel[a:z], (p[:, a:z], q[:, a:z])), \
                (bcaps, bcaps1, ends[a:z], finite[a:z], None if ux2 is None else ux2[a:z],
                 None if end2 is None else end2[:, a:z], None if mins is None else mins[a:z])
        a = z


def _flat_parts(seg, d, u, ok, kappa, with_seg, arc=None):
    """_parts_block (kappa) or _parts_lazy of a block of m strokes of npt vertices from
    _flat_chunk's rows of it (seg, u (m, npt, 2), d (m, npt): the last of each row not a
    segment; ok: its vertices finite and segments > 1e-9): the same fields (cos_turn None).
    arc: _flat_arcs' (arc lengths (m, npt), rising, tame) of these rows, or None (made here).
    The caller holds np.errstate(all="ignore").  The lazy block's segments for build_geoms'
    want (with_seg) are _Rows of them: the segments and arc lengths made only for the rows
    wanted (_kappa_wanted), most blocks' none (their rows all chains)."""
    m, npt = d.shape
    d = d[:, :-1].copy()
    seg, u = seg[:, :-1], u[:, :-1]
    if arc is None:
        s_v = _arcs_of(d)
        good = ok & (_lag_rows(s_v, 1) > 0.0).all(axis=1)
        lazy = not (good & ~(s_v[:, -1] <= KAPPA_TAME_D)).any()
    else:
        s_v = None
        good = ok & arc[1]
        lazy = not (good & ~arc[2]).any()
    if not kappa and lazy:
        if with_seg:            # (the want's κ reads the segments and s_v of its rows)
            return d, u, None, None, None, None, good, _Rows(seg, s_v, None if arc is None else arc[0])
        return d, u, None, s_v, None, None, good, None
    s_v = _arcs_of(d, arc) if s_v is None else s_v
    kappa_v, kappa_eff = _kappa_block(np.ascontiguousarray(seg), d, s_v)
    good &= np.isfinite(kappa_v).all(axis=1)
    return d, u, None, s_v, kappa_v, kappa_eff.tolist(), good


class _Rows:
    """A lazy block's segments (m, n, 2: a view of _flat_chunk's rows) and arc lengths at
    the vertices (s_v (m, n + 1), or None: made from arc, _flat_arcs' running sums (m, n + 1)
    of the rows, by _arcs_of) for _kappa_wanted: those of some rows (take) as
    _flat_parts made them for every row (the same doubles, C-contiguous)."""
    __slots__ = ("seg", "s_v", "arc")

    def __init__(self, seg, s_v, arc):
        self.seg, self.s_v, self.arc = seg, s_v, arc

    def take(self, rows, d):
        """(segments, s_v) of rows (an int array, or None: every row; d: those rows' lengths)."""
        if rows is None:
            seg, s_v, arc = np.ascontiguousarray(self.seg), self.s_v, self.arc
        else:
            seg, s_v, arc = self.seg[rows], self.s_v, self.arc
            s_v, arc = (None if s_v is None else s_v[rows]), (None if arc is None else arc[rows])
        return seg, (s_v if s_v is not None else _arcs_of(d, None if arc is None else (arc,)))


def _arcs_of(d, arc=None):
    """The arc lengths at the vertices s_v (m, n + 1) of rows of segment lengths d (m, n):
    0 then np.cumsum of each row, or the row sums arc[0] of _flat_arcs (the same sums)."""
    s_v = np.empty((d.shape[0], d.shape[1] + 1))
    s_v[:, 0] = 0.0
    if arc is None:
        np.cumsum(d, axis=1, out=s_v[:, 1:])
    else:
        s_v[:, 1:] = arc[0][:, :-1]
    return s_v


_PIECE_CUMSUM = getattr(_chain_law.CORE_MOD, "piece_cumsum", None)


def _flat_arcs(d, starts, gap):
    """(the running sums of each stroke's segment lengths d (_flat_chunk's rows, a stroke's
    from starts[k] to gap[k] - 1): np.cumsum's of its row, in order, by the chain core's
    piece_cumsum; whether each stroke's arc lengths rise from 0 at every vertex (_parts_base's
    test); whether its length is <= KAPPA_TAME_D (_parts_lazy's)), or None without the
    core (then made a block)."""
    if _PIECE_CUMSUM is None:
        return None
    off = np.empty(2 * starts.size + 1, np.int64)       # a piece a stroke, and one its gap row
    off[0:-1:2], off[1:-1:2], off[-1] = starts, gap, d.size
    s = np.empty(d.size)
    _PIECE_CUMSUM(np.ascontiguousarray(d), off, s)
    rise = np.empty(d.size, bool)
    np.greater(s[1:], s[:-1], out=rise[1:])
    rise[starts] = s[starts] > 0.0
    rise[gap] = True
    return s, np.logical_and.reduceat(rise, starts), s[gap - 1] <= KAPPA_TAME_D


_ROW_SUMS = getattr(_chain_law.CORE_MOD, "row_sums", None)


def _flat_ux2(d, u, starts, gap):
    """_blk_ux2 of each stroke of _flat_chunk's rows (d, u end to end, a stroke's segments
    from starts[k] to gap[k] - 1): its d / d.sum() times ux ** 2, summed, as _blk_ux2 makes
    them on a block's rows (the same elementwise operations; each row's sums numpy's
    pairwise sum of its run, the chain core's row_sums), for all the chunk's blocks at once
    (_blk_ux2 made the block's u again and ~10 numpy calls a block, ~620 blocks on the
    windowed gyroid plate); or None without the core (then _blk_ux2 makes them when read)."""
    if _ROW_SUMS is None:
        return None
    off = np.empty(2 * starts.size + 1, np.int64)       # a run a stroke, and one its gap row
    off[0:-1:2], off[1:-1:2], off[-1] = starts, gap, d.size
    tot = np.empty(2 * starts.size)
    _ROW_SUMS(d, off, tot)
    w = d / np.repeat(tot, np.diff(off))
    _ROW_SUMS(w * u[:, 0] ** 2, off, tot)
    return tot[0::2]


def _flat_jerk_caps(u, profile, j1, fields):
    """The caps (and at the whole jerk: j1) between each two rows of the directions u end
    to end (P, 2), the last row's NaN: classic jerk's law on one row (_curvecore.c
    jerk_caps: each vertex's own operations), where the strokes share one limits object
    and the core is built; else (None, None) (_block_geoms makes them a block)."""
    if fields is None or len(fields[0]) != 1 or profile.junction != "jerk" or _JERK_CAPS is None:
        return None, None
    lim = fields[0][0]
    jx, jy = (np.array([getattr(lim, f)], float) for f in ("jerk_x", "jerk_y"))
    out = []
    for jerk_r in (1.0 - JERK_F_STEP_R, 1.0)[:2 if j1 else 1]:
        caps = np.empty(u.shape[0])
        _JERK_CAPS(u.reshape(-1), jx, jy, jerk_r, 1, u.shape[0], caps[:-1])
        out.append(caps)
    return out[0], out[1] if j1 else None


_LAG_ROWS = getattr(_CURVE_CORE, "lag_rows", None) if _CURVE_CORE is not None else None
_DIV_PAIRS = getattr(_CURVE_CORE, "div_pairs", None) if _CURVE_CORE is not None else None


def _c_rows(x):
    """Whether x is a C-contiguous 2-D float64 array (the compiled row helpers take it)."""
    return type(x) is np.ndarray and x.ndim == 2 and x.dtype == np.float64 and x.flags.c_contiguous


def _lag_rows(x, lag, add=False):
    """x[:, lag:] - x[:, :-lag] (np.diff's subtract at lag 1), or x[:, :-lag] + x[:, lag:]
    with add, of rows x (B, N >= lag): compiled where the core is built (_curvecore.c
    lag_rows: the same operation an element), as numpy copies both strided operands
    through its buffers."""
    if _LAG_ROWS is not None and _c_rows(x) and x.shape[1] >= lag:
        out = np.empty((x.shape[0], x.shape[1] - lag))
        _LAG_ROWS(x, x.shape[0], x.shape[1], lag, int(add), out)
        return out
    return x[:, :-lag] + x[:, lag:] if add else x[:, lag:] - x[:, :-lag]


def _div_pairs(seg, d):
    """seg / d[..., None] of (x, y) pairs seg (..., 2) and lengths d (...): compiled where the
    core is built (_curvecore.c div_pairs: the same divisions), not numpy's buffered copy
    of the broadcast d."""
    if (_DIV_PAIRS is not None and type(seg) is np.ndarray and type(d) is np.ndarray and seg.dtype == np.float64
            and d.dtype == np.float64 and seg.shape == d.shape + (2,) and seg.flags.c_contiguous
            and d.flags.c_contiguous):
        out = np.empty(seg.shape)
        _DIV_PAIRS(seg, d, d.size, out)
        return out
    return seg / d[..., None]


def _parts_block(pts):
    """_batch_parts on one block of strokes with the same vertex count: pts (m, n + 1, 2)."""
    seg, d, u, cos_turn, s_v, good = _parts_base(pts)
    kappa_v, kappa_eff = _kappa_block(seg, d, s_v)
    good &= np.isfinite(kappa_v).all(axis=1)
    return d, u, cos_turn, s_v, kappa_v, kappa_eff.tolist(), good


KAPPA_TAME_D = 1e100        # mm: a path no longer than this has a finite κ (_parts_lazy)


def _parts_lazy(pts):
    """_parts_block without κ where it is sure to be finite: (d, u, cos_turn, s_v, None,
    None, good, the segments), the same good; else _parts_block's.  A row good but for κ, whose length
    S <= KAPPA_TAME_D, has a finite κ at every vertex: its kernel's arguments are finite
    (|s_v[j] - s_i| / smooth_d <= S / SMOOTH_MIN_D, squared ~1e201), so each kernel entry
    is in [0, 1] with a 1 in every row (the row's least argument); the turns are finite
    (in [-pi, pi]), so |kern @ turn| <= n pi; the spacings ell are >= 1e-9 (d > 1e-9), so
    kern @ ell is in [1e-9, n S]: a finite ratio.  κ is then made when read (_Blk.kappa_rows:
    the same rows' _kappa_block, the same bits), for the rows that are read: a chain's
    never is (the gyroid plate's chains hold 99.5 % of its kernels' entries)."""
    seg, d, u, cos_turn, s_v, good = _parts_base(pts)
    if (good & ~(s_v[:, -1] <= KAPPA_TAME_D)).any():
        kappa_v, kappa_eff = _kappa_block(seg, d, s_v)
        good &= np.isfinite(kappa_v).all(axis=1)
        return d, u, cos_turn, s_v, kappa_v, kappa_eff.tolist(), good
    return d, u, cos_turn, s_v, None, None, good, seg       # (seg: build_geoms' want)


def _parts_base(pts):
    """_parts_block's (seg, d, u, cos_turn, s_v, good) of pts (m, n + 1, 2), good not yet
    asking κ to be finite."""
    m, npt = pts.shape[:2]
    seg = _lag_rows(pts.reshape(m, 2 * npt), 2).reshape(m, npt - 1, 2)   # _segments: pts[:, 1:] - pts[:, :-1]
    d = np.hypot(seg[..., 0], seg[..., 1])
    u = _div_pairs(seg, d)
    cos_turn = np.einsum("bij,bij->bi", u[:, :-1], u[:, 1:])
    s_v = np.empty(d.shape[:1] + (d.shape[1] + 1,))
    s_v[:, 0] = 0.0
    np.cumsum(d, axis=1, out=s_v[:, 1:])
    good = np.isfinite(pts).all(axis=(1, 2)) & (d > 1e-9).all(axis=1) & (_lag_rows(s_v, 1) > 0.0).all(axis=1)
    return seg, d, u, cos_turn, s_v, good


def _kappa_block(seg, d, s_v):
    """(kappa_v (m, n + 1), kappa_eff (m,)) of _parts_block's rows: segments seg (m, n, 2),
    lengths d (m, n), arc lengths s_v (m, n + 1).  Row by row the same bits (each row's
    own median, kernel and matrix products)."""
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
    turn = np.angle(np.exp(1j * _lag_rows(heading, 1)))
    s_i = s_v[:, 1:-1]
    ell = 0.5 * _lag_rows(d, 1, add=True)
    # kern = exp(-0.5 (z2 - min z2)), z2 = ((s_v - s_i) / smooth_d)^2: the same operations
    # in place in one array (x ** 2 is np.square; -0.5 x = x (-0.5)), not one new array of
    # m (n+1)(n-1) doubles per step
    kern = _kern_packed(s_v, smooth_d, n) if _CURVE_CORE is not None else None
    if kern is None:
        if _CURVE_CORE is not None:     # the same five steps in one compiled pass (_curvecore.c)
            kern = np.empty((s_v.shape[0], n + 1, n - 1))
            _CURVE_CORE.kern_args(s_v, smooth_d, s_v.shape[0], n + 1, kern)
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
    # np.interp(s_v, s_d, kappa_v) at its own nodes is kappa_v itself
    S = s_v[:, -1]
    mid = 0.5 * (kappa_v[:, :-1] ** 2 + kappa_v[:, 1:] ** 2)
    k2 = np.sum(mid * d, axis=1) / S
    return kappa_v, _pmax(np.sqrt(k2), 1.0 / (MAX_R_OVER_S * S))


EXP_ZERO_BELOW = -746.0     # exp(x) < 2^-1076 here: +0.0 in round to nearest (the least subnormal is 2^-1074)
_EXP_ZERO_OK: list = []    # [bool]: np.exp gave +0.0 on every probe argument below EXP_ZERO_BELOW


def _exp_zero_ok():
    """Whether np.exp (this numpy, this machine: libm or a SIMD loop) gives +0.0, bit for
    bit, on a probe of arguments below EXP_ZERO_BELOW (its edge, -inf, huge, random ones,
    in arrays of several lengths and offsets, as its vector loops take them); checked once."""
    if not _EXP_ZERO_OK:
        rng = ProbeRng(21)
        edge = np.nextafter(EXP_ZERO_BELOW, -np.inf)
        x = np.concatenate([[edge, -746.5, -750.0, -800.0, -1075.0, -1e4, -1e300, -np.finfo(float).max, -np.inf],
                            rng.uniform(-760.0, EXP_ZERO_BELOW, 4000), -np.exp(rng.uniform(6.62, 700.0, 4000)),
                            edge - rng.uniform(0.0, 1e-9, 1000)])
        ok = x.max() < EXP_ZERO_BELOW
        for a in range(0, 9):
            y = np.exp(x[a:])
            ok &= bool(np.array_equal(y.view(np.int64), np.zeros(y.size, np.int64)))
        _EXP_ZERO_OK.append(bool(ok))
    return _EXP_ZERO_OK[0]


_EXP_PLACE_OK: list = []   # [bool]: np.exp gave each argument the same bits wherever it sat in the array


def _exp_place_ok():
    """Whether np.exp (this numpy, this machine) gives an argument the same bits wherever
    it sits in an array (its vector loops' lanes, head and tail alike), on a probe of the
    curvature kernel's arguments (EXP_ZERO_BELOW .. 0, the subnormal results included) in
    arrays of several lengths and offsets; checked once.  _kern_packed's symmetric packing
    (kern_pack's mirror) puts the arguments at other places than the split kernel does."""
    if not _EXP_PLACE_OK:
        _EXP_PLACE_OK.append(_same_at_every_place(np.exp))
    return _EXP_PLACE_OK[0]


def _same_at_every_place(fn):
    """_exp_place_ok's probe of an elementwise function fn (np.exp there)."""
    rng = ProbeRng(36)
    x = np.concatenate([[0.0, -0.0, -1e-300, EXP_ZERO_BELOW, -708.5, -745.0, -0.5],
                        rng.uniform(EXP_ZERO_BELOW, 0.0, 1500), -rng.exponential(2.0, 1500)])
    ref = fn(x)
    # the first ones alone too (a loop of one element: its tail code only; the results are
    # +0.0 or more, so equal values are equal bits)
    ok = all(float(fn(v)) == r for v, r in zip(x[:16].tolist(), ref[:16].tolist()))
    for a in range(1, 9):           # every argument through every lane of an 8-wide loop, and its tails
        for size in (1, 3, 5, 8, 13, 64, 511, x.size - a):
            y = fn(x[a:a + size])
            ok &= bool(np.array_equal(y.view(np.int64), ref[a:a + size].view(np.int64)))
    return bool(ok)


_KERN_PACK = getattr(_CURVE_CORE, "kern_pack", None)


def _kern_packed(s_v, smooth_d, n):
    """_parts_block's np.exp(kern) made as kern_args then _exp_inplace make it, in fewer
    passes over the kernel (_curvecore.c kern_pack: the arguments np.exp does not take to
    +0.0, packed as exp_split packs them; kern_unpack: exp_merge's kernel): the same
    arguments and the same np.exp of each (an elementwise function: its value does not
    depend on the argument's place in the array), the same bits.  Of a stroke whose
    vertices are in order, the interior block of the kernel is symmetric bit for bit
    (_curvecore.c sym_row), so np.exp takes its arguments from the diagonal on only and
    kern_unpack copies the others, where np.exp gives an argument the same bits at any
    place (_exp_place_ok): on the gyroid plate 47 % fewer arguments.  None where
    _exp_inplace would not split, or a row's kept arguments are not one run."""
    if _KERN_PACK is None or not _exp_zero_ok():
        return None
    m = s_v.shape[0]
    buf = np.empty(m * (n + 1) * (n - 1))
    rng = np.empty(m * (n + 1) * 2, np.int64)
    sym = np.empty(m, np.int64)         # per stroke: its interior rows packed from the diagonal on
    cnt = _KERN_PACK(s_v, smooth_d, m, n + 1, EXP_ZERO_BELOW, _exp_place_ok(), buf, rng, sym)
    if cnt < 0:
        return None
    part = buf[:cnt]
    np.exp(part, out=part)
    kern = np.empty((m, n + 1, n - 1))
    _CURVE_CORE.kern_unpack(kern, m, n + 1, rng, buf, cnt, sym)
    return kern


def _exp_inplace(kern):
    """np.exp(kern, out=kern); with the curve core, and where np.exp gives +0.0 on the probe
    (_exp_zero_ok), only the arguments not below EXP_ZERO_BELOW go through np.exp (packed
    by _curvecore.c exp_split, put back by exp_merge), the others are set to +0.0: the
    same bits at ~3/4 of the cost on a gyroid plate (a quarter of its curvature kernel's
    arguments underflow, which libm's exp takes ~3x longer over)."""
    core = _CURVE_CORE
    if core is None or not kern.flags.c_contiguous or not _exp_zero_ok():
        np.exp(kern, out=kern)
        return
    total = kern.size
    buf = np.empty(total)
    cnt = core.exp_split(kern, total, EXP_ZERO_BELOW, buf)
    part = buf[:cnt]
    np.exp(part, out=part)
    core.exp_merge(kern, total, EXP_ZERO_BELOW, buf, cnt)


def adjust_plan_inputs(pin, strokes, rows, profile, cap_peak=True):
    """Curve rows of a PlanInput: length-weighted direction masses, the per-axis
    acceleration cap of a turning path, the vertex speed caps (cap_peak: the law's peak
    stays under the lowest; a chain's law meets each at its own vertex instead).  The
    masses and caps of all rows in arrays: the same double operations as the scalar
    expressions (Python's min(a, b) is b where b < a), put with one index each."""
    mx, my = profile.moving_mass_x_kg, profile.moving_mass_y_kg
    # the rows an index array once (a list of ints was converted by each of the four puts)
    rows = np.array([int(i) for i in rows] if not isinstance(rows, np.ndarray) else rows, dtype=np.intp)
    sts = objfields.items(strokes, rows)
    gs = [geom(st, profile) for st in sts]
    by_blk = _by_block(gs)
    ux2 = np.array(_ux2_rows(gs) if by_blk is None else _block_rows(by_blk, _blk_ux2), float)
    uy2 = 1.0 - ux2
    den = mx * ux2 + my * uy2
    if not len(rows) or (den == 0.0).any():     # a zero mass: the scalar loop (it raises)
        for i, x in zip(rows.tolist(), ux2.tolist()):
            y = 1.0 - x
            pin.mass_r[i] = (mx * mx * x + my * my * y) / (mx * x + my * y)
    else:
        pin.mass_r[rows] = (mx * mx * ux2 + my * my * uy2) / den
    pin.a_cap[rows] = _a_caps(sts)
    if cap_peak and rows.size:
        vc = pin.v_cap[rows]
        cap = np.array([g.cap for g in gs] if by_blk is None else _block_rows(by_blk, _blk_cap), float)
        pin.v_cap[rows] = np.where(cap < vc, cap, vc)
        for g in gs:
            g.caps_jerk1 = None           # read by chains only (chains.vertex_caps): not a chain


def _ux2_rows(gs):
    """float(np.sum(w * g.u[:, 0] ** 2)), w = g.d / g.d.sum(), of every geometry in gs,
    for all of one segment count at once (row sums of a C-contiguous block add in the
    same order as the 1-D sums: the same bits; the rows stacked by stack_du)."""
    out = [0.0] * len(gs)
    by_n = {}
    try:
        sizes = [g._b.d.shape[-1] for g in gs]
    except AttributeError:
        sizes = [g.d.size for g in gs]
    for k, n in enumerate(sizes):
        by_n.setdefault(n, []).append(k)
    for ks in by_n.values():
        d, u = stack_du([gs[k] for k in ks])
        ux = np.ascontiguousarray(u[:, :, 0])
        w = d / d.sum(axis=1, keepdims=True)
        for k, x in zip(ks, np.sum(w * ux ** 2, axis=1).tolist()):
            out[k] = x
    return out


def _a_caps(sts):
    """[min(st.accel, st.lim.ax_max, st.lim.ay_max) for st in sts]: Python's min of the three
    (the later one where it is < the least so far) in arrays, the limits read once per
    limits object the strokes share; the list itself where a number is not a float."""
    m = len(sts)
    got = stroke_fields(sts, ("accel",)) if type(sts) is list else None
    if got is not None and not got[1].any():       # (kind 0 everywhere: every accel a float)
        a, acc = got[0][:, 0], []
    else:
        a, acc = None, list(map(_ACCEL, sts))
    lims, which = _lims_which(sts)
    ax = [lim.ax_max for lim in lims]
    ay = [lim.ay_max for lim in lims]
    if not all(type(x) is float for x in acc + ax + ay):
        return [min(st.accel, st.lim.ax_max, st.lim.ay_max) for st in sts]
    a = np.fromiter(acc, float, m) if a is None else a
    axr, ayr = np.array(ax, float)[which], np.array(ay, float)[which]
    a = np.where(axr < a, axr, a)
    return np.where(ayr < a, ayr, a)


_G_B = attrgetter("_b")
_G_K = attrgetter("_k")


def _by_block(gs):
    """(per distinct block, in the order first met: (block, positions in gs, rows in it))
    of geometries that are rows of build_geoms' blocks (a _Blk that keeps no u, cap an
    array), or None.  The positions and rows are intp arrays where the compiled reads
    take the geometries (_by_block_flat), else lists."""
    got = _by_block_flat(gs)
    if got is not None:
        return None if got is False else got
    try:
        bs = list(map(_G_B, gs))
        ks = list(map(_G_K, gs))
    except AttributeError:
        return None
    out = {}
    for q, (b, k) in enumerate(zip(bs, ks)):
        e = out.get(id(b))
        if e is None:
            if type(b) is not _Blk or b._u is not None or not isinstance(b.cap, np.ndarray) or b.d.ndim != 2:
                return None
            e = out[id(b)] = (b, [], [])
        e[1].append(q)
        e[2].append(k)
    return list(out.values())


def _by_block_flat(gs):
    """_by_block's groups from objfields' compiled reads of the geometries' _b and _k (a
    Python loop a row was ~1.6 k instructions, ~35 k rows twice on the gyroid plate): a
    stable sort of the rows by block, each block's positions in gs in order.  False where
    a block is not build_geoms' (_by_block's None); None where the compiled reads do not
    take them (a geometry without _b or _k, a _k not an int, no core): _by_block's loop."""
    try:
        got = objfields.ids(gs, "_b")
        ks = objfields.codes(gs, "_k", None) if got is not None else None
    except AttributeError:
        return None
    if ks is None:
        return None
    bs, which = got
    for b in bs:
        if type(b) is not _Blk or b._u is not None or not isinstance(b.cap, np.ndarray) or b.d.ndim != 2:
            return False
    if len(bs) == 1:
        return [(bs[0], np.arange(len(gs)), ks)]
    order = np.argsort(which, kind="stable")
    cut = np.flatnonzero(which[order][1:] != which[order][:-1]) + 1
    # (ids numbers the blocks in the order first met: the groups come in that order)
    return [(b, q, ks[q]) for b, q in zip(bs, np.split(order, cut))]


def _block_rows(by_blk, per_block):
    """The numbers per_block(block) (an array, one a row of the block) of every geometry,
    in the geometries' order."""
    n = sum(len(qs) for _, qs, _ in by_blk)
    out = np.empty(n)
    for b, qs, ks in by_blk:
        out[qs] = per_block(b)[ks]
    return out


def _blk_cap(b):
    return b.cap


def _blk_ux2(b):
    """_ux2_rows of every row of the block b (kept on it): the same row operations on the
    block's d and its u made from the rows' vertices (stack_du's numbers, row by row)."""
    got = b._ux2
    if got is None:
        d = np.asarray(b.d, float)
        u = b.u_rows(list(range(d.shape[0])))
        ux = np.ascontiguousarray(u[:, :, 0])
        w = d / d.sum(axis=1, keepdims=True)
        got = b._ux2 = np.sum(w * ux ** 2, axis=1)
    return got


# ------------------------------------------------------------------ law
def _solve_args(rows_geo, S, T, beta, v0, v1):
    """solve_circles' arguments for the curves rows_geo at κ_eff, and R = 1 / κ_eff."""
    R = 1.0 / np.array([g.kappa_eff for g in rows_geo])
    return (S / R, T, beta, v0 / R, v1 / R, R), R


def _solve(strokes, rows_geo, S, T, beta, v0, v1):
    args, R = _solve_args(rows_geo, S, T, beta, v0, v1)
    return solve_circles(*args), R


def _rows_of(memo, sel):
    """The memo of _kappa_rows for the rows sel of its rows: a _Knots' rows, a dict as it is."""
    return memo.sub(sel) if isinstance(memo, _Knots) else memo


# laws a chunk of true_figures: its ~20 (laws, ~300 points) arrays are ~0.3 MB each (at
# 512 laws a chunk they were 1.3 MB, ~18 MB at once: the gyroid plate's curve candidates
# peaked there after their solve)
FIGURE_ROWS = 128


def true_figures(law, R, geos, idx=None, memo=None):
    """The circle law at κ_eff, measured on each curve's true κ(s): (∫ṡ², ∫|a|², peak
    speed, peak |a|, min speed) per law.  The quadrature grid is the whole batch's; the
    evaluation goes by chunks of FIGURE_ROWS laws (law.grid_chunks), so memory stays
    bounded.  idx: only these laws (an integer array), the others' figures NaN; each
    law's figures are its own (its own row of every array, the batch's grid), so the
    same bits whatever the chunks: the laws go by chunks of one series length mostly
    (_by_series_length's order, where it is not theirs), whose products pad fewer rows."""
    if idx is None:
        idx = _by_series_length(law.coef)
    if idx is None:
        out = np.empty((5, len(geos)))
        for sl, tau, wq in law.grid_chunks(rows=FIGURE_ROWS):
            out[:, sl] = _true_figures_rows(law.rows(sl), R[sl], geos[sl], tau, wq, _rows_of(memo, sl))
        return tuple(out)
    out = np.full((5, len(geos)), np.nan)
    for r, tau, wq in law.grid_chunks(idx, rows=FIGURE_ROWS):
        out[:, r] = _true_figures_rows(law.take(r), R[r], [geos[i] for i in r.tolist()], tau, wq, _rows_of(memo, r))
    return tuple(out)


_UNIFORM_TAU = np.linspace(0.0, 1.0, 129)
_PROBE_TAU = _UNIFORM_TAU[::8]      # 17 of its points (k/16, the same numbers)
PROBE_MARGIN_R = 1e-6               # a probe over its limit by more than this is over it on any grid


def surely_over(law, R, geos, v_lim, a_lim, memo=None, why=None):
    """Laws whose speed or |a| (_true_figures_rows' arithmetic) at 17 points of the
    uniform grid _true_figures_rows also evaluates already exceeds v_lim or a_lim by
    more than PROBE_MARGIN_R: their peaks (maxima over a grid that holds these points)
    exceed them too, so the full figures would reject them.  The probe's numbers are the
    same sums in another BLAS blocking, ~1e-15 apart (the margin is 10^9 times that):
    the same decisions, at ~1/9 of the cost.  88 % of the gyroid plate's curve candidates
    break the acceleration cap; the full figures are made for the others only.
    why (a list, optional): the laws over on |a| but not on speed are appended to it (a
    bool array; candidates_curve does not retry them at beta/4).

    With memo a _Knots (the compiled core's knots), |a| is first bounded by its tangential
    part: |a|² = at² + (κv²)² is at least at² at every point (a sum of a square that is not
    NaN rounds to no less than at²), so a law whose max at² is over the cap is over on |a|,
    and one over on speed needs no |a| (over either way, not a_only): φ and κ(s) are made
    for the others only (~20 % of the plates' laws; the same decisions, bit for bit, where
    κv² cannot be NaN: _kv2_not_nan)."""
    over = np.zeros(len(geos), bool)
    a_only = np.zeros(len(geos), bool)
    lean = isinstance(memo, _Knots) and _PROBE_ROWS is not None
    for sl in law.row_chunks():
        sub = law.rows(sl)
        tau = np.broadcast_to(_PROBE_TAU[None, :], (len(sub), _PROBE_TAU.size))
        phi, w, w1, _ = sub.eval_tau(tau, w2=False, phi=not lean)
        T, Rr = sub.T_t, R[sl]
        v = _row_scale(w, Rr, T, 1)
        at = _row_scale(w1, Rr, T, 2)
        del w, w1               # (let go before φ's rows: held, the rectilinear plate's peak RSS was ~0.4 MB up)
        v_cap = v_lim[sl] * (1.0 + PROBE_MARGIN_R)
        a_cap = a_lim[sl] * (1.0 + PROBE_MARGIN_R)
        if lean:
            over_v, over_a, v_ok = np.empty((3, len(sub)), bool)
            _PROBE_ROWS(v, at, len(sub), v.shape[1], v_cap, a_cap, over_v, over_a, v_ok)
            kn = memo.sub(sl)
            over_a &= v_ok & _kv2_not_nan(sub, Rr, kn)
            rest = np.flatnonzero(~(over_a | over_v))
            if rest.size:
                phi = sub.eval_tau(tau[:rest.size], rest, w2=False, w1=False, w=False)[0]
                gsl = geos[sl]
                vr, ar = v[rest], at[rest]
                kv2 = _kappa_rows(objfields.items(gsl, rest), _row_scale(phi, Rr[rest]), kn.sub(rest)) * (vr * vr)
                over_a[rest] = np.sqrt(np.max(ar * ar + kv2 * kv2, axis=1)) > a_cap[rest]
        else:
            kv2 = _kappa_rows(geos[sl], _row_scale(phi, Rr), _rows_of(memo, sl)) * (v * v)
            a2 = at * at + kv2 * kv2
            over_v = np.max(v, axis=1) > v_cap
            over_a = np.sqrt(np.max(a2, axis=1)) > a_cap
        over[sl] = over_v | over_a
        a_only[sl] = over_a & ~over_v
    if why is not None:
        why.append(a_only)
    return over


_PROBE_ROWS = getattr(_CURVE_CORE, "probe_rows", None) if _CURVE_CORE is not None else None
_SCREEN_ROWS = getattr(_CURVE_CORE, "screen_rows", None) if _CURVE_CORE is not None else None


def screen_a_only(law, R, geos, v_lim, a_lim, memo=None):
    """The laws surely_over(law, R, geos, v_lim, a_lim, memo, why) puts in why (over on |a|,
    not on speed) for candidates_curve's screen of rough laws, whose verdicts are a filter
    only: a law it names is over on |a| alone on its full law too (SCREEN_BAND_R, ~1e5
    times the rough laws' distance from the full ones), the others are solved in full and
    decided there.  So the speeds and tangential |a| at the probe's points need not be
    BLAS's bits, only as accurate: where the core is built, a Chebyshev batch (no layer
    regime) with knots (memo a _Knots) has them from one compiled pass over its rows
    (_curvecore.c screen_rows: the series and its derivative summed in the order of the
    coefficients, ~1e-16 from eval_tau's products, and probe_rows' decisions), not eval_tau's
    gathers, BLAS calls and scatters; κ(s) and φ are made for the rows the tangential part
    leaves undecided, as surely_over does.  Elsewhere surely_over.  The speeds and |a| are
    made again for the rows left to κ(s) only (~12 %: a 4096-law screen's (laws, points)
    arrays of every row put the rectilinear plate's windowed peak RSS up ~0.5 MB)."""
    if _SCREEN_ROWS is None or not isinstance(memo, _Knots) or len(law) == 0 or law.regime.any():
        why = []
        surely_over(law, R, geos, v_lim, a_lim, memo, why)
        return why[0]
    return _screen_rows(law, R, geos, v_lim, a_lim, memo)


def _screen_rows(law, R, geos, v_lim, a_lim, memo):
    """screen_a_only of Chebyshev laws, memo their knots (a _Knots)."""
    m = _PROBE_TAU.size
    nb, K = law.coef.shape
    vand, dvand = _screen_tables(K)
    v_cap = v_lim * (1.0 + PROBE_MARGIN_R)
    a_cap = a_lim * (1.0 + PROBE_MARGIN_R)
    rest = np.empty(nb, np.int64)
    over_v, over_a = np.empty((2, nb), bool)
    args = (np.ascontiguousarray(law.coef, float), nb, K, vand, dvand, vand.shape[1], m, np.ascontiguousarray(R, float),
            np.ascontiguousarray(law.T_t, float), np.ascontiguousarray(v_cap, float),
            np.ascontiguousarray(a_cap, float), np.ascontiguousarray(_kv2_not_nan(law, R, memo), bool))
    n = _SCREEN_ROWS(*args, _NO_ROWS, _NO_ROWS, rest, over_v, over_a, 0, 0)
    rest = rest[:n]
    if rest.size:           # (surely_over's κ(s) part, these rows only: their v and at made again)
        vr, ar = np.empty((n, m)), np.empty((n, m))
        _SCREEN_ROWS(*args, vr, ar, rest, over_v, over_a, 1, n)
        tau = np.broadcast_to(_PROBE_TAU[None, :], (rest.size, m))
        phi = law.eval_tau(tau, rest, w2=False, w1=False, w=False)[0]
        kv2 = _kappa_rows(objfields.items(geos, rest), _row_scale(phi, R[rest]), memo.sub(rest)) * (vr * vr)
        over_a[rest] = np.sqrt(np.max(ar * ar + kv2 * kv2, axis=1)) > a_cap[rest]
    return over_a & ~over_v


_SCREEN_TABLES: dict = {}  # K -> screen_rows' tables at the probe's points
_NO_ROWS = np.empty((0, _PROBE_TAU.size))     # (screen_rows' v and at where it writes none)


def _screen_tables(K):
    """(T_k(x_j), d/dτ T_k(2τ_j - 1) = 2 T_k'(x_j)), k < K, at the probe's points x = 2 τ - 1
    (CircleBatch._eval_cheb's map), each (K, 20): its 17 columns, then zeros to a multiple of
    4 (screen_rows' AVX steps).  Row k of the second: chebder of the k-th unit series (scale 2)
    at the points, so that Σ c_k row_k is w'(τ) (~1e-16 from eval_tau's chebder, then sum)."""
    got = _SCREEN_TABLES.get(K)
    if got is None:
        from numpy.polynomial import chebyshev as C
        x = 2.0 * _PROBE_TAU - 1.0
        cols = -(-x.size // 4) * 4
        vand, dvand = np.zeros((K, cols)), np.zeros((K, cols))
        vand[:, :x.size] = C.chebvander(x, K - 1).T
        if K > 1:
            dvand[:, :x.size] = C.chebval(x, C.chebder(np.eye(K), scl=2.0))
        for t in (vand, dvand):
            t.flags.writeable = False
        got = _SCREEN_TABLES[K] = (vand, dvand)
    return got


# the bound of a Chebyshev law's coefficients under which its series (and those of its
# integral, whose value at -1 takes a recurrence growing ~2.4^K, K <= 513 coefficients) are
# finite: |φ| < 1e60 * 1e200
_TAME_COEF = 1e60


def _kv2_not_nan(sub, R, kn):
    """Per row of the chunk sub (a CircleBatch): whether κ(s) v² is surely not NaN at the
    probe's points where v is finite with |v| <= 1e150 (v² finite: surely_over checks it,
    _curvecore.c probe_rows): a Chebyshev law (not the layer regime) of coefficients all
    within _TAME_COEF (so φ finite; NaN coefficients fail), R finite (so s = Rφ is not NaN),
    its knots tame (_Knots.tame: κ(s) finite): a finite κ times a finite v² is a number or
    ±inf, not NaN."""
    with np.errstate(invalid="ignore"):
        return ~sub.regime & (np.max(np.abs(sub.coef), axis=1) <= _TAME_COEF) & np.isfinite(R) & kn.tame


_ROW_SCALE = getattr(_CURVE_CORE, "row_scale", None) if _CURVE_CORE is not None else None


def _row_scale(x, R, T=None, p=0):
    """R[:, None] * x (p = 0), R[:, None] * x / T[:, None] (p = 1) or R[:, None] * x /
    T[:, None] ** 2 (p = 2) of rows x (B, M), or np.maximum(p = 1's, 0.0) (p = 3): in one
    compiled pass where the core is built (_curvecore.c row_scale: the same operations), as
    numpy 2 copies a (B, 1) operand broadcast along the rows into its buffers, row by row,
    for every operation."""
    if (_ROW_SCALE is not None and type(x) is np.ndarray and x.ndim == 2 and x.dtype == np.float64
            and x.flags.c_contiguous and R.dtype == np.float64 and R.shape == x.shape[:1]
            and (p == 0 or (T.dtype == np.float64 and T.shape == R.shape))):
        out = np.empty(x.shape)
        _ROW_SCALE(x, np.ascontiguousarray(R), None if p == 0 else np.ascontiguousarray(T), p,
                   x.shape[0], x.shape[1], out)
        return out
    r = R[:, None] * x
    if p == 3:
        return np.maximum(r / T[:, None], 0.0)
    return r if p == 0 else r / (T[:, None] if p == 1 else T[:, None] ** 2)


_WSUM_ROWS = getattr(_CURVE_CORE, "wsum_rows", None) if _CURVE_CORE is not None else None


def _wsum_rows(wq, x, m):
    """np.sum(wq * x[:, :m], axis=1) (wq (B, m), x (B, >= m)): in one compiled pass where the
    core is built (_curvecore.c wsum_rows: numpy's products, then its pairwise sum of each
    row), not a copy of x's strided rows through numpy's buffers and a (B, m) product."""
    if (_WSUM_ROWS is not None and type(wq) is np.ndarray and type(x) is np.ndarray and wq.ndim == 2
            and x.ndim == 2 and wq.dtype == np.float64 and x.dtype == np.float64 and wq.flags.c_contiguous
            and x.flags.c_contiguous and wq.shape == (x.shape[0], m) and x.shape[1] >= m):
        out = np.empty(x.shape[0])
        _WSUM_ROWS(wq, x, x.shape[0], m, x.shape[1], out)
        return out
    return np.sum(wq * x[:, :m], axis=1)


def _true_figures_rows(law, R, geos, tau, wq, memo=None):
    m = tau.shape[1]
    # the quadrature grid and a uniform one for the peaks (the quadrature grid is graded
    # towards the ends), evaluated in one piece
    tu = np.broadcast_to(_UNIFORM_TAU[None, :], (len(geos), _UNIFORM_TAU.size))
    phi, w, w1, _ = law.eval_tau(np.concatenate([tau, tu], axis=1), w2=False)
    s = _row_scale(phi, R)
    v = _row_scale(w, R, law.T_t, 1)
    at = _row_scale(w1, R, law.T_t, 2)
    kap = _kappa_rows(geos, s, memo)
    v2 = v * v
    kv2 = kap * v2
    a2 = at * at + kv2 * kv2
    iv = law.T_t * _wsum_rows(wq, v2, m)
    ia = law.T_t * _wsum_rows(wq, a2, m)
    ia = ia + np.array([g.end_terms(a, b) for g, a, b in zip(geos, R * law.w0, R * law.w1)])
    return iv, ia, np.max(v, axis=1), np.sqrt(np.max(a2, axis=1)), np.min(v, axis=1)


class _Knots:
    """_kappa_rows' knots of many rows laid out for the compiled core: the geometries'
    s_v and kappa_v concatenated (xs, ys), and per row its geometry's offset and count
    and whether the core may take it (ok: at least 2 knots, finite, strictly increasing;
    the other rows go through np.interp), and whether κ there is finite at any s but NaN
    (tame: ok, |κ| <= TAME_KAPPA at every knot, knots at least TAME_GAP apart, so no slope
    of the interpolation overflows: surely_over's use)."""
    __slots__ = ("xs", "ys", "off", "cnt", "ok", "tame")

    def __init__(self, xs, ys, off, cnt, ok, tame=None):
        """tame None: no row (surely_over then makes φ and κ(s) of every row)."""
        self.xs, self.ys, self.off, self.cnt, self.ok = xs, ys, off, cnt, ok
        self.tame = np.zeros(np.shape(ok), bool) if tame is None else tame

    @classmethod
    def of(cls, gs):
        """The knots of the geometries gs (CurveGeom), one row each."""
        got = _knots_by_block(gs)
        if got is None:
            sv = [g.s_v for g in gs]
            kv = [g.kappa_v for g in gs]
            cnt = np.array([x.size for x in sv], dtype=np.int64)
        else:
            cnt = got[0]
        off = np.zeros(cnt.size, dtype=np.int64)
        if cnt.size:
            np.cumsum(cnt[:-1], out=off[1:])
        if got is not None:
            xs, ys = got[1](off)
        else:
            xs = np.concatenate(sv) if sv else np.empty(0)
            ys = np.ascontiguousarray(np.concatenate(kv) if kv else np.empty(0), dtype=float)
        ok = cnt >= 2
        tame = ok
        if xs.size:
            bad = ~np.isfinite(xs)
            bad[1:] |= ~(xs[1:] > xs[:-1])
            bad[off] = ~np.isfinite(xs[off])      # a row's first knot: no pair before it
            ok &= ~np.logical_or.reduceat(bad, off)
            wild = ~(np.abs(ys) <= TAME_KAPPA)      # (NaN too)
            wild[1:] |= ~(xs[1:] - xs[:-1] >= TAME_GAP)
            wild[off] = ~(np.abs(ys[off]) <= TAME_KAPPA)
            tame = ok & ~np.logical_or.reduceat(wild, off)
        return cls(xs, ys, off, cnt, ok, tame)

    def sub(self, sel):
        """The rows sel (a slice or an integer array)."""
        return _Knots(self.xs, self.ys, self.off[sel], self.cnt[sel], self.ok[sel], self.tame[sel])


# _Knots.tame's bounds: |κ| at most 1e30 (1/mm) and knots 1e-250 (mm) apart at least, so an
# interpolation's slope is at most ~2e280 and its value (within its two knots' range, but
# for rounding) finite wherever s is not NaN
TAME_KAPPA = 1e30
TAME_GAP = 1e-250


def _knots_by_block(gs):
    """(knot counts, fill(off) -> (xs, ys)) of _Knots.of, the geometries' s_v and kappa_v
    made a block at a time (build_geoms' _Blk: s_v is the same cumsum along each row of the
    block's d as CurveGeom.s_v's 1-D one, kappa_v the block's rows) and put at each row's
    offset off, not an s_v a geometry (~5 k geometries a plate's curve candidates); None
    when a geometry has no block of 2-D rows."""
    try:
        bs = [g._b for g in gs]
        ks = [g._k for g in gs]
    except AttributeError:
        return None
    rows = {}                           # id(block) -> (block, [positions in gs])
    for q, b in enumerate(bs):
        rows.setdefault(id(b), (b, []))[1].append(q)
    cnt = np.empty(len(gs), dtype=np.int64)
    for b, qs in rows.values():
        if not (isinstance(b.d, np.ndarray) and b.d.ndim == 2 and _kappa_rows_ok(b)):
            return None
        cnt[qs] = b.d.shape[1] + 1

    def fill(off):
        total = int(cnt.sum())
        xs, ys = np.empty(total), np.empty(total)
        for b, qs in rows.values():
            sel = [ks[q] for q in qs]
            n1 = b.d.shape[1] + 1
            sv = np.empty((len(qs), n1))
            sv[:, 0] = 0.0
            np.cumsum(np.asarray(b.d, float)[sel], axis=1, out=sv[:, 1:])
            at = off[qs][:, None] + np.arange(n1)[None, :]
            xs[at] = sv
            ys[at] = b.kappa_rows(sel)
        return xs, ys
    return cnt, fill


def _kappa_rows_ok(b):
    """Whether the block b's κ at the vertices is (or is made as) one (m, n + 1) array."""
    kv = b._kv
    return type(b) is _Blk and (kv is None or (isinstance(kv, np.ndarray) and kv.shape == (b.d.shape[0], b.d.shape[1] + 1)))


_INTERP_ROWS = getattr(_CURVE_CORE, "interp_rows", None) if _CURVE_CORE is not None else None


def _kappa_rows(geos, s, memo=None):
    """g.kappa(s[k]) for every row k (geos[k] = g): one interpolation (np.interp's compiled
    core, the same bits) per run of rows of one geometry (a stroke's candidate durations
    are adjacent rows).  The knots are the geometry's s_v and kappa_v; memo (a dict,
    optional): id(g) -> knots, kept by the caller while geos live (candidates_curve's probe
    and figures read the same geometries again).  memo a _Knots (the rows of geos): every
    row in one compiled call (_curvecore.c interp_rows: np.interp's operations), the rows
    it does not take by np.interp; without the core, the per-run path."""
    if isinstance(memo, _Knots):
        if _INTERP_ROWS is not None and s.ndim == 2:
            kn = memo
            s = np.ascontiguousarray(s, dtype=float)
            out = np.empty_like(s)
            _INTERP_ROWS(s, np.ascontiguousarray(kn.off), np.ascontiguousarray(kn.cnt), kn.xs, kn.ys,
                         s.shape[0], s.shape[1], kn.xs.size, out)
            for r in np.flatnonzero(~kn.ok).tolist():
                g = geos[r]
                out[r] = _interp(s[r], g.s_v, g.kappa_v, None, None)
            return out
        memo = None
    out = np.empty_like(s)
    n = len(geos)
    a = 0
    while a < n:
        g = geos[a]
        b = a + 1
        while b < n and geos[b] is g:
            b += 1
        kn = None if memo is None else memo.get(id(g))
        if kn is None:
            kn = (g.s_v, g.kappa_v)
            if memo is not None:
                memo[id(g)] = kn
        out[a:b] = _interp(s[a:b].ravel(), kn[0], kn[1], None, None).reshape(b - a, -1)
        a = b
    return out


# curve candidates (circle laws) solved and probed at once by candidates_curve: the solve's
# (arcs,) and (arcs, N) arrays for 4 k arcs, ~3 MB at once; the gyroid plate's 34 k in one
# batch held ~25 MB (its laws' coefficients alone 9 MB)
SOLVE_ROWS = 4096
# candidates screened on rough laws (circle.solve_circles_rough, ~1e-8 of their scale apart from
# the full ones): a probe over the |a| cap by this much more than its margin, and under the
# speed cap by as much, is over on |a| alone on the full law too
SCREEN_BAND_R = 1e-3


def _distinct_rows(args):
    """(first, inv) of laws args (solve_circles' six (n,) arguments): the first row of each
    distinct set of arguments (by their bits), in order, and each row's position in first;
    None where every row is distinct.  The budget's knot speeds (_knot_speeds) of a plate
    whose layers repeat their curves: rect 2 471 laws, 386 distinct.  Rows are told apart by a hash of their bits (one sort of integers,
    not of 48-byte keys: ~1/20 of the instructions), every row then compared with its
    group's first bit for bit; a hash shared by different rows (not met) is told apart by
    the keys themselves."""
    bits = np.ascontiguousarray(np.stack(args, axis=1), float).view(np.uint64)
    h = bits[:, 0].copy()
    for j in range(1, bits.shape[1]):
        h *= np.uint64(0x9E3779B97F4A7C15)      # (wraps: a mix of the columns' bits)
        h ^= bits[:, j]
    first, inv = unique_first_inverse(h)
    if first.size == h.size:
        return None
    if not (bits[first[inv]] == bits).all():    # (a hash shared by different rows)
        keys = bits.view(_KEY48).ravel()
        _, first, inv = np.unique(keys, return_index=True, return_inverse=True)
        if first.size == keys.size:
            return None
        inv = inv.ravel()
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    return first[order], rank[inv]


_KEY48 = np.dtype((np.void, 48))     # a law's six arguments' bits as one key (_distinct_rows)


# the plan inputs a curve's candidates read (candidate_table's and candidates_curve's), a row each
_CURVE_PIN = ("L", "v0", "v1", "v_cap", "a_cap", "T_orig", "t_seg_min")


def _distinct_curve_rows(pin, rows, strokes, profile):
    """(first, inv) of the curve strokes rows: the first of each set of rows whose
    candidates read the same numbers (their _CURVE_PIN inputs, and their geometries'
    lengths d, κ at the vertices, κ_eff and end turns cos_end: all that candidates_curve
    reads of a row), in order, and each row's position in first; None where every row is
    distinct or a geometry has no block of 2-D rows.  A plate's layers repeat their
    curves (rectilinear plate: ~3.2 k curve strokes).  Read a block at a time (κ made
    where not yet, as candidates_curve's _Knots.of makes it)."""
    gs = [geom(strokes[i], profile) for i in rows.tolist()]
    try:
        bs, ks = list(map(_GEOM_B, gs)), [g._k for g in gs]
    except AttributeError:
        return None
    by = {}                             # id(block) -> (block, [positions in gs])
    for q, b in enumerate(bs):
        by.setdefault(id(b), (b, []))[1].append(q)
    shape, ends = [None] * len(gs), [None] * len(gs)
    for b, qs in by.values():
        if not (isinstance(b.d, np.ndarray) and b.d.ndim == 2 and _kappa_rows_ok(b)):
            return None
        sel = [ks[q] for q in qs]
        kv = b.kappa_rows(sel)
        if b._ke_miss is not None:      # (κ_eff of rows whose κ was made: made with it)
            b.make_kappa(sel)
        ke = b._ke
        ke = np.asarray(ke, float)[sel] if type(ke) is not list else np.array([ke[k] for k in sel], float)
        x = np.ascontiguousarray(np.concatenate([np.asarray(b.d, float)[sel], kv, ke[:, None]], axis=1))
        cs = b.cos_end
        for q, key, k in zip(qs, x.view(np.dtype((np.void, 8 * x.shape[1]))).ravel().tolist(), sel):
            shape[q] = key
            e = cs[k]
            ends[q] = e if e is _NO_ENDS else _ends_key(e)
    num = np.ascontiguousarray(np.stack([np.asarray(getattr(pin, f)[rows], float) for f in _CURVE_PIN], axis=1))
    num = num.view(np.dtype((np.void, 8 * num.shape[1]))).ravel().tolist()
    at = {}
    inv = np.array([at.setdefault(key, len(at)) for key in zip(shape, num, ends)], np.int64)
    if len(at) == inv.size:
        return None
    first = np.full(len(at), inv.size, np.int64)
    np.minimum.at(first, inv, np.arange(inv.size))
    return first, inv


def _ends_key(cos_end):
    """A geometry's cos_end (None or a float at each end) by its floats' bits."""
    return tuple(None if c is None else float(c).hex() for c in cos_end)


def candidates_curve(pin, rows, strokes, profile, levels=None, own_levels=None, drop=True):
    """(T, beta, I, KE) rows for the curve strokes `rows`, shape (n, len(T_RATIOS)); inf
    where no candidate was computed or it breaks a limit.  I is ∫(s̈² + κ(s)²ṡ⁴)dt.
    Rows that read the same numbers (_distinct_curve_rows) are made once, where each
    candidate is its own whatever its batch (circle.rows_invariant): their tables are
    functions of those numbers and of the batch's grid levels, the largest of its
    candidates' (the same set of candidates, so the same levels, own_levels too).

    The figures of a pass are integrated on the panel levels of all its candidates (the
    largest of theirs: CircleBatch._grid_plan), so a window of the strokes would take
    other levels, and other bits (~1e-12), than the whole file.  levels: (first pass,
    retries) floors of those levels (curve_grid_levels of the file: every window then
    integrates on the file's grid), None: each pass's own.  own_levels (a list): given
    each pass's (own levels before the floor, whether it made figures on them); where it
    made none, the levels as a function (they are read only where another window's pass
    made figures: the retries' grid_levels_of was ~10 % of the curves' candidates).
    drop: κ(s) let go after (drop_kappa); False: kept for the windows after this one
    (each would make its rows' again: ~0.016 s over 23 windows of the gyroid plate)."""
    rows = np.asarray(rows, int)
    d = _distinct_curve_rows(pin, rows, strokes, profile) if rows.size > 1 and _circle.rows_invariant() else None
    if d is None:
        return _candidates_curve(pin, rows, strokes, profile, levels, own_levels, drop)
    first, inv = d
    return tuple(x[inv] for x in _candidates_curve(pin, rows[first], strokes, profile, levels, own_levels, drop))


def _candidates_curve(pin, rows, strokes, profile, levels, own_levels, drop):
    """candidates_curve of the rows (an int array), each row solved."""
    k = len(CURVE_COLS)
    geos = [g for i in rows for g in [geom(strokes[i], profile)] * k]
    S, v0, v1, vc, ac = (np.repeat(x[rows], k) for x in (pin.L, pin.v0, pin.v1, pin.v_cap, pin.a_cap))
    # _kappa_rows' knots: per row, laid out for the compiled core (a dict per geometry without it)
    knots = _Knots.of(geos[::k]).sub(np.repeat(np.arange(rows.size), k)) if _INTERP_ROWS is not None else None
    # κ_eff per row, read once per stroke (_solve read it per candidate of each pass)
    keff_r = np.array([g.kappa_eff for g in geos[::k]])
    keff = keff_r[np.repeat(np.arange(rows.size), k)]
    # what the levels asked later (own_levels' functions) read: a row's, not a candidate's
    # (S, v0, v1, keff above, each row's k times: ~1 MB a window of the gyroid plate held
    # through candidates_in_windows' windows)
    per_row = (pin.L[rows], pin.v0[rows], pin.v1[rows], keff_r)

    # candidate_table solves each candidate, then retries those that break a limit at
    # beta/4, a flatter law.  A smaller beta weighs |a| less: the law's ∫|a|² can only grow
    # (J = ∫v² + beta G is minimised, so G(beta/4) >= G(beta)), and its peak |a| grows too
    # (+0.05..0.2 % on the plates' 50 k retried laws).  The retry helps a law over on
    # speed; one over on |a| alone (on the probe: surely over) is not solved again, it is
    # rejected as its retry was on every case of the 35-case run set (86 k candidates,
    # none accepted): ~0.1 s of the gyroid plate's 0.32 s of curve candidates
    # (tests/test_speed29_curvesolve_retry.py)
    a_only = np.zeros(rows.size * k, bool)
    floor = levels
    npass = [0]             # candidate_table's pass (0: first, 1: the beta/4 retries)

    def solve_figures(idx, T, beta):
        try:
            return _solve_figures(idx, T, beta)
        finally:
            npass[0] += 1

    def _solve_figures(idx, T, beta):
        skip = a_only[idx]
        if skip.any():
            iv, ia, ok = np.full(idx.size, np.nan), np.full(idx.size, np.nan), np.zeros(idx.size, bool)
            keep = np.flatnonzero(~skip)
            if keep.size:
                iv[keep], ia[keep], ok[keep] = _figures(idx[keep], T[keep], beta[keep], idx[skip], T[skip], beta[skip])
            elif own_levels is not None:        # (no figures made: the levels they would take, when asked)
                own_levels.append((_levels_later(idx // k, T, beta, *per_row), False))
            return iv, ia, ok
        return _figures(idx, T, beta)

    def _figures(idx, T, beta, idx_out=None, T_out=None, beta_out=None):
        """(∫v², ∫|a|², ok) of the candidates idx; idx_out: candidates left out of this
        batch, whose grid levels it takes (the figures of the batch that holds them)."""
        v_lim, a_lim = vc[idx] * (1 + SPEED_TOL_R), ac[idx] * (1 + SPEED_TOL_R)
        fig, laws, levels = _probe(idx, T, beta, v_lim, a_lim, SOLVE_ROWS if _circle.rows_invariant() else idx.size)
        # figures of a rejected candidate are never read (candidate_table): a law surely
        # over a limit is rejected on a probe, NaN figures (NaN compares False)
        iv, ia, pv, pa, mv = np.full((5, idx.size), np.nan)
        if idx_out is not None and fig.size:
            out = _levels_of(idx_out, T_out, beta_out)
            levels = levels if out is None else max(levels, out)
        if own_levels is not None:
            own_levels.append((levels if idx_out is None or fig.size else     # (levels bound now: the floor follows)
                               lambda lv=levels, later=_levels_later(idx_out // k, T_out, beta_out, *per_row):
                               max(lv, later() or 0), bool(fig.size)))
        if floor is not None and npass[0] < len(floor):
            levels = max(levels, floor[npass[0]])
        if fig.size:
            law = laws[0] if len(laws) == 1 else _circle.CircleBatch.concat(laws)
            law.grid_levels = levels
            q = idx[fig]
            iv[fig], ia[fig], pv[fig], pa[fig], mv[fig] = true_figures(
                law, 1.0 / keff[q], objfields.items(geos, q), None, {} if knots is None else knots.sub(q))
        ok = (pv <= v_lim) & (pa <= a_lim) & (mv >= -1e-9 * (1 + vc[idx]))
        return iv, ia, ok

    def _levels_of(idx, T, beta):
        """The panel levels of the candidates idx's arcs (grid_levels_of), not solved."""
        R = 1.0 / keff[idx]                     # _solve's R, the same numbers
        return _circle.grid_levels_of(S[idx] / R, T, beta, v0[idx] / R, v1[idx] / R)

    def _probe(idx, T, beta, v_lim, a_lim, step):
        """(fig, laws, levels) of the candidates idx solved `step` at a time: the positions
        in idx of those not surely over a limit (surely_over; a_only set for the others),
        their circle laws (a CircleBatch a chunk), and the panel levels of the whole batch
        (the largest of its chunks').  Each law is its own whatever its chunk (Newton's
        too: circle._newton_cheb), and given the whole batch's levels its figures are too."""
        figs, laws, levels = [], [], 0
        for a in range(0, idx.size, step):
            sl = slice(a, a + step)
            q = idx[sl]
            R = 1.0 / keff[q]                   # _solve's R, the same numbers
            args = (S[q] / R, T[sl], beta[sl], v0[q] / R, v1[q] / R, R)
            r, lv, lay = _screen(q, args, v_lim[sl], a_lim[sl])
            if r is None:                       # (no rough laws: every candidate in full)
                r = np.arange(q.size)
            else:
                args = tuple(x[r] for x in args)
                lay = tuple(x[r] for x in lay)
            law = solve_circles(*args, layers=lay) if r.size else None
            levels = max(levels, law.panel_levels() if lv is None else lv)
            if law is None:
                continue
            why = []
            fig = np.flatnonzero(~surely_over(law, args[5], objfields.items(geos, q[r]), v_lim[sl][r], a_lim[sl][r],
                                              {} if knots is None else knots.sub(q[r]), why))
            a_only[q[r]] = why[0]
            if fig.size:
                figs.append(a + r[fig])
                laws.append(law.take(fig))     # (the others' laws let go with the chunk)
            del law
        return (np.concatenate(figs) if figs else np.zeros(0, int)), laws, levels

    def _screen(q, args, v_lim, a_lim):
        """(r, levels, layers) of the candidates q (solve_circles' args): their rough laws probed
        with the |a| cap raised and the speed cap lowered by SCREEN_BAND_R; those still over
        on |a| alone are so on their full laws (a_only set; ~88 % of the plates' curve
        candidates), r the positions of the others, to be solved in full; levels the panel
        levels of all (from the layer regime, the same for rough laws), layers their layer
        regime (solve_circles' layers).  Each candidate's full law, probe and figures are as
        before: its own whatever the others in its batch.  (None, None, None) where no rough
        laws are made."""
        got = _circle.solve_circles_rough(*args)
        if got is None:
            return None, None, None
        rough, lay = got
        why = screen_a_only(rough, args[5], objfields.items(geos, q), v_lim * (1.0 - SCREEN_BAND_R),
                            a_lim * (1.0 + SCREEN_BAND_R), {} if knots is None else knots.sub(q))
        a_only[q[why]] = True
        return np.flatnonzero(~why), rough.panel_levels(), lay

    table = candidate_table(pin, rows, CURVE_COLS, solve_figures, GAMMA_MIN)
    # κ(s) is read no more in this run (the segments take κ_eff): the blocks let it go
    if drop:
        drop_kappa()
    return table


def _levels_later(r, T, beta, L, v0, v1, keff):
    """candidates_curve's _levels_of of candidates (their T and beta) of the rows r, a
    function: the rows' length, end speeds and κ_eff given per row (L[r] is the S[idx] of
    _levels_of, the same numbers), so that it holds no per-candidate array of its call."""
    def levels():
        R = 1.0 / keff[r]                       # _solve's R, the same numbers
        return _circle.grid_levels_of(L[r] / R, T, beta, v0[r] / R, v1[r] / R)
    return levels


def curve_grid_levels(pin, rows, strokes, profile):
    """The panel levels of candidates_curve's first pass over the curve strokes rows: the
    largest of every candidate's it solves (at its first beta: candidate_table's), made
    without solving a law (the layer regime's solve only, ~1 us a candidate); 0: none.
    A largest over the candidates, so the levels of several sets of rows are the largest
    of theirs.  (The retries at beta/4 are those the first pass's figures reject, known
    only once they are made: schedule.candidates_in_windows.)"""
    rows = np.asarray(rows, int)
    k = len(CURVE_COLS)
    keff = np.repeat(np.array([geom(strokes[i], profile).kappa_eff for i in rows.tolist()]), k)
    S, v0, v1 = (np.repeat(x[rows], k) for x in (pin.L, pin.v0, pin.v1))
    got = [0]

    def levels_only(idx, T, beta):
        R = 1.0 / keff[idx]                     # candidates_curve's arithmetic
        got[0] = max(got[0], _circle.grid_levels_of(S[idx] / R, T, beta, v0[idx] / R, v1[idx] / R) or 0)
        nan = np.full(idx.size, np.nan)
        return nan, nan, np.ones(idx.size, bool)      # (all "within limits": no retry pass)

    candidate_table(pin, rows, CURVE_COLS, levels_only, GAMMA_MIN)
    return got[0]


def fixed_alpha_curve(plan, pin, rows, strokes, profile, alpha):
    """--alpha A on curves: beta = A * mass_r, T = the shortest candidate meeting the limits."""
    rows = np.asarray(rows, int)
    if rows.size == 0:
        return
    ratios = np.array(sorted(CURVE_T_RATIOS))
    geos = [geom(strokes[i], profile) for i in rows]
    n, k = rows.size, ratios.size
    bb = lambda a: np.broadcast_to(np.asarray(a)[:, None], (n, k)).ravel()
    gf = [g for g in geos for _ in range(k)]
    Tf = (pin.T_orig[rows, None] * ratios[None, :]).ravel()
    beta = bb(alpha * pin.mass_r[rows])
    law, R = _solve(None, gf, bb(pin.L[rows]), Tf, beta, bb(pin.v0[rows]), bb(pin.v1[rows]))
    iv, ia, pv, pa, mv = true_figures(law, R, gf)
    vc = bb(pin.v_cap[rows])
    ok = ((pv <= vc * (1 + SPEED_TOL_R)) & (pa <= bb(pin.a_cap[rows]) * (1 + SPEED_TOL_R))
          & (mv >= -1e-9 * (1 + vc)) & (Tf >= bb(pin.t_seg_min[rows]))).reshape(n, k)
    take_shortest_feasible(plan, pin, rows, alpha, Tf.reshape(n, k), ok, iv.reshape(n, k), ia.reshape(n, k))


# ------------------------------------------------------------------ segments
KNOT_ROWS = 32             # curve laws evaluated at once on curve_knots' grid (~2 MB of grid values)


_ZERO_D = array("d", (0.0,))


def knots_s(ends_d):
    """[0, ends_d] as a new array of doubles: a stroke's ends_d (an array of doubles)
    copied after a 0 (~0.4 us less than np.concatenate a stroke); anything else as
    np.concatenate([[0.0], np.asarray(ends_d, float)])."""
    if isinstance(ends_d, array) and ends_d.typecode == "d":
        return np.array(_ZERO_D + ends_d)
    return np.concatenate([[0.0], np.asarray(ends_d, float)])


def curve_knots(strokes, T, beta, profile):
    """Speeds of each curve's law at its original vertices: list of (s, v), s = [0, ends_d]."""
    s, v, off = _knot_speeds(strokes, T, beta, profile)
    return [(s[a:b].copy(), v[a:b].copy()) for a, b in zip(off[:-1].tolist(), off[1:].tolist())]


def _knot_speeds(strokes, T, beta, profile):
    """(s, v, off): curve_knots' (s, v) of every stroke end to end, stroke i's at
    off[i]:off[i + 1] (the same numbers).  The laws are evaluated by chunks of KNOT_ROWS
    as before; each chunk's knots are interpolated in one compiled call where its rows'
    grids allow (_interp_chunk), not an np.interp a stroke."""
    m = len(strokes)
    s, off = _knots_flat(strokes)
    v = np.empty(s.size)
    if m == 0:
        return s, v, off
    geos = [geom(st, profile) for st in strokes]
    got = objfields.floats(strokes, ("length_d", "v0", "v1"))      # (one compiled pass, where it reads them)
    if got is not None:
        S, v0, v1 = (np.ascontiguousarray(got[:, j]) for j in range(3))
    else:
        S = np.array([st.length_d for st in strokes])
        v0 = np.array([st.v0 for st in strokes])
        v1 = np.array([st.v1 for st in strokes])
    T, beta = np.asarray(T, float), np.asarray(beta, float)
    args, R = _solve_args(geos, S, T, beta, v0, v1)
    args = tuple(np.broadcast_arrays(*(np.atleast_1d(np.asarray(x, float)) for x in args)))
    d = _distinct_rows(args) if _circle.rows_invariant() else None
    if d is not None:
        # (each distinct law solved and evaluated once: its own whatever its batch)
        _knot_speeds_distinct(solve_circles(*(a[d[0]] for a in args)), d[1], s, off, v)
    else:
        _knot_speeds_rows(solve_circles(*args), R, T, m, s, off, v)
    v[off[:-1]] = v0
    v[off[1:] - 1] = v1
    return s, v, off


def _knot_speeds_distinct(ulaw, inv, s, off, v):
    """_knot_speeds_rows' speeds of strokes whose laws repeat: ulaw the distinct laws
    (_distinct_rows' first rows; a plate's layers repeat their curves: rect 2 471 laws,
    386 distinct), inv each stroke's law in it.  Each distinct law evaluated once (its s
    and speed on the grid are functions of its arguments, R and T among them), and every
    stroke of it interpolated at its own knots (the same operations on the same numbers,
    each point at its law's grid)."""
    R, T, n = ulaw.R_d, ulaw.T_t, len(ulaw)
    order = _by_series_length(ulaw.coef)
    at = np.full(n, -1, np.int64)               # a distinct law's row in the chunk, -1: not in it
    for a in range(0, n, KNOT_ROWS):
        sl = slice(a, a + KNOT_ROWS) if order is None else order[a:a + KNOT_ROWS]
        sub = ulaw.rows(sl) if order is None else ulaw.take(sl)
        s_run, vd, inc = _knot_grid(sub, R[sl], T[sl])
        at[sl] = np.arange(len(sub))
        ks = np.flatnonzero(at[inv] >= 0)       # the strokes of the chunk's laws
        _interp_rows_at(s, off[ks], off[ks + 1], s_run, vd, inc, v, at[inv[ks]])
        at[sl] = -1


def _knot_grid(sub, R, T):
    """(s_run, vd, inc) of the laws sub (R, T theirs) on _KNOT_TAU: per law R phi's running
    max (_running_max_rows: inc, the rows strictly increasing) and max(R w / T, 0), in one
    call each for the chunk (elementwise, and an exact max: the same numbers as law by law)."""
    phi, w, _, _ = sub.eval_tau(np.broadcast_to(_KNOT_TAU[None, :], (len(sub), _KNOT_TAU.size)),
                                w2=False, w1=False)
    s_run, inc = _running_max_rows(_row_scale(phi, R))
    return s_run, _row_scale(w, R, T, 3), inc       # (np.maximum(R w / T, 0.0))


def _knot_speeds_rows(law, R, T, m, s, off, v):
    """_knot_speeds' speeds at the knots s of the m laws law (R, T theirs), into v."""
    order = _by_series_length(law.coef)
    # evaluated by chunks of KNOT_ROWS laws (each law's figures are its own, whatever its
    # chunk): ~15 arrays of 513 points a law, ~30 MB at once by law.row_chunks' 512 laws
    for a in range(0, m, KNOT_ROWS):
        if order is None:
            sl = slice(a, a + KNOT_ROWS)
            sub = law.rows(sl)
        else:
            sl = order[a:a + KNOT_ROWS]
            sub = law.take(sl)
        s_run, vd, inc = _knot_grid(sub, R[sl], T[sl])
        if order is None:
            _interp_chunk(s, off[a:a + len(sub) + 1], s_run, vd, inc, v)
        else:
            _interp_rows_at(s, off[sl], off[sl + 1], s_run, vd, inc, v)


def _by_series_length(coef):
    """The laws (rows of coef, their Chebyshev coefficients) in the order of their own
    number of coefficients (stable), or None where that is their order already or this BLAS
    does not give a row its own bits (circle.rows_invariant): _knot_speeds' chunks then hold
    laws of one length mostly.  A chunk's series go through BLAS calls of 32 rows of one
    length (circle._series_values: a length's rows zero-padded to whole blocks), so a chunk
    of laws of mixed lengths made ~2x the products of its laws (the gyroid plate's curve
    plans); each law's values are its own whatever its chunk (rows_invariant), so the same
    knots' speeds."""
    if coef.shape[0] < 2 or not _circle.rows_invariant():
        return None
    length = _circle._row_lengths(np.ascontiguousarray(coef))
    if (length[1:] >= length[:-1]).all():
        return None
    return np.argsort(length, kind="stable")


def _interp_rows_at(s, lo, hi, xp, fp, inc, out, which=None):
    """_interp_chunk of rows whose knots lie anywhere in s: row k's at s[lo[k]:hi[k]] (the
    same operations, each point at its law's grid), into the same places of out.  which:
    the row of xp, fp and inc of each k (None: k's own)."""
    if which is not None:
        inc = inc[which]
        if _INTERP_ROWS is None or not inc.all():   # (k's own rows: np.interp's, row by row)
            xp, fp, which = xp[which], fp[which], None
    cnt = hi - lo
    n = xp.shape[1]
    start = np.zeros(cnt.size, np.int64)
    np.cumsum(cnt[:-1], out=start[1:])
    pts = np.repeat(lo - start, cnt) + np.arange(int(cnt.sum()), dtype=np.int64)
    if _INTERP_ROWS is not None and inc.any():
        grid = np.repeat(np.where(inc, n, 0), cnt)          # 0: left to np.interp below
        at = np.repeat((np.arange(inc.size, dtype=np.int64) if which is None else which) * n, cnt)
        q = s[pts]
        res = np.empty(pts.size)
        _INTERP_ROWS(q, at, grid, np.ascontiguousarray(xp).ravel(), np.ascontiguousarray(fp).ravel(),
                     pts.size, 1, xp.size, res)
        out[pts] = res
        rest = np.flatnonzero(~inc).tolist()
    else:
        rest = range(inc.size)
    for k in rest:
        a, b = int(lo[k]), int(hi[k])
        out[a:b] = _interp(s[a:b], xp[k], fp[k], None, None)      # np.interp's core, the same bits


_KNOT_TAU = np.linspace(0.0, 1.0, 513)


def _knots_flat(strokes):
    """(s, off): knots_s(st.ends_d) of every stroke end to end (the same doubles: 0, then
    its ends_d) and where each starts (off: m + 1 offsets); the arrays of doubles joined as
    bytes in one call, not an array made a stroke."""
    ends = [st.ends_d for st in strokes]
    off = np.zeros(len(ends) + 1, np.int64)
    np.cumsum(np.fromiter(map(len, ends), np.int64, len(ends)) + 1, out=off[1:])
    if not all(type(e) is array and e.typecode == "d" for e in ends):
        return (np.concatenate([knots_s(e) for e in ends]) if ends else np.zeros(0)), off
    s = np.empty(int(off[-1]))
    first = np.zeros(s.size, bool)
    first[off[:-1]] = True
    s[first] = 0.0
    s[~first] = np.frombuffer(b"".join(ends), float)
    return s, off


def _running_max_rows(x):
    """(np.maximum.accumulate(x, axis=1), inc): inc marks the rows strictly increasing,
    whose running max is the row itself (each element the max of it and the one before,
    which it exceeds: the same doubles); the others are accumulated (~8x the compare).
    The neighbours compared along the rows end to end (one contiguous pass, ~1/3 the
    time of the rows' strided views), each row's last place set True (no pair after it)."""
    n = x.shape[1]
    flat = x.ravel()
    up = np.empty(flat.size, bool)
    np.greater(flat[1:], flat[:-1], out=up[:-1])
    up[n - 1::n] = True
    if up.all():
        return x, np.ones(x.shape[0], bool)
    inc = up.reshape(-1, n).all(axis=1)
    if not inc.all():
        rest = np.flatnonzero(~inc)
        x[rest] = np.maximum.accumulate(x[rest], axis=1)
    return x, inc


def _interp_chunk(s, off, xp, fp, inc, out):
    """out[off[k]:off[k + 1]] = np.interp(s[...], xp[k], fp[k]) for the rows k of a chunk
    (off: its len + 1 offsets into s): the rows whose grid xp[k] is strictly increasing
    (inc; finite, as a compare with NaN is false) in one compiled call (_curvecore.c
    interp_rows, np.interp's operations: each point a row of one, at its law's grid), the
    others by np.interp."""
    a, b = int(off[0]), int(off[-1])
    n = xp.shape[1]
    if _INTERP_ROWS is not None and inc.any():
        cnt = np.diff(off)
        grid = np.repeat(np.where(inc, n, 0), cnt)          # 0: left to np.interp below
        at = np.repeat(np.arange(inc.size, dtype=np.int64) * n, cnt)
        q = np.ascontiguousarray(s[a:b])
        res = np.empty(b - a)
        _INTERP_ROWS(q, at, grid, np.ascontiguousarray(xp).ravel(), np.ascontiguousarray(fp).ravel(),
                     b - a, 1, xp.size, res)
        out[a:b] = res
        rest = np.flatnonzero(~inc).tolist()
    else:
        rest = range(inc.size)
    for k in rest:
        lo, hi = int(off[k]), int(off[k + 1])
        out[lo:hi] = _interp(s[lo:hi], xp[k], fp[k], None, None)      # np.interp's core, the same bits


def predict_curve(s, v, a, cos_turn, cos_end0=None, cos_end1=None):
    """Firmware execution of the curve's G1 segments: each ramps at a_k over |Δv| and
    cruises the rest (time, tangential Σ a_k |Δv_k|), plus the normal term the firmware
    model counts at every vertex turning <= 30 deg: (2 v sin(θ/2))² / ((t_k + t_{k+1})/2),
    and half of it at the curve's two ends (the other half belongs to the neighbour)."""
    # np.add.reduce is what np.sum runs on a 1-D array (the same pairwise sum), and
    # x[1:] - x[:-1] np.diff's subtraction, without their per-call overhead (~7 knots)
    s, v = np.asarray(s), np.asarray(v)
    t, a, dv = segment_times(s, v, a)
    a2 = float(_add(a * dv))
    vi = v[1:-1]
    dv2 = 2.0 * vi * vi * (1.0 - cos_turn)
    tj = 0.5 * (t[:-1] + t[1:])
    a2 += float(_add(np.where(cos_turn >= CORNER_COS, dv2 / np.maximum(tj, 1e-12), 0.0)))
    for c, vv, tt in ((cos_end0, v[0], t[0]), (cos_end1, v[-1], t[-1])):
        if c is not None and c >= CORNER_COS:
            a2 += 0.5 * 2.0 * vv * vv * (1.0 - c) / max(tt, 1e-12)
    return float(_add(t)), a2


_add = np.add.reduce


def plan_curve_segments(strokes, T, beta, rules, profile):
    """SegmentPlan per curve stroke (knots = the original vertices)."""
    return _finish_flat(strokes, *_knot_speeds(strokes, T, beta, profile), rules, profile)


def finish_curves(strokes, knots, rules, profile):
    """[finish_curve(st, s, v, rules, profile) for st, (s, v) in zip(strokes, knots)], the
    strokes of one knot count in arrays: the same elementwise arithmetic, exact maxima,
    row sums that add in the 1-D sums' order (numpy's pairwise sum per row), and per
    stroke what is not elementwise (np.convolve's window, dot2's end turns, the
    junction law of Marlin JD and Klipper); ~4x faster on the gyroid plate.  The same
    SegmentPlans (tests/test_speed_plan3_finish.py)."""
    off = np.zeros(len(knots) + 1, np.int64)
    np.cumsum([sk.size for sk, _ in knots], out=off[1:])
    s = np.concatenate([sk for sk, _ in knots]) if knots else np.zeros(0)
    v = np.concatenate([vk for _, vk in knots]) if knots else np.zeros(0)
    return _finish_flat(strokes, s, v, off, rules, profile)


def _finish_flat(strokes, s, v, off, rules, profile):
    """finish_curves of the knots (s, v) of every stroke end to end, stroke i's at
    off[i]:off[i + 1] (_knot_speeds): the strokes of one knot count gathered into rows."""
    plans = [None] * len(strokes)
    cnt = np.diff(off)
    for n1 in np.flatnonzero(np.bincount(cnt)).tolist():     # (the counts present, ascending)
        ks = np.flatnonzero(cnt == n1)
        if n1 < 3:                       # one segment: the stroke by itself
            for i, a in zip(ks.tolist(), off[ks].tolist()):
                plans[i] = finish_curve(strokes[i], s[a:a + n1].copy(), v[a:a + n1].copy(), rules, profile)
            continue
        at = off[ks][:, None] + np.arange(n1)
        for i, plan in zip(ks.tolist(), _finish_rows([strokes[i] for i in ks.tolist()], s[at], v[at], rules, profile)):
            plans[i] = plan
    return plans


def _finish_rows(sts, S, V, rules, profile):
    """finish_curve of strokes whose knots all have one size (> 2): S, V (m, size)."""
    m = len(sts)
    gs = [geom(st, profile) for st in sts]
    d = S[:, 1:] - S[:, :-1]
    v2 = V * V
    acc = np.abs(v2[:, 1:] - v2[:, :-1]) / (2.0 * d)
    a_top, jerk, v_feed = _row_fields(sts, rules.junction == "jerk")
    D, U = stack_du(gs)                  # the geometries' d and u rows, one array each
    if rules.junction == "jerk":
        acc = _jerk_junction_rows(D, V, acc, a_top, profile)
    else:
        acc = np.stack([junction_accels(st, g, vk, a, rules, profile)
                        for st, g, vk, a in zip(sts, gs, V, acc)])
    acc = hold_cruise_accels_rows(acc, np.array(a_top, float))
    if rules.junction == "jerk":
        step_v = np.array(jerk, float)
    else:
        step_v = np.full(m, np.inf)
    need = np.maximum(np.maximum(V[:, :-1], V[:, 1:]), MIN_FEED_V)        # segment_feeds
    feeds = tent_feeds_rows(need, np.array(v_feed, float), step_v)
    c0, c1 = _end_cosines(sts, U)
    # CurveGeom.cos_turn of each row (its einsum on the stacked rows, as _parts_block's)
    t_pred, a2_pred = _predict_rows(S, V, acc, np.einsum("bij,bij->bi", U[:, :-1], U[:, 1:]), c0, c1)
    # rows of the four blocks (RowPlan), not a SegmentPlan of two arrays and two views each
    # (~0.45 kB of numpy objects a plan; ~7 k curve plans held through the budget runs of
    # the gyroid plate); the same numbers, and seg_fault's verdicts made on the blocks
    return _row_plans(S, V, acc, feeds, t_pred, a2_pred, fine_rows(S, V, acc, feeds, t_pred, a2_pred))


_LIM = attrgetter("lim")


def _row_fields(sts, jerk):
    """_finish_rows' fields of the strokes: (a_top, jerk steps (jerk: else None), v_feed),
    [min(st.accel, st.lim.ax_max, st.lim.ay_max)], [JERK_F_STEP_R * min(st.lim.jerk_x,
    st.lim.jerk_y)] and [st.v_feed], read in two compiled passes where they are floats
    (arrays then: Python's min as np.where on its comparisons, the first on a tie or a
    NaN; the same product), else as those lists."""
    got = objfields.floats(sts, ("accel", "v_feed"))
    lims = list(map(_LIM, sts)) if got is not None else None
    lim = objfields.floats(lims, ("ax_max", "ay_max") + (("jerk_x", "jerk_y") if jerk else ())) if lims else None
    if lim is None:
        a_top = [min(st.accel, st.lim.ax_max, st.lim.ay_max) for st in sts]
        step = [JERK_F_STEP_R * min(st.lim.jerk_x, st.lim.jerk_y) for st in sts] if jerk else None
        return a_top, step, [st.v_feed for st in sts]
    a = got[:, 0]
    a = np.where(lim[:, 0] < a, lim[:, 0], a)
    a_top = np.where(lim[:, 1] < a, lim[:, 1], a)
    step = JERK_F_STEP_R * np.where(lim[:, 3] < lim[:, 2], lim[:, 3], lim[:, 2]) if jerk else None
    return a_top, step, got[:, 1]


def _jerk_junction_rows(D, V, acc, a_top, profile):
    """junction_accels under classic jerk, row by row in arrays: max(x, z) where x < z
    (z = min(ACCEL_MARGIN x 0, a_top)), then the finite buffer's floor (D: the segment
    lengths g.d of each row's geometry)."""
    z = np.array([min(ACCEL_MARGIN * 0.0, a) for a in a_top], float)[:, None]
    acc = np.where(z > acc, z, acc)               # Python's max(x, z): z only where z > x
    if profile.block_buffer > 0:
        nb = max(profile.block_buffer - 3, 1)
        window = _window_rows(D, nb)
        vmax = np.maximum(V[:, :-1], V[:, 1:])
        acc = np.maximum(acc, np.minimum(1.1 * vmax ** 2 / (2.0 * window), np.array(a_top, float)[:, None]))
    return acc


def dot2(a, b):
    """a . b of two 2-vectors as two products and their sum, in Python floats: every path
    (this, the row forms below, the chain core) the same bits whatever BLAS numpy links.
    np.dot does not promise that: OpenBLAS 0.3.31's Haswell ddot fuses the multiply-add."""
    return float(a[0]) * float(b[0]) + float(a[1]) * float(b[1])


def _end_cosines(sts, U):
    """([None or dot2(st.prev_u, u[0])], [None or dot2(u[-1], st.next_u)]) of the strokes
    sts, U their directions (m, n, 2), for every row at once (elementwise products and a
    sum: dot2's bits)."""
    p, q = _neighbour_dirs(sts)                 # (2, m) each, NaN where None
    a = (p[0] * U[:, 0, 0] + p[1] * U[:, 0, 1]).tolist()
    b = (U[:, -1, 0] * q[0] + U[:, -1, 1] * q[1]).tolist()
    return ([None if st.prev_u is None else x for st, x in zip(sts, a)],
            [None if st.next_u is None else x for st, x in zip(sts, b)])


def _window_rows(D, nb):
    """[np.convolve(np.concatenate([d, np.full(nb, d[-1])]), np.ones(nb), "valid")[:n]
    for d in D] as an (m, n) array, by one np.convolve over those rows end to end: numpy's
    correlate makes each "valid" output by the same dot of nb values (one BLAS ddot, or
    its small-kernel loop, whatever the position in the array), so each window the same
    bits (tests/test_speed_plan3_finish.py, tests/test_speed26_curvec_rows.py)."""
    m, n = D.shape
    ext = np.empty((m, n + nb))
    ext[:, :n] = D
    ext[:, n:] = D[:, -1:]
    flat = np.convolve(ext.ravel(), np.ones(nb), "valid")       # m (n + nb) - nb + 1 windows
    out = np.empty(m * (n + nb))
    out[:flat.size] = flat
    return out.reshape(m, n + nb)[:, :n]


def _predict_rows(S, V, A, cos_turn, c0, c1):
    """predict_curve of every row (the same operations; row sums in the 1-D sums' order),
    as two lists (time_t float, int_a2 float or numpy float64, as predict_curve's).  c0,
    c1: the end turns' cosines (_end_cosines: None, no neighbour, taken as a NaN, which
    fails the test c >= CORNER_COS as None does); the end terms added in arrays, each
    where its test holds, in predict_curve's order (Python's max(t, 1e-12) as np.maximum:
    the same double, a NaN's included), not a row at a time."""
    t, a, dv = segment_times(S, V, A)
    s1 = _add(a * dv, axis=1)
    vi = V[:, 1:-1]
    dv2 = 2.0 * vi * vi * (1.0 - cos_turn)
    tj = 0.5 * (t[:, :-1] + t[:, 1:])
    s2 = _add(np.where(cos_turn >= CORNER_COS, dv2 / np.maximum(tj, 1e-12), 0.0), axis=1)
    t_sum = _add(t, axis=1).tolist()
    a2 = s1 + s2
    ended = np.zeros(a2.size, bool)
    with np.errstate(all="ignore"):           # (the rows whose test fails are costed too, then left out)
        for c, j in ((c0, 0), (c1, -1)):
            c = np.array(c, float)
            on = c >= CORNER_COS
            if on.any():
                vv = V[:, j]
                a2 = np.where(on, a2 + 0.5 * 2.0 * vv * vv * (1.0 - c) / np.maximum(t[:, j], 1e-12), a2)
                ended |= on
    a2s = a2.tolist()
    for k in np.flatnonzero(ended).tolist():  # (a numpy float64 where an end term was added, as there)
        a2s[k] = a2[k]
    return t_sum, a2s


def junction_accels(st, g, vk, acc, rules, profile, vmax=None):
    """Segment accelerations `acc` raised to what the firmware's junction law needs to
    pass each original vertex at the knot speed vk (x ACCEL_MARGIN), and to the floor a
    finite-lookahead planner needs to stop within the blocks it knows (vmax: each
    segment's top speed, default the faster knot); never above the acceleration in force."""
    d = g.d
    n = len(d)
    acc = np.array(acc, float)
    jd = st.lim.jd
    a_top = min(st.accel, st.lim.ax_max, st.lim.ay_max)
    v0 = st.v0 if st.v0 >= FULL_STOP_V else 0.0
    v1 = st.v1 if st.v1 >= FULL_STOP_V else 0.0
    if rules.junction == "jerk":
        # accel_to_pass_junction needs 0.0 at every vertex: the loop below would set
        # acc[k] = max(acc[k], z), which changes only an acc[k] below z
        z = min(ACCEL_MARGIN * 0.0, a_top)
        if (acc < z).any():
            acc = np.array([max(x, z) for x in acc.tolist()])
    else:
        vj = np.array(vk, float)
        vj[..., 0], vj[..., -1] = v0, v1
        acc = _junctions_raised(st, g.u, d, vj, acc, rules.junction, jd, a_top)
    if profile.block_buffer > 0:
        # a finite-lookahead planner must be able to stop within the blocks it knows
        nb = max(profile.block_buffer - 3, 1)
        ext = np.concatenate([d, np.full(nb, d[-1])])
        window = np.convolve(ext, np.ones(nb), "valid")[:n]
        if vmax is None:
            vmax = np.maximum(vk[..., :-1], vk[..., 1:])
        acc = np.maximum(acc, np.minimum(1.1 * vmax ** 2 / (2.0 * window), a_top))
    return acc


def _junctions_raised(st, U, d, vj, acc, junction, jd, a_top):
    """junction_accels' raise of each segment's acceleration to ACCEL_MARGIN x what its
    junctions need ("scv": both ends; "jd": its start), for one row of knot speeds vj
    (n + 1,) or k rows (k, n + 1) of the chain or curve st at once (junctions_raised_rows);
    a row with a junction the per-junction form would raise on is taken junction by
    junction (_junctions_raised_row)."""
    pu, nu = st.prev_u, st.next_u
    out, odd = junctions_raised_rows(0.0 if pu is None else pu[0], 0.0 if pu is None else pu[1], pu is not None,
                                     0.0 if nu is None else nu[0], 0.0 if nu is None else nu[1], nu is not None,
                                     U[:, 0], U[:, 1], d, vj, acc, junction, jd, a_top)
    if odd.any():
        if out.ndim == 1:
            return _junctions_raised_row(st, U, d, vj, acc, junction, jd, a_top)
        for r in np.flatnonzero(odd.any(axis=-1)).tolist():
            out[r] = _junctions_raised_row(st, U, d, vj[r], acc[r], junction, jd, a_top)
    return out


def junctions_raised_rows(pux0, puy0, has_p0, nux1, nuy1, has_n1, ux, uy, d, vj, acc, junction, jd, a_top):
    """_junctions_raised's numbers on rows: the directions ux, uy and lengths d (..., n) of
    the segments, the knot speeds vj (..., n + 1), the accelerations acc (..., n); the
    direction before the first segment (pux0, puy0; has_p0 False: a stop) and after the
    last (nux1, nuy1, has_n1), and jd, a_top, one value or one a row ((R, 1)).
    accel_to_pass_junction_rows for the junctions (the same floats), Python's max / min
    as np.where on their comparison.  Returns (acc raised, odd): odd where the
    per-junction form would raise (a division by zero; the caller takes those rows
    junction by junction)."""
    shape = np.shape(d)
    pux, puy, has_p = np.empty(shape), np.empty(shape), np.ones(shape, bool)
    pux[..., 1:], puy[..., 1:] = ux[..., :-1], uy[..., :-1]     # direction before each segment's start
    pux[..., 0], puy[..., 0], has_p[..., 0] = pux0, puy0, has_p0
    need, odd = accel_to_pass_junction_rows(junction, vj[..., :-1], pux, puy, has_p, ux, uy, d, jd)
    if junction == "scv":                      # Klipper: both moves' accelerations bound the junction
        nux, nuy, has_n = np.empty(shape), np.empty(shape), np.ones(shape, bool)
        nux[..., :-1], nuy[..., :-1] = ux[..., 1:], uy[..., 1:]     # direction after each segment's end
        nux[..., -1], nuy[..., -1], has_n[..., -1] = nux1, nuy1, has_n1
        need1, odd1 = accel_to_pass_junction_rows("scv", vj[..., 1:], ux, uy, has_n, nux, nuy, d, jd)
        need = np.where(need1 > need, need1, need)
        odd = odd | odd1
    x = ACCEL_MARGIN * need
    m = np.where(a_top < x, a_top, x)           # min(x, a_top), then max(acc, m)
    return np.where(m > acc, m, acc), odd


def _junctions_raised_row(st, U, d, vj, acc, junction, jd, a_top):
    """_junctions_raised of one row, junction by junction (accel_to_pass_junction: raises
    where it divides by zero)."""
    acc = np.array(acc, float)
    u = [tuple(x) for x in U]
    pus = [st.prev_u] + u[:-1]
    nus = u[1:] + [st.next_u]
    for k in range(d.size):
        need = accel_to_pass_junction(junction, vj[k], pus[k], u[k], d[k], jd)
        if junction == "scv":
            need = max(need, accel_to_pass_junction("scv", vj[k + 1], u[k], nus[k], d[k], jd))
        acc[k] = max(acc[k], min(ACCEL_MARGIN * need, a_top))
    return acc


def finish_curve(st, sk, vk, rules, profile):
    g = geom(st, profile)
    d = sk[1:] - sk[:-1]                  # np.diff's subtraction, without its overhead
    v2 = vk * vk
    acc = np.abs(v2[1:] - v2[:-1]) / (2.0 * d)
    a_top = min(st.accel, st.lim.ax_max, st.lim.ay_max)
    acc = junction_accels(st, g, vk, acc, rules, profile)
    step_v = np.inf
    if rules.junction == "jerk":
        step_v = JERK_F_STEP_R * min(st.lim.jerk_x, st.lim.jerk_y)
    acc = hold_cruise_accels(acc, a_top)
    feeds = segment_feeds(vk, st.v_feed, step_v)
    c0 = None if st.prev_u is None else dot2(st.prev_u, g.u[0])
    c1 = None if st.next_u is None else dot2(g.u[-1], st.next_u)
    t_pred, a2_pred = predict_curve(sk, vk, acc, g.cos_turn, c0, c1)
    return SegmentPlan(sk, vk, acc, feeds, t_pred, a2_pred)
