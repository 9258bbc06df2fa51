"""The windowed runs' corner_cmd0 read from the store's column (issue 8, loads55):
plan_strokes read every stroke's corner_cmd0 from a StoredStrokes, a pass loading every
window (35 on the gyroid plate, 51 on the rectilinear).  StoredStrokes.column gives a
field of every row as the strokes are now (a held window's changes included) without a
window loaded; schedule._corner_cmd0 gives the list's bools from it."""
import numpy as np

from gcode_opt import schedule
from gcode_opt.stored_strokes import StoredStrokes
from gcode_opt.stroke_store import StrokeStore

from test_speed51_lazy51_stored import _strokes

MARKED = (0, 7, 8, 30, -1)          # rows across windows of 8, the last one's included


def _stored(ref, window=8):
    store = StrokeStore(in_memory=True)
    store.append(ref)
    return store, StoredStrokes(store, window)


def _marked():
    ref = _strokes("prusa_gyroid.gcode")
    for i in MARKED:
        ref[i].corner_cmd0 = True
    return ref


def test_column_holds_a_held_windows_changes():
    ref = _strokes("prusa_gyroid.gcode")
    store, s = _stored(ref)
    with store:
        st = s[9]
        st.corner_cmd0 = True
        s.changed(9)
        loads = s.loads
        col = s.column("corner_cmd0")
        assert col.dtype == np.int64 and col.tolist() == [int(i == 9) for i in range(len(ref))]
        assert s.loads == loads and s[9] is st          # (nothing loaded; the window still held)


def test_corner_cmd0_of_stored_strokes_is_the_lists_without_a_load():
    ref = _marked()
    want = schedule._corner_cmd0(ref)
    assert want.dtype == bool and np.flatnonzero(want).tolist() == sorted(i % len(ref) for i in MARKED)
    store, s = _stored(ref)
    with store:
        got = schedule._corner_cmd0(s)
        assert s.loads == 0
        assert got.dtype == bool and got.tolist() == want.tolist()


def test_a_record_not_an_int_is_read_as_the_list_reads_it():
    """A None (no int in the store's column) falls back to the objects' bools."""
    ref = _marked()
    ref[3].corner_cmd0 = None
    want = schedule._corner_cmd0(ref)
    store, s = _stored(ref)
    with store:
        assert schedule._corner_cmd0(s).tolist() == want.tolist()
        assert not want[3]
