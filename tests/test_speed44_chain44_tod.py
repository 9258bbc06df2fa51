"""Session 44 (chain44): the chain core's time-of-distance iteration (laws/_chaincore.c)
does its per-law bookkeeping in vector passes: tod_step takes the laws going on (act >= 0)
and moves their t and τ in place, and gives the largest (γx)² of those not done (the S1
terms of the next step) as bits; tod_at_into makes its laws' inputs, their numbers and τ in
one pass (tod_begin_at) instead of tod_start's loop, tod_iterate's gather and τ loops.
The numpy reference (_time_of_distance, then _eval's ṡ there) must give the same bits, on
the batches real chains hand _tod_core_at and on varied targets: inside, at and beyond the
ends, nan; laws in a scrambled order with repeats; batches across the chunks' size (256);
whole and cut short after a few steps (the laws still going)."""
import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.laws import chain as lc

pytestmark = pytest.mark.skipif(lc.CORE_MOD is None, reason=f"the chain core is not used here ({lc.CORE_WHY})")

from test_speed_chains import _chain_problems  # noqa: E402

_BATCH = {}


def _bits(x):
    return np.asarray(x, float).view(np.int64)


def _batches(prof):
    """(law, pj, s_targets) of the _tod_core_at calls of solve_chains on real chains."""
    if prof not in _BATCH:
        sts, T0, profile = _chain_problems(prof)
        got = []
        orig = lc._tod_core_at

        def rec(core, law, pj, x, max_iter=200):
            got.append((law, np.array(pj), np.array(x)))
            return orig(core, law, pj, x, max_iter)
        lc._tod_core_at = rec
        try:
            for r in (1.0, 1.1):
                T = T0 * r
                lc.solve_chains(chains._problems(sts, T, (T / chains.GAMMA_MIN) ** 2, profile))
        finally:
            lc._tod_core_at = orig
        _BATCH[prof] = got
    return _BATCH[prof]


def _targets(rng, L, kind):
    """Distances into laws of lengths L: inside, the ends, beyond them, a few nan."""
    u = rng.uniform(0.0, 1.0, L.size)
    if kind == "inside":
        return u * L
    x = u * L
    pick = rng.integers(0, 6, L.size)
    x[pick == 0] = 0.0
    x[pick == 1] = L[pick == 1]
    x[pick == 2] = -0.5 * np.abs(L[pick == 2])
    x[pick == 3] = 1.5 * L[pick == 3]
    x[rng.uniform(size=L.size) < 0.01] = np.nan
    return x


def _ref(law, pj, x, free, v, t, max_iter):
    """_at_times' numpy lines: v[free] = ṡ at the t each law ends on, t[free] += that t."""
    sub = law.take(pj)
    tl = lc._time_of_distance(sub, x, max_iter)
    v, t = v.copy(), t.copy()
    with np.errstate(all="ignore"):
        v[free] = lc._eval(sub, tl, "v")[1]
    t[free] += tl
    return v, t


def _case(law, pj, x, rng, max_iter):
    core = lc.CORE_MOD
    n = 2 * pj.size + 3
    free = np.ascontiguousarray(rng.permutation(n)[:pj.size], np.int64)
    v, t = rng.uniform(1.0, 2.0, n), rng.uniform(0.0, 5.0, n)
    v2, t2 = v.copy(), t.copy()
    with np.errstate(all="ignore"):
        assert lc._tod_core_into(core, law, pj, x, free, v2, t2, max_iter)
    v3, t3 = _ref(law, pj, x, free, v, t, max_iter)
    return (np.array_equal(_bits(v2), _bits(v3)) and np.array_equal(_bits(t2), _bits(t3)))


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
@pytest.mark.parametrize("kind", ["inside", "edges"])
def test_tod_at_into_same_bits_as_numpy(prof, kind):
    rng = np.random.default_rng(44)
    batches = _batches(prof)
    assert len(batches) >= 4
    for law, pj, x in batches:
        pj = np.ascontiguousarray(pj, np.int64)
        x = np.ascontiguousarray(x if kind == "inside" else _targets(rng, law.L[pj], kind), float)
        assert _case(law, pj, x, rng, 200)


@pytest.mark.parametrize("N", [1, 7, 255, 256, 257, 600])
@pytest.mark.parametrize("max_iter", [0, 1, 2, 3, 5, 200])
def test_tod_at_into_scrambled_and_cut_short_same_bits(N, max_iter):
    """Laws in a scrambled order with repeats, N across the chunks' size, cut short after a
    few steps (the laws still going: their last t evaluated by _tod_core_into's numpy end)."""
    law = max((b[0] for b in _batches("voron24")), key=lambda lw: lw.T.size)
    rng = np.random.default_rng(N * 31 + max_iter)
    pj = np.ascontiguousarray(rng.integers(0, law.T.size, N), np.int64)
    x = np.ascontiguousarray(_targets(rng, law.L[pj], "edges" if N % 2 else "inside"), float)
    assert _case(law, pj, x, rng, max_iter)


def test_tod_solve_same_bits_as_numpy():
    """tod_solve (tod_prep's laws; tod_step as tod_at_into runs it) against the numpy code."""
    core = lc.CORE_MOD
    rng = np.random.default_rng(4)
    for law, pj, x in _batches("prusa-mk3s")[:6]:
        sub = law.take(pj)
        xs = _targets(rng, sub.L, "edges")
        with np.errstate(all="ignore"):
            got = lc._tod_core(core, sub, xs)
            want_t = lc._time_of_distance(sub, xs)
            want_v = lc._eval(sub, want_t, "v")[1]
        assert np.array_equal(_bits(got[0]), _bits(want_t)) and np.array_equal(_bits(got[1]), _bits(want_v))


def test_a_wrong_target_is_seen():
    """(the comparison can fail)"""
    law, pj, x = _batches("voron24")[0]
    pj = np.ascontiguousarray(pj, np.int64)
    rng = np.random.default_rng(2)
    core = lc.CORE_MOD
    n = 2 * pj.size + 3
    free = np.ascontiguousarray(rng.permutation(n)[:pj.size], np.int64)
    v, t = np.ones(n), np.zeros(n)
    v2, t2 = v.copy(), t.copy()
    assert lc._tod_core_into(core, law, pj, np.ascontiguousarray(x * (1 + 1e-9)), free, v2, t2)
    v3, t3 = _ref(law, pj, x, free, v, t, 200)
    assert not np.array_equal(_bits(t2), _bits(t3))


@pytest.mark.parametrize("max_iter", [2, 200])
def test_tod_at_into_zero_and_negative_lengths_same_bits(max_iter):
    """Laws of length 0 (t starts at the middle), -0.0 and negative (sgn -1), made by
    _step_law from a real batch's pieces with some lengths changed."""
    law, pj, x = _batches("voron24")[0]
    rng = np.random.default_rng(7 + max_iter)
    L = law.L.copy()
    u = rng.uniform(size=L.size)
    L[u < 0.1] = 0.0
    L[(u >= 0.1) & (u < 0.15)] = -0.0
    L[(u >= 0.15) & (u < 0.3)] *= -1
    nl = lc._step_law(L, law.T, law.beta, law.v0, law.v1)
    assert bool(nl._c["small"].all()) and (nl.L == 0).sum() > 10 and (nl.L < 0).sum() > 10
    pj = np.ascontiguousarray(rng.integers(0, L.size, 700), np.int64)
    for kind in ("inside", "edges"):
        xs = np.ascontiguousarray(_targets(rng, nl.L[pj], kind), float)
        assert _case(nl, pj, xs, rng, max_iter)


def _knots_call(fl, bv8, K):
    """core.fixed_knots on every chain of fl, binding marks bv8 (uint8), K knots (2 chains + marks)."""
    na, n = fl.S.size, fl.sv.size
    P = K - na
    ks, kv, kt0, L, va, vb, T0 = (np.empty(K), np.empty(K), np.empty(K), np.empty(P), np.empty(P), np.empty(P),
                                  np.empty(P))
    koff, owner, kj = np.empty(na + 1, np.int64), np.empty(P, np.int64), np.empty(n, np.int64)
    lc.CORE_MOD.fixed_knots(fl.sv, fl.cv, np.zeros(n), np.arange(n, dtype=np.int64), bv8,
                            np.ascontiguousarray(fl.voff, np.int64), fl.S, fl.T, fl.v0, fl.v1, np.zeros(na, np.uint8),
                            ks, kv, kt0, koff, L, va, vb, T0, owner, kj)
    return ks, kv, koff, L, T0, owner, kj


@pytest.mark.parametrize("seed", range(6))
def test_fixed_knots_counts_every_nonzero_mark(seed):
    """fixed_knots' count of the binding vertices (its size check: K = 2 chains + that count)
    takes every nonzero byte of the marks as binding, as its knot loop does: marks 1, 2 and
    255 give the knots of bool marks; a K one off is refused."""
    rng = np.random.default_rng(seed)
    m = int(rng.integers(1, 40))
    nv = rng.integers(0, 90, m)
    S = rng.uniform(5.0, 50.0, m)
    sv = np.concatenate([np.sort(rng.uniform(0.01, 0.99, k)) * s for k, s in zip(nv, S)])
    fl = lc._Flat.of_arrays(sv, rng.uniform(10.0, 100.0, sv.size), nv, S, S / 50.0, np.ones(m),
                            rng.uniform(0.0, 20.0, m), rng.uniform(0.0, 20.0, m))
    bind = rng.uniform(size=sv.size) < 0.3
    K = 2 * m + int(bind.sum())
    want = _knots_call(fl, bind.view(np.uint8).copy(), K)
    marks = np.where(bind, rng.choice(np.array([1, 2, 255], np.uint8), sv.size), 0).astype(np.uint8)
    got = _knots_call(fl, marks, K)
    assert all(np.array_equal(_bits(g) if g.dtype == float else g, _bits(w) if w.dtype == float else w)
               for g, w in zip(got, want))
    for bad in (K - 1, K + 1):
        with pytest.raises(ValueError, match="fixed_knots: shapes"):
            _knots_call(fl, marks, bad)
