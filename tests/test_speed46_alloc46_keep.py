"""Issue 8, session 46 (alloc46): _keep_made_plans leaves the run's plans where they are in
plan.segs and sets only the rows not kept to None (_keep_plans' in_place), instead of
setting every row to None and putting the kept ones back; _keep_plans finds its common
case (every plan's verdict "") by one compiled pass (_verdicts_fine).  The same plan, row
by row: compared with the replaced functions (verbatim copies below) on random rows
(faults, plans with no verdict yet, no plan, plans that do not beat, failed rows, chunk
boundaries) and on real budget runs."""
import math
import os
from collections import deque
from itertools import repeat
from types import SimpleNamespace

import numpy as np
import pytest

from gcode_opt import objfields, pipeline, schedule
from gcode_opt.schedule import (_FAULT, _INT_A2, _IS_NONE, _NOT_BEATING, _TIME_T, GAIN_TOL_R, compress, seg_fault,
                                settle_faults)
from gcode_opt.segments import SegmentPlan
from gcode_opt.profile import load_profile

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")


def _keep_made_plans_0b09fc6(plan, strokes, idx, seg_failed, a2_orig):
    """0b09fc6's _keep_made_plans and _keep_plans, verbatim (KEEP_ROWS and the helpers read from schedule)."""
    segs = plan.segs
    for a in range(0, idx.size, schedule.KEEP_ROWS):
        rows = idx[a:a + schedule.KEEP_ROWS]
        rows_l = rows.tolist()
        seg_l = list(map(segs.__getitem__, rows_l))
        deque(map(segs.__setitem__, rows_l, repeat(None)), maxlen=0)      # segs[i] = None
        _keep_plans_0b09fc6(plan, strokes, rows, seg_l, seg_failed, rows_l, a2_orig[rows])


def _keep_plans_0b09fc6(plan, strokes, idx, seg_l, seg_failed, idx_l=None, a2_orig=None):
    """The segment plans seg_l (a list: row idx[q]'s plan, or None) of the rows idx (an int array) put on the plan:
    a row whose segmenting failed (seg_failed: its reason), whose plan has a fault
    (seg_fault), has none, or does not beat its original (beats) is left as sliced with
    its reason; the others are put in plan.segs with their figures in t_pred and a2_pred.

    Row by row, the same as a loop over idx asking each row in turn (tests/
    test_speed26_linec_keep.py keeps that loop), made as a few passes over the rows'
    lists and arrays (~41 k rows a budget run on the rectilinear plate, three runs: the
    loop's ~1 µs a row was ~0.1 s of its planning): the faults in one list, beats on
    arrays (the same product and comparison of doubles), the kept rows put at once.
    idx_l: idx.tolist(), when the caller has it; a2_orig: the rows' strokes' int_a2 (a
    float array) when the caller has them (pin.I_orig, read once: their ~41 k attribute
    reads a run were ~5 ms)."""
    if idx_l is None:
        idx_l = idx.tolist()
    n = len(seg_l)
    why_l = None
    try:                        # every row a plan with a verdict slot (else AttributeError)
        why_l = list(map(_FAULT, seg_l))
    except AttributeError:
        settle_faults(seg_l)
    else:
        if why_l.count(None):   # settle_faults of the plans with no verdict yet (it skips the others)
            settle_faults(list(compress(seg_l, map(_IS_NONE, why_l))))
            why_l = list(map(_FAULT, seg_l))
    if seg_failed:
        why_l = None
    fig = None                  # the plans' (int_a2, time_t), where read in one pass
    if why_l is not None and why_l.count("") == n:
        # the common case: every row has a plan and every plan its verdict "" (settle_faults)
        bad_why = None
        fig = objfields.floats(seg_l, ("int_a2", "time_t"))
        a2 = np.fromiter(map(_INT_A2, seg_l), float, n) if fig is None else fig[:, 0]
    else:
        # seg_fault(seg): its verdict kept on the plan (settle_faults set it on most), else made
        if seg_failed:
            fail = seg_failed.get
            why_l = [fail(i) or ("" if seg is None else seg_fault(seg)) for i, seg in zip(idx_l, seg_l)]
        else:
            why_l = ["" if seg is None else f if (f := getattr(seg, "fault", None)) is not None else seg_fault(seg)
                     for seg in seg_l]
        # the figures of the fault-free plans only (the others' are not read: they may be anything)
        nan = math.nan
        a2 = np.array([nan if why or seg is None else seg.int_a2 for seg, why in zip(seg_l, why_l)], float)
        bad_why = np.fromiter(map(bool, why_l), bool, n)
    if a2_orig is None:
        a2_orig = np.fromiter(map(_INT_A2, map(strokes.__getitem__, idx_l)), float, n)
    # beats(a2_plan, a2_orig) elementwise (the same product and comparison of doubles); a
    # plan that is None has a2 = nan: it does not beat
    keep = a2 < a2_orig * (1.0 - GAIN_TOL_R)
    if bad_why is not None:
        keep &= ~bad_why
        if bad_why.any():
            rows = idx[bad_why]
            plan.retime[rows] = False
            reason = plan.reason
            for i, why in zip(rows.tolist(), [why for why in why_l if why]):
                reason[i] = why
        lost = ~bad_why & ~keep
    else:
        lost = ~keep
    if lost.any():
        rows = idx[lost]
        plan.retime[rows] = False
        plan.reason[rows] = _NOT_BEATING
    if keep.all():
        put, put_l, kept, a2_kept = idx, idx_l, seg_l, a2
        t_kept = None if fig is None else fig[:, 1]
    else:
        k = np.flatnonzero(keep)
        put = idx[k]
        put_l, kept, a2_kept = put.tolist(), list(map(seg_l.__getitem__, k.tolist())), a2[k]
        t_kept = None if fig is None else fig[k, 1]
    if not kept:
        return
    deque(map(plan.segs.__setitem__, put_l, kept), maxlen=0)     # plan.segs[i] = seg, in C
    plan.t_pred[put] = np.fromiter(map(_TIME_T, kept), float, len(kept)) if t_kept is None else t_kept
    plan.a2_pred[put] = a2_kept



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
    fault_r, none_r, lose_r, fresh_r = rng.uniform(0, 0.3, 4) * rng.integers(0, 2, 4)
    for i in idx.tolist():
        u = rng.uniform()
        if u < none_r:
            plan.segs[i] = None
            continue
        a2 = a2_orig[i] * (rng.uniform(1.0, 1.5) if rng.uniform() < lose_r else rng.uniform(0.2, 0.99))
        if rng.uniform() < fresh_r:           # a plan with no verdict yet (settle_faults, seg_fault find it)
            s = np.cumsum(rng.uniform(0.1, 1.0, 4))
            acc = np.array([1.0, 2.0, np.nan if rng.uniform() < fault_r else 3.0])
            plan.segs[i] = SegmentPlan(s, rng.uniform(0, 2, 4), acc, np.ones(3), float(rng.uniform(0, 1)), a2)
            continue
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
    for it in range(150):
        plan, idx, seg_failed, a2_orig = _random_case(rng, int(rng.integers(1, 60)))
        ref = _copy_plan(plan)
        # (the plans are shared: the first one called finds their verdicts, the second has them)
        if it % 2:
            _keep_made_plans_0b09fc6(ref, None, idx, seg_failed, a2_orig)
            schedule._keep_made_plans(plan, None, idx, seg_failed, a2_orig)
        else:
            schedule._keep_made_plans(plan, None, idx, seg_failed, a2_orig)
            _keep_made_plans_0b09fc6(ref, None, idx, seg_failed, a2_orig)
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
