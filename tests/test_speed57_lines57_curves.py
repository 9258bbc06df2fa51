"""A windowed run's curves (issue 8, lines57): schedule._curve_calls segments the curves to
re-time in calls of at most CURVE_ROWS rows (and a window's) whatever their windows (not a call a window:
_by_windows), their strokes made of their records where sparse (no window loaded) and given
their geometry in one batch first; the plan the list gives, bit for bit."""
import pytest

from gcode_opt import schedule as sc
from gcode_opt.laws import circle

from test_speed52_runs52_windows import _ref, plan_bits, runs

NAME, PROF, WINDOW = "prusa_gyroid.gcode", "prusa-mk3s", 37


@pytest.mark.skipif(not circle.rows_invariant(), reason="this BLAS does not give rows their own bits: one batch")
@pytest.mark.parametrize("curve_rows", [16, 10 ** 6])
def test_curves_in_calls_of_at_most_curve_rows(monkeypatch, curve_rows):
    """Calls of CURVE_ROWS rows, or of a window's where fewer (no more strokes made at once)."""
    ref = _ref(NAME, PROF, WINDOW)
    monkeypatch.setattr(sc, "CURVE_ROWS", curve_rows)
    ROWS = min(curve_rows, WINDOW)
    runs_seen = []              # a run's curves: (rows asked, [rows a segments call], windows loaded)
    kind = sc.KINDS[sc.K_CURVE]
    segments, curve_calls = kind.segments, sc._curve_calls

    def spy_segments(sts, *a):
        runs_seen[-1][1].append(len(sts))
        assert all(st.curv is not None for st in sts)         # (their geometry made first)
        return segments(sts, *a)

    def spy_calls(fn, strokes, *a):
        calls = curve_calls(fn, strokes, *a)

        def spied(rows):
            runs_seen.append([rows.size, [], strokes.loads])
            out = calls(rows)
            runs_seen[-1][2] = strokes.loads - runs_seen[-1][2]
            return out
        return spied
    monkeypatch.setattr(kind, "segments", spy_segments)
    monkeypatch.setattr(sc, "_curve_calls", spy_calls)
    got = plan_bits(runs(NAME, PROF, WINDOW))
    assert got["segs"] == ref["segs"]
    assert got == ref
    seen = [r for r in runs_seen if r[0]]
    assert seen and max(r[0] for r in seen) > ROWS           # (rows of several windows asked at once)
    for n_rows, calls, loaded in seen:
        assert calls == [min(ROWS, n_rows - a) for a in range(0, n_rows, ROWS)]
        assert loaded == 0                                  # (sparse: made of their records)
