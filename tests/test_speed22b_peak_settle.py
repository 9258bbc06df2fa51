"""Issue 8, s22b (peak): schedule.settle_faults checks its plans in chunks of SETTLE_CHUNK
(all ~16 k chains of the gyroid plate at once raised the plan phase's peak RSS by ~17 MB),
and SegmentCache.drop frees a batch kind's last batch before the one that replaces it is
made.  The verdicts must be those of 7712ddd's settle_faults (copied below verbatim as
_old_settle), on random, faulty and degenerate plans, for any chunk size."""
import math

import numpy as np
import pytest

from gcode_opt import schedule as sc
from gcode_opt.segments import SegmentPlan

_F64 = np.dtype(float)


# ---------------------------------------------------------------- 7712ddd's settle_faults
def _old_settle(segs):
    todo, ss, vs, as_, fs = [], [], [], [], []
    for seg in segs:
        if type(seg) is not SegmentPlan or seg.fault is not None:
            continue
        s, v, a, f = seg.s, seg.v, seg.accel, seg.feed
        if not (type(s) is type(v) is type(a) is type(f) is np.ndarray and s.ndim == v.ndim == a.ndim == f.ndim == 1
                and s.dtype == _F64 and v.dtype == _F64 and a.dtype == _F64 and f.dtype == _F64):
            continue
        n = s.size
        if not (n >= 2 and a.size == n - 1 and f.size == n - 1 and math.isfinite(seg.time_t)
                and math.isfinite(seg.int_a2)):
            continue
        todo.append(seg)
        ss.append(s)
        vs.append(v)
        as_.append(a)
        fs.append(f)
    if not todo:
        return
    with np.errstate(invalid="ignore"):
        s, v, a, f = (np.concatenate(x) for x in (ss, vs, as_, fs))
        ok_s = np.isfinite(s)
        up = np.ones(s.size, bool)
        up[1:] = s[1:] > s[:-1]
        n_s = np.array([x.size for x in ss])
        first = np.concatenate([[0], np.cumsum(n_s)[:-1]])
        up[first] = True
        bad_s = ~(ok_s & up)
        bad_v = ~(v >= 0.0) | ~np.isfinite(v)
        bad_a = ~(a > 0.0) | ~np.isfinite(a)
        bad_f = ~(f > 0.0) | ~np.isfinite(f)
    fine = np.ones(len(todo), bool)
    for bad, sizes in ((bad_s, n_s), (bad_v, [x.size for x in vs]), (bad_a, [x.size for x in as_]),
                       (bad_f, [x.size for x in fs])):
        ends = np.cumsum(sizes)
        c = np.concatenate([[0], np.cumsum(bad)])
        fine &= (c[ends] - c[ends - np.asarray(sizes)]) == 0
    for seg, ok in zip(todo, fine.tolist()):
        if ok:
            seg.fault = ""


# ---------------------------------------------------------------- plans
def _plans(seed, count=600):
    """Fine plans with faults sprinkled in: NaN/inf, knots not increasing, zero or negative
    accelerations/feeds/speeds, wrong sizes, non-finite figures, lists, a verdict already
    made, None."""
    rng = np.random.default_rng(seed)
    out = []
    for q in range(count):
        n = int(rng.integers(2, 40))
        s = np.cumsum(rng.uniform(0.01, 3.0, n))
        s[0] = 0.0
        v = rng.uniform(0.0, 200.0, n)
        a = rng.uniform(1.0, 5000.0, n - 1)
        f = rng.uniform(1.0, 300.0, n - 1)
        t, a2 = float(rng.uniform(0.01, 2)), float(rng.uniform(0, 1e6))
        kind = int(rng.integers(0, 14))
        arr = {0: s, 1: v, 2: a, 3: f}
        if kind == 1:
            arr[int(rng.integers(0, 4))][int(rng.integers(0, n - 1))] = np.nan
        elif kind == 2:
            arr[int(rng.integers(0, 4))][-1] = np.inf
        elif kind == 3 and n > 2:
            j = int(rng.integers(1, n))
            s[j] = s[j - 1]                        # not strictly increasing
        elif kind == 4:
            a[int(rng.integers(0, n - 1))] = 0.0
        elif kind == 5:
            f[0] = -1.0
        elif kind == 6:
            v[int(rng.integers(0, n))] = -0.0 if rng.random() < 0.5 else -1e-300
        elif kind == 7:
            a = a[:-1]                              # malformed sizes
        elif kind == 8:
            t = math.inf
        elif kind == 9:
            out.append(SegmentPlan(s.tolist(), v, a, f, t, a2))
            continue
        elif kind == 10:
            p = SegmentPlan(s, v, a, f, t, a2)
            p.fault = "already"
            out.append(p)
            continue
        elif kind == 11:
            out.append(None)
            continue
        elif kind == 12:                            # views of a shared buffer (chains' rows)
            base = np.stack([v, v * 0.5])
            v = base[0]
        out.append(SegmentPlan(s, v, a, f, t, a2))
    return out


def _verdicts(plans):
    return [None if p is None else p.fault for p in plans]


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("chunk", [1, 7, 64, 1024, 10 ** 6])
def test_settle_chunked_same_verdicts(monkeypatch, seed, chunk):
    old, new = _plans(seed), _plans(seed)
    monkeypatch.setattr(sc, "SETTLE_CHUNK", chunk)
    _old_settle(old)
    sc.settle_faults(new)
    assert _verdicts(new) == _verdicts(old)
    assert "" in _verdicts(new) and None in _verdicts(new)       # both outcomes exercised
    # whatever was left unsettled, seg_fault finds the same reason on both
    assert [None if p is None else sc.seg_fault(p) for p in new] == \
           [None if p is None else sc.seg_fault(p) for p in old]


def test_settle_empty_and_all_bad():
    sc.settle_faults([])
    sc.settle_faults([None, None])
    p = SegmentPlan(np.array([0.0, 1.0]), np.array([1.0, np.nan]), np.array([1.0]), np.array([1.0]), 1.0, 1.0)
    sc.settle_faults([p] * 3)
    assert p.fault is None and sc.seg_fault(p) == "error: segments (non-finite)"


def test_cache_drop():
    from gcode_opt.strokes import K_ARC, K_CURVE
    c = sc.SegmentCache()
    rows = np.array([0, 2])
    T, beta = np.array([1.0, 2.0, 3.0]), np.array([4.0, 5.0, 6.0])
    c.store(K_CURVE, rows, T, beta, {0: "a", 2: "b"}, {}, own=True)
    c.store(K_ARC, rows, T, beta, {0: "c", 2: "d"}, {})
    assert c.lookup(K_CURVE, rows, T, beta)[0] == {0: "a", 2: "b"}
    assert c.lookup_rows(K_CURVE, rows, T, beta) == {0: "a", 2: "b"}
    c.drop(K_CURVE)
    assert c.lookup(K_CURVE, rows, T, beta) == ({}, {})
    assert c.lookup_rows(K_CURVE, rows, T, beta) == {}
    assert c.lookup(K_ARC, rows, T, beta)[0] == {0: "c", 2: "d"}
    c.drop(K_CURVE)                                   # twice: nothing to drop
