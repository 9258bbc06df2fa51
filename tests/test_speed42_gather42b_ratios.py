"""Session 42 (gather42b): plan._ratios_nonneg, Candidates.of_pieces' rows whose every
ratio of the original duration is >= 0, is ((T_orig[:, None] * T_RATIOS[None, :]) >= 0.0)
.all(axis=1) boolean for boolean: on varied lengths and values (negatives, signed zeros,
subnormals whose products underflow to a signed zero, infinities, NaNs) and dtypes."""
import numpy as np
import pytest

from gcode_opt import plan


def _want(T):
    return ((T[:, None] * plan.T_RATIOS[None, :]) >= 0.0).all(axis=1)


def _durations(rng, n):
    T = rng.random(n) * 10.0 ** rng.integers(-320, 5, n) * rng.choice([-1.0, 1.0], n)
    special = np.array([0.0, -0.0, np.inf, -np.inf, np.nan, 5e-324, -5e-324, -1e-323, 1e308, -1e308])
    hit = rng.random(n) < 0.2
    T[hit] = rng.choice(special, int(hit.sum()))
    return T


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("n", [0, 1, 2, 7, 100, 511, 512, 2048, 35018])
def test_ratios_nonneg_same(seed, n):
    T = _durations(np.random.default_rng(seed * 100 + n), n)
    got, want = plan._ratios_nonneg(T), _want(T)
    assert got.dtype == want.dtype == bool and got.shape == want.shape == (n,)
    assert np.array_equal(got, want)


@pytest.mark.parametrize("seed", range(3))
def test_ratios_nonneg_other_inputs(seed):
    T = _durations(np.random.default_rng(seed), 3000)     # (T[::3]: 1000 rows, past RATIO_ROWS_MIN)
    for x in (T[::3], T.astype(np.float32), np.arange(-5, 20), T[:, None][:, 0]):
        assert np.array_equal(plan._ratios_nonneg(x), _want(x))


def test_ratios_nonneg_edge_underflow():
    # a subnormal negative times a ratio < 1 underflows to -0.0 (>= 0): kept as the formula keeps it
    T = np.tile([-5e-324, -1e-323, -2e-323, 5e-324, -0.0, 1.0], 200)
    assert np.array_equal(plan._ratios_nonneg(T), _want(T))
