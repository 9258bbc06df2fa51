"""Which vertices need no vertex cap: a proof that curves.vertex_splitter's split is False.

split(pm, m) is True where a vertex's cap is degenerate (an exception, NaN, <= 0) or
where CAP_MARGIN x cap < feed with one of the two segments longer than CHAIN_SEG_D.  On the
gyroid plate 99.9 % of the vertices group_lines asks about have both segments <= CHAIN_SEG_D,
so only a degenerate cap could split them; short_bounds proves, per (limits, acceleration),
that none is degenerate for any vertex with

  * both unit directions computed as (dx/d, dy/d) from finite d = hypot(dx, dy),
  * pu . u >= FILTER_COS (a turn of at most 60 deg; group_lines' min_cos must imply it),
  * both lengths in [SHORT_MIN_D, CHAIN_SEG_D],

and returns that length interval (an empty one when it cannot prove it).  The proof, per
junction law of curves.vertex_cap (the ranges below keep every step away from 0, overflow
and NaN):

  * jerk (Marlin classic): cap = 1e6 x the product of the X and Y factors jx / jerk_x and
    jy / jerk_y (each taken only when the axis's jerk exceeds jx, jy), jerk_x <= 2e6 (1 + eps)
    for unit vectors: cap >= 1e6 (jx / 2.1e6) (jy / 2.1e6) > 0 for jx, jy >= LIM_LO.  No
    length or acceleration enters, no root, no division by 0 (a factor divides by a jerk > jx).
  * scv (Klipper): cos_theta = -(pu . u) <= -0.5 so sin(theta/2) >= 0.866 and the
    junction-deviation term r_jd jd a > 0; cos(theta/2) <= 0.5 so the centripetal
    terms 2 d a qt >= 2 SHORT_MIN_D LIM_LO 0.43 > 0; cos(theta/2) = 0 or 1 - sin(theta/2) <= 0
    gives INF (cap inf, which never splits).  a0 > 0 (the jd division), no root of a negative.
  * jd (Marlin junction deviation, every other junction name as in vertex_cap): ja =
    axis_limited(a) >= min(a, ax_max, ay_max) / (1 + eps) > 0 (jn > 0 for a non-collinear
    turn; jn = 0 leaves a); v2 = ja jd sin / (1 - sin) > 0 or INF; the < 1 mm rule's
    d ja / theta with Marlin's fast acos theta >= 0.0328 on cos_theta in [-1 - eps, -0.707)
    (tests/test_speed_group_filter.py evaluates it there) is > 0.  cos_theta > 0.999999
    (a reversal) cannot happen at pu . u >= 0.5.

tests/test_speed_group_filter.py checks it against the real split on every vertex of the
bundled samples and corpus files under every profile, and on random and degenerate vertices.
"""
from __future__ import annotations

from . import curves

FILTER_COS = 0.5           # the proof holds for turns of at most 60 deg
SHORT_MIN_D = 1e-6         # mm: shorter segments take the real split
LIM_LO, LIM_HI = 1e-3, 1e9  # every limit the law reads must lie in this range (finite)
EMPTY = (1.0, 0.0)         # an empty length interval: nothing proven


def _sane(*values):
    return all(LIM_LO <= x <= LIM_HI for x in values)


def short_bounds(profile, lim, accel, min_cos):
    """(lo_d, hi_d): split(pm, m) is False at every vertex of moves with limits lim and
    acceleration accel turning by pu . u >= min_cos whose two lengths lie in [lo_d, hi_d]
    (the conditions in the module docstring); EMPTY when that is not proven."""
    if not min_cos >= FILTER_COS:
        return EMPTY
    junction = profile.junction
    if junction == "jerk":
        j = 1.0 - curves.JERK_F_STEP_R          # vertex_cap's default jerk_r, its arithmetic
        ok = _sane(j * lim.jerk_x, j * lim.jerk_y)
    else:
        a0 = accel if accel > 0 else profile.default_accel_a   # accel_in_force's a0
        ok = _sane(a0, lim.ax_max, lim.ay_max) and _sane(lim.scv if junction == "scv" else lim.jd)
    return (SHORT_MIN_D, curves.CHAIN_SEG_D) if ok else EMPTY


def splitter(profile):
    """curves.vertex_splitter(profile) carrying short_bounds(lim, accel, min_cos) for this
    profile: strokes.group_lines skips the split call where those bounds prove it False."""
    split = curves.vertex_splitter(profile)

    def bounds(lim, accel, min_cos):
        return short_bounds(profile, lim, accel, min_cos)
    split.short_bounds = bounds
    return split
