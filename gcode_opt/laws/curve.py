"""Optimal law of motion along any smooth planar curve given its curvature κ(s) (MATH.md,
arc-length form), plus curvature estimation from slicer polylines.

With x = s/S, τ = t/T, k(x) = S κ(Sx) (dimensionless curvature), γ = T/√β:

    x'''' = γ² x'' + 6 k² x'² x'' + 3 k k_x x'⁴

Since (2k²x'³)' = 4 k k_x x'⁴ + 6 k² x'² x'', the speed w = x' obeys

    w'' = γ² w + 2 k(x)² w³ + C − ∫₀^τ k k_x(x) w⁴ dτ',   x = ∫₀^τ w,
    w(0) = u0, w(1) = u1, ∫₀¹ w = 1,

a second-order collocation problem (Chebyshev, Newton, N doubled until the coefficient tail
is small) that keeps the conditioning of D² rather than D⁴.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
from numpy.polynomial import chebyshev as C

from ..records import record
from .circle import _cheb_setup, _clenshaw, _gauss
from .spline import NotAKnotCubic

_N_LADDER = (32, 48, 64, 96, 128, 192, 256, 384, 512)
_TAIL_TOL = 1e-11

_CUMINT_CACHE: dict[int, np.ndarray] = {}


def _cumint_matrix(n: int) -> np.ndarray:
    """Q with (Q f)(τ_i) = ∫₀^{τ_i} f, spectrally exact on the Chebyshev nodes."""
    if n not in _CUMINT_CACHE:
        cs = _cheb_setup(n)
        coef_int = C.chebint(cs["to_coef"], lbnd=-1.0, scl=0.5, axis=0)   # (n+2, n+1)
        _CUMINT_CACHE[n] = C.chebvander(cs["x"], n + 1) @ coef_int
    return _CUMINT_CACHE[n]


def _newton_curve(n, k_fun, kx_fun, g1_fun, gam2, u0, u1, theta, w_start, max_iter=80):
    """Collocation Newton at curvature scale θ (continuation parameter); returns (w, C, ok)."""
    cs = _cheb_setup(n)
    d2, q = cs["d2"], cs["q"]
    qm = _cumint_matrix(n)
    w = w_start.copy()
    w[0], w[-1] = u0, u1
    cc = 0.0
    inner = slice(1, n)
    scale = max(1.0, abs(u0), abs(u1))

    def parts(w):
        x = qm @ w
        k, kx = theta * k_fun(x), theta * kx_fun(x)
        g = k * kx
        return x, k, kx, g

    def residual(w, cc):
        x, k, _, g = parts(w)
        r = d2 @ w - gam2 * w - 2.0 * k * k * w ** 3 - cc + qm @ (g * w ** 4)
        return np.concatenate([r[inner], [q @ w - 1.0]])

    res = residual(w, cc)
    rn = np.abs(res).max()
    for _ in range(max_iter):
        x, k, kx, g = parts(w)
        g1 = theta * theta * g1_fun(x)              # d(k k_x)/dx
        jac_w = (d2 - np.diag(gam2 + 6.0 * k * k * w * w)
                 - (4.0 * k * kx * w ** 3)[:, None] * qm
                 + qm @ ((g1 * w ** 4)[:, None] * qm + np.diag(4.0 * g * w ** 3)))
        jac = np.zeros((n, n))
        jac[: n - 1, : n - 1] = jac_w[inner, inner]
        jac[: n - 1, n - 1] = -1.0
        jac[n - 1, : n - 1] = q[inner]
        step = np.linalg.solve(jac, -res)
        lam = 1.0
        for _ in range(40):                          # backtracking on the residual
            wt = w.copy()
            wt[inner] += lam * step[: n - 1]
            ct = cc + lam * step[n - 1]
            rt = residual(wt, ct)
            rnt = np.abs(rt).max()
            if np.isfinite(rnt) and rnt <= rn * (1 - 1e-4 * lam):
                break
            if lam * np.abs(step[: n - 1]).max() <= 1e-14 * scale:
                break
            lam /= 2.0
        w, cc, res, rn = wt, ct, rt, rnt
        if lam == 1.0 and np.abs(step[: n - 1]).max() <= 1e-13 * scale:
            return w, cc, True
    return w, cc, False


@record
class CurveLaw:
    """Optimal law s(t) on a curve of length S (mm) in time T (s)."""
    S: float
    T: float
    beta: float
    kappa: Callable
    dkappa: Callable
    coef: np.ndarray        # Chebyshev coefficients of w = x'(τ) on τ ∈ [0, 1]
    cc: float
    n: int

    def _eval_tau(self, tau):
        x = 2.0 * np.asarray(tau, float) - 1.0
        c = self.coef[None, :]
        w = _clenshaw(c, x[None, :])[0]
        w1 = _clenshaw(C.chebder(c, axis=1, scl=2.0), x[None, :])[0]
        xs = _clenshaw(C.chebint(c, axis=1, lbnd=-1.0, scl=0.5), x[None, :])[0]
        w2 = _clenshaw(C.chebder(c, m=2, axis=1, scl=2.0), x[None, :])[0]
        return xs, w, w1, w2

    def eval(self, t_t):
        """(s mm, ṡ mm/s, s̈ mm/s²) at times t (s)."""
        t = np.asarray(t_t, float)
        xs, w, w1, _ = self._eval_tau(np.atleast_1d(t).ravel() / self.T)
        out = (self.S * xs, self.S * w / self.T, self.S * w1 / self.T ** 2)
        return tuple(o.reshape(t.shape) for o in out)

    def hamiltonian(self, t_t):
        """H = ½ṡ² + β(½s̈² − ṡ s⃛ + (3/2)κ²ṡ⁴); constant along the optimal law."""
        t = np.atleast_1d(np.asarray(t_t, float))
        xs, w, w1, w2 = self._eval_tau(t / self.T)
        s, sd, sdd, sddd = (self.S * xs, self.S * w / self.T, self.S * w1 / self.T ** 2,
                            self.S * w2 / self.T ** 3)
        kap = self.kappa(s)
        return 0.5 * sd ** 2 + self.beta * (0.5 * sdd ** 2 - sd * sddd + 1.5 * kap ** 2 * sd ** 4)

    def integrals(self):
        """(∫ṡ² dt, ∫|a|² dt) with |a|² = s̈² + κ²ṡ⁴."""
        gx, gw = _gauss(2 * self.n + 8)
        xs, w, w1, _ = self._eval_tau(gx)
        s, sd, sdd = self.S * xs, self.S * w / self.T, self.S * w1 / self.T ** 2
        kap = self.kappa(s)
        return (float(self.T * gw @ sd ** 2),
                float(self.T * gw @ (sdd ** 2 + kap ** 2 * sd ** 4)))

    def cost(self, m=1.0):
        iv, ia = self.integrals()
        return 0.5 * m * (iv + self.beta * ia)

    def _samples(self):
        tau = np.concatenate([np.linspace(0, 1, 4 * self.n + 1),
                              0.5 * (1 - np.cos(np.linspace(0, np.pi, 4 * self.n + 1)))])
        return np.sort(tau) * self.T

    def peak_speed(self):
        return float(np.abs(self.eval(self._samples())[1]).max())

    def min_speed(self):
        return float(self.eval(self._samples())[1].min())

    def peak_accel(self):
        t = self._samples()
        s, sd, sdd = self.eval(t)
        return float(np.sqrt(sdd ** 2 + (self.kappa(s) * sd ** 2) ** 2).max())


def _fd(f, h):
    return lambda s: (f(s + h) - f(s - h)) / (2.0 * h)


def solve_curve(kappa, dkappa_ds, S, T, beta, v0=0.0, v1=0.0, d2kappa_ds2=None, tail_tol=_TAIL_TOL) -> CurveLaw:
    """Optimal law along a curve of length S (mm) with curvature kappa(s) (1/mm, vectorised
    callable or spline on [0, S]) and dκ/ds; duration T (s), β = αm (s²), end speeds v0, v1
    (mm/s).  d2kappa_ds2 (optional) only speeds up Newton; finite differences otherwise.
    tail_tol: the Chebyshev tail (last three coefficients over the largest) a law is
    accepted at, climbing the N ladder until it is met."""
    gam2 = T * T / beta
    u0, u1 = v0 * T / S, v1 * T / S
    # dimensionless curvature k(x) = S κ(Sx) and derivatives wrt x (clip: collocation may
    # probe x slightly outside [0, 1] during Newton)
    k_fun = lambda x: S * kappa(np.clip(x, 0.0, 1.0) * S)
    kx_fun = lambda x: S * S * dkappa_ds(np.clip(x, 0.0, 1.0) * S)
    if d2kappa_ds2 is None:
        d2kappa_ds2 = _fd(dkappa_ds, 1e-5 * S)
    g1_fun = lambda x: (kx_fun(x) ** 2
                        + k_fun(x) * S ** 3 * d2kappa_ds2(np.clip(x, 0.0, 1.0) * S))

    probe = np.linspace(0, 1, 257)
    k_max = np.abs(k_fun(probe)).max()
    w_max = max(1.0, abs(u0), abs(u1))
    lam = np.sqrt(gam2 + 6.0 * (k_max * w_max) ** 2)
    need = 12.0 + 1.6 * np.sqrt(28.0 * max(lam, 1.0))
    level = int(np.searchsorted(_N_LADDER, need).clip(0, len(_N_LADDER) - 1))
    coef_prev = None
    while True:
        n = _N_LADDER[level]
        cs = _cheb_setup(n)
        if coef_prev is not None:
            w0 = _clenshaw(coef_prev[None, :], cs["x"][None, :])[0]
        else:
            w0 = np.ones(n + 1)
        w, cc, ok = _newton_curve(n, k_fun, kx_fun, g1_fun, gam2, u0, u1, 1.0, w0)
        if not ok:                                   # continuation in the curvature
            w = w0
            for theta in np.linspace(0.0, 1.0, 11):
                w, cc, ok = _newton_curve(n, k_fun, kx_fun, g1_fun, gam2, u0, u1, theta, w)
        coef = cs["to_coef"] @ w
        tail = np.abs(coef[-3:]).max() / np.abs(coef).max()
        if ok and tail <= tail_tol:
            return CurveLaw(S, T, beta, kappa, dkappa_ds, coef, cc, n)
        if level == len(_N_LADDER) - 1:
            raise RuntimeError(f"curve law did not converge (N={n}, tail={tail:.1e}, ok={ok})")
        coef_prev = coef if ok else None
        level += 1


# ---------------------------------------------------------------------------------------------
# Curvature from polylines
# ---------------------------------------------------------------------------------------------

def _turning_angles(points):
    seg = np.diff(points, axis=0)
    length_d = np.hypot(seg[:, 0], seg[:, 1])
    heading = np.arctan2(seg[:, 1], seg[:, 0])
    turn = np.angle(np.exp(1j * np.diff(heading)))       # signed, in (-π, π]
    return length_d, turn


def split_at_corners(points, max_turn_deg=30.0):
    """Index ranges (i0, i1) of smooth sub-curves: points[i0:i1+1] has no interior vertex
    turning more than max_turn_deg.  Neighbouring ranges share their corner vertex."""
    points = np.asarray(points, float)
    if len(points) < 3:
        return [(0, len(points) - 1)]
    _, turn = _turning_angles(points)
    corners = np.nonzero(np.abs(turn) > np.radians(max_turn_deg))[0] + 1
    bounds = np.concatenate([[0], corners, [len(points) - 1]])
    return [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:]) if b > a]


class PolylineCurvature:
    """Smoothed signed curvature of a polyline as a function of arc length s (mm).  The
    cubic spline through the vertex values is built on first use: curves.py reads only
    the vertex values (building 2·10⁴ scipy splines took ~4 s on a gyroid plate)."""
    __slots__ = ("s_d", "kappa_v", "_spline")

    def __init__(self, s_d, kappa_v):
        _check_spline_input(s_d, kappa_v)
        self.s_d = s_d                 # arc length at the vertices
        self.kappa_v = kappa_v         # smoothed curvature at the vertices (1/mm)
        self._spline = None

    @property
    def spline(self) -> NotAKnotCubic:
        # (the default run never calls this; scipy's CubicSpline, which this one matches,
        # took ~45 MB of `--report`'s resident set with scipy.interpolate's import)
        if self._spline is None:
            self._spline = NotAKnotCubic(self.s_d, self.kappa_v)
        return self._spline

    @property
    def length_d(self):
        return float(self.s_d[-1])

    def kappa(self, s):
        return self.spline(np.clip(s, 0.0, self.length_d))

    def dkappa_ds(self, s):
        return self.spline(np.clip(s, 0.0, self.length_d), 1)

    def d2kappa_ds2(self, s):
        return self.spline(np.clip(s, 0.0, self.length_d), 2)


def _check_spline_input(x, y):
    """Raise the ValueError scipy's CubicSpline(x, y) would (its input checks; the spline
    was scipy's), when the curvature is made, not when its spline is built lazily: a bad
    stroke still fails where it did (fault isolation)."""
    if x.size < 2:
        raise ValueError("`x` must contain at least 2 elements.")
    if not (np.isfinite(x).all() and np.isfinite(y).all()):
        raise ValueError("`x` and `y` must contain only finite values.")
    if not (np.diff(x) > 0).all():
        raise ValueError("`x` must be strictly increasing sequence.")


def curvature_from_polyline(points, smooth_d=None) -> PolylineCurvature:
    """Robust κ(s) from a chain of short segments (slicer output, coordinates rounded).

    Each vertex turning angle θ_j is spread over its half-segments (κ ≈ θ / local length);
    the turning and the lengths are then smoothed with a Gaussian kernel of width smooth_d
    (mm; default 3 × median segment length, at least 0.5 mm) so that rounding noise of the
    coordinates (±0.0005 mm on 0.3 mm segments is ±0.2° per vertex) does not make spikes:
    κ(s_j) = Σ θ_i K(s_i − s_j) / Σ ℓ_i K(s_i − s_j).  Near the ends the kernel is one-sided
    (a weighted mean of the nearest interior values) — split at corners first."""
    points = np.asarray(points, float)
    length_d, turn = _turning_angles(points)
    keep = length_d > 1e-9                       # drop duplicate points
    if not keep.all():
        points = np.concatenate([points[:1], points[1:][keep]])
        length_d, turn = _turning_angles(points)
    s_d = np.concatenate([[0.0], np.cumsum(length_d)])
    if len(points) < 3:
        z = np.zeros(len(points))
        return PolylineCurvature(s_d, z)
    if smooth_d is None:
        smooth_d = max(3.0 * float(np.median(length_d)), 0.5)
    s_v = s_d[1:-1]                              # interior vertices carry the turning
    ell = 0.5 * (length_d[:-1] + length_d[1:])   # length each vertex's turning is spread on

    def smooth(th, at_d):
        """Σ θ_i K / Σ ℓ_i K at the positions at_d (chunked: O(n · window) memory).

        The kernel is normalised in log space per row (exponents shifted by the nearest
        vertex's): at an end vertex that lies many smooth_d from every interior vertex
        (a 28 mm line ending a chain of 0.5 mm connectors) the raw weights all underflow
        to 0 and the ratio would be 0/0; shifted, the nearest vertex keeps weight 1, so
        the value falls back to the nearest vertices' curvature."""
        out = np.empty(at_d.size)
        reach = 5.0 * smooth_d                   # kernel truncated at e^-12.5 of the nearest
        n_v = s_v.size
        for a in range(0, at_d.size, 512):
            rows = at_d[a:a + 512]
            lo, hi = np.searchsorted(s_v, [rows[0] - reach, rows[-1] + reach])
            # the window always holds each row's nearest vertices, however far they are
            lo = min(lo, max(int(np.searchsorted(s_v, rows[0])) - 1, 0))
            hi = max(hi, min(int(np.searchsorted(s_v, rows[-1])) + 1, n_v))
            z2 = ((rows[:, None] - s_v[None, lo:hi]) / smooth_d) ** 2
            kern = np.exp(-0.5 * (z2 - z2.min(axis=1, keepdims=True)))
            out[a:a + 512] = (kern @ th[lo:hi]) / (kern @ ell[lo:hi])
        return out

    kappa_v = smooth(turn, s_d)
    return PolylineCurvature(s_d, kappa_v)
