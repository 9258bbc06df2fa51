"""Chain strokes: a curve whose vertices cap the speed below the slicer's feed.

Gyroid, honeycomb, concentric infill and curved walls at the slicer's full speed are
runs of short G1 segments (~0.7 mm, turning ~10-25 deg) where the firmware's junction law
caps the speed at the vertices (classic jerk, Klipper's square-corner velocity) well
below F: the firmware brakes to the cap at every vertex and accelerates after it at the
full acceleration -- a sawtooth, the worst motion in the file.  A curve stroke
(curves.py) with a vertex whose cap x CAP_MARGIN is below its feed is a chain (classify;
the planner's kind K_CHAIN, plan_kind); it is re-timed as a whole.  To the rest of the
program it stays a curve (kind=curve in its block and in the summary): the same run of
G1 lines, one per original line, only the law differs.

Law (laws/chain.py): min ∫(ṡ² + β s̈²)dt with ṡ <= cap_i at every vertex, between the
original end speeds, in a duration T from the candidates; β = (T / GAMMA_MIN)², the
inertia term dominates as for curves.  Between binding vertices the firmware plays
straight segments, so the law is 1-D: only s̈ is in ∫|a|²dt there.

Emission: every original vertex is a knot, no new points.  Each segment goes from the
law's speed at one vertex to the next in the law's time: a pure ramp (F = the faster
end, a = the ramp's) where the law is monotone, else the bump the firmware plays with
those end speeds in that time with the least ∫a²dt: a trapezoid (up, cruise at F, down;
~16 % below the triangle for a small bump), or the triangle under classic jerk.  Accelerations are raised
to what the junctions need and the planner buffer asks (as curves.finish_curve does).

Prediction (predict_chain): what the firmware does with those segments -- its junction
speed at each vertex is the lowest of the junction law at the segments' own
accelerations and feeds, both feeds, and what the neighbouring ramps reach (a forward
and a backward pass, as its lookahead); each segment is then its trapezoid, plus the
normal term the firmware model counts at every vertex turning <= 30 deg.  The candidate
table holds these predicted figures, so the budget is spent on what the firmware does.
"""
from __future__ import annotations

import math

import numpy as np

from . import curves
from .firmware.junction import (SQRT2_M1, klipper_corner_v2, marlin_jd_v2, marlin_jerk_junction_v,
                                marlin_safe_speed)
from .firmware.simulate import CORNER_COS
from .laws.chain import ChainProblem, solve_chains
from .plan import SPEED_TOL_R, T_RATIOS
from .segments import SegmentPlan, SegmentRules, hold_cruise_accels
from .strokes import K_CHAIN, K_CURVE

CHAIN_T_RATIOS = (0.98, 1.0, 1.01, 1.02, 1.03, 1.05, 1.07, 1.10, 1.16, 1.25)
CHAIN_COLS = np.array([int(np.argmin(np.abs(T_RATIOS - r))) for r in CHAIN_T_RATIOS])
GAMMA_MIN = 0.1            # beta = (T / GAMMA_MIN)^2: the law is the min-∫a² one up to a 1 % speed term
MIN_FEED_V = 0.1           # mm/s: F of a segment between two (near) stops
CHAIN_CAP_MARGIN = 0.98    # on the firmware's vertex caps (rounding of the written F and accelerations)


# ------------------------------------------------------------------ which curves are chains
def vertex_caps(st, profile):
    """Firmware speed cap at every interior vertex (mm/s) x CHAIN_CAP_MARGIN: what the law
    must stay under.  The firmware goes to its own cap at a vertex whatever the law says
    (nothing else holds it lower there), so these are the original's own vertex limits:
    at the acceleration in force (segments are raised to what their junctions need), and
    for classic jerk the whole jerk (a chain's feeds are level: tent_feeds), not the
    share curves.py keeps for a change of F."""
    g = curves.geom(st, profile)
    if g.chain_caps is None:
        if profile.junction == "jerk":
            caps = np.array([curves.vertex_cap(profile, st.lim, st.accel, tuple(g.u[k]), tuple(g.u[k + 1]),
                                               g.d[k], g.d[k + 1], jerk_r=1.0) for k in range(len(g.d) - 1)])
        else:
            caps = g.caps
        g.chain_caps = CHAIN_CAP_MARGIN * caps
    return g.chain_caps


def classify(strokes, rows, profile):
    """Curve strokes of `rows` with a vertex whose cap (x curves.CAP_MARGIN, as curves.py
    caps a curve's peak) is below the feed become chains."""
    for i in rows:
        st = strokes[i]
        if st.kind == K_CURVE:
            caps = curves.geom(st, profile).caps
            if caps.size and curves.CAP_MARGIN * float(np.min(caps)) < st.v_feed:
                st.chain_T = {}          # the mark of a chain (plan_kind)


def plan_kind(st):
    """The kind the planner treats a stroke as: a chain is a curve stroke to the rest of
    the program (same vertices, same emission, `kind=curve` in its block and summary)
    with its own law and candidates here."""
    return K_CHAIN if st.chain_T is not None and st.kind == K_CURVE else st.kind


def adjust_plan_inputs(pin, strokes, rows, profile):
    """Masses and acceleration cap as a curve's; the speed cap stays the stroke's own
    (F x overshoot): the vertex caps are the law's constraints, not a cap on its peak."""
    curves.adjust_plan_inputs(pin, strokes, rows, profile, cap_peak=False)


# ------------------------------------------------------------------ laws
def _problems(strokes, T, beta, profile):
    out = []
    for st, t, b in zip(strokes, T, beta):
        g = curves.geom(st, profile)
        out.append(ChainProblem(g.s_v[1:-1], vertex_caps(st, profile), st.length_d, t, b, st.v0, st.v1))
    return out


SOLVE_CHUNK = 256           # chains solved in one batch (bounded memory on files of 10^4 chains)


def solve(strokes, T, beta, profile):
    out = []
    for a in range(0, len(strokes), SOLVE_CHUNK):
        sl = slice(a, a + SOLVE_CHUNK)
        out += solve_chains(_problems(strokes[sl], T[sl], beta[sl], profile))
    return out


# ------------------------------------------------------------------ segments
def _a_top(st):
    return min(st.accel, st.lim.ax_max, st.lim.ay_max)


TRAP_GRID = np.linspace(0.0, 1.0, 33)[1:]    # cruise speeds tried between d/t and the triangle's peak


def shape_segments(d, t, va, vb, a_top=np.inf, trapezoid=True):
    """Per segment (length d, duration t, end speeds va -> vb): the firmware acceleration
    and feed that play it in that time.  A pure ramp where that takes at least t (F = the
    faster end).  Else a bump: the trapezoid up to F, cruise, down, whose ∫a²dt =
    a (2F - va - vb) is least among those taking t with a <= a_top, where
    a(F) = ((F - va)² + (F - vb)²) / (2 (F t - d)), d/t < F <= P; P is the triangle's peak
    (no cruise): the shape when no trapezoid fits a_top, and under classic jerk
    (trapezoid False), which counts a change of F between two moves as a jerk: there the
    feeds follow a tent from the slicer's F (tent_feeds) and a lifted F turns a trapezoid
    into a steeper triangle, while a triangle's F may be any value above its peak."""
    t_ramp = 2.0 * d / np.maximum(va + vb, 1e-12)
    ramp_a = np.abs(vb * vb - va * va) / (2.0 * d)
    bump = t < t_ramp * (1.0 - 1e-9)
    tt = np.where(bump, t, 1.0)
    disc = np.maximum(16.0 * d * d - 8.0 * tt * (2.0 * d * (va + vb) - tt * (va * va + vb * vb)), 0.0)
    peak = (4.0 * d + np.sqrt(disc)) / (4.0 * tt)
    peak = np.maximum(peak, np.maximum(va, vb))
    tri_a = (2.0 * peak * peak - va * va - vb * vb) / (2.0 * d)
    acc = np.where(bump, tri_a, ramp_a)
    feed = np.where(bump, peak, np.maximum(va, vb))
    if trapezoid and bump.any():
        b = np.flatnonzero(bump)
        lo = np.maximum(d[b] / tt[b], np.maximum(va[b], vb[b]))
        F = lo[:, None] + (peak[b] - lo)[:, None] * TRAP_GRID[None, :]
        x, y = va[b][:, None], vb[b][:, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            a = ((F - x) ** 2 + (F - y) ** 2) / (2.0 * (F * tt[b][:, None] - d[b][:, None]))
            cost = np.where((a > 0) & (a <= a_top), a * (2.0 * F - x - y), np.inf)
        j = np.argmin(cost, axis=1)
        r = np.arange(b.size)
        tri_cost = tri_a[b] * (2.0 * peak[b] - va[b] - vb[b])
        take = np.isfinite(cost[r, j]) & (cost[r, j] < tri_cost)
        acc[b] = np.where(take, a[r, j], tri_a[b])
        feed[b] = np.where(take, F[r, j], peak[b])
    return acc, np.maximum(feed, MIN_FEED_V)


def tent_feeds(need, v_feed, step_v):
    """Feeds >= need whose neighbours differ by <= step_v, the slicer's feed at both ends
    (as segments.segment_feeds, on per-segment needs: a triangle's F is its peak)."""
    if not np.isfinite(step_v):
        return need
    n = len(need)
    k = np.arange(n)
    pad = np.concatenate([[v_feed + step_v], need, [v_feed + step_v]])
    j = np.arange(-1, n + 1)
    return np.max(pad[None, :] - step_v * np.abs(k[:, None] - j[None, :]), axis=1)


def finish_chain(st, law, rules, profile):
    """SegmentPlan of one chain from its law, and whether its own ramps fit the
    acceleration limit (before what the junctions need is added; a ramp that does not
    is played at the limit, slower than the law: the prediction says how much)."""
    g = curves.geom(st, profile)
    d = g.d
    sk = np.concatenate([[0.0], np.asarray(st.ends_d, float)])
    vk = np.concatenate([[st.v0], law.vert_v, [st.v1]])
    tk = np.diff(np.concatenate([[0.0], law.vert_t, [law.problem.T]]))
    a_top = _a_top(st)
    acc, feed = shape_segments(d, np.maximum(tk, 1e-12), vk[:-1], vk[1:], a_top,
                               trapezoid=rules.junction != "jerk")
    fits = bool(np.all(acc <= a_top * (1 + SPEED_TOL_R)))
    acc = np.minimum(acc, a_top)
    acc = curves.junction_accels(st, g, vk, acc, rules, profile, vmax=feed)
    acc = hold_cruise_accels(acc, a_top)
    step_v = np.inf
    if rules.junction == "jerk":
        step_v = curves.JERK_F_STEP_R * min(st.lim.jerk_x, st.lim.jerk_y)
    feed = tent_feeds(feed, st.v_feed, step_v)
    t_pred, a2_pred = predict_chain(st, g, acc, feed, profile)
    return SegmentPlan(sk, vk, acc, feed, t_pred, a2_pred), fits


def _junction_v(profile, lim, pu, u, dp, dn, ap, an, fp, fn):
    """The firmware's junction speed limit between two moves with their own accelerations
    ap, an and feeds fp, fn (the laws of firmware/junction.py, as the firmware model)."""
    j = profile.junction
    if j == "scv":
        a0p, a_p = curves.accel_in_force(profile, lim, ap, pu)
        a0n, a_n = curves.accel_in_force(profile, lim, an, u)
        v2 = klipper_corner_v2(pu[0], pu[1], 0.0, lim.scv * lim.scv * SQRT2_M1 / a0p, a_p, 2.0 * dp * a_p,
                               u[0], u[1], 0.0, lim.scv * lim.scv * SQRT2_M1 / a0n, a_n, 2.0 * dn * a_n)
    elif j == "jd":
        _, a_n = curves.accel_in_force(profile, lim, an, u)
        v2 = marlin_jd_v2(pu[0], pu[1], 0.0, u[0], u[1], 0.0, dn, a_n, lim.jd, lim.ax_max, lim.ay_max, 1e9)
    else:
        jz = 1.0                           # z is 0 along a chain: any positive value
        sp = marlin_safe_speed(pu[0], pu[1], 0.0, fp, lim.jerk_x, lim.jerk_y, jz)
        sn = marlin_safe_speed(u[0], u[1], 0.0, fn, lim.jerk_x, lim.jerk_y, jz)
        v = marlin_jerk_junction_v(pu[0], pu[1], 0.0, fp, sp, u[0], u[1], 0.0, fn, sn,
                                   lim.jerk_x, lim.jerk_y, jz)
        return v
    return math.sqrt(v2) if math.isfinite(v2) else math.inf


def predict_chain(st, g, acc, feed, profile):
    """(time, ∫|a|²dt) of the firmware playing the chain's segments: junction speeds from
    its junction law, the feeds and its lookahead; trapezoids; normal vertex terms."""
    d = g.d
    n = d.size
    lim = st.lim
    v = np.empty(n + 1)
    v[0] = st.v0
    v[-1] = st.v1
    for k in range(1, n):
        vj = _junction_v(profile, lim, tuple(g.u[k - 1]), tuple(g.u[k]), d[k - 1], d[k],
                         acc[k - 1], acc[k], feed[k - 1], feed[k])
        v[k] = min(vj, feed[k - 1], feed[k])
    v2 = v * v
    reach = 2.0 * acc * d
    for k in range(1, n + 1):               # forward: what the ramps reach
        v2[k] = min(v2[k], v2[k - 1] + reach[k - 1])
    for k in range(n - 1, -1, -1):          # backward: what they can brake from
        v2[k] = min(v2[k], v2[k + 1] + reach[k])
    va2, vb2 = v2[:-1], v2[1:]
    peak2 = np.minimum(feed * feed, 0.5 * (reach + va2 + vb2))
    peak2 = np.maximum(peak2, np.maximum(va2, vb2))
    pk, va, vb = np.sqrt(peak2), np.sqrt(va2), np.sqrt(vb2)
    a = np.maximum(acc, 1e-12)
    up_d = (peak2 - va2) / (2.0 * a)
    dn_d = (peak2 - vb2) / (2.0 * a)
    cruise_d = np.maximum(d - up_d - dn_d, 0.0)
    t = (pk - va) / a + (pk - vb) / a + cruise_d / np.maximum(pk, 1e-9)
    a2 = float(np.sum(a * ((pk - va) + (pk - vb))))
    vi = va[1:]
    tj = 0.5 * (t[:-1] + t[1:])
    dv2 = 2.0 * vi * vi * (1.0 - g.cos_turn)
    a2 += float(np.sum(np.where(g.cos_turn >= CORNER_COS, dv2 / np.maximum(tj, 1e-12), 0.0)))
    c0 = None if st.prev_u is None else float(np.dot(st.prev_u, g.u[0]))
    c1 = None if st.next_u is None else float(np.dot(g.u[-1], st.next_u))
    for c, vv, tt in ((c0, va[0], t[0]), (c1, vb[-1], t[-1])):
        if c is not None and c >= CORNER_COS:
            a2 += 0.5 * 2.0 * vv * vv * (1.0 - c) / max(tt, 1e-12)
    return float(np.sum(t)), a2


def law_T(st, T):
    """The law's duration behind a candidate's predicted duration T (the candidate tables
    hold what the firmware takes; plan.T is one of them)."""
    return (st.chain_T or {}).get(float(T), float(T))


def plan_chain_segments(strokes, T, beta, rules, profile):
    """SegmentPlan per chain stroke (knots = the original vertices)."""
    T = np.array([law_T(st, t) for st, t in zip(strokes, T)], float)
    laws = solve(strokes, T, np.asarray(beta, float), profile)
    return [finish_chain(st, law, rules, profile)[0] for st, law in zip(strokes, laws)]


# ------------------------------------------------------------------ candidates
def _figures(strokes, rows, pin, T, beta, profile, rules):
    """Per (stroke, T): feasible?, predicted time and ∫|a|², the law's ∫ṡ².  Each stroke
    remembers which law T gave which predicted time (law_T)."""
    sts = [strokes[i] for i in rows]
    ok = np.zeros(len(sts), bool)
    tp = np.array(T, float)
    ia = np.full(len(sts), np.inf)
    iv = np.full(len(sts), np.nan)
    for a in range(0, len(sts), SOLVE_CHUNK):      # the laws of one chunk at a time
        _figures_chunk(sts, rows, pin, T, beta, profile, rules, a, ok, tp, ia, iv)
    return ok, tp, ia, iv


def _figures_chunk(sts, rows, pin, T, beta, profile, rules, a, ok, tp, ia, iv):
    sl = slice(a, a + SOLVE_CHUNK)
    laws = solve_chains(_problems(sts[sl], T[sl], beta[sl], profile))
    for k, (st, law) in enumerate(zip(sts[sl], laws), start=a):
        i = rows[k]
        if not (law.converged and law.min_v >= -1e-9 * (1 + pin.v_cap[i])
                and law.peak_v <= pin.v_cap[i] * (1 + SPEED_TOL_R) and T[k] >= pin.t_seg_min[i]):
            continue
        seg, _ = finish_chain(st, law, rules, profile)
        if not (np.isfinite(seg.int_a2) and np.isfinite(seg.time_t) and seg.time_t > 0):
            continue
        ok[k], tp[k], ia[k], iv[k] = True, seg.time_t, seg.int_a2, law.iv
        st.chain_T[float(seg.time_t)] = float(T[k])


def candidates_chain(pin, rows, strokes, profile, rules=None):
    """(T, beta, I, KE) for the chain strokes `rows`, shape (n, len(T_RATIOS)); inf where no
    candidate was computed or it breaks a limit.  I is the firmware's predicted ∫|a|²dt."""
    rules = rules or SegmentRules.for_profile(profile, 10)
    rows = np.asarray(rows, int)
    n, k_all = rows.size, len(T_RATIOS)
    T = pin.T_orig[rows, None] * T_RATIOS[None, :]
    I = np.full((n, k_all), np.inf)
    KE = np.full((n, k_all), np.nan)
    beta = np.full((n, k_all), np.inf)
    if n == 0:
        return T, beta, I, KE
    k = len(CHAIN_COLS)
    Tc = T[:, CHAIN_COLS].ravel()
    bc = (Tc / GAMMA_MIN) ** 2
    rr = np.repeat(rows, k)
    ok, tp, ia, iv = _figures(strokes, rr, pin, Tc, bc, profile, rules)
    T[:, CHAIN_COLS] = tp.reshape(n, k)
    I[:, CHAIN_COLS] = np.where(ok, ia, np.inf).reshape(n, k)
    KE[:, CHAIN_COLS] = iv.reshape(n, k)
    beta[:, CHAIN_COLS] = bc.reshape(n, k)
    return T, beta, I, KE


def fixed_alpha_chain(plan, pin, rows, strokes, profile, alpha, rules=None):
    """--alpha A on chains: beta = A * mass_r, T = the shortest candidate meeting the limits."""
    from .plan import take_shortest_feasible
    rules = rules or SegmentRules.for_profile(profile, 10)
    rows = np.asarray(rows, int)
    if rows.size == 0:
        return
    ratios = np.array(sorted(CHAIN_T_RATIOS))
    n, k = rows.size, ratios.size
    Tf = (pin.T_orig[rows, None] * ratios[None, :]).ravel()
    bf = np.repeat(alpha * pin.mass_r[rows], k)
    ok, tp, ia, iv = _figures(strokes, np.repeat(rows, k), pin, Tf, bf, profile, rules)
    take_shortest_feasible(plan, pin, rows, alpha, tp.reshape(n, k), ok.reshape(n, k),
                           iv.reshape(n, k), ia.reshape(n, k))
