"""Optimal 1-D law along a chain of short straight segments whose vertices cap the speed.

Problem (one chain, arc length s along the polyline, vertices at s_i, 0 < s_i < S):

    minimise  J = ∫₀ᵀ (ṡ² + β s̈²) dt
    s(0) = 0, s(T) = S, ṡ(0) = v0, ṡ(T) = v1,   ṡ(t_i) <= c_i where s(t_i) = s_i.

The firmware plays the chain as straight moves: only the tangential acceleration s̈ is
in its ∫|a|²dt between vertices (the small turn at each vertex is a velocity jump the
firmware model counts separately, at the vertex speed).

Active set.  With the binding vertices B fixed, the law splits at them into pieces whose
end speeds are the caps; each piece is the closed-form straight-line law (laws/line.py)
on its length L_j and duration T_j.  The vertex times are free, so the durations share T
by equal marginal cost: J_j'(T_j) = -λ for every piece, Σ T_j = T (λ = the chain's
Hamiltonian, continuous across a binding vertex).  Solved by Newton on (T_j, λ) for all
pieces of all chains at once (J_j' = the piece's Hamiltonian and J_j'' in closed form:
_exact_slopes; before session 29, central differences of LineLaw.integrals' J, still the
fallback).  Then the usual rules: a vertex whose speed exceeds
its cap joins B; a binding vertex whose multiplier is negative (s̈(t_i-) > s̈(t_i+):
the cap holds the law up instead of down) leaves B; a cap that binds rightly bends the
speed into a valley at its vertex, s̈(t_i+) >= s̈(t_i-).  The start is B = every vertex
whose cap is below COLD_BIND_R x the chain's mean speed S/T.

tests/test_chain_law.py checks the result against an independent minimisation of the
same J (piecewise-linear v(s), SLSQP with the cap inequalities) on real gyroid chains.
"""
from __future__ import annotations

import os

import numpy as np

from ..distinct import distinct
from .. import native
from . import prims
from .line import GAMMA_SWITCH as _GAMMA_SWITCH
from .line import (_NMS_COEF, _NMS_ZMAX, _S1_COEF, _S1_ZMAX, LineLaw, _atanhc, _horner_nms, _large_coeffs,
                   _nms_terms, _shc, end_speeds, time_of_distance)

# The compiled Newton loops of _share_time and of the chains' time of distance (_chaincore.c,
# module _gcode_opt_chaincore): optional, the same bits as the numpy code
# (tests/test_speed_chain_core.py, tests/test_speed20_chainprim_core.py).  Both use the
# deterministic sinh and cube of prims.py (no libm, no numpy ufunc that differs between
# machines), so their bits are the same on every machine.
CORE_MOD, CORE_WHY = native.load("_gcode_opt_chaincore",
                                 os.path.join(os.path.dirname(os.path.abspath(__file__)), "_chaincore.c"),
                                 "chain core")
CORE = "c" if CORE_MOD is not None else "python"
_COEF_C = np.ascontiguousarray(_NMS_COEF)
_ZMAX_C = np.ascontiguousarray(_NMS_ZMAX)
_S1_COEF_C, _S1_ZMAX_C = np.ascontiguousarray(_S1_COEF), np.ascontiguousarray(_S1_ZMAX)
_SINH_COEF_C = prims.SINH_COEF

CAP_TOL_R = 1e-7          # a speed above cap x (1 + this) violates the cap
MU_TOL_R = 1e-7           # multiplier (accel jump) below -this x accel scale: release the vertex
MAX_ACTIVE_ITERS = 40
MAX_NEWTON = 60
FD_H_R = 1e-4             # relative step of the central differences on T
NEWTON_TOL_R = 1e-8       # |J_j' + λ| per piece, relative to the chain's slope scale
# The cold start binds the caps below this x the chain's mean speed S/T: the law's speed
# swells between binding vertices well above the mean (a rest-to-rest cubic peaks at 1.5 x),
# so with 1 x nearly every chain's first step had vertices over their caps, joined them all
# and released many of those at the next.  Gyroid plate, cold active-set chain-steps
# (chains solved, summed over the steps): 44860 at 1.0, 37283 at 1.15, 30878 at 1.2, 31453
# at 1.25, 32260 at 1.3, 33862 at 1.4; the written file the same at each (the same final
# binding sets).  (A chain with two vertices at one place raises when both bind, as before;
# a larger start binds both more often: tests/test_speed_chains' zero-length case.)
COLD_BIND_R = 1.2


class ChainProblem:
    """One chain: interior vertex positions s_v (mm, increasing, in (0, S)), their speed
    caps c_v (mm/s; inf = none), length S, duration T, weight beta (s²), end speeds."""
    __slots__ = ("s_v", "c_v", "S", "T", "beta", "v0", "v1")

    def __init__(self, s_v, c_v, S, T, beta, v0, v1):
        self.s_v = np.asarray(s_v, float)
        self.c_v = np.asarray(c_v, float)
        self.S, self.T, self.beta, self.v0, self.v1 = float(S), float(T), float(beta), float(v0), float(v1)


class ChainLaw:
    """The solved law of one chain: binding vertices, pieces (knot s, t, speed), figures."""
    __slots__ = ("problem", "binding", "knot_s", "knot_t", "knot_v", "pieces", "iv", "ia",
                 "peak_v", "min_v", "peak_a", "vert_v", "vert_t", "converged", "lam")

    @property
    def J(self):
        return self.iv + self.problem.beta * self.ia

    def speeds_at(self, s):
        """(t, ṡ) at positions s (mm), each in its piece."""
        s = np.asarray(s, float)
        j = np.clip(np.searchsorted(self.knot_s, s, side="right") - 1, 0, len(self.knot_s) - 2)
        p = self.pieces
        law = LineLaw(p.L[j], p.T[j], p.beta[j], p.v0[j], p.v1[j])
        tl = _time_of_distance(law, s - self.knot_s[j])
        _, v, _ = _eval(law, tl, "v")
        return self.knot_t[j] + tl, v


def _coeffs(gamma):
    """The integral coefficients (Ig1, Igp, Ih, Ihp) of line._gamma_coeffs, each law in its
    own branch, the series branch (γ < GAMMA_SWITCH) with the deterministic sinh of prims
    (_small_coeffs' operations otherwise: n, m, S1 by _horner_nms on the batch)."""
    small = gamma < _GAMMA_SWITCH
    ns = int(np.count_nonzero(small))
    if ns == small.size:
        return _small_int_coeffs(np.minimum(gamma, _GAMMA_SWITCH))
    if ns == 0:
        return _large_coeffs(np.maximum(gamma, _GAMMA_SWITCH), small)
    cs = _small_int_coeffs(np.minimum(gamma[small], _GAMMA_SWITCH))
    cl = _large_coeffs(np.maximum(gamma[~small], _GAMMA_SWITCH), None)
    c = {}
    for k in ("Ig1", "Igp", "Ih", "Ihp"):
        v = np.empty(gamma.shape)
        v[small], v[~small] = cs[k], cl[k]
        c[k] = v
    return c


def _small_int_coeffs(gs):
    """line._small_coeffs' Ig1, Igp, Ih, Ihp with prims.shc for line's shc (numpy's sinh)."""
    n, m, s1 = _horner_nms(gs * gs)
    sh2 = prims.shc(gs / 2)
    return {"Ig1": m / (2 * n * n), "Igp": s1 / (2 * n * n), "Ih": 2 * s1 / sh2**2,
            "Ihp": 2 * (prims.shc(gs) + 1) / sh2**2}


def _J3(L, Tm, T0, Tp, beta, va, vb):
    """J = ∫ṡ² + β∫s̈² (LineLaw.integrals) at the three durations Tm, T0, Tp of the same
    pieces, in one batch: each element's arithmetic is LineLaw's (__init__, integrals)
    but for the deterministic sinh and cube of prims (numpy's sinh and power there), and what
    does not depend on T (√β, v0 ± v1, L²) is computed once instead of three times.
    Raises LineLaw's ValueError, in its order, on bad inputs."""
    n = T0.size
    T = np.concatenate([Tm, T0, Tp])
    if not (np.all(T > 0) and np.all(np.isfinite(T))):
        raise ValueError("T must be finite and > 0")
    if not np.all(beta > 0):
        raise ValueError("beta must be > 0 (np.inf allowed)")
    if not (np.all(np.isfinite(L)) and np.all(np.isfinite(va)) and np.all(np.isfinite(vb))):
        raise ValueError("L, v0, v1 must be finite")
    tile = lambda a: np.concatenate([a, a, a])          # noqa: E731
    gamma = T / tile(np.sqrt(beta))
    c = _coeffs(gamma)
    A = tile(L) - T * tile(va + vb) / 2
    d = T * tile(va - vb) / 2
    iv = (tile(L**2) + A**2 * c["Ig1"] + d**2 * c["Ih"]) / T
    ia = (A**2 * c["Igp"] + d**2 * c["Ihp"]) / prims.cube(T)
    b3 = tile(beta)
    J = iv + b3 * ia
    return J[:n], J[n:2 * n], J[2 * n:]


def _share_time(L, beta, va, vb, owner, T_total, T_init, core=None):
    """Durations T_j with J_j'(T_j) = -λ_c and Σ T_j = T_total[c] (_share_time_numpy's
    problem): by Newton on the exact slopes (_share_time_exact: compiled when the chain core
    is there), else, where that declines (a γ above EXACT_GAMMA_MAX, β not finite, bad
    inputs), by the central differences (_share_time_numpy, its steps compiled when the
    core is there).  core: the module; None = CORE_MOD; False = the numpy code."""
    core = CORE_MOD if core is None else core
    out = _share_time_exact(L, beta, va, vb, owner, T_total, T_init, core)
    if out is not None:
        return out
    if core:
        out = _share_time_core(core, L, beta, va, vb, owner, T_total, T_init)
        if out is not None:
            return out
    return _share_time_numpy(L, beta, va, vb, owner, T_total, T_init)


def _share_time_core(core, L, beta, va, vb, owner, T_total, T_init):
    """_share_time_numpy's whole Newton iteration in one C call (share_time), the same
    bits.  None (the numpy code runs instead, from the start) where that code would raise
    or leave the series branch of the line law."""
    n_c = T_total.size
    P = T_init.size
    if P == 0 or not (np.all(beta > 0) and np.all(np.isfinite(L)) and np.all(np.isfinite(va))
                      and np.all(np.isfinite(vb))):
        return None
    if np.any(np.diff(owner) < 0):
        return None
    f = lambda a: np.ascontiguousarray(a, float)          # noqa: E731
    L, beta, T_total = f(L), f(beta), f(T_total)
    vs, vd = f(va + vb), f(va - vb)
    npc = np.bincount(owner, None, n_c)
    poff = np.zeros(n_c + 1, np.int64)
    np.cumsum(npc, out=poff[1:])
    npc = npc.astype(float)
    sqb = np.sqrt(beta)
    T = np.array(T_init, float)
    lam = np.zeros(n_c)
    conv = np.zeros(n_c, np.uint8)
    if core.share_time(L, beta, vs, vd, sqb, poff, npc, T_total, T, lam, conv, _COEF_C, _ZMAX_C, _SINH_COEF_C,
                       MAX_NEWTON) < 0:
        return None
    return T, lam, conv.astype(bool)


def _kkt_step(o, ix, Ti, d1, d2, T, lam, conv, fresh, T_total, n_c, n_p):
    """One damped Newton step of the time-sharing KKT system (J_j'(T_j) + λ_c = 0, Σ T_j =
    T_total[c]) for the active pieces ix (owners o, durations Ti, slopes d1, curvatures d2
    already floored): T updated in place, conv and fresh too; returns the new λ.  Shared by
    the central-difference and the exact-slope solvers."""
    inv = 1.0 / d2
    s_inv = np.bincount(o, inv, n_c)
    with np.errstate(invalid="ignore", divide="ignore"):
        lam0 = -np.bincount(o, d1 * inv, n_c) / s_inv
    lam = np.where(fresh & ~conv, lam0, lam)   # λ that best matches the first slopes
    fresh[:] = False
    r = d1 + lam[o]
    e = T_total - np.bincount(o, Ti, n_c)
    with np.errstate(invalid="ignore", divide="ignore"):
        dlam = -(e + np.bincount(o, r * inv, n_c)) / s_inv
        scale = np.maximum(np.abs(lam), np.bincount(o, np.abs(d1), n_c) / n_p)
    dT = -(r + dlam[o]) * inv
    rr = np.bincount(o, np.abs(r), n_c)
    now = (~conv) & (rr <= NEWTON_TOL_R * scale * n_p) & (np.abs(e) <= 1e-12 * T_total)
    conv |= now
    move = ~now[o]
    # damped: no piece may lose more than half or gain more than its duration in a step
    step = np.clip(dT, -0.5 * Ti, Ti)
    T[ix[move]] = Ti[move] + step[move]
    lam = np.where(conv, lam, lam + np.nan_to_num(dlam))
    return lam


def _share_time_numpy(L, beta, va, vb, owner, T_total, T_init):
    """Durations T_j of all pieces with J_j'(T_j) = -λ_c per chain c and Σ_c T_j = T_total[c]
    (Newton on the KKT system).  Returns (T_j, λ_c, converged per chain).  A chain that has
    converged is frozen (its pieces leave the batch): each chain's iterates are its own,
    whatever else is in the batch, and the batch shrinks as chains converge."""
    n_c = T_total.size
    T = T_init.copy()
    lam = np.zeros(n_c)
    conv = np.zeros(n_c, bool)
    fresh = np.ones(n_c, bool)
    n_p = np.bincount(owner, None, n_c)
    for _ in range(MAX_NEWTON):
        ix = np.flatnonzero(~conv[owner])
        if ix.size == 0:
            break
        o, Ti, Li, bi, ai, ci = owner[ix], T[ix], L[ix], beta[ix], va[ix], vb[ix]
        h = FD_H_R * Ti
        jm, j0, jp = _J3(Li, Ti - h, Ti, Ti + h, bi, ai, ci)
        d1 = (jp - jm) / (2.0 * h)
        d2 = (jp - 2.0 * j0 + jm) / (h * h)
        d2 = np.maximum(d2, 1e-12 * np.abs(j0) / (Ti * Ti) + 1e-300)
        lam = _kkt_step(o, ix, Ti, d1, d2, T, lam, conv, fresh, T_total, n_c, n_p)
    return T, lam, conv


# ---------------------------------------------------------------- exact slopes of the line law's J
# J_j(T) is the line law's optimal J = ∫ṡ² + β∫s̈² for fixed L, v0, v1 as a function of its
# duration; its slope is the law's Hamiltonian (constant along the law):
#     J'(T) = H = -(ṡ² + β s̈² - 2β ṡ s⃛),
# taken at mid-piece (τ = 1/2, x = 0), where line.py's shapes are simplest: g' = h = h'' = 0,
#     g(½) = shc(γ/4)² / (8n),  g''(½) = -1/n,  h'(½) = 2/shc(γ/2)
# (n = N/γ², line._N_COEF).  With u = T ṡ = w̄ + A g - δ h (line.py), δ²β/T² = β vd²/4
# (vd = v0 - v1, vs = v0 + v1):
#     F = u² + β vd² Q + 2 (β/T²) A u R,       J' = -F / T²,     J'' = (2F/T - F') / T²,
#     u = w̄ + A G,  G = g(½),  R = 1/n,  Q = 1/shc(γ/2)²,
#     F' = 2u u' + β vd² Q_z z' + 2(β/T²) ((A u' - (vs/2) u) R + A u R_z z' - 2 A u R / T),
#     u' = (vs/2)(1 - G) + A G_z z',  z = γ² = T²/β,  z' = 2z/T.
# G, R, Q are even in γ: power series in z (their coefficients exact rationals, made here
# once), and their z-derivatives the same series differentiated; no sinh, no cancelling
# difference.  The old slopes were central differences of J at T(1 ± 1e-4): on the plates'
# pieces of γ ~ 1e-3 their rounding error (J's ~1e-13 relative error, / 1e-4, x J/(T J'))
# reached 1e-3 .. 1e-2 of the slope, so the shares stopped wherever that noise said the
# slopes were equal; these slopes are within ~1e-11 of mpmath's derivative of J
# (tests/test_speed29_chainnewton_slopes.py).
EXACT_TERMS = 30
EXACT_GAMMA_MAX = 2.0     # γ above this anywhere in a step: the exact path declines (z <= 4: 24 terms)


def _exact_series():
    """(EXACT_TERMS, 6) coefficients of G, R, Q, dG/dz, dR/dz, dQ/dz in powers of z = γ²."""
    from fractions import Fraction as Fr
    from math import factorial
    K = EXACT_TERMS + 1

    def shc(w):            # shc(x) with x² = w z: Σ (w z)^j / (2j + 1)!
        return [Fr(w) ** j / factorial(2 * j + 1) for j in range(K)]

    def mul(a, b):
        return [sum(a[i] * b[j - i] for i in range(j + 1)) for j in range(K)]

    def inv(a):
        r = [1 / a[0]]
        for j in range(1, K):
            r.append(-sum(a[i] * r[j - i] for i in range(1, j + 1)) / a[0])
        return r

    n = [Fr(2 * (j + 1), 4 ** (j + 1) * factorial(2 * j + 3)) for j in range(K)]     # line._N_COEF
    R = inv(n)
    G = [x / 8 for x in mul(mul(shc(Fr(1, 16)), shc(Fr(1, 16))), R)]
    Q = inv(mul(shc(Fr(1, 4)), shc(Fr(1, 4))))
    d = lambda a: [a[j + 1] * (j + 1) for j in range(K - 1)]        # noqa: E731
    cols = [G[:-1], R[:-1], Q[:-1], d(G), d(R), d(Q)]
    return np.ascontiguousarray(np.array([[float(c[j]) for c in cols] for j in range(EXACT_TERMS)]))


# _exact_series() as written out (its 180 doubles as hex, row by row: the same bits; Fraction
# arithmetic took ~12 ms of every run's import; tests/test_speed30_exact_series.py makes them again)
_EX_COEF_HEX = (
    "0x1.8000000000000p+0", "0x1.8000000000000p+3", "0x1.0000000000000p+0",
    "-0x1.999999999999ap-8", "-0x1.3333333333333p-2", "-0x1.5555555555555p-4",
    "-0x1.999999999999ap-8", "-0x1.3333333333333p-2", "-0x1.5555555555555p-4",
    "0x1.5748a7bdaf0e2p-13", "0x1.3bfa2608c6f2dp-7", "0x1.1111111111111p-7",
    "0x1.5748a7bdaf0e2p-14", "0x1.3bfa2608c6f2dp-8", "0x1.1111111111111p-8",
    "-0x1.a22e9dcb24606p-19", "-0x1.9f0fb38a94d24p-13", "-0x1.0410410410410p-11",
    "-0x1.16c9be876d959p-20", "-0x1.14b5225c6336dp-14", "-0x1.5ac056b015ac0p-13",
    "0x1.bdf974d43c88fp-25", "0x1.c7344ee24e9cfp-19", "0x1.845c8a0ce5129p-16",
    "0x1.bdf974d43c88fp-27", "0x1.c7344ee24e9cfp-21", "0x1.845c8a0ce5129p-18",
    "-0x1.bb3cb8b5af2adp-31", "-0x1.c90300cd14c53p-25", "-0x1.f85d955d36cbbp-21",
    "-0x1.6296fa2af288ap-33", "-0x1.6d9c00a4109dcp-27", "-0x1.937e11175f095p-23",
    "0x1.a5fa94936d3bdp-37", "0x1.b4a610a94f8b3p-31", "0x1.2b94604f647b3p-25",
    "0x1.1951b86248d29p-39", "0x1.23196070dfb22p-33", "0x1.8f708069db4efp-28",
    "-0x1.864855530e5a4p-43", "-0x1.9459b9c530ae8p-37", "-0x1.4ebfd17f7a75cp-30",
    "-0x1.be098615c7429p-46", "-0x1.ce1d669837a2ep-40", "-0x1.7e9213ff67620p-33",
    "0x1.6181db4660b3cp-49", "0x1.6e67ade60a38fp-43", "0x1.65ca93d81fc07p-35",
    "0x1.6181db4660b3cp-52", "0x1.6e67ade60a38fp-46", "0x1.65ca93d81fc07p-38",
    "-0x1.3b2a6ca225d66p-55", "-0x1.46b637a6621a3p-49", "-0x1.71c3b8122f1b8p-40",
    "-0x1.1825b5e576f77p-58", "-0x1.22691505ac891p-52", "-0x1.48adf8f3b8187p-43",
    "0x1.15815b5fa73a6p-61", "0x1.1faf9090c78b0p-55", "0x1.743335bc66c5bp-45",
    "0x1.bc022bcc3ec3cp-65", "0x1.cc4c1a813f44dp-59", "0x1.29c29163856afp-48",
    "-0x1.e3cc58453fb66p-68", "-0x1.f58e19d78d4d9p-62", "-0x1.6ecbce01cf605p-50",
    "-0x1.5fda6ebdffca7p-71", "-0x1.6cc46fe2954fbp-65", "-0x1.0ac2c45e68461p-53",
    "0x1.a23c76942aff7p-74", "0x1.b196d34b1b769p-68", "0x1.633b5f77ab6c0p-55",
    "0x1.16d2f9b81caa4p-77", "0x1.210f378767a46p-71", "0x1.d9a47f4a39e55p-59",
    "-0x1.670c2c38d060bp-80", "-0x1.743a7e4086b46p-74", "-0x1.530f58bef39a9p-60",
    "-0x1.b9e798e3769e6p-84", "-0x1.ca209b631bf1bp-78", "-0x1.a14df71266e5ap-64",
    "0x1.326948e4f5417p-86", "0x1.3da8fbad7b7c3p-80", "0x1.3fa67c7b677bdp-65",
    "0x1.5e2f2ebc8601ap-90", "0x1.6b0a4433fad71p-84", "0x1.6d508e43e3fb3p-69",
    "-0x1.04284354ff9e0p-92", "-0x1.0db5464d9052ap-86", "-0x1.2a2b54783dc00p-70",
    "-0x1.158047d221b9ap-96", "-0x1.1fb04afd66be8p-90", "-0x1.3e0c15d597333p-74",
    "0x1.b7cebcf543614p-99", "0x1.c7f42614d2940p-93", "0x1.1394209a2746fp-75",
    "0x1.b7cebcf543614p-103", "0x1.c7f42614d2940p-97", "0x1.1394209a2746fp-79",
    "-0x1.724e17ce65cfep-105", "-0x1.7fe64e45545e4p-99", "-0x1.f94c19818f701p-81",
    "-0x1.5c85bc0d8cffep-109", "-0x1.69513a9b9ab31p-103", "-0x1.db92ead44ac3dp-85",
    "0x1.36b5062bc69dbp-111", "0x1.421d1f57930c3p-105", "0x1.cbf45a6c3d689p-86",
    "0x1.142f21ee05e18p-115", "0x1.1e52c686bb990p-109", "0x1.98d933ee6f796p-90",
    "-0x1.03e57bf4b8e6cp-117", "-0x1.0d700d458124ap-111", "-0x1.a00683903e94dp-91",
    "-0x1.b5b864fa7ac7fp-122", "-0x1.c5ca314ca39c0p-116", "-0x1.5e5653d7c8e92p-95",
    "0x1.b195df0d1be34p-124", "0x1.c180cf26c0a2fp-118", "0x1.7627353e65fa5p-96",
    "0x1.5ade4c0a7cb5dp-128", "0x1.679a3f5233b59p-122", "0x1.2b5290feb7fb7p-100",
    "-0x1.68c573a435dc0p-130", "-0x1.760410b3d49b7p-124", "-0x1.4ec573247b9d1p-101",
    "-0x1.12df950f65fcfp-134", "-0x1.1cf6e8277d6a4p-128", "-0x1.fe20af748b9a0p-106",
    "0x1.2b81270af2f8ap-136", "0x1.367ff75f31e0ep-130", "0x1.2a24ed3599879p-106",
    "0x1.b3a495e16169bp-141", "0x1.c3a2dc2d5fd2cp-135", "0x1.b1aa1336b0c53p-111",
    "-0x1.f041bfb2f4c3dp-143", "-0x1.013cd7f98ee11p-136", "-0x1.0867175181f9ap-111",
    "-0x1.5938de663af78p-147", "-0x1.65e559022af66p-141", "-0x1.6fdd58185bcaap-116",
    "0x1.9a5a6fc47066bp-149", "0x1.a96b087db290cp-143", "0x1.d325fdfe7bfdep-117",
    "0x1.11919fd84aef2p-153", "0x1.1b9cb053cc608p-147", "0x1.376ea95452a94p-121",
    "-0x1.52bb14127319fp-155", "-0x1.5f2a8cc8f05e8p-149", "-0x1.9b37cdfed1479p-122",
    "-0x1.b1934ce46a5eap-160", "-0x1.c17e24d83de9ap-154", "-0x1.072df47a1f89fp-126",
    "0x1.17296ba00a9b8p-161", "0x1.21690c76af380p-155", "0x1.68cd7dcbe24bdp-127",
    "0x1.579570c4f95cfp-166", "0x1.6432857e61800p-160", "0x1.bc109ad38cac1p-132",
    "-0x1.cb74dca076f66p-168", "-0x1.dc52f12a43aacp-162", "-0x1.3b9d28fdbd6c2p-132",
    "-0x1.1045405f1716cp-172", "-0x1.1a441d2286e9fp-166", "-0x1.760f98e0e0802p-137",
    "0x1.7993f616ed083p-174", "0x1.87708726eafb0p-168", "0x1.13503f8c8e36bp-137",
    "0x1.af8486f5a12dfp-179", "0x1.bf5c082c7a437p-173", "0x1.3aa4dae9c719fp-142",
    "-0x1.35e520a81372fp-180", "-0x1.4145980eec3d6p-174", "-0x1.df1229442ac0ep-143",
    "-0x1.55f400b976908p-185", "-0x1.6281c2456e9c0p-179", "-0x1.0850a4024c8dbp-147",
    "0x1.fc159ad7392abp-187", "0x1.075e59cc364c1p-180", "0x1.9fce4537f0b48p-148",
)
_EX_COEF = np.array([float.fromhex(h) for h in _EX_COEF_HEX]).reshape(EXACT_TERMS, 6)
# k terms are enough for z <= _EX_ZMAX[k]: the k-th term of every series at most 2^-60 of its
# first (the terms fall ~z/40 each: alternating series, truncation below the last kept term)
_EX_ZMAX = np.array([0.0] + [min((2.0 ** -60 * abs(c[0]) / abs(c[k - 1])) ** (1.0 / (k - 1)) if k > 1 else 0.0
                                 for c in _EX_COEF.T) for k in range(1, EXACT_TERMS + 1)])


def _exact_terms(zmax):
    """The series terms a step whose largest z is zmax needs (as line._nms_terms: the least
    k with zmax <= _EX_ZMAX[k], plus one); 0 (decline) above EXACT_GAMMA_MAX² or nan."""
    if not zmax <= EXACT_GAMMA_MAX * EXACT_GAMMA_MAX:
        return 0
    k = int(np.searchsorted(_EX_ZMAX, zmax, side="left"))
    return k + 1 if k + 1 <= EXACT_TERMS else 0


def _chain_terms(z, owner, n_c):
    """Each piece's series terms: its chain's own (_exact_terms of the largest z = T²/β of the
    chain's pieces, owner[i] the chain of piece i), as the chain core's exact_share takes them
    (ex_terms): a chain's slopes its own whatever chains are solved with it, and the series
    no longer than the chain needs (the batch's largest z gave every piece its terms before:
    +30 % Horner steps on the gyroid plate's windowed calls).  z: finite, >= 0, within
    EXACT_GAMMA_MAX² (the batch's checked first)."""
    zc = np.zeros(n_c)
    np.maximum.at(zc, owner, z)
    return np.searchsorted(_EX_ZMAX, zc, side="left").take(owner) + 1


def _exact_slopes(L, T, b, vs, vd, k):
    """J'(T), J''(T) (see above) of pieces L, T, β = b, vs = v0 + v1, vd = v0 - v1, with k
    terms of the series (an int, or each piece's: an int array), and 1/T; the operations of
    the chain core's ex_chunk, in its order."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):     # (a piece shrinking to 0:
        return _exact_slopes_(L, T, b, vs, vd, k)                          # the caller declines)


def _exact_slopes_(L, T, b, vs, vd, k):
    TT = T * T
    z = TT / b
    if np.ndim(k) == 0:
        s = np.empty((6,) + z.shape)
        s[...] = _EX_COEF[k - 1].reshape(6, 1)
        for c in _EX_COEF[k - 2::-1]:
            np.multiply(s, z, out=s)
            np.add(s, c.reshape(6, 1), out=s)
    else:          # each piece's own k: its Horner from its term k - 1 down, the same steps
        s = _EX_COEF[k - 1].T.copy()
        for j in range(int(k.max()) - 2, -1, -1):
            s = np.where(j <= k - 2, s * z + _EX_COEF[j].reshape(6, 1), s)
    g, r, q, gz, rz, qz = s
    rt = 1.0 / T                  # (two divisions an element: the rest are products)
    rt2 = rt * rt
    hv = vs / 2
    wb = (T * vs) / 2
    A = L - wb
    bt = b * rt2
    zp = (2 * z) * rt
    u = wb + A * g
    Au = A * u
    w = b * (vd * vd)
    F = (u * u + w * q) + (2 * bt) * (Au * r)
    up = (hv - hv * g) + A * (gz * zp)
    Fp = ((2 * u) * up + w * (qz * zp)) + (2 * bt) * (((A * up - hv * u) * r + Au * (rz * zp)) - ((2 * Au) * r) * rt)
    d1 = -F * rt2
    d2 = ((2 * F) * rt - Fp) * rt2
    return d1, d2, rt


def _share_time_exact(L, beta, va, vb, owner, T_total, T_init, core=None):
    """_share_time_numpy's Newton on the exact slopes J', J'' (_exact_slopes) instead of
    central differences of J: one evaluation of the series a step instead of J three times,
    and quadratic convergence to the shares that make the true slopes equal.  The whole
    iteration in one C call (exact_share) when the core is there (core: the module, False:
    numpy), the same bits.  None (the caller runs _share_time_numpy) where a β is not finite
    and > 0, an L, va, vb not finite, a duration not finite and > 0, or a step's γ above
    EXACT_GAMMA_MAX; the caller's numpy code then raises LineLaw's errors."""
    n_c = T_total.size
    P = T_init.size
    if P == 0:
        return None
    f = lambda a: np.ascontiguousarray(a, float)          # noqa: E731
    if core and hasattr(core, "exact_share") and hasattr(core, "exact_prep"):
        got = _exact_share_core(core, f(L), f(beta), f(va), f(vb), owner, f(T_total), T_init)
        if got is not False:          # the result, or None: declined
            return got
    if not (np.all(beta > 0) and np.all(np.isfinite(beta)) and np.all(np.isfinite(L))
            and np.all(np.isfinite(va)) and np.all(np.isfinite(vb))):
        return None
    L, beta, T_total = f(L), f(beta), f(T_total)
    vs, vd = f(va + vb), f(va - vb)
    T = np.array(T_init, float)
    lam = np.zeros(n_c)
    conv = np.zeros(n_c, bool)
    fresh = np.ones(n_c, bool)
    n_p = np.bincount(owner, None, n_c)
    for _ in range(MAX_NEWTON):
        ix = np.flatnonzero(~conv[owner])
        if ix.size == 0:
            break
        o, Ti = owner[ix], T[ix]
        if not (np.all(Ti > 0) and np.all(np.isfinite(Ti))):
            return None
        z = (Ti * Ti) / beta[ix]
        if _exact_terms(float(np.max(z))) == 0:        # (the batch's largest z: decline)
            return None
        d1, d2, rt = _exact_slopes(L[ix], Ti, beta[ix], vs[ix], vd[ix], _chain_terms(z, o, n_c))
        d2 = np.maximum(d2, (1e-12 * np.abs(d1)) * rt + 1e-300)
        lam = _kkt_step(o, ix, Ti, d1, d2, T, lam, conv, fresh, T_total, n_c, n_p)
    return T, lam, conv


def _exact_share_core(core, L, beta, va, vb, owner, T_total, T_init):
    """_share_time_exact's iteration in one C call (exact_share), its checks and inputs
    (vs, vd, the pieces' counts and offsets) in another (exact_prep: one pass, not ~15
    numpy calls a step): (T, λ, conv); None where _share_time_exact declines (a bad input,
    a step's γ above EXACT_GAMMA_MAX); False where the owners are not in chain order (the
    numpy iteration runs).  L, beta, va, vb, T_total: contiguous float64."""
    n_c, P = T_total.size, T_init.size
    vs, vd, npc = np.empty(P), np.empty(P), np.empty(n_c)
    poff = np.empty(n_c + 1, np.int64)
    got = core.exact_prep(L, beta, va, vb, np.ascontiguousarray(owner, np.int64), vs, vd, poff, npc)
    if got <= 0:
        return None if got < 0 else False
    T = np.array(T_init, float)
    lam = np.zeros(n_c)
    conv = np.zeros(n_c, bool)
    if core.exact_share(L, beta, vs, vd, poff, npc, T_total, T, lam, conv.view(np.uint8), _EX_COEF, _EX_ZMAX,
                        EXACT_GAMMA_MAX * EXACT_GAMMA_MAX, MAX_NEWTON) < 0:
        return None
    return T, lam, conv


def _times_and_speeds(law, s_targets, core=None):
    """(t, ṡ(t)) where the 1-D laws `law` reach s_targets: _time_of_distance, then
    _eval(law, t, "v"); the whole iteration compiled when the chain core is there (core:
    the module; None = CORE_MOD) and every law is in the series branch, else the numpy code."""
    core = CORE_MOD if core is None else core
    if core and law.L.ndim == 1 and law.L.size and bool(law._c["small"].all()):
        out = _tod_core(core, law, s_targets)
        if out is not None:
            return out
    tl = _time_of_distance(law, s_targets)
    return tl, _eval(law, tl, "v")[1]


def _tod_core(core, law, s_targets, max_iter=200):
    """_time_of_distance's safeguarded Newton (_tod_rows) wholly in C (tod_solve), and the
    speed at the t each law ends on, which the last step has already computed (what
    _eval(t, "v") gives: the same operations).  None where the numpy code must run."""
    T = law.T
    if (hasattr(core, "tod_prep") and T.dtype == np.float64 and law.L.dtype == np.float64 and T.ndim == 1
            and np.asarray(s_targets).shape == T.shape):      # the inputs below in one C pass (tod_prep)
        N = T.size
        f = lambda a: np.ascontiguousarray(a, float)          # noqa: E731
        c = law._c
        Tc, gs, n, sh2, wbar, A, dl, target, sgn, lo, hi, t, scale, out = (np.empty(N) for _ in range(14))
        act = np.empty(N, np.int64)
        core.tod_prep(f(T), f(law.L), f(c["gs"]), f(c["n"]), f(c["sh2"]), f(law._wbar), f(law._A), f(law._delta),
                      np.arange(N, dtype=np.int64), f(s_targets), Tc, gs, n, sh2, wbar, A, dl, target, sgn, lo, hi, t,
                      scale, out, act)
        vout = np.empty(N)
        na = core.tod_solve(t, Tc, gs, n, sh2, wbar, A, dl, target, sgn, lo, hi, scale, act, out, vout,
                            _S1_COEF_C, _S1_ZMAX_C, _SINH_COEF_C, max_iter)
        if na:                 # out of steps: the last t of the laws still going, not evaluated yet
            rest = act[:na]
            vout[rest] = _eval(law.take(rest), out[rest], "v")[1]
        return out, vout
    lo_s, hi_s = np.minimum(0.0, law.L), np.maximum(0.0, law.L)
    target = np.clip(np.asarray(s_targets, dtype=float), lo_s, hi_s)
    if target.shape != T.shape:
        return None
    target = np.ascontiguousarray(target)
    sgn = np.where(law.L < 0, -1.0, 1.0)
    lo = np.zeros(T.shape)
    hi = T.copy()
    with np.errstate(divide="ignore", invalid="ignore"):
        t = lo + (hi - lo) * np.where(law.L != 0, target / law.L, 0.5)
    scale = np.maximum(np.abs(law.L), 1e-300)
    f = lambda a: np.ascontiguousarray(a, float)          # noqa: E731
    c = law._c
    T, gs, n, sh2, wbar, A, dl = (f(a) for a in (T, c["gs"], c["n"], c["sh2"], law._wbar, law._A, law._delta))
    N = T.size
    out, vout = t.copy(), np.empty(N)
    act = np.arange(N, dtype=np.int64)
    na = core.tod_solve(t, T, gs, n, sh2, wbar, A, dl, target, sgn, lo, hi, scale, act, out, vout,
                        _S1_COEF_C, _S1_ZMAX_C, _SINH_COEF_C, max_iter)
    if na:                     # out of steps: the last t of the laws still going, not evaluated yet
        rest = act[:na]
        vout[rest] = _eval(law.take(rest), out[rest], "v")[1]
    return out, vout


_TIMES_AND_SPEEDS = _times_and_speeds


def _tod_core_laws(core, name, law, pj, s_targets):
    """What the chain core's time-of-distance entry `name` (tod_at, tod_at_into) reads of the
    laws: (their eight arrays, pj, s_targets) as contiguous float64 (pj int64), or None where
    _times_and_speeds would not run _tod_core's C path on the taken laws (no such entry, not
    float64 1-d laws, no pieces, shapes that differ, a law not small)."""
    c = law._c
    T = law.T
    if not (hasattr(core, name) and isinstance(pj, np.ndarray) and pj.ndim == 1 and pj.size
            and T.dtype == np.float64 and law.L.dtype == np.float64 and T.ndim == 1 and law.L.ndim == 1
            and np.asarray(s_targets).shape == pj.shape):
        return None
    small = c["small"]
    if not (bool(small.all()) or bool(small[pj].all())):      # (the taken laws' own test)
        return None
    f = lambda a: np.ascontiguousarray(a, float)          # noqa: E731
    laws = (f(T), f(law.L), f(c["gs"]), f(c["n"]), f(c["sh2"]), f(law._wbar), f(law._A), f(law._delta))
    return laws, np.ascontiguousarray(pj, np.int64), f(s_targets)


def _tod_core_at(core, law, pj, s_targets, max_iter=200):
    """_times_and_speeds(law.take(pj), s_targets) by the chain core without taking the
    laws first: tod_at makes each law's inputs as tod_prep makes them from the taken law's
    arrays and runs tod_solve's iteration on them, reading law i's numbers at pj[i] where
    they are (the same numbers: tests/test_speed35_chains_tod_at.py).  The ~14 arrays of
    law.take were gathered and then copied again by tod_prep, each active-set step of
    every chain batch; then the laws' 7 arrays were copied out by tod_prep into as many
    arrays of the free vertices, which tod_solve gathered from again at every step.  None
    (the caller takes the laws and calls _times_and_speeds) where _times_and_speeds would
    not run _tod_core's C path on the taken laws."""
    got = _tod_core_laws(core, "tod_at", law, pj, s_targets)
    if got is None:
        return None
    laws, pj, s = got
    N = pj.size
    out, vout, act = np.empty(N), np.empty(N), np.empty(N, np.int64)
    na = core.tod_at(*laws, pj, s, out, vout, act, _S1_COEF_C, _S1_ZMAX_C, _SINH_COEF_C, max_iter)
    if na:                     # out of steps: the last t of the laws still going, not evaluated yet
        rest = act[:na]
        vout[rest] = _eval(law.take(pj[rest]), out[rest], "v")[1]
    return out, vout


_TOD_CORE_AT = _tod_core_at


def _tod_core_into(core, law, pj, s_targets, free, v, t, max_iter=200):
    """_Flat._at_times' `tl, v[free] = _tod_core_at(core, law, pj, s_targets); t[free] += tl`
    in one C call (tod_at_into: tod_at's iteration, each law's ṡ and t put at free[i] as it
    ends; no out, vout arrays, no numpy scatters of them): the same numbers
    (tests/test_speed41_chain41_into.py).  free: int64 without repeats (vert_prep's free
    vertices); v, t: contiguous float64.  False (nothing written: the caller runs its own
    lines) where _tod_core_at would return None or the arrays are not those types."""
    if not (isinstance(pj, np.ndarray) and free.shape == pj.shape and free.dtype == np.int64
            and v.dtype == t.dtype == np.float64 and v.flags.c_contiguous and t.flags.c_contiguous
            and v.shape == t.shape):
        return False
    got = _tod_core_laws(core, "tod_at_into", law, pj, s_targets)
    if got is None:
        return False
    laws, pj, s = got
    free = np.ascontiguousarray(free)
    act = np.empty(pj.size, np.int64)
    rest_t = core.tod_at_into(*laws, pj, s, free, v, t, act, _S1_COEF_C, _S1_ZMAX_C, _SINH_COEF_C, max_iter)
    if rest_t:                 # out of steps: the last t of the laws still going, not evaluated yet
        rest = act[:len(rest_t)]
        tl = np.array(rest_t, float)
        fr = free[rest]
        v[fr] = _eval(law.take(pj[rest]), tl, "v")[1]
        t[fr] += tl
    return True


# ---------------------------------------------------------------- the chains' line-law evaluation
# LineLaw.eval and time_of_distance (line.py) as the chains use them: with the deterministic
# sinh and cube of prims in the series branch (np.sinh and ** 3 there); the other branch is
# the line law's.  The reference of the compiled tod_solve.
def _eval(law, t, want="sva"):
    """law.eval(t, want) with prims."""
    return law.eval(t, want, prims)


def _time_of_distance(law, s_targets, max_iter=200):
    """line.time_of_distance with prims."""
    return time_of_distance(law, s_targets, max_iter, prims)


def solve_chains(problems, init_binding=None, init_vert_t=None):
    """ChainLaw of every ChainProblem, solved together (pieces of all chains in one batch).
    Warm start (optional, per chain, None = cold): init_binding, the binding set to start
    from; init_vert_t, vertex times of a nearby law (scaled by the caller to the problem's
    T, e.g. x T / T_nearby): the first
    guess of the pieces' durations.  Each active-set step starts from the previous law's
    vertex times.  The work is solve_flat's; this makes one ChainLaw per chain of it."""
    m = len(problems)
    if m == 0:
        return []
    fl = _Flat(problems)
    bound = np.zeros(fl.sv.size, bool)
    vt = np.zeros(fl.sv.size)            # vertex times of the warm start
    warm = np.zeros(m, bool)
    for c, pr in enumerate(problems):
        a, b = fl.voff[c], fl.voff[c + 1]
        if init_vert_t is not None and init_vert_t[c] is not None and init_vert_t[c].size == pr.s_v.size:
            vt[a:b] = init_vert_t[c]
            warm[c] = True
        if init_binding is not None and init_binding[c] is not None:
            bound[a + np.asarray(init_binding[c], int)] = True
        else:       # a cap below the mean speed is (nearly always) met: start with those
            bound[a:b] = pr.c_v < COLD_BIND_R * pr.S / pr.T
    res = solve_flat(fl, bound, vt, warm)
    return [res.law(c) for c in range(m)]


def cold_binding(fl):
    """The cold start's binding set: every vertex whose cap is below its chain's mean speed
    S/T x COLD_BIND_R (such a cap is nearly always met)."""
    return fl.cv < (COLD_BIND_R * fl.S / fl.T)[fl.ch]


def solve_flat(fl, bound, vt, warm, pieces=True):
    """The laws of all chains of fl (a _Flat) as flat arrays (FlatLaws), from the binding
    masks bound (flat over the vertices; changed in place to the final ones), the warm
    start's vertex times vt and warm (per chain: start from vt, else time shared as a
    constant speed would share it).

    The active set is held as flat arrays over all chains' vertices and pieces, and its
    bookkeeping (which vertex joins or leaves, has this binding set been seen) is done for
    all chains at once: an active-set step costs a few numpy calls for the whole batch,
    not a few per chain; each chain's arithmetic is the same, element by element, as a
    chain solved alone.  pieces False: the laws' pieces and knots are dropped once their
    figures are made (FlatLaws.law is then not available; a plate's candidate table
    needs only the vertices and figures)."""
    m = fl.S.size
    res = FlatLaws(fl, pieces)
    active = np.arange(m)
    hist = []        # the binding masks of the steps so far: a chain is active from step 0 to its end
    vt = vt.copy()
    warm = warm.copy()
    # the bookkeeping of a step in one C call (active_step) where the arrays are its types
    fast = (CORE_MOD is not None and bound.dtype == bool and bound.ndim == 1 and vt.dtype == np.float64
            and warm.dtype == bool and fl.cv.dtype == np.float64 and bound.flags.c_contiguous
            and warm.flags.c_contiguous and fl.cv.flags.c_contiguous)
    for it in range(MAX_ACTIVE_ITERS):
        if active.size == 0:
            break
        na = active.size
        st = None              # (the last step's arrays let go before this step makes its own)
        st = fl.solve_fixed(active, bound, vt, warm)
        hist.append(bound.copy())
        if fast and _active_step_core(st, fl, hist, bound, vt, warm, res, it == MAX_ACTIVE_ITERS - 1):
            active = st.active[~st.done]
            continue
        vi, rank = st.vi, st.rank
        bv = bound[vi]
        # a vertex over its cap joins the binding set; else a binding vertex whose
        # multiplier is negative leaves it
        viol = ~bv & (st.vert_v > fl.cv[vi] * (1 + CAP_TOL_R) + 1e-12)
        any_viol = np.bincount(rank[viol], None, na) > 0
        mu = st.multipliers()             # per binding vertex of the batch, in vertex order
        neg = mu < 0
        brank = rank[bv]
        any_neg = np.bincount(brank[neg], None, na) > 0
        new = bv | viol
        rel = ~any_viol & any_neg          # release the vertices of negative multiplier
        bpos = np.flatnonzero(bv)          # the binding vertices' places in vi
        off = neg & rel[brank]
        new[bpos[off]] = False
        again = rel & _seen(hist, vi, new, rank, na, rel)
        if again.any():                    # cycling: release only the worst
            order = np.lexsort((mu, brank))          # per chain, the least mu first (argmin's tie rule)
            first = order[np.r_[True, brank[order][1:] != brank[order][:-1]]]
            worst = first[again[brank[first]]]
            back = again[rank]
            new[back] = bv[back]
            new[bpos[worst]] = False
        moving = any_viol | any_neg
        cyc = moving & _seen(hist, vi, new, rank, na, moving)
        done = ~moving | cyc
        if it == MAX_ACTIVE_ITERS - 1:        # out of steps: the last law, not converged
            cyc = cyc | moving
            done = np.ones(na, bool)
        res.take(st, done, cyc)
        go = ~done
        gv = go[rank]
        bound[vi[gv]] = new[gv]
        vt[vi[gv]] = st.vert_t[gv]
        warm[active[go]] = True
        active = active[go]
    res.close(bound, pieces)
    return res


def _active_step_core(st, fl, hist, bound, vt, warm, res, last):
    """solve_flat's bookkeeping of the step st (its lines after hist.append: which vertex
    joins or leaves, cycling, done; res.take; bound, vt, warm of the chains going on) in
    one C call (active_step, chain by chain: the same masks).  Sets st.done.  False
    (nothing done: the numpy lines run) where the step's arrays are not the types it reads."""
    ix = (st.vi, st.voff, st.koff)
    if not (all(a.dtype == np.int64 and a.flags.c_contiguous for a in ix) and st.a0.dtype == np.float64
            and st.vert_v.dtype == np.float64 and st.vert_t.dtype == np.float64 and st.active.dtype == np.int64
            and len(hist) <= 64):
        return False
    na, n = st.active.size, st.vi.size
    c = np.ascontiguousarray
    new = np.empty(n, bool)
    done, cyc = np.empty(na, bool), np.empty(na, bool)
    # the multipliers: made in C from a0, a1 (_Step.multipliers' numbers), or the method's
    # own where it is not that one (a test forcing them)
    mu = None if _Step.multipliers is _MULTIPLIERS else c(np.asarray(st.multipliers(), float))
    # the done chains' vertex speeds and times written to res by active_step, unless take is
    # not FlatLaws' own (a test's stand-in: it takes them)
    own_take = type(res).take is _FLAT_TAKE and res.vert_v.flags.c_contiguous and res.vert_t.flags.c_contiguous
    rv, rt = (res.vert_v, res.vert_t) if own_take else (None, None)
    # bv None: the step's binding masks read in hist[-1] (bound as it was at the step: no gather here)
    CORE_MOD.active_step(st.vi, st.voff, None, c(st.vert_v), fl.cv, c(st.a0), c(st.a1),
                         st.koff, mu, hist, 1 + CAP_TOL_R, MU_TOL_R, int(last), new.view(np.uint8),
                         done.view(np.uint8), cyc.view(np.uint8), bound.view(np.uint8), vt, c(st.vert_t),
                         warm.view(np.uint8), c(st.active), rv, rt)
    if own_take:
        res.take(st, done, cyc, verts=False)
    else:
        res.take(st, done, cyc)
    st.done = done
    return True


def _seen(hist, vi, new, rank, na, want=None):
    """Per chain of the step: is its binding mask `new` (over the step's vertices vi) one
    of the masks of its steps so far (hist: the whole binding mask at each step; a chain
    is active in every step from the first to its last)?  want (per chain, optional): the
    chains whose answer is read (the others' entries are not looked at: meaningless)."""
    out = np.zeros(na, bool)
    if want is not None:       # only the chains want (the caller's mask: the others' answers are not read)
        if not want.any():
            return out
        sub = want[rank]
        vi, new, rank = vi[sub], new[sub], rank[sub]
    for h in hist:
        out |= np.bincount(rank, h[vi] != new, na) == 0
    return out


class _Flat:
    """The chains of one solve_chains call as flat arrays: vertex positions sv and caps cv
    (chain c's at voff[c]:voff[c + 1]), lengths S, durations T, weights beta, end speeds."""

    def __init__(self, problems):
        self.problems = problems
        self._setup(np.concatenate([pr.s_v for pr in problems]), np.concatenate([pr.c_v for pr in problems]),
                    np.array([pr.s_v.size for pr in problems], int),
                    *(np.array([getattr(pr, f) for pr in problems]) for f in ("S", "T", "beta", "v0", "v1")))

    @classmethod
    def of_arrays(cls, sv, cv, nv, S, T, beta, v0, v1):
        """The chains given as flat arrays (no ChainProblem objects: FlatLaws.law gives
        laws whose problem is None)."""
        self = object.__new__(cls)
        self.problems = None
        self._setup(np.asarray(sv, float), np.asarray(cv, float), np.asarray(nv, int),
                    *(np.asarray(a, float) for a in (S, T, beta, v0, v1)))
        return self

    def take(self, keep):
        """The chains keep (ascending indices) of these, as flat arrays of their own."""
        keep = np.asarray(keep, np.int64)
        nv = self.nv[keep]
        if keep.size and keep[0] >= 0 and np.all(keep[1:] > keep[:-1]):
            # (strictly ascending: a mask says the same) each chain's vertices as one run
            done = np.zeros(self.S.size, bool)
            done[keep] = True
            sv, cv = _blocks((self.sv, self.cv), self.voff, done, int(nv.sum()))
        else:
            vs = np.repeat(self.voff[keep] - np.concatenate([[0], np.cumsum(nv)[:-1]]), nv)
            vs = vs + np.arange(int(nv.sum()))
            sv, cv = self.sv[vs], self.cv[vs]
        return _Flat.of_arrays(sv, cv, nv, self.S[keep], self.T[keep],
                               self.beta[keep], self.v0[keep], self.v1[keep])

    def with_T(self, T, beta):
        """The same chains at durations T and weights beta."""
        out = object.__new__(_Flat)
        out.__dict__.update(self.__dict__)
        out.T, out.beta = np.asarray(T, float), np.asarray(beta, float)
        return out

    def _setup(self, sv, cv, nv, S, T, beta, v0, v1):
        self.voff = np.concatenate([[0], np.cumsum(nv)]).astype(int)
        self.nv = nv
        self.sv, self.cv = sv, cv
        self.S, self.T, self.beta, self.v0, self.v1 = S, T, beta, v0, v1
        # a vertex's piece is the count of binding vertices up to it (searchsorted on the
        # knots) when the vertices are strictly inside (0, S) and increasing
        self.ch = ch = np.repeat(np.arange(S.size), nv)      # chain of each vertex
        inner = np.ones(self.sv.size, bool)
        inner[self.voff[1:-1]] = False             # first vertex of a chain: no predecessor
        with np.errstate(invalid="ignore"):
            self.monotone = bool(np.all(self.sv > 0.0) and np.all(self.sv < self.S[ch])
                                 and np.all((np.diff(self.sv, prepend=0.0) > 0.0) | ~inner))

    def _knots_numpy(self, active, vi, rank, bvoff, nv, bound, vt, warm):
        """solve_fixed's knots [0, binding vertices, S] per chain (ks, speeds kv, warm-start
        times kt0; chain r's at koff[r]:koff[r + 1]) and pieces (owner, start knot p0, L,
        va, vb, first guess T0), numpy; kj_mono None (fixed_knots' reference)."""
        na = active.size
        ne = nv + 2
        eoff = np.concatenate([[0], np.cumsum(ne)]).astype(int)
        E = int(eoff[-1])
        es, ev, et = np.empty(E), np.empty(E), np.empty(E)
        keep = np.empty(E, bool)
        first, last = eoff[:-1], eoff[1:] - 1
        es[first], es[last] = 0.0, self.S[active]
        ev[first], ev[last] = self.v0[active], self.v1[active]
        et[first], et[last] = 0.0, self.T[active]
        keep[first] = keep[last] = True
        pos = np.arange(vi.size) + 2 * rank + 1
        es[pos], ev[pos], et[pos] = self.sv[vi], self.cv[vi], vt[vi]
        keep[pos] = bound[vi]
        ks, kv, kt0 = es[keep], ev[keep], et[keep]
        nk = np.add.reduceat(keep.astype(np.int64), eoff[:-1]) if na else np.zeros(0, np.int64)   # knots a chain
        koff = np.concatenate([[0], np.cumsum(nk)]).astype(int)
        npc = nk - 1                                   # pieces per chain
        owner = np.repeat(np.arange(na), npc)
        start = np.ones(ks.size, bool)                 # piece start knots: all but each chain's last
        start[koff[1:] - 1] = False
        p0 = np.flatnonzero(start)
        L = ks[p0 + 1] - ks[p0]
        va, vb = kv[p0], kv[p0 + 1]
        Tc, Sc = self.T[active], self.S[active]
        T0 = Tc[owner] * L / Sc[owner]                # as a constant speed would share it
        w = warm[active]
        if w.any():                # the nearby law's vertex times at the knots, if all ahead
            t0 = kt0[p0 + 1] - kt0[p0]
            good = np.bincount(owner, ~(t0 > 1e-6 * Tc[owner]), na) == 0
            use = (w & good)[owner]
            T0 = np.where(use, t0, T0)
        return ks, kv, kt0, koff, owner, p0, L, va, vb, T0, None

    def _step_vertices(self, active, bound):
        """(vi, rank, bvoff, bv) of the chains active (ascending): their vertices in order,
        the place in active of each one's chain, each chain's first in vi (and their count
        last), bound[vi].  By the chain core in one pass (step_vertices) when it is there,
        the same numbers."""
        if (CORE_MOD is not None and hasattr(CORE_MOD, "step_vertices") and active.dtype == np.int64
                and bound.dtype == bool and self.voff.dtype == np.int64):
            nall, na = self.sv.size, active.size
            vi, rank, bv = np.empty(nall, np.int64), np.empty(nall, np.int64), np.empty(nall, bool)
            bvoff = np.empty(na + 1, np.int64)
            n = CORE_MOD.step_vertices(np.ascontiguousarray(active), np.ascontiguousarray(self.voff),
                                       np.ascontiguousarray(bound).view(np.uint8), vi, rank, bvoff, bv.view(np.uint8))
            if n >= 0:
                return vi[:n], rank[:n], bvoff, bv[:n]
        nv = self.nv[active]
        on = np.zeros(self.S.size, bool)
        on[active] = True
        vi = np.flatnonzero(on[self.ch])
        rank = np.repeat(np.arange(active.size), nv)
        bvoff = np.concatenate([[0], np.cumsum(nv)]).astype(int)
        return vi, rank, bvoff, bound[vi]

    def _knots_core(self, core, active, vi, bv, bvoff, vt, warm):
        """_knots_numpy in one C call (fixed_knots, the same numbers), plus kj_mono: each
        vertex's piece start knot as solve_fixed's monotone count has it.  None where the
        inputs are not the float64 / int64 arrays it reads (the numpy code runs)."""
        sv, cv = self.sv, self.cv
        if not (sv.dtype == cv.dtype == vt.dtype == np.float64 and self.S.dtype == self.T.dtype == np.float64
                and self.v0.dtype == self.v1.dtype == np.float64 and vi.dtype == bvoff.dtype == np.int64):
            return None
        na, n = active.size, vi.size
        K = 2 * na + int(np.count_nonzero(bv))
        P = K - na
        ks, kv, kt0, L, va, vb, T0 = (np.empty(K), np.empty(K), np.empty(K), np.empty(P), np.empty(P), np.empty(P),
                                      np.empty(P))
        koff, owner, kj = np.empty(na + 1, np.int64), np.empty(P, np.int64), np.empty(n, np.int64)
        c = np.ascontiguousarray
        core.fixed_knots(c(sv), c(cv), c(vt), c(vi), c(bv).view(np.uint8), c(bvoff), c(self.S[active]),
                         c(self.T[active]), c(self.v0[active]), c(self.v1[active]),
                         c(warm[active]).view(np.uint8), ks, kv, kt0, koff, L, va, vb, T0, owner, kj)
        return ks, kv, kt0, koff, owner, np.arange(P) + owner, L, va, vb, T0, kj

    def solve_fixed(self, active, bound, vt, warm):
        """Laws of the chains `active` (ascending) for the binding vertices `bound`, all
        their pieces in one Newton batch (_share_time); warm[c]: start from the vertex
        times vt, else time shared as a constant speed would share it."""
        pre = self._fixed_knots(active, bound, vt, warm)
        kn, beta = pre[5], pre[6]
        Tj, lam, conv = _share_time(kn[6], beta, kn[7], kn[8], kn[4], self.T[active], kn[9])
        return self._at_times(*pre, Tj, lam, conv)

    def vertices_at(self, bound, Tj):
        """(vert_v, vert_t) of every chain's law for the binding mask bound and its pieces'
        durations Tj (all chains' pieces, chain after chain: FlatLaws.piece_T): what
        solve_fixed gives for a step whose _share_time gave Tj -- its operations after
        _share_time on the same inputs, so the same bits (the law of a chain is its pieces'
        durations: the rest is the knots).  No Newton on the durations: a row of the
        candidate table is kept as its binding mask and durations (chains._KeptLaws)."""
        m = self.S.size
        pre = self._fixed_knots(np.arange(m), bound, np.zeros(self.sv.size), np.zeros(m, bool))
        st = self._at_times(*pre, np.asarray(Tj, float), None, None, accels=False)
        return st.vert_v, st.vert_t

    def _fixed_knots(self, active, bound, vt, warm):
        """solve_fixed's knots and pieces of the chains active (its lines before _share_time)."""
        na = active.size
        vi, rank, bvoff, bv = self._step_vertices(active, bound)
        # knots: [0, binding vertices, S] per chain, with speeds and warm-start times
        kn = None
        if CORE_MOD is not None:
            kn = self._knots_core(CORE_MOD, active, vi, bv, bvoff, vt, warm)
        if kn is None:
            kn = self._knots_numpy(active, vi, rank, bvoff, self.nv[active], bound, vt, warm)
        beta = self.beta.take(active).take(kn[4])      # (take: beta[active][owner]'s values, fewer steps)
        return active, na, vi, rank, bvoff, kn, beta, bv

    def _at_times(self, active, na, vi, rank, bvoff, kn, beta, bv, Tj, lam, conv, accels=True):
        """solve_fixed's lines after _share_time: the laws of its pieces' durations Tj, the
        knot times and the speed and time at every vertex (accels False: the pieces' end
        accelerations, which vertices_at does not read, left out: None)."""
        ks, kv, kt0, koff, owner, p0, L, va, vb, T0, kj_mono = kn
        law = _step_law(L, Tj, beta, va, vb)
        kt = _knot_times(Tj, koff, owner, p0, ks.size)
        # the pieces' shc(γ/2) (numpy's, of a lite law): a chain's last step's are its final
        # laws' (FlatLaws.close: _flat_figures_core takes them, not np.sinh of the same γ/2 again)
        sh2 = law._c["sh2"] if "lite" in law._c else None
        # speed and time at every vertex, in its piece
        if self.monotone and kj_mono is not None:     # fixed_knots' count (the same numbers)
            kj = kj_mono
        elif self.monotone:            # binding vertices up to it in its chain
            cnt = np.cumsum(bv)
            j = cnt - np.concatenate([[0], cnt])[bvoff[:-1]][rank]
            kj = koff[:-1][rank] + j
        else:
            j = np.empty(vi.size, int)
            for r in range(na):
                sl = slice(bvoff[r], bvoff[r + 1])
                kc = ks[koff[r]:koff[r + 1]]
                j[sl] = np.clip(np.searchsorted(kc, self.sv[vi[sl]], side="right") - 1, 0, kc.size - 2)
            kj = koff[:-1][rank] + j
        # the caps (exact at the binding vertices, piece ends), the start knots' times; the
        # free vertices in their piece's law (each element's Newton is its own: the batch's
        # make-up changes no figure)
        v, t, free, pj, x = self._vertex_starts(vi, bv, kj, rank, ks, kt)
        got = None
        if CORE_MOD is not None and _times_and_speeds is _TIMES_AND_SPEEDS:     # (not a test's stand-in)
            # the lines below in one C call where _tod_core_at is its own (not a test's recorder)
            if _tod_core_at is _TOD_CORE_AT and _tod_core_into(CORE_MOD, law, pj, x, free, v, t):
                got = True
            else:
                got = _tod_core_at(CORE_MOD, law, pj, x)
        if got is not True:
            if got is None:
                vlaw = law.take(pj)                    # = LineLaw(L[pj], Tj[pj], beta[pj], ...)
                got = _times_and_speeds(vlaw, x)
            tl, v[free] = got
            t[free] += tl                              # (t[free]: the start knots' times)
        # s̈ at both ends of every piece, made after the vertices' times (not read by them):
        # not held through the time-of-distance iteration, a step's largest memory
        a0 = a1 = None
        if accels:
            a0, a1 = _end_accels(law)
        return _Step(self, active, vi, rank, bvoff, v, t,
                     ks, kv, kt, koff, L, Tj, beta, va, vb, a0, a1, owner, lam, conv, sh2)

    def _vertex_starts(self, vi, bv, kj, rank, ks, kt):
        """(v, t, free, pj, x) of the step's vertices vi (bv: binding; kj: its piece's start
        knot; rank: its chain's place in the step): v the caps, t the start knots' times
        kt[kj]; the free vertices (not binding) free, their pieces pj and distances x into
        them.  By the chain core in one pass (vert_prep) when it is there, the same numbers."""
        if (CORE_MOD is not None and hasattr(CORE_MOD, "vert_prep") and bv.dtype == bool
                and vi.dtype == kj.dtype == rank.dtype == np.int64):
            n = vi.size
            c = np.ascontiguousarray
            v, t, x = np.empty(n), np.empty(n), np.empty(n)
            free, pj = np.empty(n, np.int64), np.empty(n, np.int64)
            nf = CORE_MOD.vert_prep(c(vi), c(bv).view(np.uint8), c(kj), c(rank), c(self.cv, float), c(self.sv, float),
                                    c(ks, float), c(kt, float), v, t, free, pj, x)
            return v, t, free[:nf], pj[:nf], x[:nf]
        v, t = self.cv[vi].copy(), kt[kj]
        free = np.flatnonzero(~bv)
        kf = kj[free]
        return v, t, free, kf - rank[free], self.sv[vi[free]] - ks[kf]


def _knot_times(Tj, koff, owner, p0, K):
    """solve_fixed's K knot times: each chain's (knots at koff[r]:koff[r + 1]) 0 and the
    running sums of its own pieces' durations Tj (pieces in chain order: owner, start knots
    p0), as np.cumsum along the rows of the (chains, pieces) grid gives them; in one C
    call (knot_times) when the chain core is there, the same sums."""
    na = koff.size - 1
    if CORE_MOD is not None and Tj.dtype == np.float64 and hasattr(CORE_MOD, "knot_times"):
        kt = np.empty(K)
        CORE_MOD.knot_times(np.ascontiguousarray(Tj), np.ascontiguousarray(koff, np.int64), kt)
        return kt
    kt = np.zeros(K)
    poff = koff[:-1] - np.arange(na)
    local = np.arange(Tj.size) - poff[owner]
    P = int((np.diff(koff) - 1).max()) if na else 0
    grid = np.zeros((na, P))
    grid[owner, local] = Tj
    kt[p0 + 1] = np.cumsum(grid, axis=1)[owner, local]
    return kt


def _step_law(L, T, beta, va, vb):
    """LineLaw(L, T, beta, va, vb) for solve_fixed, which reads of it only end_accels and,
    on the free vertices' pieces (take), time_of_distance and eval(t, "v"): with every law
    in the series branch (γ < GAMMA_SWITCH: the chains' γ is ~0.1) only what those read
    of the series branch (γ, shc(γ/2), n, the branch mark), each by LineLaw's own
    operations: n by _horner_nms' recurrence on its first coefficient set with the same
    number of terms (the whole batch's _nms_terms), so the same bits.  The coefficients
    of the integrals and extrema (shc(γ), m, S1, ...) are not made: such a law (_c["lite"])
    has no integrals, peak_speed, _critical_t.  Else (bad inputs: LineLaw raises; a law
    in the other branch) the whole LineLaw."""
    L, T, beta, va, vb = (np.asarray(a, dtype=float) for a in (L, T, beta, va, vb))
    if CORE_MOD is not None and L.ndim == 1 and L.shape == T.shape == beta.shape == va.shape == vb.shape:
        law = _step_law_core(CORE_MOD, L, T, beta, va, vb)
        if law is not None:
            return law
    if (L.ndim != 1 or not (L.shape == T.shape == beta.shape == va.shape == vb.shape)
            or not (np.all(T > 0) and np.all(np.isfinite(T))) or not np.all(beta > 0)
            or not (np.all(np.isfinite(L)) and np.all(np.isfinite(va)) and np.all(np.isfinite(vb)))):
        return LineLaw(L, T, beta, va, vb)
    gamma = T / np.sqrt(beta)
    small = gamma < _GAMMA_SWITCH
    if not small.all():
        return LineLaw(L, T, beta, va, vb)
    gs = np.minimum(gamma, _GAMMA_SWITCH)
    z2 = gs * gs
    coef = _NMS_COEF[:_nms_terms(z2), 0]
    n = np.empty(z2.shape)
    n[...] = coef[-1]
    for c in coef[-2::-1]:
        np.multiply(n, z2, out=n)
        np.add(n, c, out=n)
    law = object.__new__(LineLaw)
    law.L, law.T, law.beta, law.v0, law.v1 = L, T, beta, va, vb
    law.gamma = gamma
    law._c = {"small": small, "gs": gs, "n": n, "sh2": _shc(gs / 2), "lite": np.ones(L.shape, bool)}
    law._wbar = T * (va + vb) / 2
    law._delta = T * (va - vb) / 2
    law._A = L - law._wbar
    return law


def _end_accels(law):
    """law.end_accels() (a _step_law law): of a lite law (every law in the series branch)
    in one C call (step_accels: its operations, in its order) after numpy's cosh(γ/2)
    (np.cosh, as there), when the chain core is there; else end_accels itself."""
    c = law._c
    if CORE_MOD is None or "lite" not in c or law.T.ndim != 1:
        return law.end_accels()
    P = law.T.size
    a0, a1 = np.empty(P), np.empty(P)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        ch = np.cosh(0.5 * c["gs"])
    f = np.ascontiguousarray
    CORE_MOD.step_accels(f(law.T), f(c["n"]), f(c["sh2"]), ch, f(law._A), f(law._delta), a0, a1)
    return a0, a1


def _step_law_core(core, L, T, beta, va, vb):
    """_step_law's lite law with its numbers but shc(γ/2) made in one C call (step_law: the
    same operations, in the same order); shc(γ/2) by line._shc (np.sinh) as there.  None
    (the numpy code runs) where that code would not make a lite law."""
    f = np.ascontiguousarray
    P = L.size
    gamma, gs, n, wbar, dl, A = (np.empty(P) for _ in range(6))
    if core.step_law(f(L), f(T), f(beta), f(va), f(vb), _COEF_C, _ZMAX_C, gamma, gs, n, wbar, dl, A):
        return None
    # gs is γ (step_law's copy of it, the same bits): the law holds one array for both
    del gs
    law = object.__new__(LineLaw)
    law.L, law.T, law.beta, law.v0, law.v1 = L, T, beta, va, vb
    law.gamma = gamma
    law._c = {"small": np.ones(P, bool), "gs": gamma, "n": n, "sh2": _shc(gamma / 2), "lite": np.ones(P, bool)}
    law._wbar, law._delta, law._A = wbar, dl, A
    return law


class _Step:
    """One active-set step's laws (solve_fixed), flat; law(r, c) makes chain c's ChainLaw
    (r: its place in the step)."""

    def __init__(self, fl, active, vi, rank, voff, vert_v, vert_t, ks, kv, kt, koff, L, Tj, beta, va, vb,
                 a0, a1, owner, lam, conv, sh2=None):
        self.fl, self.active, self.vi, self.rank, self.voff = fl, active, vi, rank, voff
        self.vert_v, self.vert_t = vert_v, vert_t
        self.ks, self.kv, self.kt, self.koff = ks, kv, kt, koff
        self.L, self.Tj, self.beta, self.va, self.vb, self.a0, self.a1 = L, Tj, beta, va, vb, a0, a1
        self.owner, self.lam, self.conv = owner, lam, conv
        self.sh2 = sh2             # the pieces' shc(γ/2) of their lite law (None: not one)

    def multipliers(self):
        """Each binding vertex's multiplier (as _multipliers), all chains at once: s̈ just
        after minus s̈ just before, over the chain's acceleration scale; 0 unless negative."""
        na = self.active.size
        o = self.owner
        scale = np.zeros(na)
        first = self.koff[:-1] - np.arange(na)         # each chain's first piece (pieces in chain order)
        if na and o.size and np.all(first[1:] > first[:-1]):      # every chain has a piece: max per run
            np.maximum(scale, np.maximum.reduceat(np.abs(self.a0), first), out=scale)
            np.maximum(scale, np.maximum.reduceat(np.abs(self.a1), first), out=scale)
        else:
            np.maximum.at(scale, o, np.abs(self.a0))
            np.maximum.at(scale, o, np.abs(self.a1))
        scale = np.maximum(scale, 1e-9)
        same = o[1:] == o[:-1]                          # consecutive pieces of one chain
        jump = (self.a0[1:] - self.a1[:-1])[same]
        mu = jump / scale[o[1:][same]]
        return np.where(mu < -MU_TOL_R, mu, 0.0)

_MULTIPLIERS = _Step.multipliers


class FlatLaws:
    """solve_flat's laws, flat: per vertex (in fl's order) bound (the binding masks solved
    for), vert_v, vert_t; per chain conv, lam and the figures iv, ia, peak_v, min_v,
    peak_a; the pieces (L, T, beta, v0, v1, a0, a1) chain after chain (chain c's at
    poff[c]:poff[c + 1]) and their knots (ks, kv, kt at koff[c]:koff[c + 1]).  Each chain's
    numbers are those of the active-set step that ended it (take)."""

    def __init__(self, fl, pieces=True):
        self.fl, self.pieces = fl, pieces
        m, nv = fl.S.size, fl.sv.size
        self.vert_v, self.vert_t = np.empty(nv), np.empty(nv)
        self.conv, self.lam = np.zeros(m, bool), np.zeros(m)
        self._parts = []
        # the taken pieces' shc(γ/2) kept in the parts (their last column) while every step
        # taken had them (pieces False: close hands them to _flat_figures_core)
        self._with_sh2 = not pieces

    def take(self, st, done, cyc, verts=True):
        """Keep the laws of the step st's chains `done` (cyc: ended by cycling or out of
        steps: not converged).  verts False: their vertex speeds and times are already in
        vert_v, vert_t (active_step wrote them)."""
        nd = np.count_nonzero(done)        # (one C call for both tests: not any() and all()'s wrappers)
        if nd == 0:
            return
        whole = nd == done.size
        if whole:                   # (a batch's last step: every array whole, not masked)
            done = slice(None)
        if verts:
            dv = done if whole else done[st.rank]
            vd = st.vi[dv]          # (one mask gather for both)
            self.vert_v[vd] = st.vert_v[dv]
            self.vert_t[vd] = st.vert_t[dv]
        c = st.active[done]
        self.conv[c] = st.conv[done] & ~cyc[done]
        self.lam[c] = st.lam[done]
        # the chains as blocks (each done chain's pieces are consecutive, chains ascending):
        # close orders the blocks, not piece by piece (no per-piece chain array)
        ko = st.koff
        nk = ko[1:] - ko[:-1]                     # knots per chain (np.diff's values, without its wrapper)
        npc = nk[done] - 1                        # pieces per chain: its knots - 1
        # what close reads for the figures of the candidate table; with pieces a0, a1 and the knots too
        pcs = (st.L, st.Tj, st.beta, st.va, st.vb) + ((st.a0, st.a1) if self.pieces else ())
        sh2 = getattr(st, "sh2", None)
        if sh2 is None or sh2.dtype != np.float64 or sh2.shape != st.Tj.shape:
            self._with_sh2 = False
        if self._with_sh2:
            pcs += (sh2,)
        if whole:
            self._parts.append((c, npc) + pcs + ((st.ks, st.kv, st.kt) if self.pieces else ()))
            return
        part = (c, npc) + _blocks(pcs, st.koff - np.arange(nk.size + 1), done, int(npc.sum()))
        if self.pieces:
            part += _blocks((st.ks, st.kv, st.kt), st.koff, done, int(nk[done].sum()))
        self._parts.append(part)

    def close(self, bound, pieces=True):
        """Every chain taken: pieces and knots in chain order, the figures (_flat_figures);
        pieces False (FlatLaws(fl, False)): only the figures the candidate table reads (iv,
        peak_v, min_v; ia and peak_a are None), then drop the pieces."""
        cat = [np.concatenate(x) for x in zip(*self._parts)]
        del self._parts
        m = self.fl.S.size
        chains, npc = cat[0], cat[1]
        po, self.poff = _block_order(chains, npc, m)
        self.bound = bound
        if not (pieces and self.pieces):
            # the final pieces' shc(γ/2), where every part has them (the parts' 8th column)
            sh2 = cat[7] if self._with_sh2 and len(cat) == 8 else None
            if self._block_figures(cat[2:7], sh2, chains, npc, m):
                self.T = cat[3].take(po)
            else:
                self.L, self.T, self.beta, self.v0, self.v1 = (x.take(po) for x in cat[2:7])
                sh2 = None if sh2 is None else sh2.take(po)
                del cat
                _flat_figures(self, full=False, sh2=sh2)
            # the pieces' durations kept (piece_T, chain c's at piece_off[c]:piece_off[c + 1]):
            # with the binding mask they are the law (_Flat.vertices_at makes its vertices again)
            self.piece_T, self.piece_off = self.T, self.poff
            for f in ("L", "T", "beta", "v0", "v1", "poff"):
                if hasattr(self, f):
                    delattr(self, f)
            return
        # (take: x[po]'s values by numpy's plain gather loop, fewer steps an item than indexing)
        self.L, self.T, self.beta, self.v0, self.v1, self.a0, self.a1 = (x.take(po) for x in cat[2:9])
        ko, self.koff = _block_order(chains, npc + 1, m)  # a chain's knots: its pieces + 1
        self.ks, self.kv, self.kt = (x.take(ko) for x in cat[9:12])
        _flat_figures(self)

    def _block_figures(self, cols, sh2, chains, npc, m):
        """close(pieces=False)'s figures (iv, peak_v, min_v; ia, peak_a None) made on the
        pieces in the parts' order, the blocks end to end (cols: L, T, beta, v0, v1 so;
        chain chains[i]'s npc[i] pieces its block), not on their copies in chain order:
        _flat_figures_core's arithmetic is piece by piece, then per chain over its own
        pieces in their order, the same in a block as in chain order, so each chain's
        figures are the same bits; only the chains' figures are put in chain order.  Where
        every chain has one block of pieces (else the core declines in chain order too)
        and the core takes them; False (nothing set) else."""
        if CORE_MOD is None or chains.size != m or not np.all(npc > 0):
            return False
        blk = _BlockLaws()
        blk.L, blk.T, blk.beta, blk.v0, blk.v1 = cols
        blk.poff = np.concatenate([[0], np.cumsum(npc)]).astype(np.int64)
        if not _flat_figures_core(CORE_MOD, blk, sh2):
            return False
        for f in ("iv", "peak_v", "min_v"):
            out = np.empty(m)
            out[chains] = getattr(blk, f)
            setattr(self, f, out)
        self.ia = self.peak_a = None
        return True

    def law(self, c):
        """Chain c's ChainLaw."""
        fl = self.fl
        k0, k1 = self.koff[c], self.koff[c + 1]
        p0, p1 = self.poff[c], self.poff[c + 1]
        v0, v1 = fl.voff[c], fl.voff[c + 1]
        lw = ChainLaw()
        lw.problem = fl.problems[c] if fl.problems is not None else None
        lw.binding = np.flatnonzero(self.bound[v0:v1])
        lw.knot_s, lw.knot_v, lw.knot_t = self.ks[k0:k1], self.kv[k0:k1], self.kt[k0:k1]
        p = _Pieces()
        sl = slice(p0, p1)
        p.L, p.T, p.beta, p.v0, p.v1 = self.L[sl], self.T[sl], self.beta[sl], self.v0[sl], self.v1[sl]
        p.a0, p.a1 = self.a0[sl], self.a1[sl]
        lw.pieces = p
        lw.converged = bool(self.conv[c])
        lw.lam = float(self.lam[c])
        lw.vert_v, lw.vert_t = self.vert_v[v0:v1].copy(), self.vert_t[v0:v1].copy()
        lw.iv, lw.ia = float(self.iv[c]), float(self.ia[c])
        lw.peak_v, lw.min_v, lw.peak_a = float(self.peak_v[c]), float(self.min_v[c]), float(self.peak_a[c])
        return lw


_FLAT_TAKE = FlatLaws.take


def _blocks(arrays, off, done, size):
    """Of each of arrays, the blocks (block r: items off[r]:off[r + 1]) of the chains done
    (bool mask), end to end: x[np.repeat(done, np.diff(off))].  size: their items in all.
    By the chain core's copies of whole runs (take_blocks) where the arrays are float64."""
    if CORE_MOD is not None and all(a.dtype == np.float64 and a.ndim == 1 for a in arrays):
        outs = tuple(np.empty(size) for _ in arrays)
        CORE_MOD.take_blocks(np.ascontiguousarray(off, np.int64), np.ascontiguousarray(done).view(np.uint8),
                             tuple(np.ascontiguousarray(a) for a in arrays), outs)
        return outs
    keep = np.repeat(done, np.diff(off))
    return tuple(a[keep] for a in arrays)


def _block_order(chains, counts, m):
    """(order, off): the items of blocks laid end to end -- chain chains[i]'s counts[i]
    items, each of the m chains in one block at most -- put in chain order (x[order]),
    and chain c's place in it (off[c]:off[c + 1]).  What a stable argsort of the items'
    chain numbers gives, made per block (FlatLaws.close: a chain's pieces are taken at
    one step, consecutive)."""
    counts = np.asarray(counts, np.int64)
    start = np.zeros(m, np.int64)                 # chain c's first item in the blocks' order
    start[chains] = np.cumsum(counts) - counts
    n_c = np.zeros(m, np.int64)
    n_c[chains] = counts
    off = np.concatenate([[0], np.cumsum(n_c)]).astype(int)
    order = np.repeat(start - off[:-1], n_c)
    order += np.arange(off[-1])                    # (in place: one array of the items fewer at the peak)
    return order, off


def _flat_figures(res, full=True, sh2=None):
    """∫ṡ², ∫s̈², peak and least speed, peak |s̈| of the final laws (not of the active-set
    steps before them), all pieces in one batch; each chain's sums as np.sum of its own
    pieces rounds them (row sums of the chains with the same number of pieces).  full
    False: ∫s̈² and peak |s̈| are not made (None).  sh2 (optional): the pieces' shc(γ/2)
    as their lite laws had them (_flat_figures_core's, not made again)."""
    if not full and CORE_MOD is not None and _flat_figures_core(CORE_MOD, res, sh2):
        return
    law = None if full else _figure_law(res.L, res.T, res.beta, res.v0, res.v1)
    if law is None:
        law = LineLaw(res.L, res.T, res.beta, res.v0, res.v1)
        iv, ia = law.integrals()
    else:
        iv = law._iv
    # the speed candidates of LineLaw._speed_candidates: the ends as eval has them
    # (end_speeds), the interior stationary point evaluated
    law._speeds = end_speeds(res.L, res.T, res.v0, res.v1) + (law.eval(law._critical_t(), "v")[1],)
    pv, mv = law.peak_speed(), law.min_speed()
    first = res.poff[:-1]
    res.peak_v, res.min_v = np.maximum.reduceat(pv, first), np.minimum.reduceat(mv, first)
    npc = np.diff(res.poff)
    res.iv = np.empty(npc.size)
    res.ia = res.peak_a = None
    if full:
        pa0, pa1 = np.maximum.reduceat(np.abs(res.a0), first), np.maximum.reduceat(np.abs(res.a1), first)
        res.peak_a = np.where(pa1 > pa0, pa1, pa0)        # as max(pa0, pa1)
        res.ia = np.empty(npc.size)
    if CORE_MOD is not None and iv.dtype == np.float64 and iv.ndim == 1:     # the same sums, run by run in C
        po = np.ascontiguousarray(res.poff, np.int64)
        CORE_MOD.row_sums(np.ascontiguousarray(iv), po, res.iv)
        if full:
            CORE_MOD.row_sums(np.ascontiguousarray(ia), po, res.ia)
        return
    for k in distinct(npc).tolist():
        c = np.flatnonzero(npc == k)
        ix = first[c][:, None] + np.arange(k)
        res.iv[c] = np.sum(iv[ix], axis=1)
        if full:
            res.ia[c] = np.sum(ia[ix], axis=1)


def _flat_figures_core(core, res, sh2=None):
    """_flat_figures(res, full=False) with its arithmetic in C (fig_a .. fig_d, row_sums:
    _figure_law, end_speeds, _critical_t, eval(t, "v"), peak and least speed and the
    per-chain maxima, minima and sums, each its numpy operations in their order) and
    numpy's sinh and arctanh (line._shc, line._atanhc) in between: the same bits.  False
    (nothing set: the numpy code runs) where the inputs are not what it takes (not every law
    in the series branch, bad inputs, a chain without pieces).  sh2: shc(γ/2) of the pieces
    as their step's lite law made it (_step_law: the same γ = T / √β, the same np.sinh
    element by element: the same bits, tests/test_speed41_chain41_sh2.py), or None (made
    here)."""
    f = np.ascontiguousarray
    L, T, beta, v0, v1 = (np.asarray(a) for a in (res.L, res.T, res.beta, res.v0, res.v1))
    poff = np.asarray(res.poff)
    if not (L.ndim == 1 and L.size and L.shape == T.shape == beta.shape == v0.shape == v1.shape
            and all(a.dtype == np.float64 for a in (L, T, beta, v0, v1)) and poff.dtype == np.int64
            and poff.size >= 2 and np.all(poff[1:] > poff[:-1])):
        return False
    L, T, beta, v0, v1, poff = (f(a) for a in (L, T, beta, v0, v1, poff))
    P, nc = L.size, poff.size - 1
    gamma, gs, n, m, s1, wbar, dl, A = (np.empty(P) for _ in range(8))
    if core.fig_a(L, T, beta, v0, v1, _COEF_C, _ZMAX_C, gamma, gs, n, m, s1, wbar, dl, A):
        return False
    sh2 = f(_shc(gs / 2)) if sh2 is None or sh2.shape != gs.shape else f(sh2, float)
    iv, kog, vs, ve, rho, r = (np.empty(P) for _ in range(6))
    core.fig_b(L, T, gamma, n, m, s1, sh2, wbar, dl, A, iv, kog, vs, ve, rho, r)
    res.peak_v, res.min_v, res.iv = np.empty(nc), np.empty(nc), np.empty(nc)
    if hasattr(core, "fig_need"):
        # numpy's arctanh and sinh only at the pieces whose critical speed can be their
        # chain's peak or least speed (fig_need's bounds; ~1 in 10 on the gyroid plate): the
        # others' leave each chain's maximum and minimum as they are
        idx, rs = np.empty(P, np.int64), np.empty(P)
        k = core.fig_need(T, gs, rho, kog, r, n, sh2, wbar, dl, A, vs, ve, poff, idx, rs)
        idx, rs = idx[:k], rs[:k]
        with np.errstate(divide="ignore", invalid="ignore"):
            atc = f(_atanhc(rs))
        tau, za, zb, zx = (np.empty(k) for _ in range(4))
        core.fig_c_at(idx, T, gs, rho, kog, r, atc, tau, za, zb, zx)
        pa, pb, shx = (f(_shc(z)) for z in (za, zb, zx))
        core.fig_d_at(idx, tau, pa, pb, shx, n, sh2, wbar, A, dl, T, vs, ve, poff, res.peak_v, res.min_v)
    else:
        with np.errstate(divide="ignore", invalid="ignore"):
            atc = f(_atanhc(r))
        tau, za, zb, zx = (np.empty(P) for _ in range(4))
        core.fig_c(T, gs, rho, kog, r, atc, tau, za, zb, zx)
        pa, pb, shx = (f(_shc(z)) for z in (za, zb, zx))
        core.fig_d(tau, pa, pb, shx, n, sh2, wbar, A, dl, T, vs, ve, poff, res.peak_v, res.min_v)
    core.row_sums(iv, poff, res.iv)
    res.ia = res.peak_a = None
    return True


def _figure_law(L, T, beta, v0, v1):
    """LineLaw(L, T, beta, v0, v1) for _flat_figures(full=False), which reads of it ∫ṡ²
    (integrals()[0], here _iv) and the speed candidates (_critical_t, eval(t, "v")): with
    every law in the series branch only what those read (γ, n, m, S1 by _horner_nms, shc(γ/2),
    κ/γ; Ig1, Ih), each by LineLaw's own operations (_small_coeffs, integrals), so the same
    bits; shc(γ), Igp, Ihp and ∫s̈² are not made.  None (the caller makes the whole LineLaw)
    on bad inputs (LineLaw raises) or a law in the other branch."""
    L, T, beta, v0, v1 = (np.asarray(a, dtype=float) for a in (L, T, beta, v0, v1))
    if (L.ndim != 1 or not (L.shape == T.shape == beta.shape == v0.shape == v1.shape)
            or not (np.all(T > 0) and np.all(np.isfinite(T))) or not np.all(beta > 0)
            or not (np.all(np.isfinite(L)) and np.all(np.isfinite(v0)) and np.all(np.isfinite(v1)))):
        return None
    gamma = T / np.sqrt(beta)
    small = gamma < _GAMMA_SWITCH
    if not small.all():
        return None
    gs = np.minimum(gamma, _GAMMA_SWITCH)
    n, m, s1 = _horner_nms(gs * gs)                   # _small_coeffs' operations
    n = n.copy()
    sh2 = _shc(gs / 2)
    law = object.__new__(LineLaw)
    law.L, law.T, law.beta, law.v0, law.v1 = L, T, beta, v0, v1
    law.gamma = gamma
    law._c = {"small": small, "gs": gs, "n": n, "sh2": sh2, "kappa_over_gamma": 2 * n / sh2,
              "lite": np.ones(L.shape, bool)}
    law._wbar = T * (v0 + v1) / 2
    law._delta = T * (v0 - v1) / 2
    law._A = L - law._wbar
    A, d = law._A, law._delta                         # integrals()' ∫ṡ²
    law._iv = (L**2 + A**2 * (m / (2 * n * n)) + d**2 * (2 * s1 / sh2**2)) / T
    return law


class _Pieces:
    __slots__ = ("L", "T", "beta", "v0", "v1", "a0", "a1")


class _BlockLaws:
    """FlatLaws._block_figures' pieces (and the figures _flat_figures_core sets)."""
    __slots__ = ("L", "T", "beta", "v0", "v1", "poff", "iv", "ia", "peak_v", "min_v", "peak_a")


def solve_chain(s_v, c_v, S, T, beta, v0, v1):
    """One chain (see ChainProblem)."""
    return solve_chains([ChainProblem(s_v, c_v, S, T, beta, v0, v1)])[0]
