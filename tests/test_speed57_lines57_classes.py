"""The windowed runs' line classes read from the store (issue 8, lines57): StrokeStore.fields
reads a record's fields as strokes.stroke_fields reads a stroke's (no stroke made: the
compiled core's store_fields, or its Python twin), segments.stored_line_classes makes of
them the classes segments.line_classes makes of the strokes, and schedule.plan_strokes over
a StoredStrokes takes them so (no window loaded), its held windows' changes written back
first.  Checked here against the strokes' own attributes and line_classes of a list, both
codecs, and the command windowed against the list path's bytes."""
import struct
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import features as feat, schedule as sc, segments, stroke_store as ss, strokes as stm
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.segments import line_classes, stored_line_classes
from gcode_opt.stored_strokes import StoredStrokes

from windowed_run import run_command

ROOT = Path(__file__).resolve().parent.parent
SAMPLES = ROOT / "sample_gcode"
NAMES = ("prusa_mk3s_rectilinear.gcode", "prusa_gyroid_arcs.gcode", "prusa_klipper.gcode")
COMPILED = stm._BASE is not None and hasattr(stm._CORE, "store_fields")
PURE = [False, True] if COMPILED else [True]
FIELDS = ("length_d", "v0", "_pux", "_nuy", "accel", "v_feed", "v0_fw", "corner_cmd0", "corner_cmd1", "_ends",
          "lim", "feature", "arc", "pts", "chain_T", "first_idx", "last_idx")
_NONE_NAN = struct.unpack("=d", struct.pack("=Q", 0x7ff8000000000000))[0]
_UNSET = object()
_CACHE = {}


def _planned(name):
    """The sample's strokes after plan_inputs (chains' marks, corners' fields set)."""
    if name not in _CACHE:
        path = str(SAMPLES / name)
        prof = load_profile("prusa-mk3s")
        opts = Options(features=feat.default_selection(path)[0])
        sts, _ = analyse(path, prof, opts)
        sc.plan_inputs(sts, prof, opts)
        _CACHE[name] = sts
    return _CACHE[name]


def _want(v):
    """(value's bits or None, kind) a field of a stroke reads as: stroke_fields' kinds, a
    shared str / Limits 5 (its value: the object itself), an int field its int64 bits."""
    if v is _UNSET:
        return 0.0, 4
    if v is None:
        return _NONE_NAN, 1
    if v is True or v is False:
        return float(v), 2
    if type(v) is float:
        return v, 0
    if type(v) is int:
        return None, 6
    if type(v) is str or type(v).__name__ == "Limits":
        return v, 5
    return 0.0, 3


@pytest.mark.parametrize("pure", PURE)
@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("in_memory", [False, True])
def test_fields_read_as_the_strokes_hold_them(name, pure, in_memory):
    sts = _planned(name)
    rows = np.arange(1, len(sts), 2, dtype=np.int64)          # (every other record: reads with gaps)
    seen = set()
    with ss.StrokeStore(in_memory=in_memory, pure=pure) as store:
        store.append(sts)
        got = list(store.fields(rows, FIELDS, size=100))
        assert [len(v) for v, _ in got] == [min(100, rows.size - a) for a in range(0, rows.size, 100)]
        vals = np.concatenate([v for v, _ in got])
        kinds = np.concatenate([k for _, k in got])
        for q, r in enumerate(rows.tolist()):
            for j, nm in enumerate(FIELDS):
                want, kind = _want(getattr(sts[r], nm, _UNSET))
                if kind == 6:                                    # (an int field: its int64 bits)
                    assert kinds[q, j] == 0 and vals[q, j:j + 1].view(np.int64)[0] == getattr(sts[r], nm)
                    continue
                assert kinds[q, j] == kind, (r, nm)
                seen.add((nm, kind))
                if kind == 5:
                    assert store.shared(int(vals[q, j])) is want, (r, nm)
                else:
                    assert struct.pack("=d", vals[q, j]) == struct.pack("=d", want), (r, nm)
    # (what the samples hold: floats, None, bools, shared objects, arrays / arcs)
    assert {k for _, k in seen} >= {0, 1, 2, 5} and ("_ends", 1) in seen
    if name == "prusa_gyroid_arcs.gcode":
        assert ("arc", 3) in seen and ("_ends", 3) in seen


@pytest.mark.parametrize("pure", PURE)
def test_fields_of_odd_values(pure):
    """An int and a str in float fields, an unset slot, a float lim: each its kind."""
    sts = [stm.Stroke.__new__(stm.Stroke) for _ in range(3)]
    src = _planned(NAMES[0])[:3]
    for a, b in zip(sts, src):
        for nm in stm.FIELDS:
            if hasattr(b, nm):
                setattr(a, nm, getattr(b, nm))
    sts[0].accel, sts[1].accel, sts[2].lim = 3, "x", 2.5
    sts[1].v_feed = None
    del sts[2].corner_cmd1
    with ss.StrokeStore(pure=pure) as store:
        store.append(sts)
        (vals, kinds), = store.fields(np.arange(3), ("accel", "v_feed", "lim", "corner_cmd1"))
    assert kinds.tolist() == [[3, 0, 5, 2], [5, 1, 5, 2], [0, 0, 0, 4]]
    assert vals[0, 0] == 0.0 and vals[2, 2] == 2.5 and np.isnan(vals[1, 1]) and vals[2, 3] == 0.0


def _classes_pair(sts, rows, pure):
    with ss.StrokeStore(pure=pure) as store:
        store.append(sts)
        got = stored_line_classes(store, rows)
    return got, line_classes([sts[i] for i in rows.tolist()])


@pytest.mark.parametrize("pure", PURE)
@pytest.mark.parametrize("name", NAMES)
def test_stored_classes_are_the_list_classes(name, pure, monkeypatch):
    """Every stroke's and the lines' classes from the records: line_classes' own, bit for bit
    (chunks of 64 records: the limits objects and rows met across chunks)."""
    monkeypatch.setattr(segments, "FIELD_ROWS", 64)
    sts = _planned(name)
    every = np.arange(len(sts), dtype=np.int64)
    for rows in (every, every[1::3]):
        got, want = _classes_pair(sts, rows, pure)
        assert got is not None
        assert got.dtype == want.dtype and got.tolist() == want.tolist()
    assert len(set(want.tolist())) < len(want)              # (some rows share a class)


@pytest.mark.parametrize("pure", PURE)
def test_stored_classes_tell_limits_and_types_apart(pure):
    """Lines alike but for lim's values (two objects of equal values: one class), a None lim,
    a corner command True where the others are False: the list's classes; a corner command
    a float beside the bools, an int field: declined (None: the strokes' own reading)."""
    src = _planned(NAMES[0])
    one = next(st for st in src if st._ends is None and st.first_idx == st.last_idx)
    sts = []
    for _ in range(8):                          # (eight copies of one line)
        st = stm.Stroke.__new__(stm.Stroke)
        for nm in stm.FIELDS:
            if hasattr(one, nm):
                setattr(st, nm, getattr(one, nm))
        sts.append(st)
    base = sts[0].lim
    sts[1].lim, sts[2].lim, sts[3].lim = base.replace(), base.replace(v_max=base.v_max + 1.0), None
    for st in sts:
        st.corner_cmd0 = False
    sts[4].corner_cmd0 = True
    every = np.arange(len(sts), dtype=np.int64)
    got, want = _classes_pair(sts, every, pure)
    assert got.tolist() == want.tolist()
    assert got[1] == got[0] == got[5] and len({got[0], got[2], got[3], got[4]}) == 4
    sts[5].corner_cmd0 = 1.0
    assert _classes_pair(sts, every, pure)[0] is None
    sts[5].corner_cmd0, sts[6].v_feed = False, 7
    assert _classes_pair(sts, every, pure)[0] is None


def test_windowed_runs_take_the_classes_from_the_store(monkeypatch, tmp_path):
    """plan_strokes over a StoredStrokes: the lines' classes made once, from the records (no
    window loaded meanwhile, line_classes of strokes not called), the list's classes of the
    same strokes; the command writes the list path's file and summary."""
    calls = []
    stored_fn = sc.stored_line_classes

    def spy(store, rows):
        loads = StoredStrokes._load
        monkeypatch.setattr(StoredStrokes, "_load", lambda *a: calls.append("load") or loads(*a))
        got = stored_fn(store, rows)
        monkeypatch.setattr(StoredStrokes, "_load", loads)
        calls.append(got.tolist() == line_classes(store.take(rows)).tolist())
        return got
    monkeypatch.setattr(sc, "stored_line_classes", spy)
    monkeypatch.setattr(sc, "line_classes", lambda sts: calls.append("strokes") or line_classes(sts))

    def run(windowed):
        return run_command(monkeypatch, SAMPLES / NAMES[0], tmp_path / f"{windowed}.gcode", windowed, 37)
    want = run(False)
    assert calls == ["strokes"]                 # (the list path: line_classes of the strokes)
    calls.clear()
    got = run(True)
    assert calls == [True]
    assert got[0] == want[0]
    assert got[1] == want[1]


@pytest.mark.parametrize("pure", PURE)
def test_held_window_changes_are_read(pure):
    """A change to a held window's stroke (marked changed) is in the classes read from the
    store: the window written back first."""
    sts = _planned(NAMES[0])
    store = ss.StrokeStore(pure=pure)
    store.append(sts)
    with store:
        held = StoredStrokes(store, 64)
        rows = np.flatnonzero([st._ends is None for st in sts[:64]]).astype(np.int64)
        a, b = rows[:2].tolist()
        before = sc._line_classes(held, rows, 64)
        st = held[a]
        for nm in stm.FIELDS:                   # (a the twin of b: one class)
            if nm not in ("first_idx", "last_idx", "chain_T", "curv") and hasattr(sts[b], nm):
                setattr(st, nm, getattr(sts[b], nm))
        held.changed(a)
        got = sc._line_classes(held, rows, 64)
        want = line_classes([held[i] for i in rows.tolist()])
    assert got.tolist() == want.tolist()
    assert got[0] == got[1] and before[0] != before[1]


def test_a_built_core_without_store_fields_reads_in_python(monkeypatch):
    """A core built before store_fields: the Python reading (the same fields)."""
    if not COMPILED:
        pytest.skip("no compiled core")
    sts = _planned(NAMES[0])[:50]
    with ss.StrokeStore() as store:
        store.append(sts)
        want = list(store.fields(np.arange(50), FIELDS[:10]))

        class Old:
            pass
        monkeypatch.setattr(store._codec, "_core", Old())
        got = list(store.fields(np.arange(50), FIELDS[:10]))
    assert all(a.tobytes() == b.tobytes() and c.tobytes() == d.tobytes() for (a, c), (b, d) in zip(got, want))



@pytest.mark.parametrize("pure", PURE)
def test_limits_numbered_in_the_order_met(pure):
    """A limits object first met in a later record than another's (its record rewritten
    after: the store's table holds it last): the list's numbering, not the table's."""
    one = next(st for st in _planned(NAMES[0]) if st._ends is None and st.first_idx == st.last_idx)
    sts = []
    for k in range(6):
        st = stm.Stroke.__new__(stm.Stroke)
        for nm in stm.FIELDS:
            if hasattr(one, nm):
                setattr(st, nm, getattr(one, nm))
        st.lim = one.lim.replace(v_max=one.lim.v_max + k % 2)
        sts.append(st)
    every = np.arange(len(sts), dtype=np.int64)
    with ss.StrokeStore(pure=pure) as store:
        store.append(sts)
        sts[0].lim = one.lim.replace(v_max=one.lim.v_max + 5.0)
        store.rewrite(every[:1], sts[:1])
        got = stored_line_classes(store, every)
    assert got.tolist() == line_classes(sts).tolist()
    assert len(set(got.tolist())) == 3


def _partition(places):
    """Each row's first row of its place (the partition places make, whatever the numbers)."""
    first = {}
    return [first.setdefault(p, q) for q, p in enumerate(places)]


def test_distinct_rows_by_chunks():
    """segments._Distinct (fit65: rows gathered by take, a chunk met whole compared whole):
    the places of rows added a chunk at a time make the partition of equal rows (a dict of
    the rows' bytes), the kept rows are the rows placed there, and a place is kept across
    chunks -- a first chunk, one of rows all met before, one mixed, an empty one; rows
    differing only in signs (a stroke run the other way) apart."""
    rng = np.random.default_rng(65)
    base = rng.integers(-2 ** 62, 2 ** 62, (40, 7))
    base[20:] = base[:20] ^ np.int64(-2 ** 63)          # (the sign bits of every entry flipped)
    base[30:, :2] = base[10:20, :2] ^ np.int64(-2 ** 63)
    chunks = [base[rng.integers(0, 25, 300)], base[rng.integers(0, 25, 200)], base[:0],
              base[rng.integers(0, 40, 500)], base[rng.integers(0, 40, 64)]]
    d = segments._Distinct()
    got = []
    for R in chunks:
        at = d.add(np.ascontiguousarray(R))
        assert at is not None and at.shape == (len(R),)
        got.append(at)
    rows = np.concatenate(chunks)
    places = np.concatenate(got)
    assert np.array_equal(d.rows[:d.n][places], rows)
    assert d.n == len({r.tobytes() for r in rows})
    assert _partition(places.tolist()) == _partition([r.tobytes() for r in rows])
    assert np.array_equal(d.columns(), d.rows[:d.n].T)
