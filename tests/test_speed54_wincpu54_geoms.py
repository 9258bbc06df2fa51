"""Round 54 (wincpu): the windowed pipeline's curve geometry with less per-window work.

* build_geoms reads the strokes' limits, accelerations and neighbours' directions once a
  call (curves._stroke_fields_once), each block taking its rows of them (_fields_at), not
  each block again (a window's ~90 blocks, most of a few strokes): every geometry field
  the same bits as each stroke's own geometry made alone, with strokes of two limits
  objects, their own accelerations, blocks holding a row _parts_block declines, under
  classic jerk and under square corner velocity.
* stored_strokes.curve_geometry (the candidates' on_load) makes the curves' and the
  chains' geometry in one build_geoms call, κ for the curves alone: the same fields as
  the two calls it replaces (chains without κ).
"""
import copy
import os

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.schedule import C_CHAIN, C_CURVE
from gcode_opt.stored_strokes import curve_geometry
from gcode_opt.strokes import K_CURVE, K_LINE, Points

S = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "sample_gcode")


def _bits(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return a.shape == b.shape and a.tobytes() == b.tobytes()


def _curves(profile):
    prof = load_profile(profile)
    strokes, _ = analyse(os.path.join(S, "prusa_gyroid.gcode"), prof, Options())
    return prof, [st for st in strokes if st.kind == K_CURVE]


def _varied(sts):
    """The strokes sts with fields that differ from stroke to stroke: every third on a
    second limits object (other jerks, scv, accelerations), each its own acceleration,
    every fifth without a previous direction, and every seventh with a vertex doubled
    (a row _parts_block declines, among good rows of its vertex count)."""
    lim2 = copy.copy(sts[0].lim)
    for f in ("jerk_x", "jerk_y", "scv", "ax_max", "ay_max"):
        if isinstance(getattr(lim2, f, None), float):
            setattr(lim2, f, getattr(lim2, f) * 0.61)
    out = []
    for k, st in enumerate(sts):
        st = copy.copy(st)
        st.curv = None
        st.accel = 400.0 + 37.0 * k
        if k % 3 == 0:
            st.lim = lim2
        if k % 5 == 0:
            st.prev_u = None
        if k % 7 == 0:
            xy = np.frombuffer(st.pts.xy, float).reshape(-1, 2)
            st.pts = Points(np.vstack([xy[:2], xy[1:]]).ravel().tobytes())
        out.append(st)
    return out


def _fields(st):
    g = st.curv
    caps1 = g.caps_jerk1
    return [g.d, g.caps, [g.cap], list(g.cos_end), [] if caps1 is None else caps1]


@pytest.mark.parametrize("profile", ["prusa-mk3s", "voron24"])
def test_fields_read_once_a_call_give_each_strokes_own_geometry(profile):
    prof, sts = _curves(profile)
    sts = _varied(sts[:400])
    alone = [copy.copy(st) for st in sts]
    blocks = curves.build_geoms(sts, prof, jerk1=True)
    assert len(blocks) > 5 and sum(len(b) for _, b in blocks) < len(sts)     # a declined row among them
    for st in alone:
        curves.build_geoms([st], prof, jerk1=True)
    for a, b in zip(sts, alone):
        for x, y in zip(_fields(a), _fields(b)):
            assert _bits(x, y)


def test_the_candidates_on_load_makes_curves_and_chains_as_two_calls_did():
    prof, sts = _curves("prusa-mk3s")
    sts = sts[:600]
    codes = np.array([C_CHAIN if k % 3 else C_CURVE for k in range(len(sts))], np.int8)
    one = [copy.copy(st) for st in sts]
    for st in one:
        st.curv = None
    curve_geometry(codes, prof)(0, one)
    two = [copy.copy(st) for st in sts]
    for st in two:
        st.curv = None
    for code, kappa in ((C_CURVE, True), (C_CHAIN, False)):
        curves.build_geoms([st for st, c in zip(two, codes) if c == code], prof, jerk1=True, kappa=kappa)
    for a, b, c in zip(one, two, codes):
        for x, y in zip(_fields(a), _fields(b)):
            assert _bits(x, y)
        if c == C_CURVE:        # κ made now for a curve (none read yet: the block's own)
            assert a.curv._b._kv is not None and _bits(a.curv.kappa_v, b.curv.kappa_v)
            assert _bits([a.curv.kappa_eff], [b.curv.kappa_eff])


# ---------------------------------------------------------------- units of windows
def test_level_units_group_windows_until_they_hold_enough_rows():
    from gcode_opt.schedule import _level_units
    bounds = [0, 10, 20, 30, 40, 50]
    rows = np.array([1, 2, 3, 12, 25, 26, 27, 28, 41])       # 3, 1, 4, 0, 1 a window
    assert _level_units(rows, bounds, 4) == [(0, 2), (2, 3), (3, 5)]
    assert _level_units(rows, bounds, 3) == [(0, 1), (1, 3), (3, 5)]
    assert _level_units(rows, bounds, 2) == [(0, 1), (1, 3), (3, 5)]
    assert _level_units(rows, bounds, 100) == [(0, 5)]
    assert _level_units(rows, bounds, 0) == [(j, j + 1) for j in range(5)]
    assert _level_units(None, bounds, 4) == [(j, j + 1) for j in range(5)]


def _units_case(name, w, level_rows, decide=False, line_rows=0):
    from test_speed50_wina50_windows import SAMPLES, _setup
    from gcode_opt.schedule import _faults_of, candidates_in_windows
    prof, opts, strokes, pin, rows = _setup(SAMPLES / name)
    failed = _faults_of(pin.fault)
    info = {}
    bounds = np.unique(np.r_[np.arange(0, len(strokes), w), len(strokes)])
    cands, nonfinite = candidates_in_windows(strokes, pin, prof, opts, rows, failed, bounds, info, decide,
                                             level_rows=level_rows, line_rows=line_rows)
    for i in nonfinite:
        failed.setdefault(int(i), "error: planning (non-finite)")
    return cands, failed, info


@pytest.mark.parametrize("name, w, level_rows, decide", [
    ("prusa_gyroid.gcode", 64, 40, False),              # curves: units of a few windows
    ("prusa_benchy_like.gcode", 37, 25, False),         # units made again (the largest levels late)
    ("prusa_gyroid_arcs.gcode", 37, 5, False),          # arcs' units made again
    ("prusa_gyroid_arcs.gcode", 37, 30, True),
])
def test_units_of_windows_give_one_calls_tables(name, w, level_rows, decide):
    """candidates_in_windows with its arcs' and curves' candidates a unit of windows at a
    time (level_rows): every stroke's entries one call's (schedule._candidates), bit for
    bit, units made again where their levels fall short of the file's."""
    from test_speed50_wina50_windows import SAMPLES, _assert_same, _one_call
    ref, failed_ref, _, n = _one_call(SAMPLES / name)
    got, failed, info = _units_case(name, w, level_rows, decide)
    _assert_same(ref, got, n)
    assert failed == failed_ref
    own = info["own"] + info["arc_own"]
    assert 1 < sum(1 for o in own if o) < -(-n // w)        # several units, fewer than the windows
    if name != "prusa_gyroid.gcode" and not decide:
        assert info["redone"] > 0


@pytest.mark.parametrize("name", ["prusa_mk3s_rectilinear.gcode", "prusa_gyroid.gcode", "prusa_klipper.gcode"])
def test_lines_a_unit_of_windows_give_one_calls_tables(name):
    """candidates_in_windows with the lines' candidates a unit of windows a call (line_rows,
    the arcs' and curves' too): one call's tables, bit for bit."""
    from test_speed50_wina50_windows import SAMPLES, _assert_same, _one_call
    ref, failed_ref, rows, n = _one_call(SAMPLES / name)
    assert rows[K_LINE].size > 300
    got, failed, _ = _units_case(name, 41, 60, line_rows=150)
    _assert_same(ref, got, n)
    assert failed == failed_ref
