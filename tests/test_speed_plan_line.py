"""laws/line.py evaluates each law in its own γ branch only (issue 8); the start commit
computed both branches for every law and picked one with np.where.  That two-branch
form is kept here as the reference (copied from the start commit, a071b70) and the
per-branch code must give the same bits: coefficients, shapes, LineLaw figures, for
laws all in one branch, mixed, at the switch, at γ = 0 (β = inf) and γ huge."""
import numpy as np
import pytest

from gcode_opt.laws import line
from gcode_opt.laws.line import GAMMA_SWITCH, LineLaw, _horner, _M_COEF, _N_COEF, _s1, _shc


def _gamma_coeffs_ref(gamma):
    gs = np.minimum(gamma, GAMMA_SWITCH)
    gl = np.maximum(gamma, GAMMA_SWITCH)
    small = gamma < GAMMA_SWITCH
    n = _horner(_N_COEF, gs * gs)
    m = _horner(_M_COEF, gs * gs)
    sh2 = _shc(gs / 2)
    E = np.exp(-gl)
    em = np.expm1(-gl)
    q = -em / gl
    Dn = 1.0 + E - 2.0 * q
    one_m_E2 = -np.expm1(-2.0 * gl)
    c = {"small": small, "gs": gs, "gl": gl, "n": n, "sh2": sh2, "em": em, "Dn": Dn, "E": E}
    c["Ig1"] = np.where(small, m / (2 * n * n), (one_m_E2 / gl + 2 * E - 4 * q * q) / Dn**2)
    c["Igp"] = np.where(small, _s1(gs) / (2 * n * n), gl * (one_m_E2 - 2 * gl * E) / Dn**2)
    c["Ih"] = np.where(small, 2 * _s1(gs) / sh2**2, (one_m_E2 / gl - 2 * E) / em**2)
    c["Ihp"] = np.where(small, 2 * (_shc(gs) + 1) / sh2**2, gl * (one_m_E2 + 2 * gl * E) / em**2)
    c["kappa_over_gamma"] = np.where(small, 2 * n / sh2, Dn / (-em * gl))
    return c


def _shapes_ref(c, tau):
    x = tau - 0.5
    small = c["small"]
    gs, n, sh2 = c["gs"], c["n"], c["sh2"]
    pa, pb = _shc(gs * tau / 2), _shc(gs * (1 - tau) / 2)
    shx = _shc(gs * x)
    bub = tau * (1 - tau) * pa * pb
    g_s = bub / (2 * n)
    gp_s = -x * shx / n
    G_s = 0.5 + (x * _shc(gs / 4) ** 2 / 8 - x**3 * _s1(gs * x)) / n
    h_s = 2 * x * shx / sh2
    hp_s = 2 * np.cosh(gs * x) / sh2
    Hs_s = -bub / sh2
    gl, em, Dn, E = c["gl"], c["em"], c["Dn"], c["E"]
    e0, e1 = np.expm1(-gl * tau), np.expm1(-gl * (1 - tau))
    diff = e0 - e1
    g_l = e0 * e1 / Dn
    gp_l = gl * diff / Dn
    G_l = 0.5 + (x * (1 + E) + diff / gl) / Dn
    h_l = diff / em
    hp_l = gl * (e0 + e1 + 2) / (-em)
    Hs_l = e0 * e1 / (gl * em)
    w = np.where
    return (w(small, G_s, G_l), w(small, g_s, g_l), w(small, gp_s, gp_l), w(small, Hs_s, Hs_l),
            w(small, h_s, h_l), w(small, hp_s, hp_l))


def _same(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return a.shape == b.shape and np.ascontiguousarray(a).tobytes() == np.ascontiguousarray(b).tobytes()


EDGE = [0.0, 1e-300, 1e-8, 0.1, 1.0, np.nextafter(GAMMA_SWITCH, 0.0), GAMMA_SWITCH, 4.5, 40.0, 1e6, 1e9, np.inf]


def _gammas(rng, kind, n):
    if kind == "small":
        return rng.uniform(0.0, GAMMA_SWITCH, n) * (rng.random(n) < 0.9)
    if kind == "large":
        return np.exp(rng.uniform(np.log(GAMMA_SWITCH), np.log(1e8), n))
    if kind == "chain":
        return np.full(n, 0.1)
    return np.concatenate([rng.uniform(0.0, 8.0, n - len(EDGE)), EDGE])[rng.permutation(n)]


@pytest.mark.parametrize("kind", ["small", "large", "mixed", "chain"])
def test_coefficients_and_shapes_bitwise(kind):
    rng = np.random.default_rng(3)
    with np.errstate(all="ignore"):
        for n in (1, 7, 300):
            g = _gammas(rng, kind, max(n, len(EDGE)) if kind == "mixed" else n)
            got, ref = line._gamma_coeffs(g), _gamma_coeffs_ref(g)
            for k in ("Ig1", "Igp", "Ih", "Ihp", "kappa_over_gamma"):
                assert _same(got[k], ref[k]), k
            taus = [np.float64(0.3), rng.random(9), np.r_[0.0, 0.5, 1.0]]
            for tau in taus:
                for a, b in zip(line._shapes(got, tau[..., None] if np.ndim(tau) else tau),
                                _shapes_ref(ref, tau[..., None] if np.ndim(tau) else tau)):
                    assert _same(a, b)
            gcol = {k: (v[:, None] if isinstance(v, np.ndarray) and v.ndim == 1 else v) for k, v in got.items()}
            rcol = {k: (v[:, None] if isinstance(v, np.ndarray) and v.ndim == 1 else v) for k, v in ref.items()}
            tgrid = rng.random((g.size, 5))
            for a, b in zip(line._shapes(gcol, tgrid), _shapes_ref(rcol, tgrid)):
                assert _same(a, b)


def test_scalar_law_bitwise():
    for gamma in EDGE[:-1]:
        g = np.asarray(gamma)
        got, ref = line._gamma_coeffs(g), _gamma_coeffs_ref(g)
        with np.errstate(all="ignore"):
            for a, b in zip(line._shapes(got, np.linspace(0, 1, 11)), _shapes_ref(ref, np.linspace(0, 1, 11))):
                assert _same(a, b)


def test_line_law_figures_mixed_batch_equal_one_by_one():
    """A law's figures do not depend on the batch it is in (each element in its branch)."""
    rng = np.random.default_rng(5)
    n = 200
    T = rng.uniform(0.01, 1.0, n)
    beta = (T / rng.choice([0.1, 1.0, 3.99, 4.0, 7.0, 300.0], n)) ** 2
    L, v0, v1 = rng.uniform(0.1, 50.0, n), rng.uniform(0, 100, n), rng.uniform(0, 100, n)
    law = LineLaw(L, T, beta, v0, v1)
    iv, ia = law.integrals()
    s, v, a = law.eval(0.37 * T)
    for k in range(0, n, 13):
        one = LineLaw(L[k], T[k], beta[k], v0[k], v1[k])
        i1, a1 = one.integrals()
        assert _same(i1, iv[k]) and _same(a1, ia[k])
        for x, y in zip(one.eval(0.37 * T[k]), (s[k], v[k], a[k])):
            assert _same(x, y)


@pytest.mark.parametrize("kind", ["chain", "mixed", "large"])
def test_repeated_gammas_bitwise(kind):
    """A batch with few distinct γ (each computed once) gives the reference's bits."""
    rng = np.random.default_rng(11)
    base = _gammas(rng, kind, 12)
    g = rng.choice(base, size=(40, 7))
    with np.errstate(all="ignore"):
        got, ref = line._gamma_coeffs(g), _gamma_coeffs_ref(g)
        for k in ("Ig1", "Igp", "Ih", "Ihp", "kappa_over_gamma"):
            assert _same(got[k], ref[k]), k
        tau = rng.random((40, 7))
        for a, b in zip(line._shapes(got, tau), _shapes_ref(ref, tau)):
            assert _same(a, b)


@pytest.mark.parametrize("kind", ["chain", "mixed", "large"])
def test_eval_parts_equal_full_eval(kind):
    """eval(t, want) computes only s, v or a: each the full eval's, bit for bit."""
    rng = np.random.default_rng(13)
    n = 60
    T = rng.uniform(0.01, 1.0, n)
    g = _gammas(rng, kind, n)
    g = np.where(np.isfinite(g) & (g > 0), g, 0.5)
    with np.errstate(over="ignore"):        # γ = 1e-300: β = inf (the cubic Hermite)
        law = LineLaw(rng.uniform(0.1, 50.0, n), T, (T / g) ** 2, rng.uniform(0, 100, n), rng.uniform(0, 100, n))
    for t in (rng.random(n) * T, np.zeros(n), T):
        full = law.eval(t)
        for want in ("s", "v", "a", "sv", "va"):
            part = law.eval(t, want)
            for k, q in enumerate("sva"):
                assert (part[k] is None) == (q not in want)
                if q in want:
                    assert _same(part[k], full[k])


def test_take_equals_new_laws():
    """law.take(idx) evaluates as LineLaw(L[idx], ...) does, bit for bit."""
    rng = np.random.default_rng(17)
    n = 80
    T = rng.uniform(0.01, 1.0, n)
    g = rng.choice([0.05, 0.1, 2.0, 3.999, 4.0, 9.0], n)
    L, v0, v1 = rng.uniform(0.1, 50.0, n), rng.uniform(0, 100, n), rng.uniform(0, 100, n)
    law = LineLaw(L, T, (T / g) ** 2, v0, v1)
    for idx in (rng.integers(0, n, 200), np.flatnonzero(g < 1.0), np.array([], int)):
        got = law.take(idx)
        want = LineLaw(L[idx], T[idx], ((T / g) ** 2)[idx], v0[idx], v1[idx])
        t = rng.random(idx.size) * T[idx]
        for a, b in zip(got.eval(t), want.eval(t)):
            assert _same(a, b)
        for a, b in zip(got.integrals(), want.integrals()):
            assert _same(a, b)
        assert _same(got.peak_speed(), want.peak_speed())
