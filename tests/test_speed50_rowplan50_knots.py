"""Issue 8 (s50 rowplan50, the plan's peak memory): a chain's RowPlan takes its knots from
its stroke's own ends_d (0, then those: segments.knots_of_ends, made when read), not from
a block of knots made for the plans (chains._knots_rows: ~2.5 MB held from the first
budget run to the rewrite on the gyroid plate's ~16 k chains).  Held to the code it
replaced (_knots_rows kept here verbatim from a0c8d7a, each plan a row of its block):

  * on real chains through budget runs (_fit_budget's runs, REUSE_RUNS as in production):
    every plan's knots, speeds, accelerations, feeds, figures and verdict the same bits,
    and the written G-code the same bytes;
  * their verdicts made as _replay makes them (settle_faults' _settle_rows on their knots
    made as one block there, not kept), and settle_faults' on such plans made elsewhere,
    against _seg_fault_any of each plan's own four arrays, with bad numbers in each;
  * the compiled rewrite (_emit.c's run: the knots 0 then the array's doubles) against the
    Python rewrite kept in test_speed20_rewrite_core, the run taking the chains."""
from __future__ import annotations

import os
from array import array

import numpy as np
import pytest

from gcode_opt import chains, emit, pipeline, schedule, segments
from gcode_opt.profile import load_profile
from gcode_opt.segments import RowPlan, SegmentPlan
from gcode_opt.strokes import K_ARC

from test_speed25_alloc_rowplans import _runs as runs_of_plans

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")
CASES = [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_gyroid_fullspeed.gcode", "prusa-mk3s"),
         ("prusa_gyroid_fullspeed_klipper.gcode", "voron24")]


def ref_knots_rows(sts, n):
    """chains._knots_rows at a0c8d7a (verbatim)."""
    ends = [st.ends_d for st in sts]
    if not all(type(e) is array and e.typecode == "d" and len(e) == n for e in ends):
        return None
    s = np.empty((len(ends), n + 1))
    s[:, 0] = 0.0
    s[:, 1:] = np.frombuffer(b"".join(ends), float).reshape(len(ends), n)
    return s


def _ref_ends_rows(sts, n):
    """_ends_rows giving, for each chain, the block of the old code: RowPlan(S, V, A, F,
    i, ...) of row i is then the plan a0c8d7a made."""
    S = ref_knots_rows(sts, n)
    return None if S is None else [S] * len(sts)


def _bits(x):
    return np.ascontiguousarray(np.asarray(x, float)).view(np.int64).tobytes()


def _runs(name, prof, monkeypatch, old):
    """test_speed25's budget runs (each run's plans as they are then), with the old
    blocks of knots where old."""
    if old:               # (the verdicts then made by settle_faults, as a0c8d7a made them)
        monkeypatch.setattr(chains, "_ends_rows", _ref_ends_rows)
        monkeypatch.setattr(chains, "_settle_ends_plans", lambda *a: None)
    return runs_of_plans(name, prof, monkeypatch, False)


@pytest.mark.parametrize("name,prof", CASES)
def test_plans_are_the_block_rows(name, prof, monkeypatch):
    made = []
    real = chains._ends_rows
    monkeypatch.setattr(chains, "_ends_rows", lambda sts, n: made.append(real(sts, n)) or made[-1])
    got = _runs(name, prof, monkeypatch, False)
    ref = _runs(name, prof, monkeypatch, True)
    assert sum(len(e) for e in made if e is not None) > 100     # chains' plans were made of their ends
    assert len(got) == len(ref) >= 3
    for a_run, b_run in zip(got, ref):
        assert list(map(_record, a_run)) == list(map(_record, b_run))
    assert sum(a is not None and a[0] is RowPlan for a in got[0]) > 100


def _record(a):
    """A plan's record of runs_of_plans with its arrays as (type, shape, dtype, bits) and
    its figures as bits."""
    if a is None:
        return None
    arrays = tuple((type(x), x.shape, x.dtype, _bits(x)) for x in a[1:5])
    return (a[0], arrays, _bits(a[5]), _bits(a[6])) + tuple(a[7:])


def test_written_gcode_is_the_same(tmp_path, monkeypatch):
    prof = load_profile("prusa-mk3s")
    src = os.path.join(SAMPLES, "prusa_gyroid.gcode")
    outs = []
    for old in (False, True):
        with monkeypatch.context() as m:
            if old:
                m.setattr(chains, "_ends_rows", _ref_ends_rows)
                m.setattr(chains, "_settle_ends_plans", lambda *a: None)
            out = tmp_path / f"out{old}.gcode"
            pipeline._process(src, str(out), prof, pipeline.Options())
            outs.append(out.read_bytes())
    assert outs[0] == outs[1]


def test_knots_of_ends_and_setters():
    ends = array("d", [0.5, 1.25, 3.0])
    V, A, F = np.ones((4, 4)), np.full((4, 3), 2.0), np.full((4, 3), 3.0)
    p = RowPlan(ends, V, A, F, 2, 1.0, 2.0)
    assert _bits(p.s) == _bits([0.0, 0.5, 1.25, 3.0]) and p.s.dtype == np.float64
    assert schedule.seg_fault(p) == ""
    p.feed = np.full(3, 4.0)              # another array: the plan's own rows, the knots made of ends
    assert p._row is None and type(p._s) is np.ndarray and _bits(p.s) == _bits([0.0, 0.5, 1.25, 3.0])
    assert (p.v == 1.0).all() and (p.accel == 2.0).all() and (p.feed == 4.0).all() and p.fault is None


def _synthetic_plans(rng):
    """RowPlans of ends arrays on a few sets of blocks, bad numbers here and there."""
    plans = []
    for m, n in ((7, 4), (300, 9), (2100, 3)):
        V = rng.random((m, n + 1)) + 0.1
        A = rng.random((m, n)) + 0.5
        F = rng.random((m, n)) + 1.0
        for r in rng.choice(m, m // 5, replace=False):        # bad speeds, accelerations, feeds
            blk, c = (V, A, F)[r % 3], int(rng.integers(n))
            blk[r, c] = (-1.0, 0.0, np.nan, np.inf)[r % 4]
        rows = rng.permutation(m) if m == 300 else np.arange(m)   # (rows out of order: gathered)
        for r in rows.tolist():
            e = np.cumsum(rng.random(n) + 0.01)
            if r % 7 == 3:
                e[r % n] = e[r % n - 1] if r % n else 0.0          # a knot not above the one before
            if r % 11 == 5:
                e[-1] = np.nan
            t = float(rng.uniform(0.1, 2.0)) if r % 13 else np.inf
            plans.append(RowPlan(array("d", e.tobytes()), V, A, F, r, t, float(rng.uniform(0, 9))))
    return plans


def test_settle_faults_verdicts():
    plans = _synthetic_plans(np.random.default_rng(50))
    schedule.settle_faults(plans)
    n_fine = 0
    for p in plans:
        ref = schedule._seg_fault_any(SegmentPlan(segments.knots_of_ends(p._s), p._v[p._row], p._accel[p._row],
                                                  p._feed[p._row], p.time_t, p.int_a2))
        assert p.fault in (None, "")
        if p.fault == "":                 # settled: the reference finds nothing either
            assert ref == ""
            n_fine += 1
        else:                             # left for seg_fault: its verdict is the reference's
            assert ref != "" and schedule.seg_fault(p) == ref
    assert 0.3 * len(plans) < n_fine < len(plans)


def test_replay_keeps_the_verdicts(monkeypatch):
    """The chains' plans _replay makes carry settle_faults' verdict already ("" where fine:
    chains._settle_ends_plans on their knots made as one block, not kept): each one the
    verdict of its own four arrays (_seg_fault_any)."""
    made = []
    real = chains._replay

    def replay(*a, **k):
        out = real(*a, **k)
        made.extend((p, p.fault) for p in out)       # (the verdicts as _replay left them)
        return out
    monkeypatch.setattr(chains, "_replay", replay)
    _runs("prusa_gyroid_fullspeed.gcode", "prusa-mk3s", monkeypatch, False)
    plans = [(p, f) for p, f in made if type(p) is RowPlan and type(p._s) is array]
    assert len(plans) > 100
    for p, fault in plans:
        ref = schedule._seg_fault_any(SegmentPlan(segments.knots_of_ends(p._s), p._v[p._row], p._accel[p._row],
                                                  p._feed[p._row], p.time_t, p.int_a2))
        assert fault == ref == "" or (fault is None and ref != "")


CORE = emit.CORE_MOD


@pytest.mark.skipif(CORE is None or not hasattr(CORE, "stroke_run"), reason="no compiled emit core")
def test_compiled_rewrite_takes_the_chains(tmp_path, monkeypatch):
    from test_speed20_rewrite_core import _planned, _run, ref_rewrite
    from test_speed25_rewritec_run import _counted_run
    for name, prof_name in CASES[:2]:
        prof, opts, strokes, plan = _planned(name, prof_name)
        n_ends = sum(type(getattr(s, "_s", None)) is array for s in plan.segs)
        assert n_ends > 50
        path = os.path.join(SAMPLES, name)
        ref = _run(ref_rewrite, path, strokes, plan, prof, opts, tmp_path / "ref.gcode")
        got, core = _counted_run(monkeypatch, path, strokes, plan, prof, opts, tmp_path / "run.gcode")
        assert got == ref
        # the run wrote the chains' blocks itself: the loop's stroke_block saw hardly any
        line_strokes = sum(1 for i, r in enumerate(ref[4]) if r and strokes[i].kind != K_ARC)
        assert core.runs >= 1 and core.blocks <= 0.1 * line_strokes, (core.blocks, line_strokes)
