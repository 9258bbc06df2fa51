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


def _blocks_and_heads(seed=5):
    """blocks (S, V, A, F, k) of rows of 2-D arrays (a block of none, one past the small
    ints' cache) and H: a row a plan (time_t, int_a2, the verdict flag, a fourth column)"""
    rng = np.random.default_rng(seed)
    blocks = []
    for k, n in ((3, 2), (0, 4), (300, 1), (1, 6)):
        S, V = rng.random((k, n + 1)), rng.random((k, n + 1))
        A, F = rng.random((k, n)), rng.random((k, n))
        blocks.append((S, V, A, F, k))
    m = sum(b[4] for b in blocks)
    H = np.column_stack([rng.random(m), rng.random(m), rng.integers(0, 2, m).astype(float), np.zeros(m)])
    return blocks, H


@pytest.mark.parametrize("compiled", [True, False])
def test_row_plans_are_the_row_plans_made_one_by_one(compiled, monkeypatch):
    """spill_file.row_plans (the rewrite core's row_plans, or the map where not built) =
    RowPlan(S, V, A, F, i, time_t, int_a2) with fault "" where flagged, each field the
    same object or bits"""
    from gcode_opt import emit, spill_file
    from gcode_opt.segments import RowPlan
    if not compiled:
        monkeypatch.setattr(emit, "CORE_MOD", None)
    elif getattr(emit.CORE_MOD, "row_plans", None) is None:
        pytest.skip("the rewrite core is not built")
    blocks, H = _blocks_and_heads()
    got = spill_file.row_plans(blocks, H)
    want = []
    q = 0
    for S, V, A, F, k in blocks:
        for i in range(k):
            p = RowPlan(S, V, A, F, i, float(H[q, 0]), float(H[q, 1]))
            if H[q, 2]:
                p.fault = ""
            want.append(p)
            q += 1
    assert len(got) == len(want) == H.shape[0]
    for g, w in zip(got, want):
        assert type(g) is RowPlan
        assert all(getattr(g, f) is getattr(w, f) for f in ("_s", "_v", "_accel", "_feed", "first_cmds"))
        assert type(g._row) is int and g._row == w._row
        assert type(g.time_t) is float and g.time_t == w.time_t and type(g.int_a2) is float and g.int_a2 == w.int_a2
        assert g.fault == w.fault and type(g.fault) is type(w.fault) and g.shape == w.shape == "law"
        assert np.array_equal(g.s, w.s) and np.array_equal(g.v, w.v) and np.array_equal(g.feed, w.feed)


def test_row_plans_core_declines_what_it_does_not_make():
    """the core's row_plans answers None (the caller's map then) for a class with a
    __dict__ or a __new__, a field not a slot, a slot more than the ten it fills, heads of
    two columns or not float64, counts that are not the heads' rows"""
    from gcode_opt import emit
    from gcode_opt.segments import RowPlan
    make = getattr(emit.CORE_MOD, "row_plans", None)
    if make is None:
        pytest.skip("the rewrite core is not built")
    blocks, H = _blocks_and_heads()

    class WithDict(RowPlan):
        pass

    class WithNew(RowPlan):
        __slots__ = ()

        def __new__(cls, *a):
            return object.__new__(cls)

    class Shaped(RowPlan):
        __slots__ = ()
        shape = property(lambda self: "law")

    class MoreSlots(RowPlan):
        __slots__ = ("extra",)

    assert make(RowPlan, blocks, H, "law", "") is not None
    for cls in (WithDict, WithNew, Shaped, MoreSlots):
        assert make(cls, blocks, H, "law", "") is None
    assert make(RowPlan, blocks, np.ascontiguousarray(H[:, :2]), "law", "") is None
    assert make(RowPlan, blocks, H.astype(np.float32), "law", "") is None
    assert make(RowPlan, blocks[:-1], H, "law", "") is None


@pytest.mark.parametrize("name", ["prusa_gyroid.gcode", "prusa_mk3s_rectilinear.gcode"])
def test_windowed_command_writes_the_list_paths_bytes(name, monkeypatch, tmp_path):
    """the command windowed at 64 strokes: the list path's file and summary, with the plans
    read back made by row_plans, the re-timed rows held, the summary's columns read from
    the records' fields"""
    import os
    from gcode_opt import spill_file
    from gcode_opt.stored_strokes import HeldRows
    from test_speed20_rewrite_core import SAMPLES
    from windowed_run import run_command
    seen = {"row_plans": 0, "hold": 0, "stored_columns": 0}

    def spy(owner, attr, key, check=lambda got: True):
        fn = getattr(owner, attr)

        def wrapped(*a, **k):
            got = fn(*a, **k)
            seen[key] += bool(check(got))
            return got
        monkeypatch.setattr(owner, attr, wrapped)
    spy(spill_file, "row_plans", "row_plans", len)
    spy(HeldRows, "hold", "hold")
    spy(sc, "_stored_columns", "stored_columns", lambda got: got is not None)

    def run(windowed):
        return run_command(monkeypatch, os.path.join(SAMPLES, name), tmp_path / f"out{windowed}.gcode", windowed, 64)
    want = run(False)
    assert seen == {"row_plans": 0, "hold": 0, "stored_columns": 0}
    got = run(True)
    assert got[0] == want[0] and got[1] == want[1]
    assert seen["row_plans"] and seen["hold"] > 1 and seen["stored_columns"] == 1
