"""Issue 8, session 47 (bud47): schedule.settle_faults groups its RowPlans (int row, no
verdict, finite figures) by their blocks in compiled passes (_settle_row_blocks), not a
Python loop over every plan.  The verdicts must be those of 882d7e9's settle_faults
(its loop copied below, verbatim; it calls the live _settle_rows, _take_flat and
_settle, whose checks are each plan's own), on plans of every kind the loop meets."""
import copy
import math

import numpy as np
import pytest

from gcode_opt import schedule as sc
from gcode_opt.schedule import SETTLE_CHUNK, SegmentPlan, RowPlan, _settle, _settle_rows, _take_flat


def old_settle_faults(segs):
    """882d7e9's schedule.settle_faults, verbatim."""
    todo, ss, vs, as_, fs = [], [], [], [], []
    # RowPlans by their four blocks: checked as rows of them (_settle_rows).  Known first
    # by their knots' block alone (an int key, one identity: the four ids in a tuple were
    # ~3 k instructions a plan on the gyroid plate's ~17 k), its other three blocks those
    # of the group's first plan; a plan whose other blocks differ goes by all four
    blocks, by_s = {}, {}
    for seg in segs:
        if (type(seg) is not SegmentPlan and type(seg) is not RowPlan) or seg.fault is not None:
            continue
        if type(seg) is RowPlan and type(seg._row) is int:
            if not (math.isfinite(seg.time_t) and math.isfinite(seg.int_a2)):
                continue
            got = by_s.get(id(seg._s))
            if got is None or not (got[0][1] is seg._v and got[0][2] is seg._accel and got[0][3] is seg._feed):
                key = (id(seg._s), id(seg._v), id(seg._accel), id(seg._feed))
                got = blocks.get(key)
                if got is None:
                    got = blocks[key] = ((seg._s, seg._v, seg._accel, seg._feed), [])
                    by_s.setdefault(key[0], got)
            got[1].append(seg)
            continue
        _take_flat(seg, todo, ss, vs, as_, fs)
    for (S, V, A, F), plans in blocks.values():
        if not _settle_rows(S, V, A, F, plans):
            for seg in plans:               # blocks of another shape: each plan's four arrays
                _take_flat(seg, todo, ss, vs, as_, fs)
    for a in range(0, len(todo), SETTLE_CHUNK):     # bounded memory: every check is per plan
        b = a + SETTLE_CHUNK
        _settle(todo[a:b], ss[a:b], vs[a:b], as_[a:b], fs[a:b])


def _block(rng, m, K, bad):
    S = np.cumsum(rng.uniform(0.1, 2.0, (m, K)), axis=1)
    V = rng.uniform(0.0, 100.0, (m, K))
    A = rng.uniform(1.0, 3000.0, (m, K - 1))
    F = rng.uniform(1.0, 100.0, (m, K - 1))
    for r in range(0, m, bad):                   # a fault of some kind on every bad-th row
        [lambda: S.__setitem__((r, 1), S[r, 0]), lambda: V.__setitem__((r, 0), np.nan),
         lambda: A.__setitem__((r, -1), 0.0), lambda: F.__setitem__((r, 0), -1.0),
         lambda: V.__setitem__((r, 1), -0.5), lambda: S.__setitem__((r, 0), np.inf)][r % 6]()
    return S, V, A, F


def _plans(seed):
    """Plans as the budget runs hand settle_faults: rows of many blocks (out of order, some
    twice, a row whose other blocks differ from its group's first), non-finite figures,
    verdicts already set, SegmentPlans of their own, a block of another shape, None."""
    rng = np.random.default_rng(seed)
    out = []
    for b in range(12):
        S, V, A, F = _block(rng, int(rng.integers(5, 300)), int(rng.integers(2, 9)), int(rng.integers(3, 11)))
        m = S.shape[0]
        rows = rng.permutation(m)[: max(1, m - 3)].tolist()
        for r in rows:
            t = float(rng.uniform(0.1, 2.0))
            if r % 17 == 5:
                t = math.nan
            p = RowPlan(S, V, A, F, r, t, float(rng.uniform(1.0, 9.0)))
            if r % 13 == 7:
                p.fault = "" if r % 2 else "error: segments (non-finite)"
            out.append(p)
        out.append(out[-1])                          # one plan twice
        V2 = V.copy()
        V2[:, 0] = np.nan                            # another V block (each row at fault), its knots' S
        out += [RowPlan(S, V2, A, F, r, 1.0, 2.0) for r in rows[:3]]
        out.append(None)
    S, V, A, F = _block(rng, 40, 5, 4)
    for r in range(40):
        out.append(SegmentPlan(S[r].copy(), V[r].copy(), A[r].copy(), F[r].copy(), 1.0, 2.0))
    S1, V1, A1, F1 = _block(rng, 30, 4, 5)
    blk = [list(x) for x in (S1, V1, A1, F1)]      # blocks not 2-D arrays: each plan taken alone
    out += [RowPlan(*blk, r, 1.0, 2.0) for r in range(30)]
    order = rng.permutation(len(out))
    return [out[i] for i in order.tolist()]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_settle_faults_same_verdicts(seed):
    plans = _plans(seed)
    ref = copy.deepcopy(plans)
    assert len(plans) > sc.SETTLE_PASS_MIN
    old_settle_faults(ref)
    left = sc._settle_row_blocks(copy.deepcopy(plans))
    assert len(left) < len(plans) / 2                # the passes took most of them
    sc.settle_faults(plans)
    got = [None if p is None else p.fault for p in plans]
    want = [None if p is None else p.fault for p in ref]
    assert got == want
    assert got.count("") > 100 and got.count(None) > 20         # fine plans, and some left for seg_fault


def test_settle_faults_without_passes(monkeypatch):
    """No compiled pass (objfields answers None): settle_faults' loop takes every plan."""
    plans = _plans(4)
    ref = copy.deepcopy(plans)
    old_settle_faults(ref)
    monkeypatch.setattr(sc.objfields, "_IDS", None)
    assert sc._settle_row_blocks(plans) is plans
    sc.settle_faults(plans)
    assert [None if p is None else p.fault for p in plans] == [None if p is None else p.fault for p in ref]
