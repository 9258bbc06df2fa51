"""Round 3 of issue 8 in laws/circle.py and the curves' figures: the collocation equations
solved by a preconditioned fixed-point iteration (Newton for the arcs it leaves), a lower
starting N, Chebyshev series on shared grids by fixed-shape BLAS products, the layer cruise
value iterated on the arcs not yet converged, κ(s) by one interpolation per geometry.
Equivalent numerics: each is checked against the method it replaces (kept here or in the
module), to the rounding of that method; the bit-for-bit properties the program relies on
(a law solved in a batch is the law solved alone; chunked evaluation gives the same
figures) are checked bit for bit."""
import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt.laws import circle


def _arcs(seed, nb, steep=False):
    rng = np.random.default_rng(seed)
    phi = rng.uniform(0.05, 3.0, nb) * rng.choice([1.0, -1.0], nb)
    gam2 = 10.0 ** rng.uniform(-3, 3.5 if steep else 2.0, nb)
    u0 = phi * rng.uniform(0.0, 6.0 if steep else 2.0, nb)
    u1 = phi * rng.uniform(0.0, 6.0 if steep else 2.0, nb)
    return phi, gam2, u0, u1


@pytest.mark.parametrize("n,seed,steep", [(16, 0, False), (20, 1, False), (32, 2, True), (48, 3, True)])
def test_preconditioned_iteration_solves_newtons_equations(n, seed, steep):
    """Where the preconditioned iteration converges, it is Newton's collocation solution
    to rounding; _solve_nodes hands the rest to Newton, so every arc is solved."""
    phi, gam2, u0, u1 = _arcs(seed, 300, steep)
    w0 = np.repeat(phi[:, None], n + 1, axis=1)
    wn, cn, okn = circle._newton_cheb(n, phi, gam2, u0, u1, w0)
    wp, cp, okp = circle._precond_cheb(n, phi, gam2, u0, u1, w0)
    assert okn.all()
    assert okp.mean() > (0.3 if steep else 0.95)       # steep layers: slow contraction, Newton
    scale = np.maximum.reduce([np.abs(phi), np.abs(u0), np.abs(u1)])
    err = np.abs(wp - wn).max(axis=1) / scale
    assert err[okp].max() < 1e-12, err[okp].max()
    cscale = np.abs(cn) + gam2 * scale + scale ** 3
    assert (np.abs(cp - cn) / cscale)[okp].max() < 1e-12
    ws, cs_, oks = circle._solve_nodes(n, phi, gam2, u0, u1, w0)
    assert oks.all()
    assert (np.abs(ws - wn).max(axis=1) / scale).max() < 1e-12


def test_steep_arcs_left_to_newton():
    """Steep end layers (large γ, end speeds far from the mean): the contraction is slow,
    the iteration gives them up, Newton solves them."""
    phi = np.full(20, 0.5)
    gam2 = np.full(20, 1.0)
    u0, u1 = np.full(20, 20.0), np.linspace(0.0, 4.0, 20)     # 6w² from ~0 to 2400 along the arc
    w0 = np.repeat(phi[:, None], 49, axis=1)
    _, _, okp = circle._precond_cheb(48, phi, gam2, u0, u1, w0)
    assert not okp.all()
    wn, _, okn = circle._newton_cheb(48, phi, gam2, u0, u1, w0)
    ws, _, oks = circle._solve_nodes(48, phi, gam2, u0, u1, w0)
    assert okn.all() and oks.all()
    assert np.abs(ws - wn).max() < 1e-12 * 20.0


def test_batch_is_single_bit_for_bit():
    """Arcs the preconditioned iteration solves (the Newton it falls back to may round
    differently with its batch, as before)."""
    if not circle._gemm_rows_invariant():
        pytest.skip("this BLAS does not give rows position-independent bits")
    phi, gam2, u0, u1 = _arcs(5, 70)
    T = np.full(phi.size, 0.1)
    beta = T * T / gam2
    batch = circle.solve_circles(phi, T, beta, u0 / T, u1 / T, 2.0)
    assert (~batch.regime).sum() > 40
    t = np.linspace(0.0, 1.0, 9)
    for i in range(0, phi.size, 7):
        one = circle.solve_circles(phi[i:i + 1], T[i:i + 1], beta[i:i + 1], u0[i:i + 1] / T[i], u1[i:i + 1] / T[i], 2.0)
        k = one.coef.shape[1]
        assert np.array_equal(batch.coef[i, :k], one.coef[0]) and not batch.coef[i, k:].any()
        assert batch.cc[i] == one.cc[0] and batch.wc[i] == one.wc[0]
        for a, b in zip(batch[i].eval(t * T[i]), one[0].eval(t * T[i])):
            assert np.array_equal(a, b)


def test_lower_start_n_same_laws_as_the_old_ladder(monkeypatch):
    """The old start (N from 12 + 1.6√(28λ), ladder from 24) and the new one give the same
    laws to the collocation's rounding."""
    phi, gam2, u0, u1 = _arcs(6, 200)
    T = np.full(phi.size, 0.05)
    beta = T * T / gam2
    new = circle.solve_circles(phi, T, beta, u0 / T, u1 / T, 1.0)
    monkeypatch.setattr(circle, "_N_LADDER", (32, 48, 64, 96, 128, 192, 256, 384, 512))
    old = circle.solve_circles(phi, T, beta, u0 / T, u1 / T, 1.0)
    assert circle._row_lengths(old.coef).mean() > circle._row_lengths(new.coef).mean() + 2   # a lower start
    tau = np.linspace(0.0, 1.0, 301)[None, :].repeat(phi.size, 0)
    scale = np.maximum.reduce([np.abs(phi), np.abs(u0), np.abs(u1)])[:, None]
    for a, b in zip(new.eval_tau(tau)[:2], old.eval_tau(tau)[:2]):
        assert (np.abs(a - b) / scale).max() < 1e-12
    for a, b in zip(new.integrals(), old.integrals()):
        np.testing.assert_allclose(a, b, rtol=1e-11)


def test_series_values_are_clenshaws_and_row_invariant():
    rng = np.random.default_rng(2)
    lengths = rng.choice([1, 3, 17, 21, 25, 33, 49], size=90)
    coef = np.zeros((90, 50))
    for i, k in enumerate(lengths):
        coef[i, :k] = rng.normal(size=k) / (1 + np.arange(k)) ** 2
    grid = np.sort(rng.uniform(-1, 1, 60))
    x = np.repeat(grid[None, :], 90, axis=0)
    x[::9] = rng.uniform(-1, 1, (10, 60))                  # rows on grids of their own
    got = circle._series_values((coef, coef[:, :30]), x)
    want = [circle._clenshaw_rows(coef, x), circle._clenshaw_rows(coef[:, :30], x)]
    for g, w in zip(got, want):
        np.testing.assert_allclose(g, w, rtol=1e-13, atol=1e-14)
    if circle._gemm_rows_invariant():
        perm = rng.permutation(90)
        parts = [circle._series_values((coef[p],), x[p])[0] for p in np.array_split(perm, 7)]
        assert np.array_equal(np.concatenate(parts), got[0][np.concatenate(np.array_split(perm, 7))])


def _layers_ref(phi, gam2, u0, u1):
    """The start commit's cruise iteration: every arc iterated until all are done."""
    span = np.abs(phi) + np.abs(u0) + np.abs(u1) + 1.0
    lo, hi = np.minimum.reduce([phi, u0, u1]) - span, np.maximum.reduce([phi, u0, u1]) + span
    f = circle._layers_total
    for _ in range(60):
        glo, ghi = f(lo, phi, gam2, u0, u1), f(hi, phi, gam2, u0, u1)
        bad_lo, bad_hi = glo > 0, ghi < 0
        if not (bad_lo.any() or bad_hi.any()):
            break
        lo = np.where(bad_lo, lo - 2.0 * span, lo)
        hi = np.where(bad_hi, hi + 2.0 * span, hi)
        span = np.where(bad_lo | bad_hi, 2.0 * span, span)
    wc = np.clip(phi.astype(float).copy(), lo, hi)
    for _ in range(100):
        g = f(wc, phi, gam2, u0, u1)
        lo = np.where(g < 0, wc, lo)
        hi = np.where(g > 0, wc, hi)
        h = 1e-7 * (np.abs(wc) + 1e-3 * span)
        dg = (f(wc + h, phi, gam2, u0, u1) - g) / h
        new = wc - g / np.where(dg > 0, dg, np.inf)
        outside = ~((new > lo) & (new < hi)) | ~np.isfinite(new)
        new = np.where(outside, 0.5 * (lo + hi), new)
        done = np.abs(new - wc) <= 1e-15 * span
        wc = new
        if done.all():
            break
    return wc, span


def test_layer_cruise_value_as_before():
    phi, gam2, u0, u1 = _arcs(8, 400, steep=True)
    gam2 = gam2 * 100.0                                     # many in the layers regime
    want, span = _layers_ref(phi, gam2, u0, u1)
    got = circle._solve_layers_batch(phi, gam2, u0, u1)
    assert (np.abs(got - want) / span).max() < 1e-13
    lam = np.sqrt(gam2 + 6.0 * got * got)
    scale = np.maximum.reduce([np.abs(phi), np.abs(u0), np.abs(u1)])
    assert (np.abs(circle._layers_total(got, phi, gam2, u0, u1)) / (scale * (1 + 1 / lam))).max() < 1e-12


class _G:
    end_terms = curves.CurveGeom.end_terms

    def __init__(self, rng):
        self.s_v = np.concatenate([[0.0], np.cumsum(rng.uniform(0.2, 1.0, 12))])
        self.kappa_v = rng.normal(0.0, 0.5, 13)

    def kappa(self, s):
        return np.interp(s, self.s_v, self.kappa_v)


def test_kappa_rows_are_per_row_interp_bit_for_bit():
    rng = np.random.default_rng(4)
    gs = [_G(rng) for _ in range(9)]
    geos = [g for g in gs for _ in range(int(rng.integers(1, 8)))]
    s = rng.uniform(-1.0, 14.0, (len(geos), 57))
    got = curves._kappa_rows(geos, s)
    want = np.array([g.kappa(r) for g, r in zip(geos, s)])
    assert np.array_equal(got, want)


def test_true_figures_as_the_per_grid_evaluation():
    """_true_figures_rows evaluates both grids in one piece, with v⁴ as (v²)²: the start
    commit's two-evaluation form (below) to rounding."""
    rng = np.random.default_rng(1)
    gs = [_G(rng) for _ in range(6)]
    for g in gs:
        g.cos_end = [0.99, None]
        g.d = np.array([0.5, 0.5])
        g.kappa_v = np.abs(g.kappa_v) + 0.05
    geos = [g for g in gs for _ in range(3)]
    S = np.array([g.s_v[-1] for g in geos])
    R = 1.0 / np.array([np.sqrt(np.mean(g.kappa_v ** 2)) for g in geos])
    T = S / rng.uniform(20.0, 80.0, S.size)
    law = circle.solve_circles(S / R, T, (T / rng.uniform(0.2, 8.0, S.size)) ** 2,
                               rng.uniform(5, 40, S.size) / R, rng.uniform(5, 40, S.size) / R, R)
    for sl, tau, wq in law.grid_chunks():
        got = curves._true_figures_rows(law.rows(sl), R[sl], geos[sl], tau, wq)
        want = _true_figures_ref(law.rows(sl), R[sl], geos[sl], tau, wq)
        for a, b in zip(got, want):
            np.testing.assert_allclose(a, b, rtol=1e-13)


def _true_figures_ref(law, R, geos, tau, wq):
    phi, w, w1, _ = law.eval_tau(tau)
    T = law.T_t[:, None]
    s, v, at = R[:, None] * phi, R[:, None] * w / T, R[:, None] * w1 / T ** 2
    kap = np.array([g.kappa(s[k]) for k, g in enumerate(geos)])
    a2 = at * at + kap * kap * v ** 4
    iv = law.T_t * np.sum(wq * v * v, axis=1)
    ia = law.T_t * np.sum(wq * a2, axis=1)
    ia = ia + np.array([g.end_terms(a, b) for g, a, b in zip(geos, R * law.w0, R * law.w1)])
    tu = np.broadcast_to(np.linspace(0.0, 1.0, 129)[None, :], (len(geos), 129))
    phu, wu, w1u, _ = law.eval_tau(tu)
    su, vu, au = R[:, None] * phu, R[:, None] * wu / T, R[:, None] * w1u / T ** 2
    ku = np.array([g.kappa(su[k]) for k, g in enumerate(geos)])
    a2u = au * au + ku * ku * vu ** 4
    return (iv, ia, np.maximum(v.max(1), vu.max(1)), np.sqrt(np.maximum(a2.max(1), a2u.max(1))),
            np.minimum(v.min(1), vu.min(1)))
