"""process() plans with the cyclic garbage collector off (pipeline._young_frozen around
plan_inputs and plan_strokes), and leaves it as it found it."""
import contextlib
import gc
import os

import pytest

from gcode_opt import pipeline, schedule
from gcode_opt.profile import load_profile

SAMPLE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "sample_gcode", "prusa_gyroid.gcode")


def _collections_inside(monkeypatch, tmp_path, paused=True):
    """(collections that started inside planning, the written bytes) of process() on the
    gyroid sample."""
    inside, runs = [False], []
    for name in ("plan_inputs", "plan_strokes"):
        body = getattr(pipeline, name)

        def marked(*a, _body=body, **k):
            inside[0] = True
            try:
                return _body(*a, **k)
            finally:
                inside[0] = False
        monkeypatch.setattr(pipeline, name, marked)
    if not paused:                        # the reference: the collector left running
        monkeypatch.setattr(pipeline, "_young_frozen", lambda freeze: contextlib.nullcontext())

    def cb(phase, info):
        if phase == "start" and inside[0]:
            runs.append(info["generation"])
    gc.callbacks.append(cb)
    threshold = gc.get_threshold()
    gc.set_threshold(100, 10, 10)         # a small sample: collections as often as on a plate
    out = tmp_path / ("paused.gcode" if paused else "running.gcode")
    try:
        opts = pipeline.Options()
        opts.ringing = False
        pipeline.process(SAMPLE, str(out), load_profile("prusa-mk3s"), opts)
    finally:
        gc.set_threshold(*threshold)
        gc.callbacks.remove(cb)
        monkeypatch.undo()
    return runs, out.read_bytes()


def test_no_collection_while_planning_and_gc_enabled_after(monkeypatch, tmp_path):
    assert gc.isenabled()
    runs, written = _collections_inside(monkeypatch, tmp_path)
    assert runs == []
    assert gc.isenabled() and gc.get_freeze_count() == 0
    assert b"gcode-opt begin" in written  # it did plan and re-time
    ref, written_ref = _collections_inside(monkeypatch, tmp_path, paused=False)
    assert len(ref) > 10                  # what pausing saves: the collector ran dozens of times
    assert written == written_ref


def test_a_collector_turned_off_stays_off_and_an_error_restores_it(monkeypatch, tmp_path):
    opts = pipeline.Options()
    opts.ringing = False
    gc.disable()
    try:
        with pipeline._young_frozen(lambda: None):
            assert not gc.isenabled()
        assert not gc.isenabled()
        pipeline.process(SAMPLE, str(tmp_path / "off.gcode"), load_profile("prusa-mk3s"), opts)
        assert not gc.isenabled()
    finally:
        gc.enable()

    def boom(*a, **k):
        assert not gc.isenabled()
        raise RuntimeError("planning failed")
    monkeypatch.setattr(pipeline, "plan_strokes", boom)
    with pytest.raises(RuntimeError):
        pipeline.process(SAMPLE, str(tmp_path / "boom.gcode"), load_profile("prusa-mk3s"), opts)
    assert gc.isenabled() and gc.get_freeze_count() == 0
    assert not (tmp_path / "boom.gcode").exists()      # a failed run leaves no output


def test_planning_alone_leaves_the_collector_as_it_was():
    # plan_inputs / plan_strokes themselves do not touch the collector (process() does)
    profile = load_profile("prusa-mk3s")
    opts = pipeline.Options()
    opts.ringing = False
    strokes, sim0 = pipeline.analyse(SAMPLE, profile, opts)
    pin = schedule.plan_inputs(strokes, profile, opts)
    plan = schedule.plan_strokes(strokes, pin, profile, opts, opts.max_slowdown_r * sim0.time_t)
    assert gc.isenabled() and plan.retime.sum() > 100
