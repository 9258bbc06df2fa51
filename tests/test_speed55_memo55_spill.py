"""The windowed candidates keep the chains' kept laws in a temporary file
(schedule.SPILL_CHAIN_LAWS: chains.LawSpill, _SpilledRows), not in memory: every chain's
laws read back are the in-memory ones bit for bit (binding masks, pieces' durations, T,
beta, predicted time and ∫|a|², and the knots made again from them), the tables the same,
the chains' memory after the candidates far less; _SpilledRows indexes as numpy does."""
import os
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt import features as feat
from gcode_opt import schedule as sc
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.plan_windows import plan_inputs_windowed
from gcode_opt.stored_strokes import StoredStrokes, curve_geometry
from gcode_opt.stroke_store import StrokeStore
from gcode_opt.strokes import K_CHAIN

SAMPLES = Path(__file__).resolve().parent.parent / "sample_gcode"
NAME = "prusa_gyroid_fullspeed.gcode"


def _strokes(name=NAME, folder=None):
    """(profile, options, strokes, pin) of the sample: a list of strokes (folder None), or a
    StoredStrokes of 37-stroke windows over a StrokeStore in a file in folder, as the
    windowed command's (planned_strokes)."""
    prof = load_profile("prusa-mk3s")
    path = str(SAMPLES / name)
    opts = Options(features=feat.default_selection(path)[0])
    if folder is None:
        strokes, _ = analyse(path, prof, opts)
        return prof, opts, strokes, sc.plan_inputs(strokes, prof, opts)
    store = StrokeStore(folder=str(folder))
    _, _ = analyse(path, prof, opts, store)
    pin = plan_inputs_windowed(store, prof, opts, 37)
    return prof, opts, StoredStrokes(store, 37, on_load=curve_geometry(pin.plan_kind_codes, prof),
                                     keep=("chain_T",)), pin


def _windowed(monkeypatch, spill, trace=False, batch=60, folder=None):
    """(tables' entries, {row: its memo's rows and laws as bits}, bytes traced in chains.py
    right after the candidates, the memos' kept laws) of the windowed candidates of NAME
    (16 windows, chain batches of `batch`; over a StoredStrokes whose store is in folder, or
    a list), the kept laws spilled or not."""
    monkeypatch.setattr(sc, "SPILL_CHAIN_LAWS", spill)
    prof, opts, strokes, pin = _strokes(folder=folder)
    rows = sc._rows_by_kind(strokes, sc._plan_kind_codes_of(strokes, pin))
    bounds = np.linspace(0, len(strokes), 17).astype(int)
    if trace:
        tracemalloc.start()
    try:
        cands, _ = sc.candidates_in_windows(strokes, pin, prof, opts, rows, sc._faults_of(pin.fault), bounds,
                                            chain_batch=batch)
        held = 0
        if trace:
            held = sum(s.size for s in tracemalloc.take_snapshot().statistics("filename")
                       if Path(s.traceback[0].filename).name == "chains.py")
    finally:
        tracemalloc.stop()
    chain_rows = rows[K_CHAIN].tolist()
    _MEMOS[:] = [strokes[i].chain_T for i in chain_rows]
    kept = [k for m in _MEMOS for *_, k in m.rows()]
    entries = [np.ascontiguousarray(a).tobytes() for a in (cands.cnt, cands.t_pos, cands.col, cands.vals)]
    return entries, {i: _laws_bits(strokes[i], prof) for i in chain_rows}, held, kept


def _laws_bits(st, prof):
    out = []
    items = [(kept, int(r)) for _, _, _, r, kept in st.chain_T.rows()]
    if not items:
        return out
    nv, voff, bound, tj, TL, beta, tp, a2, poff = chains._rows_laws([k for k, _ in items], np.array([r for _, r in items]))
    for q, (kept, r) in enumerate(items):
        vk, dt, t, i2 = kept.row(r, st)
        out.append((bound[voff[q]:voff[q + 1]].tobytes(), tj[poff[q]:poff[q + 1]].tobytes(),
                    TL[q].hex(), beta[q].hex(), tp[q].hex(), a2[q].hex(),
                    np.asarray(vk, float).tobytes(), np.asarray(dt, float).tobytes(), float(t).hex(), float(i2).hex()))
    return out


_REF = {}
_MEMOS = []         # the last _windowed's chains' memos


def _reference(monkeypatch):
    if not _REF:
        _REF["got"] = _windowed(monkeypatch, False, trace=True)
    return _REF["got"]


def test_spilled_laws_are_the_kept_ones(monkeypatch, tmp_path):
    tables, laws, _, _ = _reference(monkeypatch)
    got_tables, got_laws, _, kept = _windowed(monkeypatch, True, folder=tmp_path)
    assert got_tables == tables
    assert sum(map(len, laws.values())) > 1000
    assert got_laws == laws
    # (read back from the file: no array of them held)
    base = next(k.base for k in kept if type(k) is chains._KeptLaws)
    assert all(type(x) is chains._SpilledRows for x in (base[0].bits, base[1], base[2], base[6]))


def test_spilled_laws_not_held(monkeypatch, tmp_path):
    _, _, held_mem, _ = _reference(monkeypatch)
    _, _, held, _ = _windowed(monkeypatch, True, trace=True, folder=tmp_path)
    # the kept laws were ~2/3 of what chains.py held after the candidates (pieces' durations
    # most of it); with them spilled, the memos' rows and the spill's small objects
    assert held < 0.55 * held_mem, (held, held_mem)


def test_shared_small_objects(monkeypatch, tmp_path):
    """The memos' source rows are the shared row ints, and the spilled arrays of one kind
    share their (row shape, dtype): no int or tuple of their own a chain or an array."""
    _, _, _, kept = _windowed(monkeypatch, True, batch=400, folder=tmp_path)    # (one call: rows past the small ints)
    memos = list(_MEMOS)
    assert len(memos) > 300 and max(m.src_i for m in memos) > 256
    assert all(m.src_i is chains._ROW_INTS[m.src_i] for m in memos)
    bases = {id(k.base): k.base for k in kept if type(k) is chains._KeptLaws}.values()
    assert len(bases) >= 2          # (finish57: a call's groups kept in bases of up to FINISH_ROWS rows)
    for i in (1, 2, 6):
        assert len({id(b[i].kind) for b in bases}) == 1


def test_spilled_rows_index_as_numpy(tmp_path):
    spill = chains.LawSpill(str(tmp_path))
    rng = np.random.default_rng(5)
    a = rng.standard_normal(50)
    b = rng.integers(-9, 9, (40, 3)).astype(np.int32)
    c = rng.integers(0, 255, (7, 2)).astype(np.uint8)
    sa, sb, sc_ = spill.put(a), spill.put(b), spill.put(c)
    assert spill.put(np.zeros(0)).shape == (0,)
    for arr, s in ((a, sa), (b, sb), (c, sc_)):
        n = arr.shape[0]
        assert s.shape == arr.shape and s.dtype == arr.dtype and len(s) == n and s.size == arr.size
        for ix in ([3, 1, 1, n - 1], np.array([[0, 2], [n - 2, 4]]), 2, -1, [-n, 0], np.arange(n) % 3 == 0,
                   np.zeros(0, np.int64), np.array(n - 1)):
            want = arr[ix]
            got = s[ix]
            assert got.shape == want.shape and got.dtype == want.dtype and got.tobytes() == want.tobytes(), ix
        assert s[1:4].tobytes() == arr[1:4].tobytes()
        with pytest.raises(IndexError):
            s[[0, n]]


def test_pieces_in_row_order(tmp_path):
    spill = chains.LawSpill(str(tmp_path))
    PT = np.arange(30, dtype=float) / 7
    spans = np.array([[10, 3], [0, 2], [10, 3], [25, 5], [4, 0]], np.int32)
    tj, sp = spill.pieces(PT, spans)
    assert sp.dtype == np.int32 and sp[np.arange(5)][:, 1].tolist() == [3, 2, 3, 5, 0]
    whole = tj[np.arange(tj.shape[0])]
    for (a, c), (a2, c2) in zip(spans.tolist(), sp[np.arange(5)].tolist()):
        assert c2 == c and whole[a2:a2 + c2].tobytes() == PT[a:a + c].tobytes()
    assert tj.shape == (13,)


def _chain_pieces(monkeypatch, spill, folder):
    monkeypatch.setattr(sc, "SPILL_CHAIN_LAWS", spill)
    prof, opts, strokes, pin = _strokes(folder=folder)
    rows = sc._rows_by_kind(strokes, sc._plan_kind_codes_of(strokes, pin))[K_CHAIN]
    waiting = sc._WaitingChains(strokes, pin, prof, sc._faults_of(pin.fault), sc.SegmentRules.for_profile(prof, 10))
    got = waiting.add(rows[:150], False) + waiting.add(rows[150:], True)
    return got, waiting.spill


def test_spilled_pieces_read_back(monkeypatch, tmp_path):
    """A chain batch's pieces wait with their mask and values in the spill; unpacked and
    indexed, they are the pieces kept in memory, array for array."""
    ref, _ = _chain_pieces(monkeypatch, False, tmp_path)
    got, _ = _chain_pieces(monkeypatch, True, tmp_path)
    assert len(got) == len(ref) >= 1
    for g, r in zip(got, ref):
        assert type(g) is sc._SpilledPiece and type(g.vals) is chains._SpilledRows
        assert type(g.mask) is chains._SpilledRows and len(g) == len(r) == 5
        parts = list(g)
        for i in range(5):
            for x in (parts[i], g[i]):
                assert type(x) is np.ndarray and x.dtype == r[i].dtype and x.shape == r[i].shape
                assert x.tobytes() == r[i].tobytes()


def _fd_path(spill):
    return os.readlink(f"/proc/self/fd/{spill._io._fd}")


@pytest.mark.skipif(not os.path.isdir("/proc/self/fd"), reason="needs /proc")
def test_spill_beside_the_store(monkeypatch, tmp_path):
    """The spill is a file where the strokes' store has its own (the output's folder, not a
    /tmp that may be RAM); none for a list of strokes, a store in memory, or the switch off."""
    _, spill = _chain_pieces(monkeypatch, True, tmp_path)
    assert type(spill) is chains.LawSpill and _fd_path(spill).startswith(str(tmp_path) + "/")
    assert os.listdir(tmp_path) == []                # (unnamed)
    assert _chain_pieces(monkeypatch, False, tmp_path)[1] is False
    monkeypatch.setattr(sc, "SPILL_CHAIN_LAWS", True)
    assert sc._law_spill(_strokes()[2]) is False
    assert sc._law_spill(StoredStrokes(StrokeStore(in_memory=True), 37)) is False


def test_block_read_once_and_cache_bounded(tmp_path):
    """The arrays of one block are read back with one read; the cache keeps the last blocks
    read up to CACHE_BYTES (a larger block, or a whole() read, not kept); what a read gives
    is the caller's own (no view of the cache)."""
    spill = chains.LawSpill(str(tmp_path))
    spill.CACHE_BYTES = 1000
    reads = []
    read_into = spill._io.read_into
    spill._io.read_into = lambda mv, pos: (reads.append(len(mv)), read_into(mv, pos))
    a, b = np.arange(20, dtype=float), np.arange(12, dtype=np.int32).reshape(6, 2)
    sa, sb = spill.put_block([a, b])
    assert sa[[3, 1]].tolist() == [3.0, 1.0] and sb[[5]].tolist() == [[10, 11]] and len(reads) == 1
    got = sa[2:5]
    got[:] = -1
    assert sa[2:5].tolist() == [2.0, 3.0, 4.0] and len(reads) == 1          # (the caller's copy)
    blocks = [spill.put(np.full(40, float(i))) for i in range(6)]          # 320 B each
    for i, s in enumerate(blocks):
        assert s[[0]].tolist() == [float(i)]
        assert spill._cached == sum(x.size for x in spill._cache.values()) <= 1000
    assert len(spill._cache) == 3
    n = len(reads)
    big = spill.put(np.zeros(200))                  # 1600 B: over the cap
    big[[0]], big[[1]]
    assert len(reads) == n + 2 and spill._cached <= 1000
    assert blocks[0].whole().tolist() == [0.0] * 40 and blocks[0].blk not in spill._cache
