"""store60: StrokeStore's side columns (first_idx, last_idx, layer, corner_cmd0 beside the
records: lines(), column()) and its joined reads (_TempFile.read_runs: runs of records after
small gaps in one preadv), compiled and pure, from the file and from memory.

Every expected value is read off the strokes themselves (getattr), not from the store."""
import errno
import os
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import stroke_store as ss
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.schedule import plan_inputs
from test_speed50_store50_roundtrip import PATHS, check_same
from windowed_run import run_command

ROOT = Path(__file__).resolve().parent.parent
ARCS = str(ROOT / "sample_gcode/prusa_gyroid_arcs.gcode")


def _strokes(path=ARCS):
    prof = load_profile("prusa-mk3s")
    sts, _ = analyse(path, prof, Options())
    plan_inputs(sts, prof, Options())
    return sts


def _ints(sts, name):
    """The int column of field name as the strokes hold it (a bool as 0 / 1)."""
    return np.array([int(getattr(s, name)) for s in sts], np.int64)


def _check_side(store, sts):
    first, last = store.lines()
    assert first.tolist() == _ints(sts, "first_idx").tolist()
    assert last.tolist() == _ints(sts, "last_idx").tolist()
    for name in ss.SIDE:
        assert store.column(name).tolist() == _ints(sts, name).tolist(), name


@pytest.mark.parametrize("pure", PATHS)
@pytest.mark.parametrize("in_memory", [False, True])
def test_side_is_the_strokes_fields(pure, in_memory, monkeypatch):
    """After appends in several batches and rewrites of scattered rows (fields of the side
    changed, records longer and shorter), the side's columns are the strokes' values."""
    monkeypatch.setattr(ss, "BATCH", 64)
    monkeypatch.setattr(ss, "SIDE_ROWS", 100)              # (several side reads)
    sts = _strokes()
    rng = np.random.default_rng(60)
    with ss.StrokeStore(in_memory=in_memory, pure=pure) as store:
        store.append(sts[:len(sts) // 3])
        store.append(sts[len(sts) // 3:])
        assert not store._side_off                        # (every layer an int, corner_cmd0 a bool: read off the side)
        _check_side(store, sts)
        for round_ in range(3):
            rows = np.sort(rng.choice(len(sts), 150, replace=False)).astype(np.int64)
            for q, r in enumerate(rows.tolist()):
                s = sts[r]
                s.first_idx, s.last_idx = s.first_idx + 7 * round_ + q, s.last_idx + 1000 + q
                s.layer = s.layer + 3 + round_
                s.corner_cmd0 = (q + round_) % 2 == 0
                if q % 4 == 0:                            # a longer record, then a shorter one
                    s.v0_fw = None if round_ == 2 else 1.0 + q
            store.rewrite(rows, [sts[r] for r in rows.tolist()])
            _check_side(store, sts)
        assert store.column("layer", with_none=True)[1].tolist() == [False] * len(sts)


@pytest.mark.parametrize("pure", PATHS)
def test_side_off_where_a_value_is_not_an_int(pure):
    """A layer or corner_cmd0 neither an int nor a bool (appended or rewritten): column()
    reads the records and says so as it did (TypeError), and the other columns still hold."""
    sts = _strokes()[:40]
    sts[5].layer = None
    with ss.StrokeStore(pure=pure) as store:
        store.append(sts)
        with pytest.raises(TypeError):
            store.column("layer")
        assert store.column("corner_cmd0").tolist() == _ints(sts, "corner_cmd0").tolist()
        sts[5].layer = 4                                   # (back to an int: the records read, the same values)
        store.rewrite(np.array([5]), [sts[5]])
        assert store.column("layer").tolist() == _ints(sts, "layer").tolist()
        sts[9].corner_cmd0 = 2.5                           # (a float in an int column)
        store.rewrite(np.array([9]), [sts[9]])
        with pytest.raises(TypeError):
            store.column("corner_cmd0")
        assert store.lines()[0].tolist() == _ints(sts, "first_idx").tolist()


@pytest.mark.parametrize("pure", PATHS)
@pytest.mark.parametrize("gap, runs", [(0, 500), (300, 2), (1 << 20, 3), (16384, 500)])
def test_joined_reads_any_cut(pure, gap, runs, monkeypatch):
    """take of any rows (sparse, dense, unsorted) gives the strokes whatever the gap joined
    and the runs a read; a short read of a joined read is read again run by run."""
    monkeypatch.setattr(ss, "GAP", gap)
    monkeypatch.setattr(ss, "IOV_RUNS", runs)
    sts = _strokes()
    rng = np.random.default_rng(61)
    with ss.StrokeStore(pure=pure) as store:
        store.append(sts)
        for k in (1, 2, 9, 60, 300, len(sts)):
            rows = np.sort(rng.choice(len(sts), k, replace=False)).astype(np.int64)
            check_same([sts[r] for r in rows], store.take(rows))
        rows = rng.permutation(len(sts))[:80]
        check_same([sts[r] for r in rows], store.take(rows))
        real = os.preadv

        def short(fd, iov, pos):                        # (a joined read stops after its first run)
            return real(fd, iov[:1], pos)
        monkeypatch.setattr(ss.os, "preadv", short)
        rows = np.sort(rng.choice(len(sts), 200, replace=False)).astype(np.int64)
        check_same([sts[r] for r in rows], store.take(rows))


def test_fewer_reads_than_runs(monkeypatch):
    """Runs after small gaps come in one read (the point of read_runs): with no gap joined
    a read a run (GAP 0), with any gap joined IOV_RUNS runs a read, the gaps between them
    read into the scratch buffer."""
    monkeypatch.setattr(ss, "IOV_RUNS", 4)
    sts = _strokes()[:120]
    reads = []
    real = os.preadv

    def counted(fd, iov, pos):
        reads.append(len(iov))
        return real(fd, iov, pos)
    with ss.StrokeStore() as store:
        store.append(sts)
        monkeypatch.setattr(ss.os, "preadv", counted)
        rows = np.arange(0, 120, 8, dtype=np.int64)
        for gap in (0, 1 << 20):
            monkeypatch.setattr(ss, "GAP", gap)
            reads.clear()
            check_same([sts[r] for r in rows], store.take(rows))
            if gap == 0:
                runs = len(reads)
                assert runs > 4 and set(reads) == {1}
        assert len(reads) == -(-runs // 4) and sum(reads) == 2 * runs - len(reads)


@pytest.mark.parametrize("pure", PATHS)
def test_failed_side_write_leaves_the_store(pure, monkeypatch):
    """A side write that fails (disk full) raises, and the store is as before the append:
    a later append's records and side read back right."""
    sts = _strokes()[:50]
    real = ss._TempFile.write
    with ss.StrokeStore(pure=pure) as store:
        store.append(sts[:20])

        def full(self, pos, data):
            if self is store._side_io:
                raise OSError(errno.ENOSPC, "No space left on device")
            return real(self, pos, data)
        monkeypatch.setattr(ss._TempFile, "write", full)
        with pytest.raises(OSError):
            store.append(sts[20:])
        assert len(store) == 20
        monkeypatch.setattr(ss._TempFile, "write", real)
        store.append(sts[20:])
        check_same(sts, store.load(0, len(store)))
        _check_side(store, sts)


def test_failed_write_in_the_command(tmp_path, monkeypatch):
    """The command with a spill write failing (records or side): it raises OSError and
    leaves no output, as it did."""
    real = ss._TempFile.write
    for fail_at in (1, 2, 3):
        n = [0]

        def failing(self, pos, data):
            n[0] += 1
            if n[0] == fail_at:
                raise OSError(errno.ENOSPC, "No space left on device")
            return real(self, pos, data)
        monkeypatch.setattr(ss._TempFile, "write", failing)
        out = tmp_path / f"out{fail_at}.gcode"
        with pytest.raises(OSError):
            run_command(monkeypatch, ROOT / "sample_gcode/prusa_gyroid.gcode", out, True, 37)
        assert not out.exists()


@pytest.mark.parametrize("name", ["prusa_gyroid_arcs.gcode", "prusa_gyroid.gcode"])
def test_windowed_bytes_are_the_lists(name, tmp_path, monkeypatch):
    """Windowed with small windows, several side reads and joined reads of few runs: the
    list path's bytes and summary."""
    monkeypatch.setattr(ss, "SIDE_ROWS", 50)
    monkeypatch.setattr(ss, "IOV_RUNS", 3)
    src = ROOT / "sample_gcode" / name
    want = run_command(monkeypatch, src, tmp_path / "list.gcode", False, None)
    got = run_command(monkeypatch, src, tmp_path / "win.gcode", True, 37)
    assert got[0] == want[0]
    assert got[1] == want[1]


@pytest.mark.skipif(not ss._codec(False).__class__.__name__ == "_CCodec", reason="no compiled core")
def test_compiled_fields_refuse_corrupt_records():
    """store_fields' slot walk (a table of the payloads' fixed lengths): a record cut short
    inside its payloads, or with an unknown tag, is refused (ValueError), not read past."""
    sts = [s for s in _strokes() if getattr(s, "pts", None) is not None][:3]
    codes = tuple(ss.FIELD_CODE[nm] for nm in ("corner_cmd1", "layer"))
    with ss.StrokeStore(in_memory=True) as store:
        store.append(sts)
        data, offs, lens = bytearray(store._io.data), store._off[:3].copy(), store._len[:3].copy()
    vals, kinds = np.empty((3, 2)), np.empty((3, 2), np.int8)
    codec = ss._codec(False)
    codec.fields(data, offs, lens, codes, vals, kinds)
    assert kinds[:, 0].tolist() == [2, 2, 2]               # (corner_cmd1: a bool each)
    cut = lens.copy()
    cut[1] -= 9                                            # (inside the last payloads)
    with pytest.raises(ValueError, match="past its end"):
        codec.fields(data, offs, cut, codes, vals, kinds)
    bad = bytearray(data)
    bad[int(offs[2]) + ss._TAGS_AT + 3] = 99               # (slot accel: no such tag)
    with pytest.raises(ValueError, match="unknown tag 99"):
        codec.fields(bad, offs, lens, codes, vals, kinds)
