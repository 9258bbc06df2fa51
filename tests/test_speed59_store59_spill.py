"""The windowed analyse makes the plan inputs of the strokes it spills (issue 8, store59:
plan_windows.SpilledInputs): each batch of finished strokes planned (and its curve geometry
kept) before its records are written, so a record is encoded once and no window is loaded
and written back for the plan inputs.  Checked: the joined PlanInput is the list path's one
call, column by column, on real files cut in spill batches of every size (the analyse's
log flushed every few records: batches that are no multiple of anything), arcs and curves
included; every stroke's record encoded once through planning; the written file and summary
the list path's."""
import os

import numpy as np
import pytest

from gcode_opt import pipeline, plan_windows, schedule
from gcode_opt.profile import load_profile
from gcode_opt.stroke_store import StrokeStore

from test_speed56_inputs56_pin import _same_pin      # (every field, the arrays bit for bit)
from windowed_run import run_command

SAMPLES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "sample_gcode")
CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus")

# (file, profile): PrusaSlicer lines, arcs, curves and chains (gyroid), Cura, Klipper flavour
SAMPLED = [(os.path.join(SAMPLES, "prusa_mk3s_rectilinear.gcode"), "prusa-mk3s"),
           (os.path.join(SAMPLES, "prusa_gyroid_arcs.gcode"), "prusa-mk3s"),
           (os.path.join(SAMPLES, "prusa_gyroid.gcode"), "prusa-mk3s"),
           (os.path.join(SAMPLES, "cura_box.gcode"), "prusa-mk3s"),
           (os.path.join(SAMPLES, "prusa_klipper.gcode"), "voron24")]
PLATES = [pytest.param(os.path.join(CORPUS, f"{n}.gcode"), "prusa-mk3s", marks=pytest.mark.slow)
          for n in ("plate_rectilinear", "plate_gyroid")]


def _spilled(path, prof, opts, rows=None, window=64):
    """(joined PlanInput, the strokes a plan_inputs call, SpilledInputs) of analyse's
    windowed spill planned `rows` strokes at a time (None: the command's)."""
    sizes = []
    real = schedule.plan_inputs

    def counted(sts, *a, **k):
        sizes.append(len(sts))
        return real(sts, *a, **k)
    store = StrokeStore(in_memory=True)
    spill = plan_windows.SpilledInputs(store, prof, opts, window, rows)
    schedule.plan_inputs = counted
    try:
        got, _ = pipeline.analyse(path, prof, opts, spill)
        pin = spill.plan_input()
    finally:
        schedule.plan_inputs = real
    assert got is spill
    return pin, sizes, spill


def _small_spills(monkeypatch, flush_rows):
    """analyse's log flushed (its finished strokes spilled) every flush_rows records, read
    in blocks of 2 kB (the flushes come between blocks)."""
    from gcode_opt.firmware import simulate
    monkeypatch.setattr(simulate, "CHUNK_HINT", 2000)
    monkeypatch.setattr(pipeline, "LOG_FLUSH_ROWS", flush_rows)


def _check_spilled_pin(monkeypatch, path, prof, flush_rows=None, rows=None):
    """The PlanInput spilled (_spilled) is the list's one call, column by column; returns
    the strokes a plan_inputs call."""
    prof = load_profile(prof)
    opts = pipeline.Options(alpha=0.5)
    want = schedule.plan_inputs(pipeline.analyse(path, prof, opts)[0], prof, opts)
    if flush_rows is not None:
        _small_spills(monkeypatch, flush_rows)
    got, sizes, spill = _spilled(path, prof, opts, rows)
    assert sum(sizes) == len(spill) == len(spill.store) == len(want.L)
    _same_pin(got, want)
    spill.store.close()
    return sizes


@pytest.mark.parametrize("path,prof", SAMPLED)
@pytest.mark.parametrize("flush_rows,rows", [(97, 1), (300, 37), (1000, 1000)])
def test_spilled_plan_input_is_the_lists(monkeypatch, path, prof, flush_rows, rows):
    """The small samples spilled in batches of a few to a few hundred strokes (the log
    flushed every flush_rows records), planned as they come (rows 1: cuts of every size)
    or once `rows` are held: the list's PlanInput, arcs' arc_gentle included."""
    sizes = _check_spilled_pin(monkeypatch, path, prof, flush_rows, rows)
    assert all(k >= rows for k in sizes[:-1]) and sizes[-1] > 0
    if rows == 1 and pipeline._record_log() is not None:     # (the Python model: one batch, at the end)
        assert len(set(sizes)) >= 3


@pytest.mark.parametrize("path,prof", SAMPLED)
def test_plan_inputs_on_any_cut(path, prof):
    """plan_inputs of the strokes cut anywhere (pieces of 1 to 400 strokes, seeded), joined
    (stored_strokes.join_plan_inputs): the PlanInput of one call, bit for bit -- what lets
    analyse plan its strokes as they are spilled."""
    from gcode_opt.stored_strokes import join_plan_inputs
    prof = load_profile(prof)
    opts = pipeline.Options(alpha=0.5)
    want = schedule.plan_inputs(pipeline.analyse(path, prof, opts)[0], prof, opts)
    strokes = pipeline.analyse(path, prof, opts)[0]
    rng = np.random.default_rng(59)
    cuts = np.cumsum(rng.integers(1, 400, len(strokes)))
    cuts = [0] + cuts[cuts < len(strokes)].tolist() + [len(strokes)]
    assert len(cuts) > 5
    _same_pin(join_plan_inputs([schedule.plan_inputs(strokes[a:b], prof, opts) for a, b in zip(cuts, cuts[1:])]),
              want)


@pytest.mark.parametrize("path,prof", PLATES)
def test_spilled_plan_input_is_the_lists_on_plates(monkeypatch, path, prof):
    """The plates as the command spills them (LOG_FLUSH_ROWS): the list's PlanInput."""
    if not os.path.exists(path):
        pytest.skip(f"{path} not made (sample_gcode/make_corpus.sh)")
    sizes = _check_spilled_pin(monkeypatch, path, prof)
    rows = 64                                       # (_spilled's window: the least strokes a call)
    assert len(sizes) > 3 and all(k >= rows for k in sizes[:-1]) and sizes[-1] > 0


@pytest.mark.parametrize("path,prof", SAMPLED[:3])
def test_each_record_encoded_once(monkeypatch, tmp_path, path, prof):
    """The windowed command encodes each stroke's record once through its planning (the
    strokes' appends: no window read back and rewritten for the plan inputs), and decodes
    none before the candidates."""
    encoded, decoded, counts = [], [], {}
    real_encode, real_take = StrokeStore._encode, StrokeStore.take
    real_planned = plan_windows.planned_strokes

    def counted_encode(self, strokes, i0, i1, buf):
        encoded.append(i1 - i0)
        return real_encode(self, strokes, i0, i1, buf)

    def counted_take(self, rows, over=None):
        decoded.append(len(rows))
        return real_take(self, rows, over)

    def planned(store, *a):
        counts["at_planned"] = (sum(encoded), sum(decoded), len(store))
        monkeypatch.setattr(plan_windows, "candidates_windowed", stop)
        return real_planned(store, *a)

    def stop(strokes, *a):
        counts["at_candidates"] = (sum(encoded), sum(decoded))
        raise _Stop
    monkeypatch.setattr(StrokeStore, "_encode", counted_encode)
    monkeypatch.setattr(StrokeStore, "take", counted_take)
    monkeypatch.setattr(plan_windows, "planned_strokes", planned)
    _small_spills(monkeypatch, 500)
    with pytest.raises(_Stop):
        run_command(monkeypatch, path, tmp_path / "out.gcode", True, 64, prof)
    n_enc, n_dec, n = counts["at_planned"]
    assert n > 0 and n_enc <= n and n_dec == 0
    assert counts["at_candidates"] == (n, 0)


class _Stop(Exception):
    """The command stopped at its candidates (what follows is not the test's)."""


@pytest.mark.parametrize("path,prof", SAMPLED)
def test_windowed_bytes_are_the_lists(monkeypatch, tmp_path, path, prof):
    """The command windowed (window 37, the log flushed every 300 records, planned 50
    strokes at a time: plan_inputs' calls and spill batches that cut windows) writes the
    list path's file and summary."""
    want = run_command(monkeypatch, path, tmp_path / "list.gcode", False, None, prof)
    _small_spills(monkeypatch, 300)
    monkeypatch.setattr(plan_windows, "PIN_ROWS", 50)
    got = run_command(monkeypatch, path, tmp_path / "win.gcode", True, 37, prof)
    assert got[0] == want[0]
    assert got[1] == want[1]
