"""Junction-speed laws of the firmwares we model.

All functions work on plain floats (unit direction vectors, mm, mm/s, mm/s^2) so the
planner's inner loop can call them without building objects.  Squared speeds end in
``_v2``.  ``INF`` means "this law sets no limit" (the caller takes the min with the
nominal speeds and the reachability limit).

Sources (read to learn the semantics, re-written here):
  * Klipper klippy/toolhead.py ``Move.calc_junction`` (square_corner_velocity turned into
    a junction deviation, plus the "circle must touch the moves no further than mid-move"
    centripetal limits) and klippy/kinematics/extruder.py ``calc_junction``
    (instantaneous_corner_velocity on the change of the extrusion ratio).
  * Marlin 2 src/module/planner.cpp junction deviation, with JD_HANDLE_SMALL_SEGMENTS and
    its fast acos approximation (the default build), and ``limit_value_by_axis_maximum``.
  * Marlin 1.1 / Prusa-Firmware classic jerk (``safe_speed`` and the per-axis jerk on the
    exit/entry speed difference, with Marlin's "axis reversal" rule and the
    "not coasting -> use safe speed" rule).
"""
from __future__ import annotations

import math

INF = float("inf")
SQRT2_M1 = math.sqrt(2.0) - 1.0
MINIMUM_PLANNER_SPEED = 0.05      # mm/s, Marlin Configuration_adv.h default
KLIPPER_INSTANT_CORNER_V = 1.0    # mm/s, Klipper [extruder] instantaneous_corner_velocity default


# ---------------------------------------------------------------- Klipper -------------
def klipper_junction_deviation(scv: float, accel: float) -> float:
    """Klipper toolhead._calc_junction_deviation: scv^2 (sqrt2 - 1) / max_accel."""
    return scv * scv * SQRT2_M1 / accel


def klipper_corner_v2(pux, puy, puz, p_jd, p_accel, p_delta_v2,
                      ux, uy, uz, jd, accel, delta_v2) -> float:
    """Squared speed allowed by Klipper's approximated centripetal velocity at the junction
    of a previous move (unit vector pu, its junction_deviation/accel/delta_v2) and this
    move.  INF for a straight continuation; 0 for an exact reversal."""
    cos_theta = -(ux * pux + uy * puy + uz * puz)
    s2 = 0.5 * (1.0 - cos_theta)
    c2 = 0.5 * (1.0 + cos_theta)
    sin_d2 = math.sqrt(s2) if s2 > 0.0 else 0.0
    cos_d2 = math.sqrt(c2) if c2 > 0.0 else 0.0
    one_m = 1.0 - sin_d2
    if one_m > 0.0 and cos_d2 > 0.0:
        r_jd = sin_d2 / one_m
        v2 = r_jd * jd * accel
        pv2 = r_jd * p_jd * p_accel
        if pv2 < v2:
            v2 = pv2
        qt = 0.25 * sin_d2 / cos_d2
        c = delta_v2 * qt
        if c < v2:
            v2 = c
        c = p_delta_v2 * qt
        if c < v2:
            v2 = c
        return v2
    return INF


def klipper_extruder_v2(p_er: float, er: float, icv: float = KLIPPER_INSTANT_CORNER_V) -> float:
    """Klipper extruder.calc_junction: the extrusion ratio (E mm per path mm) may change
    abruptly only by instantaneous_corner_velocity / v."""
    diff = er - p_er
    if diff:
        return (icv / abs(diff)) ** 2
    return INF


# ---------------------------------------------------------------- limits -------------
def axis_limited(value: float, ux: float, uy: float, uz: float,
                 cx: float, cy: float, cz: float) -> float:
    """Largest value <= value such that value*|u_i| <= c_i on each axis (Marlin's
    limit_value_by_axis_maximum, Klipper limited_cartesian check_move)."""
    a = abs(ux)
    if a > 0.0 and value * a > cx:
        value = cx / a
    a = abs(uy)
    if a > 0.0 and value * a > cy:
        value = cy / a
    a = abs(uz)
    if a > 0.0 and value * a > cz:
        value = cz / a
    return value


# ---------------------------------------------------------------- Marlin JD ----------
def _marlin_fast_acos_neg(cos_theta: float) -> float:
    """Marlin's MinMax polynomial for acos(-cos_theta) (error +-0.033 rad; bottoms out
    at ~0.0328 rad for a straight continuation, which avoids a division by zero)."""
    neg = -1.0 if cos_theta < 0.0 else 1.0
    t = neg * cos_theta
    asinx = (0.032843707 + t * (-1.451838349 + t * (29.66153956 + t * (-131.1123477
             + t * (262.8130562 + t * (-242.7199627 + t * 84.31466202))))))
    return math.pi / 2.0 + neg * asinx


def marlin_jd_v2(pux, puy, puz, ux, uy, uz, d, accel, jd, cx, cy, cz) -> float:
    """Marlin 2 junction deviation: max squared entry speed of this block (length d,
    acceleration accel) after a block of unit vector pu.  cx/cy/cz: per-axis accel caps
    (M201).  Includes JD_HANDLE_SMALL_SEGMENTS (blocks < 1 mm turning < 45 deg, i.e. the
    'octagon' case, are limited to d*a/theta).  INF = no limit from this law."""
    cos_theta = -(pux * ux + puy * uy + puz * uz)
    if cos_theta > 0.999999:                  # 0 deg acute junction: reversal
        return MINIMUM_PLANNER_SPEED * MINIMUM_PLANNER_SPEED
    jx, jy, jz = ux - pux, uy - puy, uz - puz
    jn = math.sqrt(jx * jx + jy * jy + jz * jz)
    if jn > 0.0:
        ja = axis_limited(accel, jx / jn, jy / jn, jz / jn, cx, cy, cz)
    else:                                     # straight: Marlin's NaN vector leaves accel as is
        ja = accel
    s = 0.5 * (1.0 - cos_theta)
    sin_d2 = math.sqrt(s) if s > 0.0 else 0.0
    one_m = 1.0 - sin_d2
    v2 = ja * jd * sin_d2 / one_m if one_m > 0.0 else INF
    if d < 1.0 and cos_theta < -0.7071067812:
        theta = _marlin_fast_acos_neg(cos_theta)
        lim = d * ja / theta
        if lim < v2:
            v2 = lim
    return v2


# ---------------------------------------------------------------- classic jerk -------
def marlin_safe_speed(ux, uy, uz, nominal, jx, jy, jz) -> float:
    """Speed from which the block may start (or stop) instantly: Marlin 1.1 safe_speed
    on the XYZ axes (an axis whose speed exceeds its jerk limits the block).  The loop
    over the axes is written out (this runs once per block of the firmware model)."""
    safe = nominal
    limited = False
    comp = abs(ux) * nominal
    if comp > jx:
        limited = True
        safe = jx
    comp = abs(uy) * nominal
    if comp > jy:
        if limited:
            mjerk = jy * nominal
            if comp * safe > mjerk:
                safe = mjerk / comp
        else:
            limited = True
            safe = jy
    comp = abs(uz) * nominal
    if comp > jz:
        if limited:
            mjerk = jz * nominal
            if comp * safe > mjerk:
                safe = mjerk / comp
        else:
            safe = jz
    return safe


def marlin_jerk_junction_v(pux, puy, puz, p_nominal, p_safe, ux, uy, uz, nominal, safe,
                           jx, jy, jz) -> float:
    """Marlin 1.1 classic-jerk junction speed (mm/s, not squared) between a previous block
    (unit vector pu, nominal speed, safe speed) and this block.  The loop over the axes is
    written out; each axis's arithmetic is Marlin's, in Marlin's order."""
    vmax = nominal if nominal < p_nominal else p_nominal
    smaller = vmax / p_nominal
    v_factor = 1.0
    limited = False
    # X
    v_exit = pux * p_nominal * smaller
    v_entry = ux * nominal
    if v_exit > v_entry:
        jerk = (v_exit - v_entry) if (v_entry > 0.0 or v_exit < 0.0) else max(v_exit, -v_entry)
    else:
        jerk = (v_entry - v_exit) if (v_entry < 0.0 or v_exit > 0.0) else max(-v_exit, v_entry)
    if jerk > jx:
        v_factor *= jx / jerk
        limited = True
    # Y
    v_exit = puy * p_nominal * smaller
    v_entry = uy * nominal
    if limited:
        v_exit *= v_factor
        v_entry *= v_factor
    if v_exit > v_entry:
        jerk = (v_exit - v_entry) if (v_entry > 0.0 or v_exit < 0.0) else max(v_exit, -v_entry)
    else:
        jerk = (v_entry - v_exit) if (v_entry < 0.0 or v_exit > 0.0) else max(-v_exit, v_entry)
    if jerk > jy:
        v_factor *= jy / jerk
        limited = True
    # Z
    v_exit = puz * p_nominal * smaller
    v_entry = uz * nominal
    if limited:
        v_exit *= v_factor
        v_entry *= v_factor
    if v_exit > v_entry:
        jerk = (v_exit - v_entry) if (v_entry > 0.0 or v_exit < 0.0) else max(v_exit, -v_entry)
    else:
        jerk = (v_entry - v_exit) if (v_entry < 0.0 or v_exit > 0.0) else max(-v_exit, v_entry)
    if jerk > jz:
        v_factor *= jz / jerk
        limited = True
    if limited:
        vmax *= v_factor
    thr = vmax * 0.99
    if p_safe > thr and safe > thr:           # not coasting: Marlin restarts from safe speed
        vmax = safe
    return vmax


# ---------------------------------------------------------------- what a junction needs ---
def accel_to_pass_junction(junction: str, v: float, pu, u, d: float, jd: float = 0.0) -> float:
    """Smallest acceleration a move of length d along u must carry so that the
    firmware's junction law still allows speed v where it meets a move along pu.

    Klipper's centripetal term (2 d a tan(theta/2)/4) and Marlin's junction deviation
    (a * jd * R, and d*a/theta for blocks < 1 mm) both scale with the move's own
    acceleration: a re-timed segment that ramps gently would otherwise drag the corner
    speed of its neighbour down.  Classic jerk does not depend on it (returns 0).  pu
    or u None (a stop on that side), v = 0 or a straight continuation need nothing."""
    if v <= 0.0 or pu is None or u is None or junction == "jerk":
        return 0.0
    pux, puy = pu
    ux, uy = u
    cos_theta = -(ux * pux + uy * puy)
    if cos_theta <= -0.999999:                 # straight on: only Marlin's < 1 mm rule
        if junction == "jd" and d < 1.0:
            return v * v * _marlin_fast_acos_neg(-0.999999) / d
        return 0.0
    sin_d2 = math.sqrt(max(0.5 * (1.0 - cos_theta), 0.0))
    cos_d2 = math.sqrt(max(0.5 * (1.0 + cos_theta), 0.0))
    v2 = v * v
    if junction == "scv":
        if cos_d2 <= 0.0:                      # reversal: the junction is a stop anyway
            return 0.0
        if sin_d2 <= 0.0:                      # exact reversal: no acceleration passes v > 0
            return INF
        return v2 / (2.0 * d * 0.25 * sin_d2 / cos_d2)
    # Marlin junction deviation (the per-axis cap on the junction acceleration is left
    # out: it only matters near the machine's M201 limits, which the caller caps at)
    per_a = jd * sin_d2 / (1.0 - sin_d2) if sin_d2 < 1.0 else INF
    if d < 1.0 and cos_theta < -0.7071067812:
        per_a = min(per_a, d / _marlin_fast_acos_neg(cos_theta))
    return v2 / per_a if per_a > 0 else INF


def _marlin_fast_acos_neg_rows(cos_theta):
    """_marlin_fast_acos_neg of an array, elementwise: the same operations in the same
    order (the same bits)."""
    import numpy as np
    neg = np.where(cos_theta < 0.0, -1.0, 1.0)
    t = neg * cos_theta
    asinx = (0.032843707 + t * (-1.451838349 + t * (29.66153956 + t * (-131.1123477
             + t * (262.8130562 + t * (-242.7199627 + t * 84.31466202))))))
    return math.pi / 2.0 + neg * asinx


def accel_to_pass_junction_rows(junction, v, pux, puy, has_pu, ux, uy, d, jd):
    """accel_to_pass_junction of many junctions at once (arrays that broadcast: v, the
    previous direction pux, puy where has_pu (else pu None), this direction ux, uy, the
    length d, jd), for junction "scv" or "jd".  Returns (need, odd): need the same floats
    elementwise (every step is the same float operation; Python's max / min are np.where
    on the same comparison), odd where the per-junction form would raise (a division by
    zero) -- the caller takes those junctions one by one.  Every branch is computed on
    every element and the taken one kept (numpy's warnings on the others silenced)."""
    import numpy as np
    with np.errstate(all="ignore"):
        v, pux, puy, ux, uy, d, jd = np.broadcast_arrays(*(np.asarray(x, float) for x in (v, pux, puy, ux, uy, d, jd)))
        nil = (v <= 0.0) | ~np.asarray(has_pu, bool)
        cos_theta = -(ux * pux + uy * puy)
        straight = cos_theta <= -0.999999
        short = d < 1.0
        if junction == "jd":
            c_straight = _marlin_fast_acos_neg(-0.999999)
            need_straight = np.where(short, v * v * c_straight / d, 0.0)
            odd = straight & short & (d == 0.0)
        else:
            need_straight = np.zeros(v.shape)
            odd = np.zeros(v.shape, bool)
        x = 0.5 * (1.0 - cos_theta)
        sin_d2 = np.sqrt(np.where(0.0 > x, 0.0, x))
        x = 0.5 * (1.0 + cos_theta)
        cos_d2 = np.sqrt(np.where(0.0 > x, 0.0, x))
        v2 = v * v
        bent = ~nil & ~straight
        if junction == "scv":
            den = 2.0 * d * 0.25 * sin_d2 / cos_d2
            need = np.where(cos_d2 <= 0.0, 0.0, np.where(sin_d2 <= 0.0, np.inf, v2 / den))
            odd |= bent & ~(cos_d2 <= 0.0) & ~(sin_d2 <= 0.0) & (den == 0.0)     # v2 / 0.0 raises
        elif junction == "jd":
            per_a = np.where(sin_d2 < 1.0, jd * sin_d2 / (1.0 - sin_d2), np.inf)
            sharp = short & (cos_theta < -0.7071067812)
            acos = _marlin_fast_acos_neg_rows(cos_theta)
            b = d / acos
            per_a = np.where(sharp & (b < per_a), b, per_a)
            need = np.where(per_a > 0, v2 / per_a, np.inf)
            odd |= bent & sharp & (acos == 0.0)        # d / 0.0 raises
        else:
            raise ValueError(f"accel_to_pass_junction_rows: junction {junction!r} (scv or jd)")
        need = np.where(nil, 0.0, np.where(straight, need_straight, need))
        return need, odd & ~nil


def marlin_jd_v2_rows(pux, puy, ux, uy, d, accel, jd, cx, cy):
    """marlin_jd_v2 of XY junctions (puz = uz = 0, so Z limits nothing) on arrays that
    broadcast: the same float operations in the same order, elementwise, each branch
    computed on every element and the taken one kept.  Returns (v2, odd): odd where the
    per-junction form would raise (d * ja / theta with theta 0) -- the caller takes those
    junctions one by one."""
    import numpy as np
    with np.errstate(all="ignore"):
        cos_theta = -(pux * ux + puy * uy + 0.0)        # (+ puz * uz: 0.0, as there)
        jx, jy = ux - pux, uy - puy
        jn = np.sqrt(jx * jx + jy * jy + 0.0)           # (+ jz * jz)
        ja = np.asarray(accel, float)
        for j, c in ((jx, cx), (jy, cy)):               # axis_limited, X then Y
            a = np.abs(j / jn)
            ja = np.where((a > 0.0) & (ja * a > c), c / a, ja)
        ja = np.where(jn > 0.0, ja, accel)
        s = 0.5 * (1.0 - cos_theta)
        sin_d2 = np.where(s > 0.0, np.sqrt(np.where(s > 0.0, s, 0.0)), 0.0)
        one_m = 1.0 - sin_d2
        v2 = np.where(one_m > 0.0, ja * jd * sin_d2 / one_m, INF)
        sharp = (d < 1.0) & (cos_theta < -0.7071067812)
        theta = _marlin_fast_acos_neg_rows(cos_theta)
        lim = d * ja / theta
        v2 = np.where(sharp & (lim < v2), lim, v2)
        reverse = cos_theta > 0.999999
        v2 = np.where(reverse, MINIMUM_PLANNER_SPEED * MINIMUM_PLANNER_SPEED, v2)
        return v2, ~reverse & sharp & (theta == 0.0)


def marlin_safe_speed_rows(ux, uy, nom, jx, jy):
    """marlin_safe_speed of XY moves (uz = 0: the Z axis limits nothing) on arrays:
    the same comparisons and quotients, elementwise."""
    import numpy as np
    cx, cy = np.abs(ux) * nom, np.abs(uy) * nom
    lim_x = cx > jx
    safe = np.where(lim_x, jx, nom)
    lim_y = cy > jy
    with np.errstate(all="ignore"):
        both = np.where(cy * safe > jy * nom, (jy * nom) / cy, safe)
    return np.where(lim_y, np.where(lim_x, both, jy), safe)


def _jerk_axis(v_exit, v_entry):
    """One axis's jerk of marlin_jerk_junction_v (Marlin's cases, elementwise)."""
    import numpy as np
    down = np.where((v_entry > 0.0) | (v_exit < 0.0), v_exit - v_entry,
                    np.where(-v_entry > v_exit, -v_entry, v_exit))
    up = np.where((v_entry < 0.0) | (v_exit > 0.0), v_entry - v_exit,
                  np.where(v_entry > -v_exit, v_entry, -v_exit))
    return np.where(v_exit > v_entry, down, up)


def marlin_jerk_junction_v_rows(pux, puy, p_nom, ux, uy, nom, jx, jy):
    """marlin_jerk_junction_v of XY moves (uz = puz = 0) on arrays: the junction
    speed (mm/s) between a block along pu at nominal p_nom and one along u at nominal nom,
    each block's safe speed from marlin_safe_speed_rows; the same steps in Marlin's order."""
    import numpy as np
    p_safe = marlin_safe_speed_rows(pux, puy, p_nom, jx, jy)
    safe = marlin_safe_speed_rows(ux, uy, nom, jx, jy)
    vmax = np.where(nom < p_nom, nom, p_nom)
    smaller = vmax / p_nom
    jerk = _jerk_axis(pux * p_nom * smaller, ux * nom)
    lim_x = jerk > jx
    with np.errstate(all="ignore"):
        f = np.where(lim_x, 1.0 * (jx / jerk), 1.0)
        ex, en = puy * p_nom * smaller, uy * nom
        ex, en = np.where(lim_x, ex * f, ex), np.where(lim_x, en * f, en)
        jerk = _jerk_axis(ex, en)
        lim_y = jerk > jy
        f = np.where(lim_y, f * (jy / jerk), f)
    vmax = np.where(lim_x | lim_y, vmax * f, vmax)
    thr = vmax * 0.99
    return np.where((p_safe > thr) & (safe > thr), safe, vmax)
