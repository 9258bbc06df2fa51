"""Issue 8 (chains, round 4): the chain candidates' steps made cheaper give the bits of the
code they replace, kept below verbatim as it stood at commit 9bb98a8:

- laws/chain.solve_fixed: the step's laws as _step_law (only the series-branch coefficients
  that end_accels, time_of_distance and eval(t, "v") read; n by the batch's own number of
  Horner terms), the piece start knots without np.isin, the knot counts by reduceat, the
  knot times by the core's piece_cumsum (the grid's row cumsums, chain by chain);
- laws/chain.FlatLaws with pieces=False (the candidate table): no a0/a1/knots kept, no
  ∫s̈² or peak |s̈| made (never read there);
- chains._tent_rows: segments.tent_feeds_rows' envelopes by the core's tent_rows where
  every value is finite and > 0 (the maximum of the same differences).

Checked on real chains of the bundled full-speed gyroid (classic jerk and square-corner
velocity), cold and warm, with and without the chain core; and on made-up inputs at the
edges (the fallbacks).  Each check compares bits; the mutant checks show the inputs tell
a changed order of operations apart."""
import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.laws import chain as lc
from gcode_opt.laws.chain import (CAP_TOL_R, MAX_ACTIVE_ITERS, ChainLaw, LineLaw, _Pieces, _seen, _share_time,
                                  _Step, _times_and_speeds)
from gcode_opt.laws.line import end_speeds, time_of_distance

from test_speed_chains import _chain_problems  # noqa: E402

HAS_CORE = lc.CORE_MOD is not None
needs_core = pytest.mark.skipif(not HAS_CORE, reason=f"the chain core is not used here ({lc.CORE_WHY})")


# ---------------------------------------------------------------- the reference (commit 9bb98a8)
def ref_solve_flat(fl, bound, vt, warm, pieces=True):
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
    res = RefFlatLaws(fl)
    active = np.arange(m)
    hist = []        # the binding masks of the steps so far: a chain is active from step 0 to its end
    vt = vt.copy()
    warm = warm.copy()
    for it in range(MAX_ACTIVE_ITERS):
        if active.size == 0:
            break
        na = active.size
        st = ref_solve_fixed(fl, active, bound, vt, warm)
        vi, rank = st.vi, st.rank
        bv = bound[vi]
        hist.append(bound.copy())
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
        again = rel & _seen(hist, vi, new, rank, na)
        if again.any():                    # cycling: release only the worst
            order = np.lexsort((mu, brank))          # per chain, the least mu first (argmin's tie rule)
            first = order[np.r_[True, brank[order][1:] != brank[order][:-1]]]
            worst = first[again[brank[first]]]
            back = again[rank]
            new[back] = bv[back]
            new[bpos[worst]] = False
        moving = any_viol | any_neg
        cyc = moving & _seen(hist, vi, new, rank, na)
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

def ref_solve_fixed(self, active, bound, vt, warm):
    """Laws of the chains `active` (ascending) for the binding vertices `bound`, all
    their pieces in one Newton batch (_share_time); warm[c]: start from the vertex
    times vt, else time shared as a constant speed would share it."""
    na = active.size
    nv = self.nv[active]
    on = np.zeros(self.S.size, bool)
    on[active] = True
    vi = np.flatnonzero(on[self.ch])               # the active chains' vertices, in order
    rank = np.repeat(np.arange(na), nv)            # place in the step of each one's chain
    bvoff = np.concatenate([[0], np.cumsum(nv)]).astype(int)
    # knots: [0, binding vertices, S] per chain, with speeds and warm-start times
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
    nk = np.bincount(np.repeat(np.arange(na), ne)[keep], None, na)
    koff = np.concatenate([[0], np.cumsum(nk)]).astype(int)
    npc = nk - 1                                   # pieces per chain
    owner = np.repeat(np.arange(na), npc)
    p0 = np.flatnonzero(np.isin(np.arange(ks.size), koff[1:] - 1, invert=True))   # piece start knots
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
    beta = self.beta[active][owner]
    Tj, lam, conv = _share_time(L, beta, va, vb, owner, Tc, T0)
    law = LineLaw(L, Tj, beta, va, vb)
    a0, a1 = law.end_accels()                      # s̈ at both ends of every piece
    # knot times: each chain's cumulative sum of its own pieces (row by row)
    poff = koff[:-1] - np.arange(na)
    local = np.arange(Tj.size) - poff[owner]
    P = int(npc.max()) if na else 0
    grid = np.zeros((na, P))
    grid[owner, local] = Tj
    kt = np.zeros(ks.size)
    kt[p0 + 1] = np.cumsum(grid, axis=1)[owner, local]
    # speed and time at every vertex, in its piece
    bv = bound[vi]
    if self.monotone:              # binding vertices up to it in its chain
        cnt = np.cumsum(bv)
        j = cnt - np.concatenate([[0], cnt])[bvoff[:-1]][rank]
    else:
        j = np.empty(vi.size, int)
        for r in range(na):
            sl = slice(bvoff[r], bvoff[r + 1])
            kc = ks[koff[r]:koff[r + 1]]
            j[sl] = np.clip(np.searchsorted(kc, self.sv[vi[sl]], side="right") - 1, 0, kc.size - 2)
    kj = koff[:-1][rank] + j
    v, t = self.cv[vi].copy(), kt[kj]              # exact at the binding vertices (piece ends)
    free = np.flatnonzero(~bv)                     # the others: in their piece's law (each
    kf = kj[free]                                  # element's Newton is its own: the batch's
    pj = kf - rank[free]                           # make-up changes no figure)
    vlaw = law.take(pj)                            # = LineLaw(L[pj], Tj[pj], beta[pj], ...)
    tl, v[free] = _times_and_speeds(vlaw, self.sv[vi[free]] - ks[kf])
    t[free] = kt[kf] + tl
    return _Step(self, active, vi, rank, bvoff, v, t,
                 ks, kv, kt, koff, L, Tj, beta, va, vb, a0, a1, owner, lam, conv)

class RefFlatLaws:
    """solve_flat's laws, flat: per vertex (in fl's order) bound (the binding masks solved
    for), vert_v, vert_t; per chain conv, lam and the figures iv, ia, peak_v, min_v,
    peak_a; the pieces (L, T, beta, v0, v1, a0, a1) chain after chain (chain c's at
    poff[c]:poff[c + 1]) and their knots (ks, kv, kt at koff[c]:koff[c + 1]).  Each chain's
    numbers are those of the active-set step that ended it (take)."""

    def __init__(self, fl):
        self.fl = fl
        m, nv = fl.S.size, fl.sv.size
        self.vert_v, self.vert_t = np.empty(nv), np.empty(nv)
        self.conv, self.lam = np.zeros(m, bool), np.zeros(m)
        self._parts = []

    def take(self, st, done, cyc):
        """Keep the laws of the step st's chains `done` (cyc: ended by cycling or out of
        steps: not converged)."""
        if not done.any():
            return
        dv = done[st.rank]
        self.vert_v[st.vi[dv]] = st.vert_v[dv]
        self.vert_t[st.vi[dv]] = st.vert_t[dv]
        c = st.active[done]
        self.conv[c] = st.conv[done] & ~cyc[done]
        self.lam[c] = st.lam[done]
        pd = done[st.owner]
        nk = np.diff(st.koff)
        kd = np.repeat(done, nk)
        self._parts.append((st.active[st.owner[pd]], st.L[pd], st.Tj[pd], st.beta[pd], st.va[pd], st.vb[pd],
                            st.a0[pd], st.a1[pd], np.repeat(st.active, nk)[kd], st.ks[kd], st.kv[kd], st.kt[kd]))

    def close(self, bound, pieces=True):
        """Every chain taken: pieces and knots in chain order, the figures (_flat_figures);
        pieces False: then drop the pieces and knots."""
        cat = [np.concatenate(x) for x in zip(*self._parts)]
        del self._parts
        po, ko = np.argsort(cat[0], kind="stable"), np.argsort(cat[8], kind="stable")
        self.L, self.T, self.beta, self.v0, self.v1, self.a0, self.a1 = (x[po] for x in cat[1:8])
        self.ks, self.kv, self.kt = (x[ko] for x in cat[9:12])
        m = self.fl.S.size
        self.poff = np.concatenate([[0], np.cumsum(np.bincount(cat[0], None, m))]).astype(int)
        self.koff = self.poff + np.arange(m + 1)          # a chain's knots: its pieces + 1
        self.bound = bound
        ref_flat_figures(self)
        if not pieces:
            for f in ("L", "T", "beta", "v0", "v1", "a0", "a1", "ks", "kv", "kt", "poff", "koff"):
                delattr(self, f)

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


def ref_flat_figures(res):
    """∫ṡ², ∫s̈², peak and least speed, peak |s̈| of the final laws (not of the active-set
    steps before them), all pieces in one batch; each chain's sums as np.sum of its own
    pieces rounds them (row sums of the chains with the same number of pieces)."""
    law = LineLaw(res.L, res.T, res.beta, res.v0, res.v1)
    iv, ia = law.integrals()
    # the speed candidates of LineLaw._speed_candidates: the ends as eval has them
    # (end_speeds), the interior stationary point evaluated
    law._speeds = end_speeds(res.L, res.T, res.v0, res.v1) + (law.eval(law._critical_t(), "v")[1],)
    pv, mv = law.peak_speed(), law.min_speed()
    first = res.poff[:-1]
    res.peak_v, res.min_v = np.maximum.reduceat(pv, first), np.minimum.reduceat(mv, first)
    pa0, pa1 = np.maximum.reduceat(np.abs(res.a0), first), np.maximum.reduceat(np.abs(res.a1), first)
    res.peak_a = np.where(pa1 > pa0, pa1, pa0)        # as max(pa0, pa1)
    npc = np.diff(res.poff)
    res.iv, res.ia = np.empty(npc.size), np.empty(npc.size)
    for k in np.unique(npc).tolist():
        c = np.flatnonzero(npc == k)
        ix = first[c][:, None] + np.arange(k)
        res.iv[c], res.ia[c] = np.sum(iv[ix], axis=1), np.sum(ia[ix], axis=1)

def ref_tent_feeds_rows(need, v_feed, step_v, max_cells=4_000_000):
    """tent_feeds of every row of need (k, n): (rows, n, n + 2) envelopes of at most
    max_cells cells at a time.  A max of the same differences: the same numbers.  v_feed
    and step_v: one value, or one per row (rows of several chains)."""
    if np.ndim(step_v) == 0 and np.ndim(v_feed) == 0:
        if not np.isfinite(step_v):
            return need
    k, n = need.shape
    step = np.broadcast_to(np.asarray(step_v, float), (k,))
    vf = np.broadcast_to(np.asarray(v_feed, float), (k,))
    out = np.array(need, float)
    live = np.flatnonzero(np.isfinite(step))        # an infinite step leaves the row as it is
    ar = ref_tent_dist(n)
    per = max(1, max_cells // max(n * (n + 2), 1))
    for a in range(0, live.size, per):
        r = live[a:a + per]
        side = (vf[r] + step[r])[:, None]
        pad = np.concatenate([side, need[r], side], axis=1)
        dist = step[r][:, None, None] * ar[None, :, :]
        out[r] = np.max(pad[:, None, :] - dist, axis=2)
    return out

REF_TENT_DIST: dict[int, np.ndarray] = {}    # tent_feeds' distance matrices by segment count


def ref_tent_dist(n):
    """|k - j| for k segments and j = -1..n (the ends), cached by n."""
    dist = REF_TENT_DIST.get(n)
    if dist is None:
        dist = REF_TENT_DIST[n] = np.abs(np.arange(n)[:, None] - np.arange(-1, n + 1)[None, :])
    return dist


# ---------------------------------------------------------------- helpers
def _bits(x):
    x = np.asarray(x)
    if x.dtype == bool:
        return x.view(np.uint8)
    return x.view(np.int64) if x.dtype == np.float64 else x


def _eq(a, b, what=""):
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape and a.dtype == b.dtype, what
    assert np.array_equal(_bits(a), _bits(b)), what


def _flat(prof, ratio):
    sts, T0, profile = _chain_problems(prof)
    T = T0 * ratio
    return chains._flat_chains(sts, profile).with_T(T, (T / chains.GAMMA_MIN) ** 2)


FIG = ("vert_v", "vert_t", "conv", "lam", "iv", "peak_v", "min_v", "bound")
PIECES = ("L", "T", "beta", "v0", "v1", "a0", "a1", "ks", "kv", "kt", "poff", "koff", "ia", "peak_a")


def _compare(got, want, pieces):
    for f in FIG + (PIECES if pieces else ()):
        _eq(getattr(got, f), getattr(want, f), f)


# ---------------------------------------------------------------- solve_flat
@pytest.mark.parametrize("core", [True, False])
@pytest.mark.parametrize("pieces", [False, True])
@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_solve_flat_same_bits_as_9bb98a8(prof, pieces, core, monkeypatch):
    if core and not HAS_CORE:
        pytest.skip("no chain core")
    if not core:
        monkeypatch.setattr(lc, "CORE_MOD", None)
    fl = _flat(prof, 1.0)
    m, nv = fl.S.size, fl.sv.size
    got = lc.solve_flat(fl, lc.cold_binding(fl), np.zeros(nv), np.zeros(m, bool), pieces=pieces)
    want = ref_solve_flat(fl, lc.cold_binding(fl), np.zeros(nv), np.zeros(m, bool), pieces=pieces)
    assert want.bound.sum() > 50                  # caps bind: the active set worked
    _compare(got, want, pieces)
    # warm, at a nearby duration (the candidate table's next column)
    fl2 = _flat(prof, 1.05)
    vt = want.vert_t * 1.05
    got2 = lc.solve_flat(fl2, want.bound.copy(), vt, np.ones(m, bool), pieces=pieces)
    want2 = ref_solve_flat(fl2, want.bound.copy(), vt, np.ones(m, bool), pieces=pieces)
    _compare(got2, want2, pieces)
    if pieces:                                    # the laws made of them too
        for c in range(0, m, 17):
            a, b = got2.law(c), want2.law(c)
            for f in ("binding", "knot_s", "knot_t", "knot_v", "vert_v", "vert_t", "iv", "ia", "peak_a"):
                _eq(getattr(a, f), getattr(b, f), f)
    else:
        assert got.ia is None and got.peak_a is None and not hasattr(got, "ks")


def test_solve_flat_cut_short_same_bits(monkeypatch):
    fl = _flat("prusa-mk3s", 1.1)
    m, nv = fl.S.size, fl.sv.size
    monkeypatch.setattr(lc, "MAX_ACTIVE_ITERS", 2)
    got = lc.solve_flat(fl, np.zeros(nv, bool), np.zeros(nv), np.zeros(m, bool), pieces=False)
    g = ref_solve_flat.__globals__
    old = g["MAX_ACTIVE_ITERS"]
    g["MAX_ACTIVE_ITERS"] = 2
    try:
        want = ref_solve_flat(fl, np.zeros(nv, bool), np.zeros(nv), np.zeros(m, bool), pieces=False)
    finally:
        g["MAX_ACTIVE_ITERS"] = old
    assert not want.conv.all()
    _compare(got, want, False)


# ---------------------------------------------------------------- _step_law
def _step_batches(monkeypatch, prof="prusa-mk3s"):
    calls = []
    orig = lc._step_law

    def rec(*a):
        calls.append([np.array(x) for x in a])
        return orig(*a)
    monkeypatch.setattr(lc, "_step_law", rec)
    fl = _flat(prof, 1.02)
    lc.solve_flat(fl, lc.cold_binding(fl), np.zeros(fl.sv.size), np.zeros(fl.S.size, bool), pieces=False)
    monkeypatch.setattr(lc, "_step_law", orig)
    return calls


def test_step_law_is_the_line_law_where_read(monkeypatch):
    calls = _step_batches(monkeypatch)
    assert len(calls) >= 3
    rng = np.random.default_rng(4)
    for a in calls:
        lite, full = lc._step_law(*a), LineLaw(*a)
        assert "lite" in lite._c and "Ig1" not in lite._c
        for f in ("L", "T", "beta", "v0", "v1", "gamma", "_wbar", "_delta", "_A"):
            _eq(getattr(lite, f), getattr(full, f), f)
        for k in ("small", "gs", "n", "sh2"):
            _eq(lite._c[k], full._c[k], k)
        for x, y in zip(lite.end_accels(), full.end_accels(), strict=True):
            _eq(x, y, "end_accels")
        idx = np.sort(rng.choice(a[0].size, size=max(1, a[0].size // 2), replace=False))
        lt, ft = lite.take(idx), full.take(idx)
        s = lt.L * rng.uniform(0.05, 0.95, idx.size)
        t1, t2 = time_of_distance(lt, s), time_of_distance(ft, s)
        _eq(t1, t2, "time_of_distance")
        _eq(lt.eval(t1, "v")[1], ft.eval(t2, "v")[1], "eval v")
        for x, y in zip(_times_and_speeds(lt, s), _times_and_speeds(ft, s), strict=True):
            _eq(x, y, "_times_and_speeds")
    # mutant: the law's mean-speed term reassociated (T v0 / 2 + T v1 / 2) is told apart
    # by the checks above (n itself, ~1/12 + O(γ²), is the same in any order of its terms)
    differs = False
    for a in calls:
        mut = lc._step_law(*a)
        mut._wbar = mut.T * mut.v0 / 2 + mut.T * mut.v1 / 2
        mut._A = mut.L - mut._wbar
        full = LineLaw(*a)
        s = full.L * 0.37
        differs |= not np.array_equal(_bits(time_of_distance(mut, s)), _bits(time_of_distance(full, s)))
    assert differs


def test_step_law_falls_back_to_the_whole_law():
    L = np.array([1.0, 0.5])
    T = np.array([0.02, 0.03])
    va, vb = np.array([30.0, 20.0]), np.array([25.0, 10.0])
    big = lc._step_law(L, T, (T / 10.0) ** 2, va, vb)        # γ = 10: the other branch
    assert "Ig1" in big._c and "lite" not in big._c
    for bad, msg in (((L, -T, T, va, vb), "T must be finite"), ((L, T, 0 * T, va, vb), "beta must be > 0"),
                     ((L * np.nan, T, T, va, vb), "L, v0, v1 must be finite")):
        with pytest.raises(ValueError, match=msg):
            lc._step_law(*bad)
        with pytest.raises(ValueError, match=msg):
            LineLaw(*bad)


# ---------------------------------------------------------------- piece_cumsum
@needs_core
def test_piece_cumsum_is_the_grid_cumsum():
    rng = np.random.default_rng(7)
    npc = rng.integers(1, 30, 400)
    x = rng.uniform(1e-4, 0.05, npc.sum()) * 10.0 ** rng.integers(-3, 3, npc.sum())
    x[5], x[77] = np.inf, np.nan
    off = np.concatenate([[0], np.cumsum(npc)]).astype(np.int64)
    owner = np.repeat(np.arange(npc.size), npc)
    local = np.arange(x.size) - off[:-1][owner]
    grid = np.zeros((npc.size, int(npc.max())))
    grid[owner, local] = x
    want = np.cumsum(grid, axis=1)[owner, local]
    got = np.empty(x.size)
    lc.CORE_MOD.piece_cumsum(x, off, got)
    _eq(got, want)
    # mutant: one running sum over all pieces less its value before each chain's start
    y = np.where(np.isfinite(x), x, 1.0)
    got = np.empty(y.size)
    lc.CORE_MOD.piece_cumsum(y, off, got)
    flat = np.cumsum(y)
    mut = flat - np.concatenate([[0.0], flat])[off[:-1]][owner]
    assert np.allclose(mut, got) and not np.array_equal(_bits(mut), _bits(got))
    with pytest.raises(ValueError):
        lc.CORE_MOD.piece_cumsum(x, off[:-1], got)
    with pytest.raises(ValueError):
        lc.CORE_MOD.piece_cumsum(x, off[::-1].copy(), got)


# ---------------------------------------------------------------- tent rows
def _tent_cases():
    rng = np.random.default_rng(11)
    for n in (1, 2, 3, 7, 16, 33):
        k = 50
        need = rng.uniform(0.1, 200.0, (k, n)) * rng.choice([1.0, 1e-3, 1e3], (k, 1))
        step = rng.uniform(0.05, 20.0, k)
        vf = rng.uniform(1.0, 300.0, k)
        yield need, vf, step
        yield need, float(vf[0]), float(step[0])


@pytest.mark.parametrize("core", [None, False])
def test_tent_rows_same_bits_as_9bb98a8(core):
    if core is None and not HAS_CORE:
        pytest.skip("no chain core")
    for need, vf, step in _tent_cases():
        _eq(chains._tent_rows(need, vf, step, core=core), ref_tent_feeds_rows(need, vf, step))
    need, vf, step = next(_tent_cases())
    edges = [(need, vf, np.inf), (need, vf, np.where(np.arange(step.size) % 3, step, np.inf)),
             (need, vf, np.where(np.arange(step.size) % 4, step, 0.0)), (np.where(need > 100, np.nan, need), vf, step),
             (-need, vf, step), (need, -vf, step), (need, vf, -step), (need, vf * np.inf, step)]
    for nd, v, s in edges:
        with np.errstate(invalid="ignore"):
            _eq(chains._tent_rows(nd, v, s, core=core), ref_tent_feeds_rows(nd, v, s))


@needs_core
def test_tent_rows_core_declines_and_mutant():
    need, vf, step = next(_tent_cases())
    out = np.empty(need.shape)
    assert lc.CORE_MOD.tent_rows(need.copy(), vf.copy(), step.copy(), out)
    for bad in (np.inf, np.nan, 0.0, -1.0):
        s = step.copy()
        s[3] = bad
        assert not lc.CORE_MOD.tent_rows(need.copy(), vf.copy(), s, out)
        nd = need.copy()
        nd[2, 0] = bad
        assert not lc.CORE_MOD.tent_rows(nd, vf.copy(), step.copy(), out)
    # mutant: the envelope by running differences (out[k] = max(need[k], out[k - 1] - step)) is told apart
    need, vf, step = [c for c in _tent_cases() if c[0].shape[1] == 16][0]
    want = ref_tent_feeds_rows(need, vf, step)
    run = np.array(need)
    run[:, 0] = np.maximum(run[:, 0], vf + step - step)
    for j in range(1, run.shape[1]):
        run[:, j] = np.maximum(run[:, j], run[:, j - 1] - step)
    run[:, -1] = np.maximum(run[:, -1], vf + step - step)
    for j in range(run.shape[1] - 2, -1, -1):
        run[:, j] = np.maximum(run[:, j], run[:, j + 1] - step)
    assert np.allclose(run, want) and not np.array_equal(_bits(run), _bits(want))


@needs_core
@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_candidate_table_with_and_without_the_core(prof, monkeypatch):
    """chains._figures (the table and the chains' memories) with the chain core and with
    the numpy code throughout (CORE_MOD None: full LineLaw, grid cumsum, tent_feeds_rows)."""
    from test_speed_chain3_flat import _chains, _run

    from gcode_opt.segments import SegmentRules
    strokes, pin, rows, profile = _chains(prof)
    rows = rows[:150]
    rules = SegmentRules.for_profile(profile, 10)
    Tc = pin.T_orig[rows, None] * np.array(chains.CHAIN_T_RATIOS)[None, :]
    bc = (Tc / chains.GAMMA_MIN) ** 2
    got, got_memo = _run(chains._figures, strokes, rows, pin, profile, rules, Tc, bc)
    monkeypatch.setattr(lc, "CORE_MOD", None)
    want, want_memo = _run(chains._figures, strokes, rows, pin, profile, rules, Tc, bc)
    assert got[0].sum() > 2 * rows.size
    for a, b in zip(got, want, strict=True):
        _eq(a, b)
    assert got_memo == want_memo
