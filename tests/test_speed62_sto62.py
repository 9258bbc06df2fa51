"""sto62: the store's fields side (benchmarks/sto62.md).

StrokeStore keeps, beside the records, the fields SIDE's and the summary's columns read of
every record (FIELDS_SIDE) as store_encode reads them; fields() of names on it reads its
rows.  What it gives must be what the records give: every name, ints and not, after
appends and rewrites (longer, shorter, in place), dense and sparse rows, compiled and pure,
in a file and in memory; and the summary's columns read from it are the strokes' own."""
import numpy as np
import pytest

from gcode_opt import stroke_columns as sc, stroke_store as ss
from test_speed50_store50_roundtrip import PATHS
from test_speed61_rstore61 import _odd_and_planned


def _records_fields(store, rows, names, ints):
    """fields' (vals, kinds) of rows read from the records themselves (no side)."""
    codes = tuple(ss.FIELD_CODE[nm] for nm in names)
    vs, ks = [np.zeros((0, len(names)))], [np.zeros((0, len(names)), np.int8)]
    for buf, offs, lens in store._batches(rows):
        v, k = np.empty((len(offs), len(codes))), np.empty((len(offs), len(codes)), np.int8)
        store._codec.fields(buf, offs, lens, codes, v, k, ints)
        vs.append(v)
        ks.append(k)
    return np.concatenate(vs), np.concatenate(ks)


def _side_fields(store, rows, names, ints, size=ss.BATCH):
    got = list(store.fields(rows, names, size, ints))
    return (np.concatenate([v for v, _ in got] or [np.zeros((0, len(names)))]),
            np.concatenate([k for _, k in got] or [np.zeros((0, len(names)), np.int8)]))


def _same(a, b):
    assert (a[1] == b[1]).all()
    assert (a[0].view(np.int64) == b[0].view(np.int64)).all()     # (bit for bit: NaN, -0.0)


def _check(store, names_sets=None):
    n = len(store)
    rows_sets = [np.arange(n, dtype=np.int64), np.arange(1, n, 2, dtype=np.int64),      # (dense: the side)
                 np.arange(0, n, 5, dtype=np.int64), np.zeros(0, np.int64)]          # (sparse: the records)
    names_sets = names_sets or [ss.FIELDS_SIDE, ("layer",) + sc.FLOATS + sc._SHARED,
                                ("kind", "first_idx", "v0"), ("x0", "v0")]
    for rows in rows_sets:
        for names in names_sets:
            for ints in (False, True):
                for size in (ss.BATCH, 7):
                    _same(_side_fields(store, rows, names, ints, size), _records_fields(store, rows, names, ints))


@pytest.mark.parametrize("pure", PATHS)
@pytest.mark.parametrize("in_memory", [False, True])
def test_fields_side_is_the_records(pure, in_memory):
    """fields() of the side's names equals the records' reading, bit for bit, every kind
    met (the odd strokes: None, bools, ints in object slots, unset slots, shared objects),
    after appends in several calls and after rewrites that move records or not."""
    sts = _odd_and_planned()
    with ss.StrokeStore(in_memory=in_memory, pure=pure) as store:
        store.append(sts[:5])
        store.append(sts[5:])
        _check(store)
        kinds = _side_fields(store, np.arange(len(store), dtype=np.int64), ss.FIELDS_SIDE, True)[1]
        assert {0, 2, 5, 6} <= set(kinds.ravel().tolist())
        # rewrites: values changed in place, a record made longer (its bytes moved), rows apart
        rows = np.array([0, 2, 3, len(sts) - 1], np.int64)
        new = store.take(rows)
        for k, st in enumerate(new):
            st.v0 = float(k) + 0.25
            st.feature = "rewritten" if k % 2 else None
            st.layer = 40 + k
        new[1].v_feed = 7          # (an int in an object slot: kind 6 with ints, 3 without)
        store.rewrite(rows, new)
        _check(store)
        got = _side_fields(store, rows, ("v0", "layer"), True)
        assert got[0][:, 0].tolist() == [0.25, 1.25, 2.25, 3.25]
        assert got[0][:, 1].view(np.int64).tolist() == [40, 41, 42, 43]
        kinds = _side_fields(store, rows, ("feature", "v_feed"), False)[1]
        assert kinds[:, 0].tolist() == [1, 5, 1, 5] and kinds[1, 1] == 3


def test_dense_fields_read_no_record(monkeypatch):
    """fields() of names on the side over dense rows reads no record (the side's rows);
    a name not on it, or sparse rows, read the records."""
    sts = _odd_and_planned()
    with ss.StrokeStore() as store:
        store.append(sts)
        n = len(store)
        want = _records_fields(store, np.arange(n, dtype=np.int64), ss.FIELDS_SIDE, False)
        reads = []
        real = store._batches
        monkeypatch.setattr(store, "_batches", lambda *a: reads.append(1) or real(*a))
        _same(_side_fields(store, np.arange(n, dtype=np.int64), ss.FIELDS_SIDE, False), want)
        assert not reads
        list(store.fields(np.arange(n, dtype=np.int64), ("x0",)))
        assert reads
        reads.clear()
        list(store.fields(np.arange(0, n, 3, dtype=np.int64), ("v0",)))
        assert reads


@pytest.mark.parametrize("pure", PATHS)
def test_stored_summary_columns_are_the_strokes(pure):
    """StrokeColumns of strokes kept in a store (its fields side) equal those of the list."""
    sts = [st for st in _odd_and_planned() if type(getattr(st, "layer", None)) is int]
    want = sc.StrokeColumns(sts)
    with ss.StrokeStore(pure=pure) as store:
        store.append(sts)
        got = sc.StrokeColumns(store)
    assert got.n_moves.tolist() == want.n_moves.tolist()
    for name in sc.FLOATS:
        a, b = got.floats[name], want.floats[name]
        assert type(a) is type(b) and np.asarray(a, float).view(np.int64).tolist() == np.asarray(b, float).view(np.int64).tolist()
    for name in sc.CODED:
        assert got.code_of[name] == want.code_of[name]
        assert got.codes[name].tolist() == want.codes[name].tolist()


def test_summary_fields_are_a_run_of_the_side():
    """The summary's fields (stroke_columns._stored_columns' names, in its order) are a run of
    the side's columns (its reads are views, no column gathered), SIDE its first columns."""
    names = ("layer",) + sc.FLOATS + sc._SHARED
    at = ss.FIELDS_SIDE.index("layer")
    assert ss.FIELDS_SIDE[at:at + len(names)] == names
    assert ss.FIELDS_SIDE[:len(ss.SIDE)] == ss.SIDE
