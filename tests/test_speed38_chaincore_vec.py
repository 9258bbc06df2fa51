"""Session 38 (chaincore): the chain core's loops made into SIMD lanes give the same bits.

- step_law and fig_a: the n (and m, S1) series by Horner in blocks of 8 laws held in
  registers (NMS_HORNER8; the last block padded), against numpy's Horner of
  chain._step_law's numpy lines and line._horner_nms, on batches of every size 1 .. 40 and
  around the blocks and chunks, with γ over decades (the series' term counts k from 1 up);
- exact_share: each chain's new durations after its step in a vector loop (ex_move) and the
  largest z = T²/β by its bits (ex_move, ex_zmax), against _share_time_exact's numpy
  iteration (core=False), on synthetic chains of 1 .. 40 pieces, chains converging at
  different steps, and batches that must decline (a γ above EXACT_GAMMA_MAX at a later
  step, a duration not finite);
- exact_prep (its checks and vs, vd as vector loops) against its contract;
- chain_finish (its elementwise lines as vector loops, the vector sqrt of cf_shape and
  cf_trap_times) against its numpy path;
- tod_solve / tod_at against the numpy time of distance on synthetic edge cases.
Each compares every output bit for bit (None where the numpy code declines)."""
import numpy as np
import pytest

from gcode_opt.laws import chain as lc
from gcode_opt.laws.line import _NMS_COEF, _horner_nms, _nms_terms

CORE = lc.CORE_MOD
needs_core = pytest.mark.skipif(CORE is None, reason=f"the chain core is not used here ({lc.CORE_WHY})")


def _bits(x):
    x = np.asarray(x)
    return x.view(np.uint8) if x.dtype == bool else x.view(np.int64)


def _same(x, y):
    x, y = np.asarray(x), np.asarray(y)
    return x.shape == y.shape and x.dtype == y.dtype and np.array_equal(_bits(x), _bits(y))


def _laws(N, rng, gmax):
    """N line laws (L, T, beta, va, vb) with γ = T / √β log-uniform in [1e-4, gmax]."""
    L = rng.uniform(-3.0, 6.0, N)
    T = rng.uniform(1e-3, 0.5, N)
    gamma = 10.0 ** rng.uniform(-4.0, np.log10(gmax), N)
    beta = (T / gamma) ** 2
    return L, T, beta, rng.uniform(0.0, 200.0, N), rng.uniform(0.0, 200.0, N)


def _sizes():
    return list(range(1, 41)) + [63, 64, 65, 255, 256, 257, 1000]


def _numpy_n(gs):
    """chain._step_law's numpy Horner of n (its lines, verbatim)."""
    z2 = gs * gs
    coef = _NMS_COEF[:_nms_terms(z2), 0]
    n = np.empty(z2.shape)
    n[...] = coef[-1]
    for c in coef[-2::-1]:
        np.multiply(n, z2, out=n)
        np.add(n, c, out=n)
    return n


@needs_core
@pytest.mark.parametrize("gmax", [1e-3, 0.1, 1.0, 3.9])
def test_step_law_and_fig_a_equal_numpy(gmax):
    rng = np.random.default_rng(int(gmax * 1000) + 38)
    ks = set()
    for N in _sizes():
        L, T, beta, va, vb = _laws(N, rng, gmax)
        gamma = T / np.sqrt(beta)
        gs = np.minimum(gamma, 4.0)
        ks.add(_nms_terms(gs * gs))
        wbar, dl = T * (va + vb) / 2, T * (va - vb) / 2
        A = L - wbar
        # step_law: gamma, gs, n, wbar, delta, A
        out = [np.full(N, np.nan) for _ in range(6)]
        assert CORE.step_law(L, T, beta, va, vb, lc._COEF_C, lc._ZMAX_C, *out) == 0
        for got, want in zip(out, (gamma, gs, _numpy_n(gs), wbar, dl, A), strict=True):
            assert _same(got, want), N
        # fig_a: gamma, gs, n, m, s1, wbar, delta, A
        out = [np.full(N, np.nan) for _ in range(8)]
        assert CORE.fig_a(L, T, beta, va, vb, lc._COEF_C, lc._ZMAX_C, *out) == 0
        n, m, s1 = _horner_nms(gs * gs)
        for got, want in zip(out, (gamma, gs, n, m, s1, wbar, dl, A), strict=True):
            assert _same(got, want), N
    assert len(ks) >= (1 if gmax < 0.01 else 2)


@needs_core
def test_step_law_declines_as_before():
    """A β not > 0 (its √ a nan: the vector sqrt's), a T not finite, a γ not below the
    switch: 1 (the numpy code runs)."""
    rng = np.random.default_rng(7)
    for N in (1, 5, 8, 9, 33):
        for bad in ("beta0", "betaneg", "Tinf", "gamma"):
            L, T, beta, va, vb = _laws(N, rng, 1.0)
            j = int(rng.integers(N))
            if bad == "beta0":
                beta[j] = 0.0
            elif bad == "betaneg":
                beta[j] = -1.0
            elif bad == "Tinf":
                T[j] = np.inf
            else:
                beta[j] = (T[j] / 4.5) ** 2
            out = [np.empty(N) for _ in range(6)]
            assert CORE.step_law(L, T, beta, va, vb, lc._COEF_C, lc._ZMAX_C, *out) == 1, (N, bad)


def _chains(rng, n_c, gmax=0.3, pmax=40):
    """Synthetic _share_time inputs: n_c chains of 1 .. pmax pieces, owner ascending, one β
    a chain (its whole duration's γ log-uniform in [1e-3, gmax])."""
    npc = rng.integers(1, pmax + 1, n_c)
    owner = np.repeat(np.arange(n_c), npc)
    P = owner.size
    L = rng.uniform(0.05, 5.0, P)
    va, vb = rng.uniform(0.0, 150.0, P), rng.uniform(0.0, 150.0, P)
    T_init = L / rng.uniform(5.0, 150.0, P)
    T_total = np.bincount(owner, T_init, n_c) * rng.uniform(0.7, 1.5, n_c)
    gamma = 10.0 ** rng.uniform(-3.0, np.log10(gmax), n_c)         # a chain's whole γ (its β)
    beta = ((T_total / gamma) ** 2)[owner]
    return L, beta, va, vb, owner, T_total, T_init


def _check(a):
    got = lc._share_time_exact(*a, core=CORE)
    want = lc._share_time_exact(*a, core=False)
    assert (got is None) == (want is None)
    if want is not None:
        for x, y in zip(got, want, strict=True):
            assert _same(x, y)
    return want


@needs_core
@pytest.mark.parametrize("seed", range(6))
def test_exact_share_equals_numpy(seed):
    rng = np.random.default_rng(380 + seed)
    solved = 0
    for n_c in (1, 2, 3, 17, 120):
        for gmax in (1e-3, 0.3, 1.5):
            solved += _check(_chains(rng, n_c, gmax)) is not None
    assert solved >= 12


@needs_core
def test_exact_share_declines_as_numpy():
    rng = np.random.default_rng(38)
    L, beta, va, vb, owner, T_total, T_init = _chains(rng, 30, 0.3)
    # a chain whose total is far above its pieces: its steps grow γ past EXACT_GAMMA_MAX
    T_total[7] *= 40.0
    beta[owner == 7] = (T_total[7] / 40.0 / 1.9) ** 2
    assert _check((L, beta, va, vb, owner, T_total, T_init)) is None
    # a first duration not finite
    L, beta, va, vb, owner, T_total, T_init = _chains(rng, 30, 0.3)
    T_init[5] = np.inf
    assert _check((L, beta, va, vb, owner, T_total, T_init)) is None


def _prep_ref(L, beta, va, vb, owner, n_c):
    """exact_prep's contract: -1 on a β not finite and > 0 or an L, va, vb not finite; 0 on
    owners not nondecreasing in [0, n_c); else 1 and vs, vd, poff, npc."""
    if not (np.all(beta > 0) and np.all(np.isfinite(beta)) and np.all(np.isfinite(L))
            and np.all(np.isfinite(va)) and np.all(np.isfinite(vb))):
        return -1, None
    if owner.size and (owner[0] < 0 or np.any(owner >= n_c) or np.any(np.diff(owner) < 0)):
        return 0, None
    npc = np.bincount(owner, None, n_c).astype(float)
    return 1, (va + vb, va - vb, np.concatenate([[0], np.cumsum(npc)]).astype(np.int64), npc)


@needs_core
def test_exact_prep_equals_its_contract():
    rng = np.random.default_rng(3838)
    cases = 0
    for P in (0, 1, 3, 4, 5, 8, 9, 31, 200):
        for what in ("ok", "Linf", "vanan", "vbinf", "beta0", "betaneg", "betainf", "betanan",
                     "down", "high", "neg"):
            n_c = 6
            owner = np.sort(rng.integers(0, n_c, P))
            L, va, vb = rng.uniform(-5, 5, P), rng.uniform(0, 100, P), rng.uniform(0, 100, P)
            beta = rng.uniform(1e-6, 1.0, P)
            if P and what != "ok":
                j = int(rng.integers(P))
                if what == "Linf":
                    L[j] = -np.inf
                elif what == "vanan":
                    va[j] = np.nan
                elif what == "vbinf":
                    vb[j] = np.inf
                elif what.startswith("beta"):
                    beta[j] = {"beta0": 0.0, "betaneg": -1.0, "betainf": np.inf, "betanan": np.nan}[what]
                elif what == "down" and P > 1:
                    owner[max(j, 1)] = owner[max(j, 1) - 1] - 1 if owner[max(j, 1) - 1] > 0 else n_c
                elif what == "high":
                    owner[j:] = n_c
                elif what == "neg":
                    owner[:j + 1] = -1
            vs, vd, npc = np.empty(P), np.empty(P), np.empty(n_c)
            poff = np.empty(n_c + 1, np.int64)
            got = CORE.exact_prep(L, beta, va, vb, owner, vs, vd, poff, npc)
            want, out = _prep_ref(L, beta, va, vb, owner, n_c)
            assert got == want, (P, what)
            if want == 1:
                for x, y in zip((vs, vd, poff, npc), out, strict=True):
                    assert _same(x, y), (P, what)
            cases += want != 1
    assert cases >= 60


# chain_finish's elementwise lines as vector loops (cf_floor, cf_reach_v2, cf_corners) and the
# vector sqrt of cf_shape and cf_trap_times (-fno-math-errno): the numpy path's bits, on the
# real batches of test_speed21_chainfin_core (those its perturbation test leaves out too) and
# on perturbations of them (another seed)
@needs_core
@pytest.mark.parametrize("name", ["mk3s", "mk3s_nobuf", "voron", "voron_buf", "klipper_auto"])
def test_chain_finish_equals_numpy(tmp_path_factory, name):
    from test_speed21_chainfin_core import _batches, _numpy, _perturbed, _same as _fin_same
    from gcode_opt import chains

    rng = np.random.default_rng(3800)
    rows = 0
    for b in _batches(tmp_path_factory, name):
        for p in (b, _perturbed(b, rng), _perturbed(b, rng)):
            got = chains._finish_core(*p)
            if got is None:                        # declined (a jerk tent input <= 0)
                continue
            assert _fin_same(got, _numpy(p))
            rows += p[3].shape[0]
    assert rows >= 100


# tod_iterate (the chains' time of distance; its step is a vector loop since session 39, the
# laws' own numbers kept in act's order: test_speed39_chaincore_tod.py): tod_solve and tod_at against the numpy
# iteration (chain._time_of_distance, chain._eval), on synthetic lite laws -- lengths 0 and
# negative, speeds 0 (ṡ = 0 at an end: bisection), laws that overshoot and come back (ṡ < 0:
# Newton refused), targets outside [0, L] (clipped), at 0 and at L -- in batches across the
# chunks of 256, whole and cut short
def _tod_laws(rng, P):
    L = rng.uniform(-2.0, 8.0, P)
    L[rng.random(P) < 0.05] = 0.0
    T = rng.uniform(1e-3, 0.3, P)
    va, vb = rng.uniform(0.0, 200.0, P), rng.uniform(0.0, 200.0, P)
    va[rng.random(P) < 0.1] = 0.0
    vb[rng.random(P) < 0.1] = 0.0
    back = rng.random(P) < 0.2          # short for their end speeds: they overshoot and come back (ṡ < 0)
    L[back] = T[back] * (va[back] + vb[back]) / 2 * rng.uniform(0.0, 0.3, int(back.sum()))
    gamma = 10.0 ** rng.uniform(-3.0, 0.3, P)
    law = lc._step_law(L, T, (T / gamma) ** 2, va, vb)
    assert "lite" in law._c
    return law


def _tod_targets(rng, law, N, pj):
    L = law.L[pj]
    x = L * rng.uniform(-0.2, 1.2, N)
    x[rng.random(N) < 0.05] = 0.0
    e = rng.random(N) < 0.05
    x[e] = L[e]
    return x


@needs_core
@pytest.mark.parametrize("steps", [200, 1, 2, 4])
def test_tod_iteration_equals_numpy(steps):
    rng = np.random.default_rng(38000 + steps)
    for N in (1, 3, 8, 255, 256, 257, 700):
        law = _tod_laws(rng, N)
        x = _tod_targets(rng, law, N, np.arange(N))
        t, v = lc._tod_core(CORE, law, x, max_iter=steps)
        t_ref = lc._time_of_distance(law, x, max_iter=steps)
        v_ref = lc._eval(law, t_ref, "v")[1]
        assert _same(t, t_ref) and _same(v, v_ref), (N, steps)
        # tod_at: the laws read at pj (some twice), not taken first
        pj = rng.integers(0, N, N + 5)
        xs = _tod_targets(rng, law, pj.size, pj)
        ta, va_ = lc._tod_core_at(CORE, law, pj, xs, max_iter=steps)
        sub = law.take(pj)
        t_ref = lc._time_of_distance(sub, xs, max_iter=steps)
        assert _same(ta, t_ref) and _same(va_, lc._eval(sub, t_ref, "v")[1]), (N, steps)
