"""The steps after planning over strokes kept in a StrokeStore, a window at a time (issue 8,
rew52): pipeline.rewrite made from a StoredStrokes / StrokeStore (stored_strokes.HeldRows:
only the re-timed rows' strokes made, a window of rows at a time, the loop's state carried
from window to window) writes the same bytes, output ranges, digests, reasons and plans as
over the list -- compiled run, the loop stroke by stroke (_STROKE_RUN off), the text path
(_rewrite_text), a second pass's reuse -- on real files (four flavours, CRLF, arcs),
windows of 1, 7 and more strokes than the file has; and StrokeColumns (measure's lines,
the summary's columns), _first_line_order and stroke_lines from the store equal the list's.
The reference is the list path (itself checked against ede93db's verbatim rewrite in
test_speed20_rewrite_core)."""
from __future__ import annotations

import copy
import io

import numpy as np
import pytest

from gcode_opt import pipeline
from gcode_opt.stored_strokes import HeldRows, StoredStrokes
from gcode_opt.stroke_columns import CODED, FLOATS, StrokeColumns
from gcode_opt.stroke_store import StrokeStore

from test_speed20_rewrite_core import CASES, SAMPLES, _planned, _run

WINDOWS = (1, 7, 10 ** 6)


def _store(strokes):
    store = StrokeStore()
    store.append(strokes)
    return store


def _taken(store):
    """store.take recording the rows it made strokes of"""
    rows = []
    take = store.take

    def spy(r):
        rows.extend(np.asarray(r).tolist())
        return take(r)
    store.take = spy
    return rows


@pytest.mark.parametrize("name,prof_name", CASES)
@pytest.mark.parametrize("window", WINDOWS)
def test_rewrite_from_store_is_the_lists(name, prof_name, window, tmp_path):
    prof, opts, strokes, plan = _planned(name, prof_name)
    path = SAMPLES + name
    want = _run(pipeline.rewrite, path, strokes, plan, prof, opts, tmp_path / "a.gcode")
    with _store(strokes) as store:
        made = _taken(store)
        got = _run(pipeline.rewrite, path, StoredStrokes(store, window), plan, prof, opts, tmp_path / "b.gcode")
        assert got[0] == want[0]
        assert [tuple(r) for r in got[1]] == [tuple(r) for r in want[1]]
        assert got[2:] == want[2:]
        # only the re-timed rows' strokes were made, each once
        assert sorted(made) == np.flatnonzero(plan.retime).tolist()
    # the text path (a stream without a binary file under it), from the store as it is
    want_t = _run(pipeline.rewrite, path, strokes, plan, prof, opts, None, text_stream=True)
    with _store(strokes) as store:
        got_t = _run(pipeline.rewrite, path, StoredStrokes(store, window), plan, prof, opts, None, text_stream=True)
    assert got_t[0] == want_t[0] == want[0]
    assert [tuple(r) for r in got_t[1]] == [tuple(r) for r in want_t[1]]
    assert got_t[2:] == want_t[2:]


@pytest.mark.parametrize("window", (1, 5))
def test_rewrite_loop_and_store_window(window, monkeypatch, tmp_path):
    """the loop stroke by stroke (no compiled run) and a bare StrokeStore (its WINDOW)"""
    prof, opts, strokes, plan = _planned(*CASES[0])
    path = SAMPLES + CASES[0][0]
    want = _run(pipeline.rewrite, path, strokes, plan, prof, opts, tmp_path / "a.gcode")
    with _store(strokes) as store:
        monkeypatch.setattr("gcode_opt.stored_strokes.WINDOW", window)
        got = _run(pipeline.rewrite, path, store, plan, prof, opts, tmp_path / "b.gcode")
        monkeypatch.setattr(pipeline, "_STROKE_RUN", False)
        got2 = _run(pipeline.rewrite, path, StoredStrokes(store, window), plan, prof, opts, tmp_path / "c.gcode")
    for g in (got, got2):
        assert g[0] == want[0]
        assert [tuple(r) for r in g[1]] == [tuple(r) for r in want[1]]
        assert g[2:] == want[2:]


def test_second_pass_reuse_from_store(tmp_path):
    """a second rewrite copying the first's blocks (_Reuse), from the store: the same bytes"""
    prof, opts, strokes, plan = _planned(*CASES[0])
    path = SAMPLES + CASES[0][0]
    first = tmp_path / "first.gcode"
    with open(first, "w", encoding="utf-8", errors="surrogateescape", newline="") as fh:
        digests = {}
        plan = copy.deepcopy(plan)
        ranges = pipeline.rewrite(path, fh, strokes, plan, prof, opts, digests)
    outs = []
    for src in (strokes, "store"):
        with _store(strokes) as store:
            reuse = pipeline._Reuse(str(first), ranges, plan.segs, plan.beta, digests)
            buf = io.StringIO(newline="")
            d2 = {}
            r2 = pipeline.rewrite(path, buf, strokes if src is strokes else StoredStrokes(store, 3),
                                  copy.deepcopy(plan), prof, opts, d2, reuse)
            reuse.close()
            outs.append((buf.getvalue(), [tuple(r) for r in r2], d2))
    assert outs[0] == outs[1]
    assert outs[0][0].encode("utf-8", "surrogateescape") == first.read_bytes()


def _columns_equal(a, b):
    assert a.n == b.n
    for f in ("first_idx", "last_idx", "n_moves"):
        x, y = getattr(a, f), getattr(b, f)
        assert x.dtype == y.dtype and np.array_equal(x, y)
    for name in FLOATS:
        x, y = a.floats[name], b.floats[name]
        assert type(x) is type(y)
        if isinstance(x, np.ndarray):
            assert x.dtype == y.dtype and x.tobytes() == y.tobytes()
        else:
            assert list(map(repr, x)) == list(map(repr, y))
    for name in CODED:
        assert list(a.code_of[name].items()) == list(b.code_of[name].items())
        assert a.codes[name].dtype == b.codes[name].dtype and np.array_equal(a.codes[name], b.codes[name])


@pytest.mark.parametrize("name,prof_name", CASES)
@pytest.mark.parametrize("window", WINDOWS)
def test_columns_from_store_are_the_lists(name, prof_name, window, tmp_path):
    prof, opts, strokes, plan = _planned(name, prof_name)
    want = StrokeColumns(strokes)
    with _store(strokes) as store:
        for src in (StoredStrokes(store, window), store):
            got = StrokeColumns(src, fields=False)
            assert got.n_moves is None and not got.floats
            got.add_fields(src)
            _columns_equal(got, want)
        order = pipeline._first_line_order(StrokeColumns(store, fields=False))
    assert order == pipeline._first_line_order(want)
    with open(tmp_path / "o.gcode", "w", encoding="utf-8", errors="surrogateescape", newline="") as fh:
        ranges = pipeline.rewrite(SAMPLES + name, fh, strokes, copy.deepcopy(plan), prof, opts)
    got_l, want_l = pipeline.stroke_lines(got, order, ranges), pipeline.stroke_lines(want, order, ranges)
    assert (got_l is None) == (want_l is None)
    if want_l is not None:
        assert all(np.array_equal(x, y) for x, y in zip(got_l, want_l))


def test_columns_of_odd_values():
    """a float field holding a non-float somewhere (the list of values), a kind left unset
    ("line", as the summary reads it): the same columns from the store, windows of 1 and 3"""
    prof, opts, strokes, plan = _planned(*CASES[0])
    with _store(strokes[:20]) as store:
        sts = store.load(0, 20)
    sts[4].v_feed = None
    sts[9].v_feed = 7                 # (an int)
    del sts[12].kind
    want = StrokeColumns(sts)
    with _store(sts) as store:
        for w in (1, 3):
            _columns_equal(StrokeColumns(StoredStrokes(store, w)), want)
    assert isinstance(want.floats["v_feed"], list)


def test_columns_of_no_stroke():
    with StrokeStore() as store:
        _columns_equal(StrokeColumns(store), StrokeColumns([]))


def test_held_rows_windows():
    prof, opts, strokes, plan = _planned(*CASES[0])
    with _store(strokes[:50]) as store:
        held = HeldRows(store, 8)
        order = np.array([0, 3, 7, 8, 9, 20, 31, 32, 49], np.int64)
        assert held.ends(order) == [3, 5, 6, 7, 8, 9]
        held.hold(order[:3])
        assert [s is not None for s in held.slots[:9]] == [True, False, False, True, False, False, False, True, False]
        assert held.slots[3].first_idx == strokes[3].first_idx
        held.hold(order[3:5])
        assert [k for k, s in enumerate(held.slots) if s is not None] == [8, 9]
        assert held.made == 5
        assert held.ends(np.zeros(0, np.int64)) == [0]
        with pytest.raises(ValueError):
            HeldRows(store, 0)
