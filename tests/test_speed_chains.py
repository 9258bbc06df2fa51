"""laws/chain.solve_chains (the active set as flat arrays over all chains, issue 8) gives
bit for bit the laws of the per-chain active set it replaced: the reference below is that
code as it stood at commit 1950734 (ref_solve_chains, its _solve_fixed, _share_time,
_vertex_speeds, _multipliers), run on real chains of the bundled full-speed gyroid under a
classic-jerk and a square-corner-velocity profile, cold and warm-started, and on chains with
a zero-length segment (the flat vertex-to-piece map's fallback).

Since session 20 (chainprim) the chains' time sharing and time of distance use the
deterministic sinh and cube of laws/prims.py where this reference has np.sinh and ** 3
(through LineLaw): the comparison is a tolerance check (_close), see there.  Since session 29
(chainnewton) the time sharing's Newton steps take the exact slopes of J (laws/chain.
_exact_slopes, checked against mpmath in test_speed29_chainnewton_slopes) and the cold start
binds the caps below COLD_BIND_R x the mean speed: this reference's _share_time and cold
start follow (the rest of it, the per-chain active set, is as it stood)."""
import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.laws.chain import (CAP_TOL_R, COLD_BIND_R, MAX_ACTIVE_ITERS, MAX_NEWTON, MU_TOL_R, NEWTON_TOL_R,
                                  ChainLaw, ChainProblem, _exact_slopes, _exact_terms, _Pieces, solve_chains)
from gcode_opt.laws.line import LineLaw, time_of_distance
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.schedule import plan_inputs
from gcode_opt.strokes import K_CHAIN

SAMPLES = "sample_gcode/"


# ---------------------------------------------------------------- the reference (commit 1950734)
# (_J and _law_figures stood in laws/chain.py; only this reference uses them now)
def _J(L, T, beta, va, vb):
    iv, ia = LineLaw(L, T, beta, va, vb).integrals()
    return iv + beta * ia


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
    # extremes of every law at once (exact in any order); the sums law by law, as np.sum
    # rounds them (every law has a piece: reduceat's indices increase)
    first = starts[:-1]
    peak_v, min_v = np.maximum.reduceat(pv, first), np.minimum.reduceat(mv, first)
    a0, a1 = cat([p.a0 for p in ps]), cat([p.a1 for p in ps])
    pa0, pa1 = np.maximum.reduceat(np.abs(a0), first).tolist(), np.maximum.reduceat(np.abs(a1), first).tolist()
    for k, (lw, a, b) in enumerate(zip(laws, first, starts[1:])):
        lw.iv, lw.ia = float(np.sum(iv[a:b])), float(np.sum(ia[a:b]))
        lw.peak_v, lw.min_v = float(peak_v[k]), float(min_v[k])
        lw.peak_a = max(pa0[k], pa1[k])  # a line law's |s̈| peaks at an end


def _pieces_of(pr, B):
    """Knot positions and end speeds of the pieces of chain pr for binding set B."""
    ks = np.concatenate([[0.0], pr.s_v[B], [pr.S]])
    kv = np.concatenate([[pr.v0], pr.c_v[B], [pr.v1]])
    return ks, kv



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
        # session 29 (chainnewton): the exact slopes (checked against mpmath's derivatives
        # of J in test_speed29_chainnewton_slopes), where this stood central differences of
        # _J at Ti(1 ± FD_H_R), whose rounding noise moved the laws by up to ~2e-7
        d1, d2, rt = _exact_slopes(Li, Ti, bi, ai + ci, ai - ci, _exact_terms(float(np.max((Ti * Ti) / bi))))
        d2 = np.maximum(d2, (1e-12 * np.abs(d1)) * rt + 1e-300)
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



def ref_solve_chains(problems, init_binding=None, init_vert_t=None):
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
            # (session 29: below COLD_BIND_R x the mean speed, as laws/chain.py)
            B[c] = np.flatnonzero(pr.c_v < COLD_BIND_R * pr.S / pr.T)
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


# ---------------------------------------------------------------- the checks
FIELDS = ("binding", "knot_s", "knot_t", "knot_v", "vert_v", "vert_t", "converged", "lam", "iv", "ia",
          "peak_v", "min_v", "peak_a")


def _same(a, b):
    for f in FIELDS:
        x, y = getattr(a, f), getattr(b, f)
        assert np.array_equal(np.asarray(x), np.asarray(y), equal_nan=True), f
    for f in _Pieces.__slots__:
        assert np.array_equal(getattr(a.pieces, f), getattr(b.pieces, f), equal_nan=True), f


# The reference's J, time of distance and speeds use np.sinh and ** 3 (LineLaw); the chains
# now use prims.sinh and prims.cube (session 20, chainprim: a documented change of the last
# bits).  J's last bits differ by an ulp or two, the Newton step's central differences
# (h = 1e-4 T) amplify that to ~1e-12 of the slopes, so the laws agree to ~1e-12 of each
# chain's scale; a chain whose Newton stopping test sits at its threshold may stop a step
# earlier or later, its law then differs within the Newton tolerance (NEWTON_TOL_R = 1e-8):
# bounded here by CLOSE_ALL, and such chains must be rare (CLOSE_FEW).  The active set must
# still end on the same binding vertices with the same convergence flags.
CLOSE_TIGHT, CLOSE_ALL, CLOSE_FEW = 1e-11, 1e-7, 0.03


def _close(a, b):
    """The largest difference of chain laws a and b over their numbers, relative to each
    field's scale in b (binding and converged: exactly equal)."""
    assert np.array_equal(a.binding, b.binding) and a.converged == b.converged
    worst = 0.0
    fields = [(getattr(a, f), getattr(b, f)) for f in FIELDS[1:] if f != "converged"]
    fields += [(getattr(a.pieces, f), getattr(b.pieces, f)) for f in _Pieces.__slots__]
    for x, y in fields:
        x, y = np.atleast_1d(np.asarray(x, float)), np.atleast_1d(np.asarray(y, float))
        assert x.shape == y.shape
        if x.size:
            worst = max(worst, float(np.max(np.abs(x - y))) / max(float(np.max(np.abs(y))), 1e-300))
    return worst


def _all_close(got, want):
    """Every pair of laws within CLOSE_ALL, all but a few (CLOSE_FEW) within CLOSE_TIGHT."""
    d = np.array([_close(a, b) for a, b in zip(got, want, strict=True)])
    assert np.all(d <= CLOSE_ALL), float(d.max())
    assert np.count_nonzero(d > CLOSE_TIGHT) <= 1 + CLOSE_FEW * d.size, np.sort(d)[-5:]


_CACHE = {}


def _chain_problems(prof):
    if prof not in _CACHE:
        profile = load_profile(prof)
        opts = Options()
        opts.ringing = False
        strokes, _ = analyse(SAMPLES + "prusa_gyroid_fullspeed.gcode", profile, opts)
        pin = plan_inputs(strokes, profile, opts)
        rows = [i for i, s in enumerate(strokes) if chains.plan_kind(s) == K_CHAIN][:120]
        _CACHE[prof] = ([strokes[i] for i in rows], pin.T_orig[rows], profile)
    return _CACHE[prof]


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
@pytest.mark.parametrize("ratio", [1.0, 1.1])
def test_flat_active_set_equals_the_per_chain_one(prof, ratio):
    sts, T0, profile = _chain_problems(prof)
    assert len(sts) >= 100
    T = T0 * ratio
    probs = chains._problems(sts, T, (T / chains.GAMMA_MIN) ** 2, profile)
    got, want = solve_chains(probs), ref_solve_chains(probs)
    assert sum(lw.binding.size for lw in want) > 50          # caps bind: the active set worked
    _all_close(got, want)
    # warm-started at a nearby duration, as the candidate table does
    T2 = T * 1.05
    probs2 = chains._problems(sts, T2, (T2 / chains.GAMMA_MIN) ** 2, profile)
    init_B = [lw.binding for lw in want]
    init_t = [lw.vert_t * 1.05 for lw in want]
    _all_close(solve_chains(probs2, init_B, init_t), ref_solve_chains(probs2, init_B, init_t))


def test_zero_length_segment_takes_the_searchsorted_path():
    rng = np.random.default_rng(5)
    probs = []
    for k in range(12):
        d = rng.uniform(0.4, 1.0, 14)
        d[3 + k % 5] = 0.0                            # two vertices at the same place
        s = np.cumsum(d)
        S = float(s[-1] + 0.7)
        caps = rng.uniform(20.0, 60.0, s.size)
        probs.append(ChainProblem(s, caps, S, S / 45.0, (S / 45.0 / 0.1) ** 2, 30.0, 25.0))
    fine = []
    for pr in probs:           # a zero-length piece may make both raise: then alike
        try:
            want = ref_solve_chains([pr])
        except ValueError as e:
            with pytest.raises(type(e)):
                solve_chains([pr])
            continue
        _all_close(solve_chains([pr]), want)
        fine.append(pr)
    assert len(fine) >= 4
    want = ref_solve_chains(fine)
    assert sum(lw.binding.size for lw in want) > 5
    _all_close(solve_chains(fine), want)
