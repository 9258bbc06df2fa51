"""Planning runs with the cyclic garbage collector paused, and leaves it as it found it."""
import contextlib
import gc
import os

import pytest

from gcode_opt import pipeline, schedule
from gcode_opt.profile import load_profile

SAMPLE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "sample_gcode", "prusa_gyroid.gcode")


def _plan(profile, opts):
    strokes, sim0 = pipeline.analyse(SAMPLE, profile, opts)
    pin = schedule.plan_inputs(strokes, profile, opts)
    return strokes, pin, schedule.plan_strokes(strokes, pin, profile, opts, opts.max_slowdown_r * sim0.time_t)


def _collections_inside(monkeypatch, paused=True):
    """(collections that started inside planning's bodies, the plan) on the gyroid sample."""
    profile = load_profile("prusa-mk3s")
    opts = pipeline.Options()
    opts.ringing = False
    strokes, sim0 = pipeline.analyse(SAMPLE, profile, opts)
    inside, runs = [False], []
    for name in ("_plan_inputs", "_plan_strokes"):
        body = getattr(schedule, name)

        def marked(*a, _body=body, **k):
            inside[0] = True
            try:
                return _body(*a, **k)
            finally:
                inside[0] = False
        monkeypatch.setattr(schedule, name, marked)
    if not paused:                        # the reference: the collector left running
        monkeypatch.setattr(schedule, "_gc_paused", lambda: contextlib.nullcontext())

    def cb(phase, info):
        if phase == "start" and inside[0]:
            runs.append(info["generation"])
    gc.callbacks.append(cb)
    threshold = gc.get_threshold()
    gc.set_threshold(100, 10, 10)         # a small sample: collections as often as on a plate
    try:
        pin = schedule.plan_inputs(strokes, profile, opts)
        plan = schedule.plan_strokes(strokes, pin, profile, opts, opts.max_slowdown_r * sim0.time_t)
    finally:
        gc.set_threshold(*threshold)
        gc.callbacks.remove(cb)
    return runs, plan


def test_no_collection_while_planning_and_gc_enabled_after(monkeypatch):
    assert gc.isenabled()
    runs, plan = _collections_inside(monkeypatch)
    assert runs == []
    assert gc.isenabled()
    assert plan.retime.sum() > 100        # it did plan
    ref, plan_ref = _collections_inside(monkeypatch, paused=False)
    assert len(ref) > 10                  # what pausing saves: the collector ran dozens of times
    assert (plan.retime == plan_ref.retime).all() and (plan.T == plan_ref.T).all()


def test_a_collector_turned_off_stays_off_and_an_error_restores_it(monkeypatch):
    gc.disable()
    try:
        with schedule._gc_paused():
            assert not gc.isenabled()
        assert not gc.isenabled()
    finally:
        gc.enable()

    def boom(*a, **k):
        assert not gc.isenabled()
        raise RuntimeError("planning failed")
    monkeypatch.setattr(schedule, "_plan_strokes", boom)
    with pytest.raises(RuntimeError):
        schedule.plan_strokes([], None, None, None, 0.0)
    assert gc.isenabled()
