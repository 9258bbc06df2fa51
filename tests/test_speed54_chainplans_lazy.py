"""A windowed run's chain plans let go and made again (issue 8, chainplans54): schedule.plan_strokes
over a StoredStrokes keeps only the chains' figures (retime, reason, t_pred, a2_pred; each
window's plans judged, then let go from plan.segs, and no chain's memo keeping its last plan:
chains.plan_chain_segments(remember=False)), and the rewrite makes them again a window of rows
at a time (schedule.segs_for / _PlansAgain) from the memos the runs asked (the StoredStrokes'
side table, not the rewrite's strokes' empty ones).  Against the reference (the same runs
keeping every plan: schedule.LAZY_LINES and LAZY_CHAINS off) on chain-heavy samples at small
windows (chains cross windows): the same figures, every row's plan the same bits made again by
windows of any size, at most one window's chain plans held; the rewrite from the store and the
windowed command write the same bytes (the command: the list path's)."""
import os

import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt import pipeline as pl
from gcode_opt import schedule as sc

from windowed_run import run_command

from test_speed52_runs52_windows import seg_bits
from test_speed53_plans53_lazy import FIGURES, SAMPLES, _rewritten, _stored_plan

# (sample, profile, window): two budget runs each (the second from the first's memos)
CASES = [("prusa_gyroid_fullspeed.gcode", "prusa-mk3s", 37),
         ("prusa_gyroid.gcode", "prusa-mk3s", 64),
         pytest.param("prusa_gyroid_fullspeed.gcode", "voron24", 37, marks=pytest.mark.slow)]   # 3 runs, scv
_EAGER = {}


def _eager(name, prof_name, window, monkeypatch):
    """The reference run's (figures, reasons, every row's seg_bits, its plan's remake)."""
    if (name, prof_name, window) not in _EAGER:
        with monkeypatch.context() as m:
            m.setattr(sc, "LAZY_LINES", False)
            m.setattr(sc, "LAZY_CHAINS", False)
            _, store, _, _, plan, _ = _stored_plan(name, prof_name, window)
            with store:
                _EAGER[name, prof_name, window] = ({k: getattr(plan, k).copy() for k in FIGURES},
                                                   list(plan.reason), [seg_bits(p) for p in plan.segs], plan.remake)
    return _EAGER[name, prof_name, window]


@pytest.mark.parametrize("name,prof_name,window", CASES)
def test_lazy_chain_plans_are_the_eager_ones(name, prof_name, window, monkeypatch):
    fig, reason, segs, remake = _eager(name, prof_name, window, monkeypatch)
    assert remake is None
    strokes, store, _, _, plan, pin = _stored_plan(name, prof_name, window)
    with store:
        for k in FIGURES:
            assert getattr(plan, k).tobytes() == fig[k].tobytes(), k
        assert list(plan.reason) == reason
        kind = pin.plan_kind_codes
        chain_rows = np.flatnonzero(kind == sc.C_CHAIN)
        timed = np.flatnonzero(plan.retime & (kind == sc.C_CHAIN))
        lazy = set(np.flatnonzero(plan.retime & np.isin(kind, (sc.C_CHAIN, sc.C_LINE))).tolist())
        assert timed.size > 50                  # (chains re-timed: plans compared)
        # the chains' plans let go by the runs, and held by no memo; the arcs' and curves' kept
        assert all(plan.segs[i] is None for i in timed.tolist())
        assert all(strokes[i].chain_T.seg is None for i in chain_rows.tolist())
        assert all(seg_bits(plan.segs[i]) == segs[i] for i in range(len(segs)) if i not in lazy)
        every = np.arange(len(strokes))
        for w in (5, window, len(strokes) + 1):  # the rewrite's windows of rows, any size
            before = None
            for a in range(0, every.size, w):
                rows = every[a:a + w]
                sc.segs_for(plan, rows, strokes)
                for i in rows.tolist():
                    assert seg_bits(plan.segs[i]) == segs[i], (w, i)
                if before is not None:          # the window before let go (its chains' plans)
                    gone = np.intersect1d(before, timed)
                    assert all(plan.segs[i] is None for i in gone.tolist())
                before = rows
            sc.segs_for(plan, every[:0], strokes)
            assert all(plan.segs[i] is None for i in timed.tolist())
        assert all(strokes[i].chain_T.seg is None for i in chain_rows.tolist())


@pytest.mark.parametrize("name,prof_name,window", CASES[:2])
@pytest.mark.parametrize("text_stream", (False, True))
def test_rewrite_of_lazy_chain_plans_is_the_eager_ones(name, prof_name, window, text_stream, monkeypatch):
    """The rewrite holds the store's strokes (HeldRows: each chain an empty memo): the chains'
    plans are made from the runs' memos, the same bytes, ranges, digests and reasons."""
    path = SAMPLES + name
    with monkeypatch.context() as m:
        m.setattr(sc, "LAZY_LINES", False)
        m.setattr(sc, "LAZY_CHAINS", False)
        strokes, store, prof, opts, plan, _ = _stored_plan(name, prof_name, window)
        with store:
            want = _rewritten(path, strokes, plan, prof, opts, text_stream)
    strokes, store, prof, opts, plan, _ = _stored_plan(name, prof_name, window)
    assert sc.C_CHAIN in plan.remake.codes
    with store:
        got = _rewritten(path, strokes, plan, prof, opts, text_stream)
    assert got == want
    assert len(want[1]) > 50


@pytest.mark.parametrize("name,window", [("prusa_gyroid_fullspeed.gcode", 37), ("prusa_gyroid.gcode", 64)])
def test_windowed_command_with_lazy_chains(name, window, monkeypatch, tmp_path):
    """The command windowed (its plan's chains let go and made again) writes the list path's
    file and summary."""
    made = []
    plan_strokes = pl.plan_strokes

    def spy(*a, **k):
        got = plan_strokes(*a, **k)
        made.append(got.remake)
        return got
    monkeypatch.setattr(pl, "plan_strokes", spy)

    def run(windowed):
        return run_command(monkeypatch, os.path.join(SAMPLES, name),
                           tmp_path / f"{name}.{windowed}.gcode", windowed, window)
    want = run(False)
    assert made and all(r is None for r in made)
    made.clear()
    got = run(True)
    assert made and all(r is not None and sc.C_CHAIN in r.codes for r in made)
    assert got[0] == want[0]
    assert got[1] == want[1]


def test_plan_chain_segments_remember_off(monkeypatch):
    """remember=False: the same plans, no memo keeps one (a later ask makes it again: the same
    bits); remember=True keeps each chain's, handed back by its memo's ask."""
    strokes, store, prof, opts, plan, pin = _stored_plan("prusa_gyroid.gcode", "prusa-mk3s", 64)
    with store:
        rules = sc.SegmentRules.for_profile(prof, opts.max_segments)
        rows = np.flatnonzero(plan.retime & (pin.plan_kind_codes == sc.C_CHAIN))[:40]
        sts = [strokes[i] for i in rows.tolist()]       # (rows of one 64-stroke window or two: held)
        sc._rebuild_geometry(sts, np.arange(len(sts)), np.full(len(sts), sc.C_CHAIN), prof)
        T, beta = plan.T[rows], plan.beta[rows]
        first = chains.plan_chain_segments(sts, T, beta, rules, prof, remember=False)
        assert all(st.chain_T.seg is None for st in sts)
        again = chains.plan_chain_segments(sts, T, beta, rules, prof, remember=False)
        assert [seg_bits(p) for p in again] == [seg_bits(p) for p in first]
        kept = chains.plan_chain_segments(sts, T, beta, rules, prof)
        assert [seg_bits(p) for p in kept] == [seg_bits(p) for p in first]
        assert all(st.chain_T.seg is p for st, p in zip(sts, kept))
