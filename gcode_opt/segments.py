"""Segments: cut a planned law into firmware moves that reproduce it.

A constant-acceleration firmware executes each move as a trapezoid and can only join
moves at a speed both allow.  A segment from knot k-1 to knot k with feed
F_k = max(v_{k-1}, v_k) and acceleration a_k = |v_k^2 - v_{k-1}^2| / (2 d_k) is therefore
executed as one pure ramp from v_{k-1} to v_k: the firmware plays the law back as a
piecewise-constant acceleration (the chord of v^2 in distance), with the planner's own
lookahead agreeing at every junction.  Knots are spaced evenly in time (dense where the
motion is slow) and every original vertex is a knot, so the toolpath keeps its points.
"""
from __future__ import annotations

import copy
from array import array
from collections import deque
from itertools import compress, repeat
from functools import partial
from operator import attrgetter, is_, is_not

import numpy as np

from . import objfields
from .distinct import _row_hashes, column_classes, column_classes_first, distinct, unique_first_inverse
from .firmware.junction import (accel_to_pass_junction, accel_to_pass_junction_rows,
                                marlin_jerk_junction_v_rows)
from .firmware.simulate import FULL_STOP_V
from .laws.line import _N_COEF, _S1_COEF, _cube, check_params, line_law, time_of_distance
from .strokes import Stroke, line_spans, stroke_fields

MIN_SEG_D = 0.3          # mm: shorter segments bloat the file for no fidelity gain
EDGE_D = 0.5             # mm: longest lead-in/lead-out at a corner speed
EDGE_T = 0.01            # s: ... and no longer than this at that speed (a slow lead-in costs time)
KNOT_CHUNK = 2048         # strokes whose knots are evaluated at once (law temporaries ~ 50 x strokes x knots)
MIN_EDGE_D = 0.02        # mm: no room for a lead-in this long: none (a sliver is 0/0 for its ramp)
ROUND_D = 0.002          # mm: what writing X/Y to 3 decimals may take off a short move
EDGE_MIN_V = 1.0         # mm/s: a corner slower than this (2 x the model's full-stop threshold) is passed
                         # without a lead-in: the accel it needs is nil, and the lead-in at ~0.5 mm/s,
                         # made long enough for the firmware to keep it, ended below the stop threshold


def segment_count(T, L, n_max, t_seg_min_t, min_seg_d=MIN_SEG_D):
    """How many segments a stroke of duration T and length L gets."""
    n = min(n_max, int(T / t_seg_min_t) if t_seg_min_t > 0 else n_max, int(L / min_seg_d))
    return max(n, 0)


def law_knots(strokes, T, beta, n, views=True, fields=None):
    """Knots of many strokes at once (one vectorised law evaluation): for stroke i, the
    distances s (mm) and speeds v (mm/s) at n_i + 1 instants evenly spaced in time, plus
    every interior original vertex (law knots too close to a vertex dropped), with
    s_0 = 0, s_K = L and the end speeds exact.  Returns a list of (s, v).

    views=False: the strokes of one move (rows of the blocks) are None in the list, and
    _Knots.at(i) gives their (s, v) (plan_segments: ~95 % of a plate's strokes are planned
    from the blocks themselves, whose rows' views, ~1.3 µs a stroke, were not read)."""
    m = len(strokes)
    if m == 0:
        return []
    multi, blocks = _law_knot_blocks(strokes, T, beta, n, fields)
    out = _Knots([None]) * m
    for g, s, v in blocks if views else ():     # each stroke's s and v: its rows of the blocks
        for i, sr, vr in zip(g.tolist(), s, v):
            out[i] = (sr, vr)
    for i, sv in multi.items():
        out[i] = sv
    out.blocks = blocks
    return out


class _Knots(list):
    """law_knots' list of (s, v), with the blocks its strokes of one move are rows of:
    blocks [(rows, S, V)], out[rows[q]] == (S[q], V[q]) (_finish_jerk_rows takes them as
    they are instead of stacking the rows again).  A list like any other."""
    __slots__ = ("blocks", "_where")

    def __mul__(self, k):
        out = _Knots(list.__mul__(self, k))
        out.blocks = ()
        out._where = None
        return out

    def at(self, i):
        """Stroke i's (s, v): its entry, or where that is None (law_knots(views=False)),
        its rows of the blocks (the views law_knots would have put there)."""
        got = self[i]
        if got is not None or not self.blocks:
            return got
        if self._where is None:            # block and row of each stroke, made once
            blk = np.full(len(self), -1)
            row = np.zeros(len(self), int)
            for b, (g, _, _) in enumerate(self.blocks):
                blk[g], row[g] = b, np.arange(g.size)
            self._where = blk.tolist(), row.tolist()
        b = self._where[0][i]
        if b < 0:
            return got
        _, S, V = self.blocks[b]
        r = self._where[1][i]
        return S[r], V[r]


def _law_knot_blocks(strokes, T, beta, n, fields=None):
    """law_knots' knots as ({i: (s, v)} of the strokes of several moves, [(rows, S, V)]
    blocks of the strokes of one move, by knot count: stroke rows[q]'s s and v are the
    rows S[q], V[q]).  The speeds are evaluated without the accelerations (LineLaw.eval's
    want: the same s and v).  fields: the strokes' (L, v0, v1) as float arrays, when read
    already (plan_segments reads them once for all its chunks), else read here."""
    if fields is None:
        L = np.array([st.length_d for st in strokes])
        v0 = np.array([st.v0 for st in strokes])
        v1 = np.array([st.v1 for st in strokes])
    else:
        L, v0, v1 = fields
    T, beta, n = np.asarray(T, float), np.asarray(beta, float), np.asarray(n, int)
    j = np.arange(n.max() + 1)
    tau = np.minimum(j[None, :] / n[:, None], 1.0)
    s_all, v_all = _law_sv(L, T, beta, v0, v1, tau * T[:, None])
    # interior vertices of multi-move strokes: one vectorised inversion s -> t
    nm = _move_counts(strokes)
    owner, verts = [], []
    if max(nm) > 1:
        for i, st in enumerate(strokes):
            if nm[i] > 1:
                owner += [i] * (nm[i] - 1)
                verts += st.ends_d[:-1]
    vv = {}
    if verts:
        owner_a, verts_a = np.array(owner), np.array(verts)
        vl = line_law(L[owner_a], T[owner_a], beta[owner_a], v0[owner_a], v1[owner_a])
        _, v_vert, _ = vl.eval(np.asarray(time_of_distance(vl, verts_a), float), "v")
        for k, i in enumerate(owner):
            vv.setdefault(i, []).append((verts_a[k], float(v_vert[k])))
    # strokes of one move, by knot count: their rows in one go (the same copies, the
    # same elementwise max and the same assignments as stroke by stroke)
    single = np.ones(len(strokes), bool)
    if vv:
        single[list(vv)] = False
    blocks = []
    idx = np.flatnonzero(single)
    if idx.size:
        ks = n[idx]
        for k in distinct(ks).tolist():
            g = idx[ks == k]
            s = s_all[g, :k + 1]
            s[:, 0] = 0.0
            s[:, -1] = L[g]
            v = np.maximum(v_all[g, :k + 1], 0.0)
            v[:, 0] = v0[g]
            v[:, -1] = v1[g]
            blocks.append((g, s, v))
    multi = {}
    for i in vv:                  # strokes of several moves: their vertices' knots merged in
        s, v = s_all[i, :n[i] + 1].copy(), v_all[i, :n[i] + 1].copy()
        vs = np.array([p[0] for p in vv[i]])
        min_gap = min(MIN_SEG_D, L[i] / (4 * n[i]))
        gap = np.min(np.abs(s[:, None] - vs[None, :]), axis=1)
        keep = np.ones(len(s), bool)
        keep[1:-1] = gap[1:-1] >= min_gap
        s = np.concatenate([s[keep], vs])
        v = np.concatenate([v[keep], [p[1] for p in vv[i]]])
        order = np.argsort(s, kind="stable")
        s, v = s[order], v[order]
        s[0], s[-1] = 0.0, L[i]
        v = np.maximum(v, 0.0)
        v[0], v[-1] = v0[i], v1[i]
        multi[i] = (s, v)
    return multi, blocks


def _move_counts(strokes):
    """[st.n_moves for st in strokes]: for Strokes (whose n_moves is last_idx - first_idx
    + 1, a Python property) from their two indices as strokes.line_spans reads them (one
    compiled call; ~0.2 µs a stroke less), else each stroke's n_moves."""
    if set(map(type, strokes)) == {Stroke}:
        first, last = line_spans(strokes)
        return (last - first + 1).tolist()
    return [st.n_moves for st in strokes]


def _law_sv(L, T, beta, v0, v1, t):
    """line_law(L, T, beta, v0, v1) (1-D, as columns).eval(t, "sv")[:2] at t (m, k): the
    cubic laws (beta = inf: ~90 % of the rectilinear plate's re-timed lines) by
    _cubic_sv, the others by their LineLaw, each row its own.  The same bits: every step
    of eval is elementwise, and the series' term counts of the other rows' batch
    (_nms_terms: by its largest gamma^2) are the whole batch's, whose cubic rows' gamma^2
    are 0.  LineLaw's ValueErrors are raised on all rows first, as it raised them."""
    cubic = beta == np.inf
    if not cubic.any():
        law = line_law(L[:, None], T[:, None], beta[:, None], v0[:, None], v1[:, None])
        return law.eval(t, "sv")[:2]
    check_params(L, T, beta, v0, v1)          # LineLaw's ValueErrors, raised on all rows first
    s = np.empty(t.shape)
    v = np.empty(t.shape)
    c = np.flatnonzero(cubic)
    s[c], v[c] = _cubic_sv(L[c], T[c], v0[c], v1[c], t[c])
    if c.size < cubic.size:
        o = np.flatnonzero(~cubic)
        law = line_law(L[o, None], T[o, None], beta[o, None], v0[o, None], v1[o, None])
        s[o], v[o], _ = law.eval(t[o], "sv")
    return s, v


def _cubic_sv(L, T, v0, v1, t):
    """LineLaw.eval(t, "sv")[:2] of laws at beta = inf (T finite > 0: gamma = T / inf = +0.0
    exactly), as eval computes it in the series branch: there n (Horner at z2 = 0: each
    step c * 0 + c_j) is _N_COEF[0] and S1 is _S1_COEF[0] exactly, every shc is of a zero
    (np.where's 1.0), so pa = pb = shx = sh2 = shc(gamma / 4) = 1.0 and the products and
    quotients by them (and by 1.0 ** 2) are exact: what is left are eval's and
    _shapes_small's own operations, in their order (tests/test_speed26_linec_cubic.py)."""
    Tc = T[:, None]
    wbar = Tc * (v0 + v1)[:, None] / 2
    d = Tc * (v0 - v1)[:, None] / 2
    A = L[:, None] - wbar
    tau = np.clip(np.asarray(t, dtype=float) / Tc, 0.0, 1.0)
    n = _N_COEF[0]
    x = tau - 0.5
    bub = tau * (1 - tau)                    # tau (1 - tau) pa pb
    g = bub / (2 * n)
    Hs = -bub                                # -bub / sh2
    h = 2 * x                                # 2 x shx / sh2
    G = 0.5 + (x / 8 - _cube(x) * _S1_COEF[0]) / n    # x shc(gamma / 4)^2 / 8, cube(x) S1(0)
    s = wbar * tau + A * G - d * Hs
    v = (wbar + A * g - d * h) / Tc
    return s, v


def with_edges(s, v, edge0_d=0.0, edge1_d=0.0):
    """Add a lead-in / lead-out: a short segment run at the corner speed itself (v_0 /
    v_K, no speed change) that can carry whatever acceleration the firmware's junction
    law needs to keep that corner speed, at no cost in int a^2."""
    if edge0_d > 0.0:
        e = min(edge0_d, 0.4 * s[1])
        s = np.concatenate([[0.0, e], s[1:]])
        v = np.concatenate([[v[0], v[0]], v[1:]])
    if edge1_d > 0.0:
        e = min(edge1_d, 0.4 * (s[-1] - s[-2]))
        s = np.concatenate([s[:-1], [s[-1] - e, s[-1]]])
        v = np.concatenate([v[:-1], [v[-1], v[-1]]])
    return s, v


MIN_FEED_V = 0.1         # mm/s: F of a segment whose two knots are (near) stops; F0 is not a feed
CRUISE_A = 1e-6          # mm/s^2: below this a segment's ramp acceleration is a cruise's 0


def hold_cruise_accels(acc, a_own):
    """Accelerations to write for segments whose ramp acceleration is ~0 (constant speed).

    A cruise segment's acceleration changes nothing in its own motion (no speed change),
    but it must be > 0 (Klipper rejects `M204 S0`: a print from SD stops there) and the
    firmware's junction limits scale with it (Klipper's centripetal term, Marlin JD's
    a * jd): a tiny value would slow the corners around it.  So a cruise keeps the previous
    segment's acceleration (no extra M204 line), the next one's at the stroke's start, and
    the stroke's own when the whole stroke cruises.  NaN stays NaN (a fault, caught)."""
    acc = np.asarray(acc, float).copy()
    cruise = acc <= CRUISE_A
    if not cruise.any():
        return acc
    if cruise.all():
        acc[:] = a_own
        return acc
    idx = np.where(cruise, 0, np.arange(acc.size))
    np.maximum.accumulate(idx, out=idx)              # last non-cruise at or before k
    first = int(np.argmax(~cruise))
    held = acc[idx]
    held[:first] = acc[first]
    return np.where(cruise, held, acc)


def hold_cruise_accels_rows(acc, a_own):
    """hold_cruise_accels of every row of acc (k, n), at once; the same numbers row by row
    (tests/test_speed_plan_rows.py)."""
    acc = np.array(acc, float)
    cruise = acc <= CRUISE_A
    if not cruise.any():
        return acc
    k, n = acc.shape
    idx = np.where(cruise, 0, np.arange(n)[None, :])
    np.maximum.accumulate(idx, axis=1, out=idx)      # last non-cruise at or before each
    first = np.argmax(~cruise, axis=1)
    r = np.arange(k)[:, None]
    held = np.where(np.arange(n)[None, :] < first[:, None], acc[r[:, 0], first][:, None], acc[r, idx])
    out = np.where(cruise, held, acc)
    whole = cruise.all(axis=1)                     # a_own: one value, or one per row
    out[whole] = a_own if np.ndim(a_own) == 0 else np.asarray(a_own, float)[whole][:, None]
    return out


def tent_feeds_rows(need, v_feed, step_v, max_cells=4_000_000):
    """tent_feeds of every row of need (k, n): (rows, n, n + 2) envelopes of at most
    max_cells cells at a time.  A max of the same differences: the same numbers.  v_feed
    and step_v: one value, or one per row (rows of several chains)."""
    if np.ndim(step_v) == 0 and np.ndim(v_feed) == 0:
        if not np.isfinite(step_v):
            return need
    k, n = need.shape
    step = np.broadcast_to(np.asarray(step_v, float), (k,))
    vf = np.broadcast_to(np.asarray(v_feed, float), (k,))
    out = np.array(need, float)
    live = np.flatnonzero(np.isfinite(step))        # an infinite step leaves the row as it is
    ar = _tent_dist(n)
    if live.size and (step[live] > 0.0).all():
        _tent_by_step(out, need, vf, step, live, ar, min(max_cells, TENT_CELLS))
        return out
    per = max(1, max_cells // max(n * (n + 2), 1))
    for a in range(0, live.size, per):
        r = live[a:a + per]
        side = (vf[r] + step[r])[:, None]
        pad = np.concatenate([side, need[r], side], axis=1)
        dist = step[r][:, None, None] * ar[None, :, :]
        out[r] = np.max(pad[:, None, :] - dist, axis=2)
    return out


TENT_CELLS = 1 << 19        # cells of one envelope block of _tent_by_step (4 MB)
TENT_GROUP_ROWS = 32        # _tent_by_step: rows a step value must have on average to share its products


def _tent_by_step(out, need, vf, step, live, ar, max_cells):
    """tent_feeds_rows' envelopes of rows `live` into out: rows of one step (all > 0)
    share their distance matrix step x |k - j| (the same products as each row's own),
    subtracted into one reused block (~2x faster on the gyroid plate's chains).  Steps
    are grouped by value: a step of 0 or -0 (which np.unique would take as one) goes the
    per-row way in tent_feeds_rows."""
    n = need.shape[1]
    steps = step[live]
    per = max(1, max_cells // max(n * (n + 2), 1))
    block = np.empty((min(per, live.size), n, n + 2))
    if (steps == steps[0]).all():
        groups = [(live, steps[0])]
    else:
        uniq, inv = np.unique(steps, return_inverse=True)
        if uniq.size * TENT_GROUP_ROWS > live.size:
            # groups of a few rows (lines under classic jerk: a step per direction): each
            # row's own products step x |k - j| into the block, then the same differences
            for a in range(0, live.size, per):
                r = live[a:a + per]
                side = (vf[r] + step[r])[:, None]
                pad = np.concatenate([side, need[r], side], axis=1)
                b = block[:r.size]
                np.multiply(step[r][:, None, None], ar[None, :, :], out=b)
                np.subtract(pad[:, None, :], b, out=b)
                out[r] = np.max(b, axis=2)
            return
        groups = [(live[inv == q], uniq[q]) for q in range(uniq.size)]
    for rows, st in groups:
        dist = st * ar
        for a in range(0, rows.size, per):
            r = rows[a:a + per]
            side = (vf[r] + step[r])[:, None]
            pad = np.concatenate([side, need[r], side], axis=1)
            b = block[:r.size]
            np.subtract(pad[:, None, :], dist[None, :, :], out=b)
            out[r] = np.max(b, axis=2)


def segment_feeds(v, v_feed, step_v=np.inf):
    """Feedrate (mm/s) of each segment: at least the faster of its two knot speeds (the
    ramp is set by the acceleration, F only caps it), and smooth from segment to segment.

    Marlin's classic jerk compares the NOMINAL speeds of consecutive moves, even
    collinear ones: F jumping by more than the jerk limit throttles the junction
    (planner.cpp, v_exit vs v_entry).  So with `step_v` finite, F is the tent envelope
    max_j(need_j - step_v*|k-j|), with the slicer's feed at both ends, so neighbouring
    F differ by <= step_v and the stroke meets its neighbours at their original F."""
    return tent_feeds(np.maximum(np.maximum(v[:-1], v[1:]), MIN_FEED_V), v_feed, step_v)


def tent_feeds(need, v_feed, step_v):
    """Feeds >= need (per segment) whose neighbours differ by <= step_v, the slicer's feed
    at both ends: the tent envelope max_j(need_j - step_v |k - j|)."""
    if not np.isfinite(step_v):
        return need
    n = len(need)
    dist = _tent_dist(n)
    pad = np.concatenate([[v_feed + step_v], need, [v_feed + step_v]])
    return np.maximum.reduce(pad[None, :] - step_v * dist, axis=1)


_TENT_DIST: dict[int, np.ndarray] = {}    # tent_feeds' distance matrices by segment count


def _tent_dist(n):
    """|k - j| for k segments and j = -1..n (the ends), cached by n."""
    dist = _TENT_DIST.get(n)
    if dist is None:
        dist = _TENT_DIST[n] = np.abs(np.arange(n)[:, None] - np.arange(-1, n + 1)[None, :])
    return dist


def _diff(x):
    """np.diff of a 1-D array (the same subtraction), without its per-call overhead:
    the segment planner calls it a few times per stroke on ~10 knots."""
    x = np.asarray(x)
    return x[1:] - x[:-1]


def predict(s, v, a):
    """How a constant-acceleration firmware executes the segments (s, v knots; a per
    segment): each ramps at a_k over |dv| (a_k may exceed the ramp's need) and cruises
    the rest.  Returns (time_t, int_a2) -- the figures to weigh against the original."""
    t, a, dv = segment_times(np.asarray(s), np.asarray(v), a)
    # np.add.reduce is what np.sum runs on a 1-D array (the same pairwise sum)
    return float(np.add.reduce(t)), float(np.add.reduce(a * dv))


def segment_times(s, v, a):
    """Per segment of knots s, v (along the last axis: one stroke, or rows of strokes) and
    accelerations a: (t, a, |dv|), the time a constant-acceleration firmware takes (ramp at
    a over |dv|, cruise the rest at the faster knot's speed), a floored at 1e-12.  The one
    formula of predict, segments._predict_rows, curves.predict_curve and _predict_rows."""
    d = s[..., 1:] - s[..., :-1]
    va, vb = v[..., :-1], v[..., 1:]
    dv = np.abs(vb - va)
    vmax = np.maximum(va, vb)
    a = np.maximum(a, 1e-12)
    ramp_d = np.abs(vb * vb - va * va) / (2.0 * a)
    return dv / a + np.maximum(d - ramp_d, 0.0) / np.maximum(vmax, 1e-9), a, dv


ROUND_TURN_D = 0.003      # mm: knots are written to ~3 decimals; the turn they add at a knot <= this / segment


def rounding_junction_accels(s, v):
    """Least acceleration of each segment so that the "straight" junctions inside a stroke
    pass their knot speed under Klipper's centripetal term once the knots are rounded to
    the file's digits: written points are off the line by up to ~0.0007 mm, a turn of up to
    ROUND_TURN_D / d at the knot, and Klipper limits v^2 <= 2 d a tan-ish(theta/2)/4 ~ d a /
    theta there (both segments' d a).  A near-cruise segment of a law ramps at ~0.1 mm/s^2:
    without this floor the firmware crawls at ~3 mm/s through such knots (seen on a real
    screw: 0.23 s planned, 0.87 s played)."""
    d = _diff(s)
    need = np.zeros(d.size)
    if d.size < 2:
        return need
    theta = ROUND_TURN_D / np.minimum(d[:-1], d[1:])          # at interior knots 1..K-1
    v2 = v[1:-1] ** 2
    need[:-1] = np.maximum(need[:-1], v2 * theta / d[:-1])
    need[1:] = np.maximum(need[1:], v2 * theta / d[1:])
    return need


def ramp_accels(s, v):
    """a_k that makes segment k one ramp from v_{k-1} to v_k."""
    d = _diff(s)
    v = np.asarray(v)
    return np.abs(_diff(v * v)) / (2.0 * d)


class SegmentRules:
    """What the firmware needs from segments (from the printer profile)."""

    def __init__(self, junction, n_max, seg_t, min_seg_d, min_move_d=0.0, flavour=""):
        self.junction, self.n_max, self.seg_t, self.min_seg_d = junction, n_max, seg_t, min_seg_d
        self.min_move_d = min_move_d     # shortest X/Y travel of a move the firmware keeps (Profile.min_move_d)
        self.flavour = flavour           # which junction command the firmware takes (corners.junction_commands)

    def min_edge_d(self, ux, uy):
        """The shortest lead-in / lead-out along direction (ux, uy): MIN_EDGE_D, and long
        enough that the firmware does not drop it (a dropped lead-in does not slow its
        corner; a dropped lead-out is joined with the next move and cuts the corner)."""
        if self.min_move_d <= 0.0:
            return MIN_EDGE_D
        # + the rounding of the written coordinates (3 decimals in the slicers' files)
        return max(MIN_EDGE_D, (self.min_move_d + ROUND_D) / max(abs(ux), abs(uy), 1e-12))

    @classmethod
    def for_profile(cls, profile, max_segments):
        n_max = max_segments
        if profile.block_buffer:         # a finite-lookahead planner must see the whole stroke
            n_max = min(n_max, max(profile.block_buffer - 4, 2))
        seg_t = max(profile.min_segment_time_t, 1.0 / profile.max_segment_rate)
        # Marlin's JD caps straight runs of blocks shorter than 1 mm at v^2 = d a / 0.033
        min_d = 1.0 if profile.junction == "jd" else MIN_SEG_D
        return cls(profile.junction, n_max, seg_t, min_d, getattr(profile, "min_move_d", 0.0), profile.flavour)


class SegmentPlan:
    """Knots, per-segment acceleration and feed, and the firmware's predicted figures.
    shape: "law" (segments follow the planned law) or "trapezoid" (one move, or collinear
    moves sharing one F and acceleration, played as the least-int-a^2 trapezoid)."""
    __slots__ = ("_s", "_v", "_accel", "_feed", "time_t", "int_a2", "shape", "first_cmds", "fault")

    def __init__(self, s, v, accel, feed, time_t, int_a2, shape="law", first_cmds=None):
        self._s, self._v, self._accel, self._feed, self.time_t, self.int_a2 = s, v, accel, feed, time_t, int_a2
        self.shape = shape
        self.fault = None                # schedule.seg_fault's verdict, once made
        self.first_cmds = first_cmds     # (before, after) the first move: a junction command (schedule.py)

    # the four arrays: a verdict is made on them (the planners make it as they build a plan:
    # fine_rows), so putting another array in their place drops it
    def _set(name):
        def put(self, x):
            setattr(self, name, x)
            self.fault = None
        return put

    s = property(lambda self: self._s, _set("_s"), doc="knots (mm from the stroke's start)")
    v = property(lambda self: self._v, _set("_v"), doc="speed at each knot (mm/s)")
    accel = property(lambda self: self._accel, _set("_accel"), doc="acceleration of each segment (mm/s^2)")
    feed = property(lambda self: self._feed, _set("_feed"), doc="feed of each segment (mm/s)")
    del _set


class RowPlan(SegmentPlan):
    """A SegmentPlan made with others at once: its four arrays are row `row` of the 2-D
    blocks it holds (S, V, A, F: the knots, speeds, accelerations and feeds of the plans
    made together), each read as that row (a view, the same numbers as the view a
    SegmentPlan of the rows held).  Four views a plan were ~0.4 kB of numpy objects (the
    rectilinear plate's ~36 k line plans held ~14 MB of them at the plan's peak); the
    blocks are held as the views held them.  Setting an array makes all four the plan's
    own (views of its rows), then the plan is as a SegmentPlan.

    S may instead be the stroke's own ends_d, an array of doubles (a chain's knots are 0
    then its vertices' distances: chains._replay): the knots are then made when read (the
    same doubles), not held a second time in a block (~2.5 MB of the gyroid plate's ~16 k
    chain plans, held from the first budget run to the rewrite)."""
    __slots__ = ("_row",)

    def __init__(self, S, V, A, F, row, time_t, int_a2, shape="law", first_cmds=None):
        # SegmentPlan.__init__'s fields set here (~68 k plans on the rectilinear plate's
        # budget runs: one Python call each, not two)
        self._s, self._v, self._accel, self._feed, self.time_t, self.int_a2 = S, V, A, F, time_t, int_a2
        self.shape, self.fault, self.first_cmds, self._row = shape, None, first_cmds, row

    def _set(name):
        def put(self, x):
            r = self._row
            if r is not None:            # the four rows made the plan's own, then SegmentPlan's setter
                self._s, self._v, self._accel, self._feed = self.s, self._v[r], self._accel[r], self._feed[r]
                self._row = None
            getattr(SegmentPlan, name).fset(self, x)
        return put

    def _knots(self):
        S, r = self._s, self._row
        return S if r is None else S[r] if type(S) is not array else knots_of_ends(S)

    s = property(_knots, _set("s"), doc=SegmentPlan.s.__doc__)
    v = property(lambda self: self._v if self._row is None else self._v[self._row], _set("v"),
                 doc=SegmentPlan.v.__doc__)
    accel = property(lambda self: self._accel if self._row is None else self._accel[self._row], _set("accel"),
                     doc=SegmentPlan.accel.__doc__)
    feed = property(lambda self: self._feed if self._row is None else self._feed[self._row], _set("feed"),
                    doc=SegmentPlan.feed.__doc__)
    del _set, _knots


def knots_of_ends(ends):
    """The knots 0, then ends (an array of doubles: a stroke's ends_d), as a float64 array
    (the same doubles)."""
    s = np.empty(len(ends) + 1)
    s[0] = 0.0
    s[1:] = ends
    return s


def plan_segments(strokes, T, beta, rules: SegmentRules):
    """Segments that make the firmware play each stroke's law (L, T, beta, v0, v1): a
    list with a SegmentPlan, or None where no plan beats the original.

    A stroke too short or quick for two segments, or whose segments would not beat the
    original trapezoid, gets the one-move trapezoid of the same duration with the least
    int a^2 (trapezoid.py) instead, when that beats the original."""
    m = len(strokes)
    # the fields law_knots and _segment_counts read, read once (one compiled pass, else a
    # C-level pass each)
    got = objfields.floats(strokes, ("length_d", "v0", "v1", "int_a2"))
    if got is not None:
        L, v0, v1, a2_orig = (np.ascontiguousarray(got[:, j]) for j in range(4))
    else:
        L, v0, v1, a2_orig = (np.fromiter(map(f, strokes), float, m) for f in (_LENGTH_D, _V0, _V1, _INT_A2))
    n = _segment_counts(strokes, T, rules, L)
    ok = np.flatnonzero(n >= 2)
    plans = [None] * m
    T, beta = np.asarray(T), np.asarray(beta)
    for a in range(0, ok.size, KNOT_CHUNK):       # bounded memory; every step is per stroke
        rows = ok[a:a + KNOT_CHUNK]
        rows_l = rows.tolist()
        sts = list(map(strokes.__getitem__, rows_l))
        knots = law_knots(sts, T[rows], beta[rows], n[rows], views=False, fields=(L[rows], v0[rows], v1[rows]))
        fast = (_finish_corner_rows if rules.junction in ("scv", "jd") else _finish_jerk_rows)(sts, knots, rules)
        pending = []
        if not fast.count(None):                  # every stroke made by the rows' path (plans[i] = got, in C)
            deque(map(plans.__setitem__, rows_l, fast), maxlen=0)
            continue
        for q, (i, got) in enumerate(zip(rows_l, fast)):
            if got is not None:                   # made by the rows' path
                plans[i] = got
                continue
            sk, vk = knots.at(q)
            got = _finish(sts[q], sk, vk, rules, defer=True)
            if got is not None:
                pending.append((i, got))
        made = _finish_feeds_and_figures([g for _, g in pending])
        if rules.junction == "jerk" and JERK_CORNERS:     # an end cut where its F would slow the corner
            made = _jerk_corner_plans([g[0] for _, g in pending], made, rules)
        for (i, _), plan in zip(pending, made):
            plans[i] = plan
    # the strokes with no plan, or one that does not beat the original (NaN: not below)
    a2_plan = np.fromiter([_NAN if p is None else p.int_a2 for p in plans], float, m)
    short = np.flatnonzero(~(a2_plan < a2_orig)).tolist()
    if short:
        rows = np.array(short, int)
        for i, p in zip(short, line_trapezoids([strokes[i] for i in short], T[rows], beta[rows], rules)):
            if p is not None and p.int_a2 < strokes[i].int_a2 and (plans[i] is None or p.int_a2 < plans[i].int_a2):
                plans[i] = p
    return plans


SAME_MAX_R = 0.8        # plan_once: worth it where the distinct plans are at most this share


def plan_once(plan_fn, strokes, T, beta, same, cmd=None):
    """plan_fn(strokes, T, beta) (plan_segments with its rules) of the strokes, the
    strokes of one line class (same: line_classes) at the same (T, beta) bytes planned
    once: the first of each, in order; the others take its plan (a copy, _twin, where
    the stroke may get a junction command of its own).
    Every step of plan_segments is per stroke (the SegmentCache reuses a line's plan
    across batches on that ground) and reads only what line_classes compares, so each
    copy is the plan the stroke would be given itself.  None where that is not worth it
    (more than SAME_MAX_R of the strokes distinct): the caller plans them all.  The
    rectilinear plate's budget runs planned ~38.7 k and ~29.5 k lines, of ~3.9 k and
    ~2.1 k distinct ones (its layers repeat).  cmd: the strokes' corner_cmd0 as a bool
    array, or None: read from them (_own_command_rows)."""
    m = len(strokes)
    if m < 2:
        return None
    T, beta = np.asarray(T), np.asarray(beta)
    if not (T.dtype == beta.dtype == _F64 and T.shape == beta.shape == (m,) and np.shape(same) == (m,)):
        return None
    # inv[q]: q's key (T, beta, class), keys equal in their 24 bytes (by a hash of the bytes,
    # not np.unique's sort of 24-byte records, ~2x its time); first[k]: key k's first stroke
    inv, first = column_classes_first([T.view(np.int64), beta.view(np.int64), np.asarray(same, np.int64)])
    if first.size > SAME_MAX_R * m:
        return None
    order = np.argsort(first)               # the keys in the order of their first stroke
    rows = first[order]
    place = np.empty_like(order)            # key -> its place in rows
    place[order] = np.arange(order.size)
    made = plan_fn([strokes[i] for i in rows.tolist()], T[rows], beta[rows])
    # each stroke's plan: the first's own object; a copy for a stroke whose start corners.py
    # slowed by a junction command (schedule._command_for puts that stroke's own command on
    # its plan: their figures and verdicts the same), the first's object for the others
    # (nothing else is set on a plan once made but its verdict, the same for the same
    # arrays: ~35 k and ~27 k copies in the rectilinear plate's first two budget runs)
    out = list(map(made.__getitem__, place[inv].tolist()))
    twin = np.ones(m, bool)
    twin[rows] = False
    own = (_own_command_rows(strokes, np.flatnonzero(twin).tolist()) if cmd is None
           else np.flatnonzero(twin & cmd).tolist())
    for q in own:
        out[q] = _twin(out[q])
    return out


def _own_command_rows(strokes, qs):
    """The rows of qs whose stroke may get a junction command of its own (corner_cmd0
    true, or no such field): read by map, not a getattr a row in a Python loop (~35 k
    twins in the rectilinear plate's first budget run, none of them such without
    --corners)."""
    sts = list(map(strokes.__getitem__, qs))
    try:
        return list(compress(qs, map(_CORNER_CMD0, sts)))
    except AttributeError:
        return [q for q, st in zip(qs, sts) if getattr(st, "corner_cmd0", True)]


def _twin(p):
    """A plan of its own with p's arrays (shared: no plan's arrays are written in place,
    only replaced: SegmentPlan's setters), figures, shape, commands and verdict."""
    if p is None:
        return None
    if type(p) is RowPlan:
        q = RowPlan(p._s, p._v, p._accel, p._feed, p._row, p.time_t, p.int_a2, p.shape, p.first_cmds)
    elif type(p) is SegmentPlan:
        q = SegmentPlan(p._s, p._v, p._accel, p._feed, p.time_t, p.int_a2, p.shape, p.first_cmds)
    else:
        return copy.copy(p)
    q.fault = p.fault
    return q


_LINE_FLOATS = ("length_d", "v0", "v1", "int_a2", "ux", "uy", "accel", "v_feed")
_LINE_MAYBE = ("_pux", "_puy", "_nux", "_nuy", "v0_fw", "v1_fw", "corner_cmd0", "corner_cmd1")


def line_classes(strokes):
    """An int per stroke: two strokes of one class have every field plan_segments reads
    (length_d, v0, v1, int_a2, ux, uy, accel, v_feed, the neighbours' directions, v0_fw,
    v1_fw, corner_cmd0 / corner_cmd1, lim's values: the scalars _finish_jerk_rows,
    _finish, _jerk_corner_rows, _corner_rows and line_trapezoids read) the same, bit for
    bit and of the same type, and one move each (ends_d is (length_d,): no vertex).
    Strokes of several moves, with a field of another type, or not Strokes, are each
    a class of their own.  Fields set after (schedule: a lead-out) need the stroke's
    class made its own again (schedule.SegmentCache.alone)."""
    m = len(strokes)
    if m == 0:
        return np.zeros(0, np.int64)
    if type(strokes) is not list:           # (a windowed sequence: read a chunk at a time)
        got = _classes_by_chunks(strokes)
        if got is not None:
            return got
        strokes = list(strokes)
    if set(map(type, strokes)) != {Stroke}:
        return np.arange(m, dtype=np.int64)
    first, last = line_spans(strokes)
    alone = last != first
    # the compiled core reads the fields of every stroke without a Python object a field
    # (its rows are taken as views: no more memory than the columns made below)
    names = _LINE_FLOATS + _LINE_MAYBE
    got = _stroke_columns(strokes, names + ("_ends",))
    if got is None or (got[1][-1] == 4).any():
        alone |= np.fromiter(map(_IS_NOT_NONE, map(_ENDS, strokes)), bool, m)
    else:
        alone |= got[1][-1] != 1            # ends_d kept: more than one move
    cols = []                               # float64 columns, compared by their bytes
    for j, name in enumerate(names):
        if got is not None and _core_column(got[0][j], got[1][j], cols):
            continue
        vals = list(map(attrgetter(name), strokes))
        types = set(map(type, vals))
        if types == {float}:
            cols.append(np.fromiter(vals, float, m))
        elif types == {_NONE_TYPE}:
            continue                        # (all None: nothing apart)
        elif types == {bool}:
            cols.append(np.fromiter(vals, bool, m).astype(float))
        elif types == {float, _NONE_TYPE}:
            # None apart from any float (NaN included): a column of which are None
            cols.append(np.array(vals, float))
            cols.append(np.fromiter(map(_IS_NONE, vals), bool, m).astype(float))
        else:                               # (values of other or mixed types: those strokes alone)
            odd = np.fromiter(map(_NOT_FLOAT, vals), bool, m)
            alone |= odd
            cols.append(np.array([0.0 if o else v for v, o in zip(vals, odd.tolist())], float))
    # lim: by its values (few distinct objects)
    ulims, which = objfields.by_identity(strokes, "lim")
    lim_k = np.array(_lim_places(ulims, {}), np.int64)[which]
    alone |= lim_k < 0
    # by the columns where they are (the core's are views of its table): a table of them
    # all, and row_classes' copy of its rows, were ~13 MB more on the rectilinear plate
    out = column_classes([np.asarray(c, float).view(np.int64) for c in cols] + [lim_k])
    k = np.flatnonzero(alone)
    out[k] = out.max() + 1 + np.arange(k.size)      # each a class of its own
    return out


def _lim_places(ulims, by_val):
    """line_classes' class of each limits object of ulims by its values (floats by their
    bytes; -1: not a Limits), numbered in by_val ({key: class}, grown) in the order met."""
    by_place = []
    for lim in ulims:
        try:
            key = tuple((type(v), np.float64(v).tobytes() if isinstance(v, float) else v)
                        for v in (getattr(lim, f) for f in _LIM_FIELDS))    # (floats by their bytes)
            by_place.append(by_val.setdefault(key, len(by_val)))
        except (AttributeError, TypeError):
            by_place.append(-1)
    return by_place


_CLASS_FIELDS = _LINE_FLOATS + _LINE_MAYBE + ("_ends",)     # (stroke_fields' names _classes_of_chunks reads)


def stored_line_classes(store, rows):
    """line_classes of the strokes of a StrokeStore's records rows (int64, sorted reads
    best), read from the records (StrokeStore.fields: no stroke made, no window loaded),
    or None where line_classes' reading of the strokes is needed (as _classes_of_chunks
    declines; lim neither a shared object nor None).  The store must hold the strokes as
    they are (stored_strokes.stored: held windows written back first)."""
    if len(rows) == 0:
        return np.zeros(0, np.int64)
    return _classes_of_chunks(len(rows), _store_chunks(store, rows))


def _store_chunks(store, rows):
    """_classes_of_chunks' chunks of the records rows of store (FIELD_ROWS at a time)."""
    w = len(_CLASS_FIELDS)
    for vals, kinds in store.fields(rows, _CLASS_FIELDS + ("first_idx", "last_idx", "lim"), FIELD_ROWS):
        lim_kind = kinds[:, -1]
        if not ((lim_kind == 5) | (lim_kind == 1)).all():        # (lim not a shared object or None)
            yield None
            return
        got = vals[:, :w], kinds[:, :w]
        got[1][got[1] == 5] = 3             # (a shared str in a float field: stroke_fields' another object)
        spans = vals[:, w:w + 2].view(np.int64)
        # lim's objects by identity, in the order first met (objfields.by_identity's): the
        # store's shared objects by their table index (-1: None)
        at = np.where(lim_kind == 5, vals[:, -1], -1.0).astype(np.int64)
        f, inv = unique_first_inverse(at)
        order = np.argsort(f, kind="stable")
        place = np.empty_like(order)
        place[order] = np.arange(order.size)
        u = [None if k < 0 else store.shared(k) for k in at[f[order]].tolist()]
        yield got, spans[:, 0], spans[:, 1], u, place[inv]


def _classes_by_chunks(strokes):
    """line_classes(strokes) of their fields read a chunk of strokes at a time (a windowed
    sequence of strokes loads a window at a time): _classes_of_chunks."""
    return _classes_of_chunks(len(strokes), _stroke_chunks(strokes))


def _stroke_chunks(strokes):
    """_classes_of_chunks' chunks of strokes (FIELD_ROWS at a time: strokes[a:b], a list;
    a windowed sequence of strokes loads a window at a time); None where the core declines
    or a stroke is not a Stroke."""
    for a in range(0, len(strokes), FIELD_ROWS):
        sts = strokes[a:a + FIELD_ROWS]
        got = stroke_fields(sts, _CLASS_FIELDS) if set(map(type, sts)) == {Stroke} else None
        if got is None:
            yield None
            return
        yield (got, *line_spans(sts), *objfields.by_identity(sts, "lim"))


def _classes_of_chunks(m, chunks):
    """line_classes of m strokes without the (17, m) table of every line's fields
    (rectilinear plate: 12.2 -> ~4 MB traced at its moment, the budget runs' first): the
    fields of a chunk of strokes at a time, each chunk (stroke_fields' (vals, kinds) of
    _CLASS_FIELDS, first_idx, last_idx, lim's distinct objects and each row's place among
    them: _stroke_chunks, _store_chunks) or None (declined), and only the distinct rows
    (fields' bits and kinds, lim's class: _Distinct) kept; the classes then made of those
    rows as line_classes makes them of every row (the same hash of each row, so the same
    numbering).  None (line_classes' own reading then) where a chunk is declined, a field
    is not one the core reads as line_classes does (another type; a bool beside a float or
    None), _ends unset, or two distinct rows share a hash."""
    w = len(_CLASS_FIELDS) - 1
    alone = np.zeros(m, bool)
    row_u = np.empty(m, np.int64)           # each row's distinct row
    rows = _Distinct()
    lim_at, by_val, lim_cls = {}, {}, []    # the limits objects met (by identity: their place) and classes
    a = 0
    for chunk in chunks:
        if chunk is None:
            return None
        got, first, last, u, which = chunk
        if (got[1][:, -1] == 4).any():
            return None
        new = [x for x in u if id(x) not in lim_at]
        lim_at.update(zip(map(id, new), range(len(lim_at), len(lim_at) + len(new))))
        lim_cls += _lim_places(new, by_val)
        lim_k = np.array(lim_cls, np.int64)[np.array([lim_at[id(x)] for x in u], np.intp)[which]]
        n = len(first)
        alone[a:a + n] = (last != first) | (got[1][:, -1] != 1) | (lim_k < 0)
        at = rows.add(_raw_rows(got[0][:, :w], got[1][:, :w], lim_k))
        if at is None:
            return None
        row_u[a:a + n] = at
        a += n
    # line_classes' columns of the distinct rows (a field's kinds there are its kinds over all)
    U = rows.columns()
    vals, kinds = U[:w].view(float), _kinds_of(U[w:-1], w)
    cols = []
    for j in range(w):
        if not _core_column(vals[j], kinds[j], cols):
            return None
    cols = [np.asarray(c, float).view(np.int64) for c in cols] + [U[-1]]     # (+ lim's class)
    del vals, kinds, U, rows
    # column_classes_first of every row's columns, the distinct rows' gathered: the same
    # hashes; a row is odd where its columns differ from its hash's first row's
    h = _row_hashes(cols)[row_u]
    f, inv = unique_first_inverse(h)
    del h
    out = inv.astype(np.int64)
    urep = row_u[f[inv]]
    q = np.flatnonzero(row_u != urep)       # (rows of one distinct row have the same columns)
    ur, urep = row_u[q], urep[q]
    odd = np.zeros(q.size, bool)
    for c in cols:
        odd |= c[ur] != c[urep]
    odd = q[odd]
    out[odd] = f.size + np.arange(odd.size)
    k = np.flatnonzero(alone)
    out[k] = out.max() + 1 + np.arange(k.size)      # each a class of its own
    return out


class _Distinct:
    """Distinct rows of an int64 table, added a chunk at a time (kept in the order first
    met), found by a hash of theirs (a wrapping sum of their entries' mixes) and checked
    equal entry by entry."""

    def __init__(self):
        self.rows, self.n = None, 0             # (capacity, width), rows kept
        self.sh = np.zeros(0, np.uint64)        # the kept rows' hashes, sorted
        self.sp = np.zeros(0, np.int64)         # and their places

    def add(self, R):
        """The place of each row of the table R (n, width) among the distinct rows, or None
        where two different rows share a hash."""
        h = R.view(np.uint64) * _ROW_MULT[:R.shape[1]]
        for k, c in _MIX:                   # (splitmix64's finish: a sum of products alone
            h ^= h >> k                     # let two sign bits' changes cancel)
            if c is not None:
                h *= c
        h = h.sum(axis=1, dtype=np.uint64)
        if not (self.n and h.size):
            return self._put(R, h, np.arange(h.size), np.empty(h.size, np.int64))
        # rows are gathered by take (a row a memcpy), not by fancy indexing (an item at a
        # time); a chunk whose rows were all met before (most of a plate's) is compared whole
        at = np.minimum(np.searchsorted(self.sh, h), self.sh.size - 1)
        hit = self.sh.take(at) == h
        q = np.flatnonzero(hit)
        if q.size == h.size:
            place = self.sp.take(at)
            return place if np.array_equal(self.rows.take(place, axis=0), R) else None
        place = np.empty(h.size, np.int64)
        place[q] = self.sp.take(at.take(q))
        if not np.array_equal(self.rows.take(place.take(q), axis=0), R.take(q, axis=0)):
            return None
        return self._put(R, h, np.flatnonzero(~hit), place)

    def _put(self, R, h, miss, place):
        """add's rows miss of R (hashes h), none met before: the distinct ones kept, each
        one's place written in place (None where two different rows share a hash)."""
        if not miss.size:
            return place
        Rm, hm = R.take(miss, axis=0), h.take(miss)
        f, inv = unique_first_inverse(hm)
        if not np.array_equal(Rm, Rm.take(f.take(inv), axis=0)):
            return None
        d = self.n
        place[miss] = d + inv
        self._grow(d + f.size, R.shape[1])
        self.rows[d:d + f.size] = Rm.take(f, axis=0)
        self.n += f.size
        sh = np.concatenate([self.sh, hm.take(f)])
        order = np.argsort(sh, kind="stable")
        self.sh, self.sp = sh.take(order), np.concatenate([self.sp, d + np.arange(f.size)]).take(order)
        return place

    def _grow(self, n, width):
        cap = 0 if self.rows is None else self.rows.shape[0]
        if n > cap:
            cap = max(n, 2 * cap, 1024)
            rows = np.empty((cap, width), np.int64)
            if self.n:
                rows[:self.n] = self.rows[:self.n]
            self.rows = rows

    def columns(self):
        """The distinct rows' columns (each contiguous)."""
        return np.ascontiguousarray(self.rows[:self.n].T)


# _Distinct's hash: an odd constant an entry (multiples of the golden ratio's, as distinct.py's;
# not numpy.random's, whose import cost ~30 M instructions a command)
_ROW_MULT = (np.arange(1, 65, dtype=np.uint64) * np.uint64(0x9E3779B97F4A7C15)) | np.uint64(1)
# (its last step has no product: splitmix64's is by 1)
_MIX = tuple((np.uint64(k), None if c is None else np.uint64(c))
             for k, c in ((30, 0xBF58476D1CE4E5B9), (27, 0x94D049BB133111EB), (31, None)))


def _raw_rows(vals, kinds, lim_k):
    """A chunk's rows as an int64 table (fields' bits, their kinds packed 8 an entry, lim's
    class): rows equal, equal everything line_classes reads of them."""
    n, w = kinds.shape
    pk = np.zeros((n, -(-w // 8) * 8), np.int8)
    pk[:, :w] = kinds
    return np.concatenate([vals.view(np.int64), pk.view(np.int64), lim_k[:, None]], axis=1)


def _kinds_of(packed, w):
    """_raw_rows' packed kinds (columns) back as (w, rows) int8."""
    pk = np.ascontiguousarray(np.asarray(packed).T).view(np.int8)
    return np.ascontiguousarray(pk[:, :w].T)


FIELD_ROWS = 4096        # strokes whose fields _stroke_columns reads at once (~0.6 MB of 17 fields)


def _stroke_columns(strokes, names):
    """strokes.stroke_fields' (vals, kinds) of the strokes transposed: (len(names), m), each
    field one contiguous row, or None where it declines.  line_classes hashes and compares
    them field by field: a contiguous pass, where the (m, 17) table's strided columns were
    ~3x the time (rectilinear plate: ~8 of its ~20 ms).  Read by chunks of FIELD_ROWS
    strokes into the transposed tables (the same values), so no (m, len(names)) table is
    held beside them."""
    m, w = len(strokes), len(names)
    vals, kinds = np.empty((w, m)), np.empty((w, m), np.int8)
    for a in range(0, m, FIELD_ROWS):
        got = stroke_fields(strokes[a:a + FIELD_ROWS], names)
        if got is None:
            return None
        vals[:, a:a + FIELD_ROWS], kinds[:, a:a + FIELD_ROWS] = got[0].T, got[1].T
    return vals, kinds


def _core_column(vals, kinds, cols):
    """line_classes' columns of one field from stroke_fields' vals and kinds of it,
    appended to cols as its loop makes them (the same doubles: a float's own, None's NaN, a
    bool's 1.0 / 0.0); False (nothing appended) for a mix that loop does not make so
    (another type, or a bool with a float or None: its `alone` case)."""
    kinds = kinds.view(np.uint8)
    if kinds.size and not kinds.max():      # {float} (most fields): a max, not bincount's intp copy
        cols.append(vals)
        return True
    seen = np.bincount(kinds, minlength=5)
    if seen[3] or seen[4] or (seen[2] and (seen[0] or seen[1])):
        return False
    if seen[0] or seen[2]:                  # {float}, {bool}, {float, None}
        cols.append(vals)
        if seen[1]:
            cols.append((kinds == 1).astype(float))
    return True                             # ({None}: nothing apart)


def row_classes(B):
    """A class per row of the int64 array B (m, w): rows of one class equal, entry for
    entry (column_classes of its columns)."""
    return column_classes([B[:, j] for j in range(B.shape[1])])


def _segment_counts(strokes, T, rules, L=None):
    """[segment_count(t, st.length_d, rules.n_max, rules.seg_t, rules.min_seg_d)] as an int
    array: the same truncated quotients and the same least of three (exact on floats that
    hold integers: n_max below 2^53); anything else (a quotient not finite, which int()
    refuses, a step not > 0, an n_max not an int) takes segment_count stroke by stroke.
    L: the strokes' lengths as a float array, when read already."""
    n_max, seg_t, min_d = rules.n_max, rules.seg_t, rules.min_seg_d
    if (len(strokes) and type(n_max) is int and 0 <= n_max < 2 ** 53 and isinstance(seg_t, float)
            and isinstance(min_d, float) and seg_t > 0 and min_d > 0 and np.ndim(T) == 1):
        if L is None:
            L = np.array([st.length_d for st in strokes], float)
        Tf = np.asarray(T, float)
        if L.ndim == 1 and Tf.shape == L.shape:
            with np.errstate(all="ignore"):
                q1, q2 = np.trunc(Tf / seg_t), np.trunc(L / min_d)
            if np.isfinite(q1).all() and np.isfinite(q2).all():
                nf = np.minimum(np.minimum(q1, q2), float(n_max))
                return np.maximum(nf, 0.0).astype(int)
    return np.array([segment_count(t, st.length_d, n_max, seg_t, min_d)
                     for st, t in zip(strokes, T)], dtype=int)


def _accel_top(stroke):
    """The highest acceleration a segment of this stroke may carry: the one in force,
    capped by the per-axis limits along its direction (plan_inputs' a_cap)."""
    a = stroke.accel
    if abs(stroke.ux) > 1e-12:
        a = min(a, stroke.lim.ax_max / abs(stroke.ux))
    if abs(stroke.uy) > 1e-12:
        a = min(a, stroke.lim.ay_max / abs(stroke.uy))
    return a


def _finish(stroke, sk, vk, rules, defer=False):
    """Accelerations (incl. what the corners need) and feeds for one stroke's knots.
    defer: up to the accelerations only (before hold_cruise_accels), (stroke, sk, vk, acc,
    step_v, slow0, slow1) for _finish_feeds_and_figures, which holds the cruises' accelerations
    and makes the feeds and figures of many at once."""
    u = (stroke.ux, stroke.uy)
    # a corner slower than FULL_STOP_V is a halt already: not worth an acceleration spike
    v0 = stroke.v0 if stroke.v0 >= FULL_STOP_V else 0.0
    v1 = stroke.v1 if stroke.v1 >= FULL_STOP_V else 0.0
    jd = stroke.lim.jd

    def needs(sk):
        return (accel_to_pass_junction(rules.junction, v0, stroke.prev_u, u, sk[1] - sk[0], jd),
                accel_to_pass_junction(rules.junction, v1, u, stroke.next_u, sk[-1] - sk[-2], jd))

    if rules.min_move_d > 0.0:
        # time-even knots crowd where the law is slow (into a stop, at a corner slowed to
        # ~1 mm/s by a command): no segment the firmware would drop
        sk, vk = _merge_short(sk, vk, rules.min_edge_d(*u), stroke.ends_d)
    acc = ramp_accels(sk, vk)
    need0, need1 = needs(sk)
    slow0, slow1 = slowed_ends(stroke)
    e0 = e1 = 0.0
    # Klipper's and Marlin's corner speeds scale with the entering block's acceleration:
    # a gently ramping first segment would slow the corner.  A lead-in at the corner speed
    # carries the acceleration the corner needs without changing speed.  An end slowed
    # below the firmware's junction speed (corners.py) needs one too: its feed, the corner
    # speed, is what makes the firmware slow down there.
    if need0 > acc[0] or need1 > acc[-1] or slow0 or slow1:
        e_min = rules.min_edge_d(*u)
        # (a corner slowed by a junction command needs neither: the command sets it)
        e0 = min(EDGE_D, max(stroke.v0 * EDGE_T, 0.05, e_min)) if (
            need0 > acc[0] and v0 >= EDGE_MIN_V and not stroke.corner_cmd0) or slow0 else 0.0
        e1 = min(EDGE_D, max(stroke.v1 * EDGE_T, 0.05, e_min)) if (
            need1 > acc[-1] and v1 >= EDGE_MIN_V and not stroke.corner_cmd1) or slow1 else 0.0
        # a lead-in squeezes the first ramp into a shorter segment: keep its acceleration
        # within what the machine allows (Marlin caps M204 at M201's limit: the ramp would
        # fall short of its knot)
        a_top = _accel_top(stroke)
        if slow0 or slow1:            # a slowed end must have its edge: make room for it
            sk, vk = _room_for_edges(sk, vk, e0 if slow0 else 0.0, e1 if slow1 else 0.0, a_top, stroke.ends_d)
        e0 = min(e0, 0.99 * max(_ramp_room(sk[1], vk[0], vk[1], a_top), 0.0), 0.4 * sk[1])
        e1 = min(e1, 0.99 * max(_ramp_room(sk[-1] - sk[-2], vk[-2], vk[-1], a_top), 0.0), 0.4 * (sk[-1] - sk[-2]))
        e0, e1 = (e if e >= e_min else 0.0 for e in (e0, e1))   # no sliver the firmware would drop
        sk, vk = with_edges(sk, vk, e0, e1)
        acc = ramp_accels(sk, vk)
        need0, need1 = needs(sk)
    acc[0] = max(acc[0], min(need0, stroke.accel))
    acc[-1] = max(acc[-1], min(need1, stroke.accel))
    if rules.junction == "jd":
        for k in range(1, len(acc)):
            need = accel_to_pass_junction("jd", vk[k], u, u, sk[k + 1] - sk[k], jd)
            acc[k] = max(acc[k], min(need, stroke.accel))
    if rules.junction == "scv":
        acc = np.maximum(acc, np.minimum(rounding_junction_accels(sk, vk), stroke.accel))
    step_v = np.inf
    if rules.junction == "jerk":         # per-axis jerk limit -> limit on the change of F
        step_v = jerk_step_v(stroke)
    if defer:                             # hold_cruise_accels too in _finish_feeds_and_figures
        if (slow0 and not e0) or (slow1 and not e1):
            return None                   # (as below)
        return stroke, sk, vk, acc, step_v, slow0, slow1
    acc = hold_cruise_accels(acc, stroke.accel)
    feeds = segment_feeds(vk, stroke.v_feed, step_v)
    if slow0 or slow1:
        if (slow0 and not e0) or (slow1 and not e1):
            return None                   # no room for the lead-in / lead-out: not as planned
        if slow0:
            feeds[0] = max(stroke.v0, MIN_FEED_V)
        if slow1:
            feeds[-1] = max(stroke.v1, MIN_FEED_V)
    t_pred, a2_pred = predict(sk, vk, acc)
    return SegmentPlan(sk, vk, acc, feeds, t_pred, a2_pred)


def jerk_step_v(st):
    """Under classic jerk, how far a segment's F may step from the next one's (mm/s): 0.9 of
    the smaller axis jerk over the stroke's larger direction component (segment_feeds)."""
    return 0.9 * min(st.lim.jerk_x, st.lim.jerk_y) / max(abs(st.ux), abs(st.uy))


def _finish_jerk_rows(strokes, knots, rules):
    """The SegmentPlans _finish(st, sk, vk, rules, defer=True) and _finish_feeds_and_figures
    make of the strokes that take _finish's plainest path, for all of one knot count at
    once (law_knots' own blocks as they are, _Knots.blocks; other rows stacked by knot count:
    _jerk_rows); None for the others (and for
    all of them under a junction law other than classic jerk), which go through _finish.

    The plainest path: classic jerk (accel_to_pass_junction gives 0.0 at both ends), no
    end slowed by corners.py, no knot merged by _merge_short (every segment at least
    min_edge_d long), and ramp accelerations at both ends not below 0 (0.0 > acc would
    add edges).  Then _finish computes ramp_accels (elementwise: the same here in rows),
    acc[0] = max(acc[0], min(0.0, accel)) and the same for acc[-1] (Python's max and min:
    np.where on the same comparisons), and step_v (jerk_step_v: _jerk_steps, the same
    operations), and returns the knots it was given.  ~68 k strokes on the rectilinear
    plate (law_knots, _finish_jerk_rows and the plans: ~20 µs each there, was ~29)."""
    if rules.junction != "jerk":
        return [None] * len(strokes)
    return _finish_rows(strokes, knots, rules, _jerk_rows)


def _finish_rows(strokes, knots, rules, rows_fn):
    """The walk _finish_jerk_rows and _finish_corner_rows share: rows_fn(S, V, sts, rules,
    knots) -> (the rows it took, their plans), or None, first on law_knots' own blocks as
    they are (_Knots.blocks: strokes of one move), then on the other strokes' knots stacked
    by knot count (knots: each row's own (sk, vk)).  Returns out[i] = plan, None for the
    strokes no rows_fn call took (they go through _finish)."""
    out = [None] * len(strokes)
    blocks = getattr(knots, "blocks", None) if type(knots) is _Knots else None
    left = None                        # the strokes no block took, once one did
    for g, S, V in blocks or ():
        if (type(S) is type(V) is np.ndarray and S.ndim == V.ndim == 2 and S.shape[1] >= 3
                and S.shape == V.shape and S.dtype == V.dtype == _F64):
            qs = g.tolist()
            if qs:
                if left is None:
                    left = np.ones(len(strokes), bool)
                left[qs] = False
            got = rows_fn(S, V, list(map(strokes.__getitem__, qs)), rules, None)
            if got is not None:        # out[qs[k]] = plan, in C
                deque(map(out.__setitem__, map(qs.__getitem__, got[0]), got[1]), maxlen=0)
    by_k = {}
    at = knots.at if type(knots) is _Knots else knots.__getitem__
    rest = range(len(strokes)) if left is None else np.flatnonzero(left).tolist()
    for q in rest:                     # the strokes no block took (few: several moves)
        sk, vk = at(q)
        if (type(sk) is type(vk) is np.ndarray and sk.ndim == vk.ndim == 1 and sk.size >= 3
                and sk.shape == vk.shape and sk.dtype == vk.dtype == _F64):
            by_k.setdefault(sk.size, []).append(q)
    for qs in by_k.values():
        kn = [at(q) for q in qs]
        got = rows_fn(np.stack([k[0] for k in kn]), np.stack([k[1] for k in kn]), [strokes[q] for q in qs],
                      rules, kn)
        if got is not None:
            deque(map(out.__setitem__, map(qs.__getitem__, got[0]), got[1]), maxlen=0)
    return out


def _not_slowed(sts):
    """[not any(slowed_ends(st)) for st in sts] as a bool array: all True, from two C-level
    passes, where no stroke has a firmware end speed (corners.py sets them only where it
    slows a corner; slowed_ends is (False, False) where both are None)."""
    m = len(sts)
    try:
        unset = list(map(_V0_FW, sts)).count(None) == m and list(map(_V1_FW, sts)).count(None) == m
    except AttributeError:
        unset = False
    if unset:
        return np.ones(m, bool)
    return np.array([not any(slowed_ends(st)) for st in sts], bool)


def _jerk_rows(S, V, sts, rules, knots=None):
    """_finish_jerk_rows of one knot count's rows S, V (float64 blocks; knots: each row's
    own (sk, vk) for its plan, else the blocks' rows): (rows taken, their SegmentPlans),
    or None where no row is taken.  The strokes' fields are read into arrays once: Python's
    min / max of two floats are np.where on the same comparison (the first one on a tie
    or a NaN), the divisions the same; a stroke whose jerk step divides by 0 goes stroke by
    stroke (jerk_step_v raises as _finish would)."""
    m = len(sts)
    keep = _not_slowed(sts)
    d = S[:, 1:] - S[:, :-1]
    # read once (the jerk steps and edges read ux, uy): one compiled pass, else one each
    got = objfields.floats(sts, ("ux", "uy", "accel"))
    if got is not None:
        ux, uy, accel = (np.ascontiguousarray(got[:, j]) for j in range(3))
    else:
        ux, uy, accel = (np.fromiter(map(f, sts), float, m) for f in (_UX, _UY, _ACCEL))
    if rules.min_move_d > 0.0:
        # _merge_short leaves the knots alone where the shortest segment is >= min_d
        min_d = _min_edge_d_rows(rules, sts, ux, uy)
        with np.errstate(invalid="ignore"):
            keep &= d.min(axis=1) >= min_d
    v2 = V * V
    with np.errstate(all="ignore"):
        acc = np.abs(v2[:, 1:] - v2[:, :-1]) / (2.0 * d)
        z = np.where(accel < 0.0, accel, 0.0)      # min(0.0, accel)
        edge = (0.0 > acc[:, 0]) | (0.0 > acc[:, -1])
        acc[:, 0] = np.where(z > acc[:, 0], z, acc[:, 0])
        acc[:, -1] = np.where(z > acc[:, -1], z, acc[:, -1])
    keep &= ~edge
    take = np.flatnonzero(keep)
    if not take.size:
        return None
    if take.size < m:
        S, V, acc = S.take(take, axis=0), V.take(take, axis=0), acc.take(take, axis=0)    # (np.take: the same rows)
        accel, ux, uy = accel[take], ux[take], uy[take]
        sts = [sts[k] for k in take.tolist()]
        if knots is not None:
            knots = [knots[k] for k in take.tolist()]
    step_v = _jerk_steps(sts, ux, uy)
    v_feed = np.fromiter(map(_V_FEED, sts), float, len(sts))
    core = _rows_core()
    if core is not None:
        A, feeds, t_pred, a2_pred, fine = _jerk_tail_core(core, S, V, acc, accel, step_v, v_feed)
    else:
        A, feeds, t_pred, a2_pred, fine = _jerk_tail(S, V, acc, accel, step_v, v_feed)
    if knots is None:
        m = len(t_pred)
        made = list(map(RowPlan, repeat(S, m), repeat(V, m), repeat(A, m), repeat(feeds, m), range(m), t_pred,
                        a2_pred))
        # settle_rows: the knots and speeds are rows of the float64 blocks S, V
        if type(A) is type(feeds) is np.ndarray and A.ndim == feeds.ndim == 2 and A.dtype is feeds.dtype is _F64:
            for plan in compress(made, fine):
                plan.fault = ""
    else:
        made = [SegmentPlan(sk, vk, a, f, t, a2) for (sk, vk), a, f, t, a2 in zip(knots, A, feeds, t_pred, a2_pred)]
        settle_rows(made, fine, A, feeds)
    if JERK_CORNERS:
        for k, plan in _jerk_corner_rows(sts, S, V, A, feeds, v_feed, step_v, ux, uy, rules).items():
            made[k] = plan               # an end cut where its F would slow the corner
    return take.tolist(), made


# ---- classic jerk: a re-timed stroke's end F must not lower its corner's junction ----------
# Marlin's classic jerk (firmware/junction.marlin_jerk_junction_v) takes the NEW block's
# nominal velocity vector as its entry velocity: where the neighbour is slower than this
# stroke's first F (a corner between moves at the slicer's F, F_0 lifted above it by the
# law's overshoot), a higher F_0 means a larger jerk and a SLOWER corner than the plan's v0,
# and with the law's gentle ramps the firmware lags all along the stroke (prusa_gyroid
# stroke 135: 16.1 mm/s instead of 18.9, +60 ms on 0.55 s).  The neighbour's nominal speed
# is not known here; at the slicer's F on both sides the junction is the original's exactly.
# So where the end F, under either plausible neighbour speed (this stroke's slicer F, or the
# planned corner speed itself), gives a slower junction than the plan's and than F = the
# slicer's, the end segment is cut where its ramp crosses the slicer's F: the part next to
# the corner is written at the slicer's F, the rest at its old F.  Both parts keep the ramp's
# acceleration: the same motion (time, int a^2), one more move.  A corner at the slicer's F
# itself (no crossing) gets the shortest lead-in the firmware keeps at that F, the ramp
# beyond it a little steeper (prusa_gyroid stroke 137: entered at 16.1 mm/s, not 20).
# prusa_gyroid under prusa-mk3s: the re-timed lines played +0.96 s over their prediction,
# now -0.01 s (firmware model), and the file takes one rewrite pass, not two.
JERK_KEEP_R = 1e-9       # relative: a junction this far below the planned corner speed is kept
JERK_CORNERS = True      # tests that pin the plans made before this step turn it off


_PUX, _PUY, _NUX, _NUY = (attrgetter(a) for a in ("_pux", "_puy", "_nux", "_nuy"))


def jerk_corner_fires(sts, F0, F1, v_feed, ux, uy):
    """Per stroke, does its first (last) segment's F lower its entry (exit) corner's
    classic-jerk junction below the plan's: (fire0, fire1) bool arrays.  Only an end F
    above the slicer's feed with a moving neighbour (and a corner speed >= EDGE_MIN_V) is
    looked at; the neighbour's nominal speed is taken as the slicer's feed and as the
    planned corner speed, and the end fires where either gives a junction below the planned
    corner speed AND below what the slicer's feed at that end gives (the original)."""
    m = len(sts)
    fire0, fire1 = np.zeros(m, bool), np.zeros(m, bool)
    for end, F in ((0, F0), (1, F1)):
        look = np.flatnonzero(F > v_feed)
        if not look.size:
            continue
        ss = [sts[k] for k in look.tolist()]
        gx, gy = (_PUX, _PUY) if end == 0 else (_NUX, _NUY)
        nx = [gx(st) for st in ss]
        has = np.array([x is not None for x in nx], bool)
        v_end = np.fromiter(map(_V0 if end == 0 else _V1, ss), float, len(ss))
        has &= v_end >= EDGE_MIN_V
        if not has.any():
            continue
        k = look[has]
        ss = [s for s, h in zip(ss, has.tolist()) if h]
        ox = np.array([x for x, h in zip(nx, has.tolist()) if h], float)
        oy = np.fromiter(map(gy, ss), float, len(ss))
        v_end, F_end, vf = v_end[has], F[k], v_feed[k]
        lims = list(map(_LIM, ss))
        jx = np.fromiter(map(_JERK_X, lims), float, len(ss))
        jy = np.fromiter(map(_JERK_Y, lims), float, len(ss))
        bad = np.zeros(k.size, bool)
        for p_nom in (vf, v_end):
            if end == 0:           # the neighbour enters the corner, this stroke leaves it
                j_new = marlin_jerk_junction_v_rows(ox, oy, p_nom, ux[k], uy[k], F_end, jx, jy)
                j_old = marlin_jerk_junction_v_rows(ox, oy, p_nom, ux[k], uy[k], vf, jx, jy)
            else:
                j_new = marlin_jerk_junction_v_rows(ux[k], uy[k], F_end, ox, oy, p_nom, jx, jy)
                j_old = marlin_jerk_junction_v_rows(ux[k], uy[k], vf, ox, oy, p_nom, jx, jy)
            bad |= (j_new < v_end * (1.0 - JERK_KEEP_R)) & (j_new < j_old)
        (fire0 if end == 0 else fire1)[k[bad]] = True
    return fire0, fire1


def jerk_keep_corner(st, sk, vk, acc, feeds, fire0, fire1, step_v, rules):
    """The segments (sk, vk, acc, feeds) with the first (fire0) / last (fire1) segment cut
    where its ramp crosses the slicer's feed, the part at the corner written at that feed:
    the same ramp, the same acceleration.  Where the corner is at the slicer's feed already
    (or the crossing is nearer than the firmware keeps a move), the part at the corner is
    the shortest lead-in the firmware keeps (>= 0.05 mm, as _finish's edges), and the ramp
    beyond it steepens to reach its knot (both parts at that acceleration: one M204; not
    above the machine's cap).  A SegmentPlan, or None where no end can be cut (the ramp
    does not rise above the slicer's feed, no room, or the old F is more than a jerk step
    above the slicer's feed: the cut's own junction would slow)."""
    vf = st.v_feed
    e_min = rules.min_edge_d(st.ux, st.uy)
    sk, vk = np.asarray(sk, float), np.asarray(vk, float)
    acc, feeds = np.asarray(acc, float), np.asarray(feeds, float)
    cut = False
    for end, fire in ((0, fire0), (1, fire1)):
        if not fire:
            continue
        if end == 0:
            va, vb, d, F, a = vk[0], vk[1], sk[1] - sk[0], feeds[0], acc[0]
        else:
            va, vb, d, F, a = vk[-1], vk[-2], sk[-1] - sk[-2], feeds[-1], acc[-1]
        if not (va <= vf < vb) or F - vf > step_v:
            continue
        e = d * (vf * vf - va * va) / (vb * vb - va * va)     # v^2 is linear in s on the ramp
        if e < e_min:                  # a lead-in the firmware keeps; the ramp beyond it steeper
            e = max(e_min, 0.05)
            if e > 0.4 * d:
                continue
            a = max(a, (vb * vb - vf * vf) / (2.0 * (d - e)))
            if a > _accel_top(st):
                continue
        elif d - e < e_min:
            continue
        if end == 0:
            sk = np.concatenate([[sk[0], sk[0] + e], sk[1:]])
            vk = np.concatenate([[va, vf], vk[1:]])
            acc = np.concatenate([[a, a], acc[1:]])
            feeds = np.concatenate([[vf], feeds])
        else:
            sk = np.concatenate([sk[:-1], [sk[-1] - e, sk[-1]]])
            vk = np.concatenate([vk[:-1], [vf, va]])
            acc = np.concatenate([acc[:-1], [a, a]])
            feeds = np.concatenate([feeds, [vf]])
        cut = True
    if not cut:
        return None
    t_pred, a2_pred = predict(sk, vk, acc)
    return SegmentPlan(sk, vk, acc, feeds, t_pred, a2_pred)


def _jerk_corner_rows(sts, S, V, A, F, v_feed, step_v, ux, uy, rules):
    """{row: SegmentPlan} of the rows (one knot count's blocks, _jerk_rows) whose end F
    would lower a corner (jerk_corner_fires), cut by jerk_keep_corner: the rows where one
    end fires by _keep_corner_rows (all of them on the corpus plates), the others (both
    ends: the second cut reads the first's knots) stroke by stroke."""
    fire0, fire1 = jerk_corner_fires(sts, F[:, 0], F[:, -1], v_feed, ux, uy)
    out = {}
    for end, only in ((0, fire0 & ~fire1), (1, fire1 & ~fire0)):
        k = np.flatnonzero(only)
        if k.size:
            out.update(_keep_corner_rows([sts[q] for q in k.tolist()], k, end, S[k], V[k], A[k], F[k],
                                         v_feed[k], step_v[k], ux[k], uy[k], rules))
    for k in np.flatnonzero(fire0 & fire1).tolist():
        got = jerk_keep_corner(sts[k], S[k], V[k], A[k], F[k], fire0[k], fire1[k], step_v[k], rules)
        if got is not None:
            out[k] = got
    return out


def _keep_corner_rows(sts, rows, end, S, V, A, F, vf, step_v, ux, uy, rules):
    """{rows[q]: jerk_keep_corner(sts[q], S[q], V[q], A[q], F[q], end == 0, end == 1,
    step_v[q], rules)} of the strokes whose end `end` alone fires (S, V (m, K) knots, A, F
    (m, K - 1); vf, ux, uy the strokes' v_feed and direction), those cut only: its
    arithmetic on the rows at once (elementwise, the same operations; Python's max(x, y)
    as np.where(y > x, y, x); its tests where they hold, a NaN's included), _accel_top
    stroke by stroke where it is asked, and predict's sums by _predict_rows (each row's in
    the 1-D order).  The plans' arrays are rows of one block (m', K + 1) each (~17 us a
    stroke by jerk_keep_corner: ~350 strokes a budget run on the rectilinear plate)."""
    m, K = S.shape
    e_min = _min_edge_d_rows(rules, sts, ux, uy)
    c = -1 if end else 0                       # the cut end's knot, its neighbour c + sign
    nb = -2 if end else 1
    va, vb, a = V[:, c], V[:, nb], A[:, c]
    d = (S[:, c] - S[:, nb]) if end else (S[:, nb] - S[:, c])
    with np.errstate(all="ignore"):
        ok = (va <= vf) & (vf < vb) & ~(F[:, c] - vf > step_v)
        e = d * (vf * vf - va * va) / (vb * vb - va * va)     # v^2 is linear in s on the ramp
        short = e < e_min                      # a lead-in the firmware keeps; the ramp beyond it steeper
        e_s = np.where(0.05 > e_min, 0.05, e_min)
        ok &= np.where(short, ~(e_s > 0.4 * d), ~(d - e < e_min))
        x = (vb * vb - vf * vf) / (2.0 * (d - e_s))
        a = np.where(short & (x > a), x, a)
        e = np.where(short, e_s, e)
    for q in np.flatnonzero(short & ok).tolist():
        if a[q] > _accel_top(sts[q]):
            ok[q] = False
    q = np.flatnonzero(ok)
    if not q.size:
        return {}
    S, V, A, F, e, a, va, vf = (x.take(q, axis=0) for x in (S, V, A, F, e, a, va, vf))
    n = q.size
    Sb, Vb, Ab, Fb = np.empty((n, K + 1)), np.empty((n, K + 1)), np.empty((n, K)), np.empty((n, K))
    if end == 0:                               # [s0, s0 + e, s1 ...], [va, vf, v1 ...], [a, a, a1 ...], [vf, F ...]
        Sb[:, 0], Sb[:, 1], Sb[:, 2:] = S[:, 0], S[:, 0] + e, S[:, 1:]
        Vb[:, 0], Vb[:, 1], Vb[:, 2:] = va, vf, V[:, 1:]
        Ab[:, 0], Ab[:, 1], Ab[:, 2:] = a, a, A[:, 1:]
        Fb[:, 0], Fb[:, 1:] = vf, F
    else:                                      # [... s_-2, s_-1 - e, s_-1], [... v_-2, vf, va], [... a, a], [F ..., vf]
        Sb[:, :K - 1], Sb[:, K - 1], Sb[:, K] = S[:, :-1], S[:, -1] - e, S[:, -1]
        Vb[:, :K - 1], Vb[:, K - 1], Vb[:, K] = V[:, :-1], vf, va
        Ab[:, :K - 2], Ab[:, K - 2], Ab[:, K - 1] = A[:, :-1], a, a
        Fb[:, :K - 1], Fb[:, K - 1] = F, vf
    t_pred, a2_pred = _predict_rows(Sb, Vb, Ab)
    return {r: SegmentPlan(sb, vb_, ab, fb, t, a2)
            for r, sb, vb_, ab, fb, t, a2 in zip(rows[q].tolist(), Sb, Vb, Ab, Fb, t_pred, a2_pred)}


def _jerk_corner_plans(sts, plans, rules):
    """jerk_keep_corner on SegmentPlans of shape "law" (_finish's): the plans, each replaced
    where an end was cut."""
    rows = [k for k, p in enumerate(plans) if p is not None and p.shape == "law" and len(p.feed) >= 1]
    if not rows:
        return plans
    ss = [sts[k] for k in rows]
    F0 = np.array([plans[k].feed[0] for k in rows], float)
    F1 = np.array([plans[k].feed[-1] for k in rows], float)
    vf = np.fromiter(map(_V_FEED, ss), float, len(ss))
    ux = np.fromiter(map(_UX, ss), float, len(ss))
    uy = np.fromiter(map(_UY, ss), float, len(ss))
    fire0, fire1 = jerk_corner_fires(ss, F0, F1, vf, ux, uy)
    out = list(plans)
    for q in np.flatnonzero(fire0 | fire1).tolist():
        k, p = rows[q], plans[rows[q]]
        got = jerk_keep_corner(sts[k], p.s, p.v, p.accel, p.feed, fire0[q], fire1[q], jerk_step_v(sts[k]), rules)
        if got is not None:
            out[k] = got
    return out


def _jerk_tail(S, V, acc, accel, step_v, v_feed):
    """_jerk_rows' plans' arrays from the taken rows' knots S, V, ramp accelerations acc
    (m, K - 1), own accelerations, jerk steps and feeds: (A held, feeds, t_pred, a2_pred,
    fine) as lists for the figures and verdicts (numpy; the compiled core's jerk_tail
    makes the same bits)."""
    A = hold_cruise_accels_rows(acc, accel)
    need = np.maximum(np.maximum(V[:, :-1], V[:, 1:]), MIN_FEED_V)
    feeds = tent_feeds_rows(need, v_feed, step_v)
    t_pred, a2_pred = _predict_rows(S, V, A)
    return A, feeds, t_pred, a2_pred, fine_rows(S, V, A, feeds, t_pred, a2_pred)


def _jerk_tail_core(core, S, V, acc, accel, step_v, v_feed):
    """_jerk_tail in one compiled call a block (firmware/_core.c jerk_tail: every row's
    held accelerations, tent feeds, segment times, pairwise sums and checks as numpy makes
    them, the same operations in the same order; tests/test_speed26_linec_tail.py).  The
    numpy path made ~25 calls a block on (m, K) arrays and an (m, K - 1, K + 1) envelope:
    ~0.09 s of the rectilinear plate's ~68 k line plans, ~0.01 s here."""
    m, K = S.shape
    f64 = np.float64
    S, V, acc = (np.ascontiguousarray(x, f64) for x in (S, V, acc))
    own, step, vf = (np.ascontiguousarray(np.broadcast_to(np.asarray(x, f64), (m,))) for x in (accel, step_v, v_feed))
    A = np.empty((m, K - 1))
    feeds = np.empty((m, K - 1))
    t = np.empty(m)
    a2 = np.empty(m)
    fine = np.empty(m, np.uint8)
    core.jerk_tail(S, V, acc, own, step, vf, K, MIN_FEED_V, CRUISE_A, A, feeds, t, a2, fine)
    return A, feeds, t.tolist(), a2.tolist(), fine.astype(bool).tolist()


USE_CORE = True         # tests turn it off: _jerk_rows' tail by numpy (the reference)


def _rows_core():
    """The compiled core (firmware/_core.c) when it has jerk_tail, else None: not built,
    stale, GCODE_OPT_PURE_PYTHON, or USE_CORE off."""
    if not USE_CORE:
        return None
    from .firmware import simulate
    core = simulate._core
    return core if core is not None and hasattr(core, "jerk_tail") else None


def _jerk_steps(sts, ux=None, uy=None):
    """[jerk_step_v(st) for st in sts] as an array (the same min, max, product and quotient).
    ux, uy: the strokes' directions as float arrays, when read already."""
    m = len(sts)
    lims, which = objfields.by_identity(sts, "lim")     # (their few limits objects read once, gathered: the same floats)
    jx = np.fromiter(map(_JERK_X, lims), float, len(lims))[which]
    jy = np.fromiter(map(_JERK_Y, lims), float, len(lims))[which]
    ax = np.abs(np.fromiter(map(_UX, sts), float, m) if ux is None else ux)
    ay = np.abs(np.fromiter(map(_UY, sts), float, m) if uy is None else uy)
    mn = np.where(jy < jx, jy, jx)
    mx = np.where(ay > ax, ay, ax)
    if (mx == 0.0).any():
        return np.array([jerk_step_v(st) for st in sts], float)
    with np.errstate(all="ignore"):
        return 0.9 * mn / mx


_F64 = np.dtype(float)
# the strokes' fields the row paths read, each in one C-level pass (map) over the strokes
_V0_FW, _V1_FW, _UX, _UY = (attrgetter(a) for a in ("v0_fw", "v1_fw", "ux", "uy"))
_ACCEL, _V_FEED, _LIM, _JERK_X, _JERK_Y = (attrgetter(a) for a in ("accel", "v_feed", "lim", "jerk_x", "jerk_y"))
_LENGTH_D, _V0, _V1, _INT_A2 = (attrgetter(a) for a in ("length_d", "v0", "v1", "int_a2"))
_NAN = float("nan")
_ENDS = attrgetter("_ends")
_CORNER_CMD0 = attrgetter("corner_cmd0")
_LIM_FIELDS = ("v_max", "ax_max", "ay_max", "scv", "mcr", "jd", "jerk_x", "jerk_y")


_IS_NOT_NONE, _IS_NONE = partial(is_not, None), partial(is_, None)


def _NOT_FLOAT(x):
    return type(x) is not float


_NONE_TYPE = type(None)
_JD, _AX_MAX, _AY_MAX, _PREV_U, _NEXT_U = (attrgetter(a) for a in ("jd", "ax_max", "ay_max", "prev_u", "next_u"))
_PUX, _PUY, _NUX, _NUY, _CMD0, _CMD1 = (attrgetter(a) for a in ("_pux", "_puy", "_nux", "_nuy", "corner_cmd0",
                                                                 "corner_cmd1"))


def _min_edge_d_rows(rules, sts, ux=None, uy=None):
    """[rules.min_edge_d(st.ux, st.uy) for st in sts] as an array: for finite directions
    Python's max and np.maximum give the same float, and the division is the same; a
    stroke with a direction that is not finite takes min_edge_d itself.  ux, uy: the
    strokes' directions as float arrays, when read already."""
    if rules.min_move_d <= 0.0:
        return np.full(len(sts), MIN_EDGE_D)
    ax = np.abs(np.array([st.ux for st in sts], float) if ux is None else ux)
    ay = np.abs(np.array([st.uy for st in sts], float) if uy is None else uy)
    with np.errstate(all="ignore"):
        out = np.maximum(MIN_EDGE_D, (rules.min_move_d + ROUND_D) / np.maximum(np.maximum(ax, ay), 1e-12))
    odd = ~(np.isfinite(ax) & np.isfinite(ay))
    for k in np.flatnonzero(odd).tolist():
        out[k] = rules.min_edge_d(sts[k].ux, sts[k].uy)
    return out


def _finish_feeds_and_figures(pending):
    """The rest of _finish for many strokes (its defer=True results): segment_feeds, the
    slowed ends' feeds and predict, after hold_cruise_accels (hold_cruise_accels_rows), for
    all strokes of one knot count at once (the same elementwise arithmetic, exact maxima,
    per-row sums in the 1-D sums' order); a SegmentPlan each, in order."""
    out = [None] * len(pending)
    by_k = {}
    for q, p in enumerate(pending):
        by_k.setdefault(p[1].size, []).append(q)
    for qs in by_k.values():
        grp = [pending[q] for q in qs]
        S = np.stack([p[1] for p in grp])
        V = np.stack([p[2] for p in grp])
        for q, plan in zip(qs, _block_plans([p[:3] for p in grp], S, V, np.stack([p[3] for p in grp]),
                                            [p[4] for p in grp], [p[5:7] for p in grp])):
            out[q] = plan
    return out


def _block_plans(grp, S, V, acc, step_v, slow):
    """SegmentPlans of strokes of one knot count: grp [(stroke, sk, vk)], their knots and
    speeds S, V (rows), accelerations acc before hold_cruise_accels, step_v per row, slow
    [(slow0, slow1)] per row or None (no slowed end)."""
    A = hold_cruise_accels_rows(acc, np.array([g[0].accel for g in grp], float))
    need = np.maximum(np.maximum(V[:, :-1], V[:, 1:]), MIN_FEED_V)
    feeds = tent_feeds_rows(need, np.array([g[0].v_feed for g in grp], float), np.array(step_v, float))
    t_pred, a2_pred = _predict_rows(S, V, A)
    fine = fine_rows(S, V, A, feeds, t_pred, a2_pred)
    made = []
    for k, ((st, sk, vk), acc_k, f, t, a2) in enumerate(zip(grp, A, feeds, t_pred, a2_pred)):
        if slow is not None:
            slow0, slow1 = slow[k]
            if slow0:
                f[0] = max(st.v0, MIN_FEED_V)
            if slow1:
                f[-1] = max(st.v1, MIN_FEED_V)
            if slow0 or slow1:
                fine[k] = False                   # (a slowed end's feed was set after the check)
        made.append(SegmentPlan(sk, vk, acc_k, f, t, a2))
    settle_rows(made, fine, A, feeds)
    return made


def fine_rows(S, V, A, F, t, a2):
    """Per row of the knots S, V (m, K), accelerations A and feeds F (m, K - 1) and the
    figures t, a2 (m floats): does a SegmentPlan of these pass every check of
    schedule.seg_fault (every number finite, K >= 2, knots strictly increasing, speeds
    >= 0, accelerations and feeds > 0)?  A list of bools, made on the blocks the planner
    already has (schedule.settle_faults made them again from each plan's four arrays).
    b > a is b - a > 0 for finite floats (np.diff's subtraction: exact in sign)."""
    m, K = S.shape
    if K < 2 or A.shape != (m, K - 1) or F.shape != (m, K - 1) or V.shape != (m, K):
        return [False] * m
    with np.errstate(invalid="ignore", over="ignore"):
        ok = (np.isfinite(S).all(axis=1) & (S[:, 1:] > S[:, :-1]).all(axis=1)
              & np.isfinite(V).all(axis=1) & (V >= 0.0).all(axis=1)
              & np.isfinite(A).all(axis=1) & (A > 0.0).all(axis=1)
              & np.isfinite(F).all(axis=1) & (F > 0.0).all(axis=1)
              & np.isfinite(np.array(t, float)) & np.isfinite(np.array(a2, float)))
    return ok.tolist()


def settled(plan):
    """Keep seg_fault's verdict "" on a plan fine_rows passed, when its four arrays are the
    1-D float64 arrays whose values fine_rows checked (as _seg_fault takes them)."""
    s, v, a, f = plan._s, plan._v, plan._accel, plan._feed
    if (type(s) is type(v) is type(a) is type(f) is np.ndarray and s.ndim == v.ndim == a.ndim == f.ndim == 1
            and s.dtype is v.dtype is a.dtype is f.dtype is _F64):
        plan.fault = ""


def settle_rows(plans, fine, A, F):
    """settled() of each plan whose fine is True, whose accelerations and feeds are rows of
    the 2-D float64 blocks A and F (checked once here), and whose knots and speeds are
    1-D float64 arrays."""
    if not (type(A) is type(F) is np.ndarray and A.ndim == F.ndim == 2 and A.dtype is F.dtype is _F64):
        return
    nd = np.ndarray
    for plan, ok in zip(plans, fine):
        if ok:
            s, v = plan._s, plan._v
            if type(s) is nd and type(v) is nd and s.ndim == 1 and v.ndim == 1 and s.dtype is v.dtype is _F64:
                plan.fault = ""


def _predict_rows(S, V, A):
    """predict() of every row of knots S, V (m, K) and accelerations A (m, K - 1): the
    same operations, each row's sums added in np.add.reduce's 1-D order (numpy's
    pairwise sum runs per row): two lists of floats."""
    t, a, dv = segment_times(S, V, A)
    return np.add.reduce(t, axis=1).tolist(), np.add.reduce(a * dv, axis=1).tolist()


# ------------------------------------------------------- Klipper scv / Marlin JD lines in rows
def _finish_corner_rows(strokes, knots, rules):
    """_finish_jerk_rows for the junction laws whose corners need an acceleration (Klipper
    "scv", Marlin "jd"): the SegmentPlans _finish(st, sk, vk, rules, defer=True) and
    _finish_feeds_and_figures make, as RowPlans, for the strokes _corner_rows takes (all of
    one knot count at once); None for the others (slowed ends, knots _merge_short would
    merge, a junction whose per-stroke form raises), which go through _finish."""
    if rules.junction not in ("scv", "jd"):
        return [None] * len(strokes)
    return _finish_rows(strokes, knots, rules, _corner_rows)


def _corner_rows(S, V, sts, rules, knots=None):
    """_finish(defer=True) + _finish_feeds_and_figures of the strokes sts whose knots are
    the rows of S, V (float64, (m, K + 1), K >= 2) under rules.junction "scv" or "jd":
    the rows taken.  Taken: no end slowed by corners.py (slowed_ends:
    _room_for_edges' loop), knots _merge_short leaves alone (every segment at least
    min_edge_d), every junction need computed without a division by zero.  Every step is
    _finish's on arrays: accel_to_pass_junction_rows for the junctions, Python's min / max
    as np.where on the same comparisons (_py_min / _py_max), _ramp_room's powers (libm
    pow, which is not always x * x) on Python floats, with_edges' knots put in by rows of
    one edge pattern, then _block_plans' steps (no jerk step: the feeds are the needs).
    Returns (rows taken, their RowPlans).  knots: not read (the plans are rows of S, V;
    _finish_rows' signature)."""
    m = len(sts)
    junction = rules.junction
    keep = _not_slowed(sts)
    ux = np.fromiter(map(_UX, sts), float, m)
    uy = np.fromiter(map(_UY, sts), float, m)
    d = S[:, 1:] - S[:, :-1]
    e_min = _min_edge_d_rows(rules, sts, ux, uy)
    if rules.min_move_d > 0.0:           # _merge_short leaves the knots alone where the shortest is >= min_d
        with np.errstate(invalid="ignore"):
            keep &= d.min(axis=1) >= e_min
    sv0 = np.fromiter(map(_V0, sts), float, m)
    sv1 = np.fromiter(map(_V1, sts), float, m)
    v0 = np.where(sv0 >= FULL_STOP_V, sv0, 0.0)
    v1 = np.where(sv1 >= FULL_STOP_V, sv1, 0.0)
    lims = list(map(_LIM, sts))
    jd = np.fromiter(map(_JD, lims), float, m)
    pux, puy, has_p, nux, nuy, has_n = _neighbour_dirs(sts)

    def needs(D):
        n0, odd0 = accel_to_pass_junction_rows(junction, v0, pux, puy, has_p, ux, uy, D[:, 0], jd)
        n1, odd1 = accel_to_pass_junction_rows(junction, v1, ux, uy, has_n, nux, nuy, D[:, -1], jd)
        return n0, n1, odd0 | odd1

    with np.errstate(all="ignore"):
        acc = np.abs((V * V)[:, 1:] - (V * V)[:, :-1]) / (2.0 * d)       # ramp_accels
        need0, need1, odd = needs(d)
    keep &= ~odd
    take = np.flatnonzero(keep)
    if not take.size:
        return [], []
    if take.size < m:
        tl = take.tolist()
        S, V, d, acc = (x.take(take, axis=0) for x in (S, V, d, acc))     # (np.take: the same rows)
        need0, need1 = need0[take], need1[take]
        sts = [sts[k] for k in tl]
        lims = [lims[k] for k in tl]
        (ux, uy, e_min, sv0, sv1, v0, v1, jd, has_p, has_n, pux, puy, nux, nuy) = (
            x[take] for x in (ux, uy, e_min, sv0, sv1, v0, v1, jd, has_p, has_n, pux, puy, nux, nuy))
    mt = take.size
    accel = np.fromiter(map(_ACCEL, sts), float, mt)
    # the lead-in / lead-out lengths where a corner needs more than the end's ramp carries
    e0 = np.zeros(mt)
    e1 = np.zeros(mt)
    c0 = need0 > acc[:, 0]
    c1 = need1 > acc[:, -1]
    if (c0 | c1).any():
        cmd0, cmd1 = _corner_cmds(sts)
        with np.errstate(all="ignore"):
            a_top = _accel_top_rows(sts, lims, accel, ux, uy)
            for e, c, sv, vv, cmd, first in ((e0, c0, sv0, v0, cmd0, True), (e1, c1, sv1, v1, cmd1, False)):
                on = np.flatnonzero((c0 | c1) & c & (vv >= EDGE_MIN_V) & ~cmd)
                if not on.size:
                    continue
                x = _py_max(_py_max(sv[on] * EDGE_T, 0.05), e_min[on])
                x = _py_min(EDGE_D, x)
                if first:
                    seg_d, va, vb = S[on, 1], V[on, 0], V[on, 1]          # sk[1], vk[0], vk[1]
                else:
                    seg_d, va, vb = S[on, -1] - S[on, -2], V[on, -2], V[on, -1]
                room = np.array([dd - abs(b ** 2 - a ** 2) / (2.0 * at) for dd, a, b, at in
                                 zip(seg_d.tolist(), va.tolist(), vb.tolist(), a_top[on].tolist())], float)
                x = _py_min(_py_min(x, 0.99 * _py_max(room, 0.0)), 0.4 * seg_d)
                e[on] = np.where(x >= e_min[on], x, 0.0)
    rows, plans = [], []
    for b0 in (False, True):             # rows of one edge pattern: their knots with the edges
        for b1 in (False, True):
            r = np.flatnonzero(((e0 > 0.0) == b0) & ((e1 > 0.0) == b1))
            if r.size:
                got = _corner_rows_edged(S[r], V[r], r, e0[r], e1[r], b0, b1, rules, accel[r], v0[r], v1[r],
                                          pux[r], puy[r], has_p[r], ux[r], uy[r], nux[r], nuy[r], has_n[r],
                                          jd[r], [sts[k] for k in r.tolist()])
                rows.append(got[0])
                plans += got[1]
    return take[np.concatenate(rows)].tolist(), plans


def _accel_top_rows(sts, lims, accel, ux, uy):
    """[_accel_top(st) for st in sts] as an array: the same quotients, min as np.where."""
    m = len(sts)
    ax = np.abs(ux)
    ay = np.abs(uy)
    with np.errstate(all="ignore"):
        cx = np.fromiter(map(_AX_MAX, lims), float, m) / ax
        cy = np.fromiter(map(_AY_MAX, lims), float, m) / ay
    a = np.where((ax > 1e-12) & (cx < accel), cx, accel)
    return np.where((ay > 1e-12) & (cy < a), cy, a)


def _neighbour_dirs(sts):
    """The strokes' prev_u and next_u as arrays: (pux, puy, has_p, nux, nuy, has_n), 0.0
    where there is none (has False).  Strokes: their four slots read in C-level passes."""
    if set(map(type, sts)) == {Stroke}:
        cols = []
        for get in (_PUX, _PUY, _NUX, _NUY):
            a = np.array(list(map(get, sts)), object)
            cols.append(a)
        has_p = cols[0] != None      # noqa: E711 (elementwise)
        has_n = cols[2] != None      # noqa: E711
        out = []
        for a, has in zip(cols, (has_p, has_p, has_n, has_n)):
            a[~has] = 0.0
            out.append(a.astype(float))
        return out[0], out[1], has_p.astype(bool), out[2], out[3], has_n.astype(bool)
    pu = list(map(_PREV_U, sts))
    nu = list(map(_NEXT_U, sts))
    has_p = np.array([p is not None for p in pu], bool)
    has_n = np.array([p is not None for p in nu], bool)
    pux = np.array([p[0] if p is not None else 0.0 for p in pu], float)
    puy = np.array([p[1] if p is not None else 0.0 for p in pu], float)
    nux = np.array([p[0] if p is not None else 0.0 for p in nu], float)
    nuy = np.array([p[1] if p is not None else 0.0 for p in nu], float)
    return pux, puy, has_p, nux, nuy, has_n


def _corner_cmds(sts):
    """[bool(getattr(st, "corner_cmd0/1", False))] of the strokes as two bool arrays."""
    m = len(sts)
    try:
        return (np.fromiter(map(bool, map(_CMD0, sts)), bool, m), np.fromiter(map(bool, map(_CMD1, sts)), bool, m))
    except AttributeError:
        return (np.array([bool(getattr(st, "corner_cmd0", False)) for st in sts], bool),
                np.array([bool(getattr(st, "corner_cmd1", False)) for st in sts], bool))


def _row_plans(S, V, A, F, t_pred, a2_pred, fine, shape="law"):
    """RowPlans of every row of the blocks (made by a C-level map), seg_fault's verdict ""
    on the fine ones (fault=None: none set)."""
    m = len(t_pred)
    made = list(map(RowPlan, repeat(S, m), repeat(V, m), repeat(A, m), repeat(F, m), range(m), t_pred, a2_pred,
                    repeat(shape, m)))
    if fine is not None:
        for plan in compress(made, fine):
            plan.fault = ""
    return made


def _corner_rows_edged(S, V, rows, e0, e1, b0, b1, rules, accel, v0, v1, pux, puy, has_p, ux, uy, nux, nuy,
                       has_n, jd, sts):
    """_corner_rows' rows of one edge pattern (b0: a lead-in, b1: a lead-out): with_edges,
    ramp_accels and the needs again, the ends' and the law's junction floors, then
    _block_plans' steps.  (rows, their RowPlans): rows (an int array) where no junction
    need's per-stroke form would raise."""
    junction = rules.junction
    m = S.shape[0]
    if b0:                               # with_edges: e = min(edge0_d, 0.4 * s[1]) after [0, e] ...
        e = _py_min(e0, 0.4 * S[:, 1])
        S = np.concatenate([np.zeros((m, 1)), e[:, None], S[:, 1:]], axis=1)
        V = np.concatenate([V[:, :1], V[:, :1], V[:, 1:]], axis=1)
    if b1:
        e = _py_min(e1, 0.4 * (S[:, -1] - S[:, -2]))
        S = np.concatenate([S[:, :-1], (S[:, -1] - e)[:, None], S[:, -1:]], axis=1)
        V = np.concatenate([V[:, :-1], V[:, -1:], V[:, -1:]], axis=1)
    with np.errstate(all="ignore"):
        d = S[:, 1:] - S[:, :-1]
        acc = np.abs((V * V)[:, 1:] - (V * V)[:, :-1]) / (2.0 * d)
        need0, odd0 = accel_to_pass_junction_rows(junction, v0, pux, puy, has_p, ux, uy, d[:, 0], jd)
        need1, odd1 = accel_to_pass_junction_rows(junction, v1, ux, uy, has_n, nux, nuy, d[:, -1], jd)
        bad = odd0 | odd1                # (a lead-in's junction: the per-stroke form would raise)
        acc[:, 0] = _py_max(acc[:, 0], _py_min(need0, accel))
        acc[:, -1] = _py_max(acc[:, -1], _py_min(need1, accel))
        if junction == "jd":             # every inner junction of the straight line: Marlin's < 1 mm rule
            K = acc.shape[1]
            need, odd = accel_to_pass_junction_rows("jd", V[:, 1:K], ux[:, None], uy[:, None], True,
                                                    ux[:, None], uy[:, None], d[:, 1:], jd[:, None])
            bad |= odd.any(axis=1)
            acc[:, 1:] = _py_max(acc[:, 1:], _py_min(need, accel[:, None]))
        else:                            # scv: rounding_junction_accels
            need = np.zeros(d.shape)
            theta = ROUND_TURN_D / np.minimum(d[:, :-1], d[:, 1:])
            v2 = V[:, 1:-1] ** 2
            need[:, :-1] = np.maximum(need[:, :-1], v2 * theta / d[:, :-1])
            need[:, 1:] = np.maximum(need[:, 1:], v2 * theta / d[:, 1:])
            acc = np.maximum(acc, np.minimum(need, accel[:, None]))
    # _block_plans: the cruises' accelerations held, the feeds (no jerk step: the needs
    # themselves), the figures and the verdicts
    A = hold_cruise_accels_rows(acc, accel)
    feeds = np.maximum(np.maximum(V[:, :-1], V[:, 1:]), MIN_FEED_V)
    t_pred, a2_pred = _predict_rows(S, V, A)
    fine = fine_rows(S, V, A, feeds, t_pred, a2_pred)
    made = _row_plans(S, V, A, feeds, t_pred, a2_pred, fine)
    if bad.any():
        ok = np.flatnonzero(~bad)
        return rows[ok], [made[k] for k in ok.tolist()]
    return rows, made


def _ramp_room(d, va, vb, a_top):
    """What a segment of length d ramping from va to vb at no more than a_top leaves for
    an edge (lead-in / lead-out at the end speed)."""
    return d - abs(vb ** 2 - va ** 2) / (2.0 * a_top)


def _vertex_mask(sk, vertices_d):
    """Which knots are the ends or original vertices (they stay knots)."""
    vert = np.zeros(len(sk), bool)
    vert[0] = vert[-1] = True
    for d in vertices_d:
        vert |= np.abs(sk - d) < 1e-9
    return vert


def _merge_short(sk, vk, min_d, vertices_d):
    """Knots with no segment shorter than min_d (a move the firmware would drop: Profile.
    min_move_d): a law knot too close to the one kept before it is dropped (the ramp runs
    on to the next); original vertices and the ends stay.  Time-even knots crowd where the
    law is slow, next to a corner slowed to ~1 mm/s."""
    if len(sk) < 3 or float((sk[1:] - sk[:-1]).min()) >= min_d:     # np.min(np.diff(sk)), less overhead
        return sk, vk
    vert = _vertex_mask(sk, vertices_d)
    keep = [0]
    for k in range(1, len(sk)):
        if vert[k] or sk[k] - sk[keep[-1]] >= min_d * (1.0 - 1e-9):
            keep.append(k)
    # the last segment too short: drop the law knot before the end, if it is one
    if len(keep) > 2 and sk[keep[-1]] - sk[keep[-2]] < min_d * (1.0 - 1e-9) and not vert[keep[-2]]:
        del keep[-2]
    keep = np.array(keep)
    return sk[keep], vk[keep]


def _room_for_edges(sk, vk, e0, e1, a_top, vertices_d):
    """Knots with room for a lead-in of e0 / lead-out of e1 mm: the first (last) segment
    must hold the edge and its ramp at no more than a_top.  Where it cannot, the law knot
    next to the end is dropped (the ramp then runs to the knot after it, the chord of v^2
    over both segments); original vertices stay.  A slowed corner's longer lead-in (the
    firmware's shortest kept move, Profile.min_move_d) needs this on steep law starts."""
    # with_edges takes at most 0.4 of the end segment for the edge
    def room0(sk, vk):
        return min(_ramp_room(sk[1], vk[0], vk[1], a_top), 0.4 * 0.99 * sk[1])

    def room1(sk, vk):
        return min(_ramp_room(sk[-1] - sk[-2], vk[-2], vk[-1], a_top), 0.4 * 0.99 * (sk[-1] - sk[-2]))

    def vertex(d):
        return any(abs(d - v) < 1e-9 for v in vertices_d)

    while e0 and len(sk) > 3 and room0(sk, vk) < e0 / 0.99 and not vertex(sk[1]):
        sk, vk = np.delete(sk, 1), np.delete(vk, 1)
    while e1 and len(sk) > 3 and room1(sk, vk) < e1 / 0.99 and not vertex(sk[-2]):
        sk, vk = np.delete(sk, -2), np.delete(vk, -2)
    return sk, vk


def slowed_ends(stroke):
    """(start, end): is that end's speed below the firmware's own junction speed (lowered
    by corners.py: Stroke.v0_fw / v1_fw) and does it need a lead-in / lead-out to be
    played so (not when a junction command slows it: Stroke.corner_cmd0 / corner_cmd1)?"""
    fw0, fw1 = getattr(stroke, "v0_fw", None), getattr(stroke, "v1_fw", None)
    return (fw0 is not None and stroke.v0 < fw0 - 1e-9 and not getattr(stroke, "corner_cmd0", False),
            fw1 is not None and stroke.v1 < fw1 - 1e-9 and not getattr(stroke, "corner_cmd1", False))


# ------------------------------------------------------- one-move trapezoids (short strokes)
TRAP_GRID = 97           # peak speeds tried between the lowest and highest feasible one


def trapezoid_time(L, vp, a, v0, v1):
    """Duration (s) of one move of length L (mm) with feed vp and acceleration a, entered at
    v0 and left at v1 (peak min(vp, triangle peak)), as a constant-acceleration firmware
    plays it; and its int a^2 dt = a (2 v_peak - v0 - v1).  Broadcasts."""
    vt = np.sqrt(np.maximum((2.0 * a * L + v0 * v0 + v1 * v1) / 2.0, 0.0))
    pk = np.maximum(np.minimum(vp, vt), np.maximum(v0, v1))
    cruise_d = np.maximum(L - (2.0 * pk * pk - v0 * v0 - v1 * v1) / (2.0 * a), 0.0)
    t = (2.0 * pk - v0 - v1) / a + cruise_d / np.maximum(pk, 1e-9)
    return t, a * (2.0 * pk - v0 - v1)


def least_a2_trapezoid(L, T, v0, v1, v_lo, v_hi, a_max, a_min_fn=None, extra_fn=None):
    """The one-move trapezoid (accelerate at a from v0 to vp, cruise, brake at a to v1) of
    length L (mm) that takes at most T (s) with the least int a^2 dt = a (2 vp - v0 - v1).

    For a peak vp the slowest ramp that still takes T is a = G / (T - L/vp) with
    G = ((vp - v0)^2 + (vp - v1)^2) / (2 vp) (the time the ramps lose against cruising at
    vp, times a); a_min_fn(vp) may raise it (what the junctions need), which only makes
    the move quicker, and so does the least a whose ramps fit in L; extra_fn(vp, a) adds
    to the cost (an arc's centripetal part).  vp is searched in [max(v_lo, v0, v1, L/T),
    v_hi] (a grid dense near its low end, refined twice around the best point), a <= a_max.  At
    rest-to-rest the optimum is the 1/3 - 1/3 - 1/3 trapezoid, vp = 1.5 L/T, whose
    13.5 L^2/T^3 is within 12.5 % of the optimal law's 12 L^2/T^3.
    Returns (vp, a, time_t, int_a2) or None."""
    lo = max(v_lo, v0, v1, L / T * (1.0 + 1e-9))
    if not (lo <= v_hi and L > 0 and T > 0 and a_max > 0):
        return None

    def cost(vp):
        G = ((vp - v0) ** 2 + (vp - v1) ** 2) / (2.0 * vp)
        with np.errstate(divide="ignore", invalid="ignore"):
            a = G / (T - L / vp)
        a = np.where(np.isfinite(a) & (a > 0), a, np.where(G <= 1e-12, 2 * CRUISE_A, np.inf))
        if a_min_fn is not None:
            a = np.maximum(a, a_min_fn(vp))
        a = np.maximum(a, (2.0 * vp * vp - v0 * v0 - v1 * v1) / (2.0 * L))   # the ramps fit in L (quicker still)
        fits = a <= a_max
        c = a * (2.0 * vp - v0 - v1) + (0.0 if extra_fn is None else extra_fn(vp, a))
        return a, np.where(fits, c, np.inf)

    grid = lo + (v_hi - lo) * np.concatenate([[0.0], np.geomspace(1e-6, 1.0, TRAP_GRID - 1)])
    for step in range(3):
        a, c = cost(grid)
        k = int(np.argmin(c))
        if not np.isfinite(c[k]):
            return None
        vp, a = grid[k], a[k]
        # refine around the best point (c is smooth in vp there): the geometric grid's
        # neighbours lie within +-16 % of vp - lo, each refinement narrows 16-fold
        w = 0.25 * (vp - lo) / 16 ** step
        grid = np.append(np.linspace(max(lo, vp - w), min(v_hi, vp + w), 33), vp)
    t, i2 = trapezoid_time(L, vp, a, v0, v1)
    return float(vp), float(a), float(t), float(i2)


def trapezoid_knot_speeds(s, L, vp, a, v0, v1):
    """Speed of the one-move trapezoid at distances s (its knots)."""
    s = np.clip(s, 0.0, L)
    return np.minimum(np.minimum(np.sqrt(v0 * v0 + 2.0 * a * s), np.sqrt(v1 * v1 + 2.0 * a * (L - s))), vp)


def predict_peaked(s, v, a, feed):
    """predict() for segments that may cruise above both knot speeds (feed above them):
    each segment ramps up at a_k to min(F_k, its triangle peak), cruises, ramps down."""
    t, i2 = trapezoid_time(np.diff(s), np.asarray(feed, float), np.maximum(np.asarray(a, float), 1e-12),
                           v[:-1], v[1:])
    return float(np.sum(t)), float(np.sum(i2))


def law_peak_speeds(strokes, T, beta):
    """Peak speed of each stroke's planned law: the trapezoid never goes faster, so it
    keeps every speed cap the plan honoured (F x overshoot, machine, hotend flow)."""
    L = np.array([st.length_d for st in strokes], float)
    v0 = np.array([st.v0 for st in strokes], float)
    v1 = np.array([st.v1 for st in strokes], float)
    return np.asarray(line_law(L, np.asarray(T, float), np.asarray(beta, float), v0, v1).peak_speed(), float)


def line_trapezoids(strokes, T, beta, rules: SegmentRules):
    """SegmentPlan per line stroke: its one-move trapezoid of duration <= T (None where
    there is none).  Every original vertex stays a knot (collinear, one F and one
    acceleration: the firmware plans them as one trapezoid); a lead-in / lead-out at the
    corner speed carries what the corner needs (Klipper, Marlin JD) as in _finish."""
    if not len(strokes):
        return []
    peaks = law_peak_speeds(strokes, T, beta)
    # the strokes of one move with no slowed end in rows (_line_trapezoid_rows: the same
    # bits); the others stroke by stroke below
    made = [None] * len(strokes)
    rest = _line_trapezoid_rows(strokes, T, peaks, rules, made)
    if not rest:
        return made
    # every stroke's variants (edges, and none unless an end is slowed, as _line_trapezoid),
    # their least-a^2 trapezoids solved in one batch (least_a2_trapezoids: the same bits)
    preps = []
    Ta = np.asarray(T)
    for st, t, p in zip([strokes[i] for i in rest], Ta[rest].tolist(), np.asarray(peaks)[rest].tolist()):
        t, p = float(t), float(p)
        slow = any(slowed_ends(st))
        preps.append((_edges_prep(st, t, p, rules, True),
                      None if slow else _edges_prep(st, t, p, rules, False)))
    rows = [q for pair in preps for q in pair if q is not None]
    if rows:
        cols = np.array([q[0] for q in rows], float).T       # Lm, T, v0, v1, v_lo, v_hi, a_top, floor
        vps, accs = least_a2_trapezoids(*cols)
    out, r = [], 0
    for pair in preps:
        got = []
        for q in pair:
            if q is None:
                continue
            vp, a = vps[r], accs[r]
            r += 1
            if vp == vp:                  # nan: no trapezoid
                p = _edges_finish(q[1], float(vp), float(a))
                if p is not None:
                    got.append(p)
        out.append(min(got, key=lambda p: p.int_a2) if got else None)
    for i, p in zip(rest, out):
        made[i] = p
    return made


def _line_trapezoid_rows(strokes, T, peaks, rules, out, variants=(True, False)):
    """line_trapezoids' plans of the strokes of one move with no slowed end, in rows: both
    variants of _edges_prep (edges / none; variants: those of them, the tests' choice) on
    arrays, their trapezoids in one batch
    (least_a2_trapezoids), _edges_finish's knots, speeds, accelerations and figures by
    rows of one edge pattern (RowPlans), and the better of the two as min(key=int_a2)
    takes it (the second only where its int a^2 is below the first's).  Sets out[i] for
    the strokes taken; returns the indices of the others (slowed ends, several moves, a
    junction need whose per-stroke form would raise: _edges_prep / _edges_finish one by
    one).  Every step is the per-stroke one on arrays: Python's min / max as np.where
    on the same comparisons, `x or y` as x where x != 0."""
    m = len(strokes)
    keep = _not_slowed(strokes)
    keep &= np.array(_move_counts(strokes)) == 1
    idx = np.flatnonzero(keep)
    if not idx.size:
        return list(range(m))
    il = idx.tolist()
    sts = [strokes[i] for i in il]
    n = len(sts)
    junction = rules.junction
    Tq = np.asarray(T, float)[idx]
    vpk = np.asarray(peaks, float)[idx]
    L = np.fromiter(map(_LENGTH_D, sts), float, n)
    ux = np.fromiter(map(_UX, sts), float, n)
    uy = np.fromiter(map(_UY, sts), float, n)
    sv0 = np.fromiter(map(_V0, sts), float, n)
    sv1 = np.fromiter(map(_V1, sts), float, n)
    accel = np.fromiter(map(_ACCEL, sts), float, n)
    lims = list(map(_LIM, sts))
    jd = np.fromiter(map(_JD, lims), float, n)
    v0 = np.where(sv0 >= FULL_STOP_V, sv0, 0.0)
    v1 = np.where(sv1 >= FULL_STOP_V, sv1, 0.0)
    a_top = _accel_top_rows(sts, lims, accel, ux, uy)
    v_lo, v_hi = np.zeros(n), vpk
    if junction == "jerk":               # F within the jerk of the slicer's F (segment_feeds)
        step_v = _jerk_steps(sts, ux, uy)
        v_feed = np.fromiter(map(_V_FEED, sts), float, n)
        with np.errstate(all="ignore"):
            v_lo, v_hi = v_feed - step_v, _py_min(v_hi, v_feed + step_v)
    e_min = _min_edge_d_rows(rules, sts, ux, uy)
    cmd0, cmd1 = _corner_cmds(sts)
    if junction == "jerk":               # accel_to_pass_junction: 0.0 under classic jerk
        pux = puy = nux = nuy = np.zeros(n)
        has_p = has_n = np.zeros(n, bool)
    else:
        pux, puy, has_p, nux, nuy, has_n = _neighbour_dirs(sts)
    odd = np.zeros(n, bool)
    var = []                             # per variant: (ok, e0, e1, need0, need1, Lm, cols)
    with np.errstate(all="ignore"):
        for edges in variants:
            if edges:
                x0 = _py_min(_py_min(EDGE_D, _py_max(_py_max(v0 * EDGE_T, 0.05), e_min)), 0.25 * L)
                x1 = _py_min(_py_min(EDGE_D, _py_max(_py_max(v1 * EDGE_T, 0.05), e_min)), 0.25 * L)
                e0 = np.where((v0 >= EDGE_MIN_V) & ~cmd0, x0, 0.0)
                e1 = np.where((v1 >= EDGE_MIN_V) & ~cmd1, x1, 0.0)
            else:
                e0 = e1 = np.zeros(n)
            # d0 = ends_d[0] = L and d1 = L - 0.0 for a stroke of one move; `e0 or d0`
            if junction == "jerk":
                need0 = need1 = np.zeros(n)
            else:
                need0, o0 = accel_to_pass_junction_rows(junction, v0, pux, puy, has_p, ux, uy,
                                                        np.where(e0 != 0.0, e0, L), jd)
                need1, o1 = accel_to_pass_junction_rows(junction, v1, ux, uy, has_n, nux, nuy,
                                                        np.where(e1 != 0.0, e1, L - 0.0), jd)
                need0 = np.where(v0 > 0, need0, 0.0)
                need1 = np.where(v1 > 0, need1, 0.0)
                odd |= (v0 > 0) & o0 | (v1 > 0) & o1
            e0 = np.where((need0 > 0.0) & (e0 >= e_min), e0, 0.0)
            e1 = np.where((need1 > 0.0) & (e1 >= e_min), e1, 0.0)
            t_edges = np.where(e0 != 0.0, e0 / v0, 0.0) + np.where(e1 != 0.0, e1 / v1, 0.0)
            Lm = L - e0 - e1
            Tm = Tq - t_edges
            ok = ~((Lm <= 0) | (Tm <= 0))
            if junction == "jd":         # Marlin JD: collinear blocks shorter than 1 mm cap v^2 at d a / 0.033
                md = rules.min_seg_d
                ok &= ~((L - 0.0 < md) | (0 < e0) & (e0 < md) | (0 < e1) & (e1 < md))
            fl = _py_min(_py_max(np.where(e0 == 0.0, need0, 0.0), np.where(e1 == 0.0, need1, 0.0)), a_top)
            floor_a = np.where((e0 == 0.0) & (need0 > 0) | (e1 == 0.0) & (need1 > 0), fl, -np.inf)
            var.append((ok, e0, e1, need0, need1, Lm, (Lm, Tm, v0, v1, v_lo, v_hi, a_top, floor_a)))
    if variants == (True, False):
        # where the edges' variant has none and the same floor (its needs were asked at the
        # edge's length: the same where that was no edge, d0 in both), the other has the
        # same arguments and makes the same plan, which min() does not take: not made twice
        same = (var[0][1] == 0.0) & (var[0][2] == 0.0) & (var[0][6][7] == var[1][6][7])
        var[1] = (var[1][0] & ~same,) + var[1][1:]
    take = ~odd
    r = [np.flatnonzero(take & v[0]) for v in var]
    cols = [np.concatenate([v[6][j][rk] for v, rk in zip(var, r)]) for j in range(8)]
    vps, accs = least_a2_trapezoids(*cols)
    best = [None] * n                    # per stroke: the plan of the better variant, its int a^2
    has = np.zeros(n, bool)
    best_a2 = np.zeros(n)
    at = 0
    for (ok, e0, e1, need0, need1, Lm, _), rk in zip(var, r):
        vp, a = vps[at:at + rk.size], accs[at:at + rk.size]
        at += rk.size
        live = vp == vp                  # nan: no trapezoid
        rk, vp, a = rk[live], vp[live], a[live]
        ks, plans, a2 = _edges_finish_rows(rk, vp, a, e0[rk], e1[rk], need0[rk], need1[rk], L[rk], Lm[rk],
                                           v0[rk], v1[rk], ux[rk], uy[rk], jd[rk], accel[rk], junction)
        better = ~has[ks] | (a2 < best_a2[ks])       # min(key=int_a2): the first unless a later one is below
        if not better.all():
            sel = np.flatnonzero(better)
            ks, a2, plans = ks[sel], a2[sel], [plans[k] for k in sel.tolist()]
        has[ks] = True
        best_a2[ks] = a2
        deque(map(best.__setitem__, ks.tolist(), plans), maxlen=0)
    got = idx[take]
    deque(map(out.__setitem__, got.tolist(), compress(best, take.tolist())), maxlen=0)
    rest = np.ones(m, bool)
    rest[got] = False
    return np.flatnonzero(rest).tolist()


def _edges_finish_rows(rk, vp, a, e0, e1, need0, need1, L, Lm, v0, v1, ux, uy, jd, accel, junction):
    """_edges_finish of the strokes rk (of one move: no inner vertex) with trapezoids (vp,
    a), by rows of one edge pattern: (strokes, their RowPlans, their int a^2) of those that
    make a plan (under Marlin JD none where a straight junction needs more than the
    trapezoid's ramp)."""
    out_k, out_p, out_a2 = [], [], []
    for b0 in (False, True):
        for b1 in (False, True):
            g = np.flatnonzero(((e0 != 0.0) == b0) & ((e1 != 0.0) == b1))
            if not g.size:
                continue
            m = g.size
            cols = [np.zeros(m)] + ([e0[g]] if b0 else []) + ([L[g] - e1[g]] if b1 else []) + [L[g]]
            S = np.stack(cols, axis=1)
            Lg, vpg, ag, v0g, v1g = (x[g][:, None] for x in (Lm, vp, a, v0, v1))
            with np.errstate(all="ignore"):
                V = trapezoid_knot_speeds(S - e0[g][:, None], Lg, vpg, ag, v0g, v1g)
            V[:, 0], V[:, -1] = v0[g], v1[g]
            if b0:
                V[:, 1] = v0[g]
            if b1:
                V[:, -2] = v1[g]
            K = S.shape[1] - 1
            A = np.repeat(ag, K, axis=1)
            F = np.repeat(vpg, K, axis=1)
            if b0:
                A[:, 0] = _py_min(_py_max(need0[g], a[g]), accel[g])
                F[:, 0] = _py_max(v0[g], MIN_FEED_V)
            if b1:
                A[:, -1] = _py_min(_py_max(need1[g], a[g]), accel[g])
                F[:, -1] = _py_max(v1[g], MIN_FEED_V)
            fine = np.ones(m, bool)
            if junction == "jd" and K > 1:
                with np.errstate(all="ignore"):
                    need, _ = accel_to_pass_junction_rows("jd", V[:, 1:K], ux[g][:, None], uy[g][:, None], True,
                                                          ux[g][:, None], uy[g][:, None], S[:, 2:] - S[:, 1:K],
                                                          jd[g][:, None])
                    fine = ~(need > A[:, 1:] * (1 + 1e-9)).any(axis=1)
            A = hold_cruise_accels_rows(A, accel[g])
            with np.errstate(all="ignore"):
                t, i2 = trapezoid_time(S[:, 1:] - S[:, :-1], F, np.maximum(A, 1e-12), V[:, :-1], V[:, 1:])
            a2_sum = np.add.reduce(i2, axis=1)
            made = _row_plans(S, V, A, F, np.add.reduce(t, axis=1).tolist(), a2_sum.tolist(), None, "trapezoid")
            if not fine.all():
                sel = np.flatnonzero(fine)
                g, a2_sum, made = g[sel], a2_sum[sel], [made[k] for k in sel.tolist()]
            out_k.append(rk[g])
            out_a2.append(a2_sum)
            out_p += made
    if not out_k:
        return np.zeros(0, int), [], np.zeros(0)
    return np.concatenate(out_k), out_p, np.concatenate(out_a2)


def _line_trapezoid(st, T, v_peak, rules):
    """The better of: lead-in / lead-out at the corner speeds carrying what the corners
    need, or none and the whole move carrying it (a lead-in at a slow corner can take
    most of a short stroke's time).  A slowed end (corners.py) always has its edge."""
    slow = any(slowed_ends(st))
    got = [p for p in (_line_trapezoid_edges(st, T, v_peak, rules, True),
                       None if slow else _line_trapezoid_edges(st, T, v_peak, rules, False)) if p is not None]
    return min(got, key=lambda p: p.int_a2) if got else None


def slowed_original(st, rules: SegmentRules):
    """A line stroke the planner leaves as sliced whose start corners.py lowered with a
    junction command (Stroke.corner_cmd0): its own move(s) (the slicer's F, the
    acceleration in force), to be written behind that command (schedule.py attaches it),
    so the corner is played slower as chosen.  None where it would need a lead-in /
    lead-out (slowed_ends), whose time the corner was not priced with."""
    if not getattr(st, "corner_cmd0", False) or any(slowed_ends(st)):
        return None
    return _line_trapezoid_edges(st, np.inf, st.v_feed, rules, True, fixed_a=_accel_top(st))


def _line_trapezoid_edges(st, T, v_peak, rules, edges, fixed_a=None):
    """fixed_a: the move's own acceleration, v_peak its feed (slowed_original), instead of
    the least-int a^2 trapezoid of duration T."""
    q = _edges_prep(st, T, v_peak, rules, edges, fixed_a)
    if q is None:
        return None
    (Lm, Tm, v0, v1, v_lo, v_hi, a_top, floor_a), state = q
    if fixed_a is not None:
        vp, a = v_peak, fixed_a
        if floor_a > -np.inf:
            a = max(a, floor_a)
    else:
        a_min = None if floor_a == -np.inf else (lambda vp: np.full_like(vp, floor_a))
        got = least_a2_trapezoid(Lm, Tm, v0, v1, v_lo, v_hi, a_top, a_min)
        if got is None:
            return None
        vp, a, _, _ = got
    return _edges_finish(state, vp, a)


def _edges_prep(st, T, v_peak, rules, edges, fixed_a=None):
    """_line_trapezoid_edges up to its trapezoid: None, or ((Lm, T - t_edges, v0, v1, v_lo,
    v_hi, a_top, floor_a): least_a2_trapezoid's arguments, floor_a the constant a_min
    (-inf: none), state for _edges_finish)."""
    u = (st.ux, st.uy)
    v0 = st.v0 if st.v0 >= FULL_STOP_V else 0.0
    v1 = st.v1 if st.v1 >= FULL_STOP_V else 0.0
    L, jd, a_top = st.length_d, st.lim.jd, _accel_top(st)
    v_lo, v_hi = 0.0, v_peak
    if rules.junction == "jerk" and fixed_a is None:   # F within the jerk of the slicer's F (segment_feeds)
        step_v = jerk_step_v(st)
        v_lo, v_hi = st.v_feed - step_v, min(v_hi, st.v_feed + step_v)
    # lead-in / lead-out at the corner speeds where the corner needs more than a gentle ramp
    e_min = rules.min_edge_d(*u)
    slow0, slow1 = slowed_ends(st)
    cmd0, cmd1 = getattr(st, "corner_cmd0", False), getattr(st, "corner_cmd1", False)
    e0 = min(EDGE_D, max(v0 * EDGE_T, 0.05, e_min), 0.25 * L) if (
        (v0 >= EDGE_MIN_V and not cmd0) or slow0) and edges else 0.0
    e1 = min(EDGE_D, max(v1 * EDGE_T, 0.05, e_min), 0.25 * L) if (
        (v1 >= EDGE_MIN_V and not cmd1) or slow1) and edges else 0.0
    d0, d1 = st.ends_d[0], L - (st.ends_d[-2] if len(st.ends_d) > 1 else 0.0)   # first, last move
    need0 = accel_to_pass_junction(rules.junction, v0, st.prev_u, u, e0 or d0, jd) if v0 > 0 else 0.0
    need1 = accel_to_pass_junction(rules.junction, v1, u, st.next_u, e1 or d1, jd) if v1 > 0 else 0.0
    if (slow0 and e0 < e_min) or (slow1 and e1 < e_min):
        return None                       # a slowed end without its edge would not be slowed
    e0 = e0 if (need0 > 0.0 or slow0) and e0 >= e_min else 0.0
    e1 = e1 if (need1 > 0.0 or slow1) and e1 >= e_min else 0.0
    t_edges = (e0 / v0 if e0 else 0.0) + (e1 / v1 if e1 else 0.0)
    Lm = L - e0 - e1
    if Lm <= 0 or T - t_edges <= 0 or (fixed_a is not None and not fixed_a > 0):
        return None
    # Marlin JD: collinear blocks shorter than 1 mm cap v^2 at d a / 0.033
    if rules.junction == "jd" and (min(np.diff([0.0] + list(st.ends_d))) < rules.min_seg_d or
                                   (0 < e0 < rules.min_seg_d) or (0 < e1 < rules.min_seg_d)):
        return None
    floor_a = -np.inf
    if not e0 and need0 > 0 or not e1 and need1 > 0:    # the original passed them with at most a_top
        floor_a = float(min(max(need0 if not e0 else 0.0, need1 if not e1 else 0.0), a_top))
    return ((Lm, T - t_edges, v0, v1, v_lo, v_hi, a_top, floor_a),
            (st, rules, u, v0, v1, L, jd, e0, e1, Lm, need0, need1))


def _edges_finish(state, vp, a):
    """_line_trapezoid_edges' plan for the trapezoid (vp, a)."""
    st, rules, u, v0, v1, L, jd, e0, e1, Lm, need0, need1 = state
    # knots: the edges, every original vertex, the ends
    inner = np.array([d for d in st.ends_d[:-1] if e0 < d < L - e1], float)
    s = np.concatenate([[0.0], [e0] if e0 else [], inner, [L - e1] if e1 else [], [L]])
    v = trapezoid_knot_speeds(s - e0, Lm, vp, a, v0, v1)
    v[0], v[-1] = v0, v1
    if e0:
        v[1] = v0
    if e1:
        v[-2] = v1
    acc = np.full(len(s) - 1, a)
    feed = np.full(len(s) - 1, vp)
    if e0:
        acc[0], feed[0] = min(max(need0, a), st.accel), max(v0, MIN_FEED_V)
    if e1:
        acc[-1], feed[-1] = min(max(need1, a), st.accel), max(v1, MIN_FEED_V)
    if rules.junction == "jd":
        for k in range(1, len(acc)):
            need = accel_to_pass_junction("jd", v[k], u, u, s[k + 1] - s[k], jd)
            if need > acc[k] * (1 + 1e-9):
                return None             # a raised ramp would not be the planned trapezoid
    acc = hold_cruise_accels(acc, st.accel)
    t_pred, a2_pred = predict_peaked(s, v, acc, feed)
    return SegmentPlan(s, v, acc, feed, t_pred, a2_pred, "trapezoid")


def _py_max(a, b):
    """Python's max(a, b) elementwise (a unless b > a)."""
    return np.where(b > a, b, a)


def _py_min(a, b):
    """Python's min(a, b) elementwise (a unless b < a)."""
    return np.where(b < a, b, a)


def _rows_linspace(start, stop, num):
    """np.linspace(start[i], stop[i], num) per row i, bit for bit: numpy takes its
    step == 0 branch ((k / div) * delta) per call, so it is chosen here per row."""
    div = num - 1
    delta = stop - start
    step = delta / div
    k = np.arange(0, num, dtype=float)
    y = np.where((step == 0)[:, None], (k / div)[None, :] * delta[:, None], k[None, :] * step[:, None])
    y += start[:, None]
    y[:, -1] = stop
    return y


TRAP_ROWS = 1 << 10     # trapezoids least_a2_trapezoids solves at once (~10 (rows, 97) temporaries: ~8 MB)


def least_a2_trapezoids(L, T, v0, v1, v_lo, v_hi, a_max, a_floor):
    """least_a2_trapezoid for m trapezoids at once (1-d arrays of its arguments; a_floor the
    constant a_min per row, -inf: none; no extra_fn), the same operations row by row, so
    the same bits.  Returns (vp, a): arrays, nan where least_a2_trapezoid returns None.

    Solved TRAP_ROWS rows at a time: every row's grid, its costs and its argmin are its
    own (elementwise operations and a per-row argmin), so a block gives each row the bits
    the whole batch gave it; the whole batch's (m, 97) temporaries set the peak RSS of the
    gyroid plate under voron24 (~30 MB above the rest of planning)."""
    args = [np.asarray(x, float) for x in (L, T, v0, v1, v_lo, v_hi, a_max, a_floor)]
    m = len(args[0])
    if m <= TRAP_ROWS:
        return _least_a2_block(*args)
    vp_out, a_out = np.empty(m), np.empty(m)
    for a in range(0, m, TRAP_ROWS):
        vp_out[a:a + TRAP_ROWS], a_out[a:a + TRAP_ROWS] = _least_a2_block(*(x[a:a + TRAP_ROWS] for x in args))
    return vp_out, a_out


def _least_a2_block(L, T, v0, v1, v_lo, v_hi, a_max, a_floor):
    """least_a2_trapezoids on one block of rows (float arrays)."""
    m = len(L)
    vp_out = np.full(m, np.nan)
    a_out = np.full(m, np.nan)
    if not m:
        return vp_out, a_out
    with np.errstate(all="ignore"):
        lo = _py_max(_py_max(_py_max(v_lo, v0), v1), L / T * (1.0 + 1e-9))
        ok = (lo <= v_hi) & (L > 0) & (T > 0) & (a_max > 0)
        idx = np.flatnonzero(ok)
        if not len(idx):
            return vp_out, a_out
        L, T, v0, v1, v_hi, a_max, a_floor, lo = (x[idx] for x in (L, T, v0, v1, v_hi, a_max, a_floor, lo))
        Lc, Tc, v0c, v1c, a_maxc, floorc = (x[:, None] for x in (L, T, v0, v1, a_max, a_floor))
        table = np.concatenate([[0.0], np.geomspace(1e-6, 1.0, TRAP_GRID - 1)])
        grid = lo[:, None] + (v_hi - lo)[:, None] * table[None, :]
        alive = np.ones(len(idx), bool)
        rows = np.arange(len(idx))
        for step in range(3):
            vp = grid
            G = ((vp - v0c) ** 2 + (vp - v1c) ** 2) / (2.0 * vp)
            a = G / (Tc - Lc / vp)
            a = np.where(np.isfinite(a) & (a > 0), a, np.where(G <= 1e-12, 2 * CRUISE_A, np.inf))
            a = np.maximum(a, floorc)
            a = np.maximum(a, (2.0 * vp * vp - v0c * v0c - v1c * v1c) / (2.0 * Lc))
            fits = a <= a_maxc
            c = a * (2.0 * vp - v0c - v1c) + 0.0
            c = np.where(fits, c, np.inf)
            k = np.argmin(c, axis=1)
            alive &= np.isfinite(c[rows, k])
            vp, a = grid[rows, k], a[rows, k]
            w = 0.25 * (vp - lo) / 16 ** step
            grid = np.concatenate([_rows_linspace(_py_max(lo, vp - w), _py_min(v_hi, vp + w), 33),
                                   vp[:, None]], axis=1)
        vp_out[idx[alive]] = vp[alive]
        a_out[idx[alive]] = a[alive]
    return vp_out, a_out
