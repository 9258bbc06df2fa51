"""Round 62 (crv): two compiled steps of the curve candidates' circle solves.

* circle._solve_layers_batch's iteration with the curve core (_layers_iterate_c): each step's
  residual sums, slope, bracket, step, bisection, test and the packing of the live arcs in one
  pass (_curvecore.c lay_step), around the same lay_pre / np.exp / lay_mid / np.arcsinh.  It
  must give the numpy loop's w_c (the same function without the core) bit for bit, also where
  the steps run out (_LAYERS_ITER lowered) and on degenerate arcs (zero, huge, NaN, inf).
* _curvecore.c cheb_der_int's rows 4 at a time with AVX: the scalar rows' bits (simd(0)), and
  numpy.polynomial's, whatever the number of rows (a multiple of 4 or not) and coefficients."""
import numpy as np
import pytest

from gcode_opt.laws import circle

CORE = circle.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "lay_step"), reason="no compiled curve core")


def _same(a, b):
    """The same doubles bit for bit; NaN where NaN (a NaN's sign aside: see
    test_speed21_curvegeo_layers._bits)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    na, nb = np.isnan(a), np.isnan(b)
    return a.shape == b.shape and np.array_equal(na, nb) and np.array_equal(a[~na].view(np.int64),
                                                                          b[~nb].view(np.int64))


def _arcs(seed, n):
    rng = np.random.default_rng(seed)
    phi = rng.uniform(0.0, 30.0, n) * rng.choice([1.0, 1e-6, 40.0], n)
    gam2 = np.exp(rng.uniform(-6.0, 9.0, n))
    u0 = phi * rng.uniform(0.0, 1.6, n) * rng.choice([1.0, 0.0, 5.0], n)
    u1 = phi * rng.uniform(0.0, 1.6, n) * rng.choice([1.0, 0.0, 5.0], n)
    u0[:5] = u1[:5] = phi[:5]                   # flat layers: w_c = phi at once
    if n > 8:
        phi[5], u0[6], u1[7], gam2[8] = 0.0, 0.0, 1e6, 1e-12
    return phi, gam2, u0, u1


def _numpy_loop(monkeypatch, *args):
    with monkeypatch.context() as m:
        m.setattr(circle, "CORE_MOD", None)
        return circle._solve_layers_batch(*args)


@pytest.mark.parametrize("seed, n", [(1, 1), (2, 3), (3, 64), (4, 2000)])
def test_layer_iteration_core_as_the_numpy_loop(monkeypatch, seed, n):
    args = _arcs(seed, n)
    with np.errstate(all="ignore"):
        got = circle._solve_layers_batch(*args)
        want = _numpy_loop(monkeypatch, *args)
    assert _same(got, want) and np.isfinite(got).all()


@pytest.mark.parametrize("steps", [1, 2, 3, 5])
def test_layer_iteration_core_as_the_numpy_loop_when_the_steps_run_out(monkeypatch, steps):
    args = _arcs(9, 500)
    monkeypatch.setattr(circle, "_LAYERS_ITER", steps)
    with np.errstate(all="ignore"):
        got = circle._solve_layers_batch(*args)
        want = _numpy_loop(monkeypatch, *args)
    assert _same(got, want)
    # (some arcs still live when the steps ran out: the test reaches that path)
    monkeypatch.setattr(circle, "_LAYERS_ITER", 100)
    assert not _same(got, circle._solve_layers_batch(*args))


def test_layer_iteration_core_on_non_finite_arcs(monkeypatch):
    phi, gam2, u0, u1 = _arcs(11, 300)
    phi[10], gam2[11], u0[12], u1[13] = np.nan, np.inf, -np.inf, np.nan
    gam2[14] = 0.0
    with np.errstate(all="ignore"):
        got = circle._solve_layers_batch(phi, gam2, u0, u1)
        want = _numpy_loop(monkeypatch, phi, gam2, u0, u1)
    assert _same(got, want)


def test_layer_regime_the_same_with_and_without_the_core(monkeypatch):
    """The whole first step of solve_circles (w_c, regime, and the numbers after)."""
    rng = np.random.default_rng(5)
    n = 1000
    phi, T = rng.uniform(0.01, 20.0, n), rng.uniform(0.01, 2.0, n)
    beta = 10.0 ** rng.uniform(-6.0, -1.0, n)
    w0, w1 = phi / T * rng.uniform(0.0, 1.5, n), phi / T * rng.uniform(0.0, 1.5, n)
    got = circle._layer_regime(phi, T, beta, w0, w1)
    with monkeypatch.context() as m:
        m.setattr(circle, "CORE_MOD", None)
        want = circle._layer_regime(phi, T, beta, w0, w1)
    assert all(_same(a, b) for a, b in zip(got, want))
    assert got[1].any() and not got[1].all()        # (both regimes met)


@pytest.mark.parametrize("K", [2, 3, 4, 17, 21, 33, 256, 257])
def test_cheb_der_int_avx_rows_as_the_scalar_rows(K):
    if not CORE.simd():
        pytest.skip("no AVX")
    rng = np.random.default_rng(K)
    for nb in (1, 3, 4, 5, 8, 13, 64):
        c = rng.normal(size=(nb, K)) * rng.choice([1.0, 1e-3, 1e5, 0.0], (nb, K))
        if nb > 4:
            c[4, -1] = -0.0
            c[nb - 1, 0] = np.nan
        with np.errstate(all="ignore"):
            try:
                CORE.simd(0)
                want = circle._cheb_der_int(c)
            finally:
                CORE.simd(1)
            got = circle._cheb_der_int(c)
        assert all(x.tobytes() == y.tobytes() and x.strides == y.strides for x, y in zip(got, want)), (K, nb)
