"""out58 (issue 8, the windowed steps after planning): the summary's columns of strokes kept
in a StrokeStore read from the records' fields with no stroke made
(stroke_columns._stored_columns) equal the columns of the strokes loaded window by window
(StrokeColumns._add_loaded, the code before), values, types, dicts and their order, on real
samples and on odd values (which the records' fields do not hold: the strokes then)."""
from __future__ import annotations

import numpy as np
import pytest

from gcode_opt import stroke_columns as sc
from gcode_opt.stroke_columns import StrokeColumns
from gcode_opt.stroke_store import StrokeStore

from test_speed20_rewrite_core import CASES, _planned
from test_speed52_rew52_windowed import _columns_equal


def _store(strokes):
    store = StrokeStore()
    store.append(strokes)
    return store


def _loaded(store, window):
    """StrokeColumns of the store's strokes as _add_loaded makes them (the reference)."""
    cols = StrokeColumns(store, fields=False)
    cols.n_moves = cols.last_idx - cols.first_idx + 1
    cols._add_loaded(store, window)
    return cols


@pytest.mark.parametrize("name,prof_name", CASES)
def test_stored_columns_are_the_loaded_ones(name, prof_name):
    strokes = _planned(name, prof_name)[2]
    with _store(strokes) as store:
        assert sc._stored_columns(store) is not None       # (real strokes: read from the fields)
        got = StrokeColumns(store, fields=False)
        got.add_fields(store)
        _columns_equal(got, _loaded(store, 7))
        _columns_equal(got, StrokeColumns(strokes))


def _odd_strokes(n=40):
    """n strokes of a real sample, read back from a store (new objects to alter)"""
    strokes = _planned(*CASES[0])[2]
    with _store(strokes[:n]) as store:
        return store.load(0, n)


def test_codes_in_the_order_first_met_across_batches():
    """more strokes than a read batch (1024), the features and layers met in a new order
    past the first batch, and equal strs of two objects (two entries of the store's table):
    one code, as a dict filled value by value gives them"""
    base = _odd_strokes(1)[0]
    with _store([base] * 2500) as store:
        sts = store.load(0, 2500)
    texts = ["perimeter", "infill", "".join(["peri", "meter"])]        # (the third: the first's value, another object)
    for i, st in enumerate(sts):
        st.feature = None if i % 11 == 3 else texts[(i // 700 + i % 3 // 2) % 3]
        st.layer = 2500 - i // 300
        st.kind = "curve" if i > 1800 else "line"
    with _store(sts) as store:
        assert len({id(x) for x in store._table if isinstance(x, str) and x == "perimeter"}) == 2
        got = sc._stored_columns(store)
        assert got is not None
        want = _loaded(store, 1000)
        assert list(got[1]["feature"][0].items()) == list(want.code_of["feature"].items())
        for name in sc.CODED:
            assert list(got[1][name][0].items()) == list(want.code_of[name].items())
            assert got[1][name][1].dtype == np.intp and np.array_equal(got[1][name][1], want.codes[name])
        cols = StrokeColumns(store)
        _columns_equal(cols, want)
    _columns_equal(cols, StrokeColumns(sts))


@pytest.mark.parametrize("odd", ["v_feed_none", "v_feed_int", "kind_unset", "layer_none", "layer_bool",
                                 "feature_none"])
def test_odd_values_give_the_loaded_columns(odd):
    sts = _odd_strokes()
    st = sts[17]
    if odd == "v_feed_none":
        st.v_feed = None
    elif odd == "v_feed_int":
        st.v_feed = 7
    elif odd == "kind_unset":
        del st.kind
    elif odd == "layer_none":
        st.layer = None
    elif odd == "layer_bool":
        st.layer = True
    else:
        st.feature = None
    with _store(sts) as store:
        # a None feature is one the fields hold; the others: the strokes made
        assert (sc._stored_columns(store) is None) == (odd != "feature_none")
        cols = StrokeColumns(store)
        _columns_equal(cols, _loaded(store, 3))
    _columns_equal(cols, StrokeColumns(sts))


@pytest.mark.parametrize("compiled", [True, False])
def test_held_rows_hold_only_the_rows_asked(compiled, monkeypatch):
    """HeldRows.hold (the rewrite's re-timed rows of a window): each call's rows (unsorted,
    repeated) hold their strokes, every other slot None, with the slots put by objfields'
    compiled passes or the Python loops"""
    from gcode_opt import objfields
    from gcode_opt.stored_strokes import HeldRows
    if not compiled:
        monkeypatch.setattr(objfields, "_LIST_PUT", None)
    strokes = _planned(*CASES[0])[2][:60]
    with _store(strokes) as store:
        held = HeldRows(store, 16)
        for rows in ([5, 3, 3, 40], [], [41, 7, 59, 0, 7], [3]):
            held.hold(np.array(rows, np.int64))
            want = sorted(set(rows))
            assert [i for i, s in enumerate(held.slots) if s is not None] == want
            for i in want:
                got, ref = held.slots[i], strokes[i]
                assert (got.first_idx, got.last_idx, got.x0, got.time_t) == (ref.first_idx, ref.last_idx, ref.x0,
                                                                             ref.time_t)
        assert held.made == 3 + 0 + 4 + 1


def test_stored_lines_are_the_columns():
    """line_columns of stored strokes (one pass of the records' fields) = the store's two
    columns and the list's line_spans, across read batches"""
    from gcode_opt.stroke_columns import line_columns
    from gcode_opt.strokes import line_spans
    strokes = _planned(*CASES[0])[2]
    many = [strokes[i % len(strokes)] for i in range(2100)]
    with _store(many) as store:
        first, last = line_columns(store)
        assert first.dtype == last.dtype == np.int64
        assert np.array_equal(first, store.column("first_idx")) and np.array_equal(last, store.column("last_idx"))
        want = line_spans(many)
        assert np.array_equal(first, want[0]) and np.array_equal(last, want[1])
