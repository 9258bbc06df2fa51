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

import numpy as np

from .firmware.junction import accel_to_pass_junction
from .firmware.simulate import FULL_STOP_V
from .laws.line import line_law, time_of_distance

MIN_SEG_D = 0.3          # mm: shorter segments bloat the file for no fidelity gain
EDGE_D = 0.5             # mm: longest lead-in/lead-out at a corner speed
EDGE_T = 0.01            # s: ... and no longer than this at that speed (a slow lead-in costs time)


def segment_count(T, L, n_max, t_seg_min_t, min_seg_d=MIN_SEG_D):
    """How many segments a stroke of duration T and length L gets."""
    n = min(n_max, int(T / t_seg_min_t) if t_seg_min_t > 0 else n_max, int(L / min_seg_d))
    return max(n, 0)


def knots(stroke, T, beta, n, edge0_d=0.0, edge1_d=0.0):
    """Knot distances s_k (mm from stroke start) and speeds v_k (mm/s), k = 0..K, with
    s_0 = 0, s_K = L, every original vertex included, law knots too close to a vertex
    dropped.

    edge0_d / edge1_d > 0 add a lead-in / lead-out: a short segment run at the corner
    speed itself (v0 / v1, no speed change) that can carry whatever acceleration the
    firmware's junction law needs to keep that corner speed, at no cost in int a^2; the
    law is played on the rest of the stroke."""
    L = stroke.length_d
    law = line_law(L, T, beta, stroke.v0, stroke.v1)
    t = np.linspace(0.0, T, n + 1)
    s_law, _, _ = law.eval(t)
    s_law = np.asarray(s_law, float)
    verts = np.asarray(stroke.ends_d[:-1], float)          # interior original vertices
    min_gap = min(MIN_SEG_D, L / (4 * max(n, 1)))
    keep = np.ones(len(s_law), bool)
    if len(verts):
        gap = np.min(np.abs(s_law[:, None] - verts[None, :]), axis=1)
        keep[1:-1] &= gap[1:-1] >= min_gap
    s = np.sort(np.concatenate([s_law[keep], verts]), kind="stable")
    s[0], s[-1] = 0.0, L
    t_all = np.asarray(time_of_distance(law, s), float)
    _, v, _ = law.eval(t_all)
    v = np.maximum(np.asarray(v, float), 0.0)
    v[0], v[-1] = stroke.v0, stroke.v1
    if edge0_d > 0.0:
        edge0_d = min(edge0_d, 0.4 * s[1])
        s = np.concatenate([[0.0, edge0_d], s[1:]])
        v = np.concatenate([[stroke.v0, stroke.v0], v[1:]])
    if edge1_d > 0.0:
        edge1_d = min(edge1_d, 0.4 * (L - s[-2]))
        s = np.concatenate([s[:-1], [L - edge1_d, L]])
        v = np.concatenate([v[:-1], [stroke.v1, stroke.v1]])
    return s, v, None, law


def segment_feeds(v, v_feed, step_v=np.inf):
    """Feedrate (mm/s) of each segment: at least the faster of its two knot speeds (the
    ramp is set by the acceleration, F only caps it), and smooth from segment to segment.

    Marlin's classic jerk compares the NOMINAL speeds of consecutive moves, even
    collinear ones: F jumping by more than the jerk limit throttles the junction
    (planner.cpp, v_exit vs v_entry).  So with `step_v` finite, F is the tent envelope
    max_j(need_j - step_v*|k-j|), with the slicer's feed at both ends, so neighbouring
    F differ by <= step_v and the stroke meets its neighbours at their original F."""
    need = np.maximum(v[:-1], v[1:])
    if not np.isfinite(step_v):
        return need
    n = len(need)
    k = np.arange(n)
    pad = np.concatenate([[v_feed + step_v], need, [v_feed + step_v]])
    j = np.arange(-1, n + 1)
    return np.max(pad[None, :] - step_v * np.abs(k[:, None] - j[None, :]), axis=1)


def predict(s, v, a):
    """How a constant-acceleration firmware executes the segments (s, v knots; a per
    segment): each ramps at a_k over |dv| (a_k may exceed the ramp's need) and cruises
    the rest.  Returns (time_t, int_a2) -- the figures to weigh against the original."""
    d = np.diff(s)
    dv = np.abs(np.diff(v))
    vmax = np.maximum(v[:-1], v[1:])
    a = np.maximum(a, 1e-12)
    ramp_d = np.abs(np.diff(v * v)) / (2.0 * a)
    t = dv / a + np.maximum(d - ramp_d, 0.0) / np.maximum(vmax, 1e-9)
    return float(np.sum(t)), float(np.sum(a * dv))


def ramp_accels(s, v):
    """a_k that makes segment k one ramp from v_{k-1} to v_k."""
    d = np.diff(s)
    return np.abs(np.diff(v * v)) / (2.0 * d)


class SegmentRules:
    """What the firmware needs from segments (from the printer profile)."""

    def __init__(self, junction, n_max, seg_t, min_seg_d):
        self.junction, self.n_max, self.seg_t, self.min_seg_d = junction, n_max, seg_t, min_seg_d

    @classmethod
    def for_profile(cls, profile, max_segments):
        n_max = max_segments
        if profile.block_buffer:         # a finite-lookahead planner must see the whole stroke
            n_max = min(n_max, max(profile.block_buffer - 4, 2))
        seg_t = max(profile.min_segment_time_t, 1.0 / profile.max_segment_rate)
        # Marlin's JD caps straight runs of blocks shorter than 1 mm at v^2 = d a / 0.033
        min_d = 1.0 if profile.junction == "jd" else MIN_SEG_D
        return cls(profile.junction, n_max, seg_t, min_d)


class SegmentPlan:
    """Knots, per-segment acceleration and feed, and the firmware's predicted figures."""
    __slots__ = ("s", "v", "accel", "feed", "time_t", "int_a2")

    def __init__(self, s, v, accel, feed, time_t, int_a2):
        self.s, self.v, self.accel, self.feed, self.time_t, self.int_a2 = s, v, accel, feed, time_t, int_a2


def plan_segments(stroke, T, beta, rules: SegmentRules):
    """Segments that make the firmware play the law (L, T, beta, v0, v1) on this stroke,
    or None when the stroke is too short or quick for at least two segments."""
    n = segment_count(T, stroke.length_d, rules.n_max, rules.seg_t, rules.min_seg_d)
    if n < 2:
        return None
    u = (stroke.ux, stroke.uy)
    # a corner slower than FULL_STOP_V is a halt already: not worth an acceleration spike
    v0 = stroke.v0 if stroke.v0 >= FULL_STOP_V else 0.0
    v1 = stroke.v1 if stroke.v1 >= FULL_STOP_V else 0.0
    jd = stroke.lim.jd

    def needs(sk):
        return (accel_to_pass_junction(rules.junction, v0, stroke.prev_u, u, sk[1] - sk[0], jd),
                accel_to_pass_junction(rules.junction, v1, u, stroke.next_u, sk[-1] - sk[-2], jd))

    sk, vk, _, _ = knots(stroke, T, beta, n)
    acc = ramp_accels(sk, vk)
    need0, need1 = needs(sk)
    # Klipper's and Marlin's corner speeds scale with the entering block's acceleration:
    # a gently ramping first segment would slow the corner.  A lead-in at the corner speed
    # carries the acceleration the corner needs without changing speed.
    if need0 > acc[0] or need1 > acc[-1]:
        e0 = min(EDGE_D, max(stroke.v0 * EDGE_T, 0.05)) if need0 > acc[0] else 0.0
        e1 = min(EDGE_D, max(stroke.v1 * EDGE_T, 0.05)) if need1 > acc[-1] else 0.0
        sk, vk, _, _ = knots(stroke, T, beta, n, e0, e1)
        acc = ramp_accels(sk, vk)
        need0, need1 = needs(sk)
    acc[0] = max(acc[0], min(need0, stroke.accel))
    acc[-1] = max(acc[-1], min(need1, stroke.accel))
    if rules.junction == "jd":
        for k in range(1, len(acc)):
            need = accel_to_pass_junction("jd", vk[k], u, u, sk[k + 1] - sk[k], jd)
            acc[k] = max(acc[k], min(need, stroke.accel))
    step_v = np.inf
    if rules.junction == "jerk":         # per-axis jerk limit -> limit on the change of F
        step_v = 0.9 * min(stroke.lim.jerk_x, stroke.lim.jerk_y) / max(abs(stroke.ux), abs(stroke.uy))
    feeds = segment_feeds(vk, stroke.v_feed, step_v)
    t_pred, a2_pred = predict(sk, vk, acc)
    return SegmentPlan(sk, vk, acc, feeds, t_pred, a2_pred)
