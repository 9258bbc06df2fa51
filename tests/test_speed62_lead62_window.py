"""The windowed pipeline's planning window follows the file's curves where GCODE_OPT_WINDOW is
unset (plan_windows.window_for, issue 8, benchmarks/lead62.md): a file of few curves and
chains is planned in windows of up to MAX_WINDOW strokes, one of many keeps WINDOW.  The
written file is the list path's either way (analyse's geometry records, kept by its own
windows, are given back by rows)."""
import json
import os

import numpy as np
import pytest

from gcode_opt import pipeline, plan_windows, stored_strokes
from gcode_opt.profile import load_profile
from gcode_opt.schedule import C_CHAIN, C_CURVE, C_LINE

from test_speed53_wire53_windowed import SAMPLES, VOLATILE, _run


def _codes(lines, curves, chains):
    return np.array([C_LINE] * lines + [C_CURVE] * curves + [C_CHAIN] * chains, np.int8)


def test_window_for_the_files_curves():
    w, top, heavy = plan_windows.WINDOW, plan_windows.MAX_WINDOW, plan_windows.HEAVY_ROWS
    # the gyroid plate's make-up (13.8 k lines, 4.9 k curves, 16.4 k chains): its window kept
    assert plan_windows.window_for(w, _codes(13774, 4865, 16379)) == w
    # the rectilinear plate's (48.6 k lines, 3.2 k curves, 32 chains): the largest
    assert plan_windows.window_for(w, _codes(48625, 3221, 32)) == top
    assert plan_windows.window_for(w, _codes(5000, 0, 0)) == top           # no curve at all
    assert plan_windows.window_for(w, _codes(0, 0, 0)) == top
    # in between: HEAVY_ROWS curves and chains at the file's share
    n, k = 100 * heavy, 40
    got = plan_windows.window_for(16, _codes(n - k, k // 2, k - k // 2))
    assert got == min(top, heavy * n // k) and 16 < got <= top
    assert plan_windows.window_for(top + 5, _codes(10, 10, 10)) == top + 5   # (a larger one kept)


def test_window_fixed_by_the_environment(monkeypatch):
    monkeypatch.delenv("GCODE_OPT_WINDOW", raising=False)
    assert not plan_windows.window_fixed()
    monkeypatch.setenv("GCODE_OPT_WINDOW", "37")
    assert plan_windows.window_fixed()


@pytest.mark.parametrize("name,prof,large", [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", True),
                                             ("prusa_gyroid.gcode", "prusa-mk3s", False)])
def test_adapted_window_writes_the_list_paths_file(monkeypatch, tmp_path, name, prof, large):
    """Windows of 16 strokes, up to 64 with 2 curves and chains a window (the module's
    constants made small, GCODE_OPT_WINDOW unset): the rectilinear sample (no curve) takes
    64, the gyroid sample (161 curves and chains of 1 321 strokes: 2 a window at 16) keeps
    16; both write the list path's file and summary."""
    want = _run(monkeypatch, tmp_path, name, prof)
    seen = []
    made = stored_strokes.StoredStrokes.__init__

    def spied(self, store, window=4096, *a, **k):
        seen.append(int(window))
        made(self, store, window, *a, **k)
    monkeypatch.setattr(stored_strokes.StoredStrokes, "__init__", spied)
    monkeypatch.setattr(plan_windows, "WINDOW", 16)
    monkeypatch.setattr(plan_windows, "MAX_WINDOW", 64)
    monkeypatch.setattr(plan_windows, "HEAVY_ROWS", 2)
    monkeypatch.setenv("GCODE_OPT_WINDOWED", "1")
    monkeypatch.delenv("GCODE_OPT_WINDOW", raising=False)
    out = tmp_path / "adapted.gcode"
    s = pipeline.process(os.path.join(SAMPLES, name), str(out), load_profile(prof), pipeline.Options())
    s = json.loads(json.dumps({k: v for k, v in s.items() if k not in VOLATILE}, default=str))
    assert seen == [64 if large else 16]
    assert out.read_bytes() == want[0]
    assert s == want[1]
