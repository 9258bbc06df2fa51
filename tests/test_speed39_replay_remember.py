"""Issue 8 (s39, replay): plan_chain_segments' last loop (each chain's memo remembers its
plan and what it was made for, then the chains _replay did not drop are dropped) in one
pass of the chain core (remember_plans) instead of chains._remember_plans.  The memos must
end the same, attribute by attribute (the floats' bits, the same objects), and the same
chains dropped in the same order: plans whose time_t equals the duration asked or not,
NaN, signed zeros, a numpy float, a plan with no time_t, no plan.  Then on a sample's
chains planned twice (the budget's re-plan), the plans and the memos' states with and
without the core's loops (remember_plans and sort_asks, tests/test_speed39_replay_sort.py)."""

import numpy as np
import pytest
from array import array

from gcode_opt import chains
from gcode_opt.laws import chain as chain_law

from chain_cases import fresh_chains, float_bits

pytestmark = pytest.mark.skipif(chain_law.CORE_MOD is None, reason="chain core not built")

FIELDS = ("seg_T", "seg_beta", "seg_key", "seg", "seg_tin")


class _Stroke:
    __slots__ = ("chain_T",)

    def __init__(self):
        self.chain_T = chains.ChainMemo()


class _Plan:
    def __init__(self, time_t):
        self.time_t = time_t


def _state(memo, out, key):
    """The memo's fields: floats by type and bits, the plan by its place in out, the key by identity."""
    st = []
    for f in FIELDS:
        x = getattr(memo, f)
        if f == "seg":
            st.append(("plan", next((k for k, p in enumerate(out) if p is x), None) if x is not None else None))
        elif f == "seg_key":
            st.append(("key", x is key))
        else:
            st.append((type(x), float_bits(x) if isinstance(x, (float, np.floating)) else x))
    return st


def _run(fn, m, seed):
    rng = np.random.default_rng(seed)
    strokes = [_Stroke() for _ in range(m)]
    t = rng.uniform(0.1, 3.0, m)
    pick = rng.random(m)
    t[pick < 0.05] = np.nan
    t[(pick >= 0.05) & (pick < 0.1)] = -0.0
    t_in = array("d", t.tobytes())
    T = array("d", rng.uniform(0.1, 3.0, m).tobytes())
    b_in = array("d", rng.uniform(0.0, 1.0, m).tobytes())
    out = []
    for k in range(m):
        r = rng.random()
        tk = t_in[k]
        if r < 0.4:
            out.append(_Plan(tk))                     # its own duration (a float of the same bits)
        elif r < 0.5:
            out.append(_Plan(np.float64(tk)))         # as a numpy float
        elif r < 0.6:
            out.append(_Plan(0.0 if tk == 0.0 else tk * 1.5))     # (0.0 == -0.0: the plan's own kept)
        elif r < 0.7:
            out.append(object())                      # no time_t
        elif r < 0.75:
            out.append(None)
        else:
            out.append(_Plan(float(np.nextafter(tk, 10.0))))
    todo = sorted(rng.choice(m, size=m * 3 // 4, replace=False).tolist())
    dropped = set(rng.choice(m, size=m // 2, replace=False).tolist())
    key = ("jerk", 10, 0.01, 0.1, 1234)
    calls = []
    fn(strokes, todo, out, T, b_in, t_in, key, dropped, calls.append)
    return [_state(st.chain_T, out, key) for st in strokes], [strokes.index(s) for s in calls]


def test_remember_plans_is_the_loop():
    for seed in range(6):
        got, got_calls = _run(chain_law.CORE_MOD.remember_plans, 300, seed)
        want, want_calls = _run(chains._remember_plans, 300, seed)
        assert got_calls == want_calls and len(want_calls) > 20
        assert got == want
        assert sum(w[4][0] is np.float64 for w in want) > 10      # (the numpy floats kept as such)


def test_remember_plans_keeps_the_plan_objects():
    """seg the plan itself, seg_key the key itself, seg_tin the plan's time_t object where equal."""
    strokes = [_Stroke() for _ in range(4)]
    plans = [_Plan(1.5), _Plan(np.float64(2.0)), _Plan(3.0), object()]
    t_in = array("d", [1.5, 2.0, 4.0, 5.0])
    key = ("k",)
    calls = []
    chain_law.CORE_MOD.remember_plans(strokes, [0, 1, 2, 3], plans, array("d", [7.0, 8.0, 9.0, 10.0]),
                                      array("d", [0.1, 0.2, 0.3, 0.4]), t_in, key, {1, 3}, calls.append)
    memos = [st.chain_T for st in strokes]
    assert all(m.seg is p for m, p in zip(memos, plans)) and all(m.seg_key is key for m in memos)
    assert memos[0].seg_tin is plans[0].time_t and memos[1].seg_tin is plans[1].time_t
    assert type(memos[2].seg_tin) is float and memos[2].seg_tin == 4.0 and memos[3].seg_tin == 5.0
    assert [m.seg_T for m in memos] == [7.0, 8.0, 9.0, 10.0] and [m.seg_beta for m in memos] == [0.1, 0.2, 0.3, 0.4]
    assert calls == [strokes[0], strokes[2]]


def test_plan_chain_segments_memos_with_and_without_the_core():
    """A sample's chains planned, then re-planned at other candidates: the plans' bits and
    the memos' remembered figures the same with both loops in C or in Python."""
    res = []
    for core in (True, False):
        strokes, pin, rows, prof, rules = fresh_chains("sample_gcode/prusa_gyroid_fullspeed.gcode", "prusa-mk3s")
        chains.candidates_chain(pin, rows, strokes, prof, rules)
        sts = [strokes[i] for i in rows.tolist()]
        rng = np.random.default_rng(7)
        was = chain_law.CORE_MOD
        if not core:
            orig = chain_law.CORE_MOD.remember_plans, chain_law.CORE_MOD.sort_asks
            chain_law.CORE_MOD.remember_plans = chains._remember_plans
            chain_law.CORE_MOD.sort_asks = chains._sort_asks
        try:
            got = []
            for _ in range(2):
                picked = [st.chain_T.rows()[int(rng.integers(0, st.chain_T.n))] for st in sts]
                T = np.array([r[0] for r in picked])
                b = np.array([r[2] for r in picked])
                plans = chains.plan_chain_segments(sts, T, b, rules, prof)
                got.append([(float_bits(p.v), float_bits(p.accel), float_bits(p.feed), float_bits(p.time_t))
                            for p in plans])
                got.append([(float_bits(st.chain_T.seg_T), float_bits(st.chain_T.seg_beta),
                             float_bits(st.chain_T.seg_tin), st.chain_T.kept is not None) for st in sts])
        finally:
            chain_law.CORE_MOD = was
            if not core:
                chain_law.CORE_MOD.remember_plans, chain_law.CORE_MOD.sort_asks = orig
        res.append(got)
    assert res[0] == res[1]
