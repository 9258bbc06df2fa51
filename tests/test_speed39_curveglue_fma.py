"""Session 39 of issue 8 in laws/circle.py and laws/_curvecore.c: the circle laws' row
products (_rows_matmul, _precond_cheb_c's three products a step, _series_values) by the curve
core's rows_fma, which sums each element as the BLAS's dgemm kernel does, instead of BLAS
calls of _GEMM_ROWS rows (their zero-filled C, packing and padding rows).  rows_fma is used
only for shapes whose run-time probe found the BLAS's bits (circle._fma_rows_mode): these
tests compare it with the BLAS calls it replaces (circle._rows_matmul_padded: numpy's
matmul on zero-padded blocks), bit for bit, on varied shapes, rows and numbers, and the
solves with and without it."""
import ctypes
import glob
import os

import numpy as np
import pytest

from gcode_opt.laws import circle

CORE = circle.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None or not circle.rows_invariant(),
                                reason="no curve core, or a BLAS whose rows are not their own")

# the shapes the planner's laws use (N = 20, 24, 32 collocation steps; the series grids)
PLANNER_SHAPES = [(21, 19), (19, 19), (21, 21), (25, 23), (23, 23), (33, 31), (31, 31),
                  (20, 17), (22, 17), (21, 313), (22, 313), (21, 513), (22, 513), (26, 513)]


def _openblas_core():
    """(version, core name) of numpy's bundled OpenBLAS, or None."""
    import numpy
    libs = glob.glob(os.path.join(os.path.dirname(numpy.__file__) + ".libs", "libscipy_openblas64_*.so"))
    if not libs:
        return None
    try:
        lib = ctypes.CDLL(libs[0])
        lib.scipy_openblas_get_corename64_.restype = ctypes.c_char_p
        lib.scipy_openblas_get_config64_.restype = ctypes.c_char_p
        return lib.scipy_openblas_get_config64_().decode(), lib.scipy_openblas_get_corename64_().decode()
    except (OSError, AttributeError):
        return None


def _modelled_blas():
    """Whether numpy's BLAS is one whose sums rows_fma was written after (OpenBLAS 0.3.31,
    Haswell or SkylakeX kernels): there the planner's shapes must take rows_fma."""
    info = _openblas_core()
    return info is not None and "OpenBLAS 0.3.31" in info[0] and info[1] in ("Haswell", "SkylakeX")


def _bits(x):
    """the bits of a float64 array (other arrays as they are)"""
    x = np.ascontiguousarray(x)
    return x.view(np.int64) if x.dtype == np.float64 else x


def _operands(rng, rows, k, m, special):
    a = rng.uniform(-1.0, 1.0, (rows, k)) * rng.choice([1.0, 1e-3, 1e5], (rows, 1))
    b = rng.standard_normal((k, m))
    if special and rows >= 6:
        a[1] = 0.0                          # zero rows (products of either sign)
        a[2, ::2] = -0.0
        a[3] = 1e-170                       # products that underflow, some negative
        b[:, 0] *= -1e-170
        a[4, -1] = 0.0                      # trailing zero coefficients
        a[5, :] = rng.integers(-3, 4, k)    # exact sums that cancel to zero
    return a, b


SHAPES = sorted(set(PLANNER_SHAPES + [(1, 2), (1, 19), (2, 4), (3, 5), (8, 9), (15, 12), (16, 4),
                                      (16, 9), (17, 3), (17, 20), (24, 28), (40, 36), (47, 97),
                                      (48, 129), (31, 257), (12, 600)]))


@pytest.mark.parametrize("k,m", SHAPES)
def test_rows_fma_gives_the_blas_blocks_bits(k, m):
    mode = circle._fma_rows_mode(k, m)
    if mode is None:
        assert not _modelled_blas() or (k, m) not in PLANNER_SHAPES, "the planner's shapes fell back to BLAS"
        pytest.skip("this BLAS sums this shape otherwise")
    rng = np.random.default_rng(1000 * k + m)
    for rows in (1, 7, 31, 32, 33, 70):
        for special in (False, True):
            a, b = _operands(rng, rows, k, m, special)
            ref = circle._rows_matmul_padded(a, b)
            out = np.empty((rows, m))
            assert CORE.rows_fma(a, k, rows, k, b, m, out, mode)
            assert np.array_equal(_bits(out), _bits(ref)), (rows, special)
            # the first k columns of a wider table, read in place (lda > k)
            wide = np.concatenate([a, rng.uniform(-1.0, 1.0, (rows, 3))], axis=1)
            out2 = np.full((rows, m), np.nan)
            assert CORE.rows_fma(wide, k + 3, rows, k, b, m, out2, mode)
            assert np.array_equal(_bits(out2), _bits(ref))


def test_planner_shapes_take_rows_fma_on_the_modelled_blas():
    if not _modelled_blas():
        pytest.skip("not the BLAS rows_fma was written after")
    assert all(circle._fma_rows_mode(k, m) is not None for k, m in PLANNER_SHAPES)


@pytest.mark.parametrize("transposed", [False, True])
def test_rows_matmul_is_the_padded_blocks(transposed):
    rng = np.random.default_rng(5)
    for k, m in ((21, 19), (21, 21), (22, 513), (16, 4), (60, 600)):
        for rows in (1, 32, 45, 200):
            a, b = _operands(rng, rows, k, m, True)
            if transposed:
                b = np.ascontiguousarray(b.T).T           # dgemm_tn: left to BLAS
            ref = circle._rows_matmul_padded(a, b)
            assert np.array_equal(_bits(circle._rows_matmul(a, b)), _bits(ref))
            out = np.empty((rows, m))
            assert circle._rows_matmul(a, b, out=out) is out
            assert np.array_equal(_bits(out), _bits(ref))
            # a not C-contiguous (a column slice)
            wide = np.concatenate([a, np.ones((rows, 2))], axis=1)
            assert np.array_equal(_bits(circle._rows_matmul(wide[:, :k], b)), _bits(ref))


def _arcs(seed, nb, steep):
    rng = np.random.default_rng(seed)
    if steep:
        phi = rng.uniform(0.05, 3.0, nb) * rng.choice([1.0, -1.0], nb)
        gam2 = 10.0 ** rng.uniform(-3, 3.5, nb)
        u0, u1 = phi * rng.uniform(0.0, 6.0, nb), phi * rng.uniform(0.0, 6.0, nb)
    else:
        phi = rng.uniform(0.05, 1.0, nb)
        gam2 = 10.0 ** rng.uniform(-1, 1, nb)
        u0, u1 = phi * rng.uniform(0.5, 1.5, nb), phi * rng.uniform(0.5, 1.5, nb)
    return phi, gam2, u0, u1, np.sqrt(gam2 + 6.0 * phi ** 2)


def _no_fma(monkeypatch):
    monkeypatch.setattr(circle, "_fma_rows_mode", lambda k, m: None)


@pytest.mark.parametrize("steep", [False, True])
def test_precond_iteration_same_bits_as_blas(monkeypatch, steep):
    phi, gam2, u0, u1, _ = _arcs(11 + steep, 300, steep)
    for n in (16, 20, 24, 32):
        w0 = np.repeat(phi[:, None], n + 1, axis=1)
        got = circle._precond_cheb_c(n, phi, gam2, u0, u1, w0)
        with monkeypatch.context() as mp:
            _no_fma(mp)
            ref = circle._precond_cheb_c(n, phi, gam2, u0, u1, w0)
        for g, r in zip(got, ref):
            assert np.array_equal(_bits(g), _bits(r)), n


@pytest.mark.parametrize("steep", [False, True])
def test_solved_levels_same_bits_as_blas(monkeypatch, steep):
    args = _arcs(21 + steep, 400, steep)
    blocks, cvals = circle._solve_cheb_batch(*args)
    with monkeypatch.context() as mp:
        _no_fma(mp)
        ref_blocks, ref_cvals = circle._solve_cheb_batch(*args)
    assert np.array_equal(_bits(cvals), _bits(ref_cvals))
    assert len(blocks) == len(ref_blocks)
    for (ia, c), (ra, rc) in zip(blocks, ref_blocks):
        assert np.array_equal(ia, ra) and np.array_equal(_bits(c), _bits(rc))


def test_series_values_same_bits_as_blas(monkeypatch):
    rng = np.random.default_rng(3)
    for kmax, npts in ((21, 513), (22, 313), (25, 17), (33, 40)):
        rows = 150
        coefs = []
        for _ in range(3):
            c = rng.standard_normal((rows, kmax)) * np.exp(-0.5 * np.arange(kmax))
            c[rng.random(rows) < 0.3, kmax - 3:] = 0.0          # rows of fewer coefficients
            coefs.append(c)
        grid = np.cos(np.linspace(0.0, np.pi, npts))
        one = np.broadcast_to(grid, (rows, npts)).copy()
        two = one.copy()
        two[::3] = np.linspace(-1.0, 1.0, npts)                  # two grids
        for x in (one, two):
            got = circle._series_values(coefs, x)
            with monkeypatch.context() as mp:
                _no_fma(mp)
                ref = circle._series_values(coefs, x)
            for g, r in zip(got, ref):
                assert np.array_equal(_bits(g), _bits(r))
        # one coefficient count for every row (the whole-table path: rows_fma in place),
        # all of the table's columns or the first ones (the rest zero in every row)
        full = [rng.standard_normal((rows, kmax)) for _ in range(3)]
        full[1][:, kmax - 2:] = 0.0
        full[2][:, 1:] = 0.0
        got = circle._series_values(full, one)
        with monkeypatch.context() as mp:
            _no_fma(mp)
            ref = circle._series_values(full, one)
        for g, r in zip(got, ref):
            assert np.array_equal(_bits(g), _bits(r))
