"""A windowed run's chains keep the law each chose (issue 8, replay54): plan_chain_segments(
remember=False) drops a chain's candidate rows once its plan is made (chainplans54), and keeps
the chosen row's law in one flat _Chosen a source (binding mask bits, pieces' durations, T,
beta, predicted figures); a later ask of that same (T, beta) (the rewrite's remake,
schedule._PlansAgain) replays it (_replay by _chosen_laws_of) instead of solving the chain
again (_again_plans -> _knots_again).  Here: the replayed plans are the re-solved ones bit for
bit (the reference: the same memos with their rows dropped as _Again, chainplans54's path),
no chain of a kept law is solved again, another candidate of such a chain is solved again
(the same bits as from an _Again) and then keeps that law in turn (_chosen_solved), and a
memo taking a new source gives up its _Chosen."""
import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt import schedule as sc

from test_speed52_runs52_windows import seg_bits
from test_speed53_plans53_lazy import _stored_plan


@pytest.fixture(autouse=True)
def _no_spill(monkeypatch):
    """The runs' plans not spilled (replay55's _ChainSpill): the chains keep their chosen laws."""
    monkeypatch.setattr(sc, "SPILL_CHAINS", False)


def _chains_of_run(name="prusa_gyroid_fullspeed.gcode", window=37):
    """(strokes, store, prof, rules, plan, the re-timed chains' rows) of a windowed run."""
    strokes, store, prof, opts, plan, pin = _stored_plan(name, "prusa-mk3s", window)
    rules = sc.SegmentRules.for_profile(prof, opts.max_segments)
    rows = np.flatnonzero(plan.retime & (pin.plan_kind_codes == sc.C_CHAIN))
    return strokes, store, prof, rules, plan, rows


def _plans(strokes, rows, plan, rules, prof):
    sts = [strokes[i] for i in rows.tolist()]
    sc._rebuild_geometry(sts, np.arange(len(sts)), np.full(len(sts), sc.C_CHAIN), prof)
    return sts, chains.plan_chain_segments(sts, plan.T[rows], plan.beta[rows], rules, prof, remember=False)


def _spy_solves(monkeypatch):
    """The chains _knots_again solves again (a list of their memos' ids, appended to per
    call: a StoredStrokes' strokes are new objects at each load, their memos the same)."""
    solved = []
    real = chains._knots_again

    def spy(items, profile, *a):
        solved.extend(id(it[0].chain_T) for it in items)
        return real(items, profile, *a)
    monkeypatch.setattr(chains, "_knots_again", spy)
    return solved


def _as_dropped(sts):
    """Each memo's _Chosen given back as its source's _Again (chainplans54's dropped rows)."""
    for st in sts:
        memo = st.chain_T
        if type(memo.kept) is chains._Chosen:
            memo.kept = memo.src.again


def test_replayed_plans_are_the_resolved_ones(monkeypatch):
    strokes, store, prof, rules, plan, rows = _chains_of_run()
    with store:
        held = [strokes[i].chain_T for i in rows.tolist()]
        chosen = [type(m.kept) is chains._Chosen for m in held]
        assert sum(chosen) > 50                    # (the runs kept the laws chosen: replayed below)
        solved = _spy_solves(monkeypatch)
        sts, replayed = _plans(strokes, rows, plan, rules, prof)
        kept = {id(m) for m, c in zip(held, chosen) if c}
        assert not kept & set(solved)                        # no chain of a kept law solved again
        assert all(p is not None for p in replayed)
        _as_dropped(sts)
        solved.clear()
        _, resolved = _plans(strokes, rows, plan, rules, prof)
        assert set(solved) >= kept                           # (the reference solved them again)
        assert [seg_bits(p) for p in replayed] == [seg_bits(p) for p in resolved]


def test_other_candidate_of_a_chosen_chain_is_solved_again(monkeypatch):
    strokes, store, prof, rules, plan, rows = _chains_of_run()
    with store:
        picked, T, beta = [], [], []
        for i in rows.tolist():
            memo = strokes[i].chain_T
            if type(memo.kept) is not chains._Chosen:
                continue
            # (a candidate by its predicted duration, as the plan asks: the memo finds its law)
            other = [(tp, b) for tp, _, b, _, k in memo.rows() if k is memo.kept and tp != plan.T[i]]
            if other:
                picked.append(i)
                T.append(other[0][0])
                beta.append(other[0][1])
            if len(picked) == 30:
                break
        assert len(picked) == 30
        sts = [strokes[i] for i in picked]
        sc._rebuild_geometry(sts, np.arange(len(sts)), np.full(len(sts), sc.C_CHAIN), prof)
        T, beta = np.array(T), np.array(beta)
        solved = _spy_solves(monkeypatch)
        got = chains.plan_chain_segments(sts, T, beta, rules, prof, remember=False)
        assert set(solved) == {id(st.chain_T) for st in sts}
        # solved again, each keeps that law: asked again, it is replayed, the same bits
        assert all(type(st.chain_T.kept) is chains._Chosen for st in sts)
        solved.clear()
        replayed = chains.plan_chain_segments(sts, T, beta, rules, prof, remember=False)
        assert not solved
        assert [seg_bits(p) for p in replayed] == [seg_bits(p) for p in got]
        _as_dropped(sts)
        want = chains.plan_chain_segments(sts, T, beta, rules, prof, remember=False)
        assert [seg_bits(p) for p in got] == [seg_bits(p) for p in want]
        # (and not the chosen law's plan: another candidate's)
        chosen = chains.plan_chain_segments(sts, plan.T[picked], plan.beta[picked], rules, prof, remember=False)
        assert all(seg_bits(a) != seg_bits(b) for a, b in zip(got, chosen))


def test_new_source_gives_up_the_chosen_law():
    strokes, store, prof, rules, plan, rows = _chains_of_run()
    with store:
        memo = next(m for m in (strokes[i].chain_T for i in rows.tolist()) if type(m.kept) is chains._Chosen)
        old, old_i = memo.src, memo.src_i
        new = chains._Source(old.T, old.beta, old.order, old.prev, old.key)
        chains._own_source(memo, new, 0)
        assert type(memo.kept) is chains._Again
        assert memo.kept.src is old and memo.kept.i == old_i
        assert memo.src is new and memo.src_i == 0
