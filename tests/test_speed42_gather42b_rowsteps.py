"""Session 42 (gather42b): chains._row_steps, the chains' segment durations from knot times,
is np.diff(tk, axis=1) bit for bit: short C-contiguous rows by one flat subtraction and a
copy, the rest by np.diff; on varied shapes, layouts and values (signed zeros, infinities,
NaNs, subnormals)."""
import numpy as np
import pytest

from gcode_opt import chains


def _same(a, b):
    assert a.dtype == b.dtype and a.shape == b.shape
    assert a.flags.c_contiguous
    assert np.array_equal(a.view(np.uint8), b.view(np.uint8))


def _times(rng, R, w):
    tk = np.cumsum(rng.random((R, w)) * 10.0 ** rng.integers(-320, 3, (R, w)), axis=1)
    special = np.array([0.0, -0.0, np.inf, -np.inf, np.nan, 5e-324, -5e-324, 1e308])
    hit = rng.random((R, w)) < 0.05
    tk[hit] = rng.choice(special, int(hit.sum()))
    return tk


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("w", [1, 2, 3, 5, 7, 8, 9, 10, 12, 40])
@pytest.mark.parametrize("R", [0, 1, 2, 3, 17, 2045])
def test_row_steps_is_diff(seed, w, R):
    tk = _times(np.random.default_rng(seed * 1000 + w * 10 + R), R, w)
    _same(chains._row_steps(tk), np.diff(tk, axis=1))


@pytest.mark.parametrize("seed", range(4))
def test_row_steps_other_layouts(seed):
    rng = np.random.default_rng(seed)
    big = _times(rng, 60, 14)
    for tk in (big[:, :7], big[::2, 3:9], np.asfortranarray(big[:, :6]), big[:, :7].astype(np.float32)):
        got = chains._row_steps(tk)
        want = np.diff(tk, axis=1)
        assert got.dtype == want.dtype and got.shape == want.shape
        assert np.array_equal(np.ascontiguousarray(got).view(np.uint8), np.ascontiguousarray(want).view(np.uint8))


def test_row_steps_flat_path_taken():
    # (the short-row path is the one under test above: it must not fall back for these)
    tk = _times(np.random.default_rng(7), 50, 7)
    calls = []
    real = np.diff
    try:
        np.diff = lambda *a, **k: calls.append(1) or real(*a, **k)
        chains._row_steps(tk)
    finally:
        np.diff = real
    assert calls == []
