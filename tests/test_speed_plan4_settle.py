"""Issue 8, stop 19 (D9): the line and curve planners keep schedule.seg_fault's verdict ""
on the plans they make in rows (segments.fine_rows on the blocks they already hold,
segments.settled), so that schedule.settle_faults no longer gathers and checks them
again.  The verdict must be "" exactly where ddecd40's _seg_fault (copied below, with
_fine_1d and _seg_fault_any) finds nothing: on the plans of real files and on random and
degenerate blocks."""
import math

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt import plan as plan_mod
from gcode_opt import schedule as sc
from gcode_opt import segments as seg
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.segments import SegmentPlan
from gcode_opt.strokes import K_CURVE, K_LINE

S = "sample_gcode/"
F64 = np.dtype(float)


# ---------------------------------------------------------------- ddecd40's forms
def _old_seg_fault(seg):
    s, v, a, f = seg.s, seg.v, seg.accel, seg.feed
    if (type(s) is type(v) is type(a) is type(f) is np.ndarray and s.ndim == v.ndim == a.ndim == f.ndim == 1
            and s.dtype == F64 and v.dtype == F64 and a.dtype == F64 and f.dtype == F64
            and _old_fine_1d(seg, s, v, a, f)):
        return ""
    return _old_seg_fault_any(seg)


F64 = np.dtype(float)


def _old_fine_1d(seg, s, v, a, f):
    """True when every check of _seg_fault passes on four 1-D float arrays (what the
    planners make), on Python floats: ~10 knots, where each numpy call costs more than
    the work.  False sends the plan to _seg_fault_any for its reason (the same order).
    A sum times 0 is 0 exactly when every value is finite and the sum does not overflow
    (an overflow only sends a fine plan the long way); b > a is b - a > 0 for finite
    floats (np.diff's subtraction: exact in sign)."""
    n, m = s.size, s.size + v.size
    x = np.concatenate((s, v, a, f)).tolist()
    if not (sum(x) * 0.0 == 0.0 and math.isfinite(seg.time_t) and math.isfinite(seg.int_a2)
            and n >= 2 and a.size == n - 1 and f.size == n - 1):
        return False
    sl = x[:n]
    return (all(map(float.__lt__, sl, sl[1:])) and min(x[m:]) > 0.0
            and (m == n or min(x[n:m]) >= 0.0))


def _old_seg_fault_any(seg):
    """_seg_fault of anything (lists, other dtypes, malformed shapes)."""
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


# ---------------------------------------------------------------- comparisons
def _check(plans):
    """Every plan with a verdict has ddecd40's; returns how many had one."""
    kept = 0
    for p in plans:
        if p is None:
            continue
        want = _old_seg_fault(p)
        if p.fault is not None:
            kept += 1
            assert p.fault == want == ""
    return kept


def _kind_laws(name, profile, kind, corners=0.0):
    prof = load_profile(profile)
    opts = Options()
    opts.corner_budget_r = corners
    strokes, _ = analyse(S + name, prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    rows = np.array([i for i in sc._rows_by_kind(strokes)[kind] if not pin.fault[i]], int)
    if kind == K_LINE:
        T, beta, I, _ = plan_mod.candidates_auto(pin.take(rows))
    else:
        T, beta, I, _ = curves.candidates_curve(pin, rows, strokes, prof)
    sts, Ts, bs = [], [], []
    for col in range(T.shape[1]):
        ok = np.isfinite(I[:, col])
        sts += [strokes[i] for i in rows[ok]]
        Ts.append(T[ok, col])
        bs.append(beta[ok, col])
    return sts, np.concatenate(Ts), np.concatenate(bs), prof, seg.SegmentRules.for_profile(prof, opts.max_segments)


@pytest.mark.parametrize("name,profile,corners", [
    ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 0.0),
    ("prusa_mk3s_rectilinear.gcode", "generic-marlin", 0.3),     # slowed ends: not kept
    ("prusa_benchy_like.gcode", "voron24", 0.0)])
def test_line_plans_verdicts(name, profile, corners):
    sts, T, beta, prof, rules = _kind_laws(name, profile, K_LINE, corners)
    plans = seg.plan_segments(sts, T, beta, rules)
    assert _check(plans) > 100


@pytest.mark.parametrize("name,profile", [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_gyroid.gcode", "voron24"),
                                          ("prusa_concentric.gcode", "ender3")])
def test_curve_plans_verdicts(name, profile):
    sts, T, beta, prof, rules = _kind_laws(name, profile, K_CURVE)
    plans = curves.plan_curve_segments(sts, T, beta, rules, prof)
    assert _check(plans) > 100


def _rows(rng, m, K):
    S_ = np.concatenate([np.zeros((m, 1)), np.cumsum(rng.uniform(1e-3, 2.0, (m, K - 1)), axis=1)], axis=1)
    V = rng.uniform(0.0, 100.0, (m, K))
    A = rng.uniform(1.0, 3000.0, (m, K - 1))
    F = rng.uniform(1.0, 100.0, (m, K - 1))
    t = rng.uniform(0.01, 1.0, m)
    a2 = rng.uniform(0.0, 1e6, m)
    bad = [math.nan, math.inf, -math.inf, 0.0, -0.0, -1e-300, 5e-324, 1e308]
    for r in range(0, m, 3):                 # one odd entry a row, in one of the six arrays
        which = r // 3 % 6
        x = bad[(r // 18) % len(bad)]
        if which == 0:
            S_[r, rng.integers(K)] = x if K > 1 else x
        elif which == 1:
            V[r, rng.integers(K)] = x
        elif which == 2 and K > 1:
            A[r, rng.integers(K - 1)] = x
        elif which == 3 and K > 1:
            F[r, rng.integers(K - 1)] = x
        elif which == 4:
            t[r] = x
        else:
            a2[r] = x
    for r in range(1, m, 7):                 # knots not increasing
        if K > 2:
            S_[r, 2] = S_[r, 1]
    return S_, V, A, F, t.tolist(), a2.tolist()


@pytest.mark.parametrize("K", [1, 2, 3, 8, 30])
def test_fine_rows_same_as_seg_fault(K):
    rng = np.random.default_rng(K)
    S_, V, A, F, t, a2 = _rows(rng, 600, K)
    with np.errstate(all="ignore"):
        fine = seg.fine_rows(S_, V, A, F, t, a2)
    assert len(fine) == 600 and all(type(x) is bool for x in fine)
    n_fine = 0
    for r in range(600):
        p = SegmentPlan(S_[r], V[r], A[r], F[r], t[r], a2[r])
        with np.errstate(all="ignore"):
            want = _old_seg_fault(p)
        assert fine[r] == (want == ""), (r, want)
        n_fine += fine[r]
        seg.settled(p) if fine[r] else None
        assert p.fault == ("" if fine[r] else None)
    if K >= 2:
        assert 100 < n_fine < 550


def test_settled_only_float64_vectors():
    p = SegmentPlan(np.array([0.0, 1.0]), np.array([1.0, 2.0]), np.array([5.0]), np.array([3.0]), 0.5, 1.0)
    seg.settled(p)
    assert p.fault == ""
    for bad in (np.array([0, 1]), [0.0, 1.0], np.array([[0.0, 1.0]]), np.array([0.0, 1.0], np.float32)):
        q = SegmentPlan(bad, np.array([1.0, 2.0]), np.array([5.0]), np.array([3.0]), 0.5, 1.0)
        seg.settled(q)
        assert q.fault is None


def test_new_array_drops_the_verdict():
    """The verdict holds for the arrays it was made on: putting another in place drops it
    (tests/test_fault_isolation.py puts a NaN into a returned plan's accelerations)."""
    for field in ("s", "v", "accel", "feed"):
        p = SegmentPlan(np.array([0.0, 1.0]), np.array([1.0, 2.0]), np.array([5.0]), np.array([3.0]), 0.5, 1.0)
        seg.settled(p)
        assert p.fault == ""
        x = getattr(p, field).copy()
        setattr(p, field, x)
        assert p.fault is None and getattr(p, field) is x
        x[-1] = np.nan
        assert sc.seg_fault(p) == "error: segments (non-finite)" == p.fault


def test_settle_rows_only_float64_blocks_and_vectors():
    A = np.array([[5.0], [6.0], [7.0]])
    F = np.array([[3.0], [3.0], [3.0]])
    s = [np.array([0.0, 1.0]), np.array([0, 1]), np.array([0.0, 1.0])]
    plans = [SegmentPlan(s[k], np.array([1.0, 2.0]), A[k], F[k], 0.5, 1.0) for k in range(3)]
    seg.settle_rows(plans, [True, True, False], A, F)
    assert [p.fault for p in plans] == ["", None, None]
    plans = [SegmentPlan(np.array([0.0, 1.0]), np.array([1.0, 2.0]), a, f, 0.5, 1.0)
             for a, f in zip(A.astype(np.float32), F)]
    seg.settle_rows(plans, [True] * 3, A.astype(np.float32), F)
    assert all(p.fault is None for p in plans)
