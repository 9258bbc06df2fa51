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


def end_time_cost(v, v_orig, v_top, a):
    """Seconds an end slowed from v_orig to v costs: the longer ramp between the top speed
    v_top and the end at acceleration a ((v_top - v)^2 - (v_top - v_orig)^2) / (2 a v_top),
    plus the lead-in / lead-out the firmware plays at v (EDGE_D or EDGE_T long) instead of
    passing that stretch at about v_orig."""
    v = np.minimum(v, v_orig)
    ramp = ((v_top - v) ** 2 - (v_top - v_orig) ** 2) / (2.0 * a * v_top)
    edge_d = np.maximum(EDGE_D, v * EDGE_T)
    slowed = v < v_orig * (1.0 - 1e-9)
    edge = np.where(slowed, edge_d / np.maximum(v, 1e-9) - edge_d / np.maximum(v_orig, 1e-9), 0.0)
    return np.maximum(ramp, 0.0) + edge


def corner_share(figures: dict) -> float:
    """The corners' share of a file's ringing energy (ringing.figures of the original:
    corner / (ramp + corner + turn), squares of the RMS parts).  A budget split in this
    proportion between the laws (ramps) and the corners is a heuristic: the planner prices
    laws by J, not by ringing, so the two marginal returns are not compared directly."""
    xy = figures["xy"]
    r, c, t = xy["rms_ramp_um"] ** 2, xy["rms_corner_um"] ** 2, xy["rms_turn_um"] ** 2
    return c / (r + c + t) if r + c + t > 0 else 0.0


def end_speeds(strokes, pin, profile, opts, budget_t=None):
    """(v0_new, v1_new): start and end speed per stroke, <= the originals (pin.v0, pin.v1,
    the firmware's junction speeds), lowered at sharp corners where the time budget buys
    the most ringing energy.  budget_t: seconds to spend (default: opts.corner_slowdown_r,
    else BUDGET_R, times the strokes' original time)."""
    v0 = np.asarray(pin.v0, float)
    v1 = np.asarray(pin.v1, float)
    n = len(v0)
    if n == 0:
        return v0.copy(), v1.copy()
    if budget_t is None:
        r = getattr(opts, "corner_slowdown_r", BUDGET_R)
        budget_t = r * float(np.nansum(pin.T_orig))
    k0, k1 = corner_weights(strokes, profile)
    v_top = np.maximum(np.minimum(np.asarray(pin.v_cap, float), np.array([s.v_feed for s in strokes])),
                       np.maximum(v0, v1))
    a = np.asarray(pin.a_cap, float)
    ok = np.isfinite(v0) & np.isfinite(v1) & np.isfinite(v_top) & (a > 0) & np.isfinite(a)
    ends_v = np.concatenate([v0, v1])
    ends_k = np.concatenate([k0, k1])
    ends_top = np.concatenate([v_top, v_top])
    ends_a = np.concatenate([a, a])
    live = np.concatenate([ok, ok]) & (ends_k > 0) & (ends_v > MIN_CORNER_V)
    out = ends_v.copy()
    idx = np.flatnonzero(live)
    if idx.size and budget_t > 0:
        vo, k, top, aa = ends_v[idx], ends_k[idx], ends_top[idx], ends_a[idx]
        g = np.linspace(0.0, 1.0, GRID)[None, :]
        grid = MIN_CORNER_V * (vo[:, None] / MIN_CORNER_V) ** g        # ..., vo (last: keep)
        cost_t = end_time_cost(grid, vo[:, None], top[:, None], aa[:, None])
        energy = k[:, None] * grid * grid

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
    return np.minimum(out[:n], v0), np.minimum(out[n:], v1)
