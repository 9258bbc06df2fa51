"""Arcs and curves row-own in windowed candidates (issue 8, arcs53): the candidate tables of
schedule.candidates_in_windows at windows of 1, 7, 37 and 256 strokes are one call's
(schedule._candidates), cell by cell, on the samples with arcs or curves -- arcs too (their
figures read on the file's panel levels: arcs.candidates_arc's levels), and arcs or curves
that go to Newton (circle._newton_cheb: each arc's steps its own).  Run compiled and with
GCODE_OPT_PURE_PYTHON=1."""
import numpy as np
import pytest

from gcode_opt import arcs
from gcode_opt.laws import circle
from gcode_opt.strokes import K_ARC

from test_speed50_wina50_windows import SAMPLES, _assert_same, _setup, _windows


def _every(w):
    return lambda n, rows: np.unique(np.r_[np.arange(0, n, w), n])


_ONE = {}


def _ref(name, prof_name):
    if (name, prof_name) not in _ONE:
        _ONE[name, prof_name] = _one_call_at(name, prof_name)
    return _ONE[name, prof_name]


def _one_call_at(name, prof_name):
    from gcode_opt.schedule import _candidates, _faults_of
    prof, opts, strokes, pin, rows = _setup_at(name, prof_name)
    failed = _faults_of(pin.fault)
    n0 = circle.NEWTON_ARCS[0]
    cands, _ = _candidates(strokes, pin, prof, opts, rows, failed)
    return cands, failed, len(strokes), circle.NEWTON_ARCS[0] - n0


def _setup_at(name, prof_name):
    from gcode_opt import features as feat
    from gcode_opt.pipeline import Options, analyse
    from gcode_opt.profile import load_profile
    from gcode_opt.schedule import _plan_kind_codes_of, _rows_by_kind, plan_inputs
    prof = load_profile(prof_name)
    path = str(SAMPLES / name)
    opts = Options(features=feat.default_selection(path)[0])
    strokes, _ = analyse(path, prof, opts)
    pin = plan_inputs(strokes, prof, opts)
    return prof, opts, strokes, pin, _rows_by_kind(strokes, _plan_kind_codes_of(strokes, pin))


def _windows_at(name, prof_name, w):
    from gcode_opt.schedule import _faults_of, candidates_in_windows
    prof, opts, strokes, pin, rows = _setup_at(name, prof_name)
    failed = _faults_of(pin.fault)
    info = {}
    cands, nonfinite = candidates_in_windows(strokes, pin, prof, opts, rows, failed,
                                             _every(w)(len(strokes), rows), info)
    for i in nonfinite:
        failed.setdefault(int(i), "error: planning (non-finite)")
    return cands, failed, info


# (sample, profile, windows): every sample with arcs or curves at 1, 7, 37 and 256 strokes a
# window; in the default run one case of each defect, the others behind the slow mark
FAST = [("prusa_gyroid_arcs.gcode", "prusa-mk3s", (1,)),            # arcs' levels, the lead's defect
        ("prusa_concentric_arcs.gcode", "prusa-mk3s", (37,)),       # arcs that go to Newton
        ("prusa_benchy_like.gcode", "voron24", (37,))]              # curves that go to Newton
SLOW = [("prusa_gyroid_arcs.gcode", "prusa-mk3s", (7, 37, 256)),
        ("prusa_concentric_arcs.gcode", "prusa-mk3s", (1, 7, 256)),
        ("prusa_benchy_like.gcode", "voron24", (1, 7, 256)),
        ("prusa_benchy_like.gcode", "prusa-mk3s", (1, 7, 37, 256)),
        ("prusa_gyroid.gcode", "prusa-mk3s", (1, 7, 37, 256)),
        ("prusa_concentric.gcode", "prusa-mk3s", (1, 7, 37, 256)),
        ("edge/arcs.gcode", "prusa-mk3s", (1, 7, 37, 256)),
        ("edge/arc_variants.gcode", "prusa-mk3s", (1, 7, 37, 256))]


def _check(name, prof_name, wins):
    ref, failed_ref, n, newton = _ref(name, prof_name)
    for w in wins:
        got, failed, info = _windows_at(name, prof_name, w)
        _assert_same(ref, got, n)
        assert failed == failed_ref
    return newton, info


@pytest.mark.parametrize("name,prof_name,wins", FAST)
def test_windows_are_one_call_cell_by_cell(name, prof_name, wins):
    newton, info = _check(name, prof_name, wins)
    if "concentric" in name or "benchy" in name:
        assert newton > 0                   # (Newton took part: its arcs row-own too)


@pytest.mark.slow
@pytest.mark.parametrize("name,prof_name,wins", SLOW)
def test_windows_are_one_call_cell_by_cell_slow(name, prof_name, wins):
    _check(name, prof_name, wins)


def test_arc_levels_of_the_file():
    """The arcs of gyroid_arcs take other levels by part of the file (a part's own first pass
    below the file's), the first pass's levels are arc_grid_levels' (no law solved), of the
    file and of a part, and a floor at a call's own levels leaves its table as it is."""
    prof, opts, strokes, pin, rows = _setup(SAMPLES / "prusa_gyroid_arcs.gcode")
    r = rows[K_ARC]
    own = []
    table = arcs.candidates_arc(pin, r, strokes, None, own)
    assert own[0][0] == arcs.arc_grid_levels(pin, r, strokes) > 0
    firsts = []
    for part in np.array_split(r, 6):
        part_own = []
        arcs.candidates_arc(pin, part, strokes, None, part_own)
        assert part_own[0][0] == arcs.arc_grid_levels(pin, part, strokes)
        firsts.append(part_own[0][0])
    assert max(firsts) == own[0][0] and min(firsts) < max(firsts)
    again = arcs.candidates_arc(pin, r, strokes, tuple(lv for lv, _ in own))
    for x, y in zip(table, again):
        assert np.asarray(x).tobytes() == np.asarray(y).tobytes()


def test_windows_made_again_and_decide_first():
    """Windows of 37 strokes on gyroid_arcs: windows before the arcs' largest levels are made
    again; decide_first (arc_grid_levels, curve_grid_levels before the windows) makes fewer
    again, only those whose retries' levels fall short of the file's (retries that make
    figures: arcs have no screen); the same tables either way."""
    ref, failed_ref, n, _ = _ref("prusa_gyroid_arcs.gcode", "prusa-mk3s")
    redone = []
    for decide in (False, True):
        got, failed, info = _windows(SAMPLES / "prusa_gyroid_arcs.gcode", _every(37), decide)
        _assert_same(ref, got, n)
        assert failed == failed_ref
        redone.append(info["redone"])
        assert info["arc_levels"][0] == max(o[0][0] for o in info["arc_own"] if o)
    assert redone[0] > redone[1] > 0
