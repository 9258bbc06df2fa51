"""Issue 8, session 35 (budget): the budget runs write each row's segment plan into
plan.segs as it is found or made (no {row: plan} dicts), decide the rows KEEP_ROWS at a
time (_keep_made_plans) with the strokes' int_a2 read from pin.I_orig, put the last run's
plans (_RunMemo.put_same) and store the lines' (SegmentCache.store) PUT_ROWS at a time,
know the alloc memo by the objects it was made of, and take the plan kinds plan_inputs
found (pin.plan_kind_codes).  Each is a change of bookkeeping: the same plans, run by run."""
import os

import numpy as np
import pytest

from gcode_opt import pipeline, schedule
from gcode_opt.profile import load_profile

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")


def _analysed(name, prof, corners=0.0):
    profile = load_profile(prof)
    opts = pipeline.Options(corner_budget_r=corners)
    opts.ringing = False
    strokes, sim0 = pipeline.analyse(os.path.join(SAMPLES, name), profile, opts)
    return strokes, sim0, profile, opts


def _figures(p):
    segs = [None if s is None else (type(s).__name__, s.s.tobytes(), s.v.tobytes(), s.accel.tobytes(),
                                    s.feed.tobytes(), s.time_t, s.int_a2, s.first_cmds, schedule.seg_fault(s))
            for s in p.segs]
    return (p.retime.tobytes(), p.reason.tolist(), p.T.tobytes(), p.beta.tobytes(), p.t_pred.tobytes(),
            p.a2_pred.tobytes(), segs)


def _runs(name, prof, corners, monkeypatch, budgets=(1.0, 0.6, 0.61, 1.3, 1.0)):
    """Each budget run's plan figures (back and forth: the caches' and the last run's reuse)."""
    strokes, sim0, profile, opts = _analysed(name, prof, corners)
    pin = schedule.plan_inputs(strokes, profile, opts)
    runs = []

    def fit(run, pin_, budget_t):
        for r in budgets:
            p = run(r * budget_t)
            runs.append(_figures(p))
        return p
    monkeypatch.setattr(schedule, "_fit_budget", fit)
    schedule.plan_strokes(strokes, pin, profile, opts, opts.max_slowdown_r * sim0.time_t)
    return runs


@pytest.mark.parametrize("name,prof,corners", [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 0.0),
                                               ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 0.3),
                                               ("prusa_gyroid.gcode", "prusa-mk3s", 0.0),
                                               ("prusa_gyroid_fullspeed_klipper.gcode", "voron24", 0.3)])
def test_chunked_bookkeeping_gives_the_same_runs(name, prof, corners, monkeypatch):
    """Chunks of a few rows (every chunk boundary crossed many times) and one chunk for all
    the rows (these samples' runs have fewer than the defaults): the same plans."""
    with monkeypatch.context() as m:
        m.setattr(schedule, "KEEP_ROWS", 7)
        m.setattr(schedule, "PUT_ROWS", 5)
        small = _runs(name, prof, corners, m)
    with monkeypatch.context() as m:
        m.setattr(schedule, "KEEP_ROWS", 1 << 30)
        m.setattr(schedule, "PUT_ROWS", 1 << 30)
        whole = _runs(name, prof, corners, m)
    assert len(small) == len(whole) == 5
    for a, b in zip(small, whole):
        assert a == b
    assert sum(s is not None for s in whole[0][6]) > 100       # plans were kept
    assert whole[0][2] != whole[1][2]                           # the runs' laws differ


def test_pin_holds_what_the_runs_read_of_the_strokes():
    """The runs take each stroke's plan kind and int_a2 from pin (plan_inputs): the same as
    the strokes' own after it, bit for bit."""
    for name, prof in (("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s")):
        strokes, _, profile, opts = _analysed(name, prof)
        pin = schedule.plan_inputs(strokes, profile, opts)
        assert pin.plan_kind_codes.tobytes() == schedule.plan_kind_codes(strokes).tobytes()
        a2 = np.array([st.int_a2 for st in strokes], float)
        assert pin.I_orig.tobytes() == a2.tobytes()
        assert schedule._plan_kind_codes_of(strokes, pin) is pin.plan_kind_codes
        assert schedule._plan_kind_codes_of(strokes[:-1], pin) is not pin.plan_kind_codes    # (another list: made anew)


def test_alloc_memo_known_by_its_objects():
    """plan._AllocMemo: reused for the same group array, p and cands (the budget runs), made
    anew for another array (even an equal one) or another p; each entry holds what it was
    made of (their ids are not taken by other objects while it lives)."""
    from gcode_opt import plan as plan_mod
    strokes, sim0, profile, opts = _analysed("prusa_mk3s_rectilinear.gcode", "prusa-mk3s")
    pin = schedule.plan_inputs(strokes, profile, opts)
    budget = opts.max_slowdown_r * sim0.time_t
    schedule.plan_strokes(strokes, pin, profile, opts, budget)
    cands = pin.cached[0]
    g = np.arange(len(strokes))
    memo = {}
    first = plan_mod.plan_auto(pin, budget, cands, [g], memo)
    (key, m), = [(k, v) for k, v in memo.items() if isinstance(k, tuple)]
    assert m.made_of[0] is g and m.made_of[1] is pin and m.made_of[2] is cands
    again = plan_mod.plan_auto(pin, 0.5 * budget, cands, [g], memo)
    assert [v for k, v in memo.items() if isinstance(k, tuple)] == [m]           # reused
    plan_mod.plan_auto(pin, budget, cands, [g.copy()], memo)
    assert len([k for k in memo if isinstance(k, tuple)]) == 2                    # another array: made anew
    fresh = plan_mod.plan_auto(pin, 0.5 * budget, cands, [g])
    assert again.T.tobytes() == fresh.T.tobytes() and (again.reason == fresh.reason).all()
    assert first.retime.any()
