"""Memory held for the whole run (issue 8): every stroke lives from analyse to the summary,
so its per-vertex data is packed (strokes.Points, ends_d an array of doubles); the budget
loop holds at most two plans; --profile-time prints the peak RSS per phase."""

import gc
import math
import tracemalloc
import weakref

import numpy as np
import pytest

from gcode_opt import schedule
from gcode_opt.cli import main
from gcode_opt.profile import load_profile
from gcode_opt.state import events
from gcode_opt.strokes import K_CURVE, Points, group_strokes


def test_points_read_like_the_list_of_tuples():
    ref = [(0.5, -1.25), (3.0, 4.0), (1e-3, 7.125), (2.0, 2.0)]
    p = Points([c for xy in ref for c in xy])
    assert len(p) == 4 and bool(p) and not Points()
    assert [p[k] for k in range(4)] == ref
    assert p[-1] == ref[-1] and p[-2] == ref[-2] and p[0] == ref[0]
    assert p[1:3] == ref[1:3] and p[::-1] == ref[::-1]
    assert list(p) == ref
    assert all(type(c) is float for xy in p for c in xy)
    for k in (4, -5):
        with pytest.raises(IndexError):
            p[k]
    a = np.asarray(p, float)
    assert a.shape == (4, 2) and np.array_equal(a, np.array(ref))
    assert np.array_equal(np.array(p), np.array(ref))
    p.append((9.0, 10.0))
    assert len(p) == 5 and p[-1] == (9.0, 10.0)
    (x0, y0), (x1, y1) = p[0], p[1]
    assert (x0, y0, x1, y1) == (0.5, -1.25, 3.0, 4.0)


def _wave_file(path, n_strokes, n_vertices):
    """Gentle-turn polylines (a sine, ~2 deg a vertex): one curve stroke each."""
    out = ["G21", "G90", "M83", "G28", ";TYPE:Internal infill", "G1 F6000"]
    for k in range(n_strokes):
        y0 = 10.0 + 2.0 * k
        out.append(f"G0 X10 Y{y0:.3f}")
        for j in range(1, n_vertices + 1):
            x = 10.0 + 0.5 * j
            out.append(f"G1 X{x:.3f} Y{y0 + 0.5 * math.sin(0.03 * j):.4f} E0.02")
        out.append("G1 E-0.8")
    path.write_text("\n".join(out) + "\n")


def test_curve_strokes_keep_few_bytes_a_vertex(tmp_path):
    """A list of (x, y) tuples, a list of distances and a list of E took ~180 bytes a
    vertex; packed doubles take 24 (x, y, distance) and a stroke's fixed part."""
    n_strokes, n_vertices = 20, 400
    f = tmp_path / "waves.gcode"
    _wave_file(f, n_strokes, n_vertices)
    prof = load_profile("prusa-mk3s")
    gc.collect()
    tracemalloc.start()
    try:
        base = tracemalloc.get_traced_memory()[0]
        strokes = [item[1] for item in group_strokes(events(str(f), prof), ("sparse_infill",), 0.2, 30.0)
                   if item[0] == "stroke"]
        gc.collect()
        held = tracemalloc.get_traced_memory()[0] - base
    finally:
        tracemalloc.stop()
    curves = [s for s in strokes if s.kind == K_CURVE]
    assert len(curves) == n_strokes
    assert all(len(s.pts) == n_vertices + 1 and len(s.ends_d) == n_vertices for s in curves)
    assert held / (n_strokes * n_vertices) < 40.0, f"{held / (n_strokes * n_vertices):.0f} B a vertex"


class _FakePlan:
    def __init__(self, t_pred, retime):
        self.t_pred, self.retime = t_pred, retime


def test_fit_budget_holds_at_most_two_plans():
    """Every re-plan over the budget: the plans before it are gone when the next is made
    (the best one within the budget, if any, is the only other one alive)."""
    T_orig = np.ones(4)

    class Pin:
        pass
    pin = Pin()
    pin.T_orig = T_orig
    live = weakref.WeakSet()
    seen = []
    spend = iter([2.0, 1.5, 0.5, 0.9, 1.2, 0.95, 1.3, 0.8])    # spent time of each plan in turn

    def run(b):
        gc.collect()
        seen.append(len(live))
        p = _FakePlan(T_orig + next(spend) / 4, np.ones(4, bool))
        live.add(p)
        return p

    got = schedule._fit_budget(run, pin, 1.0)
    assert len(seen) == 1 + schedule.REPLANS
    assert max(seen) <= 1, seen
    assert float(np.sum(got.t_pred - T_orig)) == pytest.approx(0.95)   # the fullest plan within 1.0


def test_profile_time_prints_peak_rss_per_phase(capsys, tmp_path):
    src = "sample_gcode/prusa_absolute_e.gcode"
    rc = main(["process", src, "-o", str(tmp_path / "o.gcode"), "--profile", "prusa-mk3s", "-q",
               "--profile-time"])
    assert rc == 0
    err = capsys.readouterr().err
    line = [x for x in err.splitlines() if x.strip().startswith("peak RSS (MB)")]
    assert len(line) == 1, err
    fields = line[0].split(")", 1)[1].split(",")
    got = {k: float(v) for k, v in (f.split() for f in fields)}
    assert list(got) == ["analyse", "plan", "rewrite", "measure", "ringing", "summary"]
    # a Python process with numpy loaded holds more than 20 MB, and less than 2 GB on this file
    assert all(20.0 < v < 2000.0 for v in got.values())
    assert list(got.values()) == sorted(got.values())         # a running peak


def test_segment_cache_lines_hit_only_the_law_they_were_made_for():
    """Random stores and look-ups against a dict of (T, beta) per row (the old form): a
    line's plan comes back only for the very (T, beta) it was made for; a failure comes
    back as its reason; NaN never matches; forget_line drops the row."""
    rng = np.random.default_rng(3)
    cache = schedule.SegmentCache()
    oracle = {}
    n = 40
    vals = np.array([0.5, 1.0, 1.5, np.inf, np.nan])
    for step in range(60):
        rows = np.sort(rng.choice(n, size=rng.integers(0, 12), replace=False))
        T = rng.choice(vals[:3], size=n)
        beta = rng.choice(vals, size=n)
        got, bad = cache.lookup("line", rows, T, beta)
        want_got, want_bad = {}, {}
        for i in rows.tolist():
            h = oracle.get(i)
            if h is not None and h[0] == T[i] and h[1] == beta[i]:
                (want_bad if h[3] else want_got)[i] = h[3] or h[2]
        assert got.keys() == want_got.keys() and all(got[i] is want_got[i] for i in got)
        assert bad == want_bad
        todo = np.array([i for i in rows.tolist() if i not in got and i not in bad], int)
        segs = {i: object() for i in todo.tolist() if rng.random() < 0.7}
        fails = {i: "error: segments (x)" for i in todo.tolist() if i not in segs and rng.random() < 0.5}
        cache.store("line", todo, T, beta, list(map(segs.get, range(n))), fails)    # (a list by row, as a run's)
        for i in todo.tolist():
            oracle[i] = (float(T[i]), float(beta[i]), segs.get(i), fails.get(i, ""))
        if step % 7 == 3 and len(rows):
            a = int(rows[0])
            cache.forget_line(a)
            oracle.pop(a, None)


def test_trim_heap_gives_pages_back_or_does_nothing(monkeypatch):
    """glibc's malloc_trim after planning; where the C library has none, a no-op."""
    import ctypes

    from gcode_opt import pipeline
    pipeline.trim_heap()                       # this machine: glibc

    def no_libc(*a, **k):
        raise OSError("no C library")
    monkeypatch.setattr(ctypes, "CDLL", no_libc)
    assert pipeline.trim_heap() is None
