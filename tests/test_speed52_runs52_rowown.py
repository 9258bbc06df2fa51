"""Which kinds' segment plans are their rows' own (issue 8, runs52): a row's plan the same
bits whether its kind's segments are made for it alone, in windows of rows of any size, in
any order, or for the whole batch -- what lets the budget runs segment a window of rows at
a time (schedule._by_windows, WINDOW_KINDS).

- lines (segments.plan_segments): every step per stroke;
- chains (chains.plan_chain_segments): cold (no memo: solve_chains) and warm (the memos the
  candidates filled: kept plans, replayed laws);
- arcs and curves (the circle law, laws/circle.py): their own wherever the BLAS gives a row
  its bits wherever it sits (circle.rows_invariant), else _by_windows solves such a kind's
  rows in one batch; Newton's steps are each arc's own too since arcs53
  (test_speed53_arcs53_runs.py: arcs and curves that go to Newton, windows of any size)."""
import numpy as np
import pytest

from gcode_opt import features as feat
from gcode_opt import pipeline as pl
from gcode_opt import schedule as sc
from gcode_opt.laws import circle
from gcode_opt.profile import load_profile
from gcode_opt.segments import SegmentRules
from gcode_opt.strokes import K_ARC, K_CHAIN, K_CURVE, K_LINE

from test_speed52_runs52_windows import seg_bits

SAMPLES = "sample_gcode/"


def _fresh(name, prof_name, candidates=False):
    """The sample's strokes (a list) and PlanInput as the runs get them: after plan_inputs,
    and (candidates) after the candidate tables (the chains' memos filled)."""
    path = SAMPLES + name
    prof = load_profile(prof_name)
    opts = pl.Options(features=feat.default_selection(path)[0])
    strokes, sim0 = pl.analyse(path, prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    if candidates:
        rows = sc._rows_by_kind(strokes, sc._plan_kind_codes_of(strokes, pin))
        failed = sc._faults_of(pin.fault)
        sc.candidates_in_windows(strokes, pin, prof, opts, rows, failed, [0, len(strokes)])
    return strokes, pin, prof, opts, sim0


_LAWS = {}


def _laws(name, prof_name):
    """(T, beta) of every row and the re-timed rows, from the budget runs on the sample."""
    if (name, prof_name) not in _LAWS:
        strokes, pin, prof, opts, sim0 = _fresh(name, prof_name)
        plan = sc.plan_strokes(strokes, pin, prof, opts, opts.max_slowdown_r * sim0.time_t)
        _LAWS[name, prof_name] = (plan.T.copy(), plan.beta.copy(), np.flatnonzero(plan.retime))
    return _LAWS[name, prof_name]


def _segments(kind, name, prof_name, parts, candidates=False):
    """{row: its plan's bits} of the kind's re-timed rows, segmented one call a part (a list
    of row arrays), on fresh strokes; and the arcs sent to Newton meanwhile."""
    T, beta, idx = _laws(name, prof_name)
    strokes, pin, prof, opts, _ = _fresh(name, prof_name, candidates)
    rules = SegmentRules.for_profile(prof, opts.max_segments)
    sc._rebuild_geometry(strokes, idx, sc._plan_kind_codes_of(strokes, pin)[idx], prof)
    n0 = circle.NEWTON_ARCS[0]
    out = {}
    for r in parts:
        got = sc.KINDS[kind].segments([strokes[i] for i in r.tolist()], T[r], beta[r], rules, prof)
        out.update(zip(r.tolist(), map(seg_bits, got)))
    return out, circle.NEWTON_ARCS[0] - n0


def _rows(kind, name, prof_name):
    T, beta, idx = _laws(name, prof_name)
    strokes, pin = _fresh(name, prof_name)[:2]
    codes = sc._plan_kind_codes_of(strokes, pin)
    return idx[codes[idx] == sc.KIND_CODE[kind]]


def _partitions(rows, seed=0):
    """the rows whole; in windows of 1, 5 and 64 rows; shuffled in windows of 7"""
    rng = np.random.default_rng(seed)
    shuffled = rng.permutation(rows)
    yield "whole", [rows]
    for w in (1, 5, 64):
        yield f"windows of {w}", [rows[a:a + w] for a in range(0, rows.size, w)]
    yield "shuffled", [shuffled[a:a + 7] for a in range(0, rows.size, 7)]


CASES = [(K_LINE, "prusa_gyroid_arcs.gcode", "prusa-mk3s", False),
         (K_LINE, "prusa_mk3s_rectilinear.gcode", "prusa-mk3s", False),
         (K_ARC, "prusa_gyroid_arcs.gcode", "prusa-mk3s", False),
         (K_CURVE, "prusa_gyroid_arcs.gcode", "prusa-mk3s", False),
         (K_CURVE, "prusa_benchy_like.gcode", "prusa-mk3s", False),
         (K_CHAIN, "prusa_gyroid_arcs.gcode", "prusa-mk3s", False),
         (K_CHAIN, "prusa_gyroid_arcs.gcode", "prusa-mk3s", True),
         (K_CHAIN, "prusa_benchy_like.gcode", "voron24", True)]


@pytest.mark.parametrize("kind,name,prof_name,candidates", CASES)
def test_rows_are_their_own(kind, name, prof_name, candidates):
    rows = _rows(kind, name, prof_name)
    assert rows.size >= 20                                   # (enough rows to cut)
    ref, newton = _segments(kind, name, prof_name, [rows], candidates)
    if kind in (K_ARC, K_CURVE):
        assert newton == 0 and circle.rows_invariant()       # (the condition of their own bits)
    assert sum(v is not None for v in ref.values()) >= 10
    for how, parts in _partitions(rows):
        got, _ = _segments(kind, name, prof_name, parts, candidates)
        assert got == ref, how
