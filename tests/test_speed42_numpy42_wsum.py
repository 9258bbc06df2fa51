"""Session 42 (numpy42): curves._true_figures_rows' quadrature sums np.sum(wq * x[:, :m],
axis=1) in one compiled pass (_curvecore.c wsum_rows: numpy's products, then numpy's
pairwise sum of each row), not a buffered copy of x's strided rows and a product array:
the same bits as numpy."""
import numpy as np
import pytest

from gcode_opt import curves


def _bits(a):
    return np.ascontiguousarray(a).view(np.int64)


def test_wsum_rows_same_bits_as_numpy():
    if curves._WSUM_ROWS is None:
        pytest.skip("curve core not built")
    rng = np.random.default_rng(42)
    n = 0
    for nb in (0, 1, 3, 128):
        # below 8, up to 128 and above: each branch of numpy's pairwise sum
        for m in (0, 1, 5, 7, 8, 9, 16, 63, 127, 128, 129, 200, 257, 313, 444, 853):
            for extra in (0, 1, 129):
                wq = rng.uniform(0.0, 1.0, (nb, m)) * np.exp(rng.uniform(-30, 30, (nb, 1)))
                x = rng.standard_normal((nb, m + extra)) ** 2 * np.exp(rng.uniform(-20, 20, (nb, 1)))
                want = np.sum(wq * x[:, :m], axis=1)
                got = curves._wsum_rows(wq, x, m)
                assert got.shape == want.shape
                assert np.array_equal(_bits(got), _bits(want)), (nb, m, extra)
                n += 1
    assert n == 4 * 16 * 3


def test_wsum_rows_special_values():
    if curves._WSUM_ROWS is None:
        pytest.skip("curve core not built")
    special = np.array([0.0, -0.0, 1.0, -3.5, np.inf, -np.inf, 1e308, 5e-324])
    rng = np.random.default_rng(1)
    for m in (3, 8, 40, 300):
        wq = rng.choice(special, (6, m))
        x = rng.choice(special, (6, m + 129))
        with np.errstate(all="ignore"):
            want = np.sum(wq * x[:, :m], axis=1)
            got = curves._wsum_rows(wq, x, m)
        same = (_bits(got) == _bits(want)) | (np.isnan(got) & np.isnan(want))
        assert same.all(), m
