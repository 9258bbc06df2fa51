"""Optimal law of motion on a circular arc (MATH.md, circle case).

Minimises J = (m/2)∫|v|²dt + (αm²/2)∫|a|²dt along an arc of radius R swept through Φ in time T.
With the angle φ(t), β = αm and τ = t/T the Euler–Lagrange equation φ'''' = (1/β + 6φ̇²)φ̈ becomes

    φ'''' = (γ² + 6φ'²) φ''          (' = d/dτ, γ = T/√β)

so the law depends only on (Φ, γ, u0 = ω0·T, u1 = ω1·T); R cancels.  Since 6φ'²φ'' = (2φ'³)',
the angular velocity w = φ' obeys the autonomous second-order problem

    w'' = γ² w + 2 w³ + C,   w(0) = u0,  w(1) = u1,  ∫₀¹ w dτ = Φ        (C unknown)

which is what we solve.  Two regimes, both vectorised over a batch of arcs:

* "layers": when the boundary layers (rate λ = √(γ² + 6 w_c²), w_c the cruise value) cannot
  see each other (tail e^{-λ} below 1e-14), each end is the exact half-line solution of
  w'' = F'(w), which is elementary (a sinh in 1/(w - w_c)); only the scalar w_c is solved for.
* "cheb": otherwise Chebyshev collocation of w, N chosen from λ and checked a posteriori
  on the decay of the Chebyshev coefficients (N raised if needed).  The collocation
  equations are solved by a preconditioned fixed-point iteration (the Newton step with the
  Jacobian's diagonal at its mid-range value, diagonal in the eigenbasis of the second-
  derivative block: small matrix products, no LU), Newton where that contracts slowly.

The problem is convex in φ(·) (φ̇², φ̇⁴, φ̈² are convex), so the solution is unique.
"""
from __future__ import annotations

import os

import numpy as np

from ..probe_rng import ProbeRng
from ..distinct import distinct
from .. import native
from ..blas import blas_one_thread
from ..records import record
from .quad_tables import GAUSS

# The compiled elementwise steps of _precond_cheb (and curves._parts_block's kernel):
# _curvecore.c, module _gcode_opt_curvecore; optional, the same bits as the numpy code
# (tests/test_speed20_curves_core.py)
CORE_MOD, CORE_WHY = native.load("_gcode_opt_curvecore",
                                 os.path.join(os.path.dirname(os.path.abspath(__file__)), "_curvecore.c"),
                                 "curve core")
CORE = "c" if CORE_MOD is not None else "python"

# ---------------------------------------------------------------------------------------------
# Chebyshev machinery on τ ∈ [0, 1] (nodes τ_j = (1 - cos(πj/N))/2, so τ_0 = 0, τ_N = 1)
# ---------------------------------------------------------------------------------------------

_CHEB_CACHE: dict[int, dict] = {}
_TAIL_TOL = 1e-11          # accepted |last Chebyshev coefficients| / scale of w
_LAYER_TAIL_TOL = 1e-14    # accepted neglected layer interaction / scale of w
_N_LADDER = (16, 20, 24, 32, 48, 64, 96, 128, 192, 256, 384, 512)


def _cheb_setup(n: int) -> dict:
    """Differentiation matrices, Clenshaw–Curtis weights, value->coefficient map (cached)."""
    if n in _CHEB_CACHE:
        return _CHEB_CACHE[n]
    j = np.arange(n + 1)
    x = -np.cos(np.pi * j / n)                  # ascending on [-1, 1]
    tau = (1.0 + x) / 2.0
    c = np.ones(n + 1)
    c[0] = c[-1] = 2.0
    c *= (-1.0) ** j
    dx = x[:, None] - x[None, :]
    d = np.outer(c, 1.0 / c) / (dx + np.eye(n + 1))
    d -= np.diag(d.sum(axis=1))                 # negative-sum trick for accuracy
    d_tau = 2.0 * d                             # dτ = dx/2
    d2_tau = d_tau @ d_tau
    # Clenshaw–Curtis weights on [-1, 1] (Trefethen, Spectral Methods in MATLAB, clencurt)
    theta = np.pi * j / n
    w = np.zeros(n + 1)
    v = np.ones(n - 1)
    if n % 2 == 0:
        w[0] = w[n] = 1.0 / (n * n - 1)
        for k in range(1, n // 2):
            v -= 2.0 * np.cos(2 * k * theta[1:-1]) / (4 * k * k - 1)
        v -= np.cos(n * theta[1:-1]) / (n * n - 1)
    else:
        w[0] = w[n] = 1.0 / (n * n)
        for k in range(1, (n - 1) // 2 + 1):
            v -= 2.0 * np.cos(2 * k * theta[1:-1]) / (4 * k * k - 1)
    w[1:-1] = 2.0 * v / n
    vand = np.polynomial.chebyshev.chebvander(x, n)
    out = dict(x=x, tau=tau, d=d_tau, d2=d2_tau, q=w / 2.0, to_coef=np.linalg.inv(vand))
    _CHEB_CACHE[n] = out
    return out


def _clenshaw(coef: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Σ_k coef[b, k] T_k(x[b, :]) for every arc b (coef (B, K), x (B, M))."""
    x2 = 2.0 * x
    b1 = np.zeros_like(x)
    b2 = np.zeros_like(x)
    for k in range(coef.shape[1] - 1, 0, -1):
        t = x2 * b1                   # same operations, in the same order, as 2x·b1 − b2 + c
        t -= b2
        t += coef[:, k:k + 1]
        b1, b2 = t, b1
    return x * b1 - b2 + coef[:, 0:1]


_CLENSHAW_BLOCK = 32768     # elements (rows x points) per Clenshaw block


def _clenshaw_rows(coef: np.ndarray, x: np.ndarray) -> np.ndarray:
    """_clenshaw with each arc's zero padding dropped: arcs are grouped by their own number
    of coefficients (a few N of the ladder), so an arc solved on 24 nodes no longer pays
    for the batch's largest N.  Trailing zero coefficients leave the recurrence at exactly
    0, so the result is the same, bit for bit."""
    nz = coef != 0
    length = np.where(nz.any(axis=1), coef.shape[1] - np.argmax(nz[:, ::-1], axis=1), 1)
    out = np.empty(x.shape)
    for K in distinct(length):
        r = np.flatnonzero(length == K)
        # blocks of rows whose recurrence arrays stay in cache (same numbers, ~1.3x faster)
        step = max(1, _CLENSHAW_BLOCK // max(x.shape[1], 1))
        for a in range(0, r.size, step):
            rb = r[a:a + step]
            out[rb] = _clenshaw(coef[rb, :K], x[rb])
    return out


_GEMM_ROWS = 32            # series evaluated by BLAS calls of exactly this many rows
_GEMM_OK: list = []        # [bool]: this BLAS gives a row the same bits wherever it sits in such a call


def _gemm_rows_invariant():
    """Whether a (_GEMM_ROWS, K) @ (K, M) product gives each row the same bits whatever its
    position and the other rows (true of OpenBLAS, whose small-matrix kernels accumulate
    each element in order; checked once, on this machine's BLAS)."""
    if not _GEMM_OK:
        rng = ProbeRng(0)
        same = True
        for k, m in ((1, 3), (5, 40), (21, 129), (33, 184), (65, 97)):
            v = rng.uniform(-1.0, 1.0, (k, m))     # (generic numbers: uniform draws cost the least)
            a = rng.uniform(-1.0, 1.0, (1, _GEMM_ROWS, k))
            ref = (a @ v)[0, 0]                     # the stacked form _series_values uses
            # the row at every place 1 .. 2 _GEMM_ROWS - 1 of a call of three blocks, other
            # rows between: the odd places in one call, the even ones in another (a call a
            # place was ~15 ms, at the start of every command that plans a curve)
            for places in (np.arange(1, 2 * _GEMM_ROWS, 2), np.arange(2, 2 * _GEMM_ROWS, 2)):
                b = rng.uniform(-1.0, 1.0, (3, _GEMM_ROWS, k))
                b.reshape(-1, k)[places] = a[0, 0]
                same &= bool(np.array_equal((b @ v).reshape(-1, m)[places], np.broadcast_to(ref, (places.size, m))))
        _GEMM_OK.append(same)
    return _GEMM_OK[0]


def _rows_matmul(a, b, out=None):
    """a (B, K) @ b (K, M) by BLAS calls of _GEMM_ROWS rows each (zero rows pad the last),
    so each row's bits do not depend on the other rows: a law solved in a batch is the
    one solved alone, bit for bit.  Plain a @ b where this BLAS does not allow it.
    out: a C-contiguous (B, M) float64 array to hold the product (returned), or None.
    The whole blocks are multiplied in place in a C-contiguous a (views: the same calls
    of the same blocks) and written straight into the result; only the last, partial
    block is padded (not a zero-filled copy of all of a, ~29 MB on the gyroid plate)."""
    if not _gemm_rows_invariant():
        return _into(out, a @ b)
    nb, g = a.shape[0], _GEMM_ROWS
    full = nb - nb % g
    if not a.flags.c_contiguous:
        return _into(out, _rows_matmul_padded(a, b))
    if out is not None and not out.flags.c_contiguous:     # (the same BLAS calls into a new array)
        return _into(out, _rows_matmul(a, b))
    if out is None:
        out = np.empty((nb, b.shape[1]))
    if full:
        np.matmul(a[:full].reshape(full // g, g, -1), b, out=out[:full].reshape(full // g, g, -1))
    if full < nb:
        pad = np.zeros((1, g, a.shape[1]))
        pad[0, :nb - full] = a[full:]
        out[full:] = (pad @ b)[0, :nb - full]
    return out


def _rows_matmul_padded(a, b):
    """_rows_matmul(a, b) as one stacked product of a zero-padded copy of a (the code
    before the blocks; a not C-contiguous, and the tests' reference)."""
    nb = a.shape[0]
    nblk = -(-nb // _GEMM_ROWS)
    if nblk * _GEMM_ROWS != nb:
        pad = np.zeros((nblk * _GEMM_ROWS, a.shape[1]))
        pad[:nb] = a
        a = pad
    return (a.reshape(nblk, _GEMM_ROWS, -1) @ b).reshape(nblk * _GEMM_ROWS, -1)[:nb]


def _into(out, x):
    """x, or x copied into out (not None)."""
    if out is None:
        return x
    out[...] = x
    return out


def _row_lengths(coef):
    """Each row's own number of coefficients (trailing zeros dropped; at least 1); a pass
    of the curve core over the rows where it is built (one early-ending scan a row, not
    four numpy passes over the whole table: the same numbers), reading a strided table
    (_cheb_der_int's transposes) where it lies rather than a row-major copy of it."""
    core = CORE_MOD
    if core is not None and coef.ndim == 2 and coef.dtype == np.float64 and coef.shape[1] > 0:
        out = np.empty(coef.shape[0], np.int64)
        core.row_lengths(coef, coef.shape[0], coef.shape[1], out)
        return out
    nz = coef != 0
    return np.where(nz.any(axis=1), coef.shape[1] - np.argmax(nz[:, ::-1], axis=1), 1)


def _one_grid(x):
    """(x == x[:1]).all() of a (B, M) array, B >= 1, as each row == the row before it (==
    is transitive, NaN equal to nothing either way; one row: x[1:] is empty, and a lone
    row goes as one grid both ways): two rows alike, not a row broadcast against all (numpy 2
    copies a broadcast operand into its buffers row by row).  A row broadcast to all
    (_one_row): one grid, not compared (NaN aside: its rows are the same doubles, which
    _series_values evaluates as the row's grid all the same)."""
    if x.shape[0] < 2 or _one_row(x):
        return True
    return bool((x[1:] == x[:-1]).all())


def _one_row(x):
    """Whether x is a (B, M) array of one row broadcast to all (its rows' stride 0)."""
    return type(x) is np.ndarray and x.ndim == 2 and x.shape[0] > 1 and x.strides[0] == 0


def _series_values(coefs, x):
    """[_clenshaw_rows(c, x) for c in coefs], Chebyshev series c (B, K_c) at x (B, M).
    Rows of x that are one grid (the usual case: a batch's quadrature or uniform grid is
    the same for every arc whose layers are wider than the arc) are evaluated as matrix
    products with the Chebyshev values at that grid (BLAS, ~5x faster than the
    recurrence; the same sums in another order, ~1e-16 relative).  Each row goes through
    BLAS calls of a fixed shape (_GEMM_ROWS rows of its own number of coefficients), so
    its bits do not depend on which rows share its chunk (chunked evaluation gives the
    same figures); if this BLAS does not give a row the same bits at every position of
    such a call, everything goes by Clenshaw."""
    if not _gemm_rows_invariant() or x.shape[0] == 0:
        return [_clenshaw_rows(c, x) for c in coefs]
    if _one_grid(x):
        groups = [np.arange(x.shape[0])]
    else:
        by_grid: dict[bytes, list] = {}
        for i in range(x.shape[0]):
            by_grid.setdefault(x[i].tobytes(), []).append(i)
        groups = [np.array(r) for r in by_grid.values()]
    out = [np.empty(x.shape) for _ in coefs]
    kmax = max(c.shape[1] for c in coefs)
    core = CORE_MOD
    for r in groups:
        vand_t = _vander_t(x[r[0]], kmax)
        whole = len(groups) == 1             # r is every row in order: no gather, no scatter
        for o, c in zip(out, coefs):
            cr = c if whole else c[r]
            length = _row_lengths(cr)
            ks = distinct(length)
            if core is not None and not (whole and ks.size == 1):
                for k in ks.tolist():
                    rk = r if ks.size == 1 else np.flatnonzero(length == k) if whole else r[length == k]
                    _rows_matmul_put(o, c, np.ascontiguousarray(rk, np.int64), k, vand_t, core)
                continue
            for k in ks.tolist():
                if ks.size == 1:
                    rk = None
                    a = np.ascontiguousarray(cr[:, :k])     # laid out as a gather's
                    if whole:                               # the product straight into o
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


def _rows_matmul_put(o, c, rows, k, vand_t, core):
    """o[rows] = _rows_matmul(c[rows, :k], vand_t[:k]): the same BLAS calls on the same
    zero-padded blocks, the rows taken into the blocks and the products' rows put into o
    by the compiled core (not a gather, a padded copy of the last block, its product copied
    out of the pad and a scatter: ~130 MB moved on the gyroid plate)."""
    n, g, m = rows.size, _GEMM_ROWS, o.shape[1]
    nblk = -(-n // g)
    a = np.empty((nblk, g, k))
    core.rows_take(c, rows, n, k, a, nblk * g)
    core.rows_put(np.matmul(a, vand_t[:k]), n, m, rows, o)


_VANDER: dict = {}         # (grid bytes, K) -> _vander_t's array (a few grids recur: the probe's,
_VANDER_MAX = 64           # the uniform one, the batch's quadrature grid)


def _vander_t(xg, kmax):
    """np.ascontiguousarray(chebvander(xg, kmax - 1).T), (K, M): kept for the grids that
    recur (the same function of the same numbers, so the same bits)."""
    key = (xg.tobytes(), kmax)
    v = _VANDER.get(key)
    if v is None:
        if len(_VANDER) >= _VANDER_MAX:
            _VANDER.clear()
        v = _VANDER[key] = np.ascontiguousarray(np.polynomial.chebyshev.chebvander(xg, kmax - 1).T)
        v.flags.writeable = False
    return v


def _newton_cheb(n, phi, gam2, u0, u1, w_start, max_iter=60):
    """Collocation Newton for w'' = γ²w + 2w³ + C on N+1 nodes; returns (w nodes, C, ok).
    Each arc's iteration is its own, bit for bit, whatever the batch: its flags, steps and
    damping are per arc, the residual's products are _mm_ordered and row sums (a BLAS
    product rounds with the batch's size), and the batched solve is LAPACK's a matrix."""
    cs = _cheb_setup(n)
    d2, q = cs["d2"], cs["q"]
    d2_t = np.ascontiguousarray(d2[1:-1].T)
    nb = phi.size
    w = w_start.copy()
    w[:, 0], w[:, -1] = u0, u1
    cc = np.zeros(nb)
    scale = np.maximum.reduce([np.abs(phi), np.abs(u0), np.abs(u1), np.full(nb, 1e-300)])

    def residual(w, cc, ia):
        r = _mm_ordered(w, d2_t) - gam2[ia, None] * w[:, 1:-1] - 2.0 * w[:, 1:-1] ** 3 - cc[:, None]
        return np.concatenate([r, ((w * q).sum(axis=1) - phi[ia])[:, None]], axis=1)

    # Jacobians: all but the diagonal are the same for every arc and iterate (solve does
    # not write its input), so they are written once; each step writes the diagonal only
    jac = np.zeros((nb, n, n))
    jac[:, : n - 1, : n - 1] = d2[1:-1, 1:-1]
    jac[:, : n - 1, n - 1] = -1.0
    jac[:, n - 1, : n - 1] = q[1:-1]
    idx = np.arange(n - 1)
    d2_diag = d2[1:-1, 1:-1][idx, idx]
    ok = np.zeros(nb, dtype=bool)
    res = residual(w, cc, np.arange(nb))
    res_norm = np.abs(res).max(axis=1)
    for _ in range(max_iter):
        act = ~ok
        if not act.any():
            break
        ia = np.nonzero(act)[0]
        wa = w[ia]
        ja = jac[: ia.size]
        ja[:, idx, idx] = d2_diag - (gam2[ia, None] + 6.0 * wa[:, 1:-1] ** 2)
        step = np.linalg.solve(ja, -res[ia][..., None])[..., 0]
        # damped Newton: halve the step until the residual does not grow (convex problem,
        # so full steps are taken near the solution)
        lam = np.ones(ia.size)
        for _ in range(30):
            wt = wa.copy()
            wt[:, 1:-1] += lam[:, None] * step[:, : n - 1]
            ct = cc[ia] + lam * step[:, n - 1]
            rt = residual(wt, ct, ia)
            rn = np.abs(rt).max(axis=1)
            bad = (rn > res_norm[ia] * (1.0 - 1e-4 * lam)) & (lam > 1e-6) & \
                  (np.abs(step[:, : n - 1]).max(axis=1) * lam > 1e-13 * scale[ia])
            if not bad.any():
                break
            lam = np.where(bad, lam / 2.0, lam)
        w[ia], cc[ia], res[ia], res_norm[ia] = wt, ct, rt, rn
        small = np.abs(lam[:, None] * step[:, : n - 1]).max(axis=1) <= 1e-13 * scale[ia]
        ok[ia[small & (lam == 1.0)]] = True
    return w, cc, ok


def _eig_setup(n):
    """Eigenvectors of the interior second-derivative block (real, negative, distinct
    eigenvalues; the eigenvector matrix is well conditioned, cond ~2 up to N = 128), or
    None if this LAPACK says otherwise (then _precond_cheb is not used)."""
    cs = _cheb_setup(n)
    if "eig" not in cs:
        lam, v = np.linalg.eig(cs["d2"][1:-1, 1:-1])
        eg = None
        if np.isfinite(lam).all() and not np.iscomplexobj(lam) and (lam < 0).all() and np.linalg.cond(v) < 1e3:
            vinv = np.linalg.inv(v)
            eg = dict(lam=lam, v_t=np.ascontiguousarray(v.T), vinv_t=np.ascontiguousarray(vinv.T),
                      qv=cs["q"][1:-1] @ v, e=vinv.sum(axis=1))
        cs["eig"] = eg
    return cs["eig"]


_PRECOND_TOL = 1e-16       # last step / scale of w at which the preconditioned iteration stops,
_PRECOND_FLOOR = 1e-13     # or at which it stops once steps no longer shrink (rounding floor;
                           # Newton's own acceptance)
_PRECOND_ITER = 40
# solve_circles_rough's laws, for screening candidates far over a limit (curves.candidates_curve:
# ~1e-3 clear of it): the iteration stops at a step of _ROUGH_TOL of the scale (~4 steps an arc,
# not ~7.6), N starts _ROUGH_DOWN rungs lower on the ladder (16 for the plates' 20) and goes up
# while the tail is over _ROUGH_TAIL: laws within ~1e-8 of their scale (measured on the plates'
# curve candidates: their probe's speeds and |a| within ~1e-7 of the full laws')
_ROUGH_TOL = 1e-7
_ROUGH_DOWN = 1
_ROUGH_TAIL = 1e-8
_PRECOND_SLOW_R = 0.7      # a step ratio above this after a few steps: left to Newton


def _precond_cheb(n, phi, gam2, u0, u1, w_start, tol=_PRECOND_TOL):
    """_precond_cheb_c where the compiled core is there, else _precond_cheb_np: the same bits.
    tol: the step / scale at which an arc stops (_PRECOND_TOL; _ROUGH_TOL for rough laws)."""
    if CORE_MOD is not None and n + 1 <= 1024:
        return _precond_cheb_c(n, phi, gam2, u0, u1, w_start, tol)
    return _precond_cheb_np(n, phi, gam2, u0, u1, w_start, tol)


def _mm_ordered(x, m):
    """x (B, K) @ m (K, J) as the sum over k of x[:, k] m[k], each product rounded and added
    in the order of k: each row's bits its own, whatever the batch (no BLAS), and the
    compiled core's (_curvecore.c mv_ordered) the same operations."""
    out = x[:, 0:1] * m[0]
    for k in range(1, m.shape[0]):
        out += x[:, k:k + 1] * m[k]
    return out


def _precond_consts(n):
    """(d2_t, q, lam_e, vinv_t, v_t, qv, e) of the iteration on N+1 nodes (C-contiguous), or
    None where _eig_setup gives no eigenbasis."""
    cs = _cheb_setup(n)
    if "pc" not in cs:
        eg = _eig_setup(n)
        cs["pc"] = None if eg is None else tuple(np.ascontiguousarray(a, float) for a in (
            cs["d2"][1:-1].T, cs["q"], eg["lam"], eg["vinv_t"], eg["v_t"], eg["qv"], eg["e"]))
    return cs["pc"]


def _precond_start(phi, u0, u1, w_start):
    """(w, C, ok, scale) at the start of the iteration: w_start with its ends set to u0, u1."""
    nb = phi.size
    w = w_start.copy()
    w[:, 0], w[:, -1] = u0, u1
    scale = np.maximum.reduce([np.abs(phi), np.abs(u0), np.abs(u1), np.full(nb, 1e-300)])
    return w, np.zeros(nb), np.zeros(nb, dtype=bool), scale


def _precond_cheb_c(n, phi, gam2, u0, u1, w_start, tol=_PRECOND_TOL):
    """_precond_cheb_np in the compiled core (_curvecore.c pc_solve): each arc's whole
    iteration in one pass over its row (the same operations in the same order, numpy's
    pairwise row sums, NaN-propagating maxima, _mm_ordered's products)."""
    w, cc, ok, scale = _precond_start(phi, u0, u1, w_start)
    pc = _precond_consts(n)
    if pc is None or phi.size == 0:
        return w, cc, ok
    d2_t, q, lam_e, vinv_t, v_t, qv, e = pc
    CORE_MOD.pc_solve(w, cc, ok, phi.size, n, np.ascontiguousarray(gam2, float), np.ascontiguousarray(phi, float),
                      scale, d2_t, q, lam_e, vinv_t, v_t, qv, e, _PRECOND_ITER, _PRECOND_SLOW_R, tol,
                      _PRECOND_FLOOR)
    return w, cc, ok


def _precond_cheb_np(n, phi, gam2, u0, u1, w_start, tol=_PRECOND_TOL):
    """The collocation equations of _newton_cheb solved by a preconditioned fixed-point
    iteration: each step is the Newton step with the Jacobian's diagonal γ² + 6w² replaced
    by its mid-range value ḡ, whose inverse is diagonal in the eigenbasis of the second-
    derivative block (two small matrix products per step instead of an LU of (N, N) per
    arc).  The contraction factor is ≤ (half the range of 6w²) / (π² + ḡ) < 1; on the
    gentle laws of curves and arcs it is ~0.1, so ~15 cheap steps replace ~4 LU solves.
    The fixed point is the same collocation solution (the residual is computed exactly).
    Returns (w nodes, C, ok); arcs not converged (a slow contraction: steep layers) have
    ok False and are left to _newton_cheb.  tol: _precond_cheb's."""
    w, cc, ok, scale = _precond_start(phi, u0, u1, w_start)
    pc = _precond_consts(n)
    if pc is None or phi.size == 0:
        return w, cc, ok
    # row-wise products only (_mm_ordered, sums along rows): an arc's iteration is its own,
    # bit for bit, whatever the batch
    d2_t, q, lam_e, vinv_t, v_t, qv, e = pc
    act = np.arange(phi.size)
    last = np.full(phi.size, np.inf)
    for it in range(_PRECOND_ITER):
        wa, ca = w[act], cc[act]
        wi = wa[:, 1:-1]
        g2 = gam2[act]
        w2 = wi * wi
        r1 = _mm_ordered(wa, d2_t) - g2[:, None] * wi - 2.0 * wi * w2 - ca[:, None]
        r2 = (wa * q).sum(axis=1) - phi[act]
        den = lam_e[None, :] - (g2 + 3.0 * (w2.max(axis=1) + w2.min(axis=1)))[:, None]
        b = -_mm_ordered(r1, vinv_t)
        dc = (-r2 - ((b / den) * qv).sum(axis=1)) / ((qv * e) / den).sum(axis=1)
        dw = _mm_ordered((b + dc[:, None] * e) / den, v_t)
        w[act, 1:-1] = wi + dw
        cc[act] = ca + dc
        step = np.abs(dw).max(axis=1)
        # done: at the rounding floor of the residual (steps no longer shrink), or below it
        slow = (it >= 4) & ~(step < _PRECOND_SLOW_R * last[act])
        done = (step <= tol * scale[act]) | (slow & (step <= _PRECOND_FLOOR * scale[act]))
        if it >= 1:           # or the steps left (a geometric series at the last ratio) are within it
            rho = step / last[act]
            done |= (rho < 1.0) & (step * rho <= tol * scale[act] * (1.0 - rho))
        ok[act[done]] = True
        keep = ~done & np.isfinite(step) & ~slow
        last[act] = step
        act = act[keep]
        if act.size == 0:
            break
    return w, cc, ok


_PRECOND_CHUNK = 4096      # arcs per preconditioned iteration (bounded memory; the same bits)


def _solve_nodes(n, phi, gam2, u0, u1, w_start):
    """Collocation solution on N+1 nodes: the preconditioned iteration (by chunks of arcs),
    then Newton (from the same start) for the arcs it leaves."""
    w = np.empty_like(w_start)
    cc = np.empty(phi.size)
    ok = np.empty(phi.size, dtype=bool)
    for a in range(0, phi.size, _PRECOND_CHUNK):
        r = slice(a, a + _PRECOND_CHUNK)
        w[r], cc[r], ok[r] = _precond_cheb(n, phi[r], gam2[r], u0[r], u1[r], w_start[r])
    rest = np.flatnonzero(~ok)
    if rest.size:
        NEWTON_ARCS[0] += rest.size
        w[rest], cc[rest], ok[rest] = _newton_chunked(n, phi[rest], gam2[rest], u0[rest], u1[rest], w_start[rest])
    return w, cc, ok


def _start_nodes(n, phi, ia, w_guess):
    """The start values of w on the N+1 nodes for the arcs ia (indices into phi): the last
    level's solution where w_guess has one (its Chebyshev series at these nodes), else
    the constant cruise phi."""
    cs = _cheb_setup(n)
    w0 = np.empty((ia.size, n + 1))
    w0[:] = phi[ia, None]
    if w_guess:
        for k, i in enumerate(ia.tolist()):
            if i in w_guess:
                w0[k] = _clenshaw(w_guess[i][None, :], cs["x"][None, :])[0]
    return w0


# arcs taken from their start nodes to their coefficients at once (_solve_coefs): the
# preconditioned iteration's ~8 (arcs, N) work arrays, ~5.5 MB at N = 20 (the size of
# _PRECOND_CHUNK; 1024 arcs, ~1.3 MB, cost ~0.7 % more instructions of the whole command
# and did not lower the peak RSS, which the chains' figures set)
_COEF_CHUNK = 4096


def _solve_coefs(n, phi, gam2, u0, u1, ia, w_guess, rough=False):
    """(c, C, ok) of the arcs ia (indices into phi, gam2, u0, u1) on N+1 nodes: the
    Chebyshev coefficients (arcs, N+1) of _solve_nodes' collocation solutions from
    _start_nodes, C and the convergence flags.  rough (rows_invariant() only): the
    iteration stops at _ROUGH_TOL, and no arc goes to Newton (those it leaves: ok False).

    Where this BLAS gives rows their own bits (rows_invariant), _COEF_CHUNK arcs at a
    time from their start nodes to their coefficients: the preconditioned iteration and
    the coefficient product are each arc's own, so only c, C and ok are held for the whole
    level (on the gyroid plate's 34 k curve candidates its start nodes, nodes, the
    product's padded copy and its result were each held whole, ~6 MB apiece).  The arcs
    the iteration leaves go to Newton afterwards in one batch, the one _solve_nodes
    makes (each arc's Newton its own: _newton_cheb).  Elsewhere _solve_nodes on the
    whole level, then the product."""
    to_coef_t = _cheb_setup(n)["to_coef"].T
    p, g2, a0, a1 = phi[ia], gam2[ia], u0[ia], u1[ia]
    if not rows_invariant():
        w, cc, ok = _solve_nodes(n, p, g2, a0, a1, _start_nodes(n, phi, ia, w_guess))
        return _rows_matmul(w, to_coef_t), cc, ok
    nb = ia.size
    c = np.empty((nb, n + 1))
    cc = np.empty(nb)
    ok = np.empty(nb, dtype=bool)
    left = []                   # the start nodes of the arcs left to Newton, in order
    for a in range(0, nb, _COEF_CHUNK):
        r = slice(a, a + _COEF_CHUNK)
        w0 = _start_nodes(n, phi, ia[r], w_guess)
        w, cc[r], ok[r] = _precond_cheb(n, p[r], g2[r], a0[r], a1[r], w0, _ROUGH_TOL if rough else _PRECOND_TOL)
        _rows_matmul(w, to_coef_t, out=c[r])
        if not ok[r].all() and not rough:
            left.append(w0[~ok[r]])
        del w, w0
    rest = np.flatnonzero(~ok)
    if rest.size and not rough:
        NEWTON_ARCS[0] += rest.size
        w, cc[rest], ok[rest] = _newton_chunked(n, p[rest], g2[rest], a0[rest], a1[rest], np.concatenate(left))
        c[rest] = _rows_matmul(w, to_coef_t)
    return c, cc, ok


# Arcs handed to Newton so far (a count: benchmarks/arcs53).  Every step of a solve is the
# arc's own (elementwise, row sums, _mm_ordered, LAPACK a matrix, _rows_matmul's fixed-shape
# calls when rows_invariant()): each arc has the bits it would have in any other batch.
NEWTON_ARCS = [0]


def rows_invariant():
    """Whether this BLAS gives a row the same bits wherever it sits (_rows_matmul's calls)."""
    return _gemm_rows_invariant()


EVAL_CHUNK = 512           # arcs per evaluation on a grid (CircleBatch.row_chunks)
_NEWTON_BYTES = 20e6       # Jacobians (arcs, N, N) held at once by one Newton batch


def _newton_chunked(n, phi, gam2, u0, u1, w_start):
    """_newton_cheb over chunks of arcs, so memory stays bounded on large files (each
    arc's iteration its own: the same bits in any chunk)."""
    nb = phi.size
    chunk = max(64, int(_NEWTON_BYTES / (8.0 * n * n)))
    if nb <= chunk:
        return _newton_cheb(n, phi, gam2, u0, u1, w_start)
    w = np.empty_like(w_start)
    cc = np.empty(nb)
    ok = np.empty(nb, dtype=bool)
    for a in range(0, nb, chunk):
        r = slice(a, a + chunk)
        w[r], cc[r], ok[r] = _newton_cheb(n, phi[r], gam2[r], u0[r], u1[r], w_start[r])
    return w, cc, ok


def _solve_cheb_batch(phi, gam2, u0, u1, lam_est, rough=False):
    """Chebyshev regime; per-arc N from the layer rate, escalated until the tail is small.
    Returns (arcs, coefficients) blocks, one per N that accepted arcs, and C per arc.
    rough: solve_circles_rough's laws (_solve_coefs' rough iteration); an arc the iteration
    leaves, or whose tail is still large at the top N, is given NaN (not solved further)."""
    nb = phi.size
    blocks = []
    cvals = np.zeros(nb)
    # N ≈ √(28 λ) resolves e^{-λτ} to ~1e-12 (Bessel-coefficient decay); start there.  The
    # margin (5) gives tails ~1e-15 at the gyroid's λ ≈ 3 (N = 20, not 32: the same laws to
    # ~1e-14, the Newton's own rounding, at 1/3 of the cost); the tail test below escalates
    need = 5.0 + 1.6 * np.sqrt(28.0 * np.maximum(lam_est, 1.0))
    start = np.searchsorted(_N_LADDER, need).clip(0, len(_N_LADDER) - 1)
    if rough:
        start = (start - _ROUGH_DOWN).clip(0, None)
    pending = np.arange(nb)
    level = start.copy()
    w_guess: dict[int, np.ndarray] = {}
    top = len(_N_LADDER) - 1
    while pending.size:
        next_pending = []
        for lv in distinct(level[pending]):
            ia = pending[level[pending] == lv]
            n = _N_LADDER[lv]
            with blas_one_thread():
                c, cc, ok = _solve_coefs(n, phi, gam2, u0, u1, ia, w_guess, rough)
            scale = np.maximum.reduce([np.abs(phi[ia]), np.abs(u0[ia]), np.abs(u1[ia])])
            tail = np.abs(c[:, -3:]).max(axis=1) / scale
            good = ok & (tail <= (_ROUGH_TAIL if rough else _TAIL_TOL))
            if rough:
                fail = ~ok | ((lv == top) & ~good)
                c[fail] = np.nan
                cc[fail] = np.nan
                good |= fail
            if lv == top and not good.all():
                k = int(np.argmin(good))
                i = ia[k]
                raise RuntimeError(
                    f"circle law did not converge (Φ={phi[i]}, γ²={gam2[i]}, u0={u0[i]},"
                    f" u1={u1[i]}, tail={tail[k]:.1e}, newton_ok={ok[k]})")
            # (every arc accepted, the usual case: c itself, not a copy of it beside it)
            blocks.append((ia, c) if good.all() else (ia[good], c[good]))
            cvals[ia[good]] = cc[good]
            for k in np.flatnonzero(~good).tolist():
                i = int(ia[k])
                if ok[k]:
                    w_guess[i] = c[k].copy()     # (a row, not a view holding the level's c)
                else:
                    w_guess.pop(i, None)
            level[ia[~good]] = lv + 1
            next_pending.append(ia[~good])
            del c, cc, ok, tail, good       # (not held through the next level's solve)
        pending = np.concatenate(next_pending)
    return blocks, cvals


# ---------------------------------------------------------------------------------------------
# Boundary-layer regime: exact half-line solutions
# ---------------------------------------------------------------------------------------------
# With d = w - w_c and F(w) = γ²w²/2 + w⁴/2 + C w, F'(w_c) = 0:  w' = -d √Q(d),
# Q(d) = d² + 4 w_c d + c,  c = γ² + 6 w_c² (= λ²).  1/d satisfies a linear ODE, giving
#     d(σ) = d0 e^{-λσ} / [ -ρ e^{-λσ} + A + B e^{-2λσ} ],  ρ = 2 w_c d0 / c,
#     A = (1 + ρ + q)/2,  B = (1 + ρ - q)/2,  q = √Q(d0)/λ           (σ = distance from the end)
# and ∫₀^σ d = asinh((d0 + 2w_c)/k) - asinh((d(σ) + 2w_c)/k),  k = √(γ² + 2 w_c²).


def _asinh_diff(a, b):
    """asinh(a) - asinh(b) without cancellation when a ≈ b."""
    sa, sb = np.sqrt(1.0 + a * a), np.sqrt(1.0 + b * b)
    same = a * b > 0
    denom = np.where(same, a * sb + b * sa, 1.0)
    arg = np.where(same, (a - b) * (a + b) / denom, a * sb - b * sa)
    return np.arcsinh(arg)


def _layer_coeffs(d0, wc, gam2):
    c = gam2 + 6.0 * wc * wc
    lam = np.sqrt(c)
    rho = 2.0 * wc * d0 / c
    q = np.sqrt(np.maximum(d0 * d0 + 4.0 * wc * d0 + c, 0.0)) / lam
    s1 = 1.0 + rho
    num = d0 * d0 * (gam2 + 2.0 * wc * wc) / (c * c)     # = q² - s1², exact form
    a_inf = np.where(s1 >= 0, (s1 + q) / 2.0, num / (2.0 * np.where(s1 >= 0, 1.0, q - s1)))
    b_inf = np.where(s1 <= 0, (s1 - q) / 2.0, -num / (2.0 * np.where(s1 <= 0, 1.0, q + s1)))
    return lam, rho, a_inf, b_inf


def _layer_d(sig, d0, wc, gam2):
    """Deviation d(σ) of one layer at distance σ ≥ 0 from its end (broadcasts)."""
    lam, rho, a_inf, b_inf = _layer_coeffs(d0, wc, gam2)
    e = np.exp(-lam * sig)
    return d0 * e / (-rho * e + a_inf + b_inf * e * e)


def _layer_int(d0, d, wc, gam2):
    """∫₀^σ d dσ' given d = d(σ)."""
    k = np.sqrt(gam2 + 2.0 * wc * wc)
    return _asinh_diff((d0 + 2.0 * wc) / k, (d + 2.0 * wc) / k)


def _layers_total(wc, phi, gam2, u0, u1):
    """∫₀¹ w dτ - Φ for the composite layer solution with cruise value w_c:
    wc + _layer_int(dl0, _layer_d(1, dl0)) + _layer_int(dr0, _layer_d(1, dr0)) - phi, the
    terms the two layers share (c, λ, e^{-λ}, c², γ² + 2w_c², k, 2w_c, 4w_c) computed once
    for both: the same operations on the same numbers (tests/test_speed20_curves_layers.py)."""
    dl0, dr0 = u0 - wc, u1 - wc
    c = gam2 + 6.0 * wc * wc
    lam = np.sqrt(c)
    c_sq = c * c
    g2w = gam2 + 2.0 * wc * wc
    w2, w4 = 2.0 * wc, 4.0 * wc
    e = np.exp(-lam * 1.0)
    k = np.sqrt(g2w)
    tot = wc
    for d0 in (dl0, dr0):
        # _layer_coeffs(d0, wc, gam2)
        rho = w2 * d0 / c
        q = np.sqrt(np.maximum(d0 * d0 + w4 * d0 + c, 0.0)) / lam
        s1 = 1.0 + rho
        num = d0 * d0 * g2w / c_sq
        a_inf = np.where(s1 >= 0, (s1 + q) / 2.0, num / (2.0 * np.where(s1 >= 0, 1.0, q - s1)))
        b_inf = np.where(s1 <= 0, (s1 - q) / 2.0, -num / (2.0 * np.where(s1 <= 0, 1.0, q + s1)))
        # _layer_d(1.0, d0, wc, gam2), then _layer_int(d0, d1, wc, gam2)
        d1 = d0 * e / (-rho * e + a_inf + b_inf * e * e)
        tot = tot + _asinh_diff((d0 + w2) / k, (d1 + w2) / k)
    return tot - phi


def _layers_totals(xs, phi, gam2, u0, u1):
    """[_layers_total(x, phi, gam2, u0, u1) for x in xs]: with the compiled core, all of
    them in three compiled passes (_curvecore.c lay_pre, lay_mid, lay_post: _layers_total's
    operations in its order) around one np.exp and one np.arcsinh call (numpy's own, on
    the same arguments: elementwise, so the same bits; tests/test_speed21_curvegeo_layers.py),
    instead of ~45 numpy calls per cruise value; else _layers_total itself."""
    core = CORE_MOD
    if core is None:
        return [_layers_total(x, phi, gam2, u0, u1) for x in xs]
    m, n = len(xs), phi.size
    wc = np.empty((m, n))
    for k, x in enumerate(xs):
        wc[k] = x
    phi, gam2, u0, u1 = (np.ascontiguousarray(v, float) for v in (phi, gam2, u0, u1))
    a = _layers_args(wc, gam2, u0, u1)
    out = np.empty((m, n))
    core.lay_post(wc, phi, a, n, m, out)
    return list(out)


def _layer_int_bound(u, wc, gam2, out, work):
    """Upper bound on |∫₀¹ d dσ| of the layer from u at cruise value wc, into out (work: scratch
    of its size; in place: the few temporaries an arc of the plain expression raised the gyroid
    plate's peak RSS ~1 MB): d keeps the sign of d0 = u - wc and shrinks, so the integral is
    asinh over [2w_c, d0 + 2w_c]/k at most, whose slope 1/√(1 + x²) there is at most
    k/√(k² + M²) (M: the distance of 0 from that range): |d0| / √(k² + M²), k² = γ² + 2w_c²."""
    np.subtract(u, wc, out=out)                 # d0
    np.sign(out, out=work)
    work *= u + wc
    np.negative(work, out=work)
    np.maximum(work, 0.0, out=work)             # M
    work *= work
    work += gam2
    work += 2.0 * wc * wc
    np.sqrt(work, out=work)
    np.abs(out, out=out)
    out /= work
    return out


def _bracket_holds(phi, gam2, u0, u1, lo, hi):
    """True where the layer residual is provably negative at lo and positive at hi
    (_solve_layers_batch's starting bracket; lo < min(u0, u1) and hi > max(u0, u1)): the
    integrals' bound under 99 % of |lo - Φ| and |hi - Φ| (the 1 % far above rounding), so
    the check by two residuals an arc, which would find nothing to widen, can be left out."""
    b0, b1, work = np.empty((3, phi.size))
    with np.errstate(all="ignore"):
        _layer_int_bound(u0, lo, gam2, b0, work)
        b0 += _layer_int_bound(u1, lo, gam2, b1, work)
        ok = b0 <= 0.99 * (phi - lo)
        _layer_int_bound(u0, hi, gam2, b0, work)
        b0 += _layer_int_bound(u1, hi, gam2, b1, work)
        ok &= b0 <= 0.99 * (hi - phi)
    return ok


_LAYERS_ITER = 100         # _solve_layers_batch's Newton steps at most (tests lower it)


def _solve_layers_batch(phi, gam2, u0, u1):
    """Cruise value w_c (safeguarded secant/bisection; the residual is increasing in w_c).
    The first step's slope is a forward difference (w_c and w_c + h in one _layers_totals),
    each later one the secant through the last two iterates: one residual a step, not two
    (the same root to the same tolerance; ~35 % fewer residuals on the plates' curves)."""
    span = np.abs(phi) + np.abs(u0) + np.abs(u1) + 1.0
    lo, hi = np.minimum.reduce([phi, u0, u1]) - span, np.maximum.reduce([phi, u0, u1]) + span
    for _ in range(60 if not _bracket_holds(phi, gam2, u0, u1, lo, hi).all() else 0):
        # make sure the bracket holds (the layer integrals are O(log))
        glo, ghi = _layers_totals((lo, hi), phi, gam2, u0, u1)
        bad_lo, bad_hi = glo > 0, ghi < 0
        if not (bad_lo.any() or bad_hi.any()):
            break
        lo = np.where(bad_lo, lo - 2.0 * span, lo)
        hi = np.where(bad_hi, hi + 2.0 * span, hi)
        span = np.where(bad_lo | bad_hi, 2.0 * span, span)
    wc = phi.astype(float).copy()
    wc = np.clip(wc, lo, hi)
    if CORE_MOD is not None and wc.dtype == np.float64:
        return _layers_iterate_c(wc, phi, gam2, u0, u1, span, lo, hi)
    act = np.arange(wc.size)        # an arc leaves the iteration once its step is below tolerance
    # the live arcs' numbers held packed (x: their w_c, lo_a/hi_a: their bracket, xp/gp: the
    # last iterate and its residual), packed again only when arcs leave, and each arc's w_c put
    # into wc as it leaves: not gathers and scatters by act every step
    x, p_, g2, a0, a1, sp, lo_a, hi_a = (v[act] for v in (wc, phi, gam2, u0, u1, span, lo, hi))
    xp = gp = None
    for _ in range(_LAYERS_ITER if act.size else 0):
        if xp is None:
            h = 1e-7 * (np.abs(x) + 1e-3 * sp)
            g, gh = _layers_totals((x, x + h), p_, g2, a0, a1)
            dg = (gh - g) / h
        else:
            (g,) = _layers_totals((x,), p_, g2, a0, a1)
            dg = (g - gp) / (x - xp)
        lo_a = np.where(g < 0, x, lo_a)
        hi_a = np.where(g > 0, x, hi_a)
        new = x - g / np.where(dg > 0, dg, np.inf)
        outside = ~((new > lo_a) & (new < hi_a)) | ~np.isfinite(new)
        new = np.where(outside, 0.5 * (lo_a + hi_a), new)
        done = np.abs(new - x) <= 1e-15 * sp
        xp, gp, x = x, g, new
        if done.any():
            wc[act[done]] = x[done]
            # (by the mask: taking them by index put the rectilinear plate's peak RSS up ~1 MB)
            keep = ~done
            act, x, xp, gp, p_, g2, a0, a1, sp, lo_a, hi_a = (
                v[keep] for v in (act, x, xp, gp, p_, g2, a0, a1, sp, lo_a, hi_a))
            if act.size == 0:
                return wc
    wc[act] = x                     # (the steps ran out: the last ones' w_c)
    return wc


def _layers_iterate_c(wc, phi, gam2, u0, u1, span, lo, hi):
    """_solve_layers_batch's iteration from its start wc (and bracket lo, hi) with the compiled
    core: each step's residuals by _layers_totals' passes around np.exp and np.arcsinh, then
    the rest of the step (the residuals' sums, slope, bracket, step, bisection, test) and the
    packing of the live arcs in one compiled pass (_curvecore.c lay_step: the numpy loop's
    operations in its order), not ~40 numpy calls a step over the live arcs; the same w_c."""
    core = CORE_MOD
    act = np.arange(wc.size, dtype=np.int64)
    # the live arcs' state, packed (own C-contiguous copies: lay_step packs them in place)
    x, p_, g2, a0, a1, sp, lo_a, hi_a = (np.array(v[act], dtype=float) for v in (wc, phi, gam2, u0, u1, span, lo, hi))
    xp, gp = np.empty(act.size), np.empty(act.size)
    n = act.size
    for it in range(_LAYERS_ITER if n else 0):
        if it == 0:                 # (the first step's slope: a forward difference)
            h = 1e-7 * (np.abs(x) + 1e-3 * sp)
            xs = np.empty((2, n))
            xs[0] = x
            xs[1] = x + h
        else:
            h, xs = None, x
        asn = _layers_args(xs, g2, a0, a1)
        n = core.lay_step(xs.shape[0] if xs.ndim == 2 else 1, xs, asn, p_, h, act, x, xp, gp, g2, a0, a1, sp,
                          lo_a, hi_a, n, wc, wc.size)
        if n == 0:
            return wc
        act, x, xp, gp, p_, g2, a0, a1, sp, lo_a, hi_a = (
            v[:n] for v in (act, x, xp, gp, p_, g2, a0, a1, sp, lo_a, hi_a))
    wc[act] = x                     # (the steps ran out: the last ones' w_c)
    return wc


def _layers_args(xs, gam2, u0, u1):
    """np.arcsinh of _layers_totals' arguments (m, 2, n) of the cruise values xs ((m, n) or
    one (n,)): lay_pre, np.exp, lay_mid, np.arcsinh, as _layers_totals makes them."""
    core = CORE_MOD
    wc = xs if xs.ndim == 2 else xs[None, :]
    m, n = wc.shape
    e = np.empty((m, n))
    core.lay_pre(wc, gam2, n, m, e)
    np.exp(e, out=e)
    a = np.empty((m, 2, n))
    core.lay_mid(wc, gam2, u0, u1, e, n, m, a)
    np.arcsinh(a, out=a)
    return a


# ---------------------------------------------------------------------------------------------
# Public batch object
# ---------------------------------------------------------------------------------------------

def _cheb_der_int(coef, der=True, itg=True):
    """(chebder(coef, axis=1, scl=2.0), chebint(coef, axis=1, lbnd=-1.0, scl=0.5)) of
    Chebyshev series rows coef (B, K): numpy.polynomial's loops over the coefficients,
    each an operation on a strided column, run in C per row where the core is built (the
    same operations in the same order; results laid out as numpy's, the transposes of
    (coefficients, rows) arrays: tests/test_speed20_curves_core.py).  der=False or
    itg=False: that one not made (None; the other the same numbers, each row's own)."""
    from numpy.polynomial import chebyshev as C
    nb, K = coef.shape
    if CORE_MOD is None or K < 2 or K > 1024:
        return (C.chebder(coef, axis=1, scl=2.0) if der else None,
                C.chebint(coef, axis=1, lbnd=-1.0, scl=0.5) if itg else None)
    d = np.empty((K - 1, nb)) if der else None
    t = np.empty((K + 1, nb)) if itg else None
    if der or itg:
        CORE_MOD.cheb_der_int(np.ascontiguousarray(coef, float), nb, K, d, t)
    return (d.T if der else None), (t.T if itg else None)


_GL_CACHE: dict[int, tuple] = {}


def _gauss(n):
    """Gauss-Legendre nodes and weights of n points on [0, 1]: leggauss(n)'s, from
    quad_tables.GAUSS where it holds n (the same bits: make_tables.py), so the usual sizes
    do not import numpy.polynomial."""
    if n not in _GL_CACHE:
        got = GAUSS.get(n)
        x, w = (np.array(got[0]), np.array(got[1])) if got else np.polynomial.legendre.leggauss(n)
        _GL_CACHE[n] = ((x + 1) / 2, w / 2)
    return _GL_CACHE[n]


def _graded_grid(h, levels):
    """Gauss nodes/weights on [0,1]: geometric panels (ratio 2) from each end up to h, one
    middle panel.  h: (B,) layer width in τ.  Resolves layers down to h·2^-levels."""
    gx, gw = _gauss(10)
    ratios = np.concatenate([[0.0], 2.0 ** -np.arange(levels, -1, -1.0)])
    if CORE_MOD is not None and h.ndim == 1 and h.size and h.dtype == np.float64:
        # one compiled pass (_curvecore.c graded_grid: the same operations), not numpy's
        # ~10 operations on broadcast operands, each copied through its buffers
        mx, mw = _gauss(24)
        nl = (ratios.size - 1) * gx.size
        xs, ws = np.empty((h.size, 2 * nl + mx.size)), np.empty((h.size, 2 * nl + mx.size))
        CORE_MOD.graded_grid(np.ascontiguousarray(h), ratios, gx, gw, mx, mw, h.size, ratios.size - 1,
                             gx.size, mx.size, xs, ws)
        return xs, ws
    edges = h[:, None] * ratios[None, :]
    a, b = edges[:, :-1], edges[:, 1:]
    xl = (a[..., None] + (b - a)[..., None] * gx).reshape(h.size, -1)
    wl = ((b - a)[..., None] * gw).reshape(h.size, -1)
    mx, mw = _gauss(24)
    xm = h[:, None] + (1 - 2 * h)[:, None] * mx
    wm = (1 - 2 * h)[:, None] * mw
    xs = np.concatenate([xl, xm, 1.0 - xl[:, ::-1]], axis=1)
    ws = np.concatenate([wl, wm, wl[:, ::-1]], axis=1)
    return xs, ws


def _grid_plan_of(phi_total, T_t, beta_s2, w0, w1, regime, wc):
    """CircleBatch._grid_plan of a batch of these arcs (regime, wc: as solve_circles gives
    them): the layer width h in τ per arc and the panel levels of the batch."""
    gam2 = (T_t / np.sqrt(beta_s2)) ** 2         # CircleBatch.gamma ** 2
    u0, u1 = w0 * T_t, w1 * T_t
    wmax = np.maximum.reduce([np.abs(phi_total), np.abs(u0), np.abs(u1)])
    lam_min = np.sqrt(gam2 + 6.0 * np.where(regime, wc ** 2, 0.0))
    h = np.minimum(0.5, 30.0 / np.maximum(lam_min, 1e-300))
    # finest panel must resolve the steepest scale 1/(λ + |d0|)
    levels = int(np.clip(np.ceil(np.log2(np.max(20.0 * h * (lam_min + 2 * wmax)))), 2, 40))
    return h, levels


def grid_levels_of(phi_total, T, beta, w0=0.0, w1=0.0):
    """The panel levels (CircleBatch._grid_plan) a batch of these arcs (solve_circles'
    arguments, R aside) has, without its Chebyshev solve: the layer regime's solve and
    test only.  The levels of a batch are the largest of its arcs' (a maximum, then
    monotone maps), so a batch given the levels of arcs left out of it (grid_levels) has
    the grid, and the figures, of the batch that holds them too."""
    phi, T_t, beta_s2, w0, w1 = (a.copy() for a in np.broadcast_arrays(
        *(np.atleast_1d(np.asarray(v, float)) for v in (phi_total, T, beta, w0, w1))))
    if phi.size == 0:
        return None
    wc, regime = _layer_regime(phi, T_t, beta_s2, w0, w1)[:2]
    return _grid_plan_of(phi, T_t, beta_s2, w0, w1, regime, wc)[1]


def _layer_regime(phi, T_t, beta_s2, w0, w1):
    """solve_circles' first step: (w_c, regime, γ², u0, u1, λ) -- the cruise value of the
    layer solution, whether it is accepted (the neglected interaction of the two layers
    is tiny), and the dimensionless numbers the Chebyshev regime goes on with."""
    gam2 = T_t * T_t / beta_s2
    u0, u1 = w0 * T_t, w1 * T_t
    nb = phi.size
    scale = np.maximum.reduce([np.abs(phi), np.abs(u0), np.abs(u1), np.full(nb, 1e-300)])
    wc = _solve_layers_batch(phi, gam2, u0, u1)
    tail = np.maximum(np.abs(_layer_d(1.0, u0 - wc, wc, gam2)),
                      np.abs(_layer_d(1.0, u1 - wc, wc, gam2)))
    lam = np.sqrt(gam2 + 6.0 * wc * wc)
    regime = (tail * (1.0 + lam) <= _LAYER_TAIL_TOL * scale) & np.isfinite(wc)
    return wc, regime, gam2, u0, u1, lam


def _own_arrays(got, like, made):
    """The arrays eval_tau gives for values got computed on all of its rows at once: each
    value itself where it is a float64 array of like's shape holding its own memory and
    given once, not like itself (a new array, as o[k] = v's o), else a copy into a new one."""
    out, seen = [], []
    for v, m in zip(got, made):
        if not m:
            out.append(None)
            continue
        if not (type(v) is np.ndarray and v.base is None and v.dtype == like.dtype and v.shape == like.shape
                and v.flags.c_contiguous and v is not like and not any(v is u for u in seen)):
            o = np.empty(like.shape, like.dtype)      # (C order, like a broadcast row too)
            o[...] = v
            v = o
        seen.append(v)
        out.append(v)
    return out


@record
class CircleBatch:
    """Optimal laws for B arcs.  Angles in rad, t in s, R in mm (or any length unit).

    phi_total (B,), T_t (B,), beta_s2 (B,), w0/w1 (B,) end angular speeds (rad/s), R_d (B,)."""
    phi_total: np.ndarray
    T_t: np.ndarray
    beta_s2: np.ndarray
    w0: np.ndarray
    w1: np.ndarray
    R_d: np.ndarray
    regime: np.ndarray          # True: "layers", False: "cheb"
    wc: np.ndarray              # cruise value (layers regime; dimensionless)
    cc: np.ndarray              # the constant C (dimensionless)
    coef: np.ndarray            # (B, K) Chebyshev coefficients of w(τ), zero-padded (0 for layers)
    # the least panel levels of the quadrature grid (_grid_plan): a batch solved apart from
    # arcs it would have shared a batch with takes their levels too (grid_levels_of), so
    # its figures are those of the larger batch, bit for bit; None: its own levels
    grid_levels: int | None = None

    def __len__(self):
        return self.phi_total.size

    def __getitem__(self, i) -> "CircleLaw":
        return CircleLaw(self, int(i))

    @property
    def gamma(self):
        return self.T_t / np.sqrt(self.beta_s2)

    def rows(self, sl) -> "CircleBatch":
        """The arcs `sl` (a slice) as a batch of their own (views, no copy)."""
        return CircleBatch(self.phi_total[sl], self.T_t[sl], self.beta_s2[sl], self.w0[sl], self.w1[sl],
                           self.R_d[sl], self.regime[sl], self.wc[sl], self.cc[sl], self.coef[sl], self.grid_levels)

    def take(self, idx) -> "CircleBatch":
        """The arcs idx (integer array) as a batch of their own (copies)."""
        return CircleBatch(self.phi_total[idx], self.T_t[idx], self.beta_s2[idx], self.w0[idx], self.w1[idx],
                           self.R_d[idx], self.regime[idx], self.wc[idx], self.cc[idx], self.coef[idx],
                           self.grid_levels)

    def row_chunks(self):
        """Slices of at most EVAL_CHUNK arcs: evaluations on (arcs, grid) arrays go chunk by
        chunk so that memory does not grow with the batch.  Every evaluation is per arc, so
        the figures are the same as in one piece, bit for bit."""
        return [slice(a, a + EVAL_CHUNK) for a in range(0, len(self), EVAL_CHUNK)]

    # -- dimensionless evaluation: φ, w = φ', w', w'' at τ (B, M) --------------------------
    def eval_tau(self, tau: np.ndarray, idx=None, w2=True, w1=True, phi=True, w=True):
        """(φ, w, w', w'') at τ; w2=False: w'' is not computed (None), w1=False: w' is not
        (None), phi=False: φ is not, w=False: w is not (w2 needs it); the others are the same
        numbers (the curve planner reads φ, w, w' only: w'' cost a cube per point; curve_knots
        reads φ and w: w' cost a third of its series; the probes read φ only where w and w'
        leave |a| undecided)."""
        w = w or w2
        made = (phi, w, w1, w2)
        idx = np.arange(len(self)) if idx is None else np.asarray(idx)
        tau = np.broadcast_to(np.asarray(tau, float), (idx.size,) + np.shape(tau)[-1:])
        gam2 = self.gamma[idx] ** 2
        lay = self.regime[idx]
        if lay.all() or not lay.any():      # one regime (the usual case): no gather, no scatter
            # (read only: the caller's own array where it is C-contiguous or one row
            # broadcast to every arc, not a copy)
            if not _one_row(tau):
                tau = np.ascontiguousarray(tau)
            got = (self._eval_layers if lay.all() else self._eval_cheb)(tau, idx, gam2, w2, w1, phi, w)
            return _own_arrays(got, tau, made)
        tau = tau.copy()
        out = [np.empty_like(tau) if m else None for m in made]
        for rows, part in ((lay, self._eval_layers), (~lay, self._eval_cheb)):
            if rows.any():
                k = np.nonzero(rows)[0]
                for o, v in zip(out, part(tau[k], idx[k], gam2[k], w2, w1, phi, w)):
                    if o is not None:
                        o[k] = v
        return out

    def _eval_layers(self, tau, idx, gam2, w2=True, w1=True, phi_on=True, w_on=True):
        """(φ, w, w', w'') of layer-regime arcs (all made; those not asked given as None)."""
        wc = self.wc[idx][:, None]
        g2 = gam2[:, None]
        u0, u1 = self.w0[idx] * self.T_t[idx], self.w1[idx] * self.T_t[idx]
        dl0, dr0 = (u0[:, None] - wc), (u1[:, None] - wc)
        dl = _layer_d(tau, dl0, wc, g2)
        dr = _layer_d(1.0 - tau, dr0, wc, g2)
        dr_full = _layer_d(1.0, dr0, wc, g2)
        phi = wc * tau + _layer_int(dl0, dl, wc, g2) + (_layer_int(dr0, dr_full, wc, g2)
                                                        - _layer_int(dr0, dr, wc, g2))
        w = wc + dl + dr
        c = g2 + 6.0 * wc * wc

        def dp(d):   # d' (in σ)
            return -d * np.sqrt(np.maximum(d * d + 4.0 * wc * d + c, 0.0))

        def dpp(d):  # d''
            return d * (c + 6.0 * wc * d + 2.0 * d * d)
        return (phi if phi_on else None), (w if w_on else None), (dp(dl) - dp(dr) if w1 else None), \
            (dpp(dl) + dpp(dr) if w2 else None)

    def _eval_cheb(self, tau, idx, gam2, w2=True, w1=True, phi_on=True, w_on=True):
        """(φ, w, w', w'') of Chebyshev-regime arcs, those not asked None (not made: each
        series is evaluated apart, its own products row by row, so those left out leave the
        others the same numbers; w'' needs w)."""
        # (one row broadcast to every arc: its x once, broadcast the same way)
        x = np.broadcast_to(2.0 * tau[0] - 1.0, tau.shape) if _one_row(tau) else 2.0 * tau - 1.0
        coef = self.coef[idx]
        nz = np.nonzero(np.any(coef != 0, axis=0))[0]
        coef = coef[:, : (nz[-1] + 1 if nz.size else 1)]      # drop padding common to all
        dcoef, pcoef = _cheb_der_int(coef, der=w1, itg=phi_on)
        asked = [c for c, on in ((coef, w_on), (dcoef, w1), (pcoef, phi_on)) if on]
        got = iter(_series_values(asked, x) if asked else ())
        w, dw, phi = (next(got) if on else None for on in (w_on, w1, phi_on))
        w2_v = gam2[:, None] * w + 2.0 * w ** 3 + self.cc[idx][:, None] if w2 else None
        return phi, w, dw, w2_v

    # -- dimensional quantities ------------------------------------------------------------
    def eval(self, t_t, idx=None):
        """φ (rad), φ̇ (rad/s), φ̈ (rad/s²) at times t (s); t shape (M,) or (B, M)."""
        idx = np.arange(len(self)) if idx is None else np.asarray(idx)
        T = self.T_t[idx][:, None]
        phi, w, w1, _ = self.eval_tau(np.asarray(t_t, float) / T, idx)
        return phi, w / T, w1 / T ** 2

    def hamiltonian(self, t_t, idx=None):
        """H = ½ṡ² + β(½s̈² − ṡ s⃛ + (3/2)κ²ṡ⁴) (mm²/s²); constant along an exact solution."""
        idx = np.arange(len(self)) if idx is None else np.asarray(idx)
        T, R = self.T_t[idx][:, None], self.R_d[idx][:, None]
        beta = self.beta_s2[idx][:, None]
        _, w, w1, w2 = self.eval_tau(np.asarray(t_t, float) / T, idx)
        sd, sdd, sddd = R * w / T, R * w1 / T ** 2, R * w2 / T ** 3
        return 0.5 * sd ** 2 + beta * (0.5 * sdd ** 2 - sd * sddd + 1.5 * sd ** 4 / R ** 2)

    def _quad_grid(self):
        """Per-arc quadrature nodes in τ resolving the layers (and their weights)."""
        return _graded_grid(*self._grid_plan())

    def grid_chunks(self, idx=None, rows=None):
        """(slice, τ nodes, weights) per chunk of arcs: the batch's _quad_grid, built chunk
        by chunk (each arc's nodes depend on its own layer width and the batch's number of
        levels only), so the (arcs, nodes) arrays are never held for the whole batch.
        idx: only these arcs (an integer array; chunks of them, each given as its index
        array), on the whole batch's grid: the same nodes as without idx.  rows: arcs a
        chunk (default EVAL_CHUNK)."""
        h, levels = self._grid_plan()
        step = EVAL_CHUNK if rows is None else rows
        if idx is None:
            for a in range(0, len(self), step):
                sl = slice(a, a + step)
                yield (sl,) + _graded_grid(h[sl], levels)
            return
        idx = np.asarray(idx, int)
        for a in range(0, idx.size, step):
            r = idx[a:a + step]
            yield (r,) + _graded_grid(h[r], levels)

    def panel_levels(self):
        """The panel levels of this batch's quadrature grid (at least grid_levels, when
        set): the largest of its arcs' (a maximum, then monotone maps), so the levels of
        a batch made of several are the largest of theirs."""
        return self._grid_plan()[1]

    @classmethod
    def concat(cls, batches):
        """The arcs of batches (a non-empty list), in order, as one batch; coefficients
        zero-padded to the widest (trailing zeros: the same series), grid_levels None."""
        coef = np.zeros((sum(len(b) for b in batches), max(b.coef.shape[1] for b in batches)))
        a = 0
        for b in batches:
            coef[a:a + len(b), :b.coef.shape[1]] = b.coef
            a += len(b)
        cols = ("phi_total", "T_t", "beta_s2", "w0", "w1", "R_d", "regime", "wc", "cc")
        return cls(*(np.concatenate([getattr(b, f) for b in batches]) for f in cols), coef)

    def _grid_plan(self):
        """(h, levels) of _quad_grid: layer width in τ per arc, panel levels of the batch
        (at least grid_levels, when set)."""
        h, levels = _grid_plan_of(self.phi_total, self.T_t, self.beta_s2, self.w0, self.w1, self.regime, self.wc)
        if self.grid_levels is not None and self.grid_levels > levels:
            levels = self.grid_levels
        return h, levels

    def integrals(self):
        """(∫ṡ² dt  [mm²/s],  ∫|a|² dt  [mm²/s³]) with |a|² = R²(φ̈² + φ̇⁴)."""
        i_v, i_a = np.empty(len(self)), np.empty(len(self))
        for sl, tau, wq in self.grid_chunks():   # the batch's grid, chunk by chunk
            _, w, w1, _ = self.rows(sl).eval_tau(tau)
            i_v[sl] = (wq * w * w).sum(axis=1)
            i_a[sl] = (wq * (w1 * w1 + w ** 4)).sum(axis=1)
        T, R = self.T_t, self.R_d
        return R ** 2 * i_v / T, R ** 2 * i_a / T ** 3

    def cost(self, m=1.0):
        """J = (m/2)(∫|v|² + β∫|a|²)."""
        iv, ia = self.integrals()
        return 0.5 * m * (iv + self.beta_s2 * ia)

    def _extremum(self, which):
        """max/min over τ of f ∈ {w (speed), g = w'² + w⁴ (|a|²)} by grid + Newton polish."""
        out = np.empty(len(self))
        for sl, tau, _ in self.grid_chunks():    # the batch's grid, chunk by chunk
            out[sl] = self.rows(sl)._extremum_on(which, tau)
        return out

    def _extremum_on(self, which, tau):
        tau = np.concatenate([np.zeros((len(self), 1)), tau, np.ones((len(self), 1))], axis=1)
        gam2 = (self.gamma ** 2)[:, None]

        def f_and_derivs(tt):
            _, w, w1, w2 = self.eval_tau(tt)
            w3 = (gam2 + 6.0 * w * w) * w1
            if which in ("vmax", "vmin"):
                return w * np.sign(self.phi_total + (self.phi_total == 0))[:, None], \
                    w1 * np.sign(self.phi_total + (self.phi_total == 0))[:, None], \
                    w2 * np.sign(self.phi_total + (self.phi_total == 0))[:, None]
            g = w1 * w1 + w ** 4
            g1 = 2 * w1 * w2 + 4 * w ** 3 * w1
            g2 = 2 * w2 * w2 + 2 * w1 * w3 + 12 * w * w * w1 * w1 + 4 * w ** 3 * w2
            return g, g1, g2
        f, _, _ = f_and_derivs(tau)
        sgn = -1.0 if which == "vmin" else 1.0
        k = np.argmax(sgn * f, axis=1)
        rows = np.arange(len(self))
        best = f[rows, k]
        t0 = tau[rows, k][:, None]
        lo = tau[rows, np.maximum(k - 1, 0)][:, None]
        hi = tau[rows, np.minimum(k + 1, tau.shape[1] - 1)][:, None]
        for _ in range(6):                      # Newton on f' = 0 inside the grid cell
            _, f1, f2 = f_and_derivs(t0)
            step = np.where(f2 != 0, -f1 / np.where(f2 != 0, f2, 1.0), 0.0)
            t0 = np.clip(t0 + step, lo, hi)
        fb = f_and_derivs(t0)[0][:, 0]
        return np.where(sgn * fb > sgn * best, fb, best)

    def peak_speed(self):
        """max |ṡ| (mm/s)."""
        return self.R_d * np.abs(self._extremum("vmax")) / self.T_t

    def min_speed(self):
        """min ṡ along the arc (mm/s, signed along the direction of travel)."""
        return self.R_d * self._extremum("vmin") / self.T_t

    def peak_accel(self):
        """max |a| (mm/s²) including the centripetal part R φ̇²."""
        return self.R_d * np.sqrt(self._extremum("amax")) / self.T_t ** 2


@record
class CircleLaw:
    """One arc of a CircleBatch (same methods, scalars / 1-D arrays)."""
    batch: CircleBatch
    i: int

    phi_total = property(lambda self: float(self.batch.phi_total[self.i]))
    T = property(lambda self: float(self.batch.T_t[self.i]))
    beta = property(lambda self: float(self.batch.beta_s2[self.i]))
    R = property(lambda self: float(self.batch.R_d[self.i]))
    regime = property(lambda self: "layers" if self.batch.regime[self.i] else "cheb")

    def eval(self, t_t):
        """(φ, φ̇, φ̈) at times t (s)."""
        t = np.atleast_1d(np.asarray(t_t, float))
        out = self.batch.eval(t[None, :], [self.i])
        return tuple(o[0].reshape(np.shape(t_t)) for o in out)

    def eval_s(self, t_t):
        """(s mm, ṡ mm/s, s̈ mm/s²) along the arc."""
        return tuple(self.R * v for v in self.eval(t_t))

    def hamiltonian(self, t_t):
        t = np.atleast_1d(np.asarray(t_t, float))
        return self.batch.hamiltonian(t[None, :], [self.i])[0].reshape(np.shape(t_t))

    def _sub(self):
        b = self.batch
        i = slice(self.i, self.i + 1)
        return CircleBatch(b.phi_total[i], b.T_t[i], b.beta_s2[i], b.w0[i], b.w1[i], b.R_d[i],
                           b.regime[i], b.wc[i], b.cc[i], b.coef[i], b.grid_levels)

    def integrals(self):
        iv, ia = self._sub().integrals()
        return float(iv[0]), float(ia[0])

    def cost(self, m=1.0):
        return float(self._sub().cost(m)[0])

    def peak_speed(self):
        return float(self._sub().peak_speed()[0])

    def min_speed(self):
        return float(self._sub().min_speed()[0])

    def peak_accel(self):
        return float(self._sub().peak_accel()[0])


def solve_circles(phi_total, T, beta, w0=0.0, w1=0.0, R=1.0, layers=None) -> CircleBatch:
    """Vectorised solve for B arcs.

    phi_total: swept angle (rad, any size incl. several turns), T: duration (s),
    beta = α·m (s²), w0/w1: end angular speeds (rad/s), R: radius (mm).  Broadcast to (B,).
    layers: these arcs' layer regime (_layer_regime's tuple of (B,) arrays), where a solve
    of them made it already (solve_circles_rough's, its rows taken): not solved again (each
    arc's numbers are its own whatever its batch, so the same)."""
    return _solve_circles(phi_total, T, beta, w0, w1, R, False, layers)


def solve_circles_rough(phi_total, T, beta, w0=0.0, w1=0.0, R=1.0):
    """solve_circles' laws to ~1e-12 of their scale, not to the rounding of the collocation
    equations: the preconditioned iteration stopped at _ROUGH_TOL, N from a rung lower and
    a tail of _ROUGH_TAIL (laws within ~1e-8 of their scale), no Newton (an arc it leaves has
    NaN coefficients).  The same layer regime (the same regime, w_c and panel levels); for
    screening candidates that are far over a limit.  Returns (batch, layers): layers, the arcs' layer regime (solve_circles' layers).
    None where this BLAS does not give rows their own bits (rows_invariant)."""
    if not rows_invariant():
        return None
    return _solve_circles(phi_total, T, beta, w0, w1, R, True)


def _solve_circles(phi_total, T, beta, w0, w1, R, rough, layers=None):
    """solve_circles (rough False: the batch) or solve_circles_rough ((batch, layers))."""
    phi, T_t, beta_s2, w0, w1, R_d = np.broadcast_arrays(
        *(np.atleast_1d(np.asarray(v, float)) for v in (phi_total, T, beta, w0, w1, R)))
    phi, T_t, beta_s2, w0, w1, R_d = (a.copy() for a in (phi, T_t, beta_s2, w0, w1, R_d))
    if np.any(T_t <= 0) or np.any(beta_s2 <= 0):
        raise ValueError("T and beta must be positive")
    nb = phi.size
    # layer regime first: accept where the neglected interaction of the two layers is tiny
    layers = _layer_regime(phi, T_t, beta_s2, w0, w1) if layers is None else layers
    wc, regime, gam2, u0, u1, lam = layers

    coef = np.zeros((nb, 1))
    cc = -gam2 * wc - 2.0 * wc ** 3
    rest = np.nonzero(~regime)[0]
    if rest.size:
        # local rate at the ends (steep end layers need more nodes)
        q0 = np.sqrt(np.abs((u0 - wc) ** 2 + 4 * wc * (u0 - wc)) + lam ** 2)
        q1 = np.sqrt(np.abs((u1 - wc) ** 2 + 4 * wc * (u1 - wc)) + lam ** 2)
        lam_est = np.maximum.reduce([lam, q0, q1])
        if rest.size == nb:         # (every arc: the arrays themselves, not gathers of all)
            blocks, cv = _solve_cheb_batch(phi, gam2, u0, u1, lam_est, rough)
        else:
            blocks, cv = _solve_cheb_batch(phi[rest], gam2[rest], u0[rest], u1[rest], lam_est[rest], rough)
        coef = _coef_table(blocks, rest, nb)
        cc[rest] = cv
    law = CircleBatch(phi, T_t, beta_s2, w0, w1, R_d, regime, wc, cc, coef)
    return (law, layers) if rough else law


def _coef_table(blocks, rest, nb):
    """The (nb, K) coefficients of _solve_cheb_batch's blocks ((arcs, coefficients) of the
    arcs rest), zero-padded to the largest N, each block let go once copied; one block of
    every arc in order (every arc accepted at its first N, the usual case): its array."""
    if len(blocks) == 1 and rest.size == nb and blocks[0][0].size == nb and (blocks[0][0] == np.arange(nb)).all():
        return np.ascontiguousarray(blocks.pop()[1], float)
    coef = np.zeros((nb, max(c.shape[1] for _, c in blocks)))
    while blocks:
        ia, c = blocks.pop()
        coef[rest[ia], : c.shape[1]] = c
    return coef


def solve_circle(phi_total, T, beta, w0=0.0, w1=0.0, R=1.0) -> CircleLaw:
    """Optimal law on one arc: swept angle phi_total (rad), duration T (s), β = αm (s²),
    end angular speeds w0, w1 (rad/s), radius R (mm; only scales s = Rφ)."""
    return solve_circles(phi_total, T, beta, w0, w1, R)[0]
