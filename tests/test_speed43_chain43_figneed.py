"""Session 43 (chain43): _flat_figures_core makes numpy's arctanh and sinh only at the pieces
whose speed at the critical t can be their chain's peak or least speed (the chain core's
fig_need bounds, then fig_c_at and fig_d_at), not at every piece (fig_c, fig_d).  The figures
(∫ṡ², peak and least speed per chain) must be those of the replaced code bit for bit: on real
chains of the bundled profiles (cold and warm solves, several durations) and on made-up pieces
(ties between equal pieces, bumps above and below the end speeds, γ above the bounds' range,
|r| between 1/8 and 1 and above 1, zero and signed-zero speeds, one-piece chains)."""
import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.laws import chain as lc

pytestmark = pytest.mark.skipif(lc.CORE_MOD is None or not hasattr(lc.CORE_MOD, "fig_need"),
                                reason=f"the chain core is not used here ({lc.CORE_WHY})")

from test_speed_chains import _chain_problems  # noqa: E402


class _Without:
    """The chain core without fig_need: _flat_figures_core's former path (fig_c, fig_d)."""

    def __init__(self, core):
        self.core = core

    def __getattr__(self, name):
        if name in ("fig_need", "fig_c_at", "fig_d_at"):
            raise AttributeError(name)
        return getattr(self.core, name)


class _Count:
    def __init__(self, core):
        self.core, self.k, self.P = core, 0, 0

    def __getattr__(self, name):
        return getattr(self.core, name)

    def fig_need(self, *a):
        k = self.core.fig_need(*a)
        self.k += k
        self.P += a[0].size
        return k


def _bits(x):
    return np.asarray(x, float).view(np.int64)


def _block(L, T, beta, v0, v1, poff):
    b = lc._BlockLaws()
    b.L, b.T, b.beta, b.v0, b.v1 = (np.ascontiguousarray(a, float) for a in (L, T, beta, v0, v1))
    b.poff = np.asarray(poff, np.int64)
    return b


def _same(res, sh2=None, count=None):
    """Both paths on copies of res: (the new one's result, whether it set anything)."""
    a, b = _block(res.L, res.T, res.beta, res.v0, res.v1, res.poff), _block(res.L, res.T, res.beta, res.v0,
                                                                                res.v1, res.poff)
    core = count if count is not None else lc.CORE_MOD
    ga = lc._flat_figures_core(core, a, sh2)
    gb = lc._flat_figures_core(_Without(lc.CORE_MOD), b, sh2)
    assert ga == gb
    if ga:
        for f in ("iv", "peak_v", "min_v"):
            assert np.array_equal(_bits(getattr(a, f)), _bits(getattr(b, f))), f
    return ga


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_real_chains_same_figures(prof, monkeypatch):
    sts, T0, profile = _chain_problems(prof)
    seen = []
    orig = lc._flat_figures_core

    def rec(core, res, sh2=None):
        seen.append((_block(res.L, res.T, res.beta, res.v0, res.v1, res.poff), None if sh2 is None else sh2.copy()))
        return orig(core, res, sh2)
    monkeypatch.setattr(lc, "_flat_figures_core", rec)
    for r in (0.9, 1.0, 1.07, 1.3):
        T = T0 * r
        fl = lc._Flat(chains._problems(sts, T, (T / chains.GAMMA_MIN) ** 2, profile))
        m, nv = fl.S.size, fl.sv.size
        a = lc.solve_flat(fl, lc.cold_binding(fl), np.zeros(nv), np.zeros(m, bool), pieces=False)
        lc.solve_flat(fl, a.bound.copy(), a.vert_t * 1.0, np.ones(m, bool), pieces=False)
    monkeypatch.setattr(lc, "_flat_figures_core", orig)
    count = _Count(lc.CORE_MOD)
    assert len(seen) == 8
    for res, sh2 in seen:
        assert _same(res, sh2, count)
    assert count.P > 300 and count.k < count.P       # (pieces left out: the new path tried)


def _made_up(rng, nc):
    """nc chains of made-up pieces: kinds of chains that put vc at, above, below the ends."""
    L, T, beta, v0, v1, poff = [], [], [], [], [], [0]
    for _ in range(nc):
        m = int(rng.integers(1, 12))
        kind = rng.integers(0, 6)
        g = rng.choice([0.01, 0.1, 0.2, 0.24, 0.3, 1.5]) * rng.uniform(0.5, 1.0, m)     # γ
        t = rng.uniform(0.001, 0.2, m)
        cap = rng.uniform(5, 300)
        if kind == 0:            # cruise: equal pieces between speeds at the cap (ties)
            t[:] = t[0]
            g[:] = g[0]
            a, b = np.full(m, cap), np.full(m, cap)
            ln = cap * t * rng.choice([0.999, 1.0, 1.001])
            ln = np.full(m, ln[0])
        elif kind == 1:          # a rise and a fall through random knots
            knots = np.concatenate([[0.0], rng.uniform(0, cap, m - 1), [0.0]]) if m > 1 else np.array([0.0, 0.0])
            a, b = knots[:-1], knots[1:]
            ln = t * (a + b) / 2 * rng.uniform(0.9, 1.2, m)
        elif kind == 2:          # large bumps (|r| small, vc far inside) and |r| near and above 1
            a, b = rng.uniform(0, cap, m), rng.uniform(0, cap, m)
            ln = t * (a + b) / 2 + rng.choice([-1, 1], m) * t * cap * rng.choice([1e-6, 1e-3, 0.05, 0.3, 2.0], m)
        elif kind == 3:          # zero and signed-zero speeds
            a = rng.choice([0.0, -0.0, cap], m)
            b = rng.choice([0.0, -0.0, cap], m)
            ln = t * (a + b) / 2 + rng.choice([0.0, 1e-9, -1e-9], m)
        elif kind == 4:          # a piece whose r lies between 1/8 and 1
            a, b = np.full(m, cap), np.full(m, cap * 0.5)
            ln = t * (a + b) / 2 * rng.uniform(0.98, 1.02, m)
        else:                    # near-linear pieces (A ~ 0): vc near an end
            a, b = rng.uniform(0, cap, m), rng.uniform(0, cap, m)
            ln = t * (a + b) / 2 * (1 + rng.uniform(-1e-12, 1e-12, m))
        L += list(ln)
        T += list(t)
        beta += list((t / g) ** 2)
        v0 += list(a)
        v1 += list(b)
        poff.append(poff[-1] + m)
    return _block(L, T, beta, v0, v1, poff)


@pytest.mark.parametrize("seed", range(12))
def test_made_up_pieces_same_figures(seed):
    rng = np.random.default_rng(seed)
    count = _Count(lc.CORE_MOD)
    for nc in (1, 3, 40, 400):
        assert _same(_made_up(rng, nc), None, count)
    assert count.k < count.P


def _vc_and_need(res):
    """Every piece's vc by the former path's operations (fig_a, fig_b, _atanhc, fig_c, _shc, fig_d's
    formula) and fig_need's mask, with the chains' end-speed extremes and vc's."""
    core, f = lc.CORE_MOD, np.ascontiguousarray
    L, T, beta, v0, v1, poff = res.L, res.T, res.beta, res.v0, res.v1, res.poff
    P = L.size
    gamma, gs, n, m, s1, wbar, dl, A = (np.empty(P) for _ in range(8))
    assert not core.fig_a(L, T, beta, v0, v1, lc._COEF_C, lc._ZMAX_C, gamma, gs, n, m, s1, wbar, dl, A)
    sh2 = f(lc._shc(gs / 2))
    iv, kog, vs, ve, rho, r = (np.empty(P) for _ in range(6))
    core.fig_b(L, T, gamma, n, m, s1, sh2, wbar, dl, A, iv, kog, vs, ve, rho, r)
    with np.errstate(divide="ignore", invalid="ignore"):
        atc = f(lc._atanhc(r))
    tau, za, zb, zx = (np.empty(P) for _ in range(4))
    core.fig_c(T, gs, rho, kog, r, atc, tau, za, zb, zx)
    pa, pb, shx = (lc._shc(z) for z in (za, zb, zx))
    g = (((tau * (1 - tau)) * pa) * pb) / (2 * n)
    h = ((2 * (tau - 0.5)) * shx) / sh2
    vc = ((wbar + A * g) - dl * h) / T
    idx, rs = np.empty(P, np.int64), np.empty(P)
    k = core.fig_need(T, gs, rho, kog, r, n, sh2, wbar, dl, A, vs, ve, poff, idx, rs)
    need = np.zeros(P, bool)
    need[idx[:k]] = True
    assert np.array_equal(_bits(rs[:k]), _bits(r[idx[:k]]))
    return vc, need, np.abs(r), gs, vs, ve


@pytest.mark.parametrize("seed", range(4))
def test_left_out_pieces_are_strictly_inside(seed):
    """fig_need's soundness itself: a piece left out has its exact vc strictly below its
    chain's largest speed candidate and strictly above its least; and the made-up pieces reach
    each branch (left out, needed, γ > 1/4, 1/8 < |r| < 1, |r| >= 1)."""
    rng = np.random.default_rng(100 + seed)
    res = _made_up(rng, 3000)
    vc, need, ar, gs, vs, ve = _vc_and_need(res)
    poff = res.poff
    cnt = np.diff(poff)
    hi = np.maximum.reduceat(np.maximum(np.maximum(vs, ve), vc), poff[:-1])
    lo = np.minimum.reduceat(np.minimum(np.minimum(vs, ve), vc), poff[:-1])
    out = ~need
    assert out.sum() > 100 and need.sum() > 100
    assert np.all(vc[out] < np.repeat(hi, cnt)[out]) and np.all(vc[out] > np.repeat(lo, cnt)[out])
    assert np.any(gs > 0.25) and np.all(need[gs > 0.25])
    mid = (ar > 0.125) & (ar < 1)
    assert mid.any() and np.all(need[mid])
    assert np.any(ar >= 1)


def test_runs_of_chains_and_a_chain_longer_than_a_run():
    """fig_need takes whole chains in runs of at most 1024 pieces: chains across a run's end,
    and a chain of more pieces (all its pieces needed), the same figures."""
    rng = np.random.default_rng(5)
    a, b = _made_up(rng, 300), _made_up(rng, 300)
    m = 1500                                            # one long chain: a rise and a fall
    t = rng.uniform(0.001, 0.02, m)
    knots = np.concatenate([[0.0], rng.uniform(0, 100, m - 1), [0.0]])
    ln = t * (knots[:-1] + knots[1:]) / 2 * rng.uniform(0.9, 1.2, m)
    cat = lambda f, x: np.concatenate([getattr(a, f), x, getattr(b, f)])      # noqa: E731
    poff = np.concatenate([a.poff, a.poff[-1] + m + b.poff])
    res = _block(cat("L", ln), cat("T", t), cat("beta", (t / 0.1) ** 2), cat("v0", knots[:-1]),
                 cat("v1", knots[1:]), poff)
    count = _Count(lc.CORE_MOD)
    assert _same(res, None, count)
    assert 0 < count.k < count.P
    _, need, _, _, _, _ = _vc_and_need(res)
    long = slice(int(a.poff[-1]), int(a.poff[-1]) + m)
    assert need[long].all() and not need[:long.start].all() and res.L.size > 2 * 1024
