"""Circle law: against direct minimisation of J, a tight solve_bvp, H, and the line limit."""
import numpy as np
import pytest
from scipy.integrate import solve_bvp

from gcode_opt.laws.circle import solve_circle, solve_circles
from gcode_opt.laws.direct import circle_path, minimise_law


def tight_bvp(phi, gam, u0=0.0, u1=0.0):
    """Independent reference: 4th-order φ'''' = (γ² + 6φ'²)φ'' on τ ∈ [0,1], tolerance
    tightened in steps 1e-4 → 1e-6 → 1e-8 (MATH.md)."""
    g2 = gam * gam
    tau = np.linspace(0.0, 1.0, 200)
    h01, h10, h11 = 3 * tau**2 - 2 * tau**3, tau**3 - 2 * tau**2 + tau, tau**3 - tau**2
    y = np.vstack([phi * h01 + u0 * h10 + u1 * h11,
                   phi * 6 * tau * (1 - tau) + u0 * (3 * tau**2 - 4 * tau + 1) + u1 * (3 * tau**2 - 2 * tau),
                   phi * (6 - 12 * tau) + u0 * (6 * tau - 4) + u1 * (6 * tau - 2),
                   np.full_like(tau, -12 * phi + 6 * u0 + 6 * u1)])
    def f(t, y):
        return np.vstack([y[1], y[2], y[3], (g2 + 6 * y[1]**2) * y[2]])

    def bc(a, b):
        return np.array([a[0], a[1] - u0, b[0] - phi, b[1] - u1])

    for tol in (1e-4, 1e-6):
        sol = solve_bvp(f, bc, tau, y, tol=tol, max_nodes=100000)
        assert sol.success, sol.message
        tau, y = sol.x, sol.y
    # the last step can exhaust the mesh on a few strongly nonlinear cases: 1e-7 is then
    # still two orders below the 1e-6 being checked
    for tol in (1e-8, 3e-8, 1e-7):
        tight = solve_bvp(f, bc, tau, y, tol=tol, max_nodes=40000)
        if tight.success:
            return tight
    raise AssertionError("reference solve_bvp did not reach 1e-7")
    return sol


def law_error(law, ref_eval, t_t, phi, T):
    """max relative deviation of (φ, φ̇, φ̈) scaled by Φ, Φ/T, Φ/T²."""
    ours, ref = law.eval(t_t), ref_eval(t_t)
    scales = (abs(phi), abs(phi) / T, abs(phi) / T**2)
    return max(np.abs(a - b).max() / s for a, b, s in zip(ours, ref, scales))


@pytest.mark.parametrize("alpha", [1e-3, 1e-2, 0.1, 1.0])
def test_semicircle_matches_direct_minimisation(alpha):
    # the paper's example: R = 1, Φ = π, T = 1, rest to rest, m = 1 (β = α)
    law = solve_circle(np.pi, 1.0, alpha)
    direct = minimise_law(circle_path(1.0), 0.0, np.pi, 1.0, alpha, n_basis=56)
    assert abs(law.cost() - direct.J) <= 1e-6 * direct.J
    t = np.linspace(0, 1, 101)
    assert law_error(law, direct.eval, t, np.pi, 1.0) < 1e-5   # direct basis truncation
    iv, ia = law.integrals()
    assert iv == pytest.approx(direct.int_v2, rel=1e-6)
    assert ia == pytest.approx(direct.int_a2, rel=1e-6)


@pytest.mark.parametrize("phi, w0, w1, alpha", [
    (2 * np.pi, 0.0, 0.0, 0.01),          # full circle
    (1.5 * np.pi, 0.0, 0.0, 0.1),
    (1.5 * np.pi, 3.0, 1.0, 0.01),        # non-zero end speeds
    (np.pi / 2, 2.0, 0.0, 1.0),
    (4 * np.pi, 10.0, 10.0, 0.01),        # two turns
])
def test_sweeps_and_end_speeds_match_direct(phi, w0, w1, alpha):
    R = 7.0                               # R only scales s = Rφ
    law = solve_circle(phi, 1.0, alpha, w0, w1, R=R)
    direct = minimise_law(circle_path(R), 0.0, phi, 1.0, alpha, w0, w1, n_basis=56)
    assert abs(law.cost() - direct.J) <= 1e-6 * direct.J
    assert law_error(law, direct.eval, np.linspace(0, 1, 101), phi, 1.0) < 1e-5
    phi_t, phid, _ = law.eval(np.array([0.0, 1.0]))
    np.testing.assert_allclose(phi_t, [0.0, phi], atol=1e-12)
    np.testing.assert_allclose(phid, [w0, w1], atol=1e-11 * max(1.0, phi))


def test_fast_solver_vs_tight_bvp_random_off_grid():
    rng = np.random.default_rng(12345)
    n = 22
    phi = rng.uniform(0.1, 4 * np.pi, n)
    gam = 10 ** rng.uniform(-1.5, 2.5, n)                 # γ = T/√β from 0.03 to 300
    u0 = phi * rng.uniform(0, 1.5, n) * (rng.random(n) < 0.7)
    u1 = phi * rng.uniform(0, 1.5, n) * (rng.random(n) < 0.7)
    # dimensional: random T, R; β from γ; end angular speeds from u
    T = 10 ** rng.uniform(-2, 0.3, n)
    beta = (T / gam) ** 2
    batch = solve_circles(phi, T, beta, u0 / T, u1 / T, R=rng.uniform(0.5, 100, n))
    assert batch.regime.any() and not batch.regime.all()   # both regimes exercised
    worst = 0.0
    for i in range(n):
        sol = tight_bvp(phi[i], gam[i], u0[i], u1[i])
        ref = lambda t, s=sol, Ti=T[i]: (s.sol(t / Ti)[0], s.sol(t / Ti)[1] / Ti,
                                          s.sol(t / Ti)[2] / Ti**2)
        err = law_error(batch[i], ref, np.linspace(0, T[i], 301), phi[i], T[i])
        worst = max(worst, err)
    assert worst <= 1e-6, worst


def test_batch_equals_single_calls():
    phi = np.array([0.5, np.pi, 5.0, 2 * np.pi])
    T = np.array([0.05, 0.2, 1.5, 0.01])
    beta, w0, w1 = 1e-3, np.array([0, 5, 1, 300]), np.array([3, 0, 2, 100])
    batch = solve_circles(phi, T, beta, w0, w1, R=2.0)
    t = np.linspace(0, 1, 7)
    for i in range(4):
        single = solve_circle(phi[i], T[i], beta, w0[i], w1[i], R=2.0)
        np.testing.assert_allclose(batch[i].eval(t * T[i]), single.eval(t * T[i]), rtol=1e-12,
                                   atol=1e-12)
        assert batch[i].cost() == pytest.approx(single.cost(), rel=1e-12)


@pytest.mark.parametrize("phi, T, beta, w0, w1", [
    (np.pi, 1.0, 1e-3, 0, 0), (2 * np.pi, 0.5, 1e-2, 3, 8), (1.0, 2.0, 1e-6, 0, 0),
    (4 * np.pi, 0.01, 1.0, 0, 0), (0.3, 0.05, 1e-4, 2, 9)])
def test_first_integral_constant(phi, T, beta, w0, w1):
    law = solve_circle(phi, T, beta, w0, w1, R=3.0)
    t = np.linspace(0, T, 501)
    H = law.hamiltonian(t)
    _, phid, phidd = law.eval(t)
    R = 3.0
    # size of the individual terms of H (they cancel each other at small γ)
    terms = np.max(0.5 * (R * phid)**2 + beta * (0.5 * (R * phidd)**2 + 1.5 * R**2 * phid**4
                                                  + R**2 * np.abs(phid) * np.abs(phidd) * 6 / T))
    assert np.ptp(H) <= 1e-8 * terms


def test_large_radius_reduces_to_straight_line():
    """κ → 0: s(t) of a huge-radius arc equals the exponential line law (derived inline)."""
    L_d, T_t, beta, v0, v1 = 20.0, 0.4, 2e-3, 30.0, 80.0
    R = 1e7
    law = solve_circle(L_d / R, T_t, beta, v0 / R, v1 / R, R=R)
    # line: s = c0 + c1 t + c2 e^{-t/√β} + c3 e^{-(T-t)/√β}
    rb = np.sqrt(beta)
    eT = np.exp(-T_t / rb)
    A = np.array([[1, 0, 1, eT], [1, T_t, eT, 1], [0, 1, -1 / rb, eT / rb],
                  [0, 1, -eT / rb, 1 / rb]])
    c = np.linalg.solve(A, [0, L_d, v0, v1])
    t = np.linspace(0, T_t, 201)
    e0, e1 = np.exp(-t / rb), np.exp(-(T_t - t) / rb)
    s_line = c[0] + c[1] * t + c[2] * e0 + c[3] * e1
    v_line = c[1] - c[2] * e0 / rb + c[3] * e1 / rb
    s, v, _ = law.eval_s(t)
    np.testing.assert_allclose(s, s_line, atol=1e-9 * L_d)
    np.testing.assert_allclose(v, v_line, atol=1e-8 * L_d / T_t)


def test_peaks_and_symmetry():
    law = solve_circle(np.pi, 1.0, 0.01, R=5.0)
    t = np.linspace(0, 1, 20001)
    phi, phid, phidd = law.eval(t)
    np.testing.assert_allclose(phid, phid[::-1], atol=1e-10)        # rest-to-rest is symmetric
    assert law.peak_speed() == pytest.approx(5.0 * phid.max(), rel=1e-7)
    assert law.peak_speed() >= 5.0 * phid.max()
    a = 5.0 * np.hypot(phidd, phid**2)
    assert law.peak_accel() == pytest.approx(a.max(), rel=1e-6)
    assert law.min_speed() == pytest.approx(0.0, abs=1e-9)
    moving = solve_circle(np.pi, 1.0, 0.01, 2.0, 2.0, R=5.0)
    assert moving.min_speed() == pytest.approx(5.0 * moving.eval(t)[1].min(), rel=1e-7)


# ------------------------------------------------------------------ bounded-memory paths
def _mixed_batch(n=40, seed=5):
    rng = np.random.default_rng(seed)
    phi = rng.uniform(0.1, 4 * np.pi, n)
    gam = 10 ** rng.uniform(-1.0, 2.5, n)
    u0 = phi * rng.uniform(0, 1.5, n) * (rng.random(n) < 0.7)
    u1 = phi * rng.uniform(0, 1.5, n) * (rng.random(n) < 0.7)
    T = 10 ** rng.uniform(-2, 0.3, n)
    return solve_circles(phi, T, (T / gam) ** 2, u0 / T, u1 / T, R=rng.uniform(0.5, 100, n))


def test_clenshaw_per_row_length_is_numpys_chebval():
    """Rows padded with zeros to different lengths, evaluated per row group: the same
    values as numpy's chebval of each row's own coefficients."""
    from numpy.polynomial import chebyshev as C

    from gcode_opt.laws.circle import _clenshaw_rows
    rng = np.random.default_rng(1)
    lengths = [1, 3, 25, 33, 33, 49, 65]
    coef = np.zeros((len(lengths), 66))
    for i, k in enumerate(lengths):
        coef[i, :k] = rng.normal(size=k) / (1 + np.arange(k)) ** 2
    x = rng.uniform(-1, 1, (len(lengths), 50))
    got = _clenshaw_rows(coef, x)
    for i, k in enumerate(lengths):
        np.testing.assert_allclose(got[i], C.chebval(x[i], coef[i, :k]), rtol=1e-13, atol=1e-14)


def test_chunked_evaluation_gives_the_same_figures(monkeypatch):
    """integrals and extrema evaluated a few arcs at a time: the same numbers, bit for bit."""
    import gcode_opt.laws.circle as circle
    batch = _mixed_batch()
    assert batch.regime.any() and not batch.regime.all()
    whole = [batch.integrals(), batch.peak_speed(), batch.min_speed(), batch.peak_accel()]
    monkeypatch.setattr(circle, "EVAL_CHUNK", 3)
    assert len(batch.row_chunks()) > 10
    chunked = [batch.integrals(), batch.peak_speed(), batch.min_speed(), batch.peak_accel()]
    for a, b in zip(whole, chunked):
        assert np.array_equal(np.asarray(a), np.asarray(b))


def test_newton_in_chunks_solves_the_same_laws(monkeypatch):
    """Collocation Newton over chunks of arcs: the same laws up to rounding (each arc's
    iteration is its own; only the batched BLAS may round differently)."""
    import gcode_opt.laws.circle as circle
    monkeypatch.setattr(circle, "_NEWTON_BYTES", 1.0)     # chunks of the 64-arc floor
    rng = np.random.default_rng(9)
    n = 150                                               # > 64: several chunks
    phi = rng.uniform(0.1, 4 * np.pi, n)
    T = 10 ** rng.uniform(-2, 0.3, n)
    beta = (T / 10 ** rng.uniform(-1.0, 1.2, n)) ** 2      # small γ: collocation regime
    chunked = solve_circles(phi, T, beta, 0.0, 0.0, R=1.0)
    monkeypatch.setattr(circle, "_NEWTON_BYTES", 1e12)
    one = solve_circles(phi, T, beta, 0.0, 0.0, R=1.0)
    assert (~one.regime).sum() > 64
    t = np.linspace(0, 1, 33)[None, :] * T[:, None]
    for a, b in zip(chunked.eval(t), one.eval(t)):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * np.abs(b).max())
