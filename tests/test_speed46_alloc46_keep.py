"""Issue 8, session 46 (alloc46): _keep_made_plans leaves the run's plans where they are in
plan.segs and sets only the rows not kept to None (_keep_plans' in_place), instead of
setting every row to None and putting the kept ones back.  The same plan, row by row:
compared with the replaced function (a verbatim copy below) on random rows (faults, no
plan, plans that do not beat, failed rows, chunk boundaries) and on real budget runs."""
import os
from collections import deque
from itertools import repeat
from types import SimpleNamespace

import numpy as np
import pytest

from gcode_opt import pipeline, schedule
from gcode_opt.profile import load_profile

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")


def _keep_made_plans_0b09fc6(plan, strokes, idx, seg_failed, a2_orig):
    """0b09fc6's _keep_made_plans, verbatim (KEEP_ROWS and _keep_plans read from schedule)."""
    segs = plan.segs
    for a in range(0, idx.size, schedule.KEEP_ROWS):
        rows = idx[a:a + schedule.KEEP_ROWS]
        rows_l = rows.tolist()
        seg_l = list(map(segs.__getitem__, rows_l))
        deque(map(segs.__setitem__, rows_l, repeat(None)), maxlen=0)      # segs[i] = None
        schedule._keep_plans(plan, strokes, rows, seg_l, seg_failed, rows_l, a2_orig[rows])


def _state(plan):
    """What _keep_made_plans writes: each row's plan (by identity), retime, reason, t_pred, a2_pred."""
    return ([id(s) for s in plan.segs], plan.retime.tobytes(), list(plan.reason), plan.t_pred.tobytes(),
            plan.a2_pred.tobytes())


def _copy_plan(plan):
    out = SimpleNamespace(segs=list(plan.segs), retime=plan.retime.copy(), reason=plan.reason.copy(),
                          t_pred=plan.t_pred.copy(), a2_pred=plan.a2_pred.copy())
    return out


def _random_case(rng, n):
    """A plan whose rows idx hold fake segment plans (a verdict "" or a fault, or None),
    their int_a2 beating the original or not; failed rows (seg_failed) among them."""
    idx = np.sort(rng.choice(n, size=int(rng.integers(0, n + 1)), replace=False))
    a2_orig = rng.uniform(1.0, 2.0, n)
    plan = SimpleNamespace(segs=[object() for _ in range(n)], retime=np.ones(n, bool),
                           reason=np.full(n, "retimed", dtype=object), t_pred=rng.uniform(0, 1, n),
                           a2_pred=a2_orig.copy())
    fault_r, none_r, lose_r = rng.uniform(0, 0.3, 3) * rng.integers(0, 2, 3)
    for i in idx.tolist():
        u = rng.uniform()
        if u < none_r:
            plan.segs[i] = None
            continue
        a2 = a2_orig[i] * (rng.uniform(1.0, 1.5) if rng.uniform() < lose_r else rng.uniform(0.2, 0.99))
        plan.segs[i] = SimpleNamespace(fault="bad plan" if rng.uniform() < fault_r else "", int_a2=a2,
                                       time_t=float(rng.uniform(0, 1)))
    seg_failed = {}
    if idx.size and rng.uniform() < 0.3:
        seg_failed = {int(i): "error: segments" for i in rng.choice(idx, size=min(3, idx.size), replace=False)}
    return plan, idx, seg_failed, a2_orig


@pytest.mark.parametrize("keep_rows", [1, 7, 8192])
def test_keep_made_plans_same_as_0b09fc6_random(keep_rows, monkeypatch):
    monkeypatch.setattr(schedule, "KEEP_ROWS", keep_rows)
    rng = np.random.default_rng(46 + keep_rows)
    lost = 0
    for _ in range(150):
        plan, idx, seg_failed, a2_orig = _random_case(rng, int(rng.integers(1, 60)))
        ref = _copy_plan(plan)
        _keep_made_plans_0b09fc6(ref, None, idx, seg_failed, a2_orig)
        schedule._keep_made_plans(plan, None, idx, seg_failed, a2_orig)
        assert _state(plan) == _state(ref)
        lost += int(sum(1 for i in idx.tolist() if ref.segs[i] is None))
    assert lost > 100             # rows not kept were set to None (the path that writes)


def test_items_is_the_rows_items():
    seq = list(range(100, 150))
    for at in ([], [3], [4, 4], [0, 49, 7]):
        assert schedule._items(seq, at) == [seq[i] for i in at]
        assert type(schedule._items(seq, at)) is list


def _runs(name, prof, keep, monkeypatch, budgets=(1.0, 0.6, 0.61, 1.3, 1.0)):
    profile = load_profile(prof)
    opts = pipeline.Options(corner_budget_r=0.0)
    opts.ringing = False
    strokes, sim0 = pipeline.analyse(os.path.join(SAMPLES, name), profile, opts)
    pin = schedule.plan_inputs(strokes, profile, opts)
    runs = []

    def fit(run, pin_, budget_t):
        for r in budgets:
            p = run(r * budget_t)
            runs.append((_state(p), p.T.tobytes()))
        return p
    monkeypatch.setattr(schedule, "_fit_budget", fit)
    monkeypatch.setattr(schedule, "_keep_made_plans", keep)
    schedule.plan_strokes(strokes, pin, profile, opts, opts.max_slowdown_r * sim0.time_t)
    return runs


@pytest.mark.parametrize("name", ["prusa_mk3s_rectilinear.gcode", "prusa_gyroid.gcode"])
def test_budget_runs_keep_the_same_plans(name, monkeypatch):
    """Each of five budget runs: the new function, checked against the old one on a copy
    of the plan as it stood before (the same plan objects in the same rows)."""
    new = schedule._keep_made_plans
    checked = []

    def both(plan, strokes, idx, seg_failed, a2_orig):
        ref = _copy_plan(plan)
        _keep_made_plans_0b09fc6(ref, strokes, idx, seg_failed, a2_orig)
        new(plan, strokes, idx, seg_failed, a2_orig)
        assert _state(plan) == _state(ref)
        checked.append(idx.size)
    with monkeypatch.context() as m:
        m.setattr(schedule, "KEEP_ROWS", 64)
        runs = _runs(name, "prusa-mk3s", both, m)
    assert len(checked) == 5 and max(checked) > 64
    with monkeypatch.context() as m:
        old = _runs(name, "prusa-mk3s", _keep_made_plans_0b09fc6, m)
    assert [r[0][1:] + (r[1],) for r in runs] == [r[0][1:] + (r[1],) for r in old]
