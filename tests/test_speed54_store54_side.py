"""stored_strokes.StoredStrokes' side tables (issue 8, store54): the kept fields' objects
(chain_T: the chains' memos) held in a list of one slot a row, not a dict {row: object}:
the same objects given back to their rows, the row's value as its window was let go (a
None then included), nothing made while no object is kept, and ~8 bytes a row held."""
import tracemalloc

from gcode_opt import stored_strokes
from gcode_opt.stored_strokes import StoredStrokes
from gcode_opt.stroke_store import StrokeStore

from test_speed51_lazy51_stored import _strokes


def _stored(window=8):
    ref = _strokes("prusa_gyroid.gcode")
    store = StrokeStore(in_memory=True)
    store.append(ref)
    return store, StoredStrokes(store, window, 1, keep=("chain_T",)), ref


def test_kept_objects_are_the_rows_across_windows():
    store, s, ref = _stored()
    with store:
        marks = {i: object() for i in (0, 7, 8, 9, len(ref) - 1)}
        for i, m in marks.items():
            s[i].chain_T = m
        s.let_go()
        for i in list(marks)[::-1] + list(marks):         # (windows loaded again, in any order)
            assert s[i].chain_T is marks[i]
        assert s[1].chain_T is ref[1].chain_T is None


def test_a_kept_object_set_to_none_stays_none():
    """The side table holds the row's value as its window was let go: a later None is not
    replaced by the object kept before (a dict updated with the objects only gave it back)."""
    store, s, ref = _stored()
    with store:
        mark = object()
        s[2].chain_T = mark
        s[100]
        assert s[2].chain_T is mark
        s[2].chain_T = None
        s[100]
        assert s[2].chain_T is None


def test_no_table_while_nothing_is_kept():
    store, s, ref = _stored()
    with store:
        for _ in s:
            pass
        s.let_go()
        assert s._side == {"chain_T": None}
        s[5].chain_T = object()
        s.let_go()
        assert len(s._side["chain_T"]) == len(s)


def test_side_table_holds_a_slot_a_row():
    """Every row keeping an object (one shared: only the table is counted): the memory
    stored_strokes.py holds once every window is let go is ~8 bytes a row (a dict held an
    int key and a hash entry a row besides: ~70)."""
    store, s, ref = _stored(window=64)
    with store:
        mark = object()
        tracemalloc.start()
        try:
            for st in s:
                st.chain_T = mark
            s.let_go()
            snap = tracemalloc.take_snapshot().filter_traces(
                [tracemalloc.Filter(True, stored_strokes.__file__)])
        finally:
            tracemalloc.stop()
        held_b = sum(t.size for t in snap.traces)
        assert len(s) > 500
        assert held_b <= 8 * len(s) + 2048, held_b       # (the list, the windows' bookkeeping)
        assert all(st.chain_T is mark for st in s)


def test_one_window_held_by_default():
    """StoredStrokes holds one window unless told: reading another lets the first go (its
    rows are new objects when read again), the kept memos given back to them."""
    ref = _strokes("prusa_gyroid.gcode")
    with StrokeStore(in_memory=True) as store:
        store.append(ref)
        s = StoredStrokes(store, 8, keep=("chain_T",))
        a = s[3]
        mark = a.chain_T = object()
        s[20]
        b = s[3]
        assert b is not a and b.chain_T is mark
        assert s.loads == 3
        two = StoredStrokes(store, 8, held=2)
        a = two[3]
        two[20]
        assert two[3] is a and two.loads == 2


def test_rows_appended_later_keep_their_objects():
    """The store appended to after the side table was made: the new rows' objects kept too."""
    ref = _strokes("prusa_gyroid.gcode")
    with StrokeStore(in_memory=True) as store:
        store.append(ref[:40])
        s = StoredStrokes(store, 8, keep=("chain_T",))
        s[3].chain_T = m3 = object()
        s[20]
        store.append(ref[40:60])
        s[50].chain_T = m50 = object()
        s[3]
        assert s[50].chain_T is m50 and s[3].chain_T is m3
