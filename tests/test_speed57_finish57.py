"""finish57: the windowed candidates keep the kept laws of a chain call's finishing groups
together (chains._Finisher._keep: bases of up to FINISH_ROWS rows of several segment counts,
their binding masks one run of bits, _RaggedMask), not a base a group: the masks read back
row by row as written, the tables, laws and knots the ones a base a group gives, and the
windowed command's output the list path's."""
import os
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt import schedule as sc

from windowed_run import run_command

from test_speed55_memo55_spill import _MEMOS, _windowed

SAMPLES = Path(__file__).resolve().parent.parent / "sample_gcode"


def _runs(rng, G):
    """G runs of random rows (0..5) and widths (0..11): (at, w, each row's bools)."""
    counts = rng.integers(0, 6, G)
    w = rng.integers(0, 12, G)
    rows = [rng.random(int(wi)) < 0.4 for wi, c in zip(w, counts) for _ in range(int(c))]
    at = np.zeros(G + 1, np.int64)
    np.cumsum(counts, out=at[1:])
    return at, w.astype(np.int64), rows


@pytest.mark.parametrize("spilled", [False, True])
def test_ragged_mask_rows(spilled, tmp_path):
    """_RaggedMask's rows (in memory, or its bits in a LawSpill) are the rows it was made of:
    rows_flat of any rows their bools one after the other and their widths, indexing rows
    of one width their (rows, width) bools, rows of two widths refused."""
    rng = np.random.default_rng(57)
    spill = chains.LawSpill(str(tmp_path)) if spilled else None
    for _ in range(40):
        at, w, rows = _runs(rng, int(rng.integers(1, 7)))
        if not rows:
            continue
        flat = np.concatenate(rows) if rows else np.zeros(0, bool)
        m = chains._RaggedMask(flat, at, w)
        if spill is not None:
            (m.bits,) = spill.put_block([m.bits])
        qq = rng.integers(0, len(rows), int(rng.integers(1, 3 * len(rows) + 1)))
        got, gw = m.rows_flat(qq)
        assert got.dtype == bool
        assert got.tobytes() == np.concatenate([rows[q] for q in qq]).astype(bool).tobytes()
        assert gw.tolist() == [rows[q].size for q in qq] == m.widths(qq).tolist()
        for q in rng.permutation(len(rows))[:3].tolist():
            same = [r for r in range(len(rows)) if rows[r].size == rows[q].size]
            pick = rng.permutation(same)[:4]
            assert m[pick].tobytes() == np.array([rows[r] for r in pick], bool).reshape(pick.size, -1).tobytes()
            other = [r for r in range(len(rows)) if rows[r].size != rows[q].size]
            if other:
                with pytest.raises(IndexError):
                    m[[q, other[0]]]


def _bases(kept):
    return list({id(k.base): k.base for k in kept if type(k) is chains._KeptLaws}.values())


def _one_base_a_group(monkeypatch):
    """The windowed candidates' kept laws a base a finishing group (spilled), as before finish57."""
    def keep(self, done):
        for d in done:
            self._keep_run([d])
    monkeypatch.setattr(chains._Finisher, "_keep", keep)


@pytest.mark.parametrize("solve_segs", [None, 400])
def test_merged_bases_are_the_groups_laws(monkeypatch, tmp_path, solve_segs):
    """The windowed candidates (spilled, 16 windows, chain calls of 60; solved in chunks of
    at most solve_segs segments: a base's rows of several chunks) keep their groups' laws in
    few bases (of several segment counts, at most FINISH_ROWS rows each); the tables, each
    chain's laws and knots read back (chains56's _laws_bits: _rows_laws, kept.row), and the
    laws of rows of many bases read in one _rows_laws call, in any order, are those of a
    base a group, bit for bit."""
    if solve_segs is not None:
        monkeypatch.setattr(chains, "SOLVE_SEGS", solve_segs)
    chunks = []
    pieces = chains.LawSpill.pieces
    monkeypatch.setattr(chains.LawSpill, "pieces", lambda self, PT, sp: chunks.append(id(PT)) or pieces(self, PT, sp))
    with monkeypatch.context() as mp:
        _one_base_a_group(mp)
        (tmp_path / "a").mkdir()
        want_tables, want_laws, _, want_kept = _windowed(mp, True, folder=tmp_path / "a")
    want_items = [(k, int(r)) for m in _MEMOS for _, _, _, r, k in m.rows()]
    (tmp_path / "b").mkdir()
    tables, laws, _, kept = _windowed(monkeypatch, True, folder=tmp_path / "b")
    items = [(k, int(r)) for m in _MEMOS for _, _, _, r, k in m.rows()]
    bases, old = _bases(kept), _bases(want_kept)
    merged = [b for b in bases if type(b[0]) is chains._RaggedMask]
    assert merged and len(bases) * 3 < len(old)
    if solve_segs is not None:      # (the pieces of bases of several chunks gathered a chunk at a time)
        assert len(chunks) > len(bases) + 5
    assert all(b[0].w.size > 1 and b[0].at[-1] <= chains.FINISH_ROWS for b in merged)
    assert sum(b[0].at[-1] if type(b[0]) is chains._RaggedMask else b[0].shape[0] for b in bases) \
        == sum(b[0].shape[0] for b in old)
    assert tables == want_tables
    assert sum(map(len, laws.values())) > 1000 and laws == want_laws
    order = np.random.default_rng(3).permutation(len(items))
    got = chains._rows_laws([items[i][0] for i in order], np.array([items[i][1] for i in order]))
    ref = chains._rows_laws([want_items[i][0] for i in order], np.array([want_items[i][1] for i in order]))
    assert len({id(items[i][0].base) for i in order}) > 3
    assert [np.asarray(x).tobytes() for x in got] == [np.asarray(x).tobytes() for x in ref]


def test_merged_bases_blocks_bounded(monkeypatch, tmp_path):
    """A merged base's spill block (what a replay reads whole) holds at most KEPT_BLOCK_BYTES:
    with a small bound, more bases of fewer groups, the same tables and laws."""
    (tmp_path / "a").mkdir()
    want_tables, want_laws, _, want_kept = _windowed(monkeypatch, True, folder=tmp_path / "a")
    monkeypatch.setattr(chains, "KEPT_BLOCK_BYTES", 3000)
    (tmp_path / "b").mkdir()
    tables, laws, _, kept = _windowed(monkeypatch, True, folder=tmp_path / "b")
    merged = [b for b in _bases(kept) if type(b[0]) is chains._RaggedMask]
    assert len(merged) > 2 and len(_bases(kept)) > len(_bases(want_kept))
    assert all(b[1].blk[1] <= 3000 and b[1].blk == b[0].bits.blk for b in merged)
    assert max(b[1].blk[1] for b in _bases(want_kept)) > 3 * 3000
    assert tables == want_tables and laws == want_laws


def test_windowed_command_same_bits(monkeypatch, tmp_path):
    """The windowed command (window 64, chain calls of 50 chains: their kept laws in merged
    bases) writes the list path's bytes and summary."""
    monkeypatch.setattr(sc, "CHAIN_BATCH", 50)
    made = []
    merged_base = chains._Finisher._merged_base

    def spy(self, run):
        made.append(len(run))
        return merged_base(self, run)
    monkeypatch.setattr(chains._Finisher, "_merged_base", spy)

    def run(windowed):
        return run_command(monkeypatch, os.path.join(SAMPLES, "prusa_gyroid.gcode"),
                           tmp_path / f"o.{windowed}.gcode", windowed, 64)
    want = run(False)
    assert made == []
    got = run(True)
    assert len(made) >= 2 and max(made) > 5
    assert got[0] == want[0]
    assert got[1] == want[1]


def test_kept_caps_read_no_block_rows_jerk1(monkeypatch):
    """chains._kept_caps makes the caps of the chains whose caps are their geometry block's
    rows without reading those chains' caps at the whole jerk (a row view of the block's
    caps_jerk1 each); the mixed chains' caps are still vertex_caps' own."""
    from gcode_opt import curves
    from test_speed55_geoms55 import _bits, mixed_chain_geoms
    prof, sts, want = mixed_chain_geoms(160, made=False)
    read = []
    prop = curves.CurveGeom.caps_jerk1
    monkeypatch.setattr(curves.CurveGeom, "caps_jerk1",
                        property(lambda g: read.append(g) or prop.fget(g), prop.fset))
    block_rows = {id(st.curv) for k, st in enumerate(sts) if k % 4 in (0, 1)}
    got = chains._kept_caps(sts, [st.curv for st in sts], prof)
    assert read and not block_rows & set(map(id, read))
    for g, w in zip(got, want):
        assert _bits(chains._caps_array(g), w)
