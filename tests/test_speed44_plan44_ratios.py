"""Round 44 (plan44): plan._ratios_nonneg is T_orig >= 0.0 where every ratio is positive and
finite and one of them is 1.0 (the products' signs are the durations' own), not a (k, n)
table of products.  The reference is the formula itself, on durations with signed zeros,
subnormals whose products underflow, infinities and NaNs; ratios without 1.0, or with a
negative or NaN one, go by the table as before."""
import numpy as np
import pytest

from gcode_opt import plan


def _formula(T, ratios):
    return ((T[:, None] * ratios[None, :]) >= 0.0).all(axis=1)


def _durations(rng, n):
    T = rng.random(n) * 10.0 ** rng.integers(-323, 6, n) * rng.choice([-1.0, 1.0], n)
    special = np.array([0.0, -0.0, np.inf, -np.inf, np.nan, 5e-324, -5e-324, -1e-323, 1e308, -1e308, -1e-310])
    hit = rng.random(n) < 0.3
    T[hit] = rng.choice(special, int(hit.sum()))
    return T


@pytest.mark.parametrize("n", [0, 1, 5, 511, 512, 4096, 51874])
def test_same_booleans_as_the_products(n):
    T = _durations(np.random.default_rng(n), n)
    got = plan._ratios_nonneg(T)
    assert got.dtype == bool and got.shape == (n,)
    assert np.array_equal(got, _formula(T, plan.T_RATIOS))


@pytest.mark.parametrize("ratios", [[0.7, 0.9, 1.2], [0.1, 0.3], [1.0, -1.0, 2.0], [0.5, 1.0, np.nan], [1e-300, 1.0]])
def test_other_ratios(ratios, monkeypatch):
    # without 1.0 a tiny negative duration's products may all underflow to -0.0 (>= 0)
    ratios = np.array(ratios)
    monkeypatch.setattr(plan, "T_RATIOS", ratios)
    T = np.concatenate([_durations(np.random.default_rng(3), 3000), [-5e-324, -1e-323]])
    assert np.array_equal(plan._ratios_nonneg(T), _formula(T, ratios))
