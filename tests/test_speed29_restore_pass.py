"""The second rewrite pass when the firmware model departs from a stroke's plan (pipeline._process):
the departed strokes go back to their lines; where that alone brings the written file within the
time budget (or the laws are fixed, --alpha A: a re-plan would make the same plans) the first
pass's plan is kept without them -- no second plan -- and its other blocks are copied; otherwise the
budget is lowered by 1.2 x the overrun that is left once the departed strokes give theirs back.

Real files: the bundled MK3S benchy (PrusaSlicer) under voron24 with its intro line selected
(`custom`): Klipper plays the re-timed intro line far slower than its plan (a purge line whose
gentle ramps the lookahead cannot use), and putting it back alone brings the file within the budget.
Checked by independent means: the firmware model played afresh on the written file (its time is
the summary's), verify's invariants (toolpath, filament, untouched lines), the departed stroke's
lines copied byte for byte."""
import os

import pytest

from gcode_opt import pipeline
from gcode_opt.firmware.simulate import simulate_file
from gcode_opt.profile import load_profile
from gcode_opt.verify import verify

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")
DEPARTED = "firmware model departs from the plan"


def _run(tmp_path, monkeypatch, name, prof, **kw):
    calls = []
    real = pipeline.plan_strokes

    def counted(*a, **k):
        calls.append(a[4])                # the budget each plan was made for
        return real(*a, **k)
    monkeypatch.setattr(pipeline, "plan_strokes", counted)
    src = os.path.join(SAMPLES, name)
    out = tmp_path / ("out_" + name)
    opts = pipeline.Options(features=("custom", "sparse_infill", "solid_infill"), **kw)
    opts.ringing = False
    profile = load_profile(prof)
    summary = pipeline.process(src, str(out), profile, opts)
    return src, str(out), profile, summary, calls


def _intro_lines(path):
    with open(path, encoding="utf-8") as fh:
        return [ln for ln in fh if "intro line" in ln]


def test_departed_stroke_restored_without_a_second_plan(tmp_path, monkeypatch):
    src, out, profile, s, calls = _run(tmp_path, monkeypatch, "prusa_benchy_like.gcode", "voron24")
    assert s["rewrite_passes"] == 2
    assert s["strokes"]["not_retimed"].get(DEPARTED) == 1
    assert len(calls) == 1                                  # the first pass's plan, kept
    # the intro line as sliced, byte for byte; every invariant of the file holds
    assert _intro_lines(out) == _intro_lines(src)
    verify(src, out, profile)
    # the figures are the written file's, played afresh by the firmware model
    fresh = simulate_file(out, profile)
    assert fresh.time_t == pytest.approx(s["print_time_s"]["after"], rel=1e-12)
    # within the budget the pipeline holds (0.05 % of the print over, as for a first pass)
    assert s["print_time_s"]["change"] <= s["options"]["max_slowdown"] + 5e-4


def test_fixed_alpha_restores_without_a_second_plan(tmp_path, monkeypatch):
    src, out, profile, s, calls = _run(tmp_path, monkeypatch, "prusa_benchy_like.gcode", "voron24", alpha=0.5)
    assert s["strokes"]["not_retimed"].get(DEPARTED) == 1
    assert len(calls) == 1 and s["rewrite_passes"] == 2
    assert _intro_lines(out) == _intro_lines(src)
    verify(src, out, profile)
    assert simulate_file(out, profile).time_t == pytest.approx(s["print_time_s"]["after"], rel=1e-12)


def test_overrun_left_after_restoring_is_replanned(tmp_path, monkeypatch):
    # the absolute-E sample: putting the intro line back leaves the file over the budget, so
    # the budget is re-planned, lowered by 1.2 x what is left (not by the whole overrun)
    first = []
    real = pipeline.measure

    def measured(*a, **k):
        got = real(*a, **k)
        first.append(got[0].time_t)
        return got
    monkeypatch.setattr(pipeline, "measure", measured)
    src, out, profile, s, calls = _run(tmp_path, monkeypatch, "prusa_absolute_e.gcode", "voron24")
    assert s["strokes"]["not_retimed"].get(DEPARTED) == 1
    assert len(calls) == 2 and len(first) == 1
    before = s["print_time_s"]["before"]
    whole_over = (first[0] - before) - s["options"]["max_slowdown"] * before
    lowered = calls[0] - calls[1]
    assert 0 < lowered < 1.2 * whole_over * 0.9     # the departed stroke's share was not taken off
    assert s["print_time_s"]["change"] <= s["options"]["max_slowdown"] + 5e-4
    verify(src, out, profile)
