"""Issue 8, stop 18 (D8): schedule.settle_faults gives the verdict "" to every segment plan
of a re-plan that passes the checks, in flat arrays at once, before plan_strokes asks
seg_fault plan by plan; the others keep no verdict and seg_fault finds their reason.
The verdicts must be those of 9bb98a8's _seg_fault, copied below."""
import math

import numpy as np
import pytest

from gcode_opt import schedule as sc
from gcode_opt.segments import SegmentPlan


def _old_seg_fault(seg):
    s, v, a, f = seg.s, seg.v, seg.accel, seg.feed
    if (type(s) is type(v) is type(a) is type(f) is np.ndarray and s.ndim == v.ndim == a.ndim == f.ndim == 1
            and s.dtype == float and v.dtype == float and a.dtype == float and f.dtype == float
            and _old_fine_1d(seg, s, v, a, f)):
        return ""
    return _old_seg_fault_any(seg)


def _old_fine_1d(seg, s, v, a, f):
    n, m = s.size, s.size + v.size
    x = np.concatenate((s, v, a, f)).tolist()
    if not (sum(x) * 0.0 == 0.0 and math.isfinite(seg.time_t) and math.isfinite(seg.int_a2)
            and n >= 2 and a.size == n - 1 and f.size == n - 1):
        return False
    sl = x[:n]
    return (all(map(float.__lt__, sl, sl[1:])) and min(x[m:]) > 0.0
            and (m == n or min(x[n:m]) >= 0.0))


def _old_seg_fault_any(seg):
    try:
        s, v, a, f = (np.asarray(x, float) for x in (seg.s, seg.v, seg.accel, seg.feed))
    except (TypeError, ValueError):
        return "error: segments (malformed)"
    if not (np.isfinite(s).all() and np.isfinite(v).all() and np.isfinite(a).all() and np.isfinite(f).all()
            and math.isfinite(seg.time_t) and math.isfinite(seg.int_a2)):
        return "error: segments (non-finite)"
    if len(s) < 2 or a.size != len(s) - 1 or f.size != len(s) - 1:
        return "error: segments (malformed)"
    if not (np.diff(s) > 0).all():
        return "error: segments (knots not increasing)"
    if not ((a > 0).all() and (f > 0).all() and (v >= 0).all()):
        return "error: segments (acceleration, feed or speed not above 0)"
    return ""


def _plan(rng, n):
    s = np.concatenate([[0.0], np.cumsum(rng.uniform(0.01, 3.0, n - 1))])
    v = rng.uniform(0.0, 150.0, n)
    a = rng.uniform(1.0, 4000.0, n - 1)
    f = rng.uniform(1.0, 150.0, n - 1)
    t, a2 = float(rng.uniform(0.01, 1.0)), float(rng.uniform(0.0, 1e6))
    pick = rng.integers(0, 16)
    if pick == 0:
        s[rng.integers(1, n)] = s[0]                     # a knot not increasing
    elif pick == 1:
        v[rng.integers(n)] = -1.0
    elif pick == 2:
        a[rng.integers(n - 1)] = 0.0
    elif pick == 3:
        f[rng.integers(n - 1)] = -0.0
    elif pick == 4:
        [s, v, a, f][rng.integers(4)][0] = rng.choice([np.nan, np.inf, -np.inf])
    elif pick == 5:
        t = math.nan
    elif pick == 6:
        a2 = math.inf
    elif pick == 7:
        a = a[:-1]                                       # malformed sizes
    elif pick == 8:
        s = s[:1]
        a, f = a[:0], f[:0]
    elif pick == 9:
        s = s.astype(np.float32)                         # another dtype: left to seg_fault
    elif pick == 10:
        v = list(v)
    elif pick == 11:
        v = v[:0]                                        # no speeds: _fine_1d skips their check
    elif pick == 12:
        s = s / s[-1] * 1.5e308                         # finite, but their sum overflows: fine
    return SegmentPlan(s, v, a, f, t, a2)


@pytest.mark.parametrize("seed", range(4))
def test_same_verdicts(seed):
    rng = np.random.default_rng(seed)
    plans = [_plan(rng, int(rng.integers(2, 40))) for _ in range(3000)]
    want = [_old_seg_fault(p) for p in plans]
    assert sum(w == "" for w in want) > 500 and sum(w != "" for w in want) > 500
    mixed = plans + [None, "not a plan"]
    sc.settle_faults(mixed)
    settled = sum(p.fault == "" for p in plans)
    assert settled > 500                                  # most fine plans were settled at once
    for p, w in zip(plans, want):
        assert p.fault in (None, "")
        assert p.fault is None or w == ""                 # "" only where the old verdict is ""
        assert sc.seg_fault(p) == w


def test_fine_plans_of_every_shape_are_settled():
    rng = np.random.default_rng(9)
    plans = []
    for n in (2, 3, 9, 17, 100):
        s = np.concatenate([[0.0], np.cumsum(rng.uniform(0.01, 3.0, n - 1))])
        plans.append(SegmentPlan(s, rng.uniform(0.0, 9.0, n), rng.uniform(1, 9, n - 1), rng.uniform(1, 9, n - 1), 0.5, 2.0))
    sc.settle_faults(plans)
    assert all(p.fault == "" for p in plans)


def test_a_verdict_already_made_is_kept():
    rng = np.random.default_rng(1)
    p = _plan(rng, 5)
    p.fault = "kept"
    sc.settle_faults([p])
    assert p.fault == "kept"


def test_boundary_between_plans_is_not_a_knot_step():
    """Plan 2 starts below where plan 1 ends: fine (the flat arrays' step across plans is
    not a knot step), while a step down inside a plan is caught."""
    a = SegmentPlan(np.array([0.0, 5.0, 9.0]), np.ones(3), np.ones(2), np.ones(2), 1.0, 1.0)
    b = SegmentPlan(np.array([0.0, 1.0]), np.ones(2), np.ones(1), np.ones(1), 1.0, 1.0)
    c = SegmentPlan(np.array([0.0, 2.0, 1.0]), np.ones(3), np.ones(2), np.ones(2), 1.0, 1.0)
    sc.settle_faults([a, b, c])
    assert a.fault == "" and b.fault == "" and c.fault is None
    assert sc.seg_fault(c) == "error: segments (knots not increasing)"
