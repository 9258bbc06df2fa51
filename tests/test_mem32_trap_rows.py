"""Session 32 (issue 8, memory): least_a2_trapezoids solves its rows TRAP_ROWS at a time;
every row's result must be the bits the whole batch in one block gives it."""
import numpy as np
import pytest

from gcode_opt import segments as seg


def _rows(n, seed):
    rng = np.random.default_rng(seed)
    L = rng.choice([0.0, 1e-4, 0.5, 3.0, 50.0], n) * rng.uniform(0.5, 1.5, n)
    v0 = rng.choice([0.0, 1.0], n) * rng.uniform(0, 150, n)
    v1 = np.where(rng.random(n) < 0.2, v0, rng.choice([0.0, 1.0], n) * rng.uniform(0, 150, n))
    T = np.where(L > 0, L, 1.0) / rng.uniform(5, 300, n) * rng.uniform(0.8, 3.0, n)
    v_lo = rng.choice([0.0, 1.0], n) * rng.uniform(0, 100, n)
    v_hi = np.stack([rng.uniform(50, 600, n), np.full(n, np.inf), v0])[rng.integers(0, 3, n), np.arange(n)]
    a_max = rng.choice([1e-9, 0.0, 3000.0, 20000.0, np.inf], n)
    floor = np.where(rng.random(n) < 0.5, -np.inf, rng.uniform(0, 5000, n))
    return L, T, v0, v1, v_lo, v_hi, a_max, floor


def _bits(x):
    return np.asarray(x, float).view(np.uint64)


@pytest.mark.parametrize("block", [1, 7, 1000])
def test_blocks_give_the_whole_batch_bits(monkeypatch, block):
    cols = _rows(3001, block)
    want = seg._least_a2_block(*(np.asarray(c, float) for c in cols))    # the whole batch, one block
    assert 100 < np.count_nonzero(want[0] == want[0]) < 3001 - 100        # both outcomes present
    monkeypatch.setattr(seg, "TRAP_ROWS", block)
    got = seg.least_a2_trapezoids(*cols)
    for g, w in zip(got, want):
        assert np.array_equal(_bits(g), _bits(w))


def test_one_block_and_empty(monkeypatch):
    cols = _rows(50, 3)
    monkeypatch.setattr(seg, "TRAP_ROWS", 50)
    a = seg.least_a2_trapezoids(*cols)
    monkeypatch.setattr(seg, "TRAP_ROWS", 49)
    b = seg.least_a2_trapezoids(*cols)
    for x, y in zip(a, b):
        assert np.array_equal(_bits(x), _bits(y))
    vp, acc = seg.least_a2_trapezoids(*np.zeros((8, 0)))
    assert vp.shape == (0,) and acc.shape == (0,)
