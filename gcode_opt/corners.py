"""Slower corners: spend print time on lower speeds where strokes meet a corner.

At a corner turning by theta the firmware jumps the velocity vector by |dv| = 2 v sin(theta/2)
at the junction speed v it allows.  A jump is an impulse for the frame: the ringing it starts
has, per axis, energy (the integral of r^2 over time) dv_axis^2 / (4 z w^3) -- quadratic in
the corner speed.  A stroke that starts or ends slower than the firmware's junction speed
shrinks that jump; it costs time (a longer deceleration, and the lead-in / lead-out segment
the firmware must play at the corner speed for it to slow down at all: segments.py).

Objective (why not J): the paper's J counts an impulse as infinite whatever its size, so it
cannot rank corner speeds; the ringing energy can, and it is what the resonance model
(ringing.py) reports.  Per stroke end e with turn weight k_e (sum over axes of the change of
the unit vector squared, weighted 1/w_axis^3) the corner's energy is k_e v_e^2; its time
cost dt_e(v_e) (model below).  end_speeds minimises sum k_e v_e^2 + lam sum dt_e(v_e) per end
on a grid of speeds, lam set by bisection so the time spent is the budget: every end gets
the speed where one more second buys the same energy everywhere.

In the product (`--corners R`, Options.corner_budget_r; schedule.plan_inputs calls
lower_corners): the corners may spend R x --max-slowdown x the strokes' original time;
`--corners auto`: R = the corners' share of the original's ringing energy (corner_share).
That time is not on top of --max-slowdown: the planner budgets every stroke's law against
its original time, so what slower ends cost comes out of the same budget and the laws get
the rest.  Only line strokes are lowered (segments.py writes their lead-in / lead-out at the
corner speed); arcs, curves and chains keep their ends, and so does a line end that meets
one of them (the junction is one speed for both sides).

The firmware's junction speed stays an upper bound (v_e <= the original's); speeds never go
below MIN_CORNER_V (no new full stops: the firmware model counts < 0.5 mm/s as a stop, and
segment feeds are written to 0.1 mm/s).
"""
from __future__ import annotations

import math

import numpy as np

from .firmware.simulate import CORNER_COS

MIN_CORNER_V = 1.0       # mm/s: the slowest corner chosen (2x the model's full-stop threshold)
EDGE_D = 0.05            # mm: the lead-in / lead-out a slowed end needs at least (segments.py MIN 0.05)
EDGE_T = 0.01            # s: ... or this long at the corner speed, whichever is longer
GRID = 48                # corner speeds tried per end, geometric between MIN_CORNER_V and the original
BUDGET_R = 0.02          # default: 2 % of the strokes' original time
END_COST_R = 0.25        # one slowed end costs at most this share of its stroke's original time
                         # (the planner's candidates stop at 1.5 x: a stroke slowed beyond has no law)


def _unit(x, y):
    d = math.hypot(x, y)
    return (x / d, y / d) if d > 0 else None


def end_tangents(st):
    """Unit XY tangents at a stroke's start and end (lines, arcs, curves)."""
    if st.kind == "arc" and st.arc is not None:
        a = st.arc
        sgn = 1.0 if a.sweep > 0 else -1.0
        th = a.theta0 + a.sweep
        return (st.ux, st.uy), (-math.sin(th) * sgn, math.cos(th) * sgn)
    if st.kind == "curve" and st.pts and len(st.pts) >= 2:
        (x0, y0), (x1, y1) = st.pts[0], st.pts[1]
        (xa, ya), (xb, yb) = st.pts[-2], st.pts[-1]
        return _unit(x1 - x0, y1 - y0) or (st.ux, st.uy), _unit(xb - xa, yb - ya) or (st.ux, st.uy)
    return (st.ux, st.uy), (st.ux, st.uy)


def _weights(u_from, u_to, wx, wy):
    """k: the corner's ringing energy per v^2 (sum over axes of du^2 / w^3, relative)."""
    if u_from is None or u_to is None:
        return 0.0, 1.0
    cos_t = u_from[0] * u_to[0] + u_from[1] * u_to[1]
    dux, duy = u_to[0] - u_from[0], u_to[1] - u_from[1]
    return dux * dux * wx + duy * duy * wy, cos_t


def corner_weights(strokes, profile):
    """(k0, k1): per stroke, the energy weight of the corner at its start and at its end
    (0 where the neighbour is a stop or the turn is gentle, < 30 degrees: a curve's vertex,
    which the firmware model does not count as a corner)."""
    fx = getattr(profile, "freq_x_hz", 50.0)
    fy = getattr(profile, "freq_y_hz", 50.0)
    wx, wy = 1.0, (fx / fy) ** 3            # 1/w^3, relative to X
    n = len(strokes)
    k0, k1 = np.zeros(n), np.zeros(n)
    for i, st in enumerate(strokes):
        t0, t1 = end_tangents(st)
        k, c = _weights(st.prev_u, t0, wx, wy)
        k0[i] = k if c < CORNER_COS else 0.0
        k, c = _weights(t1, st.next_u, wx, wy)
        k1[i] = k if c < CORNER_COS else 0.0
    return k0, k1


def end_time_cost(v, v_orig, v_top, a, edge_min_d=EDGE_D, edge=True):
    """Seconds an end slowed from v_orig to v costs: the longer ramp between the top speed
    v_top and the end at acceleration a ((v_top - v)^2 - (v_top - v_orig)^2) / (2 a v_top),
    plus the lead-in / lead-out the firmware plays at v (edge_min_d or EDGE_T long) instead of
    passing that stretch at about v_orig.  edge_min_d: at least EDGE_D, and what the firmware
    needs not to drop the move (segments.SegmentRules.min_edge_d).  edge False (per end):
    the corner is slowed by a junction command instead (junction_commands), no lead-in."""
    v = np.minimum(v, v_orig)
    ramp = ((v_top - v) ** 2 - (v_top - v_orig) ** 2) / (2.0 * a * v_top)
    edge_d = np.maximum(np.maximum(EDGE_D, edge_min_d), v * EDGE_T)
    slowed = v < v_orig * (1.0 - 1e-9)
    edge_cost = np.where(slowed, edge_d / np.maximum(v, 1e-9) - edge_d / np.maximum(v_orig, 1e-9), 0.0)
    return np.maximum(ramp, 0.0) + np.where(edge, edge_cost, 0.0)


def corner_share(figures: dict) -> float:
    """The corners' share of a file's ringing energy (ringing.figures of the original:
    corner / (ramp + corner + turn), squares of the RMS parts).  A budget split in this
    proportion between the laws (ramps) and the corners is a heuristic: the planner prices
    laws by J, not by ringing, so the two marginal returns are not compared directly."""
    xy = figures["xy"]
    r, c, t = xy["rms_ramp_um"] ** 2, xy["rms_corner_um"] ** 2, xy["rms_turn_um"] ** 2
    return c / (r + c + t) if r + c + t > 0 else 0.0


def _tops(strokes, pin):
    """(v_top, a): per stroke, the speed its ramps reach and their acceleration, for the
    time model (end_time_cost)."""
    v0, v1 = np.asarray(pin.v0, float), np.asarray(pin.v1, float)
    v_top = np.maximum(np.minimum(np.asarray(pin.v_cap, float), np.array([s.v_feed for s in strokes], float)),
                       np.maximum(v0, v1))
    return v_top, np.asarray(pin.a_cap, float)


def end_speeds(strokes, pin, profile, opts, budget_t=None, allow0=None, allow1=None, pairs=None,
               cmd0=None, cmd1=None):
    """(v0_new, v1_new): start and end speed per stroke, <= the originals (pin.v0, pin.v1,
    the firmware's junction speeds), lowered at sharp corners where the time budget buys
    the most ringing energy.  budget_t: seconds to spend (default: opts.corner_slowdown_r,
    else BUDGET_R, times the strokes' original time).  allow0 / allow1: bool per stroke,
    which starts / ends may be lowered (default all).  pairs: (a, b) strokes whose a's end
    is b's start (junctions()): one speed for both.  cmd0 / cmd1: bool per stroke, that
    end is slowed by a junction command (no lead-in to pay for)."""
    v0 = np.asarray(pin.v0, float)
    v1 = np.asarray(pin.v1, float)
    n = len(v0)
    if n == 0:
        return v0.copy(), v1.copy()
    if budget_t is None:
        r = getattr(opts, "corner_slowdown_r", BUDGET_R)
        budget_t = r * float(np.nansum(pin.T_orig))
    k0, k1 = corner_weights(strokes, profile)
    v_top, a = _tops(strokes, pin)
    ok = np.isfinite(v0) & np.isfinite(v1) & np.isfinite(v_top) & (a > 0) & np.isfinite(a)
    ends_v = np.concatenate([v0, v1])
    ends_k = np.concatenate([k0, k1])
    ends_top = np.concatenate([v_top, v_top])
    ends_a = np.concatenate([a, a])
    # the shortest lead-in / lead-out the firmware keeps along each stroke (Profile.min_move_d)
    min_move_d = float(getattr(profile, "min_move_d", 0.0))
    axis_r = np.array([max(abs(s.ux), abs(s.uy), 1e-12) for s in strokes], float)
    ends_edge = np.maximum(EDGE_D, np.concatenate([min_move_d / axis_r] * 2))
    ends_lead = np.ones(2 * n, bool)         # the end pays for a lead-in / lead-out
    if cmd0 is not None:
        ends_lead = ~np.concatenate([np.asarray(cmd0, bool), np.asarray(cmd1, bool)])
    t_orig = np.asarray(getattr(pin, "T_orig", np.full(n, np.inf)), float)
    ends_tmax = END_COST_R * np.concatenate([t_orig, t_orig])
    live = np.concatenate([ok, ok]) & (ends_k > 0) & (ends_v > MIN_CORNER_V)
    if allow0 is not None:
        live &= np.concatenate([np.asarray(allow0, bool), np.asarray(allow1, bool)])
    # a junction shared by two strokes (a's end, b's start) is one speed: one decision,
    # priced with both sides' time; its energy once (one velocity jump)
    mate = np.full(2 * n, -1)
    for a_i, b_i in pairs or ():
        e, f = n + a_i, b_i
        if live[e] and live[f]:
            mate[e] = f
            live[f] = False           # decided with e
        else:
            live[e] = live[f] = False
    out = ends_v.copy()
    idx = np.flatnonzero(live)
    if idx.size and budget_t > 0:
        m = mate[idx]
        paired = m >= 0
        mi = np.where(paired, m, idx)
        vo = np.where(paired, np.minimum(ends_v[idx], ends_v[mi]), ends_v[idx])
        k = ends_k[idx]
        g = np.linspace(0.0, 1.0, GRID)[None, :]
        grid = MIN_CORNER_V * (vo[:, None] / MIN_CORNER_V) ** g        # ..., vo (last: keep)

        def side(e):
            c = end_time_cost(grid, ends_v[e][:, None], ends_top[e][:, None], ends_a[e][:, None],
                              ends_edge[e][:, None], ends_lead[e][:, None])
            return c, c > ends_tmax[e][:, None]
        cost_t, too_slow = side(idx)
        c2, slow2 = side(mi)
        cost_t = np.where(paired[:, None], cost_t + c2, cost_t)
        too_slow = too_slow | (paired[:, None] & slow2)
        energy = k[:, None] * grid * grid
        too_slow[:, -1] = False                                          # keeping costs ~nothing
        energy = np.where(too_slow, np.inf, energy)

        def pick(lam):
            j = np.argmin(energy + lam * cost_t, axis=1)
            return j, float(cost_t[np.arange(idx.size), j].sum())

        lo, hi = 0.0, 1.0
        while pick(hi)[1] > budget_t and hi < 1e12:
            hi *= 10.0
        if pick(lo)[1] <= budget_t:
            hi = lo
        for _ in range(60):
            if hi - lo <= 1e-9 * hi:
                break
            mid = 0.5 * (lo + hi)
            if pick(mid)[1] > budget_t:
                lo = mid
            else:
                hi = mid
        j, _ = pick(hi)
        out[idx] = grid[np.arange(idx.size), j]
        out[mi[paired]] = out[idx[paired]]
    return np.minimum(out[:n], v0), np.minimum(out[n:], v1)


def _end_point(st):
    """XY where a stroke ends (None: not known)."""
    if st.kind == "arc" and st.arc is not None:
        a = st.arc
        th = a.theta0 + a.sweep
        return a.cx + a.r * math.cos(th), a.cy + a.r * math.sin(th)
    if st.pts:
        return st.pts[-1]
    return st.x0 + st.ux * st.length_d, st.y0 + st.uy * st.length_d


JOIN_D = 1e-3            # mm: one stroke's end and the next's start are the same point (digits written)


def junctions(strokes):
    """(a, b) index pairs: stroke a ends where stroke b starts, b the next stroke in file
    order and entered from a's direction (no move between them: a connector would move the
    point, an E-only move makes b's start a stop)."""
    order = sorted(range(len(strokes)), key=lambda i: strokes[i].first_idx)
    out = []
    for a, b in zip(order, order[1:]):
        sa, sb = strokes[a], strokes[b]
        if sb.prev_u is None or sa.next_u is None or sb.first_idx <= sa.last_idx:
            continue
        p = _end_point(sa)
        tol = JOIN_D + (getattr(sa.arc, "end_off_d", 0.0) if sa.kind == "arc" and sa.arc is not None else 0.0)
        if p is None or math.hypot(p[0] - sb.x0, p[1] - sb.y0) > tol:
            continue
        t_end = end_tangents(sa)[1]
        if abs(t_end[0] * sb.prev_u[0] + t_end[1] * sb.prev_u[1] - 1.0) > 1e-3:
            continue
        out.append((a, b))
    return out


AUTO_FALLBACK_R = 0.5    # --corners auto without the original's ringing figures (--no-ringing)


def budget_share(opts) -> float:
    """Options.corner_budget_r as a number: 0 = off; "auto" = the corners' share of the
    original's ringing energy (corner_share of opts.ringing_before, which the pipeline's
    analyse pass fills), AUTO_FALLBACK_R without it."""
    r = getattr(opts, "corner_budget_r", 0.0) or 0.0
    if r == "auto":
        fig = getattr(opts, "ringing_before", None)
        try:
            return corner_share(fig) if fig else AUTO_FALLBACK_R
        except (KeyError, TypeError):
            return AUTO_FALLBACK_R
    return max(float(r), 0.0)


# ------------------------------------------------------------ junction commands
CMD_MARGIN_R = 0.98      # the commanded corner speed a little under the chosen one (rounding)


def _command_kind(flavour, junction):
    """Which junction command slows one junction, written before the move after it with no
    lead-in: "scv" (Klipper: SET_VELOCITY_LIMIT SQUARE_CORNER_VELOCITY; each move keeps
    the junction deviation in force when it is queued, toolhead.py takes the smaller of
    the two moves'), "jerk" (Marlin 1.x / Prusa-Firmware classic jerk: M205 X Y, the jerk
    in force when the move is planned; Prusa-Firmware's M205 does not wait for the queue),
    or None: Marlin 2 JD (M205 J only takes 0.01-0.3 mm), RepRapFirmware (M566)."""
    if junction == "scv" and flavour == "klipper":
        return "scv"
    if junction == "jerk" and flavour in ("marlin-legacy", "marlin2"):
        return "jerk"
    return None


def junction_command_capable(profile) -> bool:
    """Can one junction be slowed by a command before the move after it (_command_kind)?"""
    return _command_kind(profile.flavour, profile.junction) is not None


def junction_commands(stroke, flavour, junction):
    """(before, after): the command written before the stroke's first move so that the
    firmware passes the junction into it at no more than stroke.v0, and the one restoring
    the value in force after that move; None when the stroke's start is not slowed that way.

    Klipper: v^2 = R_jd scv^2 (sqrt2 - 1), R_jd = sin(t/2) / (1 - sin(t/2)), t the angle
    between the moves' directions (toolhead.py calc_junction, the junction deviation taken
    with the accel it was computed for).  Classic jerk: each axis' velocity change
    |v u_a - v pu_a| (max(|u_a|, |pu_a|) v where the axis reverses) must stay within the
    jerk, so v = J / max_a m_a.  The firmware model plays the written commands (state.py
    reads M205 and SET_VELOCITY_LIMIT) and checks the corner against the plan."""
    if not getattr(stroke, "corner_cmd0", False) or stroke.prev_u is None:
        return None
    v_c = CMD_MARGIN_R * stroke.v0
    pu, u = stroke.prev_u, end_tangents(stroke)[0]
    lim = stroke.lim
    kind = _command_kind(flavour, junction)
    if kind == "scv":
        cos_t = -(pu[0] * u[0] + pu[1] * u[1])
        sin_d2 = math.sqrt(max(0.5 * (1.0 - cos_t), 0.0))
        if not 0.0 < sin_d2 < 1.0:
            return None
        r_jd = sin_d2 / (1.0 - sin_d2)
        scv_c = v_c / math.sqrt(r_jd * (math.sqrt(2.0) - 1.0))
        if not (math.isfinite(scv_c) and 0.0 < scv_c < lim.scv):
            return None
        return (f"SET_VELOCITY_LIMIT SQUARE_CORNER_VELOCITY={scv_c:.3f}",
                f"SET_VELOCITY_LIMIT SQUARE_CORNER_VELOCITY={lim.scv:.6g}")
    if kind == "jerk":
        m = 0.0
        for a, b in ((pu[0], u[0]), (pu[1], u[1])):
            m = max(m, abs(b - a) if a * b >= 0.0 else max(abs(a), abs(b)))
        j_c = v_c * m
        if not (math.isfinite(j_c) and 0.001 <= j_c < min(lim.jerk_x, lim.jerk_y)):
            return None
        return (f"M205 X{j_c:.3f} Y{j_c:.3f}", f"M205 X{lim.jerk_x:.6g} Y{lim.jerk_y:.6g}")
    return None


def lower_corners(strokes, pin, profile, opts, kinds):
    """Lower strokes' end speeds at sharp corners (Options.corner_budget_r > 0): lines'
    starts and ends, curves' and chains' starts where a junction command can do it:
    strokes' v0 / v1 and pin.v0 / pin.v1 become the chosen speeds, v0_fw / v1_fw keep the
    firmware's (segments.py writes the lead-in / lead-out for the difference).  Both sides
    of a junction between two strokes get one speed.  Returns the
    number of ends lowered."""
    r = budget_share(opts)
    n = len(strokes)
    if r <= 0.0 or n == 0:
        return 0
    line = np.array([k == "line" for k in kinds], bool)
    # curves and chains have no lead-in: their start is slowed only by a junction command
    capable = junction_command_capable(profile)
    curvy = np.array([k in ("curve", "chain") for k in kinds], bool) & capable
    allow0, allow1 = line | curvy, line.copy()
    pairs = junctions(strokes)
    for a, b in pairs:              # a junction after an arc / curve / chain keeps its speed
        if not (line[a] and (line[b] or curvy[b])):
            allow1[a] = allow0[b] = False
    with np.errstate(invalid="ignore"):
        t_orig = np.asarray(pin.T_orig, float)
        budget_t = r * float(getattr(opts, "max_slowdown_r", 0.03)) * float(np.sum(t_orig[np.isfinite(t_orig)]))
    v0_fw = np.asarray(pin.v0, float).copy()
    v1_fw = np.asarray(pin.v1, float).copy()
    # a start is slowed by a junction command where the firmware takes one; an end, when the
    # next stroke's start command sets that same junction (a pair)
    # (a stroke the planner then leaves as sliced writes its own move behind the command:
    # schedule._keep_slowed_corners)
    cmd0 = allow0 & capable & np.array([s.prev_u is not None for s in strokes], bool)
    allow0 &= line | cmd0
    cmd1 = np.zeros(n, bool)
    nxt = {}
    for a, b in pairs:
        if allow1[a] and cmd0[b]:
            cmd1[a] = True
            nxt[a] = b
    v0, v1 = end_speeds(strokes, pin, profile, opts, budget_t=budget_t, allow0=allow0, allow1=allow1,
                        pairs=pairs, cmd0=cmd0, cmd1=cmd1)
    v0, v1 = np.minimum(v0, v0_fw), np.minimum(v1, v1_fw)
    lowered = 0
    pin.corner_next = {}
    for i, st in enumerate(strokes):
        if v0[i] < v0_fw[i] or v1[i] < v1_fw[i]:
            st.v0_fw, st.v1_fw = float(v0_fw[i]), float(v1_fw[i])
            st.v0, st.v1 = float(v0[i]), float(v1[i])
            st.corner_cmd0 = bool(cmd0[i] and v0[i] < v0_fw[i])
            st.corner_cmd1 = bool(cmd1[i] and v1[i] < v1_fw[i])
            if st.corner_cmd1:
                pin.corner_next[i] = nxt[i]        # the stroke whose command sets this end
            lowered += int(v0[i] < v0_fw[i]) + int(v1[i] < v1_fw[i])
    pin.v0, pin.v1 = v0, v1
    return lowered
