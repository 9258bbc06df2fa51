"""Issue 8 (s33, planrun): chains.ask_all answers ChainMemo.ask for every chain of a
plan_chain_segments call, the memos whose rows share one array (the chains finished
together) by numpy on that array.  Its answers must be ask's own, chain by chain: the law
duration's bits, the same last plan, the same kept plans object and row, on real memos of
the sample files (classic jerk and Klipper SCV) asked for their candidates' durations,
others, NaN and signed zeros, with and without a last plan; and on memos built by hand
whose rows repeat a duration in another column."""

import numpy as np
import pytest
from array import array

from gcode_opt import chains

from chain_cases import fresh_chains, float_bits

CASES = [("sample_gcode/prusa_gyroid_fullspeed.gcode", "prusa-mk3s"),
         ("sample_gcode/prusa_gyroid_fullspeed_klipper.gcode", "voron24")]


def _same(got, want):
    lt, seg, hit = got
    wlt, wseg, whit = want
    return (float_bits(lt) == float_bits(wlt) and seg is wseg and (hit is None) == (whit is None)
            and (hit is None or (hit[0] is whit[0] and type(hit[1]) is int and hit[1] == whit[1])))


def _counted(monkeypatch):
    """chains._ask_rows counting its calls (the numpy path taken, not only ask; not the
    chain core's one pass, tests/test_speed39_replay_ask.py)."""
    monkeypatch.setattr(chains._chain_law, "CORE_MOD", None)
    calls = []
    f = chains._ask_rows

    def counted(*a):
        calls.append(len(a[1]))             # (its memos' places)
        return f(*a)
    monkeypatch.setattr(chains, "_ask_rows", counted)
    return calls


def _check(memos, t, b, key):
    t_in, b_in = array("d", np.asarray(t, float).tobytes()), array("d", np.asarray(b, float).tobytes())
    T = array("d", bytes(8 * len(memos)))
    segs, kept, rows = chains.ask_all(memos, t_in, b_in, key, T)
    got = [(T[k], segs[k], None if rows[k] is None else (kept[k], rows[k])) for k in range(len(memos))]
    want = [m.ask(t_in[k], b_in[k], key) for k, m in enumerate(memos)]
    assert len(segs) == len(kept) == len(rows) == len(want)
    assert all(_same(g, w) for g, w in zip(got, want))
    assert all(r is not None or k is None for k, r in zip(kept, rows))     # (no kept plans without a row)
    return want


@pytest.mark.parametrize("path,prof_name", CASES)
def test_ask_all_is_ask(path, prof_name, monkeypatch):
    strokes, pin, rows, prof, rules = fresh_chains(path, prof_name)
    chains.candidates_chain(pin, rows, strokes, prof, rules)
    key = chains._rules_key(rules, prof)
    memos = [strokes[i].chain_T for i in rows.tolist()]
    m = len(memos)
    assert m >= 2 * chains.ASK_ROWS_MIN
    rng = np.random.default_rng(0)
    monkeypatch.setattr(chains, "ASK_ROWS_MIN", 8)          # (the samples' groups are small)
    calls = _counted(monkeypatch)
    # each chain asked for one of its candidates (its predicted duration and beta), a
    # duration off the table, NaN, a zero; another beta
    for mode in range(4):
        picked = [memo.rows()[int(rng.integers(0, memo.n))] if memo.n else (1.0, 1.0, 1.0) for memo in memos]
        t = np.array([r[0] for r in picked])
        b = np.array([r[2] for r in picked])
        pick = rng.random(m)
        t[pick < 0.1] *= 1.013
        t[(pick >= 0.1) & (pick < 0.13)] = np.nan
        t[(pick >= 0.13) & (pick < 0.15)] = -0.0
        if mode == 1:
            b[rng.random(m) < 0.3] *= 2.0
        if mode >= 2:                    # some memos with a last plan: asked by ask
            for k in np.flatnonzero(rng.random(m) < 0.3).tolist():
                memo = memos[k]
                memo.seg = object()
                memo.seg_T, memo.seg_beta, memo.seg_key = memo.law_of(float(t[k])), float(b[k]), key
                memo.seg_tin = float(t[k]) if mode == 2 else float(t[k]) * 2
        want = _check(memos, t, b, key)
        if mode == 0:
            assert sum(w[2] is not None for w in want) > m // 2      # (plans found: rows compared)
        for memo in memos:
            memo.seg = memo.seg_T = memo.seg_beta = memo.seg_key = memo.seg_tin = None
    assert sum(calls) > m                # (most memos answered by numpy, each mode)
    monkeypatch.setattr(chains, "ASK_ROWS_MIN", 1 << 30)     # (every memo by ask)
    _check(memos, t, b, key)


def test_ask_all_on_rows_repeating_a_duration_in_another_column(monkeypatch):
    """The rows of several memos in one array (put_shared), durations repeated as another
    row's law T or beta, kept plans one object or a list (put mixes them), no rows."""
    monkeypatch.setattr(chains, "ASK_ROWS_MIN", 2)
    calls = _counted(monkeypatch)
    rows = array("d", [2.0, 3.0, 5.0, 3.0,   3.0, 1.0, 2.0, 2.0,   1.0, 2.0, 5.0, 1.0,   2.0, 3.0, 9.0, 0.0,
                       0.0, 7.0, 1.0, 0.0,   -0.0, 8.0, 1.0, 1.0])
    kept = [object() for _ in range(3)]
    memos = [chains.ChainMemo() for _ in range(6)]
    memos[0].put_shared(rows, 0, 4, kept[0])
    memos[1].put_shared(rows, 1, 3, kept[1])
    memos[2].put_shared(rows, 4, 2, kept[2])
    memos[3].put_shared(rows, 0, 4, kept[0])
    memos[3].put(4.0, 6.0, 1.0, kept[1], 7)     # (its own rows now, a list of kept)
    memos[4].put_shared(rows, 6, 0, kept[2])    # (no row)
    key = "k"
    vals = (1.0, 2.0, 3.0, 4.0, 5.0, 9.0, 0.0, -0.0, np.nan)
    for t in vals:
        for b in (2.0, 5.0, 9.0, 1.0, 0.0, -0.0):
            _check(memos, [t] * len(memos), [b] * len(memos), key)
    # every memo of the shared array asked for its own candidates at once
    _check(memos, [2.0, 3.0, 0.0, 4.0, 2.0, 1.0], [5.0, 2.0, 1.0, 1.0, 9.0, 1.0], key)
    assert calls and all(c == 4 for c in calls)     # (memos 0, 1, 2 and 4 by numpy)
