"""Independent check: direct minimisation of J on a parametric path (no ODE code).

J = (m/2)∫|ṙ|² dt + (αm²/2)∫|r̈|² dt with r = r(p(t)), ṙ = r'ṗ, r̈ = r''ṗ² + r'p̈ (β = αm).
The law p(τ), τ = t/T, is a cubic Hermite part carrying the four boundary values plus
Σ c_k · 16τ²(1−τ)² · T_k(2τ−1) (each term vanishes with its slope at both ends).  J is a sum of
squares over Gauss–Legendre nodes, minimised by Levenberg–Marquardt with an exact Jacobian
(generic minimisers stall on this badly conditioned problem — MATH.md).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from numpy.polynomial import Chebyshev, Polynomial

# path(p) -> (r1, r2, r3): first three derivatives of r wrt p, each (n, 2)
PathDerivs = Callable[[np.ndarray], tuple]


def circle_path(r_d: float = 1.0) -> PathDerivs:
    """x = R cos p, y = R sin p (p = angle)."""
    def derivs(p):
        c, s = np.cos(p), np.sin(p)
        return (r_d * np.stack([-s, c], -1), r_d * np.stack([-c, -s], -1),
                r_d * np.stack([s, -c], -1))
    return derivs


def ellipse_path(a_d: float, b_d: float) -> PathDerivs:
    """x = a cos p, y = b sin p (p = eccentric anomaly)."""
    def derivs(p):
        c, s = np.cos(p), np.sin(p)
        return (np.stack([-a_d * s, b_d * c], -1), np.stack([-a_d * c, -b_d * s], -1),
                np.stack([a_d * s, -b_d * c], -1))
    return derivs


def line_path(dx_d: float = 1.0, dy_d: float = 0.0) -> PathDerivs:
    """r = p · (dx, dy)."""
    def derivs(p):
        one = np.ones_like(p)
        z = np.zeros((p.size, 2))
        return np.stack([dx_d * one, dy_d * one], -1), z, z
    return derivs


def _basis(n_basis: int, tau: np.ndarray):
    """Values and first two τ-derivatives of 16τ²(1−τ)²T_k(2τ−1), k < n_basis: (3, n, K)."""
    # stay in the Chebyshev form: converting T_k to monomials loses everything for k ≳ 20
    bump = Polynomial([0, 0, 16, -32, 16]).convert(kind=Chebyshev, domain=[0, 1])
    out = np.empty((3, tau.size, n_basis))
    for k in range(n_basis):
        f = Chebyshev.basis(k, domain=[0, 1]) * bump
        out[0, :, k], out[1, :, k], out[2, :, k] = f(tau), f.deriv(1)(tau), f.deriv(2)(tau)
    return out


def _hermite(p0, p1, dp0, dp1, tau):
    """Cubic Hermite in τ with p(0)=p0, p(1)=p1, p'(0)=dp0, p'(1)=dp1 (τ-derivatives)."""
    t2, t3 = tau ** 2, tau ** 3
    h = (p0 * (2 * t3 - 3 * t2 + 1) + dp0 * (t3 - 2 * t2 + tau) + p1 * (-2 * t3 + 3 * t2)
         + dp1 * (t3 - t2))
    h1 = (p0 * (6 * t2 - 6 * tau) + dp0 * (3 * t2 - 4 * tau + 1) + p1 * (-6 * t2 + 6 * tau)
          + dp1 * (3 * t2 - 2 * tau))
    h2 = p0 * (12 * tau - 6) + dp0 * (6 * tau - 4) + p1 * (-12 * tau + 6) + dp1 * (6 * tau - 2)
    return h, h1, h2


@dataclass
class DirectLaw:
    """Result of the direct minimisation.  J, its two integrals, and the law p(t)."""
    J: float
    int_v2: float          # ∫|ṙ|² dt
    int_a2: float          # ∫|r̈|² dt
    coef: np.ndarray
    T: float
    _bc: tuple
    success: bool
    message: str

    def eval(self, t_t):
        """(p, ṗ, p̈) at times t (s)."""
        tau = np.atleast_1d(np.asarray(t_t, float)) / self.T
        h, h1, h2 = _hermite(*self._bc, tau)
        b = _basis(self.coef.size, tau)
        p, p1, p2 = h + b[0] @ self.coef, h1 + b[1] @ self.coef, h2 + b[2] @ self.coef
        shape = np.shape(t_t)
        return p.reshape(shape), (p1 / self.T).reshape(shape), (p2 / self.T ** 2).reshape(shape)


def minimise_law(path: PathDerivs, p0: float, p1: float, T: float, beta: float,
                 pdot0: float = 0.0, pdot1: float = 0.0, m: float = 1.0,
                 n_basis: int = 48, n_quad: int | None = None,
                 coef0: np.ndarray | None = None) -> DirectLaw:
    """Minimise J over laws p(t), t ∈ [0, T], with p(0)=p0, p(T)=p1, ṗ(0)=pdot0, ṗ(T)=pdot1.

    path: p -> (r', r'', r''') arrays (n, 2).  beta = α·m (s²).  Returns a DirectLaw."""
    n_quad = n_quad or 4 * n_basis + 40
    gx, gw = np.polynomial.legendre.leggauss(n_quad)
    tau, wq = (gx + 1) / 2, gw / 2
    bc = (p0, p1, pdot0 * T, pdot1 * T)              # τ-derivatives at the ends
    h, h1, h2 = _hermite(*bc, tau)
    b0, b1, b2 = _basis(n_basis, tau)
    # residual weights: J = Σ (m/2) T wq |ṙ|² + (βm/2) T wq |r̈|²
    sv = np.sqrt(0.5 * m * T * wq)[:, None]
    sa = np.sqrt(0.5 * beta * m * T * wq)[:, None]

    def law(c):
        return h + b0 @ c, (h1 + b1 @ c) / T, (h2 + b2 @ c) / T ** 2

    def residual(c):
        p, pd, pdd = law(c)
        r1, r2, _ = path(p)
        v = r1 * pd[:, None]
        a = r2 * pd[:, None] ** 2 + r1 * pdd[:, None]
        return np.concatenate([(sv * v).ravel(), (sa * a).ravel()])

    def jacobian(c):
        p, pd, pdd = law(c)
        r1, r2, r3 = path(p)
        pd_, pdd_ = pd[:, None, None], pdd[:, None, None]
        bp, bv, ba = b0[:, None, :], (b1 / T)[:, None, :], (b2 / T ** 2)[:, None, :]
        dv = r2[..., None] * pd_ * bp + r1[..., None] * bv
        da = ((r3[..., None] * pd_ ** 2 + r2[..., None] * pdd_) * bp
              + 2 * r2[..., None] * pd_ * bv + r1[..., None] * ba)
        return np.concatenate([(sv[..., None] * dv).reshape(-1, n_basis),
                               (sa[..., None] * da).reshape(-1, n_basis)])

    from scipy.optimize import least_squares  # here: the default run never minimises directly

    c0 = np.zeros(n_basis) if coef0 is None else np.asarray(coef0, float)
    res = least_squares(residual, c0, jac=jacobian, method="lm", xtol=1e-15, ftol=1e-15,
                        gtol=1e-15, max_nfev=2000)
    p, pd, pdd = law(res.x)
    r1, r2, _ = path(p)
    iv = float(np.sum(T * wq * np.sum((r1 * pd[:, None]) ** 2, axis=1)))
    ia = float(np.sum(T * wq * np.sum((r2 * pd[:, None] ** 2 + r1 * pdd[:, None]) ** 2, axis=1)))
    return DirectLaw(J=0.5 * m * (iv + beta * ia), int_v2=iv, int_a2=ia, coef=res.x, T=T,
                     _bc=bc, success=bool(res.success), message=str(res.message))
