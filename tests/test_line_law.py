"""Independent checks of gcode_opt.laws.line (no numbers copied from the code under test).

References: (1) mpmath solve of the 4×4 system in the raw basis {1, t, sinh, cosh};
(2) scipy solve_bvp of s'''' = s̈/β; (3) direct linear-least-squares minimisation of J on a
polynomial basis; (4) quadrature of eval(); (5) textbook limits (cubic Hermite, paper's J formula).
"""
import time

import mpmath as mp
import numpy as np
import pytest
from numpy.polynomial import chebyshev as C
from scipy.integrate import solve_bvp

from gcode_opt.laws.line import GAMMA_SWITCH, line_law, time_of_distance

END_SPEEDS = [(0.0, 0.0), (0.3, 1.7), (2.0, 0.0), (1.0, 1.0)]   # (v0, v1) for L = T = 1


# ------------------------------------------------------------------------------------------
# helpers
# ------------------------------------------------------------------------------------------
def mp_reference(beta, T, cases, taus):
    """s, ṡ, s̈ at τ·T for each (L, v0, v1) in cases, from the raw sinh/cosh basis.

    The raw basis cancels like e^{γ} (γ = T/√β): c2 sinh + c3 cosh is O(1) while each term is
    O(e^{γ}); so the working precision is 60 digits *plus* γ/ln10 digits (≈ 16 600 at
    α = 1e-9).  Only one exp per point keeps that affordable."""
    gamma = float(T / mp.sqrt(mp.mpf(beta)))
    with mp.workdps(60 + int(1.2 * gamma / 2.302585)):
        sb, T = mp.sqrt(mp.mpf(beta)), mp.mpf(T)
        X = T / sb
        eX = mp.exp(X)
        shX, chX = (eX - 1 / eX) / 2, (eX + 1 / eX) / 2
        A = mp.matrix([[1, 0, 0, 1], [1, T, shX, chX], [0, 1, 1 / sb, 0], [0, 1, chX / sb, shX / sb]])
        coefs = [mp.lu_solve(A, mp.matrix([0, L, v0, v1])) for (L, v0, v1) in cases]
        out = np.zeros((len(cases), 3, len(taus)))
        for j, tau in enumerate(taus):
            t = mp.mpf(tau) * T
            ey = mp.exp(t / sb)
            sh, ch = (ey - 1 / ey) / 2, (ey + 1 / ey) / 2
            for i, c in enumerate(coefs):
                out[i, 0, j] = float(c[0] + c[1] * t + c[2] * sh + c[3] * ch)
                out[i, 1, j] = float(c[1] + (c[2] * ch + c[3] * sh) / sb)
                out[i, 2, j] = float((c[2] * sh + c[3] * ch) / sb**2)
    return out


def scales(L, T, v0, v1):
    """Length / speed / acceleration scales for relative errors."""
    S = max(abs(L), abs(v0) * T, abs(v1) * T)
    return S, S / T, S / T**2


def graded_nodes(gamma, n_per=16):
    """Gauss–Legendre nodes/weights on [0, 1/2], graded towards 0 on the 1/γ boundary layer."""
    inner = np.minimum(0.5, np.logspace(-4, 2, 25) / gamma) if gamma > 0 else np.array([0.5])
    b = np.unique(np.concatenate([[0.0, 0.5], inner]))
    x, w = np.polynomial.legendre.leggauss(n_per)
    a, c = b[:-1, None], b[1:, None]
    return ((a + c) / 2 + (c - a) / 2 * x).ravel(), ((c - a) / 2 * w).ravel()


def hermite(tau, L, T, v0, v1):
    """Cubic Hermite s, ds/dτ, d²s/dτ² (the β = inf law; min ∫s̈² by the textbook argument)."""
    s = L * (3 * tau**2 - 2 * tau**3) + v0 * T * (tau - 2 * tau**2 + tau**3) + v1 * T * (tau**3 - tau**2)
    ds = L * (6 * tau - 6 * tau**2) + v0 * T * (1 - 4 * tau + 3 * tau**2) + v1 * T * (3 * tau**2 - 2 * tau)
    dds = L * (6 - 12 * tau) + v0 * T * (-4 + 6 * tau) + v1 * T * (6 * tau - 2)
    return s, ds, dds


# ------------------------------------------------------------------------------------------
# 1. against mpmath in the raw basis, α = 1e-9 … 1e9 (m = T = L = 1 ⇒ β = α)
# ------------------------------------------------------------------------------------------
TAUS = [0.0, 1e-6, 0.013, 0.1, 0.37, 0.5, 0.81, 0.999, 1.0]


@pytest.mark.parametrize("alpha", [10.0**k for k in range(-9, 10)])
def test_against_mpmath_raw_basis(alpha):
    cases = [(1.0, v0, v1) for v0, v1 in END_SPEEDS]
    ref = mp_reference(alpha, 1.0, cases, TAUS)
    for (L, v0, v1), r in zip(cases, ref):
        s, v, a = line_law(L, 1.0, alpha, v0, v1).eval(np.array(TAUS))
        sS, sV, sA = scales(L, 1.0, v0, v1)
        # brief: 1e-8 on the L, L/T, L/T² scales; measured ≤ 1.2e-16·max(1, γ), so also 1e-12
        # relative to the largest |s̈| (≈ γ L/T² at large γ) to catch regressions.
        assert np.max(np.abs(s - r[0])) <= 1e-12 * sS
        assert np.max(np.abs(v - r[1])) <= 1e-12 * sV
        assert np.max(np.abs(a - r[2])) <= 1e-8 * sA
        assert np.max(np.abs(a - r[2])) <= 1e-12 * max(sA, np.max(np.abs(r[2])))


@pytest.mark.parametrize("beta", [1e-6, 3e-3, 0.7, 40.0])
def test_against_mpmath_dimensional(beta):
    # T ≠ 1, L ≠ 1, end speeds in mm/s: checks the τ scaling of s, ṡ, s̈.
    T, cases = 0.37, [(23.0, 0.0, 0.0), (23.0, 10.0, 80.0), (5.0, 60.0, 0.0)]
    ref = mp_reference(beta, T, cases, TAUS)
    for (L, v0, v1), r in zip(cases, ref):
        s, v, a = line_law(L, T, beta, v0, v1).eval(np.array(TAUS) * T)
        sS, sV, sA = scales(L, T, v0, v1)
        assert np.max(np.abs(s - r[0])) <= 1e-10 * sS
        assert np.max(np.abs(v - r[1])) <= 1e-10 * sV
        assert np.max(np.abs(a - r[2])) <= 1e-10 * sA


# ------------------------------------------------------------------------------------------
# 2. against scipy solve_bvp, tolerance tightened in steps (MATH.md)
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("beta", [1e-3, 1e-2, 1e-1, 1.0, 1e2])
@pytest.mark.parametrize("v0,v1", [(0.0, 0.0), (0.3, 1.7)])
def test_against_solve_bvp(beta, v0, v1):
    L, T = 1.0, 1.0

    def rhs(t, y):                       # y = (s, ṡ, s̈, s⃛)
        return np.vstack([y[1], y[2], y[3], y[2] / beta])

    def bc(ya, yb):
        return np.array([ya[0], yb[0] - L, ya[1] - v0, yb[1] - v1])

    t = np.linspace(0, T, 201)
    s, ds, dds = hermite(t / T, L, T, v0, v1)        # independent initial guess
    y = np.vstack([s, ds / T, dds / T**2, np.zeros_like(t)])
    for tol in (1e-4, 1e-6, 1e-8):
        sol = solve_bvp(rhs, bc, t, y, tol=tol, max_nodes=200_000)
        assert sol.success, sol.message
        t, y = sol.x, sol.y
    tt = np.linspace(0, T, 57)
    ys = sol.sol(tt)
    s, v, a = line_law(L, T, beta, v0, v1).eval(tt)
    sS, sV, sA = scales(L, T, v0, v1)
    gamma = T / np.sqrt(beta)
    assert np.max(np.abs(s - ys[0])) <= 1e-7 * sS
    assert np.max(np.abs(v - ys[1])) <= 1e-6 * sV
    assert np.max(np.abs(a - ys[2])) <= 1e-5 * sA * max(1.0, gamma)   # s̈(0) ~ γ L/T²


# ------------------------------------------------------------------------------------------
# 3. against direct minimisation of J (no ODE involved)
# ------------------------------------------------------------------------------------------
class DirectJ:
    """J(s) for s = Hermite(BCs) + τ²(1−τ)² Σ c_k T_k(2τ−1): a linear least-squares problem.

    J = Σ_i w_i T [ m/2 (s_τ/T)² + β m/2 (s_ττ/T²)² ] (Gauss–Legendre, exact for this
    polynomial degree), i.e. ‖r0 + M c‖² with r linear in the coefficients c."""

    def __init__(self, L, T, beta, v0, v1, m, K=60, nq=200):
        y, w = np.polynomial.legendre.leggauss(nq)
        self.tau, self.w = (y + 1) / 2, w / 2
        self.L, self.T, self.beta, self.m = L, T, beta, m
        bump = C.chebmul(C.poly2cheb([1, 0, -1]), C.poly2cheb([1, 0, -1])) / 16   # (1−y²)²/16
        d1, d2 = np.empty((nq, K)), np.empty((nq, K))
        for k in range(K):
            phi = C.chebmul(bump, np.eye(K)[k])
            d1[:, k] = 2 * C.chebval(y, C.chebder(phi))       # d/dτ = 2 d/dy
            d2[:, k] = 4 * C.chebval(y, C.chebder(phi, 2))
        _, h1, h2 = hermite(self.tau, L, T, v0, v1)
        self.basis = (bump, K)
        self.rows = self._residual_rows(h1, h2), self._residual_rows(d1, d2)

    def _residual_rows(self, d1, d2):
        T, wk = self.T, self.w[:, None] if np.ndim(d1) == 2 else self.w
        kin = np.sqrt(wk * T * self.m / 2) * d1 / T
        acc = np.sqrt(wk * T * self.beta * self.m / 2) * d2 / T**2
        return np.concatenate([kin, acc])

    def minimise(self):
        r0, M = self.rows
        c, *_ = np.linalg.lstsq(M, -r0, rcond=None)
        return c, float(np.sum((r0 + M @ c) ** 2))

    def J_of_derivatives(self, ds_dtau, dds_dtau2):
        """J of any admissible law given its τ-derivatives at the quadrature nodes."""
        return float(np.sum(self._residual_rows(ds_dtau, dds_dtau2) ** 2))

    def position(self, c, tau, v0, v1):
        bump, K = self.basis
        return hermite(tau, self.L, self.T, v0, v1)[0] + C.chebval(2 * tau - 1, C.chebmul(bump, c))


@pytest.mark.parametrize("beta", [1e-3, 1e-1, 1.0, 30.0])
@pytest.mark.parametrize("L,T,v0,v1,m", [(1.0, 1.0, 0.0, 0.0, 1.0), (1.0, 1.0, 0.3, 1.7, 1.0),
                                         (12.0, 0.8, 25.0, 0.0, 0.35)])
def test_against_direct_minimisation(beta, L, T, v0, v1, m):
    direct = DirectJ(L, T, beta, v0, v1, m)
    c, J_min = direct.minimise()
    law = line_law(L, T, beta, v0, v1)
    # brief asks ~1e-6; measured ≤ 1.1e-14 (J) and ≤ 3e-15 (s), so 1e-10 keeps a wide margin
    assert abs(law.cost(m) / J_min - 1) <= 1e-10
    tau = np.linspace(0, 1, 41)
    s_direct = direct.position(c, tau, v0, v1)
    assert np.max(np.abs(law.eval(tau * T)[0] - s_direct)) <= 1e-10 * scales(L, T, v0, v1)[0]


@pytest.mark.parametrize("beta", [1e-3, 0.2, 10.0])
def test_law_is_minimum_against_perturbations(beta):
    L, T, v0, v1, m = 3.0, 0.6, 2.0, 7.0, 0.8
    direct = DirectJ(L, T, beta, v0, v1, m, K=12)
    law = line_law(L, T, beta, v0, v1)
    _, v, a = law.eval(direct.tau * T)
    J0 = direct.J_of_derivatives(v * T, a * T**2)
    assert abs(J0 / law.cost(m) - 1) < 1e-10           # quadrature of the law agrees with cost
    rng = np.random.default_rng(1)
    bump, _ = direct.basis
    y = 2 * direct.tau - 1
    for _ in range(10):
        phi = C.chebmul(bump, rng.normal(size=8))       # admissible: zero value & slope at ends
        p1 = 2 * C.chebval(y, C.chebder(phi))
        p2 = 4 * C.chebval(y, C.chebder(phi, 2))
        for eps in (1e-1, 1e-3):
            Jp = direct.J_of_derivatives(v * T + eps * L * p1, a * T**2 + eps * L * p2)
            Jm = direct.J_of_derivatives(v * T - eps * L * p1, a * T**2 - eps * L * p2)
            assert Jp > J0 and Jm > J0
            # first variation vanishes: the odd part is rounding-level relative to the even part
            assert abs(Jp - Jm) <= 1e-6 * (Jp + Jm - 2 * J0) + 1e-13 * J0


# ------------------------------------------------------------------------------------------
# 4. closed-form integrals vs quadrature of eval()
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("gamma", [0.0, 1e-6, 1e-3, 0.5, 1.0, 2.0, 3.9, 4.5, 8.0, 50.0, 1e4, 1e8])
@pytest.mark.parametrize("v0,v1", [(0.0, 0.0), (0.3, 1.7), (2.0, 0.0), (5.0, 5.0)])
def test_integrals_vs_quadrature(gamma, v0, v1):
    L, T = 4.0, 2.5
    beta = np.inf if gamma == 0 else (T / gamma) ** 2
    v0, v1 = v0 * L / T, v1 * L / T
    law = line_law(L, T, beta, v0, v1)
    # Quadrature on [0, T/2] of the law and of its time reverse (L, v1, v0), which is the
    # law's second half (s(T − t) = L − s_rev(t)).  Nodes near t = T would be wrong: float t
    # has absolute resolution eps·T there, a relative error 2γ·eps of e^{−2γ(T−t)/T}.
    tau, w = graded_nodes(gamma)
    q_v2 = q_a2 = 0.0
    for half in (law, line_law(L, T, beta, v1, v0)):
        _, v, a = half.eval(tau * T)
        q_v2, q_a2 = q_v2 + T * np.sum(w * v**2), q_a2 + T * np.sum(w * a**2)
    int_v2, int_a2 = law.integrals()
    sS, sV, sA = scales(L, T, v0, v1)
    assert abs(int_v2 - q_v2) <= 1e-12 * sV**2 * T
    assert abs(int_a2 - q_a2) <= 1e-12 * max(q_a2, sA**2 * T)


@pytest.mark.parametrize("gamma", [1e-4, 0.3, 3.9, 4.1, 20.0, 3e3, 1e9])
def test_cost_matches_paper_closed_form(gamma):
    # Rest to rest, unit time: J = m L² / (2 (1 − (2/γ) tanh(γ/2))) (MATH.md), in mpmath.
    L, m = 2.0, 1.3
    g = mp.mpf(gamma)
    with mp.workdps(50):
        J_ref = float(m * L**2 / (2 * (1 - (2 / g) * mp.tanh(g / 2))))
    assert abs(line_law(L, 1.0, 1 / gamma**2).cost(m) / J_ref - 1) <= 1e-13


# ------------------------------------------------------------------------------------------
# 5. limits
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("v0,v1", END_SPEEDS + [(0.0, 3.0)])
def test_beta_inf_is_cubic_hermite(v0, v1):
    L, T = 7.0, 0.9
    tau = np.linspace(0, 1, 101)
    s, v, a = line_law(L, T, np.inf, v0 * L / T, v1 * L / T).eval(tau * T)
    hs, hd, hdd = hermite(tau, L, T, v0 * L / T, v1 * L / T)
    assert np.allclose(s, hs, rtol=0, atol=1e-14 * L)
    assert np.allclose(v, hd / T, rtol=0, atol=1e-14 * L / T)
    assert np.allclose(a, hdd / T**2, rtol=0, atol=1e-13 * L / T**2)


def test_rest_to_rest_small_gamma_limits():
    L, T = 5.0, 0.4
    cubic = line_law(L, T, np.inf)
    assert cubic.integrals()[1] == pytest.approx(12 * L**2 / T**3, rel=1e-15)
    assert cubic.integrals()[0] == pytest.approx(1.2 * L**2 / T, rel=1e-15)
    assert cubic.peak_speed() == pytest.approx(1.5 * L / T, rel=1e-15)
    assert cubic.peak_accel() == pytest.approx(6 * L / T**2, rel=1e-15)
    assert cubic.min_speed() == 0.0
    near = line_law(L, T, (T / 1e-6) ** 2)                      # γ = 1e-6: O(γ²) from the cubic
    assert near.integrals()[1] == pytest.approx(12 * L**2 / T**3, rel=1e-11)


@pytest.mark.parametrize("beta", [np.inf, 1e6, 1.0, 1e-4, 1e-12])
def test_constant_speed_for_every_beta(beta):
    L, T = 3.0, 0.2
    law = line_law(L, T, beta, L / T, L / T)
    t = np.linspace(0, T, 33)
    s, v, a = law.eval(t)
    assert np.allclose(s, L * t / T, rtol=0, atol=1e-15 * L)
    assert np.allclose(v, L / T, rtol=1e-15, atol=0)
    assert np.all(np.abs(a) <= 1e-15 * L / T**2 * max(1.0, T / np.sqrt(beta)))
    int_v2, int_a2 = law.integrals()
    assert int_v2 == pytest.approx(L**2 / T, rel=1e-15)
    assert int_a2 <= 1e-28 * L**2 / T**3 * max(1.0, T / np.sqrt(beta))
    assert np.isfinite(law.cost(1.0))


def test_huge_gamma_constant_speed_limit():
    L, T = 10.0, 1.0
    for gamma in (1e6, 1e8, 1e9):
        law = line_law(L, T, (T / gamma) ** 2)
        int_v2, int_a2 = law.integrals()
        # boundary layers of width 1/γ: excess kinetic term ~ L²/(Tγ); a(0) ~ γ L/T²
        assert 0 < int_v2 / (L**2 / T) - 1 < 2 / gamma
        assert law.eval(0.0)[2] == pytest.approx(gamma * L / T**2, rel=3 / gamma)
        assert law.eval(T / 2)[1] == pytest.approx(L / T, rel=3 / gamma)
        assert np.all(np.isfinite(law.eval(np.linspace(0, T, 11))))


# ------------------------------------------------------------------------------------------
# 6. extrema vs brute-force sampling; time_of_distance
# ------------------------------------------------------------------------------------------
def random_laws(n, seed):
    rng = np.random.default_rng(seed)
    L = rng.uniform(0.5, 50, n)
    T = rng.uniform(0.01, 2, n)
    gamma = 10 ** rng.uniform(-3, 5, n)
    gamma[:5] = [0.0, 1e-8, 3.99, 4.0, 4.01]
    beta = np.where(gamma == 0, np.inf, (T / np.where(gamma == 0, 1, gamma)) ** 2)
    v0 = rng.uniform(0, 5, n) * L / T        # mean end speed > 3 L/T reverses the cubic
    v1 = rng.uniform(0, 5, n) * L / T
    return L, T, beta, v0, v1


def test_extrema_vs_dense_sampling():
    L, T, beta, v0, v1 = random_laws(300, seed=7)
    law = line_law(L[:, None], T[:, None], beta[:, None], v0[:, None], v1[:, None])
    gamma = law.gamma
    layer = np.logspace(-6, 1, 300) / np.maximum(gamma, 1.0)          # resolve 1/γ layers
    tau = np.concatenate([np.broadcast_to(np.linspace(0, 1, 20001), (len(L), 20001)),
                          np.minimum(layer, 1), np.maximum(1 - layer, 0)], axis=1)
    _, v, a = law.eval(tau * law.T)
    sV = np.maximum.reduce([L, v0 * T, v1 * T])[:, None] / law.T
    vmax, vmin = v.max(axis=1, keepdims=True), v.min(axis=1, keepdims=True)
    pk, mn, pa = law.peak_speed(), law.min_speed(), law.peak_accel()
    # closed form ≥ any sample, and within the sampling resolution of the best sample
    assert np.all(pk >= vmax - 1e-13 * sV) and np.all(pk <= vmax + 1e-7 * sV)
    assert np.all(mn <= vmin + 1e-13 * sV) and np.all(mn >= vmin - 1e-7 * sV)
    assert np.all(np.abs(pa - np.abs(a).max(axis=1, keepdims=True)) <= 1e-12 * pa)
    # the random set must exercise interior extrema (v0, v1 > L/T ⇒ interior dip), reversal too
    interior = (mn < np.minimum(v0, v1)[:, None] - 1e-3 * sV)
    assert interior.sum() > 20 and (mn < 0).sum() > 5


def test_time_of_distance_inverts_s():
    L, T, beta, v0, v1 = random_laws(400, seed=3)
    law = line_law(L[:, None], T[:, None], beta[:, None], v0[:, None], v1[:, None])
    ok = law.min_speed()[:, 0] >= 0
    targets = np.linspace(0, 1, 17) * L[:, None]
    t = time_of_distance(law, targets)
    s = law.eval(t)[0]
    assert np.all(np.abs(s - targets)[ok] <= 1e-12 * L[ok, None])
    assert np.all(np.diff(t[ok], axis=1) > 0)
    # negative stroke (s decreasing) and a scalar law
    neg = line_law(-4.0, 0.3, 1e-3, -2.0, 0.0)
    tn = time_of_distance(neg, [-1.0, -3.9])
    assert np.allclose(neg.eval(tn)[0], [-1.0, -3.9], rtol=0, atol=1e-14)
    # cubic: s(T/2) = L/2 exactly by symmetry
    assert time_of_distance(line_law(2.0, 0.5, np.inf), 1.0) == pytest.approx(0.25, rel=1e-14)


# ------------------------------------------------------------------------------------------
# 7. vectorisation
# ------------------------------------------------------------------------------------------
def test_vectorised_1e5_laws():
    n, k = 100_000, 8
    L, T, beta, v0, v1 = random_laws(n, seed=11)
    t0 = time.perf_counter()
    law = line_law(L, T, beta, v0, v1)
    grid = law.expand_dims()
    s, v, a = grid.eval(np.linspace(0, 1, k) * grid.T)
    iv, ia = law.integrals()
    pk, mn, pa = law.peak_speed(), law.min_speed(), law.peak_accel()
    J = law.cost(0.5)
    print(f"\n1e5 laws: build + eval(n×{k}) + integrals + extrema + cost in "
          f"{time.perf_counter() - t0:.3f} s")
    assert s.shape == v.shape == a.shape == (n, k)
    assert iv.shape == ia.shape == pk.shape == mn.shape == pa.shape == J.shape == (n,)
    for i in (0, 4, 12345, n - 1):                      # same as the scalar law
        si, vi, ai = line_law(L[i], T[i], beta[i], v0[i], v1[i]).eval(np.linspace(0, 1, k) * T[i])
        assert np.array_equal(si, s[i]) and np.array_equal(vi, v[i]) and np.array_equal(ai, a[i])
    one = line_law(1.0, 1.0, 0.01)                       # one law, many t
    assert one.eval(np.linspace(0, 1, 1000))[0].shape == (1000,)
    assert np.ndim(one.peak_speed()) == 0


# ------------------------------------------------------------------ planner's fast paths
def _random_laws(n, seed):
    rng = np.random.default_rng(seed)
    L = rng.uniform(0.05, 300.0, n)
    T = L / rng.uniform(2.0, 400.0, n) * rng.uniform(0.5, 2.0, n)
    v0 = rng.uniform(0.0, 250.0, n) * (rng.random(n) < 0.8)
    v1 = rng.uniform(0.0, 250.0, n) * (rng.random(n) < 0.7)
    gamma = np.exp(rng.uniform(np.log(1e-4), np.log(1e6), n))     # both branches, and the switch
    gamma[:20] = GAMMA_SWITCH * (1 + np.linspace(-1e-12, 1e-12, 20))
    beta = (T / gamma) ** 2
    beta[20:40] = np.inf
    return L, T, beta, v0, v1


def test_interior_speed_is_the_laws_own_bit_for_bit():
    """The bisection's lean speed equals the full law's interior-extremum speed exactly
    (same rounding), and the end speeds do not depend on beta."""
    from gcode_opt.laws.line import end_speeds, interior_speed
    L, T, beta, v0, v1 = _random_laws(20000, 3)
    law = line_law(L, T, beta, v0, v1)
    vs, ve, vc = law._speed_candidates()
    assert np.array_equal(interior_speed(L, T, beta, v0, v1), vc)
    es, ee = end_speeds(L, T, v0, v1)
    assert np.array_equal(es, vs) and np.array_equal(ee, ve)
    # and they are the end speeds asked for (independent of the law's formulas)
    assert np.allclose(es, v0, rtol=1e-12, atol=1e-9) and np.allclose(ee, v1, rtol=1e-12, atol=1e-9)


def test_interior_speed_refuses_what_the_law_refuses():
    from gcode_opt.laws.line import interior_speed
    for bad in ((1.0, 0.0, 1.0), (1.0, 1.0, 0.0), (np.nan, 1.0, 1.0), (1.0, np.inf, 1.0)):
        with pytest.raises(ValueError):
            interior_speed(*bad, 0.0, 0.0)
        with pytest.raises(ValueError):
            line_law(*bad, 0.0, 0.0)
