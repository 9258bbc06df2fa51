"""plan_windows.planned_strokes' plan_inputs (issue 8, inputs56): PIN_ROWS strokes a
plan_inputs call (a window if larger), not a window: the same PlanInput as the list's one
call, bit for bit; the strokes made at once during it that many at most."""
import math
import os

import numpy as np
import pytest

from gcode_opt import pipeline, plan_windows, schedule
from gcode_opt.profile import load_profile
from gcode_opt.stroke_store import StrokeStore

SAMPLES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "sample_gcode")


def _same_pin(got, want):
    assert sorted(vars(got)) == sorted(vars(want))
    for k, v in vars(want).items():
        g = getattr(got, k)
        if isinstance(v, np.ndarray):
            assert g.dtype == v.dtype and g.tobytes() == v.tobytes(), k
        else:
            assert g == v, k


@pytest.mark.parametrize("window,pin_rows", [(7, None), (7, 150), (600, 150)])
def test_planned_inputs_in_pin_rows_calls(monkeypatch, window, pin_rows):
    prof = load_profile("prusa-mk3s")
    opts = pipeline.Options(alpha=0.5)        # (no candidates: they change the PlanInput after)
    path = os.path.join(SAMPLES, "prusa_gyroid_arcs.gcode")
    want = schedule.plan_inputs(pipeline.analyse(path, prof, opts)[0], prof, opts)
    if pin_rows is None:                        # (the default: the sample in one call)
        pin_rows = plan_windows.PIN_ROWS
    monkeypatch.setattr(plan_windows, "PIN_ROWS", pin_rows)
    calls, made = [], {"pin": 0, "rest": 0}
    real_pin, real_take = schedule.plan_inputs, StrokeStore.take

    def counted_pin(sts, *a, **k):
        calls.append(len(sts))
        return real_pin(sts, *a, **k)

    def counted_take(self, rows, over=None):
        got = real_take(self, rows, over)
        key = "pin" if made.get("in_pin") else "rest"
        made[key] = max(made[key], len(got))
        return got
    real_windowed = plan_windows.plan_inputs_windowed

    def flagged(*a):
        made["in_pin"] = True
        try:
            return real_windowed(*a)
        finally:
            made["in_pin"] = False
    monkeypatch.setattr(schedule, "plan_inputs", counted_pin)
    monkeypatch.setattr(StrokeStore, "take", counted_take)
    monkeypatch.setattr(plan_windows, "plan_inputs_windowed", flagged)
    with StrokeStore() as store:
        store.append(pipeline.analyse(path, prof, opts)[0])
        n = len(store)
        got, strokes = plan_windows.planned_strokes(store, prof, opts, window)
        strokes.let_go()
    rows = max(window, pin_rows)
    assert n > 2 * rows or rows == plan_windows.PIN_ROWS >= n
    assert calls == [rows] * (n // rows) + ([n % rows] if n % rows else [])
    assert len(calls) == math.ceil(n / rows)
    assert made["pin"] == min(rows, n) and made["rest"] == 0
    _same_pin(got, want)
