"""Session 42 (chain42): the chain core's sinh series by Horner from a lower term (HornerSkip in
_chaincore.c: shc_quarter and tod_chunk start a block of 8 lanes at the term its largest square
allows, run lower and upper bounds until they meet, then the plain steps) give the full Horner's
bits.  Reference: the numpy operations of prims (full Horner, every term) and tod_chunk's formula
written out here; the C entry horner_skip_c runs shc_quarter then tod_chunk with a table made at
tol_exp (-60: the module's; 0: every block the full Horner; coarser ones: many blocks take several
bound steps or miss and run the whole series again)."""
import numpy as np
import pytest

from gcode_opt.laws import chain, prims
from gcode_opt.laws.line import _S1_COEF

CORE = chain.CORE_MOD
pytestmark = pytest.mark.skipif(not (CORE and hasattr(CORE, "horner_skip_c")), reason="no chain core")

TOLS = (-60, 0, -30, -40, -50, -53, -56, -62)
CHUNK = 256


def _horner(coef, x2):
    e = np.full(x2.shape, coef[-1])
    for c in coef[-2::-1]:
        e = e * x2 + c
    return e


def _reference(tau, g, k, n, sh2, wbar, A, dl, T):
    """shc(γ/4) and tod_chunk's s, ṡ with prims (numpy, the whole sinh series)."""
    with np.errstate(all="ignore"):
        za, zb, zx = (g * tau) / 2, (g * (1 - tau)) / 2, g * (tau - 0.5)
        x = tau - 0.5
        pa, pb, shx, s4 = prims.shc(za), prims.shc(zb), prims.shc(zx), prims.shc(g / 4)
        s1 = _horner(np.ascontiguousarray(_S1_COEF[:k]), zx * zx)
        bub = ((tau * (1 - tau)) * pa) * pb
        gg = bub / (2 * n)
        Hs = (-bub) / sh2
        h = ((2 * x) * shx) / sh2
        G = 0.5 + (((x * (s4 * s4)) / 8) - prims.cube(x) * s1) / n
        s = ((wbar * tau) + (A * G)) - (dl * Hs)
        v = ((wbar + A * gg) - dl * h) / T
    return s4, s, v


def _core(tau, g, k, n, sh2, wbar, A, dl, T, tol):
    N = tau.size
    s4, s, v = np.empty(N), np.empty(N), np.empty(N)
    f = np.ascontiguousarray
    CORE.horner_skip_c(f(tau), f(g), f(_S1_COEF), k, f(prims.SINH_COEF), f(n), f(sh2), f(wbar), f(A), f(dl),
                       f(T), s4, s, v, tol)
    return s4, s, v


def _same(a, b):
    """Bit for bit, a nan anywhere matching a nan (numpy's and the C's nan payloads may differ)."""
    na, nb = np.isnan(a), np.isnan(b)
    return bool(np.array_equal(na, nb) and np.array_equal(a[~na].view(np.int64), b[~nb].view(np.int64)))


def _laws(rng, g, tau):
    N = g.size
    n = rng.uniform(0.05, 0.2, N)
    sh2 = rng.uniform(1.0, 1.5, N)
    wbar = rng.uniform(-5, 5, N)
    A = rng.uniform(-3, 3, N)
    dl = rng.uniform(-2, 2, N)
    T = rng.uniform(1e-3, 1.0, N)
    return tau, g, n, sh2, wbar, A, dl, T


def _random_gammas(rng, N):
    """γ log-uniform over 1e-9 .. 4 (the series branch), the chains' 0.002 .. 0.1 weighted, shuffled so
    blocks of 8 mix magnitudes; τ uniform with 0, 1/2, 1 and near them."""
    g = np.concatenate([np.exp(rng.uniform(np.log(1e-9), np.log(4.0), N // 2)),
                        np.exp(rng.uniform(np.log(2e-3), np.log(0.1), N - N // 2))])
    rng.shuffle(g)
    tau = rng.uniform(0, 1, N)
    pick = rng.integers(0, 12, N)
    tau = np.where(pick == 0, 0.0, np.where(pick == 1, 1.0, np.where(pick == 2, 0.5, tau)))
    tau = np.where(pick == 3, rng.uniform(0, 1e-6, N), np.where(pick == 4, 1 - rng.uniform(0, 1e-6, N), tau))
    return g, tau


def _adversarial(rng):
    """Squares at and beside each table row's bound 2^e (γ/2 = 2^(e/2) and its neighbours, τ = 1: za = zx =
    γ/2, zb = 0; γ/4 for shc_quarter), zeros, subnormals, nan, inf, γ past the table (x up to ~100), blocks
    of equal lanes and blocks of tiny lanes with one large."""
    parts = []
    for e in range(-188, 12, 2):
        r = 2.0 ** (e / 2)
        for x in (r, np.nextafter(r, 0), np.nextafter(r, np.inf), np.nextafter(np.nextafter(r, 0), 0)):
            parts.append([2 * x, 4 * x, 2 * x * 1.0000001, 2 * x * 0.9999999])
    g = np.concatenate([np.ravel(parts)] * 3)
    tau = np.concatenate([np.ones(g.size // 3), rng.uniform(0, 1, g.size // 3), np.full(g.size // 3, 0.5)])
    special = np.array([0.0, 5e-324, 1e-310, 2.2250738585072014e-308, np.nan, np.inf, -np.inf, -0.0,
                        4.0, 3.9999999999999996, 8.0, 12.0, 20.0, 1e-160, 1e-100])
    sg = np.repeat(special, 8)
    st = np.tile(np.array([0.0, 0.25, 0.5, 0.75, 1.0, 0.1, 0.9, 0.6]), special.size)
    mix = np.full(8 * 64, 1e-5)
    mix[::8] = np.exp(rng.uniform(np.log(1e-3), np.log(4.0), 64))
    mt = rng.uniform(0, 1, mix.size)
    return np.concatenate([g, sg, mix]), np.concatenate([tau, st, mt])


@pytest.mark.parametrize("tol", TOLS)
def test_random_against_numpy(tol):
    rng = np.random.default_rng(4200 + tol)
    g, tau = _random_gammas(rng, 400_000)
    args = _laws(rng, g, tau)
    for k in (1, 6, 17, 24):
        ref = _reference(*args[:2], k, *args[2:])
        got = _core(*args[:2], k, *args[2:], tol)
        for a, b in zip(ref, got):
            assert _same(a, b), (tol, k)


@pytest.mark.parametrize("tol", TOLS)
def test_adversarial_against_numpy(tol):
    rng = np.random.default_rng(42)
    g, tau = _adversarial(rng)
    for shift in range(0, 8, 3):          # the same lanes in other blocks of 8, and a tail not a block
        gg, tt = np.roll(g, shift)[: g.size - shift], np.roll(tau, shift)[: g.size - shift]
        args = _laws(rng, gg, tt)
        ref = _reference(*args[:2], 7, *args[2:])
        got = _core(*args[:2], 7, *args[2:], tol)
        for a, b in zip(ref, got):
            assert _same(a, b), (tol, shift)


def test_millions_chains_range():
    """The chains' own range (γ 0.002 .. 0.1), 3 M laws, the module's table against the full Horner (C
    both: all bits, nan-free)."""
    rng = np.random.default_rng(7)
    N = 3_000_000
    g = np.exp(rng.uniform(np.log(2e-3), np.log(0.1), N))
    tau = rng.uniform(0, 1, N)
    args = _laws(rng, g, tau)
    full = _core(*args[:2], 6, *args[2:], 0)
    skip = _core(*args[:2], 6, *args[2:], -60)
    for a, b in zip(full, skip):
        assert np.array_equal(a.view(np.int64), b.view(np.int64))


def test_tod_solve_unchanged_against_numpy():
    """The whole iteration (tod_solve, which now starts its series lower) against the numpy
    _time_of_distance and _eval: the same t and ṡ bits."""
    from gcode_opt.laws.line import LineLaw
    rng = np.random.default_rng(11)
    N = 3000
    T = rng.uniform(0.002, 0.05, N)
    beta = (T / rng.uniform(2e-3, 0.1, N)) ** 2
    L = rng.uniform(0.01, 3.0, N)
    va, vb = rng.uniform(0, 60, N), rng.uniform(0, 60, N)
    law = LineLaw(L, T, beta, va, vb)
    s = L * rng.uniform(0, 1, N)
    assert bool(law._c["small"].all())
    t_c, v_c = chain._times_and_speeds(law, s, core=CORE)
    t_n, v_n = chain._times_and_speeds(law, s, core=False)
    assert np.array_equal(t_c.view(np.int64), t_n.view(np.int64))
    assert np.array_equal(v_c.view(np.int64), v_n.view(np.int64))
