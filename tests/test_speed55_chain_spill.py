"""The windowed runs' chain plans spilled for the rewrite (issue 8, replay55): schedule.plan_strokes
over a StoredStrokes writes each chain plan its runs make (_chain_plans) to a temporary file
(_ChainSpill: a record of doubles a plan), and the rewrite's remake (_PlansAgain) reads back the
record of each re-timed chain whose (T, beta) is the record's instead of planning the chain
again.  Here: the plans read back are the plans made again bit for bit (arrays, figures, type,
fault verdict), a record of another law is not read back, plans the records do not hold are
left out, a later record of a row replaces it, a failed write loses every record (the rows are
planned again), and the windowed command's rewrite plans no chain."""
import os

import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt import pipeline as pl
from gcode_opt import schedule as sc
from gcode_opt.profile import load_profile
from gcode_opt.segments import RowPlan, SegmentPlan

from windowed_run import run_command

from test_speed52_runs52_windows import seg_bits
from test_speed53_plans53_lazy import SAMPLES, _stored_plan


def _bits(p):
    """seg_bits with the plan's fault verdict (the settle's "" or None: made when asked)."""
    return None if p is None else seg_bits(p) + (p.fault,)


def _timed_chains(name="prusa_gyroid_fullspeed.gcode", window=37):
    strokes, store, prof, opts, plan, pin = _stored_plan(name, "prusa-mk3s", window)
    rules = sc.SegmentRules.for_profile(prof, opts.max_segments)
    rows = np.flatnonzero(plan.retime & (pin.plan_kind_codes == sc.C_CHAIN))
    return strokes, store, prof, rules, plan, rows


def test_spilled_plans_are_the_plans_made_again():
    strokes, store, prof, rules, plan, rows = _timed_chains()
    with store:
        spill = plan.remake.spill
        assert rows.size > 50 and (spill.at[rows] >= 0).all()
        got, plans, rest = spill.take(rows, plan.T[rows], plan.beta[rows])
        assert got.tolist() == rows.tolist() and rest.size == 0
        again = sc._chain_plans(strokes, plan, rules, prof, rows)        # (no spill: made again)
        assert [_bits(p) for p in plans] == [_bits(p) for p in again]
        assert all(p.fault == "" for p in plans)


def test_spilled_chains_keep_no_law():
    """The runs spilling their plans, no chain keeps the law it chose for the rewrite (_Chosen,
    replay54's: kept with no spill)."""
    for spill in (True, False):
        sc.SPILL_CHAINS = spill
        try:
            strokes, store, prof, rules, plan, rows = _timed_chains()
        finally:
            sc.SPILL_CHAINS = True
        with store:
            assert (plan.remake.spill is not None) == spill
            n = sum(type(strokes[i].chain_T.kept) is chains._Chosen for i in rows.tolist())
            assert n == 0 if spill else n > 50


def test_record_of_another_law_is_not_read_back():
    strokes, store, prof, rules, plan, rows = _timed_chains()
    with store:
        spill = plan.remake.spill
        beta = plan.beta[rows].copy()
        beta[::3] = np.nextafter(beta[::3], np.inf)        # (one bit off: another law)
        T = plan.T[rows].copy()
        T[1::3] = np.nextafter(T[1::3], 0.0)
        got, plans, rest = spill.take(rows, T, beta)
        assert got.tolist() == rows[2::3].tolist()
        assert sorted(rest.tolist()) == sorted(rows[0::3].tolist() + rows[1::3].tolist())
        free = np.setdiff1d(np.arange(len(strokes)), rows)[:5]
        free = free[spill.at[free] < 0]
        assert free.size
        got, _, rest = spill.take(free, plan.T[free], plan.beta[free])
        assert got.size == 0 and rest.tolist() == free.tolist()


def _plans_of_kinds():
    """A RowPlan of a block (knots from ends: chains._replay's), a SegmentPlan, a trapezoid,
    a plan with a junction command, None, and a SegmentPlan with a fault (a feed below 0)."""
    from array import array
    rng = np.random.default_rng(5)
    V, A, F = rng.random((3, 4)), rng.random((3, 3)) + 1.0, rng.random((3, 3)) + 1.0
    ends = [array("d", np.cumsum(rng.random(3) + 0.1).tolist()) for _ in range(3)]
    row = [RowPlan(ends[i], V, A, F, i, 1.0 + i, 2.0 + i) for i in range(3)]
    seg = SegmentPlan(np.array([0.0, 1.0, 2.5]), np.array([1.0, 2.0, 1.5]), np.array([3.0, 4.0]),
                      np.array([5.0, 6.0]), 0.75, 0.25)
    trap = SegmentPlan(seg.s, seg.v, seg.accel, seg.feed, 0.5, 0.5, shape="trapezoid")
    cmd = SegmentPlan(seg.s, seg.v, seg.accel, seg.feed, 0.5, 0.5, first_cmds=("M204 S1", ""))
    bad = SegmentPlan(seg.s, seg.v, seg.accel, np.array([-1.0, 6.0]), 0.75, 0.25)
    return [row[2], seg, trap, row[0], cmd, None, row[1], bad]


def test_records_of_every_kind_held():
    plans = _plans_of_kinds()
    spill = sc._ChainSpill.make(20)
    rows = np.array([1, 3, 4, 6, 9, 10, 12, 14])
    T, beta = np.linspace(1.0, 2.0, 8), np.linspace(0.1, 0.2, 8)
    sc.seg_fault(plans[0])              # (a verdict made: "", kept with the record)
    spill.put(rows, T, beta, plans)
    got, back, rest = spill.take(rows, T, beta)
    assert got.tolist() == [1, 3, 6, 12, 14] and rest.tolist() == [4, 9, 10]
    assert [seg_bits(p) for p in back] == [seg_bits(plans[q]) for q in (0, 1, 3, 6, 7)]
    assert [p.fault for p in back] == ["", None, None, None, None]
    assert [sc.seg_fault(p) for p in back] == [sc.seg_fault(plans[q]) for q in (0, 1, 3, 6, 7)]
    assert sc.seg_fault(back[-1]) != ""
    assert [type(p) for p in back] == [RowPlan, SegmentPlan, RowPlan, RowPlan, SegmentPlan]
    # a later record of a row replaces it (another law: the old one no longer read back)
    spill.put(rows[:1], T[1:2], beta[1:2], [plans[1]])
    got, back, rest = spill.take(rows[:2], T[:2], beta[:2])
    assert got.tolist() == [3] and rest.tolist() == [1]
    got, back, _ = spill.take(rows[:1], T[1:2], beta[1:2])
    assert got.tolist() == [1] and seg_bits(back[0]) == seg_bits(plans[1])
    spill.close()


def test_failed_write_loses_every_record():
    plans = _plans_of_kinds()
    spill = sc._ChainSpill.make(20)
    rows = np.array([1, 3, 4, 6, 9, 10, 12, 14])
    T, beta = np.linspace(1.0, 2.0, 8), np.linspace(0.1, 0.2, 8)
    spill.put(rows[:2], T[:2], beta[:2], plans[:2])
    assert spill.take(rows[:2], T[:2], beta[:2])[0].tolist() == [1, 3]
    fh = spill.fh
    spill.fh = _Refusing(fh)
    spill.put(rows[2:], T[2:], beta[2:], plans[2:])
    assert spill.fh is None
    fh.close()
    got, back, rest = spill.take(rows, T, beta)
    assert got.size == 0 and rest.tolist() == rows.tolist()


def test_records_past_their_bounds_are_made_again(monkeypatch):
    """A plan of more segments than nseg holds is not spilled; records that would pass the
    int32 indices (_SPILL_END) end the spill: every row is made again."""
    plans = _plans_of_kinds()
    rows = np.array([1, 3, 4, 6, 9, 10, 12, 14])
    T, beta = np.linspace(1.0, 2.0, 8), np.linspace(0.1, 0.2, 8)
    monkeypatch.setattr(sc, "_SPILL_N", 2)          # (the block's RowPlans have 3 segments, the others 2)
    spill = sc._ChainSpill.make(20)
    spill.put(rows, T, beta, plans)
    assert spill.take(rows, T, beta)[0].tolist() == [3, 14]
    monkeypatch.setattr(sc, "_SPILL_END", spill.end + sc._spill_len(2) - 1)
    spill.put(rows[1:2], T[1:2], beta[1:2], plans[1:2])
    assert spill.fh is None
    got, _, rest = spill.take(rows, T, beta)
    assert got.size == 0 and rest.tolist() == rows.tolist()


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


@pytest.mark.parametrize("name,window", [("prusa_gyroid_fullspeed.gcode", 37), ("prusa_gyroid.gcode", 64)])
def test_windowed_rewrite_reads_the_spill(name, window, monkeypatch, tmp_path):
    """The command windowed writes the list path's file and summary, its rewrite planning no
    chain (every re-timed chain's plan read back from the runs' spill)."""
    after, planned = [False], []
    plan_strokes, plan_chain = pl.plan_strokes, chains.plan_chain_segments

    def spy_plan(*a, **k):
        got = plan_strokes(*a, **k)
        after[0] = True
        return got

    def spy_chain(strokes, *a, **k):
        if after[0]:
            planned.append(len(strokes))
        return plan_chain(strokes, *a, **k)
    monkeypatch.setattr(pl, "plan_strokes", spy_plan)
    monkeypatch.setattr(chains, "plan_chain_segments", spy_chain)

    def run(windowed):
        after[0] = False
        return run_command(monkeypatch, os.path.join(SAMPLES, name),
                           tmp_path / f"{name}.{windowed}.gcode", windowed, window)
    want = run(False)
    planned.clear()
    got = run(True)
    assert got[0] == want[0]
    assert got[1] == want[1]
    assert planned == []


def test_replay_finishes_a_group_in_one_ragged_call(monkeypatch):
    """chains._replay finishes each group of kept laws' batches in one _finish_ragged call
    (predict off, _finished_knots): the runs' plans (their spilled records) are those of the
    batch-by-batch finishing (_finish_stacked_dt) bit for bit."""
    real, calls = chains._finish_ragged, []

    def spy(batches, rules, profile, core=None, predict=True):
        got = real(batches, rules, profile, core, predict)
        if not predict:
            calls.append(got is not None)
        return got
    monkeypatch.setattr(chains, "_finish_ragged", spy)
    strokes, store, prof, rules, plan, rows = _timed_chains()
    with store:
        got, plans, _ = plan.remake.spill.take(rows, plan.T[rows], plan.beta[rows])
        ragged = [_bits(p) for p in plans]
    if chains._chain_law.CORE_MOD is not None:
        assert calls and all(calls)
    monkeypatch.setattr(chains, "_finish_ragged", lambda *a, predict=True, **k: real(*a, **k) if predict else None)
    strokes, store, prof, rules, plan2, rows2 = _timed_chains()
    with store:
        assert rows2.tolist() == rows.tolist() == got.tolist()
        _, plans, _ = plan2.remake.spill.take(rows, plan2.T[rows], plan2.beta[rows])
        assert [_bits(p) for p in plans] == ragged


@pytest.mark.skipif(not os.path.isdir("/proc/self/fd"), reason="needs /proc")
def test_spill_beside_the_output(monkeypatch, tmp_path):
    """The runs' chain spill is a file in the folder the strokes' store spills to (the
    output's, not a /tmp that may be tmpfs: RAM the process's RSS does not show)."""
    where = []
    make = sc._ChainSpill.make.__func__

    def spy(cls, n_rows, folder=None):
        got = make(cls, n_rows, folder)
        if got is not None:
            where.append(os.path.dirname(os.readlink(f"/proc/self/fd/{got.fh.fileno()}")))
        return got
    monkeypatch.setattr(sc._ChainSpill, "make", classmethod(spy))
    monkeypatch.setenv("GCODE_OPT_WINDOWED", "1")
    monkeypatch.setenv("GCODE_OPT_WINDOW", "64")
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    monkeypatch.setenv("TMPDIR", str(tmp_path / "elsewhere"))
    pl.process(os.path.join(SAMPLES, "prusa_gyroid.gcode"), str(out_dir / "o.gcode"), load_profile("prusa-mk3s"),
               pl.Options())
    assert where and all(w == str(out_dir) for w in where), where
