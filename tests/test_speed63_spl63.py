"""Round 63 (spl): the analyse spill's geometry steps a chunk or a put at a time.

* build_geoms' flat chunks make adjust_plan_inputs' direction weights of every block
  (curves._flat_ux2, the chain core's row sums): the same doubles as _blk_ux2 makes from
  the block's rows when read; and with end_cols the blocks' end turns as columns
  (_Blk._end2): the cosines of cos_end, NaN where None.
* curves._by_block groups the geometries by block from objfields' compiled reads: the same
  blocks, positions and rows as its Python loop.
* geom_keep.put checks the chains' caps a put at a time (_chain_fits): a block whose
  chains' caps are not n - 1 doubles is not kept, as before; the records are those of the
  Python pass a block (geom_keep's give hands back the same geometry).
* The command's bytes and summary, windowed (small windows), are the list path's and
  those of the paths these replace.
"""
import copy
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt import geom_keep as gk
from gcode_opt.geom_keep import GeomKeep
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.schedule import C_CHAIN, C_CURVE, plan_inputs
from gcode_opt.strokes import K_CURVE

from windowed_run import run_command

S = Path(__file__).resolve().parent.parent / "sample_gcode"
_CACHE = {}


def _strokes(name="prusa_gyroid.gcode", profile="prusa-mk3s"):
    """Fresh copies (no geometry, no chain mark) of the sample's strokes."""
    key = (profile, name)
    if key not in _CACHE:
        prof = load_profile(profile)
        _CACHE[key] = prof, analyse(str(S / name), prof, Options())[0]
    prof, sts = _CACHE[key]
    out = []
    for st in sts:
        st = copy.copy(st)
        st.curv = st.chain_T = None
        out.append(st)
    return prof, out


def _blocks(sts):
    """The distinct geometry blocks of the curve strokes sts, in the order first met."""
    seen = {}
    for st in sts:
        if st.kind == K_CURVE and st.curv is not None and type(getattr(st.curv, "_b", None)) is curves._Blk:
            seen.setdefault(id(st.curv._b), st.curv._b)
    return list(seen.values())


@pytest.mark.parametrize("name", ["prusa_gyroid.gcode", "prusa_gyroid_fullspeed.gcode"])
def test_flat_ux2_is_blk_ux2(name):
    """Every block build_geoms made holds the weights _blk_ux2 makes again from its rows."""
    if curves._ROW_SUMS is None:
        pytest.skip("chain core not built")
    prof, sts = _strokes(name)
    curves.build_geoms([st for st in sts if st.kind == K_CURVE], prof, jerk1=True, end_cols=True, weights=True)
    blocks = _blocks(sts)
    assert blocks
    for b in blocks:
        got = b._ux2
        assert got is not None
        b._ux2 = None
        assert curves._blk_ux2(b).tobytes() == got.tobytes()


def test_end_cols_are_cos_end():
    """end_cols: each block's _end2 is its cos_end as doubles (NaN where None); without it
    (and without weights) neither is made."""
    prof, sts = _strokes()
    cur = [st for st in sts if st.kind == K_CURVE]
    curves.build_geoms(cur, prof)
    assert all(b._end2 is None and b._ux2 is None for b in _blocks(cur))
    prof, sts = _strokes()
    cur = [st for st in sts if st.kind == K_CURVE]
    curves.build_geoms(cur, prof, end_cols=True)
    turns = 0
    for b in _blocks(cur):
        want = np.array([[np.nan if x is None else x for x in e] for e in
                         [(None, None) if e is curves._NO_ENDS else e for e in b.cos_end]], float).T
        assert want.tobytes() == b._end2.tobytes()
        turns += int(np.isfinite(want).sum())
    assert turns > 0


def test_by_block_is_the_loop(monkeypatch):
    """_by_block's groups from the compiled reads are its loop's (positions and rows as
    arrays there, lists here); a geometry of no block: None on both."""
    prof, sts = _strokes()
    cur = [st for st in sts if st.kind == K_CURVE]
    curves.build_geoms(cur, prof)
    gs = [st.curv for st in cur][::-1]            # (blocks met in another order than made)
    gs = gs[::2] + gs[1::2]
    got = curves._by_block(gs)
    with monkeypatch.context() as m:
        m.setattr(curves, "_by_block_flat", lambda gs: None)
        ref = curves._by_block(gs)
        assert len(got) == len(ref) > 1
        for (b, q, k), (rb, rq, rk) in zip(got, ref):
            assert b is rb and list(q) == rq and list(k) == rk
        own = curves.CurveGeom(cur[0], prof)      # (its own block: a _Blk that keeps u)
        assert curves._by_block(gs + [own]) is None
    assert curves._by_block(gs + [own]) is None


def test_chain_fits_skips_a_block_of_odd_chain_caps():
    """A block with a chain whose caps are not n - 1 doubles is not kept (its rows are not
    given back); the others are, with their chains' caps."""
    prof, sts = _strokes()
    pin = plan_inputs(sts, prof, Options(), end_cols=True)
    codes = pin.plan_kind_codes
    rows = np.flatnonzero((codes == C_CURVE) | (codes == C_CHAIN))
    chains = [i for i in rows.tolist() if sts[i].curv.chain_caps is not None]
    assert chains
    odd = sts[chains[0]].curv
    odd.chain_caps = odd.chain_caps + b"\0" * 8
    blk = odd._b
    keep = GeomKeep(1 << 20, prof)
    keep.put(0, sts, codes)
    fresh = [copy.copy(sts[i]) for i in rows.tolist()]
    for st in fresh:
        st.curv = None
    keep.give(rows, fresh)
    for i, st in zip(rows.tolist(), fresh):
        if sts[i].curv._b is blk:
            assert st.curv is None
        elif curves._Blk is type(sts[i].curv._b) and gk._keepable(sts[i].curv._b):
            assert st.curv is not None
            assert st.curv.chain_caps == sts[i].curv.chain_caps
            assert st.curv.cap == sts[i].curv.cap
            assert st.curv.cos_end == sts[i].curv.cos_end


@pytest.mark.parametrize("name", ["prusa_gyroid.gcode", "prusa_gyroid_fullspeed.gcode"])
def test_command_bytes_are_the_python_paths(tmp_path, monkeypatch, name):
    """The list path with the loops these replace (no flat weights, the Python groups)
    against the list path and the windowed one (small windows) with them."""
    with monkeypatch.context() as m:
        m.setattr(curves, "_ROW_SUMS", None)
        m.setattr(curves, "_by_block_flat", lambda gs: None)
        ref = run_command(m, S / name, tmp_path / "ref.gcode", False, None)
    for windowed, window in ((False, None), (True, 37), (True, 7)):
        got = run_command(monkeypatch, S / name, tmp_path / "got.gcode", windowed, window)
        assert got[0] == ref[0]
        assert got[1] == ref[1]
