"""Session 21 (chainsolve, issue 8): the chains' active-set steps cheaper, the same bits.

- laws/_chaincore.c fixed_knots (solve_fixed's knots and pieces in one C call) against a
  verbatim copy of solve_fixed's numpy knot building at d3559db (REFERENCE below) and
  against _knots_numpy, on every solve_fixed call of real chains (the bundled full-speed
  gyroid, cold and warm-started);
- tod_solve (now streamed chunk by chunk, prims.shc(γ/4) once per law) against the numpy
  time of distance, also when it runs out of steps (max_iter small: the laws still going);
- _seen with `want` against the verbatim old _seen on the chains it answers for;
- _flat_figures(full=False) through _figure_law against the verbatim old _flat_figures;
- solve_flat as a whole: with the chain core and without it (the numpy code everywhere),
  bit for bit."""
import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.laws import chain as lc
from gcode_opt.laws.line import LineLaw, end_speeds

from test_speed_chains import _chain_problems  # noqa: E402

needs_core = pytest.mark.skipif(lc.CORE_MOD is None, reason=f"the chain core is not used here ({lc.CORE_WHY})")


def _bits(x):
    x = np.asarray(x)
    return x.view(np.uint8) if x.dtype == bool else x.view(np.int64)


def _eq(x, y):
    x, y = np.asarray(x), np.asarray(y)
    return x.shape == y.shape and np.array_equal(_bits(x), _bits(y))


# ------------------------------------------------------------------ REFERENCE (d3559db, verbatim)
def ref_knots(self, active, bound, vt, warm):
    """laws/chain.py _Flat.solve_fixed at d3559db, its lines up to the share_time call and
    the monotone kj, verbatim (returns what the new code's knots give)."""
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
    bv = bound[vi]
    cnt = np.cumsum(bv)
    j = cnt - np.concatenate([[0], cnt])[bvoff[:-1]][rank]
    kj = koff[:-1][rank] + j
    return ks, kv, kt0, koff, owner, p0, L, va, vb, T0, kj


def ref_seen(hist, vi, new, rank, na):
    out = np.zeros(na, bool)
    for h in hist:
        out |= np.bincount(rank, h[vi] != new, na) == 0
    return out


def ref_flat_figures(res, full=True):
    law = LineLaw(res.L, res.T, res.beta, res.v0, res.v1)
    iv, ia = law.integrals()
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
# ------------------------------------------------------------------ end of REFERENCE


def _flats(prof):
    """(fl, bound, vt, warm) of a cold solve of the gyroid's chains and of a warm one at a
    nearby duration (the candidate table's way)."""
    sts, T0, profile = _chain_problems(prof)
    T = T0 * 1.03
    probs = chains._problems(sts, T, (T / chains.GAMMA_MIN) ** 2, profile)
    fl = lc._Flat(probs)
    cold = (fl, lc.cold_binding(fl), np.zeros(fl.sv.size), np.zeros(fl.S.size, bool))
    res = lc.solve_flat(fl, cold[1].copy(), cold[2], cold[3])
    T2 = T * 1.02
    fl2 = fl.with_T(T2, (T2 / chains.GAMMA_MIN) ** 2)
    warm = (fl2, res.bound.copy(), res.vert_t * 1.02, np.ones(fl.S.size, bool))
    return [cold, warm]


def _steps(prof, monkeypatch):
    """Every solve_fixed call's arguments (copies) of both solves."""
    calls = []
    orig = lc._Flat.solve_fixed

    def rec(self, active, bound, vt, warm):
        calls.append((self, active.copy(), bound.copy(), vt.copy(), warm.copy()))
        return orig(self, active, bound, vt, warm)
    monkeypatch.setattr(lc._Flat, "solve_fixed", rec)
    for fl, b, vt, w in _flats(prof):
        lc.solve_flat(fl, b.copy(), vt, w)
    monkeypatch.undo()
    return calls


def _core_knots(fl, active, bound, vt, warm, core=None):
    na = active.size
    nv = fl.nv[active]
    on = np.zeros(fl.S.size, bool)
    on[active] = True
    vi = np.flatnonzero(on[fl.ch])
    bvoff = np.concatenate([[0], np.cumsum(nv)]).astype(int)
    rank = np.repeat(np.arange(na), nv)
    got = fl._knots_core(core or lc.CORE_MOD, active, vi, bound[vi], bvoff, vt, warm)
    num = fl._knots_numpy(active, vi, rank, bvoff, nv, bound, vt, warm)
    return got, num


@needs_core
@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_fixed_knots_same_numbers_as_the_old_numpy_code(prof, monkeypatch):
    calls = _steps(prof, monkeypatch)
    assert len(calls) >= 4
    nwarm = 0
    for fl, active, bound, vt, warm in calls:
        assert fl.monotone
        want = ref_knots(fl, active, bound, vt, warm)
        got, num = _core_knots(fl, active, bound, vt, warm)
        assert got is not None
        for g, n, w in zip(got, num[:10] + (want[10],), want, strict=True):
            assert _eq(g, w)
            assert _eq(n, w)
        nwarm += int(warm[active].any())
    assert nwarm >= 2                       # the warm start's T0 was exercised
    # the check is sharp: a T one part in 2^40 off changes the first guesses it compares
    fl, active, bound, vt, warm = max(calls, key=lambda c: c[1].size)
    cold = np.zeros_like(warm)
    want = ref_knots(fl, active, bound, vt, cold)
    alt = lc._Flat.of_arrays(fl.sv, fl.cv, fl.nv, fl.S, fl.T, fl.beta, fl.v0, fl.v1)
    alt.T = fl.T * (1 + 2 ** -40)          # a perturbed input: the check sees a changed T0
    got, _ = _core_knots(alt, active, bound, vt, cold)
    assert not _eq(got[9], want[9])
    # (mutants tried by hand, session 21: T0 = T (L / S) in fixed_knots; the S1 series' s4 at
    # γ/4.000000001 in shc_quarter; _seen's sub = ~want; _figure_law's A² Ig1 as A (A Ig1):
    # each failed the checks here)


@needs_core
def test_tod_solve_out_of_steps_and_in_full_same_bits():
    for fl, b, vt, w in _flats("prusa-mk3s"):
        res = lc.solve_flat(fl, b.copy(), vt, w)
        law = lc._step_law(res.L, res.T, res.beta, res.v0, res.v1)
        # the distance to mid-piece and to a quarter of each piece
        for frac in (0.5, 0.25, 0.999):
            x = res.L * frac
            for mi in (1, 2, 3, 4, 200):
                t, v = lc._tod_core(lc.CORE_MOD, law, x, max_iter=mi)
                want_t = lc._time_of_distance(law, x, max_iter=mi)
                assert _eq(t, want_t), (frac, mi)
                assert _eq(v, lc._eval(law, want_t, "v")[1]), (frac, mi)


def test_seen_with_want_matches_the_old_seen():
    rng = np.random.default_rng(21)
    for _ in range(200):
        na = int(rng.integers(1, 12))
        nv = rng.integers(0, 6, na)
        nvt = int(nv.sum()) + 3
        vi = np.sort(rng.choice(nvt, int(nv.sum()), replace=False))
        rank = np.repeat(np.arange(na), nv)
        hist = [rng.random(nvt) < 0.5 for _ in range(int(rng.integers(1, 6)))]
        new = hist[int(rng.integers(len(hist)))][vi].copy() if rng.random() < 0.5 else rng.random(vi.size) < 0.5
        want = rng.random(na) < 0.5
        ref = ref_seen(hist, vi, new, rank, na)
        assert _eq(lc._seen(hist, vi, new, rank, na), ref)
        assert _eq(lc._seen(hist, vi, new, rank, na, want) & want, ref & want)


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_flat_figures_lite_same_bits_as_the_old_code(prof):
    for fl, b, vt, w in _flats(prof):
        res = lc.solve_flat(fl, b.copy(), vt, w)          # pieces kept
        for full in (False, True):
            a, r = lc.FlatLaws(fl), lc.FlatLaws(fl)
            for x in (a, r):
                x.L, x.T, x.beta, x.v0, x.v1, x.a0, x.a1, x.poff = (res.L, res.T, res.beta, res.v0, res.v1,
                                                                     res.a0, res.a1, res.poff)
            lc._flat_figures(a, full)
            ref_flat_figures(r, full)
            for f in ("iv", "ia", "peak_v", "min_v", "peak_a"):
                if getattr(r, f) is None:
                    assert getattr(a, f) is None
                else:
                    assert _eq(getattr(a, f), getattr(r, f)), (f, full)
    # the lite law is used here (every law in the series branch) and its ∫ṡ² is integrals()'
    law = lc._figure_law(res.L, res.T, res.beta, res.v0, res.v1)
    assert law is not None
    assert _eq(law._iv, LineLaw(res.L, res.T, res.beta, res.v0, res.v1).integrals()[0])
    # not the series branch (γ >= 4): no lite law
    assert lc._figure_law(res.L, res.T * 1e4, res.beta, res.v0, res.v1) is None


@needs_core
@pytest.mark.parametrize("pieces", [True, False])
def test_solve_flat_with_and_without_the_core_same_bits(pieces, monkeypatch):
    fields = ("vert_v", "vert_t", "conv", "lam", "iv", "ia", "peak_v", "min_v", "peak_a", "L", "T", "beta",
              "v0", "v1", "a0", "a1", "ks", "kv", "kt", "koff", "poff", "bound")
    for fl, b, vt, w in _flats("voron24"):
        got = lc.solve_flat(fl, b.copy(), vt, w, pieces)
        with monkeypatch.context() as m:
            m.setattr(lc, "CORE_MOD", None)
            want = lc.solve_flat(fl, b.copy(), vt, w, pieces)
        n = 0
        for f in fields:
            x, y = getattr(got, f, None), getattr(want, f, None)
            assert (x is None) == (y is None), f
            if x is not None:
                assert _eq(x, y), f
                n += 1
        assert n >= (len(fields) if pieces else 7)
