"""vertex_filter.short_bounds (issue 8): where it proves curves.vertex_splitter's split
False, the real split is False -- on every vertex of real files under every profile, on
random and degenerate vertices; and group_lines with the filter hands over the same strokes
as without it (bit for bit), calling split far less."""
from __future__ import annotations

import math
import os

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as hs

from gcode_opt import curves, vertex_filter
from gcode_opt import features as feat
from gcode_opt.firmware.junction import _marlin_fast_acos_neg
from gcode_opt.profile import load_profile
from gcode_opt.state import LINE, Limits, Move, events
from gcode_opt.strokes import COLLINEAR_SIN, group_strokes
from test_speed_analyse import _ref_group_strokes, _stroke_bits

SAMPLES = "sample_gcode/"
CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus/")
PROFILES = ["bambu-x1c", "ender3", "generic-klipper", "generic-marlin", "prusa-mk3s", "prusa-mk4", "voron24"]
JUNCTION_PROFILE = {"jerk": "prusa-mk3s", "scv": "voron24", "jd": "ender3"}
COS30 = math.cos(math.radians(30.0))


def _unit_of(dx, dy):
    """group_lines' arithmetic for a move's length and direction."""
    d = math.hypot(dx, dy)
    return d, dx / d, dy / d


def _check(profile, split, pm, m, dp, dn, pu, u, min_cos=COS30):
    """The filter's claim at one vertex: True when it proves split False (and then split is False)."""
    lo, hi = vertex_filter.short_bounds(profile, m.lim, m.accel, min_cos)
    dot = pu[0] * u[0] + pu[1] * u[1]
    if not (dot >= min_cos and lo <= dp <= hi and lo <= dn <= hi):
        return False
    assert split(pm, m, dp, dn, pu, u) is False, (dp, dn, pu, u, m.accel, m.v)
    return True


def _file_vertices(path, profile):
    """Every vertex between two consecutive G0/G1 lines that move in XY (any feature, feed
    or acceleration): (previous move, move, their lengths and directions)."""
    pm = None
    for _, _, ev in events(path, profile):
        if type(ev) is not Move or ev.kind != LINE or (ev.x1 == ev.x0 and ev.y1 == ev.y0):
            pm = None
            continue
        cur = (ev,) + _unit_of(ev.x1 - ev.x0, ev.y1 - ev.y0)
        if pm is not None:
            yield pm[0], ev, pm[1], cur[1], (pm[2], pm[3]), (cur[2], cur[3])
        pm = cur


def _check_file(path, prof):
    profile = load_profile(prof)
    split = curves.vertex_splitter(profile)
    n = proven = splits = 0
    for pm, m, dp, dn, pu, u in _file_vertices(path, profile):
        if pu[0] * u[0] + pu[1] * u[1] < vertex_filter.FILTER_COS:
            continue
        n += 1
        if _check(profile, split, pm, m, dp, dn, pu, u, vertex_filter.FILTER_COS):
            proven += 1
        elif split(pm, m, dp, dn, pu, u):
            splits += 1
    return n, proven, splits


_QUICK = [("prusa_gyroid.gcode", p) for p in PROFILES] + [
    ("prusa_klipper.gcode", "voron24"), ("cura_box.gcode", "ender3"), ("prusa_concentric.gcode", "generic-marlin"),
    ("edge/tiny_move.gcode", "voron24"), ("edge/long_end_segment_curve.gcode", "ender3"),
    ("edge/g92_resets.gcode", "generic-klipper"), ("edge/m204_variants.gcode", "prusa-mk3s"),
    ("edge/prusa_firmware.gcode", "prusa-mk3s")]


@pytest.mark.parametrize("name,prof", _QUICK)
def test_filter_holds_on_every_vertex_of_samples(name, prof):
    n, proven, _ = _check_file(SAMPLES + name, prof)
    if name == "prusa_gyroid.gcode":
        assert proven > 0.5 * n > 1000       # the filter does prove most of them


@pytest.mark.slow
@pytest.mark.parametrize("prof", PROFILES)
def test_filter_holds_on_every_vertex_of_every_sample(prof):
    names = sorted(f for f in os.listdir(SAMPLES) if f.endswith(".gcode"))
    names += ["edge/" + f for f in sorted(os.listdir(SAMPLES + "edge")) if f.endswith(".gcode")]
    for name in names:
        _check_file(SAMPLES + name, prof)


@pytest.mark.slow
@pytest.mark.parametrize("name,prof", [("plate_gyroid", "prusa-mk3s"), ("plate_gyroid", "voron24"),
                                       ("plate_gyroid", "ender3"), ("cura_gyroid", "ender3"),
                                       ("bridges_klipper", "voron24"), ("gyroid_fwretract", "prusa-mk4"),
                                       ("plate_rectilinear", "generic-klipper")])
def test_filter_holds_on_every_vertex_of_corpus(name, prof):
    path = CORPUS + name + ".gcode"
    if not os.path.exists(path):
        pytest.skip("corpus not built")
    n, proven, splits = _check_file(path, prof)
    assert proven > 0


def test_marlin_fast_acos_is_positive_where_the_proof_needs_it():
    """jd's < 1 mm rule divides by Marlin's fast acos on cos_theta in [-1 - eps, -0.7071067812)."""
    lo = min(_marlin_fast_acos_neg(-0.7071067812 - k * (1.0 - 0.7071067812) / 200000) for k in range(200001))
    assert lo > 0.03
    assert _marlin_fast_acos_neg(-1.0 - 2.2e-16) > 0.03 and _marlin_fast_acos_neg(-1.0000001) > 0.03


# ---------------------------------------------------------------- random and degenerate vertices
def _vertex(theta0, turn, dp, dn, v, accel, lim):
    """Moves pm, m meeting at the origin: pm of length ~dp along theta0, m of ~dn turning by turn."""
    ax, ay = dp * math.cos(theta0), dp * math.sin(theta0)
    bx, by = dn * math.cos(theta0 + turn), dn * math.sin(theta0 + turn)
    pm = Move(0, LINE, -ax, -ay, 0.2, 0.0, 0.0, 0.2, 0.1, v, accel, "x", 0, lim)
    m = Move(1, LINE, 0.0, 0.0, 0.2, bx, by, 0.2, 0.1, v, accel, "x", 0, lim)
    return pm, m, _unit_of(ax, ay), _unit_of(bx, by)


_ODD = [0.0, -1.0, 5e-324, 1e-300, 1e-4, 9.99e-4, 1e-3, 1.0, 8.0, 1e9, 1.01e9, 1e12, math.inf, math.nan]
_limit = hs.one_of(hs.sampled_from(_ODD), hs.floats(1e-3, 1e5))
_length = hs.one_of(hs.sampled_from([5e-324, 1e-300, 1e-7, 1e-6, 1.0000001e-6, 0.999, 1.0, 2.0, 2.0000001, 2.5]),
                    hs.floats(0.0, 3.0, allow_subnormal=True))


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(junction=hs.sampled_from(["jerk", "scv", "jd"]), theta0=hs.floats(-4.0, 4.0),
       turn_deg=hs.one_of(hs.sampled_from([0.0, 1e-9, 0.06, 0.0573, 30.0, 60.0, -60.0, 90.0, 179.9, 180.0]),
                          hs.floats(-180.0, 180.0)),
       dp=_length, dn=_length, v=hs.one_of(hs.sampled_from([1.0, 1e4]), hs.floats(1.0, 1e3)),
       accel=hs.one_of(hs.sampled_from(_ODD), hs.floats(1.0, 2e4)),
       lims=hs.tuples(*[_limit] * 6), min_cos=hs.sampled_from([-1.0, 0.0, 0.49, 0.5, COS30, 0.99]))
def test_filter_holds_on_random_vertices(junction, theta0, turn_deg, dp, dn, v, accel, lims, min_cos):
    profile = load_profile(JUNCTION_PROFILE[junction])
    ax, ay, scv, jd, jx, jy = lims
    lim = Limits(300.0, ax, ay, scv, 0.5, jd, jx, jy)
    try:
        pm, m, (dp_, *pu), (dn_, *u) = _vertex(theta0, math.radians(turn_deg), dp, dn, v, accel, lim)
    except ZeroDivisionError:            # a zero length: group_lines never has one
        return
    _check(profile, curves.vertex_splitter(profile), pm, m, dp_, dn_, tuple(pu), tuple(u), min_cos)


_in_range = hs.one_of(hs.sampled_from([1e-3, 1e9]), hs.floats(1e-3, 1e9))


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(junction=hs.sampled_from(["jerk", "scv", "jd"]), theta0=hs.floats(-4.0, 4.0),
       turn_deg=hs.one_of(hs.sampled_from([0.0, 1e-9, 0.0573, 60.0, -60.0]), hs.floats(-60.0, 60.0)),
       dp=hs.one_of(hs.sampled_from([1e-6, 2.0]), hs.floats(1e-6, 2.0)),
       dn=hs.one_of(hs.sampled_from([1e-6, 2.0]), hs.floats(1e-6, 2.0)),
       v=hs.floats(1.0, 1e4), accel=hs.one_of(hs.just(0.0), _in_range), lims=hs.tuples(*[_in_range] * 6))
def test_filter_holds_on_random_vertices_it_proves(junction, theta0, turn_deg, dp, dn, v, accel, lims):
    """Vertices inside the filter's bounds, limits in its range: most are proven, each one checked."""
    profile = load_profile(JUNCTION_PROFILE[junction])
    ax, ay, scv, jd, jx, jy = lims
    lim = Limits(300.0, ax, ay, scv, 0.5, jd, jx / 0.85, jy / 0.85)
    pm, m, (dp_, *pu), (dn_, *u) = _vertex(theta0, math.radians(turn_deg), dp, dn, v, accel, lim)
    _check(profile, curves.vertex_splitter(profile), pm, m, dp_, dn_, tuple(pu), tuple(u),
           vertex_filter.FILTER_COS)


_SANE = Limits(300.0, 1000.0, 1000.0, 5.0, 0.5, 0.013, 8.0, 8.0)
# vertices where split is True though a wider filter would have called them safe: a mutant of
# short_bounds (no lower length, a higher upper one, limits or min_cos unchecked) fails here
_DEGENERATE = [
    (0.0, "scv", 20.0, 5e-324, 1.0, 1e-3, _SANE, COS30),          # a centripetal term underflows: cap 0
    (-0.35, "scv", 20.0, 1.0, 5e-324, 1e-3, _SANE, COS30),        # (m along X: a unit direction)
    (0.3, "jerk", 20.0, 1.0, 1.0, 1000.0, Limits(300, 1e3, 1e3, 5, .5, .013, 0.0, 8), COS30),  # no X jerk
    (0.3, "jd", 20.0, 1.0, 1.0, 1000.0, Limits(300, 1e3, 1e3, 5, .5, 0.0, 8, 8), COS30),       # JD 0
    (0.3, "scv", 20.0, 1.0, 1.0, 1000.0, Limits(300, 1e3, 1e3, 0.0, .5, .013, 8, 8), COS30),   # scv 0
    (0.0, "scv", 180.0, 1.0, 1.0, 1000.0, _SANE, -1.0),          # a reversal when curves take any turn
    (0.3, "jerk", 29.0, 2.5, 0.5, 1000.0, _SANE, COS30),         # capped below the feed, a segment > 2 mm
    (0.3, "scv", 29.0, 0.5, 2.0000001, 1000.0, _SANE, COS30),
]


@pytest.mark.parametrize("theta0,junction,turn_deg,dp,dn,accel,lim,min_cos", _DEGENERATE)
def test_filter_refuses_vertices_that_split(theta0, junction, turn_deg, dp, dn, accel, lim, min_cos):
    profile = load_profile(JUNCTION_PROFILE[junction])
    pm, m, (dp_, *pu), (dn_, *u) = _vertex(theta0, math.radians(turn_deg), dp, dn, 200.0, accel, lim)
    split = curves.vertex_splitter(profile)
    assert split(pm, m, dp_, dn_, tuple(pu), tuple(u)) is True
    assert not _check(profile, split, pm, m, dp_, dn_, tuple(pu), tuple(u), min_cos)


def test_filter_proves_the_common_vertex():
    """A gyroid-like vertex (0.5 mm segments, 10 deg) under each law, sane limits: proven."""
    for junction, prof in JUNCTION_PROFILE.items():
        profile = load_profile(prof)
        pm, m, (dp, *pu), (dn, *u) = _vertex(0.3, math.radians(10.0), 0.5, 0.5, 200.0, 1000.0, _SANE)
        assert _check(profile, curves.vertex_splitter(profile), pm, m, dp, dn, tuple(pu), tuple(u)), junction


# ---------------------------------------------------------------- group_lines with the filter
def _tagged(fn, path, profile, min_d, turn, split):
    out = []
    for item in fn(events(path, profile), feat.DEFAULT_SELECTED, min_d, turn, split):
        out.append(("line", item[1]) if item[0] == "line" else ("stroke", _stroke_bits(item[1])))
    return out


def _counting(split):
    calls = [0]

    def counted(*a):
        calls[0] += 1
        return split(*a)
    if hasattr(split, "short_bounds"):
        counted.short_bounds = split.short_bounds
    return counted, calls


@pytest.mark.parametrize("min_d,turn", [(0.2, 30.0), (0.0, 30.0), (2.0, 10.0), (0.2, 60.0), (0.2, 90.0)])
@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_gyroid_arcs.gcode", "voron24"),
                                       ("prusa_gyroid.gcode", "ender3"), ("cura_box.gcode", "generic-klipper"),
                                       ("edge/long_end_segment_curve.gcode", "prusa-mk3s")])
def test_group_strokes_with_the_filter_is_the_reference(name, prof, min_d, turn):
    """The c8abe7b grouping with the plain splitter, against group_strokes with the filtering
    one: the same lines and strokes in the same order, every slot's bits."""
    profile = load_profile(prof)
    plain, n_plain = _counting(curves.vertex_splitter(profile))
    filtered, n_filtered = _counting(vertex_filter.splitter(profile))
    ref = _tagged(_ref_group_strokes, SAMPLES + name, profile, min_d, turn, plain)
    assert _tagged(group_strokes, SAMPLES + name, profile, min_d, turn, filtered) == ref
    if name == "prusa_gyroid.gcode" and turn <= 60.0:
        assert n_filtered[0] < 0.2 * n_plain[0] and n_plain[0] > 500
    if turn > 60.0:                       # min_cos < FILTER_COS: nothing proven, every vertex asked
        assert n_filtered[0] == n_plain[0]
