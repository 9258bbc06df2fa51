"""plan._largest_beta_under_speed_cap leaves the laws whose cubic is under the cap out of
the bisection (their answer is beta = inf whatever it finds): the same bits as the start
commit's bisection over every law, kept here as the reference."""
import numpy as np
import pytest

from gcode_opt.laws.line import end_speeds, interior_speed
from gcode_opt.plan import GAMMA_HI, GAMMA_LO, SPEED_TOL_R, _largest_beta_under_speed_cap


def _reference(L, T, v0, v1, v_cap, iters=32):
    L, T, v0, v1, v_cap = np.broadcast_arrays(*(np.asarray(a, float) for a in (L, T, v0, v1, v_cap)))
    lo = np.full(L.shape, np.log(GAMMA_LO))
    hi = np.full_like(lo, np.log(GAMMA_HI))
    cap = v_cap * (1 + SPEED_TOL_R)
    v_end = np.maximum(*end_speeds(L, T, v0, v1))
    cubic_ok = np.maximum(v_end, interior_speed(L, T, np.inf, v0, v1)) <= cap
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        g = np.exp(mid)
        ok = np.maximum(v_end, interior_speed(L, T, (T / g) ** 2, v0, v1)) <= cap
        hi = np.where(ok, mid, hi)
        lo = np.where(ok, lo, mid)
    gamma = np.exp(hi)
    return np.where(cubic_ok, np.inf, (T / gamma) ** 2)


@pytest.mark.parametrize("seed", [0, 1])
def test_same_bits_as_bisecting_every_law(seed):
    rng = np.random.default_rng(seed)
    n = 500
    L = rng.uniform(0.2, 80.0, n)
    T = L / rng.uniform(10.0, 200.0, n)
    v0, v1 = rng.uniform(0.0, 150.0, n), rng.uniform(0.0, 150.0, n)
    v_cap = np.maximum(np.maximum(v0, v1), L / T) * rng.uniform(1.0, 1.6, n)    # some cubics fit, some not
    want = _reference(L, T, v0, v1, v_cap)
    got = _largest_beta_under_speed_cap(L, T, v0, v1, v_cap)
    assert np.isinf(want).any() and np.isfinite(want).any()
    assert got.tobytes() == want.tobytes()
    for k in (0, 7, 123):                      # one law, and all cubic / none cubic batches
        assert _largest_beta_under_speed_cap(L[k], T[k], v0[k], v1[k], v_cap[k]).tobytes() == \
            _reference(L[k], T[k], v0[k], v1[k], v_cap[k]).tobytes()
    fit = np.isinf(want)
    assert _largest_beta_under_speed_cap(L[fit], T[fit], v0[fit], v1[fit], v_cap[fit]).tobytes() == \
        want[fit].tobytes()


def test_underflowing_beta_still_raises():
    """A duration so short that a tried beta underflows to 0 raises as before (the row
    is then dropped alone by plan.isolate), even when its cubic fits."""
    L, T = np.array([1.0, 1e-300]), np.array([0.05, 1e-302])
    v0 = v1 = np.array([20.0, 1e-300])
    with pytest.raises(ValueError):
        _reference(L, T, v0, v1, np.array([1e9, 1e9]))
    with pytest.raises(ValueError):
        _largest_beta_under_speed_cap(L, T, v0, v1, np.array([1e9, 1e9]))
