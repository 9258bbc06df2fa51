"""The windowed run's kept curve geometry given back as the runs ask for it (geom_keep.GeomKeep.give,
benchmarks/cands58.md): a window's curves' rows, then its chains' rows, each a call of their
own (schedule._rebuild_geometry), are the geometry build_geoms makes of that window, bit
for bit, and each block given holds the rows asked alone; a window's rows given whole take
the record's doubles as they are (no copy), its rows given in part their own copies."""
import numpy as np
import pytest

from gcode_opt.schedule import C_CHAIN, C_CURVE
from gcode_opt.stored_strokes import curve_geometry
# (the same sample, windows and store as the kept geometry's own tests)
from test_speed57_geom57 import WINDOW, _fields, _kept


@pytest.mark.parametrize("prof_name", ["prusa-mk3s", "voron24"])     # classic jerk; Klipper's (caps kept)
def test_kinds_given_apart(tmp_path, prof_name):
    prof, store, keep, codes = _kept(tmp_path, prof_name)
    made = curve_geometry(codes, prof)            # (no keep: build_geoms of the window)
    mixed = 0                                     # windows with a block of both kinds (given in part)
    for lo in range(0, len(store), WINDOW):
        given, want, whole = (store.load(lo, lo + WINDOW) for _ in range(3))
        made(lo, want)
        c = codes[lo:lo + len(given)]
        keep.give(np.arange(lo, lo + len(whole)), whole)
        mixed += bool({id(st.curv._b) for st, k in zip(whole, c) if k == C_CURVE}
                      & {id(st.curv._b) for st, k in zip(whole, c) if k == C_CHAIN})
        for kind in (C_CURVE, C_CHAIN):           # (the runs' order: _rebuild_geometry)
            ks = np.flatnonzero(c == kind)
            sts = [given[k] for k in ks.tolist()]
            keep.give(ks + lo, sts)
            blocks = {id(st.curv._b): st.curv._b for st in sts}
            # (no row of the other kind made: the blocks hold the rows asked alone)
            assert sum(b.d.shape[0] for b in blocks.values()) == len(sts)
            for k, st in zip(ks.tolist(), sts):
                assert st.curv._b._pts[st.curv._k] is st.pts
                # (κ_eff read first: a chain's, not made by classify, is made from its vertices)
                assert float(st.curv.kappa_eff).hex() == float(want[k].curv.kappa_eff).hex(), (lo + k)
                assert _fields(st, kind == C_CHAIN, prof) == _fields(want[k], kind == C_CHAIN, prof), (lo + k)
    ours = (codes == C_CURVE) | (codes == C_CHAIN)
    assert keep.given == 2 * ours.sum()           # (the whole windows' and the kinds')
    assert mixed > 3
    assert (codes == C_CHAIN).sum() > 10 and (codes == C_CURVE).sum() > 10


def test_whole_window_given_as_kept(tmp_path):
    """A window given whole: each block's lengths, κ_eff and caps are the record's doubles
    read back (views of one read, not copies); rows given in part: arrays of their own."""
    prof, store, keep, codes = _kept(tmp_path, "voron24")
    ours = np.flatnonzero((codes == C_CURVE) | (codes == C_CHAIN))
    lo = int(ours[0]) // WINDOW * WINDOW
    whole = store.load(lo, lo + WINDOW)
    keep.give(np.arange(lo, lo + len(whole)), whole, kappa=True)
    blocks = [st.curv._b for st in whole if st.curv is not None]
    main = blocks[0].d.base
    assert main is not None and all(x.base is main for b in blocks for x in (b.d, b._ke, b.cap, b._caps))
    rows = ours[(ours >= lo) & (ours < lo + WINDOW)][::2]
    part = store.take(rows)
    keep.give(rows, part, kappa=True)
    got = [st.curv._b for st in part]
    assert all(x.base is not main for b in got for x in (b.d, b._ke, b.cap, b._caps))
    for st, r in zip(part, rows.tolist()):
        chain = codes[r] == C_CHAIN
        assert _fields(st, chain, prof) == _fields(whole[r - lo], chain, prof), r
