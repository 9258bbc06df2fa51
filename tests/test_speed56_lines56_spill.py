"""The windowed runs' line plans (issue 8, lines56): schedule.plan_strokes over a StoredStrokes
segments each (line class, T, beta) of a run's lines once, by one row of it, in calls of at
most a window of strokes (schedule._line_figures), judges every row on its key's figures, and
writes each plan made to a temporary file (line_spill.LineSpill: a record of doubles a plan,
a row pointing at its key's record); the rewrite's remake (schedule._PlansAgain._lines) reads
back the record of each re-timed line whose (T, beta) is the record's instead of segmenting it
again.  Here: the runs' figures and reasons are the eager runs' (LAZY_LINES off), each key is
segmented once a run in the fewest calls of a window, made of their records alone where sparse
(no window loaded for them); the plans read back are the eager plans
bit for bit (arrays, figures, type, shape); a record of another law is not read back; plans
the records do not hold are left out; a failed write loses every record; the records of the
call before are not read again; and the windowed command writes the list path's file with no
line segmented by its rewrite."""
import os

import numpy as np
import pytest

from gcode_opt import line_spill as ls
from gcode_opt import pipeline as pl
from gcode_opt import schedule as sc
from gcode_opt.segments import RowPlan, SegmentPlan

from windowed_run import run_command

from test_speed52_runs52_windows import seg_bits
from test_speed53_plans53_lazy import FIGURES, SAMPLES, _plans

NAME, PROF, WINDOW = "prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 16


@pytest.fixture(autouse=True)
def _chains_eager(monkeypatch):
    """The lines alone let go here (the chains' plans kept: test_speed55_chain_spill.py)."""
    monkeypatch.setattr(sc, "LAZY_CHAINS", False)


def _bits(p):
    """seg_bits with the plan's fault verdict."""
    return None if p is None else seg_bits(p) + (p.fault,)


def test_runs_segment_each_key_once_in_window_calls(monkeypatch):
    runs = []                   # a run's lines: ([strokes of each _line_segments call], its keys met)
    figures, segments = sc._line_figures, sc._line_segments

    def spy_figures(fn, rows, window, plan, strokes, a2_orig, line_cls, spill=None):
        runs.append(([], [], rows.size, line_cls))
        return figures(fn, rows, window, plan, strokes, a2_orig, line_cls, spill)

    def spy_segments(sts, T, beta, rules, same=None, cmd=None):
        if sc.LAZY_LINES:       # (not the eager reference's runs)
            runs[-1][0].append(len(sts))
            runs[-1][1].extend(zip(same.tolist(), T.tolist(), beta.tolist()))
        return segments(sts, T, beta, rules, same, cmd)
    monkeypatch.setattr(sc, "_line_figures", spy_figures)
    monkeypatch.setattr(sc, "_line_segments", spy_segments)
    (strokes, store, _, _, plan, pin), (fig, reason, _) = _plans(NAME, PROF, WINDOW, monkeypatch)
    store.close()
    assert plan.remake.line_cls is not None            # (the sample's lines repeat: keyed)
    first = [r for r in runs if r[2]][0]
    for calls, keys, n_rows, _ in runs:
        assert len(keys) == len(set(keys))              # each key segmented once a run
        assert all(n <= WINDOW for n in calls)          # a window of strokes as objects a call at most
        assert len(calls) == -(-len(keys) // WINDOW)    # in the fewest such calls
    # far fewer lines segmented than judged (the sample's layers repeat)
    assert len(first[1]) * 2 < first[2]
    for k in FIGURES:
        assert getattr(plan, k).tobytes() == fig[k].tobytes(), k
    assert list(plan.reason) == reason


@pytest.mark.parametrize("name,window", [(NAME, WINDOW), ("prusa_gyroid.gcode", 64)])
def test_runs_load_no_window_for_sparse_lines(name, window, monkeypatch):
    """The lines a run segments, where under half of their windows' strokes, are made of their
    records alone (the store's take), keyed or not: no window of the StoredStrokes loaded for
    them; the others by their windows; the eager runs' figures either way."""
    calls = []                  # (sparse, windows loaded, strokes made)
    taken = sc._stored_rows

    def spy(strokes, rows):
        n = strokes.loads
        spans = np.unique(rows // strokes.window).size
        got = taken(strokes, rows)
        calls.append((2 * rows.size < spans * strokes.window, strokes.loads - n, len(got)))
        return got
    monkeypatch.setattr(sc, "_stored_rows", spy)
    (strokes, store, _, _, plan, pin), (fig, reason, _) = _plans(name, PROF, window, monkeypatch)
    store.close()
    sparse = [c for c in calls if c[0]]
    assert sum(c[2] for c in sparse) > 100 and all(c[1] == 0 for c in sparse)
    for k in FIGURES:
        assert getattr(plan, k).tobytes() == fig[k].tobytes(), k
    assert list(plan.reason) == reason


@pytest.mark.parametrize("name,window", [(NAME, WINDOW), ("prusa_gyroid.gcode", 64)])
def test_rewrite_reads_back_every_line_plan(name, window, monkeypatch):
    """Every re-timed line's plan read back (none segmented again), the eager runs' bit for bit;
    keyed (the rectilinear sample's classes) or not (the gyroid's lines repeat too little)."""
    (strokes, store, _, _, plan, pin), (_, _, segs) = _plans(name, PROF, window, monkeypatch)
    made = []
    segments = sc._line_segments
    monkeypatch.setattr(sc, "_line_segments", lambda sts, *a, **k: made.append(len(sts)) or segments(sts, *a, **k))
    lines = np.flatnonzero(plan.retime & (pin.plan_kind_codes == sc.C_LINE))
    assert lines.size > 50
    assert (plan.remake.line_cls is not None) == ("rectilinear" in name)
    with store:
        every = np.arange(len(strokes))
        for a in range(0, every.size, window):
            rows = every[a:a + window]
            sc.segs_for(plan, rows, strokes)
            for i in rows.tolist():
                assert seg_bits(plan.segs[i]) == segs[i], i
    assert made == []


def test_record_of_another_key_is_not_read_back(monkeypatch):
    (strokes, store, _, _, plan, pin), _ = _plans(NAME, PROF, WINDOW, monkeypatch)
    with store:
        spill, cls = plan.remake.line_spill, plan.remake.line_cls
        rows = np.flatnonzero(plan.retime & (pin.plan_kind_codes == sc.C_LINE))
        assert rows.size > 50
        got, _, rest = spill.take(rows, cls[rows], plan.T[rows], plan.beta[rows])
        assert got.tolist() == rows.tolist() and rest.size == 0
        beta = plan.beta[rows].copy()
        beta[::4] = np.nextafter(beta[::4], -np.inf)       # (one bit off: another law; beta may be inf)
        T = plan.T[rows].copy()
        T[1::4] = np.nextafter(T[1::4], 0.0)
        c = cls[rows].copy()
        c[2::4] = -1 - rows[2::4]                           # (another class: none such)
        spill.last = None
        for _ in range(2):      # (the second: the call before's records, taken without a read, checked too)
            got, plans, rest = spill.take(rows, c, T, beta)
            assert got.tolist() == rows[3::4].tolist()
            assert sorted(rest.tolist()) == sorted(set(rows.tolist()) - set(rows[3::4].tolist()))


def _plans_of_kinds():
    """RowPlans of a block (two of the law, one a trapezoid), a SegmentPlan, a trapezoid
    SegmentPlan, a plan with a junction command, None, a SegmentPlan with a fault (a feed
    below 0), a RowPlan whose knots are its stroke's ends (an array of doubles)."""
    from array import array
    rng = np.random.default_rng(56)
    S = np.cumsum(rng.random((3, 4)), axis=1)
    V, A, F = rng.random((3, 4)), rng.random((3, 3)) + 1.0, rng.random((3, 3)) + 1.0
    row = [RowPlan(S, V, A, F, i, 1.0 + i, 2.0 + i) for i in range(3)]
    row[1].shape = "trapezoid"
    seg = SegmentPlan(np.array([0.0, 1.0, 2.5]), np.array([1.0, 2.0, 1.5]), np.array([3.0, 4.0]),
                      np.array([5.0, 6.0]), 0.75, 0.25)
    trap = SegmentPlan(seg.s, seg.v, seg.accel, seg.feed, 0.5, 0.5, shape="trapezoid")
    cmd = SegmentPlan(seg.s, seg.v, seg.accel, seg.feed, 0.5, 0.5, first_cmds=("M204 S1", ""))
    bad = SegmentPlan(seg.s, seg.v, seg.accel, np.array([-1.0, 6.0]), 0.75, 0.25)
    ends = RowPlan(array("d", [0.5, 1.5, 2.0]), V, A, F, 0, 3.0, 4.0)
    return [row[2], seg, trap, row[0], cmd, None, row[1], bad, ends]


def _keys(m=9):
    """m keys: classes 10, 11, ..., T and beta rising."""
    return np.arange(10, 10 + m, dtype=np.int64), np.linspace(1.0, 2.0, m), np.linspace(0.1, 0.2, m)


def test_records_of_every_kind_held():
    plans = _plans_of_kinds()
    spill = ls.LineSpill.make()
    cls, T, beta = _keys()
    sc.seg_fault(plans[0])              # (verdicts made: "" kept with the record, a reason not)
    sc.seg_fault(plans[7])
    spill.put(plans, cls, T, beta)
    rows = np.array([1, 3, 4, 6, 9, 10, 12, 14, 15])
    got, back, rest = spill.take(rows, cls, T, beta)
    held = [0, 1, 2, 3, 6, 7, 8]
    assert got.tolist() == rows[held].tolist() and rest.tolist() == [9, 10]
    assert [_bits(p) for p in back] == [_bits(p) if p.fault == "" else _bits(p)[:-1] + (None,)
                                        for p in map(plans.__getitem__, held)]
    assert [type(p) for p in back] == [RowPlan, SegmentPlan, SegmentPlan, RowPlan, RowPlan, SegmentPlan, RowPlan]
    assert [p.shape for p in back] == ["law", "law", "trapezoid", "law", "trapezoid", "law", "law"]
    assert sc.seg_fault(back[5]) == sc.seg_fault(plans[7]) != ""
    # rows of one key share one plan object
    got, back, _ = spill.take(np.array([2, 3, 5]), cls[[1, 1, 1]], T[[1, 1, 1]], beta[[1, 1, 1]])
    assert got.tolist() == [2, 3, 5] and back[0] is back[1] is back[2]
    spill.close()


def test_keys_sharing_a_hash_told_apart(monkeypatch):
    """Keys whose hashes are equal (every one here): a row never gets another key's plan (a
    key whose hash another record holds first is the caller's to make)."""
    monkeypatch.setattr(ls, "_key_hash", lambda cls, T, beta: np.zeros(np.size(cls), np.uint64))
    plans = _plans_of_kinds()
    spill = ls.LineSpill.make()
    cls, T, beta = _keys()
    spill.put(plans, cls, T, beta)
    rows = np.arange(9)
    got, back, rest = spill.take(rows, cls, T, beta)
    assert got.size == 1 and sorted(got.tolist() + rest.tolist()) == rows.tolist()
    assert [seg_bits(p) for p in back] == [seg_bits(plans[q]) for q in got.tolist()]
    # a key one part off: none (its hash the same)
    for key in ((cls + 100, T, beta), (cls, np.nextafter(T, 0.0), beta), (cls, T, np.nextafter(beta, 0.0))):
        assert spill.take(rows, *key)[0].size == 0
    spill.close()


def test_records_of_the_call_before_not_read_again(monkeypatch):
    plans = _plans_of_kinds()
    spill = ls.LineSpill.make()
    cls, T, beta = _keys()
    rows = np.arange(9)
    spill.put(plans, cls, T, beta)
    reads = []
    read = spill._read
    monkeypatch.setattr(spill, "_read", lambda at, lens: reads.append(at.size) or read(at, lens))
    _, first, _ = spill.take(rows[:4], cls[:4], T[:4], beta[:4])
    _, again, _ = spill.take(rows[2:8], cls[2:8], T[2:8], beta[2:8])
    assert reads == [4, 2]                      # (rows 2, 3 taken from the call before; 4, 5 hold none)
    assert again[0] is first[2] and again[1] is first[3]
    _, third, _ = spill.take(rows[:2], cls[:2], T[:2], beta[:2])
    assert reads == [4, 2, 2]                   # (only the call just before kept)
    assert [_bits(p) for p in third] == [_bits(p) for p in first[:2]]
    spill.close()


class _Refusing:
    """A file whose writes fail."""

    def __init__(self, fh):
        self.fh = fh

    def seek(self, *a):
        return self.fh.seek(*a)

    def write(self, b):
        raise OSError("disk full")

    def close(self):
        pass


def test_failed_write_loses_every_record():
    plans = _plans_of_kinds()
    spill = ls.LineSpill.make()
    cls, T, beta = _keys()
    rows = np.arange(9)
    spill.put(plans[:2], cls[:2], T[:2], beta[:2])
    assert spill.take(rows[:2], cls[:2], T[:2], beta[:2])[0].tolist() == [0, 1]
    fh = spill.fh
    spill.fh = _Refusing(fh)
    spill.put(plans[2:], cls[2:], T[2:], beta[2:])
    assert spill.fh is None
    fh.close()
    got, back, rest = spill.take(rows, cls, T, beta)
    assert got.size == 0 and rest.tolist() == rows.tolist()


def test_plans_past_the_bounds_are_not_held(monkeypatch):
    """A plan of more segments than nseg holds is not written; records that would pass
    MAX_END doubles end the spill."""
    plans = _plans_of_kinds()
    cls, T, beta = _keys()
    monkeypatch.setattr(ls, "MAX_N", 2)         # (the block's RowPlans have 3 segments, the others 2)
    spill = ls.LineSpill.make()
    spill.put(plans, cls, T, beta)
    assert spill.take(np.arange(9), cls, T, beta)[0].tolist() == [1, 2, 7]
    monkeypatch.setattr(ls, "MAX_END", spill.end + ls.record_len(2) - 1)
    spill.put(plans[1:2], cls[1:2], T[1:2], beta[1:2])
    assert spill.fh is None


def test_windowed_command_segments_no_line_in_its_rewrite(monkeypatch, tmp_path):
    """The command windowed writes the list path's file and summary, its rewrite segmenting no
    line (every re-timed line's plan read back from the runs' spill)."""
    monkeypatch.setattr(sc, "LAZY_CHAINS", True)
    after, made = [False], []
    plan_strokes, segments = pl.plan_strokes, sc._line_segments

    def spy_plan(*a, **k):
        got = plan_strokes(*a, **k)
        after[0] = True
        return got
    monkeypatch.setattr(pl, "plan_strokes", spy_plan)
    monkeypatch.setattr(sc, "_line_segments", lambda sts, *a, **k: (made.append(len(sts)) if after[0] else None)
                        or segments(sts, *a, **k))

    def run(windowed):
        after[0] = False
        return run_command(monkeypatch, os.path.join(SAMPLES, NAME),
                           tmp_path / f"{windowed}.gcode", windowed, 37, PROF)
    want = run(False)
    made.clear()
    got = run(True)
    assert got[0] == want[0]
    assert got[1] == want[1]
    assert made == []
