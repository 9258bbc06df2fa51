"""Energy/inertia-optimal law of motion along a straight stroke.

Problem (see /work/shared/MATH.md): s(t) on [0, T] minimising

    J = (m/2) ∫ ṡ² dt + (α m²/2) ∫ s̈² dt,      β = α m  [s²],

with s(0) = 0, s(T) = L, ṡ(0) = v0, ṡ(T) = v1.  Euler–Lagrange: s'''' = s̈/β.
Dimensionless stiffness γ = T/√β (β = inf ⇒ γ = 0, the cubic Hermite).

Formulation used here (τ = t/T, x = τ − 1/2, u = ds/dτ in mm):
integrating the EL equation once gives u'' = γ²(u − const), so

    u(τ) = w̄ + A·g(τ) − δ·h(τ),     w̄ = T(v0+v1)/2,  δ = T(v0−v1)/2,  A = L − w̄,

with two normalised shape functions
    g: even about τ = 1/2, g(0) = g(1) = 0, ∫g = 1   (rest-to-rest speed profile, = P')
    h: odd,               h(0) = −1, h(1) = 1       (h ∝ sinh(γx); ∫h = 0)
and s(τ) = w̄τ + A·G(τ) − δ·Hs(τ) with G = ∫g = P (rest-to-rest law), Hs = ∫h.
This is the requested L·P + v0T·H0 + v1T·H1 split, regrouped into even/odd parts
(H0 = (τ − P − Hs)/2, H1 = (τ − P + Hs)/2): parity makes the cross terms of ∫u², ∫u'² vanish,
so the integrals are diagonal quadratic forms with one γ-coefficient per shape.

Stability.  Two closed forms of every shape quantity, switched at γ = GAMMA_SWITCH:
  * γ < GAMMA_SWITCH: hyperbolic forms written with shc(z) = sinh(z)/z and positive-term power
    series (_n, _m, _s1).  The only cancelling combination, N = cosh(γ/2) − (2/γ)sinh(γ/2)
    (the D of MATH.md times e^{γ/2}/2), is summed as a series in γ² with positive terms, so there
    is no cancellation at all, and γ = 0 (β = inf) is evaluated exactly, not as a limit.
  * γ ≥ GAMMA_SWITCH: the same expressions multiplied through by e^{−γ/2}: only decaying
    exponentials and expm1, so nothing overflows up to γ = inf-ish (tested to 1e9).  The residual
    cancellation in D = 1 + e^{−γ} + 2 expm1(−γ)/γ is a factor ~12/γ², harmless above the switch.
"""
from __future__ import annotations

from math import factorial

import numpy as np

__all__ = ["LineLaw", "line_law", "time_of_distance", "GAMMA_SWITCH", "interior_speed", "end_speeds",
           "InteriorSpeeds", "cubic_figures", "peak_root_guess"]

# Switch between the series/hyperbolic and the exponential forms.  Measured against mpmath
# (80 digits) for each branch alone: the exponential branch's integral coefficient ∫g² − 1
# has relative error 1e-10 at γ = 0.1, 2e-14 at γ = 1, 2e-15 at γ = 2, 2e-16 from γ = 4 on
# (cancellation ~12/γ² in D plus a factor ~50 → ~6 in its numerator between γ = 2 and 4); the
# series branch is at 2e-16..4e-16 for every quantity up to γ = 12 with 24 terms (all terms
# positive, the truncation error at γ = 4 is < 1e-25).  So switch at 4, well inside both.
GAMMA_SWITCH = 4.0
_NTERMS = 24  # series length: last term at γ = 4 is < 1e-25 of the first for every series


def _series_coeffs(fn):
    return np.array([fn(j) for j in range(_NTERMS)], dtype=float)


# n(γ) = N/γ²  = Σ_j γ^{2j} 2(j+1) / (4^{j+1} (2j+3)!),   n(0) = 1/12
_N_COEF = _series_coeffs(lambda j: 2 * (j + 1) / (4 ** (j + 1) * factorial(2 * j + 3)))
# m(γ) = M/γ⁴, M = sinh(γ)/γ + 1 − 8 sinh²(γ/2)/γ² = Σ_j γ^{2j} (2j+2)/(2j+6)!,  m(0) = 1/360
_M_COEF = _series_coeffs(lambda j: (2 * j + 2) / factorial(2 * j + 6))
# S1(z) = (sinh z − z)/z³ = Σ_j z^{2j}/(2j+3)!,  S1(0) = 1/6
_S1_COEF = _series_coeffs(lambda j: 1.0 / factorial(2 * j + 3))


def _horner(coef, z2):
    """Σ coef[j] z2^j (all coef > 0 and z2 ≥ 0 here: no cancellation).  In place: the
    same product then sum per term as out * z2 + c, without two new arrays a term."""
    out = np.full_like(z2, coef[-1])
    for c in coef[-2::-1]:
        np.multiply(out, z2, out=out)
        np.add(out, c, out=out)
    return out[()]


# n, m and S1 of _small_coeffs as one (3, ...) Horner pass: each row is _horner's
# arithmetic on the same z2 (γ² = gs * gs = gs ** 2 bitwise: numpy squares by x * x)
_NMS_COEF = np.stack([_N_COEF, _M_COEF, _S1_COEF], axis=1)        # (terms, 3)


# Terms of _horner_nms a batch needs: with K terms kept, the last kept term is at most
# 2^-60 of the first for every z2 <= _NMS_ZMAX[K] in all three series (the terms decrease
# fast: ~z2 / (16 j^2)), plus one term more.  What the dropped terms add moves the last kept
# partial sums, but reaches the result only as a change of 2^-60 of its ulp: a rounding
# differs with a chance of that order per value, i.e. the values are the full series' in
# practice (tests/test_speed_chain3_horner.py; the chains' laws, all at γ <= 0.1, need 7 of the 24 terms).
def _zmax_table(coef):
    """_NMS_ZMAX for the coefficient columns coef (terms, k)."""
    return np.array([0.0] + [min((2.0 ** -60 * col[0] / col[k - 1]) ** (1.0 / (k - 1)) if k > 1 else 0.0
                                 for col in coef.T) for k in range(1, _NTERMS + 1)])


_NMS_ZMAX = _zmax_table(_NMS_COEF)
_S1_ZMAX = _zmax_table(_S1_COEF[:, None])


def _nms_terms(z2, table=_NMS_ZMAX):
    """How many terms of the (n, m, S1) series (or those of `table`) the batch z2 needs."""
    if z2.size == 0:
        return _NTERMS
    zmax = float(np.max(z2))
    if not zmax >= 0.0:                    # nan
        return _NTERMS
    k = int(np.searchsorted(table, zmax, side="left"))   # least k with zmax <= table[k]
    return min(k + 1, _NTERMS)


def _horner_nms(z2):
    """(n, m, S1) series at z2 (= _horner of each coefficient set), one pass; the terms
    that cannot move the result are left out (_nms_terms)."""
    z2 = np.asarray(z2, dtype=float)
    coef = _NMS_COEF[:_nms_terms(z2)]
    col = (3,) + (1,) * z2.ndim
    out = np.empty((3,) + z2.shape)
    out[...] = coef[-1].reshape(col)
    for c in coef[-2::-1]:
        np.multiply(out, z2, out=out)
        np.add(out, c.reshape(col), out=out)
    return out[0], out[1], out[2]


def _shc(z):
    """sinh(z)/z, = 1 at z = 0 (np.sinh is relatively accurate for small z)."""
    z = np.asarray(z, dtype=float)
    zero = z == 0.0
    if z.ndim and not zero.any():          # no 0: the quotient as the np.where below has it
        return np.sinh(z) / z
    if not z.ndim:
        safe = np.where(zero, 1.0, z)
        return np.where(zero, 1.0, np.sinh(safe) / safe)
    # np.where(zero, 1.0, np.sinh(safe) / safe), safe = np.where(zero, 1.0, z), with the
    # zeros' places listed once and stored to: the same quotients of the same numbers,
    # without np.where's two passes over every element
    safe = z.flatten()
    iz = np.flatnonzero(zero)
    safe[iz] = 1.0
    q = np.sinh(safe)
    q /= safe
    q[iz] = 1.0
    return q.reshape(z.shape)


def _s1(z):
    """(sinh z − z)/z³ for |z| ≤ GAMMA_SWITCH, by its positive series (the terms its batch
    needs, as _horner_nms)."""
    z2 = np.asarray(z, dtype=float) ** 2
    return _horner(_S1_COEF[:_nms_terms(z2, _S1_ZMAX)], z2)


# --------------------------------------------------------------------------------------------
# γ-only coefficients (one value per law)
# --------------------------------------------------------------------------------------------
def _gamma_coeffs(gamma):
    """Per-law constants, each law in its own branch only (the other branch's numbers are
    not computed: the chains' laws are all at γ = 0.1).  Each branch is fed a γ clipped to
    its own range as before, so every value is the two-branch np.where's, bit for bit
    (tests/test_speed_plan_line.py)."""
    gamma = np.asarray(gamma, dtype=float)
    small = gamma < GAMMA_SWITCH
    ns = int(np.count_nonzero(small))
    if ns == small.size:                       # one branch: no gather/scatter
        return _small_coeffs(np.minimum(gamma, GAMMA_SWITCH), small)
    if ns == 0:
        return _large_coeffs(np.maximum(gamma, GAMMA_SWITCH), small)
    cs = _small_coeffs(np.minimum(gamma[small], GAMMA_SWITCH), None)
    cl = _large_coeffs(np.maximum(gamma[~small], GAMMA_SWITCH), None)
    c = {"small": small}
    for k in _OUT_KEYS:                        # per-law outputs: scattered back
        v = np.empty(gamma.shape)
        v[small], v[~small] = cs[k], cl[k]
        c[k] = v
    for k, fill in (("gs", 0.0), ("n", 1.0), ("sh2", 1.0)):   # branch inputs of _shapes, placed
        v = np.full(gamma.shape, fill)
        v[small] = cs[k]
        c[k] = v
    for k, fill in (("gl", GAMMA_SWITCH), ("em", -1.0), ("Dn", 1.0), ("E", 0.0)):
        v = np.full(gamma.shape, fill)
        v[~small] = cl[k]
        c[k] = v
    return c


_OUT_KEYS = ("Ig1", "Igp", "Ih", "Ihp", "kappa_over_gamma")


def _small_coeffs(gs, small):
    """Small branch: n = N/γ², m = M/γ⁴, shc(γ/2) (γ in [0, switch])."""
    n, m, s1 = _horner_nms(gs * gs)
    n = n.copy()            # kept by the law: not a view holding m's and S1's rows alive
    sh2 = _shc(gs / 2)
    # Integral coefficients: Ig1 = ∫g² − 1 = ∫(g−1)²,  Igp = ∫g'²,  Ih = ∫h²,  Ihp = ∫h'²
    c = {"small": small, "gs": gs, "n": n, "sh2": sh2,
         "Ig1": m / (2 * n * n), "Igp": s1 / (2 * n * n), "Ih": 2 * s1 / sh2**2,
         "Ihp": 2 * (_shc(gs) + 1) / sh2**2,
         # κ/γ with κ = N/sinh(γ/2): an interior extremum of u sits at tanh(γx) = (B/A)κ.
         "kappa_over_gamma": 2 * n / sh2}
    return c


def _large_coeffs(gl, small):
    """Large branch (γ ≥ switch): everything times e^{−γ/2} (or e^{−γ})."""
    E = np.exp(-gl)
    em = np.expm1(-gl)                          # e^{−γ} − 1  (< 0)
    q = -em / gl                                # ∫ e^{−γτ} dτ
    Dn = 1.0 + E - 2.0 * q                      # = 2 e^{−γ/2} N
    one_m_E2 = -np.expm1(-2.0 * gl)
    return {"small": small, "gl": gl, "em": em, "Dn": Dn, "E": E,
            "Ig1": (one_m_E2 / gl + 2 * E - 4 * q * q) / Dn**2,
            "Igp": gl * (one_m_E2 - 2 * gl * E) / Dn**2,
            "Ih": (one_m_E2 / gl - 2 * E) / em**2,
            "Ihp": gl * (one_m_E2 + 2 * gl * E) / em**2,
            "kappa_over_gamma": Dn / (-em * gl)}


def _cube(x):
    return x**3


def _shapes_small(gs, n, sh2, tau, want, prim=None):
    """Small γ: hyperbolic forms, no cancellation (products/ratios of shc and series).
    want: which of the six shapes to compute ("G", "g", "gp", "Hs", "h", "hp"; None for
    the others).  prim: where sinh(z)/z and the cube come from (None: numpy's sinh and
    ** 3; the chains pass laws/prims.py, whose bits are the same on every machine)."""
    shc, cube = (_shc, _cube) if prim is None else (prim.shc, prim.cube)
    x = tau - 0.5
    G_s = g_s = gp_s = Hs_s = h_s = hp_s = None
    if "g" in want or "Hs" in want:
        pa, pb = shc(gs * tau / 2), shc(gs * (1 - tau) / 2)
        bub = tau * (1 - tau) * pa * pb             # = 4 sinh(γτ/2) sinh(γ(1−τ)/2)/γ²
        g_s = bub / (2 * n)
        Hs_s = -bub / sh2
    if "gp" in want or "h" in want:
        shx = shc(gs * x)
        gp_s = -x * shx / n
        h_s = 2 * x * shx / sh2
    if "G" in want:
        G_s = 0.5 + (x * shc(gs / 4) ** 2 / 8 - cube(x) * _s1(gs * x)) / n
    if "hp" in want:
        hp_s = 2 * np.cosh(gs * x) / sh2
    return G_s, g_s, gp_s, Hs_s, h_s, hp_s


def _shapes_large(gl, em, Dn, E, tau, want):
    """Large γ: decaying exponentials only."""
    x = tau - 0.5
    e0, e1 = np.expm1(-gl * tau), np.expm1(-gl * (1 - tau))   # both in (−1, 0]
    diff = e0 - e1                               # e^{−γτ} − e^{−γ(1−τ)}, no cancellation
    G_l = g_l = gp_l = Hs_l = h_l = hp_l = None
    if "g" in want:
        g_l = e0 * e1 / Dn
    if "gp" in want:
        gp_l = gl * diff / Dn
    if "G" in want:
        G_l = 0.5 + (x * (1 + E) + diff / gl) / Dn
    if "h" in want:
        h_l = diff / em
    if "hp" in want:
        hp_l = gl * (e0 + e1 + 2) / (-em)
    if "Hs" in want:
        Hs_l = e0 * e1 / (gl * em)
    return G_l, g_l, gp_l, Hs_l, h_l, hp_l


ALL_SHAPES = ("G", "g", "gp", "Hs", "h", "hp")
_WANT = {"s": ("G", "Hs"), "v": ("g", "h"), "a": ("gp", "hp")}


def _shapes(c, tau, want=ALL_SHAPES, prim=None):
    """(G, g, g', Hs, h, h') at τ ∈ [0, 1] (broadcast with the law shape), each element
    in its law's branch only; the shapes not in `want` are None (not computed); prim as
    _shapes_small's."""
    tau = np.asarray(tau, dtype=float)
    small = c["small"]
    shape = np.broadcast_shapes(tau.shape, small.shape)
    bc = lambda a: a if a is None or a.shape == shape else np.broadcast_to(a, shape)    # noqa: E731
    if small.all():
        return tuple(bc(a) for a in _shapes_small(c["gs"], c["n"], c["sh2"], tau, want, prim))
    if not small.any():
        return tuple(bc(a) for a in _shapes_large(c["gl"], c["em"], c["Dn"], c["E"], tau, want))
    sm = bc(small)
    lg = ~sm
    ts, tl = bc(tau)[sm], bc(tau)[lg]
    out_s = _shapes_small(bc(c["gs"])[sm], bc(c["n"])[sm], bc(c["sh2"])[sm], ts, want, prim)
    out_l = _shapes_large(bc(c["gl"])[lg], bc(c["em"])[lg], bc(c["Dn"])[lg], bc(c["E"])[lg], tl, want)
    res = []
    for a, b in zip(out_s, out_l):
        if a is None:
            res.append(None)
            continue
        v = np.empty(shape)
        v[sm], v[lg] = a, b
        res.append(v)
    return tuple(res)


def _atanhc(r):
    """atanh(r)/r for |r| < 1 (1 at r = 0); inf for |r| ≥ 1."""
    r = np.asarray(r, dtype=float)
    inside = np.abs(r) < 1
    if not r.ndim:
        rs = np.where(inside & (r != 0), r, 0.5)
        return np.where(r == 0, 1.0, np.where(inside, np.arctanh(rs) / rs, np.inf))
    # np.where(r == 0, 1.0, np.where(inside, np.arctanh(rs) / rs, np.inf)), rs = np.where(inside
    # & (r != 0), r, 0.5), with the places of the elements that are not their quotient (0, or
    # |r| >= 1, NaN) listed once and stored to: the same quotients of the same numbers, without
    # np.where's three passes over every element
    other = np.flatnonzero(~inside | (r == 0))
    if not other.size:
        return np.arctanh(r) / r
    rs = r.flatten()
    at = rs[other]
    rs[other] = 0.5
    q = np.arctanh(rs)
    q /= rs
    q[other] = np.where(at == 0, 1.0, np.inf)
    return q.reshape(r.shape)


def check_params(L, T, beta, v0, v1):
    """The law's parameters as float arrays broadcast together, checked (LineLaw's
    ValueErrors, in its order): T finite > 0, beta > 0 (inf allowed: gamma = 0; 0 and NaN
    not), L, v0, v1 finite."""
    L, T, beta, v0, v1 = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (L, T, beta, v0, v1)))
    if not (np.all(T > 0) and np.all(np.isfinite(T))):
        raise ValueError("T must be finite and > 0")
    if not np.all(beta > 0):
        raise ValueError("beta must be > 0 (np.inf allowed)")
    if not (np.all(np.isfinite(L)) and np.all(np.isfinite(v0)) and np.all(np.isfinite(v1))):
        raise ValueError("L, v0, v1 must be finite")
    return L, T, beta, v0, v1


class LineLaw:
    """Optimal straight-line law; all attributes are broadcast numpy arrays.

    Units: L [mm], T [s], beta [s²], v0, v1 [mm/s].  Parameters broadcast together; eval(t)
    broadcasts t against them with numpy rules, e.g. scalars + t of shape (k,), or parameters of
    shape (n, 1) (see `expand_dims`) + t of shape (n, k).
    """

    def __init__(self, L, T, beta, v0=0.0, v1=0.0):
        L, T, beta, v0, v1 = check_params(L, T, beta, v0, v1)
        self.L, self.T, self.beta, self.v0, self.v1 = L, T, beta, v0, v1
        self.gamma = T / np.sqrt(beta)                          # dimensionless, 0 for beta=inf
        self._c = _gamma_coeffs(self.gamma)
        self._wbar = T * (v0 + v1) / 2                          # mm
        self._delta = T * (v0 - v1) / 2                         # mm
        self._A = L - self._wbar                                # mm

    def take(self, idx):
        """The laws idx (an index array into 1-D laws), their γ-coefficients taken, not
        computed again (each is a function of its own law's γ only: the same numbers)."""
        out = object.__new__(LineLaw)
        for f in ("L", "T", "beta", "v0", "v1", "gamma", "_wbar", "_delta", "_A"):
            setattr(out, f, getattr(self, f)[idx])
        out._c = {k: v[idx] for k, v in self._c.items()}
        return out

    @property
    def shape(self):
        return self.L.shape

    def expand_dims(self):
        """Same laws with a trailing axis (params (..., 1)) for eval on per-law grids (..., k)."""
        return LineLaw(self.L[..., None], self.T[..., None], self.beta[..., None],
                       self.v0[..., None], self.v1[..., None])

    # ---------------------------------------------------------------- evaluation
    def eval(self, t, want="sva", prim=None):
        """(s [mm], ṡ [mm/s], s̈ [mm/s²]) at t [s]; t is clamped to [0, T].  want: which of
        s, v, a to compute (None for the others; the same numbers as all three); prim as
        _shapes_small's.

        t broadcasts against the law parameters: one law (scalars) × t (k,) → (k,);
        n laws with params (n, 1) (`expand_dims()`) × t (n, k) → (n, k)."""
        T = self.T
        tau = np.clip(np.asarray(t, dtype=float) / T, 0.0, 1.0)
        G, g, gp, Hs, h, hp = _shapes(self._c, tau, sum((_WANT[w] for w in want), ()), prim)
        wbar, A, d = self._wbar, self._A, self._delta
        s = wbar * tau + A * G - d * Hs if "s" in want else None
        v = (wbar + A * g - d * h) / T if "v" in want else None
        a = (A * gp - d * hp) / T**2 if "a" in want else None
        return s, v, a

    # ---------------------------------------------------------------- closed-form integrals
    def integrals(self):
        """(∫ṡ² dt [mm²/s], ∫s̈² dt [mm²/s³]) over [0, T], closed form.

        ∫u²dτ = L² + A²(∫g² − 1) + δ²∫h²,  ∫u'²dτ = A²∫g'² + δ²∫h'²  (parity kills cross terms;
        ∫g = 1 turns w̄² + 2w̄A + A² into L²)."""
        c, T, A, d = self._c, self.T, self._A, self._delta
        int_v2 = (self.L**2 + A**2 * c["Ig1"] + d**2 * c["Ih"]) / T
        int_a2 = (A**2 * c["Igp"] + d**2 * c["Ihp"]) / T**3
        return int_v2, int_a2

    def cost(self, m):
        """J = m/2 ∫ṡ² + β m/2 ∫s̈²  (= α m²/2 ∫s̈²); inf for β = inf unless s̈ ≡ 0."""
        int_v2, int_a2 = self.integrals()
        with np.errstate(invalid="ignore"):
            acc_term = np.where(int_a2 == 0, 0.0, self.beta * int_a2)
        return 0.5 * np.asarray(m, dtype=float) * (int_v2 + acc_term)

    # ---------------------------------------------------------------- extrema
    def _critical_t(self):
        """t [s] of the (at most one) interior stationary point of ṡ, or an endpoint.

        u' = A g' − δ h' ∝ −A sinh(γx)/N − δ cosh(γx)/sinh(γ/2) vanishes only at
        tanh(γx*) = r := (−δ/A)κ: tanh is monotone, so there is at most one.  Written as
        x* = (−δ/A)(κ/γ)·atanh(r)/r so that γ → 0 (x* = −δ/(6A)) needs no special case.
        Any fallback (nan → centre, |r| ≥ 1 → end) is still a point of [0, T], so using
        its speed as a candidate can never overstate the extremum."""
        with np.errstate(divide="ignore", invalid="ignore"):
            rho = -self._delta / self._A
            r = rho * self._c["kappa_over_gamma"] * self.gamma
            x = rho * self._c["kappa_over_gamma"] * _atanhc(r)
            x = np.where(np.abs(r) >= 1, np.sign(r) * 0.5, x)
        x = np.clip(np.nan_to_num(x, nan=0.0), -0.5, 0.5)
        return (x + 0.5) * self.T

    def _speed_candidates(self):
        if getattr(self, "_speeds", None) is None:     # peak_speed and min_speed share them
            self._speeds = self._compute_speed_candidates()
        return self._speeds

    def _compute_speed_candidates(self):
        zero = np.zeros_like(self.T)
        v_start = self.eval(zero, "v")[1]
        v_end = self.eval(self.T, "v")[1]
        v_crit = self.eval(self._critical_t(), "v")[1]
        return v_start, v_end, v_crit

    def peak_speed(self):
        """max ṡ over [0, T] [mm/s]: endpoints and the closed-form interior stationary point."""
        return np.maximum.reduce(self._speed_candidates())

    def min_speed(self):
        """min ṡ over [0, T] [mm/s]; < 0 means the law reverses (invalid print move)."""
        return np.minimum.reduce(self._speed_candidates())

    def end_accels(self):
        """(s̈(0), s̈(T)) [mm/s²] from the γ-coefficients alone (what eval(0 / T, "a")
        computes, to rounding): g'(0) = -g'(1) and h'(0) = h'(1) in closed form,
        small branch g'(0) = shc(γ/2) / (2n), h' = 2 cosh(γ/2) / shc(γ/2); large branch
        g'(0) = -γ (e^-γ - 1) / Dn, h' = γ (e^-γ + 1) / (1 - e^-γ)."""
        c = self._c
        small = c["small"]
        gp0 = hp = None
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            if small.any():
                gp0 = 0.5 * c["sh2"] / c["n"]
                hp = 2.0 * np.cosh(0.5 * c["gs"]) / c["sh2"]
            if not small.all():
                gl, em = c["gl"], c["em"]
                gp0_l, hp_l = -gl * em / c["Dn"], gl * (em + 2.0) / (-em)
                gp0 = gp0_l if gp0 is None else np.where(small, gp0, gp0_l)
                hp = hp_l if hp is None else np.where(small, hp, hp_l)
        T2 = self.T * self.T
        A, d = self._A, self._delta
        return (A * gp0 - d * hp) / T2, (-A * gp0 - d * hp) / T2

    def peak_accel(self):
        """max |s̈| over [0, T] [mm/s²], attained at an endpoint.

        Proof: (u')'' = γ² u'.  At an interior maximum of u' with u' > 0 we would need
        (u')'' ≤ 0 < γ²u'; symmetrically for a negative minimum; for γ = 0 u' is linear."""
        a0 = self.eval(np.zeros_like(self.T), "a")[2]
        a1 = self.eval(self.T, "a")[2]
        return np.maximum(np.abs(a0), np.abs(a1))


def interior_speed(L, T, beta, v0, v1):
    """The speed at the interior stationary point of the law (L, T, beta, v0, v1) [mm/s]:
    LineLaw(...)._speed_candidates()[2], bit for bit, at a fraction of the cost.

    Only what that one value needs is computed (the γ-coefficient κ/γ and the two shapes
    g, h at one τ), and each law only in its own γ branch; the expressions are the same
    as in _gamma_coeffs/_shapes, in the same order, so the rounding is the same.  The
    planner's bisection on β calls this 32 times per candidate: the end speeds do not
    depend on β (g = 0 and h = ∓1 exactly at the ends), so they are not recomputed."""
    L, T, beta, v0, v1 = check_params(L, T, beta, v0, v1)
    gamma = T / np.sqrt(beta)
    wbar = T * (v0 + v1) / 2
    delta = T * (v0 - v1) / 2
    A = L - wbar
    out = np.empty(gamma.shape)
    small = gamma < GAMMA_SWITCH
    for branch in (small, ~small):
        if not branch.any():
            continue
        g_, T_, wbar_, d_, A_ = gamma[branch], T[branch], wbar[branch], delta[branch], A[branch]
        if branch is small:
            n = _horner(_N_COEF, g_ * g_)
            sh2 = _shc(g_ / 2)
            kog = 2 * n / sh2
        else:
            E = np.exp(-g_)
            em = np.expm1(-g_)
            q = -em / g_
            Dn = 1.0 + E - 2.0 * q
            kog = Dn / (-em * g_)
        with np.errstate(divide="ignore", invalid="ignore"):
            rho = -d_ / A_
            r = rho * kog * g_
            x = rho * kog * _atanhc(r)
            x = np.where(np.abs(r) >= 1, np.sign(r) * 0.5, x)
        x = np.clip(np.nan_to_num(x, nan=0.0), -0.5, 0.5)
        tau = np.clip(((x + 0.5) * T_) / T_, 0.0, 1.0)
        x = tau - 0.5
        if branch is small:
            pa, pb = _shc(g_ * tau / 2), _shc(g_ * (1 - tau) / 2)
            shx = _shc(g_ * x)
            bub = tau * (1 - tau) * pa * pb
            g = bub / (2 * n)
            h = 2 * x * shx / sh2
        else:
            e0, e1 = np.expm1(-g_ * tau), np.expm1(-g_ * (1 - tau))
            g = e0 * e1 / Dn
            h = (e0 - e1) / em
        out[branch] = (wbar_ + A_ * g - d_ * h) / T_
    return out


class InteriorSpeeds:
    """interior_speed(L, T, beta, v0, v1) of fixed laws (L, T, v0, v1) at many beta (the
    planner's bisection): what does not depend on beta (w̄, δ, A, −δ/A and the checks of
    L, T, v0, v1) made once, the rest as interior_speed makes it, the same expressions in
    the same order, elementwise, so the same bits.  1-D arrays of one shape; the caller
    checks T finite > 0 and L, v0, v1 finite (ValueError here otherwise, as interior_speed),
    and each beta > 0 (not checked again at each call)."""

    def __init__(self, L, T, v0, v1):
        L, T, v0, v1 = (np.asarray(a, dtype=float) for a in (L, T, v0, v1))
        if not (np.all(T > 0) and np.all(np.isfinite(T))):
            raise ValueError("T must be finite and > 0")
        if not (np.all(np.isfinite(L)) and np.all(np.isfinite(v0)) and np.all(np.isfinite(v1))):
            raise ValueError("L, v0, v1 must be finite")
        self.T = T
        self.wbar = T * (v0 + v1) / 2
        self.delta = T * (v0 - v1) / 2
        self.A = L - self.wbar
        with np.errstate(divide="ignore", invalid="ignore"):
            self.rho = -self.delta / self.A
        self._split = None

    def take(self, rows):
        """The laws rows only (an index array): their constants taken, not made again."""
        out = object.__new__(InteriorSpeeds)
        for f in ("T", "wbar", "delta", "A", "rho"):
            setattr(out, f, getattr(self, f)[rows])
        out._split = None
        return out

    @staticmethod
    def concat(parts):
        """The laws of several InteriorSpeeds, one after the other (their constants joined)."""
        out = object.__new__(InteriorSpeeds)
        for f in ("T", "wbar", "delta", "A", "rho"):
            setattr(out, f, np.concatenate([getattr(p, f) for p in parts]))
        out._split = None
        return out

    def _branches(self, small):
        """{is_small: (its rows, and T, wbar, delta, A, rho taken at them)} of the split
        small (gamma < GAMMA_SWITCH, both branches taken): the last call's where its split
        was the same (the planner's bisection keeps one for its last ~20 of 33 steps on the
        rectilinear plate), else taken anew.  The same values either way."""
        last = self._split
        if last is not None and np.array_equal(last[0], small):
            return last[1]
        got = {}
        for is_small in (True, False):
            # the branch's elements by index: the same values as by the boolean mask,
            # without its search of the mask for each of six arrays
            branch = np.flatnonzero(small if is_small else ~small)
            got[is_small] = (branch, *(a.take(branch) for a in (self.T, self.wbar, self.delta, self.A, self.rho)))
        self._split = (small, got)
        return got

    def cubic(self):
        """self(inf) (every law's cubic, beta = inf), without the series and the sinh:
        gamma = T / sqrt(inf) is +0.0 exactly (T finite > 0), so __call__ takes its small
        branch for all, the series n (Horner on z2 = 0: each step c * 0 + c_j) is _N_COEF[0]
        exactly, and every _shc is of a zero (its np.where branch: 1.0 exactly), so
        kog = 2 n / 1.0, pa = pb = shx = sh2 = 1.0, and the products and quotients by them
        are exact (x * 1.0 and x / 1.0 are x, signed zeros, infinities and NaN included).
        What is left are __call__'s own operations, in its order: the same bits
        (tests/test_speed24_lineplan_candidates.py).  The planner's 650 k cubic laws on the
        rectilinear plate: ~4x faster than self(inf)."""
        T, wbar, delta, A, rho = self.T, self.wbar, self.delta, self.A, self.rho
        n2 = 2 * _N_COEF[0]                   # 2 * n, and kog = 2 * n / sh2
        with np.errstate(divide="ignore", invalid="ignore"):
            rk = rho * n2                     # rho_ * kog
            r = rk * 0.0                      # rho_ * kog * g_
            x = rk * _atanhc(r)
            x = np.where(np.abs(r) >= 1, np.sign(r) * 0.5, x)
        x = np.minimum(np.maximum(np.where(x != x, 0.0, x), -0.5), 0.5)
        tau = np.minimum(np.maximum(((x + 0.5) * T) / T, 0.0), 1.0)
        x = tau - 0.5
        g = tau * (1 - tau) / n2              # bub / (2 n), bub = tau (1 - tau) * 1.0 * 1.0
        h = 2 * x                             # 2 x shx / sh2
        return (wbar + A * g - delta * h) / T

    def __call__(self, beta):
        """interior_speed at beta."""
        T, wbar, delta, A, rho = self.T, self.wbar, self.delta, self.A, self.rho
        gamma = T / np.sqrt(beta)
        out = np.empty(gamma.shape)
        small = gamma < GAMMA_SWITCH
        ns = int(np.count_nonzero(small))
        split = self._branches(small) if 0 < ns < gamma.size else None
        for is_small in (True, False):
            cnt = ns if is_small else gamma.size - ns
            if cnt == 0:
                continue
            if cnt == gamma.size:                  # one branch: no gather/scatter
                g_, T_, wbar_, d_, A_, rho_ = gamma, T, wbar, delta, A, rho
            else:                                  # the branch's elements (taken, put back)
                branch, T_, wbar_, d_, A_, rho_ = split[is_small]
                g_ = gamma.take(branch)
            if is_small:
                n = _horner(_N_COEF, g_ * g_)
                sh2 = _shc(g_ / 2)
                kog = 2 * n / sh2
            else:
                E = np.exp(-g_)
                em = np.expm1(-g_)
                q = -em / g_
                Dn = 1.0 + E - 2.0 * q
                kog = Dn / (-em * g_)
            with np.errstate(divide="ignore", invalid="ignore"):
                r = rho_ * kog * g_
                x = rho_ * kog * _atanhc(r)
                x = np.where(np.abs(r) >= 1, np.sign(r) * 0.5, x)
            # np.clip(np.nan_to_num(x, nan=0.0), -0.5, 0.5) and np.clip(..., 0.0, 1.0): the
            # same values (±inf and ±max clip alike; the bounds are not zero where a signed
            # zero could tie: x + 0.5 >= +0.0, T_ > 0)
            x = np.minimum(np.maximum(np.where(x != x, 0.0, x), -0.5), 0.5)
            tau = np.minimum(np.maximum(((x + 0.5) * T_) / T_, 0.0), 1.0)
            x = tau - 0.5
            if is_small:
                pa, pb = _shc(g_ * tau / 2), _shc(g_ * (1 - tau) / 2)
                shx = _shc(g_ * x)
                bub = tau * (1 - tau) * pa * pb
                g = bub / (2 * n)
                h = 2 * x * shx / sh2
            else:
                e0, e1 = np.expm1(-g_ * tau), np.expm1(-g_ * (1 - tau))
                g = e0 * e1 / Dn
                h = (e0 - e1) / em
            v = (wbar_ + A_ * g - d_ * h) / T_
            if cnt == gamma.size:
                return v
            out[branch] = v
        return out


# The interior peak as a function of two numbers.  With rho = -delta/A the interior speed is
# (wbar + A P) / T, P = (g + rho h)(tau*) the largest of g + rho h over tau (InteriorSpeeds of
# L = 1, T = 1, v0 = -rho, v1 = rho is P itself): P depends on gamma and rho^2 only (g even, h
# odd about tau = 1/2).  P0(y) = P at rho = 0 (g at the centre) falls from 1.5 (the cubic) to 1
# (+ 2/gamma); P - P0 is ~rho^2/6 at small gamma and vanishes at large gamma.  The guess model
# M(y, rho^2) = P0 + rho^2 (C0 + rho^2 C1) is the quadratic in rho^2 through rho = 0, 0.5, 1,
# on a table of y = log gamma; it only starts the planner's search (which evaluates the true
# speeds): its root is off by ~7e-5 in y for most laws of the plates (the table's linear
# interpolation), 4.5e-4 at most.  Its nodes cost 3 speed evaluations each, once a process;
# the plates' searches take 4.0 a law with N = 512, 4.0 with 1024, 4.5 with 256.
PEAK_TABLE_N = 512
PEAK_TABLE_Y = (-6.0, 7.0)            # log gamma (0.0025 ... 1100; beyond, the guess is an end)
_peak_table = None


def _peak_table_rows():
    """(y, P0, C0, C1) on PEAK_TABLE_N nodes of PEAK_TABLE_Y, made on first use."""
    global _peak_table
    if _peak_table is None:
        y = np.linspace(*PEAK_TABLE_Y, PEAK_TABLE_N)
        one = np.ones(y.size)
        P0, Pa, Pb = (InteriorSpeeds(one, one, -rho * one, rho * one)(np.exp(-2.0 * y)) for rho in (0.0, 0.5, 1.0))
        C0 = (Pa - P0 - 0.0625 * (Pb - P0)) / 0.1875      # the quadratic through rho^2 = 0, 0.25, 1
        _peak_table = (y, P0, C0, (Pb - P0) - C0)
    return _peak_table


PEAK_GUESS_STEPS = 3    # Newton steps on the table model
PEAK_GUESS_MARGIN = 0.01      # how far the model's root may be out of P0's two (rounding)


def peak_root_guess(rho2, w):
    """(y, dM/dy at y): the root y = log gamma of the model M(y, rho2) = w (the interior
    peak P reaching w = (cap T - wbar) / A) and the model's slope there, elementwise; NaN
    inputs give some y in PEAK_TABLE_Y.  The root lies between P0's roots for w and for
    w - rho2 / 6 (P0 <= P <= P0 + rho2 / 6, both falling; most of the plates' laws are near
    the latter, at small gamma): Newton on the table's piecewise-linear model from the
    latter, each step kept within PEAK_GUESS_MARGIN of the two."""
    y_n, P0, C0, C1 = _peak_table_rows()
    h = y_n[1] - y_n[0]
    with np.errstate(invalid="ignore", divide="ignore"):
        a = np.interp(w, P0[::-1], y_n[::-1]) - PEAK_GUESS_MARGIN
        y = np.interp(w - rho2 / 6.0, P0[::-1], y_n[::-1])
        b = y + PEAK_GUESS_MARGIN
        for _ in range(PEAK_GUESS_STEPS):
            y = np.where(y == y, y, y_n[0])              # (a NaN w or rho2: any point will do)
            u = (y - y_n[0]) / h
            j = np.minimum(u.astype(np.intp), y_n.size - 2)
            M0 = P0[j] + rho2 * (C0[j] + rho2 * C1[j])
            dM = P0[j + 1] + rho2 * (C0[j + 1] + rho2 * C1[j + 1]) - M0
            y = np.clip(y - (M0 + (u - j) * dM - w) * h / dM, np.maximum(a, y_n[0]), np.minimum(b, y_n[-1]))
    return np.where(y == y, y, y_n[0]), dM / h


def cubic_figures(L, T, v0, v1):
    """(peak_accel(), *integrals()) of the laws LineLaw(L, T, inf, v0, v1) (1-D arrays, T
    finite > 0), bit for bit, without the law: gamma = T / inf is +0.0, so in the series
    branch n, m and S1 are their first coefficients exactly (Horner at z2 = 0: each step
    c * 0 + c_j), every shc is of a zero (np.where's 1.0) and cosh(±0) is 1.0, so
    Ig1 = m / (2 n n), Igp = S1 / (2 n n), Ih = 2 S1, Ihp = 4, and at the ends g' = ±0.5 / n,
    h' = 2 (the products and quotients by 1.0 are exact).  What is left are eval's and
    integrals' own operations, in their order (tests/test_speed26_linec_cubic.py).  The
    planner's ~610 k cubic candidates on the rectilinear plate: their LineLaw, its two
    end evaluations and its integrals were most of _live_tables."""
    L, T, v0, v1 = (np.asarray(a, dtype=float) for a in (L, T, v0, v1))
    n, m, s1 = _N_COEF[0], _M_COEF[0], _S1_COEF[0]
    wbar = T * (v0 + v1) / 2
    d = T * (v0 - v1) / 2
    A = L - wbar
    gp0 = 0.5 * 1.0 / n                 # -x shx / n at x = -0.5
    gp1 = -0.5 * 1.0 / n                # at x = 0.5
    hp = 2 * 1.0 / 1.0                  # 2 cosh(gs x) / sh2
    a0 = (A * gp0 - d * hp) / T**2
    a1 = (A * gp1 - d * hp) / T**2
    peak = np.maximum(np.abs(a0), np.abs(a1))
    Ig1, Igp = m / (2 * n * n), s1 / (2 * n * n)
    Ih, Ihp = 2 * s1 / 1.0 ** 2, 2 * (1.0 + 1) / 1.0 ** 2
    int_v2 = (L**2 + A**2 * Ig1 + d**2 * Ih) / T
    int_a2 = (A**2 * Igp + d**2 * Ihp) / T**3
    return peak, int_v2, int_a2


def end_speeds(L, T, v0, v1):
    """(ṡ(0), ṡ(T)) of any law on (L, T, v0, v1), as LineLaw.eval computes them: g = 0 and
    h = −1, +1 exactly at τ = 0, 1 in both branches, so they do not depend on β."""
    L, T, v0, v1 = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (L, T, v0, v1)))
    wbar = T * (v0 + v1) / 2
    delta = T * (v0 - v1) / 2
    A = L - wbar
    return (wbar + A * 0.0 - delta * -1.0) / T, (wbar + A * 0.0 - delta * 1.0) / T


def line_law(L, T, beta, v0=0.0, v1=0.0) -> LineLaw:
    """Optimal law for stroke L [mm] in T [s] with β = α m [s²] (np.inf ⇒ cubic Hermite) and
    end speeds v0, v1 [mm/s]; all arguments broadcast."""
    return LineLaw(L, T, beta, v0, v1)


def time_of_distance(law: LineLaw, s_targets, max_iter: int = 200, prim=None):
    """t [s] with s(t) = s_targets [mm] (broadcast with the law), for monotone laws.

    Safeguarded Newton: a bracket [lo, hi] with s(lo) ≤ target ≤ s(hi) is kept; a Newton step
    leaving the bracket (or with ṡ ≤ 0) is replaced by bisection, so convergence is guaranteed
    (≤ ~60 bisections to machine resolution) and quadratic near simple roots.  Targets outside
    [0, L] are clamped.  If min_speed() < 0 the result is *a* root, not necessarily the first.
    prim: the law's primitives (LineLaw.eval's)."""
    T = law.T
    lo_s, hi_s = np.minimum(0.0, law.L), np.maximum(0.0, law.L)
    target = np.clip(np.asarray(s_targets, dtype=float), lo_s, hi_s)
    shape = np.broadcast_shapes(target.shape, T.shape)
    target = np.broadcast_to(target, shape)
    sgn = np.where(law.L < 0, -1.0, 1.0)           # make f increasing for L < 0 too
    lo = np.zeros(shape)
    hi = np.broadcast_to(T, shape).copy()
    with np.errstate(divide="ignore", invalid="ignore"):
        t = lo + (hi - lo) * np.where(law.L != 0, target / law.L, 0.5)
    scale = np.maximum(np.abs(law.L), 1e-300)
    if len(shape) == 1 and law.L.shape == shape:
        return _tod_rows(law, target, sgn, lo, hi, t, scale, max_iter, prim)
    for _ in range(max_iter):
        t, lo, hi, done = _tod_step(law, t, target, sgn, lo, hi, scale, T, prim)
        if done is None:
            break
    return t


def _tod_step(law, t, target, sgn, lo, hi, scale, T, prim=None):
    """One safeguarded Newton step of time_of_distance: the bracket [lo, hi] shrunk to t,
    then Newton where it stays inside, else bisection.  done is None when every element
    has converged (t, lo, hi as they were then)."""
    s, v, _a = law.eval(t, "sv", prim)
    f = sgn * (s - target)
    lo = np.where(f <= 0, t, lo)
    hi = np.where(f >= 0, t, hi)
    done = (np.abs(f) <= 4 * np.finfo(float).eps * scale) | (hi - lo <= 4 * np.finfo(float).eps * T)
    if np.all(done):
        return t, lo, hi, None
    with np.errstate(divide="ignore", invalid="ignore"):
        t_newton = t - f / (sgn * v)
    ok = (sgn * v > 0) & (t_newton > lo) & (t_newton < hi)
    return np.where(done, t, np.where(ok, t_newton, 0.5 * (lo + hi))), lo, hi, done


def _tod_rows(law, target, sgn, lo, hi, t, scale, max_iter, prim=None):
    """time_of_distance's iteration for 1-D laws, one target each, on the elements not done
    only: a done element's t no longer moves (its f is unchanged and its bracket only
    shrinks, so it stays done), and every step is elementwise, so each t is the same."""
    T = law.T
    out = t.copy()
    idx = np.arange(t.size)
    for _ in range(max_iter):
        t, lo, hi, done = _tod_step(law, t, target, sgn, lo, hi, scale, T, prim)
        if done is None:
            break
        out[idx] = t
        if done.any():                     # the rest go on alone
            keep = np.flatnonzero(~done)
            idx, t, lo, hi = idx[keep], t[keep], lo[keep], hi[keep]
            target, sgn, scale, T = target[keep], sgn[keep], scale[keep], T[keep]
            law = law.take(keep)
    return out
