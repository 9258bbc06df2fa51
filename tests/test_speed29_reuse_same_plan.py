"""pipeline._Reuse._same_plan compares the plans' four arrays by their bytes (was
np.array_equal on each): a second rewrite pass takes a first-pass block only for a plan with
the same numbers, bit for bit.  Checked against the array_equal rule on plan pairs that are
equal, differ in one element's last bit, in a length, in a dtype, hold a list, or are RowPlans
(views made on each read); -0.0 against 0.0, or float32 against float64 of the same numbers,
now count as different (the block is written anew from the plan in hand, never taken for one
made from other bits)."""
import numpy as np
import pytest

from gcode_opt.pipeline import _Reuse
from gcode_opt.segments import RowPlan, SegmentPlan

FIELDS = ("s", "v", "accel", "feed")


def _reference(a, b):
    """The rule before: the same object, or the same time_t and array_equal on each field."""
    if a is b:
        return True
    if a is None or b is None or type(a) is not type(b) or a.time_t != b.time_t:
        return False
    for f in FIELDS:
        x, y = getattr(a, f, None), getattr(b, f, None)
        if (x is None) != (y is None) or (x is not None and not np.array_equal(x, y)):
            return False
    return True


def _plan(rng, n):
    s = np.cumsum(rng.uniform(0.1, 2.0, n))
    return SegmentPlan(s, rng.uniform(10, 100, n), rng.uniform(100, 3000, n - 1), rng.uniform(10, 100, n - 1), 0.25, 5e3)


def _copy(p):
    return SegmentPlan(*(np.array(getattr(p, f)) for f in FIELDS), p.time_t, p.int_a2)


@pytest.mark.parametrize("seed", range(6))
def test_same_plan_agrees_with_array_equal(seed):
    rng = np.random.default_rng(seed)
    for _ in range(60):
        a = _plan(rng, int(rng.integers(3, 12)))
        b = _copy(a)
        case = int(rng.integers(0, 6))
        if case == 1:                     # one element one ulp off
            f = FIELDS[int(rng.integers(0, 4))]
            x = getattr(b, f).copy()
            k = int(rng.integers(0, x.size))
            x[k] = np.nextafter(x[k], np.inf)
            setattr(b, f, x)
        elif case == 2:                   # one knot fewer
            b = SegmentPlan(a.s[:-1], a.v[:-1], a.accel[:-1], a.feed[:-1], a.time_t, a.int_a2)
        elif case == 3:                   # another time
            b.time_t = np.nextafter(a.time_t, 1.0)
        elif case == 4:                   # a list where the other holds an array (same numbers)
            b.feed = list(a.feed)
        elif case == 5:                   # float32 of numbers exact in it
            b.accel = np.round(a.accel).astype(np.float32)
            a.accel = np.round(a.accel)
        if case == 5:                     # other bits of the same numbers: written anew (stricter)
            assert _reference(a, b) and not _Reuse._same_plan(a, b)
        else:
            assert _Reuse._same_plan(a, b) == _reference(a, b), case


def test_row_plans_read_as_views():
    rng = np.random.default_rng(9)
    S, V = np.cumsum(rng.uniform(0.1, 2, (5, 4)), axis=1), rng.uniform(10, 90, (5, 4))
    A, F = rng.uniform(100, 900, (5, 3)), rng.uniform(10, 90, (5, 3))
    for r in range(5):
        a = RowPlan(S, V, A, F, r, 0.5, 1.0)
        b = SegmentPlan(S[r].copy(), V[r].copy(), A[r].copy(), F[r].copy(), 0.5, 1.0)
        c = RowPlan(S.copy(), V.copy(), A.copy(), F.copy(), (r + 1) % 5, 0.5, 1.0)
        assert _Reuse._same_plan(a, a) and _reference(a, a)
        assert not _Reuse._same_plan(a, b) and not _reference(a, b)     # another class: never taken
        assert _Reuse._same_plan(a, c) == _reference(a, c) is False
        d = RowPlan(S.copy(), V.copy(), A.copy(), F.copy(), r, 0.5, 1.0)
        assert _Reuse._same_plan(a, d) and _reference(a, d)


def test_signed_zero_is_written_anew():
    a = SegmentPlan(np.array([0.0, 1.0, 2.0]), np.array([0.0, 20.0, 0.0]), np.array([500.0, 500.0]),
                    np.array([20.0, 20.0]), 0.2, 1.0)
    b = _copy(a)
    b.v = np.array([-0.0, 20.0, 0.0])
    assert _reference(a, b)               # array_equal took them for one
    assert not _Reuse._same_plan(a, b)
