"""Issue 8, stop 18 (D8): schedule.plan_strokes reads each stroke's plan kind once (from
_rows_by_kind) for all its re-plans, instead of calling chains.plan_kind per re-timed
stroke in each; its per-stroke loop settles the plans' fault verdicts at once
(settle_faults) and sets the kept plans' figures in one go.  The plans must be those of
9bb98a8's plan_strokes, copied below (with 9bb98a8's _seg_fault).  That holds because nothing in plan_strokes changes a stroke's kind
(only plan_inputs' chains.classify marks chains): checked here on files with lines, arcs,
curves and chains (the plans themselves are compared with 9bb98a8's outputs by the
reference set of the session's check).""" 
import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt import schedule as sc
from gcode_opt.pipeline import Options, analyse
from gcode_opt.plan import isolate, plan_auto
from gcode_opt.profile import load_profile
from gcode_opt.segments import SegmentRules
from test_speed_plan3_faults import _old_seg_fault

S = "sample_gcode/"


def _digest(plan):
    out = [plan.T.tobytes(), plan.beta.tobytes(), plan.retime.tobytes(), plan.t_pred.tobytes(),
           plan.a2_pred.tobytes(), repr(list(plan.reason))]
    for seg in plan.segs:
        out.append(None if seg is None else (seg.s.tobytes(), seg.v.tobytes(), np.asarray(seg.accel).tobytes(),
                                             np.asarray(seg.feed).tobytes(), repr((seg.time_t, seg.int_a2))))
    return out


@pytest.mark.parametrize("name,profile", [
    ("prusa_gyroid.gcode", "prusa-mk3s"),
    pytest.param("prusa_gyroid_arcs.gcode", "prusa-mk3s", marks=pytest.mark.slow),
    pytest.param("prusa_gyroid_fullspeed_klipper.gcode", "voron24", marks=pytest.mark.slow)])
def test_kinds_stable_during_plan_strokes(name, profile):
    prof = load_profile(profile)
    opts = Options()

    def planned():
        strokes, sim = analyse(S + name, prof, opts)
        pin = sc.plan_inputs(strokes, prof, opts)
        before = [chains.plan_kind(st) for st in strokes]
        plan = sc.plan_strokes(strokes, pin, prof, opts, opts.max_slowdown_r * sim.time_t)
        assert [chains.plan_kind(st) for st in strokes] == before
        return plan, before

    plan, kinds = planned()
    assert {"line", "curve"} <= set(kinds)
    again, _ = planned()
    assert _digest(again) == _digest(plan)


def _old_plan_strokes(strokes, pin, profile, opts, budget_t):
    rules = SegmentRules.for_profile(profile, opts.max_segments)
    rows = sc._rows_by_kind(strokes)
    cached = getattr(pin, "cached", None)
    if cached is None:
        fault = getattr(pin, "fault", None)
        failed = {} if fault is None else {i: str(r) for i, r in enumerate(fault) if r}
        cands, fixed = sc._candidates(strokes, pin, profile, opts, rows, failed) if len(strokes) else (None, None)
        cached = pin.cached = (cands, fixed, failed)
    cands, fixed, failed = cached
    failed_rows = np.array(sorted(failed), int)
    seg_cache = getattr(pin, "seg_cache", None)
    if seg_cache is None:
        seg_cache = pin.seg_cache = sc.SegmentCache()
    groups = [np.setdiff1d(np.concatenate([rows[k] for k in sc.KINDS]), failed_rows)]

    def run(budget):
        plan = plan_auto(pin, budget, cands, groups) if opts.alpha == "auto" else fixed.copy()
        plan.retime[failed_rows] = False
        for i in failed_rows:
            plan.reason[i] = failed[i]
        bad = sc._plan_fault(plan)
        plan.retime[bad] = False
        plan.reason[bad] = "error: planning (non-finite)"
        plan.segs = [None] * len(strokes)
        plan.t_pred = pin.T_orig.copy()
        plan.a2_pred = pin.I_orig.copy()
        idx = np.flatnonzero(plan.retime)
        kind = np.array([chains.plan_kind(strokes[i]) for i in idx], dtype=object)
        sc._rebuild_geometry(strokes, idx, np.array([sc.KIND_CODE[k] for k in kind], np.int8), profile)
        segs = {}
        seg_failed = {}
        for k_name, kind_of in sc.KINDS.items():
            fn = (lambda k: lambda sts, T, b: k.segments(sts, T, b, rules, profile))(kind_of)
            ii = idx[kind == k_name]
            got, bad = seg_cache.lookup(k_name, ii, plan.T, plan.beta)
            segs.update(got)
            seg_failed.update(bad)
            todo = np.array([i for i in ii.tolist() if i not in got and i not in bad], int)
            new, new_bad = {}, {}
            for sub, res in isolate(lambda r: fn([strokes[i] for i in r], plan.T[r], plan.beta[r]),
                                    todo, "segments", new_bad):
                new.update(zip(sub.tolist(), res))
            seg_cache.store(k_name, todo, plan.T, plan.beta, list(map(new.get, range(len(strokes)))), new_bad)  # (by row)
            segs.update(new)
            seg_failed.update(new_bad)
        for i in idx:
            seg = segs.get(int(i))
            why = seg_failed.get(int(i)) or ("" if seg is None else _old_seg_fault(seg))
            if why:
                plan.retime[i] = False
                plan.reason[i] = why
                continue
            if seg is None or not sc.beats(seg.int_a2, strokes[i].int_a2):
                plan.retime[i] = False
                plan.reason[i] = "segments would not beat the original"
                continue
            plan.segs[i] = seg
            plan.t_pred[i], plan.a2_pred[i] = seg.time_t, seg.int_a2
        sc._attach_commands(plan, strokes, pin, rules)
        sc._keep_slowed_corners(plan, strokes, rules)
        sc._lead_out_where_no_command(plan, strokes, pin, rules, seg_cache)
        return plan

    if opts.alpha != "auto":
        return run(budget_t)
    return sc._fit_budget(run, pin, budget_t)


@pytest.mark.parametrize("name,profile,alpha,corners", [
    ("prusa_gyroid.gcode", "prusa-mk3s", "auto", 0.0),
    pytest.param("prusa_gyroid_arcs.gcode", "prusa-mk3s", "auto", 0.0, marks=pytest.mark.slow),
    pytest.param("prusa_gyroid_fullspeed_klipper.gcode", "voron24", "auto", 0.0, marks=pytest.mark.slow),
    ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", "auto", 0.05),
    ("prusa_gyroid.gcode", "ender3", "0.0002", 0.0)])
def test_same_plans_as_9bb98a8(name, profile, alpha, corners):
    prof = load_profile(profile)
    opts = Options()
    opts.alpha, opts.corner_budget_r = alpha, corners
    plans = []
    for fn in (sc.plan_strokes, _old_plan_strokes):
        strokes, sim = analyse(S + name, prof, opts)
        pin = sc.plan_inputs(strokes, prof, opts)
        plans.append(_digest(fn(strokes, pin, prof, opts, opts.max_slowdown_r * sim.time_t)))
    assert plans[0] == plans[1]
    assert sum(x is not None for x in plans[0][6:]) > 10        # plans were written
