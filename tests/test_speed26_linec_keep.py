"""Issue 8 (s26, "linec"): a budget run's per-row Python in schedule.run.

  _keep_plans       the segment plans put on the plan (faults, beats, figures) in a few
                    passes over the rows instead of one loop body a row;
  _attach_commands  asks only the strokes corners.py slowed with a junction command.

The reference is the loop the run made before (kept here verbatim as _keep_plans_old and
_attach_commands_old): random mixtures of plans (fine, faulty, None, failed, not beating,
not SegmentPlans) and real sample files through several budget runs, with and without
--corners, compared bit for bit."""
import math
import os
import types

import numpy as np
import pytest

from gcode_opt import pipeline, schedule
from gcode_opt.plan import Plan
from gcode_opt.profile import load_profile
from gcode_opt.schedule import _as_sliced, _command_for, beats, seg_fault, settle_faults
from gcode_opt.segments import RowPlan, SegmentPlan

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")


def _keep_plans_old(plan, strokes, idx, segs, seg_failed):
    """schedule.run's loop as it was (ad24489)."""
    idx_l = idx.tolist()
    settle_faults([segs.get(i) for i in idx_l])
    put, t_put, a2_put = [], [], []
    for i in idx_l:
        seg = segs.get(i)
        why = seg_failed.get(i) or ("" if seg is None else seg_fault(seg))
        if why:
            plan.retime[i] = False
            plan.reason[i] = why
            continue
        if seg is None or not beats(seg.int_a2, strokes[i].int_a2):
            plan.retime[i] = False
            plan.reason[i] = "segments would not beat the original"
            continue
        plan.segs[i] = seg
        put.append(i)
        t_put.append(seg.time_t)
        a2_put.append(seg.int_a2)
    plan.t_pred[put] = np.array(t_put, float)
    plan.a2_pred[put] = np.array(a2_put, float)


def _attach_commands_old(plan, strokes, pin, rules, cmd0=None):   # (cmd0: the current signature; read per stroke here)
    for i in np.flatnonzero(plan.retime).tolist():
        seg = plan.segs[i]
        if seg is not None and not _command_for(seg, strokes[i], rules):
            _as_sliced(plan, pin, i, "no junction command for its slower corner")


def _fresh_plan(n, rng):
    p = Plan(n)
    p.retime[:] = rng.random(n) < 0.8
    p.reason[:] = "retimed"
    p.segs = [None] * n
    p.t_pred = rng.random(n)
    p.a2_pred = rng.random(n)
    return p


def _random_seg(rng, kind):
    k = int(rng.integers(2, 7))
    s = np.cumsum(rng.random(k) + 0.1)
    v, a, f = rng.random(k) * 50, rng.random(k - 1) * 1000 + 1, rng.random(k - 1) * 50 + 1
    t, a2 = float(rng.random()), float(rng.random() * 100)
    if kind == 0:
        return SegmentPlan(s, v, a, f, t, a2)
    if kind == 1:                         # non-finite: a fault
        v[0] = np.nan
        return SegmentPlan(s, v, a, f, t, a2)
    if kind == 2:                         # knots not increasing
        return SegmentPlan(s[::-1].copy(), v, a, f, t, a2)
    if kind == 3:                         # rows of blocks
        S, V = np.stack([s, s + 1]), np.stack([v, v])
        A, F = np.stack([a, a]), np.stack([f, f])
        return RowPlan(S, V, A, F, int(rng.integers(0, 2)), t, a2)
    if kind == 4:                         # not a SegmentPlan (lists), no fault slot
        return types.SimpleNamespace(s=s.tolist(), v=v.tolist(), accel=a.tolist(), feed=f.tolist(), time_t=t,
                                     int_a2=a2)
    if kind == 5:                         # a verdict already kept
        p = SegmentPlan(s, v, a, f, t, a2)
        p.fault = "error: segments (kept)"
        return p
    return SegmentPlan(s, v, a, f, t, math.inf)       # fine arrays, a figure not finite


def _state(plan):
    return (plan.retime.tobytes(), plan.reason.tolist(), [id(s) for s in plan.segs],
            plan.t_pred.view(np.int64).tolist(), plan.a2_pred.view(np.int64).tolist())


@pytest.mark.parametrize("seed", range(16))
def test_keep_plans_random(seed):
    """seeds 12..15: every row a fine plan, no failure (_keep_plans' common path)."""
    rng = np.random.default_rng(seed)
    n = 300
    strokes = [types.SimpleNamespace(int_a2=float(x)) for x in rng.random(n) * 100]
    for q in range(0, n, 17):             # ties with a plan's figure: beats decides on rounding
        strokes[q].int_a2 = 50.0
    idx = np.sort(rng.choice(n, 200, replace=False))
    kinds = rng.integers(-1, 7, idx.size) if seed < 12 else rng.choice([0, 3], idx.size)
    made = {}
    for i, kd in zip(idx.tolist(), kinds.tolist()):
        if kd >= 0:
            made[i] = _random_seg(rng, kd)
            if i % 17 == 0 and kd in (0, 3):
                made[i].int_a2 = 50.0 * (1.0 - schedule.GAIN_TOL_R) * float(rng.choice([0.999999999, 1.0, 1.0000001]))
    failed = {} if seed % 3 == 0 or seed >= 12 else {i: f"error: segments (x{i})" for i in idx[::7].tolist()}
    if seed % 4 == 1 and seed < 12:       # a failed row that also has a plan
        failed[int(idx[1])] = "error: segments (both)"
        made.setdefault(int(idx[1]), _random_seg(rng, 0))
    old, new = _fresh_plan(n, np.random.default_rng(seed)), _fresh_plan(n, np.random.default_rng(seed))
    segs_old = {i: _copy(s) for i, s in made.items()}
    _keep_plans_old(old, strokes, idx, segs_old, failed)
    schedule._keep_plans(new, strokes, idx, list(map(made.get, idx.tolist())), failed)    # (its plans by idx)
    if seed >= 12:                        # (their verdicts are made: the common path is taken)
        settle_faults(list(made.values()))
        assert all(s.fault == "" for s in made.values())
    o, w = _state(old), _state(new)
    assert o[0] == w[0] and o[1] == w[1] and o[3] == w[3] and o[4] == w[4]
    # the same plans kept (the copies made for the old path, row for row)
    back = {id(s): i for i, s in segs_old.items()}
    assert [back.get(k) for k in o[2]] == [None if s is None else i for i, s in enumerate(new.segs)]
    assert [None if s is None else getattr(s, "fault", "x") for s in segs_old.values()] == \
           [None if s is None else getattr(s, "fault", "x") for s in made.values()]


def _copy(s):
    if isinstance(s, RowPlan):
        c = RowPlan(s._s, s._v, s._accel, s._feed, s._row, s.time_t, s.int_a2)
    elif isinstance(s, SegmentPlan):
        c = SegmentPlan(s.s, s.v, s.accel, s.feed, s.time_t, s.int_a2)
    else:
        return types.SimpleNamespace(**vars(s))
    c.fault = s.fault
    return c


def _plan_figures(p):
    segs = [None if s is None else (np.asarray(s.s, float).tobytes(), np.asarray(s.v, float).tobytes(),
                                    np.asarray(s.accel, float).tobytes(), np.asarray(s.feed, float).tobytes(),
                                    s.time_t, s.int_a2, s.first_cmds, seg_fault(s)) for s in p.segs]
    return (p.retime.tobytes(), p.reason.tolist(), p.T.tobytes(), p.beta.tobytes(), p.t_pred.tobytes(),
            p.a2_pred.tobytes(), segs)


def _keep_plans_old_of_list(plan, strokes, idx, seg_l, failed, idx_l=None, a2_orig=None, in_place=False):
    """_keep_plans_old called as the run calls _keep_plans now (its plans by row; in_place:
    they are in plan.segs already, where the old loop put the kept ones on rows of None)."""
    if in_place:
        for i in idx.tolist():
            plan.segs[i] = None
    _keep_plans_old(plan, strokes, idx, dict(zip(idx.tolist(), seg_l)), failed)


def _runs(name, prof, corners, monkeypatch, old, budgets=(1.0, 0.6, 0.61, 1.3)):
    if old:
        monkeypatch.setattr(schedule, "_keep_plans", _keep_plans_old_of_list)
        monkeypatch.setattr(schedule, "_attach_commands", _attach_commands_old)
    profile = load_profile(prof)
    opts = pipeline.Options(corner_budget_r=corners)
    opts.ringing = False
    strokes, sim0 = pipeline.analyse(os.path.join(SAMPLES, name), profile, opts)
    pin = schedule.plan_inputs(strokes, profile, opts)
    runs = []

    def fit(run, pin_, budget_t):
        for r in budgets:
            p = run(r * budget_t)
            runs.append(_plan_figures(p))
        return p
    monkeypatch.setattr(schedule, "_fit_budget", fit)
    schedule.plan_strokes(strokes, pin, profile, opts, opts.max_slowdown_r * sim0.time_t)
    monkeypatch.undo()
    return runs, sum(bool(s.corner_cmd0) for s in strokes)


@pytest.mark.parametrize("name,prof,corners", [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 0.0),
                                               ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 0.3),
                                               ("prusa_gyroid_fullspeed_klipper.gcode", "voron24", 0.3)])
def test_budget_runs_as_before(name, prof, corners, monkeypatch):
    old, n_cmd_old = _runs(name, prof, corners, monkeypatch, True)
    new, n_cmd = _runs(name, prof, corners, monkeypatch, False)
    assert n_cmd == n_cmd_old
    if corners:
        assert n_cmd > 0                  # the commands' path is taken
    assert len(old) == len(new) == 4
    for a, b in zip(old, new):
        assert a == b
    # each run keeps plans and leaves some strokes as sliced for not beating the original
    assert any(s is not None for s in new[0][6])
