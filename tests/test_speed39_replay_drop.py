"""Issue 8 (s39, replay): _replay's drop of the chosen chains' rows (ChainMemo.drop_rows,
each geometry's caps, items' kept entries cleared) in one pass of the chain core
(drop_items) instead of chains._drop_items.  The memos must keep the same kept objects
(dropped to their source's _Again only where drop_rows drops them: kept laws of exactly
_KeptLaws, a source, the same rules key, equal but not the same tuple), the caps cleared,
the items (stroke, None, row), on memos built in every state and on a sample's chains
after its candidate table."""

import numpy as np
import pytest

from gcode_opt import chains, curves
from gcode_opt.laws import chain as chain_law

from chain_cases import fresh_chains

pytestmark = pytest.mark.skipif(chain_law.CORE_MOD is None, reason="chain core not built")


class _Stroke:
    def __init__(self, memo):
        self.chain_T = memo


class _Geom:
    def __init__(self):
        self.chain_caps = np.ones(3)


def _case(m, seed):
    rng = np.random.default_rng(seed)
    key = ("jerk", 10, 0.01, 0.1, 7)
    src = chains._Source(None, None, [0], {}, ("jerk", 10, 0.01, 0.1, 7))
    other = chains._Source(None, None, [0], {}, ("scv", 10, 0.01, 0.1, 7))
    items = []
    for k in range(m):
        memo = chains.ChainMemo()
        r = rng.random()
        laws = chains._KeptLaws(key if rng.random() < 0.7 else other.key, None, 0, 0)
        if r < 0.5:
            memo.kept = laws
        elif r < 0.55:
            memo.kept = src.again                   # (an _Again: a _KeptLaws, not exactly)
        elif r < 0.6:
            memo.kept = chains._Again(src)          # (not its source's: kept)
        elif r < 0.7:
            memo.kept = [laws, laws]
        else:
            memo.kept = laws
        s = rng.random()
        memo.src = None if s < 0.15 else other if s < 0.3 else src
        items.append((_Stroke(memo), laws, int(rng.integers(0, 5))))
    return items, [_Geom() for _ in range(m)]


def _state(items, gs, strokes):
    return ([id(st.chain_T.kept) for st in strokes], [g.chain_caps is None for g in gs],
            [(id(it[0]), it[1], it[2]) for it in items])


def test_drop_items_is_drop_rows():
    for seed in range(6):
        got_items, got_gs = _case(300, seed)
        want_items, want_gs = _case(300, seed)
        want_kept = [id(it[0].chain_T.kept) for it in want_items]
        sts_got, sts_want = [it[0] for it in got_items], [it[0] for it in want_items]
        chain_law.CORE_MOD.drop_items(got_items, got_gs, chains._KeptLaws)
        chains._drop_items(want_items, want_gs, chains._KeptLaws)
        g, w = _state(got_items, got_gs, sts_got), _state(want_items, want_gs, sts_want)
        # (the two cases' objects differ: kept compared as dropped or not, and to which source)
        assert [type(st.chain_T.kept) for st in sts_got] == [type(st.chain_T.kept) for st in sts_want]
        assert [st.chain_T.kept is st.chain_T.src.again if st.chain_T.src is not None else None for st in sts_got] \
            == [st.chain_T.kept is st.chain_T.src.again if st.chain_T.src is not None else None for st in sts_want]
        dropped = sum(a != b for a, b in zip(w[0], want_kept))
        assert 50 < dropped < 250
        assert g[1] == w[1] and all(g[1])
        assert [x[1:] for x in g[2]] == [x[1:] for x in w[2]] and all(x[1] is None for x in g[2])
        assert [x[0] for x in g[2]] == [id(s) for s in sts_got]


def test_drop_items_on_a_sample():
    res = []
    for fn in (chain_law.CORE_MOD.drop_items, chains._drop_items):
        strokes, pin, rows, prof, rules = fresh_chains("sample_gcode/prusa_gyroid_fullspeed.gcode", "prusa-mk3s")
        chains.candidates_chain(pin, rows, strokes, prof, rules)
        sts = [strokes[i] for i in rows.tolist()]
        items = [(st, st.chain_T.kept, 0) for st in sts]
        gs = [curves.geom(st, prof) for st in sts]
        fn(items, gs, chains._KeptLaws)
        res.append(([type(st.chain_T.kept).__name__ for st in sts],
                    [st.chain_T.kept is st.chain_T.src.again for st in sts],
                    [g.chain_caps is None for g in gs], [it[1:] for it in items]))
    assert res[0] == res[1]
    assert sum(res[1][1]) > len(res[1][1]) // 2
