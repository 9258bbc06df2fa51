"""Round 44 (plan44): the curve core's row_lengths reads a strided table where it lies
(circle._row_lengths no longer copies _cheb_der_int's transposes into rows first).  The
numpy expression it replaces is the reference: the same lengths on C-ordered tables,
transposes, column and row slices and reversed views, with zeros, -0.0, NaN and
all-zero rows."""
import numpy as np
import pytest

from gcode_opt.laws import circle


def _row_lengths_ref(coef):
    nz = coef != 0
    return np.where(nz.any(axis=1), coef.shape[1] - np.argmax(nz[:, ::-1], axis=1), 1)


@pytest.mark.skipif(circle.CORE_MOD is None, reason="the curve core is not built")
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_row_lengths_of_strided_tables(seed):
    rng = np.random.default_rng(seed)
    for _ in range(200):
        B, K = int(rng.integers(0, 50)), int(rng.integers(1, 40))
        c = rng.normal(size=(B, K))
        c[np.arange(K)[None, :] >= rng.integers(0, K + 1, B)[:, None]] = 0.0     # trailing zeros
        c[rng.random((B, K)) < 0.05] = -0.0
        c[rng.random((B, K)) < 0.02] = np.nan
        t = np.ascontiguousarray(c.T).T          # (B, K) laid out as its transpose
        for x in (c, t, t[:, :max(K - 2, 1)], t[::2], c[:, ::-1], t[::-1], c[:, 1:] if K > 1 else c):
            got, want = circle._row_lengths(x), _row_lengths_ref(x)
            assert got.dtype == want.dtype and got.tolist() == want.tolist()


@pytest.mark.skipif(circle.CORE_MOD is None, reason="the curve core is not built")
def test_row_lengths_checks_its_table():
    out = np.empty(3, np.int64)
    with pytest.raises(ValueError):
        circle.CORE_MOD.row_lengths(np.zeros((3, 4)), 3, 5, out)
    with pytest.raises(ValueError):
        circle.CORE_MOD.row_lengths(np.zeros(12), 3, 4, out)
