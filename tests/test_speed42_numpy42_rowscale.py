"""Session 42 (numpy42): numpy 2 runs a ufunc whose operand is broadcast along the rows of
a 2-D array (a (B, 1) column, or one row against all) through its iterator's buffers,
copying the broadcast operand into a buffer row by row.

* curves._row_scale (R[:, None] * x, over T or T ** 2) is compiled (_curvecore.c
  row_scale) for curve_knots, surely_over and _true_figures_rows: the same bits as the
  numpy expressions it replaces, AVX loops on and off;
* laws/circle._one_grid ((x == x[:1]).all() as each row == the row before it): the same
  answer as the broadcast comparison it replaces."""
import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt.laws import circle


def _ref_row_scale(x, R, T=None, p=0):
    """The expressions _row_scale replaced (curve_knots, surely_over, _true_figures_rows)."""
    with np.errstate(all="ignore"):
        if p == 0:
            return R[:, None] * x
        Tc = T[:, None]
        return R[:, None] * x / (Tc if p == 1 else Tc ** 2)


def _inputs():
    rng = np.random.default_rng(42)
    special = np.array([0.0, -0.0, np.inf, -np.inf, np.nan, 5e-324, -2.2e-308, 1e308, -1e-300, 3.0])
    for nb, m in ((0, 5), (3, 0), (1, 1), (2, 3), (5, 4), (7, 17), (32, 513), (33, 429), (128, 146)):
        for scale in (1.0, 1e-200, 1e200):
            x = rng.standard_normal((nb, m)) * scale
            R = np.exp(rng.uniform(-5.0, 5.0, nb))
            T = np.exp(rng.uniform(-3.0, 3.0, nb)) * (scale ** 0.5 if scale > 1 else 1.0)
            yield x, R, T
    x = rng.choice(special, (10, 23))
    yield x, rng.choice(special, 10), rng.choice(special, 10)
    yield np.full((4, 9), np.nan), np.array([1.0, np.nan, -0.0, np.inf]), np.array([0.0, 1.0, np.nan, -np.inf])


def _bits(a):
    return np.ascontiguousarray(a).view(np.int64)


@pytest.mark.parametrize("avx", [1, 0])
def test_row_scale_same_bits_as_numpy(avx):
    if curves._ROW_SCALE is None:
        pytest.skip("curve core not built")
    core = curves._CURVE_CORE
    was = core.simd(avx)
    try:
        n = 0
        for x, R, T in _inputs():
            for p in (0, 1, 2):
                want = _ref_row_scale(x, R, T, p)
                got = curves._row_scale(x, R, T, p)
                assert got.shape == want.shape and got.dtype == want.dtype
                # NaN payloads aside (both NaN), every element's bits
                same = (_bits(got) == _bits(want)) | (np.isnan(got) & np.isnan(want))
                assert same.all(), (p, x.shape, np.argwhere(~same)[:3])
                n += 1
        assert n > 30
    finally:
        core.simd(1 if was else 0)


def test_row_scale_fallback_is_the_expression():
    """Non-contiguous x (or no core): numpy's expression itself."""
    rng = np.random.default_rng(1)
    x = rng.standard_normal((9, 40))[:, ::2]
    R, T = rng.uniform(0.5, 2.0, 9), rng.uniform(0.1, 3.0, 9)
    for p in (0, 1, 2):
        assert np.array_equal(_bits(curves._row_scale(x, R, T, p)), _bits(_ref_row_scale(x, R, T, p)))


def _grids():
    rng = np.random.default_rng(7)
    g = np.linspace(-1.0, 1.0, 17)
    yield np.tile(g, (1, 1))
    yield np.tile(g, (5, 1))
    for b in (1, 2, 3, 6):
        for r in range(b):
            for c in (0, 8, 16):
                x = np.tile(g, (b, 1))
                x[r, c] = np.nan
                yield x
                x = np.tile(g, (b, 1))
                x[r, c] += 1e-16 if c else 2e-16
                yield x
    x = np.tile(g, (4, 1))
    x[:, 8] = 0.0
    x[2, 8] = -0.0          # -0.0 == 0.0: one grid both ways
    yield x
    x = np.tile(g, (4, 1))
    x[1:3] = rng.uniform(-1.0, 1.0, 17)
    yield x
    yield np.tile(g, (2, 1))[:, :0]


def test_one_grid_same_as_broadcast_compare():
    n = 0
    for x in _grids():
        want = bool((x == x[:1]).all())
        if x.shape[0] == 1:
            assert circle._one_grid(x)      # (one row: one group either way, below)
        else:
            assert circle._one_grid(x) == want, x
        n += 1
    assert n > 40


def test_series_values_same_bits_as_broadcast_compare(monkeypatch):
    """_series_values with _one_grid and with the broadcast comparison it replaced: the
    same bits, on one grid, grids that differ in a row, NaN in a row, a lone row."""
    rng = np.random.default_rng(3)
    cases = []
    for x in _grids():
        if x.shape[1] == 0:
            continue
        b = x.shape[0]
        coef = rng.standard_normal((b, 12)) * 0.5 ** np.arange(12)
        coef[b // 2:, 9:] = 0.0           # rows of their own lengths
        cases.append(((coef, coef[:, :7]), x))
    new = [circle._series_values(c, x) for c, x in cases]
    monkeypatch.setattr(circle, "_one_grid", lambda x: bool((x == x[:1]).all()))
    old = [circle._series_values(c, x) for c, x in cases]
    for a, b in zip(new, old):
        for u, v in zip(a, b):
            assert np.array_equal(_bits(u), _bits(v))
