"""Round 44 (plan44): laws/circle._series_values takes the rows of each length straight into
_rows_matmul's zero-padded blocks and puts the products' rows straight into the result
(the curve core's rows_take / rows_put around the same BLAS calls), instead of a gather, a
padded copy of the last block, its product copied out of the pad and a scatter.  The code
it replaced (ebdd6f9) is kept here as the reference: the new one must give the same bits
on rows of many lengths, one grid or several, C-ordered, transposed and column-sliced
tables, and the row counts around a block's."""
import numpy as np
import pytest

from gcode_opt.distinct import distinct
from gcode_opt.laws import circle

HAVE_CORE = circle.CORE_MOD is not None


def _series_values_ref(coefs, x):
    """circle._series_values as of ebdd6f9."""
    _rows_matmul, _row_lengths, _vander_t = circle._rows_matmul, circle._row_lengths, circle._vander_t
    if not circle._gemm_rows_invariant() or x.shape[0] == 0:
        return [circle._clenshaw_rows(c, x) for c in coefs]
    if circle._one_grid(x):
        groups = [np.arange(x.shape[0])]
    else:
        by_grid = {}
        for i in range(x.shape[0]):
            by_grid.setdefault(x[i].tobytes(), []).append(i)
        groups = [np.array(r) for r in by_grid.values()]
    out = [np.empty(x.shape) for _ in coefs]
    kmax = max(c.shape[1] for c in coefs)
    for r in groups:
        vand_t = _vander_t(x[r[0]], kmax)
        whole = len(groups) == 1
        for o, c in zip(out, coefs):
            cr = c if whole else c[r]
            length = _row_lengths(cr)
            ks = distinct(length)
            for k in ks.tolist():
                if ks.size == 1:
                    rk = None
                    a = np.ascontiguousarray(cr[:, :k])
                    if whole:
                        _rows_matmul(a, vand_t[:k], out=o)
                        continue
                    got = _rows_matmul(a, vand_t[:k])
                else:
                    rk = np.flatnonzero(length == k)
                    got = _rows_matmul(cr[rk, :k], vand_t[:k])
                if whole:
                    o[rk] = got
                else:
                    o[r if rk is None else r[rk]] = got
    return out


def _coefs(rng, b, kmax, lengths):
    """(B, kmax) series rows, each with its own number of coefficients from lengths (the
    rest zero; a length 0 row is all zero)."""
    c = rng.uniform(-1.0, 1.0, (b, kmax)) * rng.choice([1.0, 1e-9, 1e6], (b, 1))
    n = rng.choice(lengths, b)
    c[np.arange(kmax)[None, :] >= n[:, None]] = 0.0
    return c


def _grid(rng, b, m, n_grids):
    grids = [np.sort(rng.uniform(-1.0, 1.0, m)) for _ in range(n_grids)]
    return np.array([grids[i] for i in rng.integers(0, n_grids, b)]) if n_grids > 1 else np.tile(grids[0], (b, 1))


def _bits(a, b):
    return a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64))


CASES = [  # (rows, grid points, grids, kmax, lengths)
    (1, 9, 1, 12, [5]), (31, 40, 1, 21, [3, 7, 21]), (32, 40, 1, 21, [2, 21]), (33, 64, 1, 33, [1, 2, 17, 33]),
    (257, 97, 1, 40, list(range(0, 41))), (300, 129, 3, 24, [4, 9, 24]), (70, 17, 2, 10, [10]),
    (65, 1, 1, 8, [3, 8]), (200, 50, 1, 30, [30]), (90, 33, 4, 16, [0, 16]),
]


@pytest.mark.skipif(not HAVE_CORE, reason="the curve core is not built")
@pytest.mark.parametrize("case", range(len(CASES)))
@pytest.mark.parametrize("layout", ["C", "T", "slice"])
def test_same_bits_as_gather_pad_and_scatter(case, layout):
    b, m, n_grids, kmax, lengths = CASES[case]
    rng = np.random.default_rng(100 + case)
    x = _grid(rng, b, m, n_grids)
    base = [_coefs(rng, b, kmax + d, [min(v + d, kmax + d) for v in lengths]) for d in (0, -1, 1) if kmax + d > 0]
    if layout == "T":        # _cheb_der_int's results: transposes of (coefficients, rows) tables
        coefs = tuple(np.ascontiguousarray(c.T).T for c in base)
    elif layout == "slice":  # _eval_cheb's coef[:, :n]: a column slice of a wider table
        coefs = tuple(np.concatenate([c, rng.uniform(-1, 1, (b, 3)) * 0.0], axis=1)[:, :c.shape[1]] for c in base)
    else:
        coefs = tuple(base)
    new = circle._series_values(coefs, x)
    old = _series_values_ref(coefs, x)
    assert len(new) == len(old)
    for a, o in zip(new, old):
        assert _bits(a, o)


@pytest.mark.skipif(not HAVE_CORE, reason="the curve core is not built")
def test_same_bits_without_the_core(monkeypatch):
    rng = np.random.default_rng(5)
    x = _grid(rng, 150, 40, 2)
    coefs = (_coefs(rng, 150, 20, [2, 11, 20]), _coefs(rng, 150, 19, [19]))
    with_core = circle._series_values(coefs, x)
    monkeypatch.setattr(circle, "CORE_MOD", None)
    for a, o in zip(with_core, circle._series_values(coefs, x)):
        assert _bits(a, o)


@pytest.mark.skipif(not HAVE_CORE, reason="the curve core is not built")
def test_rows_take_and_put_check_their_rows():
    core = circle.CORE_MOD
    src = np.arange(12.0).reshape(3, 4)
    a = np.full((4, 2), np.nan)
    core.rows_take(src.T, np.array([3, 0], np.int64), 2, 2, a, 4)   # columns 3 and 0 of src
    assert a.tolist() == [[3.0, 7.0], [0.0, 4.0], [0.0, 0.0], [0.0, 0.0]]
    with pytest.raises(IndexError):
        core.rows_take(src, np.array([3], np.int64), 1, 2, a, 4)
    with pytest.raises(ValueError):
        core.rows_take(src, np.array([0], np.int64), 1, 5, a, 4)
    dst = np.zeros((3, 2))
    core.rows_put(a, 2, 2, np.array([2, 0], np.int64), dst)
    assert dst.tolist() == [[0.0, 4.0], [0.0, 0.0], [3.0, 7.0]]
    with pytest.raises(IndexError):
        core.rows_put(a, 1, 2, np.array([3], np.int64), dst)
