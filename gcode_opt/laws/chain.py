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
pieces of all chains at once (J_j from LineLaw.integrals, derivatives by central
differences of that closed form).  Then the usual rules: a vertex whose speed exceeds
its cap joins B; a binding vertex whose multiplier is negative (s̈(t_i-) > s̈(t_i+):
the cap holds the law up instead of down) leaves B; a cap that binds rightly bends the
speed into a valley at its vertex, s̈(t_i+) >= s̈(t_i-).  The start is B = every vertex
whose cap is below the chain's mean speed S/T.

tests/test_chain_law.py checks the result against an independent minimisation of the
same J (piecewise-linear v(s), SLSQP with the cap inequalities) on real gyroid chains.
"""
from __future__ import annotations

import numpy as np

from .line import LineLaw, time_of_distance

CAP_TOL_R = 1e-7          # a speed above cap x (1 + this) violates the cap
MU_TOL_R = 1e-7           # multiplier (accel jump) below -this x accel scale: release the vertex
MAX_ACTIVE_ITERS = 40
MAX_NEWTON = 60
FD_H_R = 1e-4             # relative step of the central differences on T
NEWTON_TOL_R = 1e-8       # |J_j' + λ| per piece, relative to the chain's slope scale


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
        tl = time_of_distance(law, s - self.knot_s[j])
        _, v, _ = law.eval(tl)
        return self.knot_t[j] + tl, v


def _pieces_of(pr, B):
    """Knot positions and end speeds of the pieces of chain pr for binding set B."""
    ks = np.concatenate([[0.0], pr.s_v[B], [pr.S]])
    kv = np.concatenate([[pr.v0], pr.c_v[B], [pr.v1]])
    return ks, kv


def _J(L, T, beta, va, vb):
    iv, ia = LineLaw(L, T, beta, va, vb).integrals()
    return iv + beta * ia


def _share_time(L, beta, va, vb, owner, T_total, T_init):
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
        jm, j0, jp = _J(Li, Ti - h, bi, ai, ci), _J(Li, Ti, bi, ai, ci), _J(Li, Ti + h, bi, ai, ci)
        d1 = (jp - jm) / (2.0 * h)
        d2 = (jp - 2.0 * j0 + jm) / (h * h)
        d2 = np.maximum(d2, 1e-12 * np.abs(j0) / (Ti * Ti) + 1e-300)
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
    return T, lam, conv


def solve_chains(problems, init_binding=None, init_vert_t=None):
    """ChainLaw of every ChainProblem, solved together (pieces of all chains in one batch).
    Warm start (optional, per chain, None = cold): init_binding, the binding set to start
    from; init_vert_t, vertex times of a nearby law (scaled by the caller to the problem's
    T, e.g. x T / T_nearby): the first
    guess of the pieces' durations.  Each active-set step starts from the previous law's
    vertex times."""
    m = len(problems)
    B = [None] * m
    vts = [None] * m
    if init_vert_t is not None:
        for c, (pr, vt) in enumerate(zip(problems, init_vert_t)):
            if vt is not None and vt.size == pr.s_v.size:
                vts[c] = np.asarray(vt, float)
    for c, pr in enumerate(problems):
        if init_binding is not None and init_binding[c] is not None:
            B[c] = np.asarray(init_binding[c], int)
        else:       # a cap below the mean speed is (nearly always) met: start with those
            B[c] = np.flatnonzero(pr.c_v < pr.S / pr.T)
    active = list(range(m))
    out = [None] * m
    seen = [set() for _ in range(m)]
    for it in range(MAX_ACTIVE_ITERS):
        if not active:
            break
        res = _solve_fixed([problems[c] for c in active], [B[c] for c in active], [vts[c] for c in active])
        nxt = []
        for c, law in zip(active, res):
            pr = problems[c]
            out[c] = law
            Bc = B[c]
            bound = np.zeros(pr.s_v.size, bool)
            bound[Bc] = True
            viol = ~bound & (law.vert_v > pr.c_v * (1 + CAP_TOL_R) + 1e-12)
            seen[c].add(Bc.tobytes())
            if viol.any():
                newB = np.flatnonzero(bound | viol)
            else:
                mu = _multipliers(law, Bc)
                neg = mu < 0
                if not neg.any():
                    continue
                newB = Bc[~neg]
                if newB.tobytes() in seen[c]:          # cycling: release only the worst
                    newB = np.delete(Bc, int(np.argmin(mu)))
            if newB.tobytes() in seen[c]:
                law.converged = False
                continue
            B[c] = newB
            vts[c] = law.vert_t
            nxt.append(c)
        active = nxt
    for c in active:
        out[c].converged = False
    _law_figures(out)
    return out


def _multipliers(law, Bc):
    """Each binding vertex's multiplier, up to a positive factor: s̈ just after minus s̈
    just before, relative to the chain's acceleration scale (>= 0 for a cap that holds the
    law down: a point constraint ṡ <= c bends the speed into a valley).  0 unless negative."""
    p = law.pieces
    a_start, a_end = p.a0, p.a1
    jump = a_start[1:] - a_end[:-1]
    scale = max(float(np.max(np.abs(a_start))), float(np.max(np.abs(a_end))), 1e-9)
    mu = jump / scale
    return np.where(mu < -MU_TOL_R, mu, 0.0)


class _Pieces:
    __slots__ = ("L", "T", "beta", "v0", "v1", "a0", "a1")


def _solve_fixed(problems, Bs, vts=None):
    """Laws for fixed binding sets (all chains' pieces in one Newton batch); vts: per chain
    vertex times of a nearby law (None: time shared as a constant speed would share it)."""
    vts = vts or [None] * len(problems)
    L, va, vb, beta, owner, T0, knots = [], [], [], [], [], [], []
    for c, (pr, B, vt) in enumerate(zip(problems, Bs, vts)):
        ks, kv = _pieces_of(pr, B)
        Lc = np.diff(ks)
        knots.append((ks, kv))
        L.append(Lc)
        va.append(kv[:-1])
        vb.append(kv[1:])
        t0 = None
        if vt is not None:          # start: the nearby law's vertex times at the knots
            t0 = np.diff(np.concatenate([[0.0], vt[B], [pr.T]]))
            if not np.all(t0 > 1e-6 * pr.T):
                t0 = None
        T0.append(pr.T * Lc / pr.S if t0 is None else t0)   # else: as a constant speed would
    sizes = [x.size for x in L]
    owner = np.repeat(np.arange(len(problems)), sizes)
    beta = np.repeat([pr.beta for pr in problems], sizes)
    L, va, vb, T0 = (np.concatenate(x) for x in (L, va, vb, T0))
    T_total = np.array([pr.T for pr in problems])
    Tj, lam, conv = _share_time(L, beta, va, vb, owner, T_total, T0)
    law = LineLaw(L, Tj, beta, va, vb)
    a0 = law.eval(np.zeros_like(Tj))[2]          # s̈ at both ends of every piece
    a1 = law.eval(Tj)[2]
    starts = np.concatenate([[0], np.cumsum([len(k[0]) - 1 for k in knots])])
    out = []
    for c, pr in enumerate(problems):
        sl = slice(starts[c], starts[c + 1])
        ks, kv = knots[c]
        lw = ChainLaw()
        lw.problem = pr
        lw.binding = Bs[c]
        lw.knot_s, lw.knot_v = ks, kv
        lw.knot_t = np.concatenate([[0.0], np.cumsum(Tj[sl])])
        p = _Pieces()
        p.L, p.T, p.beta, p.v0, p.v1 = L[sl], Tj[sl], beta[sl], va[sl], vb[sl]
        p.a0, p.a1 = a0[sl], a1[sl]
        lw.pieces = p
        lw.converged = bool(conv[c])
        lw.lam = float(lam[c])
        out.append(lw)
    _vertex_speeds(out)
    return out


def _law_figures(laws):
    """∫ṡ², ∫s̈², peak and least speed, peak |s̈| of the final laws (not of the active-set
    steps before them), all pieces in one batch."""
    if not laws:
        return
    cat = np.concatenate
    ps = [lw.pieces for lw in laws]
    law = LineLaw(*(cat([getattr(p, f) for p in ps]) for f in ("L", "T", "beta", "v0", "v1")))
    iv, ia = law.integrals()
    pv, mv = law.peak_speed(), law.min_speed()
    starts = np.concatenate([[0], np.cumsum([p.L.size for p in ps])])
    for lw, p, a, b in zip(laws, ps, starts[:-1], starts[1:]):
        lw.iv, lw.ia = float(np.sum(iv[a:b])), float(np.sum(ia[a:b]))
        lw.peak_v, lw.min_v = float(np.max(pv[a:b])), float(np.min(mv[a:b]))
        lw.peak_a = max(float(np.max(np.abs(p.a0))), float(np.max(np.abs(p.a1))))  # a line law's |s̈| peaks at an end


def _vertex_speeds(laws):
    """Speed and time of every law at every interior vertex (binding ones: the cap, exactly)."""
    Ls, Ts, bs, v0s, v1s, tgt, t0s, who = [], [], [], [], [], [], [], []
    for c, lw in enumerate(laws):
        pr = lw.problem
        j = np.clip(np.searchsorted(lw.knot_s, pr.s_v, side="right") - 1, 0, len(lw.knot_s) - 2)
        p = lw.pieces
        Ls.append(p.L[j]); Ts.append(p.T[j]); bs.append(p.beta[j]); v0s.append(p.v0[j]); v1s.append(p.v1[j])
        tgt.append(pr.s_v - lw.knot_s[j]); t0s.append(lw.knot_t[j]); who.append(np.full(j.size, c))
    if not laws:
        return
    cat = np.concatenate
    law = LineLaw(cat(Ls), cat(Ts), cat(bs), cat(v0s), cat(v1s))
    tl = time_of_distance(law, cat(tgt))
    _, v, _ = law.eval(tl)
    t = cat(t0s) + tl
    who = cat(who)
    for c, lw in enumerate(laws):
        sel = who == c
        vv, tt = v[sel].copy(), t[sel].copy()
        B = lw.binding
        if B.size:             # exact at the binding vertices (piece ends)
            vv[B] = lw.problem.c_v[B]
            tt[B] = lw.knot_t[1:-1]
        lw.vert_v, lw.vert_t = vv, tt


def solve_chain(s_v, c_v, S, T, beta, v0, v1):
    """One chain (see ChainProblem)."""
    return solve_chains([ChainProblem(s_v, c_v, S, T, beta, v0, v1)])[0]
