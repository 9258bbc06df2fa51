"""The per-stroke loops outside planning made row operations (issue 8, s24 "front") must
give what the loops they replace give, bit for bit, on real runs and on random inputs made
to hit their refusals and odd values:

- pipeline.stroke_lines (numpy rows) against _stroke_lines_loop (the loop before it);
- pipeline._departures (rows) against its loop;
- summary's by-kind sums (add.accumulate from the total so far) against _by_kind_loop,
  NaN, inf and -0.0 included, compared as bits;
- summary.coverage's candidate moves (stroke_columns.n_moves) against Stroke.n_moves;
- the measure pass's watch list (zip of tolist) against the old comprehension;
- pipeline._young_frozen: the collector back on, the young objects frozen, the state left
  as it was without a freeze; and the same bytes with and without the freezes."""
import copy
import gc
import math
import random
import struct
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import pipeline as pl
from gcode_opt import summary as sm
from gcode_opt.stroke_columns import n_moves
from gcode_opt.profile import load_profile
from gcode_opt.strokes import Stroke

SAMPLES = Path(__file__).resolve().parents[1] / "sample_gcode"


def _bits(x):
    if isinstance(x, float):
        return struct.pack("<d", x)
    if isinstance(x, dict):
        return {k: _bits(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_bits(v) for v in x]
    return x


def _same_lines(got, want):
    if want is None:
        return got is None
    return got is not None and all(np.array_equal(g, w) and g.dtype == w.dtype for g, w in zip(got, want))


class _S:
    """A stroke as stroke_lines reads it: its first and last input line."""
    __slots__ = ("first_idx", "last_idx")

    def __init__(self, a, z):
        self.first_idx, self.last_idx = a, z


# ---------------------------------------------------------------- real runs
@pytest.fixture(scope="module")
def seen():
    """Each call's inputs and the loop's answers, from process() on samples (both plates'
    kinds: curves, lines, arcs; one and two passes)."""
    calls = {"lines": [], "departures": [], "rows": []}
    real_lines, real_dep, real_rows = pl.stroke_lines, pl._departures, sm._per_stroke_rows

    def spy_lines(strokes, order, out_ranges):
        got = real_lines(strokes, order, out_ranges)
        calls["lines"].append((got, pl._stroke_lines_loop(strokes, order, out_ranges), list(order)))
        return got

    def spy_dep(plan, out_ranges, t1):
        got = real_dep(plan, out_ranges, t1)
        want = [i for k, (_, _, i) in enumerate(out_ranges) if t1[k] > pl.DEPART_R * plan.t_pred[i] + pl.DEPART_T]
        calls["departures"].append((got, want))
        return got

    def spy_rows(idx, out_first, t0, i0, t_law, i_law, t1, a21, beta, strokes, per_stroke, by_kind):
        real_rows(idx, out_first, t0, i0, t_law, i_law, t1, a21, beta, strokes, per_stroke, by_kind)
        ref = {}
        kinds = strokes.values("kind", np.asarray(idx, np.intp))      # (the strokes' columns: stroke_columns)
        sm._by_kind_loop(kinds, (t0, t_law, t1, i0, i_law, a21), ref)
        calls["rows"].append((copy.deepcopy(by_kind), ref, len(idx)))   # (build_summary adds to by_kind)
    mp = pytest.MonkeyPatch()
    mp.setattr(pl, "stroke_lines", spy_lines)
    mp.setattr(pl, "_departures", spy_dep)
    mp.setattr(sm, "_per_stroke_rows", spy_rows)
    try:
        import tempfile
        with tempfile.TemporaryDirectory() as d:
            for name, prof, kw in (("prusa_gyroid.gcode", "prusa-mk3s", {}),
                                   ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", {}),
                                   ("prusa_concentric_arcs.gcode", "voron24", {}),
                                   ("prusa_gyroid.gcode", "prusa-mk3s", {"max_slowdown_r": 0.0})):
                pl.process(str(SAMPLES / name), str(Path(d) / "out.gcode"), load_profile(prof), pl.Options(**kw))
    finally:
        mp.undo()
    return calls


def test_stroke_lines_on_real_runs(seen):
    assert len(seen["lines"]) >= 4
    for got, want, order in seen["lines"]:
        assert want is not None and len(order) > 50
        assert _same_lines(got, want)


def test_departures_on_real_runs(seen):
    assert seen["departures"]
    for got, want in seen["departures"]:
        assert got == want


def test_by_kind_on_real_runs(seen):
    assert seen["rows"] and max(n for _, _, n in seen["rows"]) >= 64     # the rows' path was taken
    for got, want, _ in seen["rows"]:
        assert list(got) == list(want)
        assert _bits(got) == _bits(want)


# ---------------------------------------------------------------- random inputs
def _random_case(rng, n):
    """Strokes in file order with gaps, some re-timed with blocks of other lengths; now and
    then one thing broken (a block at the wrong line, overlapping strokes, a block that
    ends before it starts, a stroke listed twice, a shuffled order)."""
    strokes, line = [], 0
    for _ in range(n):
        line += rng.randrange(0, 4)
        k = rng.randrange(1, 6)
        strokes.append(_S(line, line + k - 1))
        line += k
    out_ranges, off = [], 0
    for i, s in enumerate(strokes):
        if rng.random() < 0.5:
            a = s.first_idx + off
            z = a + rng.randrange(0, 12)
            out_ranges.append((a, z, i))
            off += (z - a) - (s.last_idx - s.first_idx)
    order = list(range(n))
    broken = rng.randrange(8)
    if broken == 0 and out_ranges:
        k = rng.randrange(len(out_ranges))
        a, z, i = out_ranges[k]
        out_ranges[k] = (a + rng.choice((-1, 1)), z, i)
    elif broken == 1 and n > 1:
        k = rng.randrange(1, n)
        strokes[k].first_idx = strokes[k - 1].last_idx - rng.randrange(0, 2)
    elif broken == 2 and out_ranges:
        k = rng.randrange(len(out_ranges))
        a, z, i = out_ranges[k]
        out_ranges[k] = (a, a - 1, i)
    elif broken == 3 and out_ranges:
        out_ranges.append(out_ranges[rng.randrange(len(out_ranges))])
    elif broken == 4:
        rng.shuffle(order)
    return strokes, order, out_ranges


def test_stroke_lines_random():
    rng = random.Random(24)
    n_none = n_ok = 0
    for _ in range(3000):
        strokes, order, out_ranges = _random_case(rng, rng.randrange(1, 40))
        want = pl._stroke_lines_loop(strokes, order, out_ranges)
        got = pl.stroke_lines(strokes, order, out_ranges)
        assert _same_lines(got, want), (order, out_ranges)
        n_none += want is None
        n_ok += want is not None
    assert n_none > 300 and n_ok > 1000        # both answers were met
    assert pl.stroke_lines([], [], []) is not None


def test_departures_random():
    rng = np.random.default_rng(24)

    class _P:
        pass
    for n in (0, 1, 5, 300):
        plan = _P()
        plan.t_pred = rng.uniform(0.0, 0.2, n + 7)
        plan.t_pred[rng.integers(0, n + 7, 3)] = np.nan
        idx = rng.permutation(n + 7)[:n]
        out_ranges = [(3 * k, 3 * k + 2, int(i)) for k, i in enumerate(idx)]
        t1 = plan.t_pred[idx] * rng.choice([1.0, 1.6, 3.0], n) + rng.choice([0.0, 0.06], n)
        if n:
            t1[0] = np.nan
        want = [i for k, (_, _, i) in enumerate(out_ranges) if t1[k] > pl.DEPART_R * plan.t_pred[i] + pl.DEPART_T]
        got = pl._departures(plan, out_ranges, t1)
        assert got == want
        assert all(type(i) is int for i in got)
        if n == 300:
            assert 10 < len(want) < 290


def test_by_kind_random_bits():
    rng = random.Random(7)
    odd = [math.nan, math.inf, -math.inf, -0.0, 0.0, 5e-324, 1e308]
    for n in (3, 64, 65, 500, 2000):
        kinds = [rng.choice(("line", "curve", "arc", "chain")) for _ in range(n)]
        cols = tuple([rng.choice(odd) if rng.random() < 0.02 else rng.uniform(-1, 1) * 10 ** rng.randrange(-8, 4)
                      for _ in range(n)] for _ in range(6))
        ss = []
        for k in kinds:
            s = Stroke.__new__(Stroke)
            s.kind = k
            ss.append(s)
        got, want = {}, {}
        t0, t_law, t1, i0, i_law, a21 = cols
        _kinds_only(list(range(n)), ss, t0, i0, t_law, i_law, t1, a21, got)
        sm._by_kind_loop(kinds, cols, want)
        assert list(got) == list(want)
        assert _bits(got) == _bits(want), n
    # all zeros of both signs: the loop's sums are +0.0 (from 0.0), the rows' too
    kinds = ["line"] * 100
    cols = tuple([-0.0] * 100 for _ in range(6))
    got, want = {}, {}
    _kinds_only(list(range(100)), [_kind_stroke("line")] * 100, *cols[:1], cols[3], cols[1], cols[4], cols[2],
                cols[5], got)
    sm._by_kind_loop(kinds, cols, want)
    assert _bits(got) == _bits(want)


def _kind_stroke(k):
    s = Stroke.__new__(Stroke)
    s.kind = k
    return s


def _kinds_only(idx, ss, t0, i0, t_law, i_law, t1, a21, by_kind):
    """_per_stroke_rows' by-kind sums on strokes that have only a kind (the rows' other
    columns are not wanted here): the by-kind part run through the real function with the
    row columns stubbed."""
    saved = sm.round_list
    sm.round_list = lambda vals, nd: vals
    try:
        for s in ss:
            for f in ("length_d", "v0", "v1", "v_feed", "layer", "feature"):
                if not hasattr(s, f) or getattr(s, f, None) is None:
                    setattr(s, f, 0.0)
            s.first_idx = s.last_idx = 0
        rows = []
        sm._per_stroke_rows(idx, [0] * len(idx), t0, i0, t_law, i_law, t1, a21, [0.0] * len(idx), ss, rows, by_kind)
    finally:
        sm.round_list = saved


def test_n_moves_against_the_property():
    rng = random.Random(3)
    ss = []
    for _ in range(500):
        s = Stroke.__new__(Stroke)
        s.first_idx = rng.randrange(10 ** 6)
        s.last_idx = s.first_idx + rng.randrange(0, 30)
        ss.append(s)
    assert n_moves(ss).tolist() == [s.n_moves for s in ss]

    class Other:
        n_moves = 17
    assert n_moves(ss[:3] + [Other()]).tolist() == [s.n_moves for s in ss[:3]] + [17]
    assert n_moves([]).tolist() == []


def test_watch_list_as_before():
    rng = np.random.default_rng(1)
    n = 1000
    lines = (rng.integers(0, 10 ** 7, n), rng.integers(0, 10 ** 7, n))
    order = rng.permutation(n).tolist()
    want = [(int(lines[0][i]), int(lines[1][i])) for i in order]
    got = list(zip(lines[0][order].tolist(), lines[1][order].tolist()))
    assert got == want and all(type(a) is int and type(z) is int for a, z in got)


# ---------------------------------------------------------------- the collector
def test_young_frozen():
    calls = []
    was = gc.isenabled()
    try:
        gc.enable()
        with pl._young_frozen(lambda: calls.append(gc.isenabled())):
            assert not gc.isenabled()
        assert gc.isenabled() and calls == [False]      # frozen while still off, then on again
        gc.disable()
        with pl._young_frozen(lambda: calls.append("x")):
            pass
        assert not gc.isenabled() and calls == [False]  # off before: left off, no freeze
        gc.enable()
        with pl._young_frozen(None):
            assert gc.isenabled()                       # no freeze: nothing changed
        with pytest.raises(KeyError):
            with pl._young_frozen(lambda: calls.append(1)):
                raise KeyError("x")
        assert gc.isenabled() and calls == [False, 1]
    finally:
        (gc.enable if was else gc.disable)()


def test_process_freezes_after_analyse_plan_and_summary(tmp_path, monkeypatch):
    """The freezes are taken (the count grows after analyse, after planning, after the
    summary), everything is thawed at the end, and the bytes and summary are those of a
    run without any freeze."""
    # segments.JERK_CORNERS (session 29) keeps classic-jerk corners, and this sample (prusa-mk3s)
    # no longer overruns its budget: one pass.  Off, the segments are those this test was made on
    # (two passes under prusa-mk3s; other profiles are not touched by it)
    from gcode_opt import segments as _segments
    monkeypatch.setattr(_segments, "JERK_CORNERS", False)
    counts = []
    real_plan, real_summary, real_rewrite = pl.plan_strokes, sm.build_summary, pl.rewrite

    def spy_plan(*a, **k):
        counts.append(("plan", gc.get_freeze_count(), gc.isenabled()))
        return real_plan(*a, **k)

    def spy_rewrite(*a, **k):
        counts.append(("rewrite", gc.get_freeze_count(), gc.isenabled()))
        return real_rewrite(*a, **k)

    def spy_summary(*a, **k):
        counts.append(("summary", gc.get_freeze_count(), gc.isenabled()))
        return real_summary(*a, **k)
    monkeypatch.setattr(pl, "plan_strokes", spy_plan)
    monkeypatch.setattr(pl, "rewrite", spy_rewrite)
    monkeypatch.setattr(sm, "build_summary", spy_summary)
    src = str(SAMPLES / "prusa_gyroid.gcode")
    prof = load_profile("prusa-mk3s")
    assert gc.get_freeze_count() == 0
    s1 = pl.process(src, str(tmp_path / "a.gcode"), prof, pl.Options())
    assert gc.get_freeze_count() == 0
    assert counts[0][0] == "plan" and counts[0][1] > 1000 and not counts[0][2]   # planned with it off
    summ = [c for c in counts if c[0] == "summary"]
    assert summ and not summ[0][2]
    # planning's objects frozen too (seen at the rewrite: the strokes, frozen since analyse,
    # are let go before the summary, session 50)
    written = [c for c in counts if c[0] == "rewrite"]
    assert written and written[0][1] > counts[0][1]

    class _NoFreeze:
        def __enter__(self):
            return None

        def __exit__(self, *exc):
            return False
    monkeypatch.setattr(pl, "_strokes_frozen", _NoFreeze)
    s2 = pl.process(src, str(tmp_path / "b.gcode"), prof, pl.Options())
    assert (tmp_path / "a.gcode").read_bytes() == (tmp_path / "b.gcode").read_bytes()
    for k in ("timing_s", "elapsed_s", "input", "output"):
        s1.pop(k, None)
        s2.pop(k, None)
    assert _bits(s1) == _bits(s2)
