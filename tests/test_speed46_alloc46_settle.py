"""Issue 8, session 46 (alloc46): settle_faults finds a RowPlan's block group by its
knots' block alone (an int key) where its other three blocks are the group's, and
_settle_rows makes each row's eight checks side by side and reduces them with one all()
along the rows (not eight).  The same verdicts: compared with 0b09fc6's two functions
(verbatim copies below) on random blocks with every kind of bad entry, plans sharing a
knots' block with others of other speed blocks, plans with verdicts, SegmentPlans, None."""
import copy
import math

import numpy as np
import pytest

from gcode_opt import schedule
from gcode_opt.schedule import _ROW, SETTLE_CHUNK, _run_or_rows, _settle, _take_flat, compress, objfields
from gcode_opt.segments import RowPlan, SegmentPlan


# ---------------------------------------------------------------- 0b09fc6, verbatim (SETTLE_CHUNK
# read from schedule, as the new code reads it: the tests set it there)
def settle_faults_0b09fc6(segs):
    todo, ss, vs, as_, fs = [], [], [], [], []
    blocks = {}                 # RowPlans by their four blocks: checked as rows of them (_settle_rows)
    for seg in segs:
        if (type(seg) is not SegmentPlan and type(seg) is not RowPlan) or seg.fault is not None:
            continue
        if type(seg) is RowPlan and type(seg._row) is int:
            if not (math.isfinite(seg.time_t) and math.isfinite(seg.int_a2)):
                continue
            key = (id(seg._s), id(seg._v), id(seg._accel), id(seg._feed))
            got = blocks.get(key)
            if got is None:
                got = blocks[key] = ((seg._s, seg._v, seg._accel, seg._feed), [])
            got[1].append(seg)
            continue
        _take_flat(seg, todo, ss, vs, as_, fs)
    for (S, V, A, F), plans in blocks.values():
        if not _settle_rows_0b09fc6(S, V, A, F, plans):
            for seg in plans:               # blocks of another shape: each plan's four arrays
                _take_flat(seg, todo, ss, vs, as_, fs)
    for a in range(0, len(todo), schedule.SETTLE_CHUNK):     # bounded memory: every check is per plan
        b = a + schedule.SETTLE_CHUNK
        _settle(todo[a:b], ss[a:b], vs[a:b], as_[a:b], fs[a:b])


def _settle_rows_0b09fc6(S, V, A, F, plans):
    nd = np.ndarray
    if not (type(S) is nd and type(V) is nd and type(A) is nd and type(F) is nd
            and S.ndim == V.ndim == A.ndim == F.ndim == 2 and S.dtype == V.dtype == A.dtype == F.dtype == schedule._F64):
        return False
    m, K = S.shape
    if not (K >= 2 and V.shape == (m, K) and A.shape == F.shape == (m, K - 1)):
        return False
    for a in range(0, len(plans), schedule.SETTLE_CHUNK):    # bounded memory: every check is per row
        part = plans[a:a + schedule.SETTLE_CHUNK]
        r = objfields.codes(part, "_row", None)
        r = _run_or_rows(np.fromiter(map(_ROW, part), np.intp, len(part)) if r is None else r)
        with np.errstate(invalid="ignore"):
            # (a run's rows are views; other rows gathered by np.take, the same rows)
            Sr, Vr, Ar, Fr = ((S[r], V[r], A[r], F[r]) if type(r) is slice
                              else (S.take(r, axis=0), V.take(r, axis=0), A.take(r, axis=0), F.take(r, axis=0)))
            fine = (np.isfinite(Sr).all(axis=1) & (Sr[:, 1:] > Sr[:, :-1]).all(axis=1)
                    & np.isfinite(Vr).all(axis=1) & (Vr >= 0.0).all(axis=1)
                    & np.isfinite(Ar).all(axis=1) & (Ar > 0.0).all(axis=1)
                    & np.isfinite(Fr).all(axis=1) & (Fr > 0.0).all(axis=1))
        for seg in compress(part, fine.tolist()):
            seg.fault = ""
    return True


# ---------------------------------------------------------------- random plans
BAD = (np.nan, np.inf, -np.inf, 0.0, -1.0, -0.0)


def _block(rng, m, K, bad_r):
    """(S, V, A, F) of m rows of K knots, entries spoilt at rate bad_r (NaN, inf, zero,
    negative; knots repeated or going back)."""
    S = np.cumsum(rng.uniform(0.01, 1.0, (m, K)), axis=1)
    V, A, F = rng.uniform(0.0, 5.0, (m, K)), rng.uniform(0.1, 5.0, (m, K - 1)), rng.uniform(0.1, 5.0, (m, K - 1))
    V[rng.random((m, K)) < 0.05] = 0.0                  # a stop: fine
    for X in (S, V, A, F):
        hit = rng.random(X.shape) < bad_r
        X[hit] = rng.choice(BAD, int(hit.sum()))
    back = np.flatnonzero(rng.random(m) < bad_r)
    S[back, K // 2] = S[back, K // 2 - 1]               # a knot repeated
    return S, V, A, F


def _plans(rng, n_blocks):
    segs = []
    for _ in range(n_blocks):
        m, K = int(rng.integers(1, 40)), int(rng.integers(2, 12))
        S, V, A, F = _block(rng, m, K, rng.choice([0.0, 0.01, 0.1]))
        V2 = V.copy()                                   # a second speed block on the same knots
        V2[rng.random(m) < 0.5, 0] = np.nan             # (other verdicts on some rows)
        for r in rng.permutation(m)[:int(rng.integers(0, m + 1))].tolist():
            t = rng.choice([1.0, 1.0, 1.0, np.nan, np.inf])
            other = rng.random() < 0.2
            segs.append(RowPlan(S, V2 if other else V, A, F, int(r), float(t), 2.0))
    for _ in range(int(rng.integers(0, 20))):          # plans alone, None, verdicts already given
        s = np.cumsum(rng.uniform(0.01, 1.0, 5))
        v, a, f = rng.uniform(0, 5, 5), rng.uniform(0.1, 5, 4), rng.uniform(0.1, 5, 4)
        if rng.random() < 0.3:
            a[1] = rng.choice(BAD)
        segs.append(SegmentPlan(s, v, a, f, 1.0, 2.0))
        segs.append(None)
    for seg in segs:
        if seg is not None and rng.random() < 0.1:
            seg.fault = rng.choice(["", "error: segments (non-finite)"])
    rng.shuffle(segs)
    return segs


def _verdicts(segs):
    return [None if s is None else s.fault for s in segs]


@pytest.mark.parametrize("chunk", [3, SETTLE_CHUNK])
@pytest.mark.parametrize("seed", range(6))
def test_settle_faults_same_verdicts_as_0b09fc6(seed, chunk, monkeypatch):
    monkeypatch.setattr(schedule, "SETTLE_CHUNK", chunk)
    rng = np.random.default_rng(seed)
    segs = _plans(rng, int(rng.integers(1, 30)))
    ref = copy.deepcopy(segs)
    settle_faults_0b09fc6(ref)
    schedule.settle_faults(segs)
    got, want = _verdicts(segs), _verdicts(ref)
    assert got == want
    assert want.count("") > 10 and sum(1 for s in segs if s is not None and s.fault is None) > 0


def test_settle_rows_same_as_0b09fc6():
    rng = np.random.default_rng(7)
    for _ in range(40):
        m, K = int(rng.integers(1, 60)), int(rng.integers(2, 15))
        blk = _block(rng, m, K, rng.choice([0.0, 0.02, 0.2]))
        rows = rng.permutation(m)[:int(rng.integers(1, m + 1))]
        if rng.random() < 0.5:
            rows = np.sort(rows)
        a = [RowPlan(*blk, int(r), 1.0, 2.0) for r in rows.tolist()]
        b = copy.deepcopy(a)
        assert schedule._settle_rows(a[0]._s, a[0]._v, a[0]._accel, a[0]._feed, a)
        assert _settle_rows_0b09fc6(b[0]._s, b[0]._v, b[0]._accel, b[0]._feed, b)
        assert _verdicts(a) == _verdicts(b)
