"""Issue 8 (s39, replay): chains.ask_all answers every memo in one pass of the chain core
(ask_memos) instead of numpy on the shared rows arrays and ask one by one.  Its answers
must be the numpy code's and ask's, chain by chain: the law duration's bits, the same last
plan, the same kept plans object and row (an int), on real memos of a sample file asked
for their candidates' durations, others, NaN and signed zeros, with and without a last
plan; on memos built by hand (rows shared, mixed by put, repeating a duration in another
column, none); and ask's own exceptions where its rows are out of their array."""

import numpy as np
import pytest
from array import array

from gcode_opt import chains
from gcode_opt.laws import chain as chain_law

from chain_cases import fresh_chains, float_bits

pytestmark = pytest.mark.skipif(chain_law.CORE_MOD is None, reason="chain core not built")


def _ask(memos, t, b, key, core):
    """ask_all's (T, segs, kept, rows) with the core (True) or the numpy code (False)."""
    t_in, b_in = array("d", np.asarray(t, float).tobytes()), array("d", np.asarray(b, float).tobytes())
    T = array("d", bytes(8 * len(memos)))
    was = chain_law.CORE_MOD
    chain_law.CORE_MOD = was if core else None
    try:
        segs, kept, rows = chains.ask_all(memos, t_in, b_in, key, T)
    finally:
        chain_law.CORE_MOD = was
    return T, segs, kept, rows


def _check(memos, t, b, key):
    """The core's answers are the numpy code's and each memo's ask; the number of hits."""
    T, segs, kept, rows = _ask(memos, t, b, key, True)
    T0, segs0, kept0, rows0 = _ask(memos, t, b, key, False)
    assert float_bits(np.frombuffer(T, float)) == float_bits(np.frombuffer(T0, float))
    assert all(a is b for a, b in zip(segs, segs0)) and len(segs) == len(segs0) == len(memos)
    assert all(a is b for a, b in zip(kept, kept0)) and len(kept) == len(kept0) == len(memos)
    assert [type(r) for r in rows] == [type(r) for r in rows0] and rows == rows0
    t_in, b_in = array("d", np.asarray(t, float).tobytes()), array("d", np.asarray(b, float).tobytes())
    for k, memo in enumerate(memos):
        lt, seg, hit = memo.ask(t_in[k], b_in[k], key)
        assert float_bits(T[k]) == float_bits(lt) and segs[k] is seg
        assert (hit is None and kept[k] is None and rows[k] is None) or (
            hit[0] is kept[k] and type(rows[k]) is int and rows[k] == hit[1])
    return sum(r is not None for r in rows)


def test_ask_memos_on_a_sample_plate():
    strokes, pin, rows, prof, rules = fresh_chains("sample_gcode/prusa_gyroid_fullspeed.gcode", "prusa-mk3s")
    chains.candidates_chain(pin, rows, strokes, prof, rules)
    key = chains._rules_key(rules, prof)
    memos = [strokes[i].chain_T for i in rows.tolist()]
    m = len(memos)
    assert m >= 2 * chains.ASK_ROWS_MIN                 # (the numpy code's groups taken too)
    rng = np.random.default_rng(39)
    for mode in range(4):
        picked = [memo.rows()[int(rng.integers(0, memo.n))] if memo.n else (1.0, 1.0, 1.0) for memo in memos]
        t = np.array([r[0] for r in picked])
        b = np.array([r[2] for r in picked])
        pick = rng.random(m)
        t[pick < 0.1] *= 1.013
        t[(pick >= 0.1) & (pick < 0.13)] = np.nan
        t[(pick >= 0.13) & (pick < 0.15)] = -0.0
        t[(pick >= 0.15) & (pick < 0.17)] = np.array([r[1] for r in picked])[(pick >= 0.15) & (pick < 0.17)]
        if mode == 1:
            b[rng.random(m) < 0.3] *= 2.0
        if mode >= 2:                    # some memos with a last plan (ask itself)
            for k in np.flatnonzero(rng.random(m) < 0.3).tolist():
                memo = memos[k]
                memo.seg = object()
                memo.seg_T, memo.seg_beta, memo.seg_key = memo.law_of(float(t[k])), float(b[k]), key
                memo.seg_tin = float(t[k]) if mode == 2 else float(t[k]) * 2
        hits = _check(memos, t, b, key)
        if mode == 0:
            assert hits > m // 2         # (plans found: rows compared)
        for memo in memos:
            memo.seg = memo.seg_T = memo.seg_beta = memo.seg_key = memo.seg_tin = None


def test_ask_memos_on_rows_built_by_hand():
    rows = array("d", [2.0, 3.0, 5.0, 3.0,   3.0, 1.0, 2.0, 2.0,   1.0, 2.0, 5.0, 1.0,   2.0, 3.0, 9.0, 0.0,
                       0.0, 7.0, 1.0, 0.0,   -0.0, 8.0, 1.0, 1.0])
    kept = [object() for _ in range(3)]
    memos = [chains.ChainMemo() for _ in range(7)]
    memos[0].put_shared(rows, 0, 4, kept[0])
    memos[1].put_shared(rows, 1, 3, kept[1])
    memos[2].put_shared(rows, 4, 2, kept[2])
    memos[3].put_shared(rows, 0, 4, kept[0])
    memos[3].put(4.0, 6.0, 1.0, kept[1], 7)     # (its own rows now, a list of kept)
    memos[3].put(4.5, 3.0, 5.0, kept[2], 8)     # (its (3, 5) twice: the newest one's row)
    memos[4].put_shared(rows, 6, 0, kept[2])    # (no row)
    # memos[5]: no rows at all; memos[6]: a last plan
    memos[6].put_shared(rows, 2, 3, kept[1])
    memos[6].seg, memos[6].seg_T, memos[6].seg_beta, memos[6].seg_key, memos[6].seg_tin = object(), 2.0, 5.0, "k", 1.0
    vals = (1.0, 2.0, 3.0, 4.0, 5.0, 9.0, 0.0, -0.0, np.nan)
    hits = 0
    for key in ("k", "other"):
        for t in vals:
            for b in (2.0, 5.0, 9.0, 1.0, 0.0, -0.0):
                hits += _check(memos, [t] * len(memos), [b] * len(memos), key)
    assert hits > 30
    _check(memos, [2.0, 3.0, 0.0, 4.0, 2.0, 1.0, 1.0], [5.0, 2.0, 1.0, 1.0, 9.0, 1.0, 5.0], "k")


def test_ask_memos_raises_as_ask():
    """Rows past their array: ask's IndexError (the pass asks the memo itself)."""
    memo = chains.ChainMemo()
    memo.put_shared(array("d", [2.0, 3.0, 5.0, 0.0]), 0, 1, object())
    memo.n = 2                                   # (a row past the array)
    with pytest.raises(IndexError):
        memo.ask(7.0, 5.0, "k")
    T = array("d", [0.0])
    with pytest.raises(IndexError):
        chain_law.CORE_MOD.ask_memos([memo], array("d", [7.0]), array("d", [5.0]), "k", T, array,
                                     [None], [None], [None])
