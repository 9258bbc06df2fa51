"""Session 29 (chainnewton): the chains' time sharing (laws/chain._share_time) by Newton on
the exact slopes of the line law's J (chain._exact_slopes: J' = the law's Hamiltonian at
mid-piece, J'' its derivative, power series in γ²) instead of central differences of J.

Checked against independent references:
- the slopes against mpmath's derivatives of the closed-form J (its own sinh / cosh
  formulas at 60 digits, not the series), over γ from 1e-3 (the plates' pieces) to 2;
- the KKT conditions of the solved shares (J_j' + λ = 0 per piece, Σ T_j = T per chain) on
  the batches real chains of the bundled gyroid hand _share_time: met within NEWTON_TOL_R
  of each chain's slope scale, and at least as tightly as by the central-difference
  solver they replace (_share_time_numpy, kept as the fallback);
- each chain's J = Σ J_j at the new shares is not above the old shares' J (the new ones
  are the minimum of J over the shares; the old ones stopped where the differences' noise
  said the slopes were equal);
- the compiled iteration (exact_share) against the numpy one, bit for bit, and a planted
  bug in the numpy slopes must be seen by these checks.
"""
import mpmath as mp
import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.laws import chain as lc
from gcode_opt.laws.line import LineLaw

from test_speed_chains import _chain_problems  # noqa: E402

mp.mp.dps = 60


def _J_mp(L, T, beta, va, vb):
    """The line law's J = ∫ṡ² + β∫s̈² (line.py's integrals) in closed form with mpmath."""
    g = T / mp.sqrt(beta)
    n = (mp.cosh(g / 2) - 2 / g * mp.sinh(g / 2)) / g ** 2
    m = (mp.sinh(g) / g + 1 - 8 * mp.sinh(g / 2) ** 2 / g ** 2) / g ** 4
    S1 = (mp.sinh(g) - g) / g ** 3
    sh2, shg = mp.sinh(g / 2) / (g / 2), mp.sinh(g) / g
    Ig1, Igp, Ih, Ihp = m / (2 * n * n), S1 / (2 * n * n), 2 * S1 / sh2 ** 2, 2 * (shg + 1) / sh2 ** 2
    A, d = L - T * (va + vb) / 2, T * (va - vb) / 2
    return (L ** 2 + A ** 2 * Ig1 + d ** 2 * Ih) / T + beta * (A ** 2 * Igp + d ** 2 * Ihp) / T ** 3


def _slopes_mp(L, T, beta, va, vb):
    f = lambda t: _J_mp(mp.mpf(L), t, mp.mpf(beta), mp.mpf(va), mp.mpf(vb))     # noqa: E731
    t = mp.mpf(T)
    return float(mp.diff(f, t)), float(mp.diff(f, t, 2)), float(f(t))


def _pieces(n=60, seed=29):
    rng = np.random.default_rng(seed)
    L = rng.uniform(0.05, 5.0, n)
    va, vb = rng.uniform(0.0, 150.0, n), rng.uniform(0.0, 150.0, n)
    T = L / rng.uniform(5.0, 150.0, n)
    gamma = 10.0 ** rng.uniform(-3.0, np.log10(2.0), n)
    return L, T, (T / gamma) ** 2, va, vb


def _check_slopes(slopes):
    L, T, beta, va, vb = _pieces()
    k = lc._exact_terms(float(np.max(T * T / beta)))
    d1, d2, _ = slopes(L, T, beta, va + vb, va - vb, k)
    for i in range(L.size):
        m1, m2, J = _slopes_mp(L[i], T[i], beta[i], va[i], vb[i])
        # relative to the slope scale J/T (J' itself may be near 0 where the law's
        # Hamiltonian is), and J'' to J/T²
        assert abs(d1[i] - m1) <= 1e-12 * J / T[i], (i, d1[i], m1)
        assert abs(d2[i] - m2) <= 1e-10 * J / T[i] ** 2, (i, d2[i], m2)


def test_exact_slopes_against_mpmath():
    _check_slopes(lc._exact_slopes)


def test_planted_slope_bug_is_seen():
    def bad(L, T, b, vs, vd, k):          # J' off by 1e-9 of itself
        d1, d2, rt = lc._exact_slopes(L, T, b, vs, vd, k)
        return d1 * (1 + 1e-9), d2, rt
    with pytest.raises(AssertionError):
        _check_slopes(bad)


def _batches(monkeypatch):
    """The _share_time arguments of a cold and a warm solve of the bundled gyroid's chains."""
    sts, T0, profile = _chain_problems("prusa-mk3s")
    calls = []
    orig = lc._share_time

    def rec(*a, **k):
        calls.append([np.array(x) for x in a])
        return orig(*a, **k)
    monkeypatch.setattr(lc, "_share_time", rec)
    for r in (1.0, 1.3):
        T = T0 * r
        lc.solve_chains(chains._problems(sts, T, (T / chains.GAMMA_MIN) ** 2, profile))
    monkeypatch.setattr(lc, "_share_time", orig)
    assert len(calls) >= 4 and sum(c[0].size for c in calls) > 1000
    return calls


def _kkt(a, T, lam, conv):
    """Per converged chain: Σ|J_j' + λ| / n / slope scale (the solver's own measure, with
    the exact slopes) and |Σ T_j - T| / T."""
    L, beta, va, vb, owner, T_total, _ = a
    d1, _, _ = lc._exact_slopes(L, T, beta, va + vb, va - vb, lc.EXACT_TERMS)
    n_c = T_total.size
    n_p = np.bincount(owner, None, n_c)
    scale = np.maximum(np.abs(lam), np.bincount(owner, np.abs(d1), n_c) / n_p)
    r = np.bincount(owner, np.abs(d1 + lam[owner]), n_c) / n_p / scale
    e = np.abs(np.bincount(owner, T, n_c) - T_total) / T_total
    return r[conv], e[conv]


def _chain_J(a, T):
    L, beta, va, vb, owner, T_total, _ = a
    iv, ia = LineLaw(L, T, beta, va, vb).integrals()
    return np.bincount(owner, iv + beta * ia, T_total.size)


def test_kkt_and_J_on_real_batches(monkeypatch):
    worst_new = worst_old = 0.0
    for a in _batches(monkeypatch):
        T, lam, conv = lc._share_time_exact(*a, core=False)
        To, lamo, convo = lc._share_time_numpy(*a)
        assert np.array_equal(conv, convo) and conv.all()
        r, e = _kkt(a, T, lam, conv)
        ro, eo = _kkt(a, To, lamo, convo)
        assert np.all(r <= lc.NEWTON_TOL_R) and np.all(e <= 1e-12)
        worst_new, worst_old = max(worst_new, float(r.max())), max(worst_old, float(ro.max()))
        # the old shares are within their differences' noise of these: J the same to ~1e-9
        # at most, and not lower (a chain's J at its new shares is the least, to rounding)
        J, Jo = _chain_J(a, T), _chain_J(a, To)
        assert np.all(J <= Jo * (1 + 1e-13)), float(np.max(J / Jo - 1))
        assert np.all(Jo <= J * (1 + 1e-8))
    assert worst_new <= worst_old


def test_exact_share_c_equals_numpy(monkeypatch):
    if lc.CORE_MOD is None:
        pytest.skip(f"the chain core is not used here ({lc.CORE_WHY})")
    for a in _batches(monkeypatch):
        got = lc._share_time_exact(*a, core=lc.CORE_MOD)
        want = lc._share_time_exact(*a, core=False)
        assert got is not None and want is not None
        for x, y in zip(got, want, strict=True):
            x, y = np.asarray(x), np.asarray(y)
            assert np.array_equal(x.view(np.uint8), y.view(np.uint8))


def test_exact_declines_to_the_differences():
    """γ above EXACT_GAMMA_MAX or β = inf: the central-difference solver's result."""
    rng = np.random.default_rng(3)
    owner = np.repeat(np.arange(4), 3)
    L = rng.uniform(0.3, 1.0, owner.size)
    va, vb = rng.uniform(10, 50, owner.size), rng.uniform(10, 50, owner.size)
    T_total = np.bincount(owner, L, 4) / 40.0
    T_init = T_total[owner] / 3
    beta = (T_total[owner] / 8.0) ** 2                 # pieces at γ ~ 2.7
    for core in (False, lc.CORE_MOD):
        assert lc._share_time_exact(L, beta, va, vb, owner, T_total, T_init, core) is None
    want = lc._share_time_numpy(L, beta, va, vb, owner, T_total, T_init)
    for core in (False, lc.CORE_MOD):
        got = lc._share_time(L, beta, va, vb, owner, T_total, T_init, core=core)
        for x, y in zip(got, want, strict=True):
            assert np.array_equal(np.asarray(x), np.asarray(y))
    inf = np.full(owner.size, np.inf)
    for core in (False, lc.CORE_MOD):
        assert lc._share_time_exact(L, inf, va, vb, owner, T_total, T_init, core) is None
    with np.errstate(invalid="ignore"), pytest.raises(ValueError):       # the differences' own error
        lc._share_time(L, inf, va, vb, owner, T_total, T_init, core=False)
    beta = (T_total[owner] / 0.1) ** 2
    assert lc._share_time_exact(L, beta, va, vb, owner, T_total, T_init, False) is not None
