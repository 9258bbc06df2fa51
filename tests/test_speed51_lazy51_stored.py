"""stored_strokes.StoredStrokes (issue 8, lazy51): the strokes of a StrokeStore as a sequence
that holds a few windows: every row's stroke equal, field for field, to the list's; the same
object for a row while its window is held; changes written back (writeback / changed) and
the kept fields' objects (chain_T) given back to their rows after their window was let go;
and the candidate tables of schedule.candidates_in_windows over it the same bits as over the
list (windows of 1, a few and many strokes)."""
import numpy as np
import pytest

from gcode_opt import features as feat
from gcode_opt import pipeline as pl
from gcode_opt.profile import load_profile
from gcode_opt.schedule import (_faults_of, _plan_kind_codes_of, _rows_by_kind, candidates_in_windows, plan_inputs)
from gcode_opt.stored_strokes import StoredStrokes
from gcode_opt.stroke_store import StrokeStore

from test_speed51_lazy51_spill import _fields

SAMPLES = "sample_gcode/"


def _strokes(name, prof="prusa-mk3s"):
    opts = pl.Options(features=feat.default_selection(SAMPLES + name)[0])
    return pl.analyse(SAMPLES + name, load_profile(prof), opts)[0]


@pytest.mark.parametrize("window,held", [(1, 1), (7, 2), (100, 3), (10 ** 6, 1)])
def test_rows_are_the_lists(window, held):
    ref = _strokes("prusa_gyroid.gcode")
    with StrokeStore() as store:
        store.append(ref)
        s = StoredStrokes(store, window, held)
        assert len(s) == len(ref)
        assert [_fields(a) for a in s] == [_fields(b) for b in ref]          # __iter__
        for i in (0, 5, len(ref) - 1, -1, -len(ref), 3):                      # __getitem__, random order
            assert _fields(s[i]) == _fields(ref[i])
        assert [_fields(a) for a in s[3:11]] == [_fields(b) for b in ref[3:11]]
        with pytest.raises(IndexError):
            s[len(ref)]
        # the same object while its window is held
        a = s[4]
        assert s[4] is a
        if window >= len(ref):
            assert s[len(ref) - 1] is s[len(ref) - 1] and s[4] is a
        assert s.bounds()[0] == 0 and s.bounds()[-1] == len(ref)


@pytest.mark.parametrize("writeback", [True, False])
def test_changes_written_back(writeback):
    ref = _strokes("prusa_mk3s_rectilinear.gcode")
    with StrokeStore() as store:
        store.append(ref)
        s = StoredStrokes(store, 16, 1, writeback=writeback)
        s[3].v1 = 1.25
        if not writeback:
            s.changed(3)
        s[40].v0 = 2.5                 # (another window: row 3's let go, written back)
        s.changed(40)
        s.let_go()
        back = store.load(0, len(store))
    assert back[3].v1 == 1.25 and back[40].v0 == 2.5
    assert _fields(back[5]) == _fields(ref[5])


def test_unmarked_change_is_lost_without_writeback():
    """(the hazard the audit names: a change not marked is not written back)"""
    ref = _strokes("prusa_mk3s_rectilinear.gcode")
    with StrokeStore() as store:
        store.append(ref)
        s = StoredStrokes(store, 16, 1)
        s[3].v1 = 1.25
        s[40]
        assert s[3].v1 == ref[3].v1


def test_kept_objects_come_back():
    ref = _strokes("prusa_gyroid.gcode")
    with StrokeStore() as store:
        store.append(ref)
        s = StoredStrokes(store, 8, 1, keep=("chain_T",))
        mark = object()
        s[2].chain_T = mark
        s[100]                          # row 2's window let go
        assert s[2].chain_T is mark
        assert s[3].chain_T is ref[3].chain_T is None


def _pin(strokes, prof, opts):
    pin = plan_inputs(strokes, prof, opts)
    return pin, _rows_by_kind(strokes, _plan_kind_codes_of(strokes, pin))


def _table(c, n):
    cnt = c.cnt
    at = np.repeat(c.first - np.cumsum(cnt) + cnt, cnt) + np.arange(int(cnt.sum()))
    return cnt.tobytes(), c.t_pos.tobytes(), c.col[at].tobytes(), c.vals[:, at].tobytes()


@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_gyroid_fullspeed.gcode", "prusa-mk3s"),
                                       ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"), ("cura_box.gcode", "ender3")])
@pytest.mark.parametrize("window", [1, 97, 10 ** 6])
def test_candidates_over_stored_strokes(name, prof, window):
    profile = load_profile(prof)
    opts = pl.Options(features=feat.default_selection(SAMPLES + name)[0])
    ref_st = _strokes(name, prof)
    pin, rows = _pin(ref_st, profile, opts)
    bounds = list(range(0, len(ref_st), window)) + [len(ref_st)]
    failed = _faults_of(pin.fault)
    ref, bad = candidates_in_windows(ref_st, pin, profile, opts, rows, failed, bounds)
    want = _table(ref, len(ref_st))
    got_st = _strokes(name, prof)
    pin2, rows2 = _pin(got_st, profile, opts)
    with StrokeStore() as store:
        store.append(got_st)            # (after plan_inputs: the chains' marks kept)
        del got_st
        s = StoredStrokes(store, window, 1, keep=("chain_T",))
        got, bad2 = candidates_in_windows(s, pin2, profile, opts, rows2, _faults_of(pin2.fault), bounds)
    assert _table(got, len(s)) == want
    assert list(bad) == list(bad2)
