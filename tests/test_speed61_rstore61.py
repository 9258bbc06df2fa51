"""rstore61: the windowed path's per-stroke store costs (benchmarks/rstore61.md).

- store_encode's fields (the side's values taken as each record is written): every field
  of every record equal to what store_fields (ints) reads of the written bytes, and to the
  Python twin's reading (_py_fields: code this round did not change); a core built before
  them (no STORE_ENCODE_FIELDS) reads them after, the same side.
- HeldRows' freeze: the strokes a hold makes are out of the collector's view (not in
  gc.get_objects()) and the collector is left as it was; the windowed command holds its
  rewrite's strokes frozen, and writes the list path's bytes and summary."""
import gc
import types

import numpy as np
import pytest

from gcode_opt import stored_strokes as sst, stroke_store as ss
from test_speed50_store50_roundtrip import PATHS, _odd_strokes
from test_speed60_store60_side import ARCS, _check_side, _strokes
from windowed_run import run_command

ALL_CODES = tuple(range(len(ss.FIELD_CODE)))


def _odd_and_planned():
    """The odd strokes (every kind of value a field may hold) and a planned sample's."""
    _, odd = _odd_strokes()
    return odd + _strokes()


def _encoded_fields(codec, sts):
    """(buf, lens, vals, kinds) of codec's encode of sts asked for every field."""
    buf, lens = bytearray(), np.empty(len(sts), np.int64)
    vals, kinds = np.empty((len(sts), len(ALL_CODES))), np.empty((len(sts), len(ALL_CODES)), np.int8)
    nb = codec.encode(sts, 0, len(sts), {}, [], buf, lens, (ALL_CODES, vals, kinds))
    assert nb == int(lens.sum())
    return buf, lens, vals, kinds


def _read_fields(fields, buf, lens):
    vals, kinds = np.empty((len(lens), len(ALL_CODES))), np.empty((len(lens), len(ALL_CODES)), np.int8)
    fields(buf, np.cumsum(lens) - lens, lens, ALL_CODES, vals, kinds, True)
    return vals, kinds


@pytest.mark.parametrize("pure", PATHS)
def test_encode_fields_are_the_records(pure):
    """encode's fields of every field code equal store_fields' (ints) and _py_fields' reading
    of the bytes it wrote, bit for bit (vals compared as int64 bits: NaN, -0.0)."""
    sts = _odd_and_planned()
    codec = ss._codec(pure)
    buf, lens, vals, kinds = _encoded_fields(codec, sts)
    for read in (codec.fields, ss._py_fields):
        v, k = _read_fields(read, buf, lens)
        assert (k == kinds).all()
        assert (v.view(np.int64) == vals.view(np.int64)).all()
    assert {0, 1, 2, 3, 4, 5, 6} <= set(kinds.ravel().tolist())          # (every kind met)


def test_compiled_store_fields_are_the_twins():
    """The compiled store_fields (its row reading shared with store_encode now) reads every
    field of the odd strokes' records as _py_fields does, ints and not."""
    if PATHS == [True]:
        pytest.skip("no compiled core")
    sts = _odd_and_planned()
    buf, lens, _, _ = _encoded_fields(ss._codec(True), sts)
    core = ss._codec(False)._core
    offs = np.cumsum(lens) - lens
    for ints in (False, True):
        got = [np.empty((len(sts), len(ALL_CODES))), np.empty((len(sts), len(ALL_CODES)), np.int8)]
        want = [np.empty((len(sts), len(ALL_CODES))), np.empty((len(sts), len(ALL_CODES)), np.int8)]
        core.store_fields(buf, offs, lens, ALL_CODES, *got, ints)
        ss._py_fields(buf, offs, lens, ALL_CODES, *want, ints)
        assert (got[1] == want[1]).all() and (got[0].view(np.int64) == want[0].view(np.int64)).all()


def test_core_without_encode_fields(monkeypatch):
    """A compiled core built before store_encode's fields: the side read after the encode,
    the same side and records as with them."""
    if PATHS == [True]:
        pytest.skip("no compiled core")
    sts = _strokes(ARCS)
    real = ss._codec(False)._core
    old = types.SimpleNamespace(store_encode=real.store_encode, store_fields=real.store_fields,
                                store_decode=real.store_decode, STORE_FIELDS_INTS=1)
    calls = []

    def encode_no_fields(*a):
        calls.append(len(a))
        return real.store_encode(*a[:8])          # (the old signature: no fields)
    old.store_encode = encode_no_fields
    with ss.StrokeStore(in_memory=True) as a, ss.StrokeStore(in_memory=True) as b:
        b._codec._core = old
        for store in (a, b):
            store.append(sts[:40])
            store.append(sts[40:])
            store.rewrite(np.arange(10, 30, dtype=np.int64), sts[10:30])
            _check_side(store, sts)
        assert a._io.data == b._io.data and a._side_io.data == b._side_io.data
    assert calls and set(calls) == {8}


def _tracked_ids():
    return set(map(id, gc.get_objects()))


@pytest.mark.parametrize("freeze", [False, True])
def test_held_strokes_frozen(freeze):
    """hold's strokes are out of the collector's view with a freeze (gc.freeze), in it
    without; the collector on (or off) after hold as before."""
    sts = _strokes(ARCS)
    with ss.StrokeStore(in_memory=True) as store:
        store.append(sts)
        held = sst.HeldRows(store, 50, freeze=gc.freeze if freeze else None)
        was = gc.isenabled()
        try:
            for on in (True, False):
                (gc.enable if on else gc.disable)()
                rows = np.arange(20, 90, 3)
                held.hold(rows)
                assert gc.isenabled() is on
                made = [held.slots[r] for r in rows.tolist()]
                assert all(st is not None for st in made)
                tracked = _tracked_ids()
                assert all((id(st) in tracked) is (not freeze) for st in made)
        finally:
            (gc.enable if was else gc.disable)()
            gc.unfreeze()


@pytest.mark.parametrize("sample", ["prusa_gyroid.gcode", "prusa_gyroid_arcs.gcode"])
def test_windowed_rewrite_holds_frozen(monkeypatch, tmp_path, sample):
    """The windowed command's rewrite holds its strokes frozen (none of them in the
    collector's view after a hold) and writes the list path's bytes and summary."""
    src = ARCS.replace("prusa_gyroid_arcs.gcode", sample)
    seen = []
    real_hold = sst.HeldRows.hold

    def hold(self, rows):
        real_hold(self, rows)
        tracked = _tracked_ids()
        made = [self.slots[r] for r in self._held.tolist()]
        seen.append((self.freeze is not None, len(made), sum(id(st) in tracked for st in made)))
    ref = run_command(monkeypatch, src, tmp_path / "list.gcode", False, 0)
    monkeypatch.setattr(sst.HeldRows, "hold", hold)
    got = run_command(monkeypatch, src, tmp_path / "win.gcode", True, 37)
    assert got == ref
    assert seen and sum(n for _, n, _ in seen) > 0
    assert all(has and tracked == 0 for has, _, tracked in seen)


def test_encode_refuses_bad_field_buffers():
    """store_encode's fields buffers of the wrong type, size or codes: ValueError, and
    neither buffer kept (their reference counts as before)."""
    if PATHS == [True]:
        pytest.skip("no compiled core")
    import sys
    sts = _strokes(ARCS)[:5]
    codec = ss._codec(False)
    for vals, kinds, codes in ((np.empty((5, 2)), np.empty((5, 2), np.int16), (0, 1)),     # (kinds not int8)
                               (np.empty((5, 2), np.float32), np.empty((5, 2), np.int8), (0, 1)),
                               (np.empty((4, 2)), np.empty((4, 2), np.int8), (0, 1)),      # (a row short)
                               (np.empty((5, 2)), np.empty((5, 2), np.int8), (0, 999))):   # (no such field)
        counts = sys.getrefcount(vals), sys.getrefcount(kinds)
        with pytest.raises(ValueError):
            codec.encode(sts, 0, 5, {}, [], bytearray(), np.empty(5, np.int64), (codes, vals, kinds))
        assert (sys.getrefcount(vals), sys.getrefcount(kinds)) == counts
