"""The steps after the passes hold only what the summary reads (issue 8, memory, s54 tail54):
once the rewrite+measure passes are over, the last pass's firmware-model Ledger, its watched
output lines (LineRanges) and the written file's ringing Collector are let go before the
summary's columns are made (StrokeColumns.add_fields) and the summary is built: on the
rectilinear plate, windowed, ~8 MB of heap the summary's peak was made on top of.  Checked on
a real sample, the list path and windowed (one pass, and a second pass: remeasure), compiled
and pure: no such object alive at either step, and the summary the same."""
import gc
import json
import os

import pytest

from gcode_opt import pipeline, summary
from gcode_opt import ringing as rg
from gcode_opt.firmware import simulate as fwsim
from gcode_opt.profile import load_profile
from gcode_opt.stroke_columns import StrokeColumns

SAMPLES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "sample_gcode")
VOLATILE = ("timing_s", "elapsed_s", "output")
DEAD = (fwsim.Ledger, fwsim.LineRanges, rg.Collector)


def _alive():
    """Names of the DEAD kinds with an instance alive now."""
    gc.collect()
    return sorted({type(o).__name__ for o in gc.get_objects() if type(o) in DEAD})


def _run(monkeypatch, tmp_path, name, prof, window):
    """(the summary as JSON reads it, but VOLATILE; {step: DEAD kinds alive at its start})."""
    if window is None:
        monkeypatch.delenv("GCODE_OPT_WINDOWED", raising=False)
    else:
        monkeypatch.setenv("GCODE_OPT_WINDOWED", "1")
        monkeypatch.setenv("GCODE_OPT_WINDOW", str(window))
    seen = {}
    add_fields, build = StrokeColumns.add_fields, summary.build_summary

    def watched_add_fields(self, strokes):
        seen["add_fields"] = _alive()
        return add_fields(self, strokes)

    def watched_build(*a, **k):
        seen["build_summary"] = _alive()
        return build(*a, **k)
    monkeypatch.setattr(StrokeColumns, "add_fields", watched_add_fields)
    monkeypatch.setattr(summary, "build_summary", watched_build)
    opts = pipeline.Options()
    opts.summary_rows = "table"                # (the command line's --json)
    out = tmp_path / f"{name}.{window}.gcode"
    s = pipeline.process(os.path.join(SAMPLES, name), str(out), load_profile(prof), opts)
    s = json.loads(json.dumps({k: v for k, v in s.items() if k not in VOLATILE},
                              default=lambda v: list(v) if isinstance(v, summary.StrokeRows) else str(v)))
    return s, seen


@pytest.mark.parametrize("name,prof,passes", [("prusa_gyroid.gcode", "prusa-mk3s", 1),
                                              ("prusa_benchy_like.gcode", "prusa-mk3s", 2)])
def test_passes_state_is_gone_before_the_summary(monkeypatch, tmp_path, name, prof, passes):
    want = None
    for window in (None, 64):
        s, seen = _run(monkeypatch, tmp_path, name, prof, window)
        assert s["rewrite_passes"] == passes and "ringing" in s
        assert seen == {"add_fields": [], "build_summary": []}
        if want is None:
            want = s
        else:
            assert s == want                   # (windowed: the list path's summary)
