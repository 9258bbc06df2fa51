"""Arc strokes: re-time a G2/G3 with the circle law and emit it as sub-arcs.

Plan.  One arc = one stroke, path length S = R |sweep|.  The law is the optimal circle law
(laws/circle.py, batched): φ(t) with end speeds v0/R, v1/R from the firmware model of the
original.  Candidates over T (a subset of plan.T_RATIOS, the other columns are inf so the
global allocation of plan.py sees one table), with β at each T the largest one whose
*line* law (same S, T, v0, v1) keeps the peak speed under v_cap: the circle law of the same
β has no higher peak (its 6κ²ṡ²s̈ term flattens the profile; checked on the solved law,
infeasible candidates dropped, one retry at β/4).  ∫|a|² of the law includes the centripetal
part (s̈² + ṡ⁴/R²), as does the firmware model's figure for the original (chord junctions).

Firmware facts (firmware/junction.py, simulate.py): G2/G3 are cut into chords of about
profile.arc_segment_d; the chord junctions are limited by
  * Klipper: v² <= 2 c a tan(θ/2)/... ~ a R (centripetal term, scales with the move's
    acceleration a) and v² <= R_jd scv² (√2-1) (independent of a);
  * Marlin JD: v² <= a jd R_jd and, chords < 1 mm, v² <= c a / θ ~ a R;
  * classic jerk: v 2 sin(θ/2) <= jerk per axis (independent of a).
So a sub-arc must carry an acceleration >= its peak v²/R (x margin) on Klipper/JD, and its
speed must stay under the accel-independent caps everywhere.  The price: the firmware ramps
such a sub-arc at that acceleration, faster than the law's tangential acceleration, which
adds a |Δv| per sub-arc to ∫|a|² (predict_arc accounts for it; the planner compares the
prediction with the original and keeps the original where the arc would not gain).
"""
from __future__ import annotations

import math

import numpy as np

from .firmware.junction import SQRT2_M1, accel_to_pass_junction
from .firmware.simulate import ARC_MIN_TURN, FULL_STOP_V, arc_chords
from .distinct import distinct
from .laws.circle import grid_levels_of, solve_circles
from .plan import SPEED_TOL_R, T_RATIOS, candidate_table, take_shortest_feasible
from .segments import SegmentPlan, hold_cruise_accels, least_a2_trapezoid, segment_feeds

ARC_T_RATIOS = (0.90, 0.96, 1.0, 1.02, 1.05, 1.10, 1.20)
ARC_COLS = np.array([int(np.argmin(np.abs(T_RATIOS - r))) for r in ARC_T_RATIOS])
GAMMA_MIN = 0.1            # beta <= (T/GAMMA_MIN)^2: the circle solver needs a finite beta
CHORD_MARGIN = 1.05        # sub-arc accel >= margin x what the chord junctions need
MIN_SUBARC_D = 2.0         # mm: a sub-arc spans at least ~2 firmware chords
CAP_MARGIN = 0.95          # on the accel-independent chord caps


def chord_d(S, profile, R=None):
    """Chord length the firmware cuts an arc of length S (radius R) into: simulate.py's
    rule (arc_chords), floor(S / arc_segment_d) chords, at most one per ARC_MIN_TURN rad
    (a huge radius is not cut into millions of chords)."""
    seg = profile.arc_segment_d
    S = np.asarray(S, float)
    n = np.maximum(np.floor(S / seg), 1.0) if seg > 0 else np.ones_like(S)
    if R is not None:
        n = np.minimum(n, np.maximum(np.ceil(S / (np.asarray(R, float) * ARC_MIN_TURN)), 1.0))
    return S / n


def _turn_dirs(theta):
    """Unit directions of two chords turning by theta (pu, u) for accel_to_pass_junction."""
    return (1.0, 0.0), (math.cos(theta), math.sin(theta))


def chord_need_per_v2(junction, c, R, jd):
    """Acceleration per v² that the chord junctions of an arc (chord c, radius R) need."""
    pu, u = _turn_dirs(min(c / R, math.pi / 2))
    return accel_to_pass_junction(junction, 1.0, pu, u, c, jd)


def chord_speed_cap(profile, lim, c, R):
    """Speed cap (mm/s) at the chord junctions that no acceleration lifts."""
    theta = min(c / R, math.pi / 2)
    if profile.junction == "jerk":
        return CAP_MARGIN * min(lim.jerk_x, lim.jerk_y) / max(2.0 * math.sin(theta / 2.0), 1e-12)
    if profile.junction == "scv":
        sin_d2 = math.cos(theta / 2.0)              # junction angle = pi - theta
        r_jd = sin_d2 / max(1.0 - sin_d2, 1e-300)
        return CAP_MARGIN * math.sqrt(r_jd * lim.scv * lim.scv * SQRT2_M1)
    return math.inf


def adjust_plan_inputs(pin, strokes, rows, profile):
    """Arc rows of a PlanInput: direction-averaged masses and caps, chord caps."""
    mx, my = profile.moving_mass_x_kg, profile.moving_mass_y_kg
    for i in rows:
        st = strokes[i]
        a = st.arc
        # mean of cos^2 over the swept angles (the velocity is tangent: angle + 90 deg)
        th0, sw = a.theta0, a.sweep
        if abs(sw) > 1e-9:
            c2 = 0.5 - (math.sin(2 * (th0 + sw)) - math.sin(2 * th0)) / (4.0 * sw)
        else:
            c2 = 0.5
        c2 = min(max(c2, 0.0), 1.0)      # <ux^2> = <sin^2 th> = 1 - <cos^2 th>
        ux2 = 1.0 - c2
        uy2 = c2
        m = mx * ux2 + my * uy2
        m2 = mx * mx * ux2 + my * my * uy2
        pin.mass_r[i] = m2 / m
        pin.a_cap[i] = min(st.accel, st.lim.ax_max, st.lim.ay_max)
        c = float(chord_d(np.array(st.length_d), profile, a.r))
        cap = chord_speed_cap(profile, st.lim, c, a.r)
        per_v2 = chord_need_per_v2(profile.junction, c, a.r, st.lim.jd)
        if per_v2 > 0:
            cap = min(cap, math.sqrt(pin.a_cap[i] / (CHORD_MARGIN * per_v2)))
        pin.v_cap[i] = min(pin.v_cap[i], cap)
        if max(st.v0, st.v1) > pin.v_cap[i]:      # no law fits: the same arc, gentler
            if not hasattr(pin, "arc_gentle"):
                pin.arc_gentle = {}
            pin.arc_gentle[int(i)] = [o[1:] for o in gentle_options(st, profile) if o[2] < st.int_a2]


def _solve(S, R, T, beta, v0, v1):
    law = solve_circles(S / R, T, beta, v0 / R, v1 / R, R)
    return law


def _feasible(law, v_cap, a_cap):
    return ((law.peak_speed() <= v_cap * (1 + SPEED_TOL_R)) & (law.peak_accel() <= a_cap * (1 + SPEED_TOL_R))
            & (law.min_speed() >= -1e-9 * (1 + v_cap)))


def candidates_arc(pin, rows, strokes, levels=None, own_levels=None):
    """(T, beta, I, KE) rows for the arc strokes `rows` (shape (n, len(T_RATIOS))), inf
    where no candidate was computed or it breaks a limit.

    A pass's figures and limits are read on the quadrature grid of all its candidates
    (panel levels the largest of theirs: CircleBatch._grid_plan), so a window of the
    strokes alone would take other levels, and other bits (~1e-16), than the whole file.
    levels: (first pass, retries) floors of those levels (the file's: every window then
    reads its laws on the file's grid), None: each pass's own.  own_levels (a list):
    given each pass's (own levels before the floor, True: it made figures), as
    curves.candidates_curve's (schedule.candidates_in_windows)."""
    rows = np.asarray(rows, int)
    k = len(ARC_COLS)

    def flat(x):
        return np.repeat(np.asarray(x), k)

    R, S = flat([strokes[i].arc.r for i in rows]), flat(pin.L[rows])
    v0, v1, vc, ac = (flat(x[rows]) for x in (pin.v0, pin.v1, pin.v_cap, pin.a_cap))
    npass = [0]             # candidate_table's pass (0: first, 1: the beta/4 retries)

    def solve_figures(idx, T, beta):
        law = _solve(S[idx], R[idx], T, beta, v0[idx], v1[idx])
        if own_levels is not None:
            own_levels.append((law.panel_levels(), True))
        if levels is not None and npass[0] < len(levels):
            law.grid_levels = levels[npass[0]]
        npass[0] += 1
        iv, ia = law.integrals()
        return iv, ia, _feasible(law, vc[idx], ac[idx])

    T, beta, I, KE = candidate_table(pin, rows, ARC_COLS, solve_figures, GAMMA_MIN)
    gentle = getattr(pin, "arc_gentle", None) or {}
    for r, i in enumerate(rows.tolist()):
        got = gentle.get(i)
        if not got or np.isfinite(I[r]).any():
            continue
        for j, (t_g, i_g, ke_g) in enumerate(got[:len(T_RATIOS)]):   # beta = inf marks them
            T[r, j], I[r, j], KE[r, j], beta[r, j] = t_g, i_g, ke_g, np.inf
    return T, beta, I, KE


def arc_grid_levels(pin, rows, strokes):
    """The panel levels of candidates_arc's first pass over the arc strokes rows: the
    largest of every candidate's it solves (at its first beta: candidate_table's), made
    without solving a law (the layer regime only: circle.grid_levels_of); 0: none.  A
    largest, so the levels of several sets of rows are the largest of theirs.  (The
    retries' are known only once the first pass's figures are: candidates_in_windows.)"""
    rows = np.asarray(rows, int)
    k = len(ARC_COLS)
    R = np.repeat(np.array([strokes[i].arc.r for i in rows.tolist()], float), k)
    S, v0, v1 = (np.repeat(x[rows], k) for x in (pin.L, pin.v0, pin.v1))
    got = [0]

    def levels_only(idx, T, beta):
        got[0] = max(got[0], grid_levels_of(S[idx] / R[idx], T, beta, v0[idx] / R[idx], v1[idx] / R[idx]) or 0)
        nan = np.full(idx.size, np.nan)
        return nan, nan, np.ones(idx.size, bool)      # (all "within limits": no retry pass)

    candidate_table(pin, rows, ARC_COLS, levels_only, GAMMA_MIN)
    return got[0]


# ------------------------------------------------------------------ gentler arcs
GENTLE_STEPS = 8            # accelerations tried: a_orig / 2^k, k = 0..7, and the least that works


def gentle_figures(st, profile, a, junction=None):
    """Time and int|a|^2 dt of the arc played as it is (the slicer's F) at acceleration a,
    as the firmware plays its chords (cut as simulate.arc_chords, Klipper's cruise ratio 0
    inside a block): chord junctions at min(the acceleration-independent cap, the one
    that scales with a), forward/backward passes at a, a trapezoid per chord, plus the
    centripetal v^4/R^2.  None when the arc could no longer be entered at v0 or left at
    v1 (the neighbouring moves would change)."""
    junction = junction or profile.junction
    S, R = st.length_d, st.arc.r
    n = arc_chords(S, st.arc.sweep, profile.arc_segment_d)
    c = S / n
    v0, v1, F = st.v0, st.v1, st.v_feed
    vj2 = math.inf
    if n > 1:
        cap = chord_speed_cap(profile, st.lim, c, R) / CAP_MARGIN
        per_v2 = chord_need_per_v2(junction, c, R, st.lim.jd)
        vj2 = min(cap * cap, a / per_v2 if per_v2 > 0 else math.inf, F * F)
    J2 = np.full(n + 1, vj2)
    J2[0], J2[-1] = v0 * v0, v1 * v1
    for k in range(n - 1, -1, -1):              # backward: able to brake to the next junction
        J2[k] = min(J2[k], J2[k + 1] + 2 * a * c)
    for k in range(n):                         # forward: able to reach it
        J2[k + 1] = min(J2[k + 1], J2[k] + 2 * a * c)
    if J2[0] < v0 * v0 * (1 - 1e-9) or J2[-1] < v1 * v1 * (1 - 1e-9):
        return None
    Ja, Jb = np.sqrt(J2[:-1]), np.sqrt(J2[1:])
    pk = np.maximum(np.minimum(F, np.sqrt((2 * a * c + J2[:-1] + J2[1:]) / 2)), np.maximum(Ja, Jb))
    cruise_d = np.maximum(c - (2 * pk * pk - J2[:-1] - J2[1:]) / (2 * a), 0.0)
    t = (2 * pk - Ja - Jb) / a + cruise_d / np.maximum(pk, 1e-9)
    cent = ((2 * pk ** 5 - Ja ** 5 - Jb ** 5) / (5 * a) + pk ** 3 * cruise_d) / (R * R)
    return float(t.sum()), float(np.sum(a * (2 * pk - Ja - Jb)) + cent.sum()), float(np.sum(pk * pk * c / np.maximum(pk, 1e-9)))


def gentle_options(st, profile):
    """[(a, time_t, int_a2, int_v2~)] for the arc at the slicer's F and gentler
    accelerations: the arcs no law fits (their chord junctions cap the speed below an end
    speed, e.g. gyroid fitted with arcs of ~2 mm radius: the firmware brakes at full
    acceleration into every chord junction and speeds up again).  Each a must still pass
    the arc's corners with the neighbouring moves."""
    a_top = min(st.accel, st.lim.ax_max, st.lim.ay_max)
    if not (a_top > 0 and st.v_feed > 0 and st.length_d > 0):
        return []
    c = float(chord_d(np.array(st.length_d), profile, st.arc.r))
    sgn = 1.0 if st.arc.sweep > 0 else -1.0
    tha = st.arc.theta0 + sgn * c / (2.0 * st.arc.r)
    thb = st.arc.theta0 + st.arc.sweep - sgn * c / (2.0 * st.arc.r)
    u_start = (-math.sin(tha) * sgn, math.cos(tha) * sgn)
    u_end = (-math.sin(thb) * sgn, math.cos(thb) * sgn)
    need = max(accel_to_pass_junction(profile.junction, st.v0, st.prev_u, u_start, c, st.lim.jd),
               accel_to_pass_junction(profile.junction, st.v1, u_end, st.next_u, c, st.lim.jd))
    out = []
    for k in range(GENTLE_STEPS):
        a = a_top / 2 ** k
        if a < CHORD_MARGIN * need:
            break
        got = gentle_figures(st, profile, a)
        if got is None:
            break
        out.append((a,) + got)
    return out


def gentle_plan(st, profile, T):
    """The gentle_options entry whose time is T (the plan chose it) as a SegmentPlan: one
    sub-arc, the slicer's F, its own acceleration."""
    opts = gentle_options(st, profile)
    if not opts:
        return None
    a, t, i2, _ = min(opts, key=lambda o: abs(o[1] - T))
    acc = hold_cruise_accels(np.array([a]), st.accel)
    return SegmentPlan(np.array([0.0, st.length_d]), np.array([st.v0, st.v1]), acc, np.array([st.v_feed]),
                       t, i2, "gentle")


# ------------------------------------------------------------------ segments
def arc_knots(strokes, T, beta, n, profile=None):
    """Knots (s, v) of each arc's law at n_i + 1 instants evenly spaced in time."""
    m = len(strokes)
    if m == 0:
        return []
    R = np.array([st.arc.r for st in strokes])
    S = np.array([st.length_d for st in strokes])
    v0 = np.array([st.v0 for st in strokes])
    v1 = np.array([st.v1 for st in strokes])
    T, beta, n = np.asarray(T, float), np.asarray(beta, float), np.asarray(n, int)
    law = _solve(S, R, T, beta, v0, v1)
    c0 = chord_d(S, profile, R) if profile is not None else np.zeros(m)
    out = []
    for sl in law.row_chunks():                  # evaluated by chunks: bounded memory
        sub = law.rows(sl)
        phi, w = _own_instants(sub, n[sl], T[sl])
        dense = np.linspace(0.0, 1.0, 257)[None, :] * T[sl, None]
        phi_d, w_d, _ = sub.eval(dense)
        for k, i in enumerate(range(m)[sl]):
            s = R[i] * phi[k, :n[i] + 1]
            v = np.maximum(R[i] * w[k, :n[i] + 1], 0.0)
            s[0], s[-1] = 0.0, S[i]
            if c0[i] > 0 and S[i] >= 4.0 * c0[i]:
                # first and last sub-arcs = the original's first and last firmware chords, so
                # the junctions with the neighbouring moves see the original's geometry (at a
                # near-reversal, e.g. a wipe, a few degrees decide whether the machine stops)
                inner = s[(s > 1.5 * c0[i]) & (s < S[i] - 1.5 * c0[i])]
                s = np.concatenate([[0.0, c0[i]], inner, [S[i] - c0[i], S[i]]])
                v = np.maximum(np.interp(s, R[i] * phi_d[k], R[i] * w_d[k]), 0.0)
            v[0], v[-1] = v0[i], v1[i]
            out.append((s, v))
    return out


def _own_instants(law, n, T):
    """(φ, φ̇) of each arc of law at its n_i + 1 instants evenly spaced in its time T_i,
    (arcs, n.max() + 1), columns past an arc's own unset.  The arcs of one n evaluated
    together on their n + 1 instants only: a BLAS product's element rounds with the number
    of columns (_series_values), so a grid padded to the batch's largest n gave an arc other
    bits in another batch."""
    phi, w = np.empty((2, n.size, n.max() + 1))
    for k in distinct(n).tolist():
        r = np.flatnonzero(n == k)
        got = law.eval((np.arange(k + 1) / k)[None, :] * T[r, None], r)
        phi[r, :k + 1], w[r, :k + 1] = got[0], got[1]
    return phi, w


def predict_arc(s, v, a, R, feed=None):
    """Firmware execution of sub-arcs (ramp at a_k over |Δv|, cruise the rest): time and
    ∫|a|² = tangential Σ a_k |Δv_k| + centripetal ∫ v⁴/R² dt.  With `feed`, a sub-arc may
    cruise above both its knot speeds: up at a_k to min(F_k, its triangle peak), cruise, down."""
    if feed is not None:
        return _predict_arc_peaked(s, v, a, R, np.asarray(feed, float))
    d = np.diff(s)
    va, vb = v[:-1], v[1:]
    vmax = np.maximum(va, vb)
    a = np.maximum(a, 1e-12)
    ramp_d = np.abs(vb * vb - va * va) / (2.0 * a)
    cruise_d = np.maximum(d - ramp_d, 0.0)
    t = np.abs(vb - va) / a + cruise_d / np.maximum(vmax, 1e-9)
    cent = (np.abs(vb ** 5 - va ** 5) / (5.0 * a) + vmax ** 3 * cruise_d) / (R * R)
    return float(np.sum(t)), float(np.sum(a * np.abs(vb - va)) + np.sum(cent))


def _predict_arc_peaked(s, v, a, R, feed):
    d = np.diff(s)
    va, vb = v[:-1], v[1:]
    a = np.maximum(a, 1e-12)
    vt = np.sqrt(np.maximum((2.0 * a * d + va * va + vb * vb) / 2.0, 0.0))
    pk = np.maximum(np.minimum(feed, vt), np.maximum(va, vb))
    cruise_d = np.maximum(d - (2.0 * pk * pk - va * va - vb * vb) / (2.0 * a), 0.0)
    t = (2.0 * pk - va - vb) / a + cruise_d / np.maximum(pk, 1e-9)
    cent = ((2.0 * pk ** 5 - va ** 5 - vb ** 5) / (5.0 * a) + pk ** 3 * cruise_d) / (R * R)
    return float(np.sum(t)), float(np.sum(a * (2.0 * pk - va - vb)) + np.sum(cent))


def plan_arc_segments(strokes, T, beta, rules, profile):
    """SegmentPlan per arc stroke (None where no plan beats the original).  beta = inf
    marks the same arc at a gentler acceleration (candidates_arc): gentle_plan."""
    n = []
    gentle = ~np.isfinite(np.asarray(beta, float))
    for st, t, vy in zip(strokes, T, gentle):
        k = min(rules.n_max, int(st.length_d / MIN_SUBARC_D), int(t / rules.seg_t) if rules.seg_t > 0 else 99)
        n.append(0 if vy else max(k, 0))
    n = np.array(n, int)
    ok = np.flatnonzero(n >= 2)
    plans = [None] * len(strokes)
    knots = arc_knots([strokes[i] for i in ok], np.asarray(T)[ok], np.asarray(beta)[ok], n[ok], profile)
    for i, (sk, vk) in zip(ok, knots):
        plans[i] = finish_arc(strokes[i], sk, vk, rules, profile)
    # too short for two sub-arcs, or sub-arcs that would not beat the original: one sub-arc
    # played as the least-int-a^2 trapezoid of the same duration, when that beats the original
    for i in np.flatnonzero(gentle).tolist():
        p = gentle_plan(strokes[i], profile, float(np.asarray(T, float)[i]))
        plans[i] = p if p is not None and p.int_a2 < strokes[i].int_a2 else None
    short = np.array([i for i, p in enumerate(plans)
                      if not gentle[i] and (p is None or not p.int_a2 < strokes[i].int_a2)], int)
    if short.size:
        sts = [strokes[i] for i in short]
        law = _solve(np.array([s.length_d for s in sts]), np.array([s.arc.r for s in sts]), np.asarray(T, float)[short],
                     np.asarray(beta, float)[short], np.array([s.v0 for s in sts]), np.array([s.v1 for s in sts]))
        peaks = np.asarray(law.peak_speed(), float)
        for i, st, t, pk in zip(short.tolist(), sts, np.asarray(T, float)[short], peaks):
            p = arc_trapezoid(st, float(t), float(pk), rules, profile)
            if p is not None and p.int_a2 < st.int_a2 and (plans[i] is None or p.int_a2 < plans[i].int_a2):
                plans[i] = p
    return plans


def arc_trapezoid(st, T, v_peak, rules, profile):
    """One sub-arc (the G2/G3 itself with its own F and acceleration) that the firmware
    plays as the trapezoid of duration <= T with the least int a^2 (segments.
    least_a2_trapezoid), no faster than the planned law's peak v_peak; its acceleration
    covers its chord junctions at the peak (x CHORD_MARGIN), the junctions with the
    neighbouring moves and, under a finite Marlin buffer, a stop within the buffer."""
    R, S, jd = st.arc.r, st.length_d, st.lim.jd
    v0 = st.v0 if st.v0 >= FULL_STOP_V else 0.0
    v1 = st.v1 if st.v1 >= FULL_STOP_V else 0.0
    c = float(chord_d(np.array(S), profile, R))
    per_v2 = CHORD_MARGIN * chord_need_per_v2(rules.junction, c, R, jd)
    sgn = 1.0 if st.arc.sweep > 0 else -1.0
    tha = st.arc.theta0 + sgn * c / (2.0 * R)
    thb = st.arc.theta0 + st.arc.sweep - sgn * c / (2.0 * R)
    u_start = (-math.sin(tha) * sgn, math.cos(tha) * sgn)
    u_end = (-math.sin(thb) * sgn, math.cos(thb) * sgn)
    a_top = min(st.accel, st.lim.ax_max, st.lim.ay_max)
    # the original passed its corners with at most a_top (the firmware caps M204 per axis)
    need_ends = min(max(CHORD_MARGIN * accel_to_pass_junction(rules.junction, v0, st.prev_u, u_start, c, jd),
                        CHORD_MARGIN * accel_to_pass_junction(rules.junction, v1, u_end, st.next_u, c, jd)),
                    a_top)
    window_d = max(profile.block_buffer - 3, 1) * c if profile.block_buffer > 0 else math.inf
    # the law starts and ends at v0 and v1, so its peak is at least both: a peak at an end,
    # rounded one ulp below it, must not leave no trapezoid (the choice hung on rounding)
    v_lo, v_hi = 0.0, max(v_peak, v0, v1)
    if rules.junction == "jerk":       # F within the jerk of the slicer's F (finish_arc's step)
        step_v = 0.5 * min(st.lim.jerk_x, st.lim.jerk_y)
        v_lo, v_hi = st.v_feed - step_v, min(v_hi, st.v_feed + step_v)

    def a_min(vp):
        return np.maximum(np.maximum(per_v2 * vp * vp, need_ends), 1.1 * vp * vp / (2.0 * window_d))

    def centripetal(vp, a):        # int v^4/R^2 dt of the trapezoid (full cruise at vp)
        cruise_d = np.maximum(S - (2 * vp * vp - v0 * v0 - v1 * v1) / (2 * a), 0.0)
        return ((2 * vp ** 5 - v0 ** 5 - v1 ** 5) / (5 * a) + vp ** 3 * cruise_d) / (R * R)

    got = least_a2_trapezoid(S, T, v0, v1, v_lo, v_hi, a_top, a_min, centripetal)
    if got is None:
        return None
    vp, a, _, _ = got
    s = np.array([0.0, S])
    v = np.array([v0, v1])
    acc = hold_cruise_accels(np.array([a]), st.accel)
    feed = np.array([vp])
    t_pred, a2_pred = predict_arc(s, v, acc, R, feed)
    return SegmentPlan(s, v, acc, feed, t_pred, a2_pred, "trapezoid")


def finish_arc(st, sk, vk, rules, profile):
    R = st.arc.r
    d = np.diff(sk)
    acc = np.abs(np.diff(vk * vk)) / (2.0 * d)
    c = chord_d(d, profile, R)                      # each sub-arc is cut on its own
    c_nb = np.maximum(c, np.maximum(np.concatenate([[c[0]], c[:-1]]), np.concatenate([c[1:], [c[-1]]])))
    vmax = np.maximum(vk[:-1], vk[1:])
    jd = st.lim.jd
    for k in range(len(d)):
        pu, u = _turn_dirs(min(c_nb[k] / R, math.pi / 2))
        need = CHORD_MARGIN * accel_to_pass_junction(rules.junction, vmax[k], pu, u, c[k], jd)
        acc[k] = max(acc[k], min(need, st.accel))
    if profile.block_buffer > 0:
        # a finite-lookahead planner (Marlin) must be able to stop within the blocks it
        # knows: ~(B - 3) chords ahead.  The firmware cuts the arc into chords whatever we
        # do, so every sub-arc needs a_floor = v_max^2 / (2 D_window) or the planner
        # crawls (a law at near-constant speed would otherwise get ~0.1 mm/s^2).
        window_d = max(profile.block_buffer - 3, 1) * float(np.min(c))
        a_floor = 1.1 * float(np.max(vk)) ** 2 / (2.0 * window_d)
        acc = np.maximum(acc, min(a_floor, st.accel))
    # the arc's own ends: the junction with the neighbouring moves
    v0 = st.v0 if st.v0 >= FULL_STOP_V else 0.0
    v1 = st.v1 if st.v1 >= FULL_STOP_V else 0.0
    # directions of the first and last firmware chords (not the tangents: at a near-reversal
    # such as a wipe the few degrees between them decide the junction speed)
    sgn = 1.0 if st.arc.sweep > 0 else -1.0
    tha = st.arc.theta0 + sgn * c[0] / (2.0 * R)
    thb = st.arc.theta0 + st.arc.sweep - sgn * c[-1] / (2.0 * R)
    u_start = (-math.sin(tha) * sgn, math.cos(tha) * sgn)
    u_end = (-math.sin(thb) * sgn, math.cos(thb) * sgn)
    acc[0] = max(acc[0], min(CHORD_MARGIN * accel_to_pass_junction(rules.junction, v0, st.prev_u, u_start, c[0], jd),
                             st.accel))
    acc[-1] = max(acc[-1], min(CHORD_MARGIN * accel_to_pass_junction(rules.junction, v1, u_end, st.next_u, c[-1], jd),
                               st.accel))
    step_v = np.inf
    if rules.junction == "jerk":
        step_v = 0.5 * min(st.lim.jerk_x, st.lim.jerk_y)
    acc = hold_cruise_accels(acc, st.accel)
    feeds = segment_feeds(vk, st.v_feed, step_v)
    t_pred, a2_pred = predict_arc(sk, vk, acc, R)
    return SegmentPlan(sk, vk, acc, feeds, t_pred, a2_pred)


def fixed_alpha_arc(plan, pin, rows, strokes, alpha):
    """--alpha A on arcs: beta = A * mass_r, T = the shortest candidate meeting the limits."""
    rows = np.asarray(rows, int)
    if rows.size == 0:
        return
    ratios = np.array(sorted(ARC_T_RATIOS))
    R = np.array([strokes[i].arc.r for i in rows])
    n, k = rows.size, ratios.size
    bb = lambda a: np.broadcast_to(np.asarray(a)[:, None], (n, k)).ravel()
    Tf = (pin.T_orig[rows, None] * ratios[None, :]).ravel()
    beta = bb(alpha * pin.mass_r[rows])
    law = _solve(bb(pin.L[rows]), bb(R), Tf, beta, bb(pin.v0[rows]), bb(pin.v1[rows]))
    ok = (_feasible(law, bb(pin.v_cap[rows]), bb(pin.a_cap[rows])) & (Tf >= bb(pin.t_seg_min[rows]))).reshape(n, k)
    iv, ia = (x.reshape(n, k) for x in law.integrals())
    take_shortest_feasible(plan, pin, rows, alpha, Tf.reshape(n, k), ok, iv, ia)
