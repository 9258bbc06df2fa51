"""Session 62 (chf): the exact shares' series terms are each chain's own.

laws/chain._share_time_exact (and the chain core's exact_share) evaluate the slopes J', J''
of each chain's pieces with the terms its own largest z = T²/β needs (_chain_terms; the core's
ex_terms), not the batch's largest: so
- _exact_slopes with an array of terms gives each piece the numbers of a call with its own
  scalar k (the same Horner steps, bit for bit);
- a chain's shares are the same bits whether it is solved alone or beside a chain of much
  larger z (the windowed candidates' calls hold other chains than the list path's one call),
  compiled and numpy;
- _chain_terms gives each chain the least terms _exact_terms gives its largest z.
The batch's largest z still decides a decline (test_speed38_chaincore_vec.py)."""
import numpy as np
import pytest

from gcode_opt.laws import chain as lc

CORE = lc.CORE_MOD
needs_core = pytest.mark.skipif(CORE is None, reason=f"the chain core is not used here ({lc.CORE_WHY})")


def _same(x, y):
    x, y = np.asarray(x), np.asarray(y)
    v = (lambda a: a.view(np.uint8)) if x.dtype == bool else (lambda a: a.view(np.int64))
    return x.shape == y.shape and x.dtype == y.dtype and np.array_equal(v(x), v(y))


def _chains(rng, n_c, gammas, pmax=30):
    """_share_time inputs of n_c chains of 1 .. pmax pieces, chain c's whole γ gammas[c]."""
    npc = rng.integers(1, pmax + 1, n_c)
    owner = np.repeat(np.arange(n_c), npc)
    P = owner.size
    L = rng.uniform(0.05, 5.0, P)
    va, vb = rng.uniform(0.0, 150.0, P), rng.uniform(0.0, 150.0, P)
    T_init = L / rng.uniform(5.0, 150.0, P)
    T_total = np.bincount(owner, T_init, n_c) * rng.uniform(0.7, 1.5, n_c)
    beta = ((T_total / np.asarray(gammas, float)) ** 2)[owner]
    return L, beta, va, vb, owner, T_total, T_init


def _take(a, keep):
    """The chains keep (ascending) of the inputs a, renumbered."""
    L, beta, va, vb, owner, T_total, T_init = a
    on = np.isin(owner, keep)
    new = np.searchsorted(keep, owner[on])
    return L[on], beta[on], va[on], vb[on], new, T_total[keep], T_init[on]


def test_slopes_with_each_piece_terms():
    rng = np.random.default_rng(62)
    P = 300
    L, T = rng.uniform(0.05, 5.0, P), rng.uniform(1e-3, 0.3, P)
    b = (T / 10.0 ** rng.uniform(-3.0, 0.2, P)) ** 2
    vs, vd = rng.uniform(0.0, 300.0, P), rng.uniform(-150.0, 150.0, P)
    k = rng.integers(2, lc.EXACT_TERMS + 1, P)
    got = lc._exact_slopes(L, T, b, vs, vd, k)
    for kk in np.unique(k).tolist():
        on = k == kk
        want = lc._exact_slopes(L[on], T[on], b[on], vs[on], vd[on], kk)
        for x, y in zip(got, want, strict=True):
            assert _same(x[on], y)


def test_chain_terms_are_the_chains_own():
    rng = np.random.default_rng(621)
    owner = np.repeat(np.arange(5), [3, 1, 4, 2, 6])
    z = 10.0 ** rng.uniform(-6.0, 0.3, owner.size)
    k = lc._chain_terms(z, owner, 5)
    for c in range(5):
        assert np.all(k[owner == c] == lc._exact_terms(float(z[owner == c].max())))
    assert len(set(k.tolist())) > 1          # (the chains' terms differ: the test's point)


@pytest.mark.parametrize("core", [pytest.param("c", marks=needs_core), "numpy"])
def test_a_chain_shares_alone_or_beside_a_large_one(core):
    rng = np.random.default_rng(622)
    # small chains (few terms) and, among them, chains of γ near EXACT_GAMMA_MAX (many terms)
    gam = np.where(np.arange(40) % 7 == 3, 0.5, 10.0 ** rng.uniform(-3.0, -1.0, 40))
    a = _chains(rng, 40, gam)
    cm = CORE if core == "c" else False
    both = lc._share_time_exact(*a, core=cm)
    assert both is not None
    small = np.flatnonzero(gam < 0.4)
    alone = lc._share_time_exact(*_take(a, small), core=cm)
    assert alone is not None
    on = np.isin(a[4], small)
    assert _same(both[0][on], alone[0])
    assert _same(both[1][small], alone[1])
    assert _same(both[2][small], alone[2])


@needs_core
def test_compiled_equals_numpy_on_mixed_terms():
    rng = np.random.default_rng(623)
    for n_c in (2, 9, 60):
        gam = 10.0 ** rng.uniform(-4.0, np.log10(1.7), n_c)
        a = _chains(rng, n_c, gam)
        got, want = lc._share_time_exact(*a, core=CORE), lc._share_time_exact(*a, core=False)
        assert (got is None) == (want is None)
        if want is not None:
            for x, y in zip(got, want, strict=True):
                assert _same(x, y)
