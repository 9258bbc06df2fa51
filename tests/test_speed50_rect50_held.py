"""Issue 8, session 50 (rect50): what planning and the measure hold besides the strokes, cut
with the same bits.  The lines' repeat memo keeps a digest of the rows, not their bytes
(schedule._lines_repeat); the segment cache keeps no line plan where a _RunMemo hands a later
budget run the last one's (SegmentCache.keep_lines); the first pass's record (pipeline.
_FirstPass) holds its plan's own arrays, not copies.  Each is checked against the code it
replaced (kept here verbatim, or forced back by a patch): the same plans run by run, the same
bytes and figures written."""
import json
import os

import numpy as np
import pytest

from gcode_opt import pipeline, schedule
from gcode_opt.profile import load_profile
from test_speed35_budget_runs import _analysed, _figures

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")


# ---------------------------------------------------------------- _lines_repeat's memo key
def test_rows_digest_is_a_key_of_the_int64_bytes():
    rng = np.random.default_rng(0)
    rows = np.sort(rng.choice(10_000, 3000, replace=False))
    key = schedule._rows_digest(rows)
    # the same rows however given (int32, a list, a strided view): the same key, as their
    # int64 bytes were
    assert schedule._rows_digest(rows.astype(np.int32)) == key
    assert schedule._rows_digest(rows.tolist()) == key
    assert schedule._rows_digest(np.repeat(rows, 2)[::2]) == key
    # other rows (one changed, one fewer, one more, reordered): another key
    other = rows.copy()
    other[1234] += 1
    for x in (other, rows[:-1], np.append(rows, 10_001), rows[::-1]):
        assert schedule._rows_digest(x) != key
    assert schedule._rows_digest(np.zeros(0, np.int64)) != schedule._rows_digest(np.zeros(1, np.int64))


def _lines_repeat_bytes_key(pin, rows):
    """The code _lines_repeat replaced (its memo keyed by the rows' bytes), verbatim."""
    if rows.size < 2:
        return False
    key = np.asarray(rows, np.int64).tobytes()
    memo = getattr(pin, "lines_repeat_memo", None)
    if memo is not None and memo[0] == key:
        return memo[1]
    cols = [np.asarray(x[rows], float).view(np.int64) for x in (pin.L, pin.v0, pin.v1, pin.T_orig)]
    got = bool(schedule.column_classes_first(cols)[1].size <= schedule.REPEAT_R * rows.size)
    pin.lines_repeat_memo = (key, got)
    return got


@pytest.mark.parametrize("name", ["prusa_mk3s_rectilinear.gcode", "prusa_gyroid.gcode"])
def test_lines_repeat_memo_answers_as_before(name):
    """The same answers as the bytes-keyed memo, and the rows asked again after the inputs were
    set aside are answered from the memo (pin's arrays not read back)."""
    profile = load_profile("prusa-mk3s")
    opts = pipeline.Options()
    opts.ringing = False
    strokes, _ = pipeline.analyse(os.path.join(SAMPLES, name), profile, opts)
    pin = schedule.plan_inputs(strokes, profile, opts)
    ref = schedule.plan_inputs(strokes, profile, opts)
    lines = schedule._rows_by_kind(strokes)[schedule.K_LINE]
    asks = [lines, lines[: lines.size // 2], lines[::3], lines, np.arange(len(strokes)), lines]
    for rows in asks:
        assert schedule._lines_repeat(pin, rows) == _lines_repeat_bytes_key(ref, rows)
    assert pin.lines_repeat_memo[0] == schedule._rows_digest(lines)
    assert pin.set_aside()
    assert schedule._lines_repeat(pin, lines.astype(np.int32)) == _lines_repeat_bytes_key(ref, lines)
    assert "_aside" in pin.__dict__                     # (answered by the memo: nothing read back)


# ---------------------------------------------------------------- SegmentCache.keep_lines
class _KeepingLines(schedule.SegmentCache):
    """The cache as it was: every line plan kept, whatever plan_strokes asks."""
    keep_lines = property(lambda self: True, lambda self, v: None)


def _runs(name, prof, corners, monkeypatch, alpha="auto", budgets=(1.0, 0.6, 0.61, 1.3, 1.0, 0.6)):
    """Each budget run's plan figures (back and forth: the caches' and the last run's reuse;
    test_speed35's runs with a fixed alpha too), and the lines' plans the segment cache
    holds after the last."""
    strokes, sim0, profile, opts = _analysed(name, prof, corners)
    opts.alpha = alpha
    pin = schedule.plan_inputs(strokes, profile, opts)
    runs = []

    def fit(run, pin_, budget_t):
        for r in budgets:
            runs.append(_figures(run(r * budget_t)))
    monkeypatch.setattr(schedule, "_fit_budget", fit)
    p = schedule.plan_strokes(strokes, pin, profile, opts, opts.max_slowdown_r * sim0.time_t)
    if alpha != "auto":
        runs.append(_figures(p))
    return runs, sum(s is not None for s in pin.seg_cache.line_seg)


@pytest.mark.parametrize("name,prof,corners,alpha", [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 0.0, "auto"),
                                                     ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 0.3, "auto"),
                                                     ("prusa_gyroid.gcode", "prusa-mk3s", 0.0, "auto"),
                                                     ("prusa_gyroid.gcode", "prusa-mk3s", 0.0, 0.5),
                                                     ("prusa_gyroid_fullspeed_klipper.gcode", "voron24", 0.3, "auto")])
def test_runs_without_the_line_cache_make_the_same_plans(name, prof, corners, alpha, monkeypatch):
    with monkeypatch.context() as m:
        got, kept = _runs(name, prof, corners, m, alpha)
    with monkeypatch.context() as m:
        m.setattr(schedule, "SegmentCache", _KeepingLines)
        ref, kept_ref = _runs(name, prof, corners, m, alpha)
    assert len(got) == len(ref) > 0
    for a, b in zip(got, ref):
        assert a == b
    assert sum(s is not None for s in ref[0][6]) > 100          # plans were made
    assert kept_ref > 0
    # the cache keeps no line plan where a _RunMemo reuses them, nor for a fixed alpha's one
    # run (--corners with junction commands: no _RunMemo, the cache keeps them as before)
    assert kept in (0, kept_ref)
    if not corners:
        assert kept == 0


# ---------------------------------------------------------------- _FirstPass
class _FirstPassCopies:
    """The code _FirstPass replaced (its plan's arrays copied), verbatim."""

    def __init__(self, plan, digests, lines, out_ranges, figures, led):
        self.retime = plan.retime.copy()
        self.segs = list(plan.segs)
        self.beta = plan.beta.copy()
        self.digests, self.lines, self.out_ranges, self.figures, self.led = digests, lines, out_ranges, figures, led


def _process(path, out, prof, **kw):
    opts = pipeline.Options(**kw)
    s = pipeline.process(path, str(out), load_profile(prof), opts)
    for key in ("timing_s", "elapsed_s", "output"):      # (the run's clock and file name)
        s.pop(key, None)
    return out.read_bytes(), json.dumps(s, sort_keys=True, default=str)


CASES = [("edge/long_end_segment_curve.gcode", "prusa-mk3s", {}),                 # a re-plan
         ("prusa_benchy_like.gcode", "prusa-mk3s", {}),                           # a re-plan
         ("prusa_benchy_like.gcode", "voron24",                                   # a restore, no re-plan
          {"features": ("custom", "sparse_infill", "solid_infill")})]


@pytest.mark.parametrize("name,prof,kw", CASES)
def test_first_pass_holds_its_plan_unchanged(tmp_path, monkeypatch, name, prof, kw):
    """Two passes: what the first pass's record holds (its plan's own arrays) is, when the
    second pass has used it, what the first plan was (nothing wrote into it); and the run
    writes the same bytes and figures as with the record's copies."""
    held = []
    real = pipeline._FirstPass

    def recorded(plan, *a):
        first = real(plan, *a)
        assert first.retime is plan.retime and first.segs is plan.segs and first.beta is plan.beta
        held.append((first, plan.retime.tobytes(), plan.beta.tobytes(), list(plan.segs),
                     [None if s is None else (s.s.tobytes(), s.v.tobytes(), s.accel.tobytes(), s.feed.tobytes())
                      for s in plan.segs]))
        return first
    monkeypatch.setattr(pipeline, "_FirstPass", recorded)
    got = _process(os.path.join(SAMPLES, name), tmp_path / "a.gcode", prof, **kw)
    assert json.loads(got[1])["rewrite_passes"] == 2 and len(held) == 2
    for first, retime, beta, segs, arrays in held:
        assert first.retime.tobytes() == retime and first.beta.tobytes() == beta
        assert all(a is b for a, b in zip(first.segs, segs)) and len(first.segs) == len(segs)
        assert [None if s is None else (s.s.tobytes(), s.v.tobytes(), s.accel.tobytes(), s.feed.tobytes())
                for s in first.segs] == arrays
    monkeypatch.setattr(pipeline, "_FirstPass", _FirstPassCopies)
    ref = _process(os.path.join(SAMPLES, name), tmp_path / "b.gcode", prof, **kw)
    assert got == ref
