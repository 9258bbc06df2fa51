"""Session 22 (chainlaw, issue 8): laws/chain.solve_flat's glue in the chain core, the same bits.

New C functions at the end of laws/_chaincore.c: step_law (the lite law of solve_fixed's
pieces but numpy's shc), step_accels (end_accels after np.cosh), tod_prep (_tod_core's
inputs of law.take(pj), no take), active_step (solve_flat's active-set bookkeeping of a
step: violations, multipliers, release, cycling, done; bound, vt, warm), fig_a .. fig_d and
row_sums (_flat_figures(full=False): numpy's sinh and arctanh in between).

Checked against a verbatim copy of solve_flat, _seen, solve_fixed, _step_law, _Step,
FlatLaws and _flat_figures at 479aedb (REFERENCE below, run in a copy of the module's
namespace, with the compiled share_time / tod_solve / fixed_knots they call), bit for bit,
on: real chains of the bundled gyroids (the full-speed one cold and warm; every solve_flat
call of the candidate table of prusa_gyroid.gcode, prusa-mk3s and voron24); the active set
cut short (MAX_ACTIVE_ITERS 1, 2); multipliers forced negative (release, 'seen before',
release only the worst, give up: the cycling rules in C); without the core (the numpy
lines). Mutants (hand-made, see the report) fail these tests."""
import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.laws import chain as lc
from gcode_opt.laws.line import LineLaw, end_speeds  # noqa: F401  (the reference's names)

from test_speed21_chainsolve_core import _flats  # noqa: E402

needs_core = pytest.mark.skipif(lc.CORE_MOD is None, reason=f"the chain core is not used here ({lc.CORE_WHY})")

FIELDS = ("vert_v", "vert_t", "conv", "lam", "iv", "ia", "peak_v", "min_v", "peak_a", "L", "T", "beta",
          "v0", "v1", "a0", "a1", "ks", "kv", "kt", "koff", "poff", "bound")


def _bits(x):
    x = np.asarray(x)
    return x.view(np.uint8) if x.dtype == bool else x.view(np.int64)


def _eq(x, y):
    x, y = np.asarray(x), np.asarray(y)
    return x.shape == y.shape and x.dtype == y.dtype and np.array_equal(_bits(x), _bits(y))


# ------------------------------------------------------------------ REFERENCE (479aedb, verbatim)
# laws/chain.py at 479aedb: solve_flat, _seen, _Flat.solve_fixed (dedented), _step_law, _Step,
# FlatLaws, _flat_figures; executed in a copy of the module's namespace (_ref_ns).
REF_SRC = r'''
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
    for it in range(MAX_ACTIVE_ITERS):
        if active.size == 0:
            break
        na = active.size
        st = fl.solve_fixed(active, bound, vt, warm)
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


def solve_fixed(self, active, bound, vt, warm):
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
    bv = bound[vi]
    kn = None
    if CORE_MOD is not None:
        kn = self._knots_core(CORE_MOD, active, vi, bv, bvoff, vt, warm)
    if kn is None:
        kn = self._knots_numpy(active, vi, rank, bvoff, nv, bound, vt, warm)
    ks, kv, kt0, koff, owner, p0, L, va, vb, T0, kj_mono = kn
    npc = np.diff(koff) - 1                        # pieces per chain
    Tc = self.T[active]
    beta = self.beta[active][owner]
    Tj, lam, conv = _share_time(L, beta, va, vb, owner, Tc, T0)
    law = _step_law(L, Tj, beta, va, vb)
    a0, a1 = law.end_accels()                      # s̈ at both ends of every piece
    # knot times: each chain's cumulative sum of its own pieces (row by row)
    poff = koff[:-1] - np.arange(na)
    kt = np.zeros(ks.size)
    if CORE_MOD is not None and Tj.dtype == np.float64:    # the same sums, chain by chain in C
        pc = np.empty(Tj.size)
        CORE_MOD.piece_cumsum(np.ascontiguousarray(Tj), np.append(poff, Tj.size).astype(np.int64), pc)
        kt[p0 + 1] = pc
    else:
        local = np.arange(Tj.size) - poff[owner]
        P = int(npc.max()) if na else 0
        grid = np.zeros((na, P))
        grid[owner, local] = Tj
        kt[p0 + 1] = np.cumsum(grid, axis=1)[owner, local]
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
    v, t = self.cv[vi].copy(), kt[kj]              # exact at the binding vertices (piece ends)
    free = np.flatnonzero(~bv)                     # the others: in their piece's law (each
    kf = kj[free]                                  # element's Newton is its own: the batch's
    pj = kf - rank[free]                           # make-up changes no figure)
    vlaw = law.take(pj)                            # = LineLaw(L[pj], Tj[pj], beta[pj], ...)
    tl, v[free] = _times_and_speeds(vlaw, self.sv[vi[free]] - ks[kf])
    t[free] = kt[kf] + tl
    return _Step(self, active, vi, rank, bvoff, v, t,
                 ks, kv, kt, koff, L, Tj, beta, va, vb, a0, a1, owner, lam, conv)


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


class _Step:
    """One active-set step's laws (solve_fixed), flat; law(r, c) makes chain c's ChainLaw
    (r: its place in the step)."""

    def __init__(self, fl, active, vi, rank, voff, vert_v, vert_t, ks, kv, kt, koff, L, Tj, beta, va, vb,
                 a0, a1, owner, lam, conv):
        self.fl, self.active, self.vi, self.rank, self.voff = fl, active, vi, rank, voff
        self.vert_v, self.vert_t = vert_v, vert_t
        self.ks, self.kv, self.kt, self.koff = ks, kv, kt, koff
        self.L, self.Tj, self.beta, self.va, self.vb, self.a0, self.a1 = L, Tj, beta, va, vb, a0, a1
        self.owner, self.lam, self.conv = owner, lam, conv

    def multipliers(self):
        """Each binding vertex's multiplier (as _multipliers), all chains at once: s̈ just
        after minus s̈ just before, over the chain's acceleration scale; 0 unless negative."""
        na = self.active.size
        o = self.owner
        scale = np.zeros(na)
        np.maximum.at(scale, o, np.abs(self.a0))
        np.maximum.at(scale, o, np.abs(self.a1))
        scale = np.maximum(scale, 1e-9)
        same = o[1:] == o[:-1]                          # consecutive pieces of one chain
        jump = (self.a0[1:] - self.a1[:-1])[same]
        mu = jump / scale[o[1:][same]]
        return np.where(mu < -MU_TOL_R, mu, 0.0)

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
        if not self.pieces:     # what close reads for the figures of the candidate table (no a0, a1, knots)
            self._parts.append((st.active[st.owner[pd]], st.L[pd], st.Tj[pd], st.beta[pd], st.va[pd], st.vb[pd]))
            return
        self._parts.append((st.active[st.owner[pd]], st.L[pd], st.Tj[pd], st.beta[pd], st.va[pd], st.vb[pd],
                            st.a0[pd], st.a1[pd], np.repeat(st.active, nk)[kd], st.ks[kd], st.kv[kd], st.kt[kd]))

    def close(self, bound, pieces=True):
        """Every chain taken: pieces and knots in chain order, the figures (_flat_figures);
        pieces False (FlatLaws(fl, False)): only the figures the candidate table reads (iv,
        peak_v, min_v; ia and peak_a are None), then drop the pieces."""
        cat = [np.concatenate(x) for x in zip(*self._parts)]
        del self._parts
        po = np.argsort(cat[0], kind="stable")
        m = self.fl.S.size
        self.poff = np.concatenate([[0], np.cumsum(np.bincount(cat[0], None, m))]).astype(int)
        self.bound = bound
        if not (pieces and self.pieces):
            self.L, self.T, self.beta, self.v0, self.v1 = (x[po] for x in cat[1:6])
            _flat_figures(self, full=False)
            for f in ("L", "T", "beta", "v0", "v1", "poff"):
                delattr(self, f)
            return
        ko = np.argsort(cat[8], kind="stable")
        self.L, self.T, self.beta, self.v0, self.v1, self.a0, self.a1 = (x[po] for x in cat[1:8])
        self.ks, self.kv, self.kt = (x[ko] for x in cat[9:12])
        self.koff = self.poff + np.arange(m + 1)          # a chain's knots: its pieces + 1
        _flat_figures(self)

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


def _flat_figures(res, full=True):
    """∫ṡ², ∫s̈², peak and least speed, peak |s̈| of the final laws (not of the active-set
    steps before them), all pieces in one batch; each chain's sums as np.sum of its own
    pieces rounds them (row sums of the chains with the same number of pieces).  full
    False: ∫s̈² and peak |s̈| are not made (None)."""
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
    for k in np.unique(npc).tolist():
        c = np.flatnonzero(npc == k)
        ix = first[c][:, None] + np.arange(k)
        res.iv[c] = np.sum(iv[ix], axis=1)
        if full:
            res.ia[c] = np.sum(ia[ix], axis=1)
'''
# ------------------------------------------------------------------ end of REFERENCE


def _ref_ns(max_iters=None):
    ns = dict(vars(lc))
    exec(REF_SRC, ns)
    if max_iters is not None:
        ns["MAX_ACTIVE_ITERS"] = max_iters

    class RefFlat(lc._Flat):
        solve_fixed = ns["solve_fixed"]
    ns["RefFlat"] = RefFlat
    return ns


def _ref_solve(ns, fl, bound, vt, warm, pieces=True):
    rf = object.__new__(ns["RefFlat"])
    rf.__dict__.update(fl.__dict__)
    return ns["solve_flat"](rf, bound, vt, warm, pieces)


def _same(got, want, pieces):
    n = 0
    for f in FIELDS:
        x, y = getattr(got, f, None), getattr(want, f, None)
        assert (x is None) == (y is None), f
        if x is not None:
            assert _eq(x, y), f
            n += 1
    assert n >= (len(FIELDS) if pieces else 8)


class _Count:
    """The chain core with a count of the calls of each function."""

    def __init__(self, mod):
        self.mod, self.n = mod, {}

    def __getattr__(self, name):
        f = getattr(self.mod, name)

        def w(*a):
            self.n[name] = self.n.get(name, 0) + 1
            return f(*a)
        return w


def _table_calls(prof, monkeypatch):
    """The arguments of every solve_flat call of the candidate table of the bundled gyroid."""
    import os
    import tempfile

    from gcode_opt.cli import main
    calls = []
    orig = chains.solve_flat

    def rec(fl, bound, vt, warm, pieces=True):
        calls.append((fl, bound.copy(), vt.copy(), warm.copy(), pieces))
        return orig(fl, bound, vt, warm, pieces)
    here = os.path.dirname(os.path.abspath(__file__))
    src = os.path.join(here, "..", "sample_gcode", "prusa_gyroid.gcode")
    with monkeypatch.context() as m, tempfile.TemporaryDirectory() as d:
        m.setattr(chains, "solve_flat", rec)
        assert main(["process", src, "-o", os.path.join(d, "o.gcode"), "--profile", prof, "-q"]) in (0, None)
    return calls


@needs_core
@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
@pytest.mark.parametrize("pieces", [True, False])
def test_solve_flat_same_bits_as_479aedb(prof, pieces, monkeypatch):
    ns = _ref_ns()
    cnt = _Count(lc.CORE_MOD)
    for fl, b, vt, w in _flats(prof):
        want = _ref_solve(ns, fl, b.copy(), vt, w, pieces)
        with monkeypatch.context() as m:
            m.setattr(lc, "CORE_MOD", cnt)
            got = lc.solve_flat(fl, b.copy(), vt, w, pieces)
        _same(got, want, pieces)
    # the new C code ran (tod_prep's work is tod_at's since session 35, tod_at_into's since 41;
    # fig_d's is fig_need's and fig_d_at's since 43)
    need = {"step_law", "step_accels", "tod_at_into", "active_step"} | (
        {"fig_a", "fig_need", "fig_d_at", "row_sums"} if not pieces else set())
    assert need <= set(cnt.n), cnt.n


@needs_core
@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_candidate_table_calls_same_bits_as_479aedb(prof, monkeypatch):
    calls = _table_calls(prof, monkeypatch)
    assert len(calls) >= 5 and sum(c[0].sv.size for c in calls) > 5000
    ns = _ref_ns()
    for i, (fl, b, vt, w, pieces) in enumerate(calls):
        for p in ([pieces, True] if i == 0 else [pieces]):
            _same(lc.solve_flat(fl, b.copy(), vt, w, p), _ref_solve(ns, fl, b.copy(), vt, w, p), p)


@needs_core
@pytest.mark.parametrize("iters", [1, 2])
def test_cut_short_same_bits(iters, monkeypatch):
    ns = _ref_ns(iters)
    monkeypatch.setattr(lc, "MAX_ACTIVE_ITERS", iters)
    for pieces in (False, True):
        for fl, b, vt, w in _flats("prusa-mk3s"):
            # (session 29: from the cold start's binding set (COLD_BIND_R) every chain here now
            # ends within two steps; from no binding vertex some do not)
            cut = 0
            for b0 in (b, np.zeros_like(b)):
                got = lc.solve_flat(fl, b0.copy(), vt, w, pieces)
                want = _ref_solve(ns, fl, b0.copy(), vt, w, pieces)
                _same(got, want, pieces)
                cut += (~want.conv).sum()
            assert cut > 0          # some chains were cut short


@needs_core
@pytest.mark.parametrize("tied", [False, True])
def test_forced_release_and_cycling_same_bits(tied, monkeypatch):
    """Every binding vertex wants release (a negative multiplier growing with its position,
    or all the same: the worst is the first): release, re-add, 'seen before', release only
    the worst, give up; the C bookkeeping (given the forced multipliers) as the reference's."""
    def forced(self):
        inner = np.ones(self.ks.size, bool)
        inner[self.koff[:-1]] = inner[self.koff[1:] - 1] = False
        return np.full(int(inner.sum()), -1.0) if tied else -(1.0 + self.ks[inner])
    ns = _ref_ns()
    ns["_Step"].multipliers = forced
    cnt = _Count(lc.CORE_MOD)
    monkeypatch.setattr(lc._Step, "multipliers", forced)
    monkeypatch.setattr(lc, "CORE_MOD", cnt)
    n_unconv = 0
    for fl, b, vt, w in _flats("voron24"):
        got = lc.solve_flat(fl, b.copy(), vt, w, False)
        want = _ref_solve(ns, fl, b.copy(), vt, w, False)
        _same(got, want, False)
        n_unconv += int((~want.conv).sum())
    assert n_unconv >= 10 and cnt.n.get("active_step", 0) > 0


@needs_core
@pytest.mark.parametrize("pieces", [True, False])
def test_without_the_core_same_bits(pieces, monkeypatch):
    ns = _ref_ns()
    for fl, b, vt, w in _flats("voron24"):
        want = _ref_solve(ns, fl, b.copy(), vt, w, pieces)
        with monkeypatch.context() as m:
            m.setattr(lc, "CORE_MOD", None)
            got = lc.solve_flat(fl, b.copy(), vt, w, pieces)
        _same(got, want, pieces)


@needs_core
def test_row_sums_are_numpy_sums():
    rng = np.random.default_rng(7)
    lens = np.array([0, 1, 2, 7, 8, 9, 15, 16, 17, 127, 128, 129, 130, 255, 256, 300, 1000, 3], np.int64)
    x = rng.standard_normal(int(lens.sum())) * 10.0 ** rng.integers(-8, 8, int(lens.sum()))
    off = np.concatenate([[0], np.cumsum(lens)]).astype(np.int64)
    out = np.empty(lens.size)
    lc.CORE_MOD.row_sums(x, off, out)
    want = np.array([np.sum(x[a:b]) for a, b in zip(off[:-1], off[1:])])
    assert _eq(out, want)
    for k in (3, 9, 130):                      # as _flat_figures summed rows of one count
        rows = rng.standard_normal((20, k)) * 10.0 ** rng.integers(-8, 8, (20, k))
        o = np.empty(20)
        lc.CORE_MOD.row_sums(np.ascontiguousarray(rows).ravel(), np.arange(21, dtype=np.int64) * k, o)
        assert _eq(o, np.sum(rows, axis=1))
    with pytest.raises(ValueError):
        lc.CORE_MOD.row_sums(x, off[::-1].copy(), out)


@needs_core
def test_fallbacks_decline_cleanly():
    """step_law and fig_a decline (the numpy code runs) on inputs LineLaw refuses or a law
    outside the series branch; the figures then are the numpy code's."""
    L, T, beta, va, vb = (np.array([1.0, 2.0]), np.array([0.05, 0.04]), np.array([0.25, 0.16]),
                          np.array([10.0, 20.0]), np.array([20.0, 10.0]))
    assert lc._step_law_core(lc.CORE_MOD, L, T, beta, va, vb) is not None
    assert lc._step_law_core(lc.CORE_MOD, L, T * 1e3, beta, va, vb) is None        # γ >= 4
    assert lc._step_law_core(lc.CORE_MOD, L, -T, beta, va, vb) is None
    assert lc._step_law_core(lc.CORE_MOD, L, T, beta, np.array([np.nan, 1.0]), vb) is None
    law, ref = lc._step_law_core(lc.CORE_MOD, L, T, beta, va, vb), _ref_ns()["_step_law"](L, T, beta, va, vb)
    for f in ("gamma", "_wbar", "_delta", "_A"):
        assert _eq(getattr(law, f), getattr(ref, f)), f
    for k in ("small", "gs", "n", "sh2", "lite"):
        assert _eq(law._c[k], ref._c[k]), k
    for x, y in zip(lc._end_accels(law), ref.end_accels()):
        assert _eq(x, y)

    class R:
        pass
    r = R()
    r.L, r.T, r.beta, r.v0, r.v1, r.poff = L, T * 1e3, beta, va, vb, np.array([0, 1, 2])
    assert not lc._flat_figures_core(lc.CORE_MOD, r)
    r.T, r.poff = T, np.array([0, 0, 2])                                        # a chain without pieces
    assert not lc._flat_figures_core(lc.CORE_MOD, r)
    r.poff = np.array([0, 1, 2])
    assert lc._flat_figures_core(lc.CORE_MOD, r)
    r2 = R()
    r2.L, r2.T, r2.beta, r2.v0, r2.v1, r2.poff = L, T, beta, va, vb, np.array([0, 1, 2])
    _ref_ns()["_flat_figures"](r2, full=False)
    for f in ("iv", "peak_v", "min_v"):
        assert _eq(getattr(r, f), getattr(r2, f)), f


@needs_core
def test_lite_laws_and_figures_over_the_whole_series_branch():
    """step_law and the figures' C passes against the reference's _step_law, end_accels and
    _flat_figures on laws of γ all over the series branch (0 .. 4: the batch's series terms
    grow with its largest γ), batches of small and large γ."""
    rng = np.random.default_rng(11)
    ns = _ref_ns()

    class R:
        pass
    for gmax in (0.05, 0.3, 1.0, 2.0, 3.9):
        P = 400
        T = rng.uniform(0.01, 0.2, P)
        gam = rng.uniform(0.0, gmax, P)
        gam[0] = gmax
        beta = (T / np.maximum(gam, 1e-3)) ** 2
        L = rng.uniform(0.1, 5.0, P)
        va, vb = rng.uniform(0, 2, P) * L / T, rng.uniform(0, 2, P) * L / T
        law, ref = lc._step_law_core(lc.CORE_MOD, L, T, beta, va, vb), ns["_step_law"](L, T, beta, va, vb)
        assert law is not None
        for f in ("gamma", "_wbar", "_delta", "_A"):
            assert _eq(getattr(law, f), getattr(ref, f)), (f, gmax)
        for k in ("gs", "n", "sh2"):
            assert _eq(law._c[k], ref._c[k]), (k, gmax)
        for x, y in zip(lc._end_accels(law), ref.end_accels()):
            assert _eq(x, y), gmax
        poff = np.concatenate([[0], np.sort(rng.choice(np.arange(1, P), 60, replace=False)), [P]]).astype(np.int64)
        r, r2 = R(), R()
        for o in (r, r2):
            o.L, o.T, o.beta, o.v0, o.v1, o.poff = L, T, beta, va, vb, poff
        assert lc._flat_figures_core(lc.CORE_MOD, r)
        ns["_flat_figures"](r2, full=False)
        for f in ("iv", "peak_v", "min_v"):
            assert _eq(getattr(r, f), getattr(r2, f)), (f, gmax)
