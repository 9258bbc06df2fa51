"""A budget run frees the line plans it is about to make again (SegmentCache.forget_lines)
before it makes them: the same plans as keeping them, less memory at the run's peak."""
import os

import numpy as np

from gcode_opt import pipeline, schedule
from gcode_opt.profile import load_profile

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")


def _plans(name, prof, keep, monkeypatch, budgets):
    """The plans of several budget runs (as _fit_budget makes them) on one sample."""
    if keep:                               # the reference: the old plans stay in the cache
        monkeypatch.setattr(schedule.SegmentCache, "forget_lines", lambda self, rows: None)
    profile = load_profile(prof)
    opts = pipeline.Options()
    opts.ringing = False
    strokes, sim0 = pipeline.analyse(os.path.join(SAMPLES, name), profile, opts)
    pin = schedule.plan_inputs(strokes, profile, opts)
    runs = []

    def fit(run, pin_, budget_t):
        for r in budgets:
            runs.append(run(r * budget_t))
        return runs[-1]
    monkeypatch.setattr(schedule, "_fit_budget", fit)
    schedule.plan_strokes(strokes, pin, profile, opts, opts.max_slowdown_r * sim0.time_t)
    monkeypatch.undo()
    return runs, pin


def _same(a, b):
    assert (a.retime == b.retime).all() and (a.T == b.T).all() and (a.beta == b.beta).all()
    assert a.reason == b.reason if isinstance(a.reason, list) else (a.reason == b.reason).all()
    for sa, sb in zip(a.segs, b.segs):
        assert (sa is None) == (sb is None)
        if sa is not None:
            for f in ("s", "v", "accel", "feed"):
                x, y = np.asarray(getattr(sa, f)), np.asarray(getattr(sb, f))
                assert x.shape == y.shape and (x.view(np.int64) == y.view(np.int64)).all(), f
            assert sa.time_t == sb.time_t and sa.int_a2 == sb.int_a2


def test_replans_equal_with_and_without_forgetting(monkeypatch):
    # budgets that move many lines to other durations and back (a plan at 1.0 again last)
    budgets = (1.0, 0.4, 1.3, 1.0)
    for name, prof in (("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24")):
        got, pin = _plans(name, prof, False, monkeypatch, budgets)
        ref, _ = _plans(name, prof, True, monkeypatch, budgets)
        assert len(got) == len(ref) == len(budgets)
        for a, b in zip(got, ref):
            _same(a, b)
        # the runs did move lines (else forgetting was never exercised)
        assert (got[0].T != got[1].T).sum() > 20


def test_forget_lines_frees_only_those_rows():
    c = schedule.SegmentCache()
    rows = np.arange(6)
    T, beta = np.linspace(1.0, 2.0, 6), np.full(6, 0.5)
    plans = {i: object() for i in range(6)}
    c.store(schedule.K_LINE, rows, T, beta, plans, {})
    c.forget_lines(np.array([1, 4, 99]))          # 99: never stored
    got, bad = c.lookup(schedule.K_LINE, rows, T, beta)
    assert sorted(got) == [0, 2, 3, 5] and not bad
    assert all(got[i] is plans[i] for i in got)
    assert c.line_seg[1] is None and c.line_seg[4] is None
