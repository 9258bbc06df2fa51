"""The windowed pipeline as a code path of the command (issue 8, wire53): GCODE_OPT_WINDOWED=1
makes pipeline._process keep the strokes in a StrokeStore (plan_windows: plan_inputs PIN_ROWS
strokes at a time, the candidates a window at a time, GCODE_OPT_WINDOW strokes) and run its passes over a
StoredStrokes.  Checked against the list path (the default) on real samples: the written file
byte for byte and the summary equal but for its volatile keys, files with arcs at small
windows included (arcs53: the arcs' candidates on the file's quadrature levels); on the
second passes (a departed stroke restored, a re-plan) too; and real Klipper takes a windowed output without an error.
Windows of 7 strokes put window edges inside every feature."""
import json
import os

import numpy as np
import pytest

from gcode_opt import pipeline, plan_windows
from gcode_opt.profile import load_profile
from gcode_opt.stroke_store import StrokeStore

SAMPLES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "sample_gcode")
VOLATILE = ("timing_s", "elapsed_s", "output")
INTRO = ("custom", "sparse_infill", "solid_infill")      # test_speed29_restore_pass's: a purge line departs


@pytest.fixture
def spy(monkeypatch):
    """Counts of the windowed path's planning calls and the largest number of strokes a
    StrokeStore made at once (take: load, the held rows, the summary's columns), those of
    plan_inputs (PIN_ROWS a call: plan_windows.planned_strokes) apart (pin_made)."""
    seen = {"planned": 0, "most_made": 0, "plans": 0, "pin_made": 0}
    planned, take, plan = plan_windows.planned_strokes, StrokeStore.take, pipeline.plan_strokes
    pin_windowed = plan_windows.plan_inputs_windowed
    in_pin = []

    def counted_planned(*a, **k):
        seen["planned"] += 1
        return planned(*a, **k)

    def counted_pin(*a, **k):
        in_pin.append(1)
        try:
            return pin_windowed(*a, **k)
        finally:
            in_pin.pop()

    def counted_take(self, rows, over=None):
        got = take(self, rows, over)
        key = "pin_made" if in_pin else "most_made"
        seen[key] = max(seen[key], len(got))
        return got

    def counted_plan(*a, **k):
        seen["plans"] += 1
        return plan(*a, **k)
    monkeypatch.setattr(plan_windows, "planned_strokes", counted_planned)
    monkeypatch.setattr(plan_windows, "plan_inputs_windowed", counted_pin)
    monkeypatch.setattr(StrokeStore, "take", counted_take)
    monkeypatch.setattr(pipeline, "plan_strokes", counted_plan)
    return seen


def _run(monkeypatch, tmp_path, name, prof, window=None, features=None, **kw):
    """(written bytes, summary as JSON reads it back, but VOLATILE) of the command's job,
    windowed at `window` strokes or (None) on the list path."""
    if window is None:
        monkeypatch.delenv("GCODE_OPT_WINDOWED", raising=False)
    else:
        monkeypatch.setenv("GCODE_OPT_WINDOWED", "1")
        monkeypatch.setenv("GCODE_OPT_WINDOW", str(window))
    out = tmp_path / f"{os.path.basename(name)}.{window}.gcode"
    opts = pipeline.Options(**({"features": features} if features else {}), **kw)
    s = pipeline.process(os.path.join(SAMPLES, name), str(out), load_profile(prof), opts)
    s = json.loads(json.dumps({k: v for k, v in s.items() if k not in VOLATILE}, default=str))
    return out.read_bytes(), s


# (file, profile, window): PrusaSlicer, Cura, Klipper flavour, arcs
SAMPLED = [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 7),
           ("cura_box.gcode", "prusa-mk3s", 64),
           ("prusa_klipper.gcode", "voron24", 64),
           ("prusa_gyroid_arcs.gcode", "prusa-mk3s", 37),      # arcs at a window edge (arcs53: file-wide levels)
           ("prusa_gyroid_arcs.gcode", "prusa-mk3s", 1024),
           ("edge/checksums.gcode", "prusa-mk3s", 7)]                # moves, but no stroke


@pytest.mark.parametrize("name,prof,window", SAMPLED)
def test_windowed_writes_the_list_paths_file(monkeypatch, tmp_path, spy, name, prof, window):
    want = _run(monkeypatch, tmp_path, name, prof)
    assert spy["planned"] == 0
    got = _run(monkeypatch, tmp_path, name, prof, window)
    # the windowed path ran, and never made more strokes at once than a window holds (but
    # plan_inputs: PIN_ROWS, or a window if more)
    assert spy["planned"] == 1 and spy["most_made"] <= window
    assert spy["pin_made"] <= max(window, plan_windows.PIN_ROWS)
    assert got[0] == want[0]
    assert got[1] == want[1]


# (file, profile, features, alpha, plan_strokes calls on the list path, window)
SECOND_PASS = [("prusa_absolute_e.gcode", "voron24", INTRO, "auto", 2, 7),
               ("prusa_absolute_e.gcode", "voron24", INTRO, 0.5, 1, 7),
               ("prusa_gyroid_fullspeed.gcode", "voron24", None, "auto", 2, 300)]


@pytest.mark.parametrize("name,prof,features,alpha,plans,window", SECOND_PASS)
def test_second_pass_over_the_store(monkeypatch, tmp_path, spy, name, prof, features, alpha, plans, window):
    """Files the list path writes twice, windowed: the same file and summary.  The absolute-E
    sample under voron24 with its intro line: the firmware model departs from the purge
    line's plan; auto: the file is still over its budget once that line is back to its
    lines, so the budget is re-planned (plan_strokes over the StoredStrokes again, the first
    pass's blocks reused); a fixed alpha: the first plan kept without it.  The full-speed
    gyroid overruns its budget: re-planned, its chains' runs starting from their memos (the
    StoredStrokes' side table: without it the file differs)."""
    want = _run(monkeypatch, tmp_path, name, prof, features=features, alpha=alpha)
    assert want[1]["rewrite_passes"] == 2 and spy["plans"] == plans
    got = _run(monkeypatch, tmp_path, name, prof, window, features=features, alpha=alpha)
    assert spy["planned"] == 1 and spy["plans"] == 2 * plans and 0 < spy["most_made"] <= window
    assert spy["pin_made"] == 0          # (the plan inputs made as analyse spilled: no record read, store59)
    assert got[0] == want[0]
    assert got[1] == want[1]


def test_window_size_from_the_environment(monkeypatch):
    monkeypatch.delenv("GCODE_OPT_WINDOWED", raising=False)
    monkeypatch.setenv("GCODE_OPT_WINDOW", "7")
    assert plan_windows.window_size() is None                # the list path: the default
    monkeypatch.setenv("GCODE_OPT_WINDOWED", "0")
    assert plan_windows.window_size() is None
    monkeypatch.setenv("GCODE_OPT_WINDOWED", "1")
    assert plan_windows.window_size() == 7
    monkeypatch.delenv("GCODE_OPT_WINDOW")
    assert plan_windows.window_size() == plan_windows.WINDOW     # (unset: the default)
    monkeypatch.setenv("GCODE_OPT_WINDOW", "0")
    with pytest.raises(ValueError):
        plan_windows.window_size()


def test_plan_inputs_windowed_is_one_calls(tmp_path):
    """plan_inputs a window at a time, joined: every array the one call's, bit for bit (the
    arcs sample: arc_gentle's rows moved by their window's first row)."""
    from gcode_opt.schedule import plan_inputs
    prof, opts = load_profile("prusa-mk3s"), pipeline.Options()
    path = os.path.join(SAMPLES, "prusa_gyroid_arcs.gcode")
    strokes, _ = pipeline.analyse(path, prof, opts)
    want = plan_inputs(strokes, prof, opts)
    with StrokeStore() as store:
        store.append(pipeline.analyse(path, prof, opts)[0])
        got = plan_windows.plan_inputs_windowed(store, prof, opts, 7)
    assert sorted(vars(got)) == sorted(vars(want))
    assert getattr(want, "arc_gentle", None)                 # (the file's arcs: the dict's rows checked)
    for k, v in vars(want).items():
        g = getattr(got, k)
        if isinstance(v, np.ndarray):
            assert g.dtype == v.dtype and g.tobytes() == v.tobytes(), k
        else:
            assert g == v, k


def test_klipper_takes_a_windowed_file(monkeypatch, tmp_path):
    """Real Klipper (tests/klipper_oracle.py) plays a file written windowed without an error."""
    import klipper_oracle as ko
    ko.oracle_or_skip()
    got, s = _run(monkeypatch, tmp_path, "prusa_klipper.gcode", "voron24", 7)
    assert s["strokes"]["retimed"] > 0
    out = tmp_path / "windowed.gcode"
    out.write_bytes(got)
    assert ko.run_oracle(str(out), load_profile("voron24"))["errors"] == []


def test_windowed_spill_beside_the_output(monkeypatch, tmp_path):
    """The StrokeStore's file is made in the output's folder (on its disk, as the output's
    own temporary file), not in the system's temporary folder, which may be tmpfs: RAM that
    the process's RSS does not show."""
    import tempfile
    made = []
    real = tempfile.TemporaryFile

    def seen(*a, **k):
        made.append(k.get("dir"))
        return real(*a, **k)
    monkeypatch.setattr(tempfile, "TemporaryFile", seen)
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    monkeypatch.setenv("GCODE_OPT_WINDOWED", "1")
    monkeypatch.setenv("GCODE_OPT_WINDOW", "64")
    pipeline.process(os.path.join(SAMPLES, "prusa_mk3s_rectilinear.gcode"), str(out_dir / "o.gcode"),
                     load_profile("prusa-mk3s"), pipeline.Options())
    assert made and all(d == str(out_dir) for d in made), made


@pytest.mark.parametrize("corners", [0.3, "auto"])
def test_corners_take_the_list_path(monkeypatch, tmp_path, corners):
    """--corners (a share or auto) with GCODE_OPT_WINDOWED=1: the job takes the list path
    (pipeline._corners_on; windowed, the runs re-made the same lead-outs without end) and
    writes the list path's file.  The windowed planning is made to raise here, so a job
    that took it fails at once rather than hanging."""
    name, prof = "prusa_gyroid_fullspeed.gcode", "prusa-mk3s"
    want = _run(monkeypatch, tmp_path, name, prof, corner_budget_r=corners)
    plain = plan_windows.planned_strokes

    def windowed(*a, **k):
        raise AssertionError("the windowed path was taken with --corners")
    monkeypatch.setattr(plan_windows, "planned_strokes", windowed)
    got = _run(monkeypatch, tmp_path, name, prof, 37, corner_budget_r=corners)
    assert got[0] == want[0]
    assert got[1] == want[1]
    monkeypatch.setattr(plan_windows, "planned_strokes", plain)
    assert want[0] != _run(monkeypatch, tmp_path, name, prof)[0]     # (the corners changed the file)
