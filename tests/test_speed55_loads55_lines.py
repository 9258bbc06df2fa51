"""A windowed run's lines segmented several windows at a time (issue 8, loads55): without
line classes (lines56: with them each key once a run, test_speed56_lines56_spill.py) the
lines of schedule.LINE_WINDOWS windows of rows together, in calls of a window of strokes at
most, the same figures and reasons as a call a window and as the runs keeping every plan
(LAZY_LINES off)."""
import numpy as np

from gcode_opt import schedule as sc

from test_speed53_plans53_lazy import _EAGER, FIGURES, _plans, _stored_plan

NAME, PROF, WINDOW = "prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 16


def _lines_run(monkeypatch, line_windows, made=None):
    """(the runs' plan and pin, the rows of each lines call) with LINE_WINDOWS at line_windows;
    made: given a list, the number of strokes of each _line_segments call appended."""
    calls = []
    figures = sc._window_figures
    segments = sc._line_segments

    def counted(sts, *a, **k):
        made.append(len(sts))
        return segments(sts, *a, **k)

    def spy(fn, rows, window, *a, **k):
        def seen(r):
            calls.append(r.copy())
            return fn(r)
        return figures(seen if len(a) > 3 else fn, rows, window, *a, **k)     # (the lines': their spill, classes)
    with monkeypatch.context() as m:
        m.setattr(sc, "LINE_WINDOWS", line_windows)
        m.setattr(sc, "_keyed", lambda *a: False)      # (lines not keyed: keyed, _line_figures' own, lines56)
        m.setattr(sc, "LAZY_CHAINS", False)
        m.setattr(sc, "_window_figures", spy)
        if made is not None:
            m.setattr(sc, "_line_segments", counted)
        strokes, store, _, _, plan, pin = _stored_plan(NAME, PROF, WINDOW)
    store.close()
    return plan, pin, calls


def _eager(monkeypatch):
    """The figures, reasons and plans of the runs keeping every plan (test_speed53_plans53_lazy's)."""
    if (NAME, WINDOW) not in _EAGER:
        with monkeypatch.context() as m:
            m.setattr(sc, "LAZY_CHAINS", False)
            _plans(NAME, PROF, WINDOW, m)[0][1].close()
    return _EAGER[NAME, WINDOW]


def test_lines_of_several_windows_in_one_call(monkeypatch):
    made = []
    plan, pin, calls = _lines_run(monkeypatch, sc.LINE_WINDOWS, made)
    one, _, calls_one = _lines_run(monkeypatch, 1)
    assert sc.LINE_WINDOWS > 1 and len(calls_one) > 10
    spans = [np.unique(r // WINDOW).size for r in calls]
    assert max(spans) > 1 and len(calls) < len(calls_one)
    # a window of strokes as objects a call at most, however many windows' rows are asked
    assert max(made) == WINDOW and max(r.size for r in calls) > WINDOW
    assert all(np.unique(r // (WINDOW * sc.LINE_WINDOWS)).size == 1 for r in calls)
    # the same figures as a call a window and as the runs keeping every plan
    eager, reason, _ = _eager(monkeypatch)
    for k in FIGURES:
        assert getattr(plan, k).tobytes() == getattr(one, k).tobytes() == eager[k].tobytes(), k
    assert list(plan.reason) == list(one.reason) == reason
    assert (plan.retime & (pin.plan_kind_codes == sc.C_LINE)).sum() > 10     # (lines re-timed: compared)
