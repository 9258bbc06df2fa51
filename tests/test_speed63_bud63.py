"""bud63 (benchmarks/bud63.md): the windowed budget runs' pieces made with fewer calls give
what they gave before, bit for bit.

- line_spill._row_blocks_compiled: the same blocks, places, rows and other places, in the
  same order, as the loop (blocks sharing a V, a junction command, a bad shape, SegmentPlans
  and None mixed in); line_spill._rest_records: the same record doubles as _record's.
- schedule._KeyFigures.add: the figures and reasons of the keys' plans as seg_fault gives
  them a plan, whether their verdicts are made or not."""
import numpy as np
import pytest

from gcode_opt import line_spill as ls
from gcode_opt import schedule as sc
from gcode_opt.segments import RowPlan, SegmentPlan


def _mixed_plans(seed):
    """Line plans as a put meets them: RowPlans of several blocks (two sharing a V with
    other S, A, F), one with a junction command, one of a shape the records do not hold, a
    block of another width, SegmentPlans and None."""
    rng = np.random.default_rng(seed)

    def block(m, n):
        S = np.cumsum(rng.random((m, n + 1)), axis=1)
        return S, rng.random((m, n + 1)), rng.random((m, n)) + 1.0, rng.random((m, n)) + 1.0
    b1, b2, b3 = block(30, 4), block(25, 6), block(20, 4)
    b4 = (b3[0].copy(), b1[1], b1[2], b1[3])            # b1's V with another S
    plans = []
    for b, m in ((b1, 30), (b2, 25), (b3, 20), (b4, 10)):
        plans += [RowPlan(*b, i, float(rng.normal()), float(rng.normal())) for i in range(m)]
    for i in range(0, len(plans), 7):
        plans[i].shape = "trapezoid"
    plans[40].first_cmds = None
    plans[41].shape = "odd"                             # (its block goes to the others, one by one)
    s = np.cumsum(rng.random(5))
    plans += [SegmentPlan(s, rng.random(5), rng.random(4) + 1, rng.random(4) + 1, 1.5, 2.5) for _ in range(6)]
    plans += [None] * 5
    order = rng.permutation(len(plans))
    return [plans[q] for q in order.tolist()]


@pytest.mark.parametrize("seed", range(4))
def test_compiled_row_blocks_are_the_loops(seed, monkeypatch):
    plans = _mixed_plans(seed)
    got = ls._row_blocks_compiled(plans)
    if got is None:
        pytest.skip("objfields' compiled passes not built")
    monkeypatch.setattr(ls, "COMPILED_PLANS", 10 ** 9)
    want = ls._row_blocks(plans)
    assert got[1] == want[1]
    assert len(got[0]) == len(want[0]) >= 3
    for (gb, gi, gr), (wb, wi, wr) in zip(*[x[0] for x in (got, want)]):
        assert all(x is y for x, y in zip(gb, wb))
        assert gi.dtype == wi.dtype and gi.tolist() == wi.tolist()
        assert gr.dtype == wr.dtype and gr.tolist() == wr.tolist()
    # a junction command: the compiled passes decline (the loop answers)
    plans[next(q for q, p in enumerate(plans) if type(p) is RowPlan)].first_cmds = ["M205"]
    assert ls._row_blocks_compiled(plans) is None


def test_rest_records_are_the_one_by_one_records():
    plans = _mixed_plans(7)
    _, rest = ls._row_blocks(plans)
    m = len(plans)
    cls, T, beta = np.arange(3, 3 + m, dtype=np.int64), np.linspace(1, 2, m), np.full(m, .3)
    for i, q in enumerate(rest):
        if plans[q] is not None:
            plans[q].fault = ("", None, "a reason")[i % 3]
    one = [ls._record(plans[q], cls[q], T[q], beta[q]) for q in rest]
    parts, qs, ns = ls._rest_records(plans, rest, cls, T, beta)
    held = [q for q, r in zip(rest, one) if r is not None]
    assert qs.tolist() == held and len(held) >= 6
    assert ns.tolist() == [r[3].size for r in one if r is not None]
    assert np.concatenate(parts).tobytes() == np.concatenate([a for r in one if r is not None for a in r]).tobytes()


def _key_plans():
    """Plans as the runs' line keys give them: verdicts not made, a fault (a NaN knot), a
    non-finite figure, None."""
    rng = np.random.default_rng(63)
    m, n = 12, 4
    S = np.cumsum(rng.random((m, n + 1)), axis=1)
    V, A, F = rng.random((m, n + 1)), rng.random((m, n)) + 1.0, rng.random((m, n)) + 1.0
    V[3, 2] = np.nan
    plans = [RowPlan(S, V, A, F, i, float(rng.random()), float(rng.random())) for i in range(m)]
    plans[5].int_a2 = float("inf")
    return plans + [None]


@pytest.mark.parametrize("failed", [None, "some"])
def test_key_figures_are_seg_faults(failed):
    made = _key_plans()
    fails = None if failed is None else [None] * 6 + ["error: segments"] + [None] * (len(made) - 7)
    figs = sc._KeyFigures()
    figs.add(made, fails)
    figs.add(_key_plans()[:4])                          # (a second call: the fast one where fine)
    figs.done()
    want_why, want_a2, want_t = [], [], []
    for seg, f in list(zip(_key_plans(), fails or [None] * len(made))) + [(p, None) for p in _key_plans()[:4]]:
        w = f or ("" if seg is None else sc.seg_fault(seg))
        want_why.append(w)
        want_a2.append(np.nan if w or seg is None else seg.int_a2)
        want_t.append(np.nan if w or seg is None else seg.time_t)
    assert figs.why == want_why
    assert figs.a2.tobytes() == np.array(want_a2).tobytes()
    assert figs.t.tobytes() == np.array(want_t).tobytes()
    assert figs.bad.tolist() == [bool(w) for w in want_why]
    assert want_why.count("") >= 8 and len(set(want_why)) >= (2 if failed is None else 3)
