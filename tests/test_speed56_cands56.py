"""cands56: the windowed candidates' per-batch bookkeeping paid less often, the same bits.
The chains' spill (chains.LawSpill) gathers the blocks put and writes them WRITE_BYTES at a
time (or before a block not written yet is read): every array reads back as it was put,
whatever was written when."""
import numpy as np

from gcode_opt import chains


def _counted(spill):
    """spill with its file's writes counted: [(pos, bytes)]."""
    writes = []
    write = spill._io.write
    spill._io.write = lambda pos, data: (writes.append((pos, len(memoryview(data)))), write(pos, data))
    return writes


def test_blocks_written_together(tmp_path):
    spill = chains.LawSpill(str(tmp_path))
    spill.WRITE_BYTES = 1000
    writes = _counted(spill)
    rng = np.random.default_rng(56)
    arrays = [rng.standard_normal(rng.integers(1, 30)) for _ in range(40)]
    for a in arrays:
        spill.put_block([a, (a * 4).astype(np.int32)])
    total = sum(a.nbytes * 3 // 2 for a in arrays)
    # (a write once 1000 bytes wait: far fewer than the 80 arrays put)
    assert 1 <= len(writes) <= total // 1000 + 1 and len(writes) < 20
    assert all(n >= 1000 for _, n in writes)
    # (each write at the file's end: the bytes put before it, in order)
    assert [p for p, _ in writes] == np.cumsum([0] + [n for _, n in writes])[:-1].tolist()


def test_read_back_written_or_not(tmp_path):
    """Blocks read back before and after their write, one still waiting at the end of the
    puts, one read while later ones wait: each array's own values, dtype and shape."""
    spill = chains.LawSpill(str(tmp_path))
    spill.WRITE_BYTES = 700
    writes = _counted(spill)
    rng = np.random.default_rng(7)
    put = []
    for i in range(25):
        a = rng.standard_normal((rng.integers(1, 9), 2))
        b = rng.integers(0, 255, rng.integers(0, 12)).astype(np.uint8)
        sa, sb = spill.put_block([a, b])
        put.append(((a, sa), (b, sb)))
        if i % 6 == 5:             # (read while blocks wait: the last one, then an early one)
            for arr, s in put[-1] + put[0]:
                assert s[np.arange(len(arr))].tobytes() == arr.tobytes()
    assert spill._pend_n and len(writes) >= 2      # (the last blocks not written yet)
    for pair in reversed(put):
        for arr, s in pair:
            got = s.whole()
            assert got.dtype == arr.dtype and got.shape == arr.shape and got.tobytes() == arr.tobytes()
    assert not spill._pend_n



def test_windowed_laws_through_small_writes(monkeypatch, tmp_path):
    """The windowed candidates of a real sample with the spill written a few hundred bytes
    at a time (many writes, reads between them): the tables and every chain's kept laws
    read back are the in-memory ones, bit for bit."""
    import test_speed55_memo55_spill as m55
    tables, laws, _, _ = m55._reference(monkeypatch)
    monkeypatch.setattr(chains.LawSpill, "WRITE_BYTES", 300)
    writes = []
    write = chains.LawSpill._write
    monkeypatch.setattr(chains.LawSpill, "_write", lambda self: (writes.append(self._pend_n), write(self)))
    got_tables, got_laws, _, _ = m55._windowed(monkeypatch, True, folder=tmp_path)
    assert len([n for n in writes if n]) > 20
    assert got_tables == tables
    assert sum(map(len, laws.values())) > 1000 and got_laws == laws
