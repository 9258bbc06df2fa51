"""Session 40 (chain): the chain core's Horner loops keep a block's series in registers
(gcc's 4-double vectors) and give the same bits.

- ex_chunk (exact_share's slopes J', J''): the six series of 8 pieces at a time, each
  coefficient read a vector wide as it is added (exact_share's table), not the series
  stored and loaded a term;
- tod_chunk (the time of distance's s and ṡ): the three sinh series and the S1 series of 8
  laws at a time as two vectors each (gcc's own vectorising of the block kept a third of
  it in scalar lanes).
Both against the numpy code they stand for (_share_time_exact with core=False; the numpy
time of distance and _eval), bit for bit, on every series length k the step can pick (the
largest z of a batch put in each of _EX_ZMAX's bands, γ over decades for the sinh and S1
series) and on batch and chain sizes around the blocks of 8 and the chunks of 256 (the
last block's padding lanes)."""
import numpy as np
import pytest

from gcode_opt.laws import chain as lc

CORE = lc.CORE_MOD
needs_core = pytest.mark.skipif(CORE is None, reason=f"the chain core is not used here ({lc.CORE_WHY})")


def _same(x, y):
    x, y = np.asarray(x), np.asarray(y)
    return x.shape == y.shape and x.dtype == y.dtype and x.tobytes() == y.tobytes()


def _chains_at_z(rng, npc, zmax):
    """_share_time inputs of chains of npc pieces (owner ascending) whose pieces' z = T²/β
    are uniform in [0.6 zmax, zmax] (one at zmax), their totals near their pieces' sum (small
    steps: few batches declined): the first step's series length is _exact_terms(zmax)'s."""
    n_c = len(npc)
    owner = np.repeat(np.arange(n_c), npc)
    P = owner.size
    L = rng.uniform(0.05, 5.0, P)
    va, vb = rng.uniform(40.0, 60.0, P), rng.uniform(40.0, 60.0, P)
    T_init = 2 * L / (va + vb) * rng.uniform(0.9, 1.1, P)          # near the shares: small steps
    T_total = np.bincount(owner, T_init, n_c) * rng.uniform(0.99, 1.01, n_c)
    z = zmax * rng.uniform(0.6, 1.0, P)
    z[rng.integers(0, P)] = zmax
    beta = T_init * T_init / z
    return L, beta, va, vb, owner, T_total, T_init


# the bands of z the exact path takes (not empty, not above what it declines)
_BANDS = [b for b in range(2, lc._EX_ZMAX.size)
          if lc._EX_ZMAX[b] > 0.0 and lc._EX_ZMAX[b - 1] < 0.9 * lc.EXACT_GAMMA_MAX ** 2]


def test_bands_to_check_are_there():
    assert len(_BANDS) >= 3


@needs_core
@pytest.mark.parametrize("band", _BANDS)
def test_exact_share_every_series_length(band):
    rng = np.random.default_rng(4000 + band)
    zmax = min(lc._EX_ZMAX[band] * 0.999, 0.9 * lc.EXACT_GAMMA_MAX ** 2)
    assert lc._exact_terms(zmax) == band + 1          # (k terms: the band of z, plus one)
    solved = 0
    for npc in ([1], [7], [8], [9], [3, 16, 1, 5], list(range(1, 20)), [255, 256, 257], [300, 2, 520]):
        a = _chains_at_z(rng, np.array(npc), zmax)
        got = lc._share_time_exact(*a, core=CORE)
        want = lc._share_time_exact(*a, core=False)
        assert (got is None) == (want is None), npc
        if want is not None:
            solved += 1
            for x, y in zip(got, want, strict=True):
                assert _same(x, y), (band, npc)
    assert solved >= 4


def _tod_laws(rng, P, gmax):
    L = rng.uniform(-2.0, 8.0, P)
    L[rng.random(P) < 0.05] = 0.0
    T = rng.uniform(1e-3, 0.3, P)
    va, vb = rng.uniform(0.0, 200.0, P), rng.uniform(0.0, 200.0, P)
    gamma = 10.0 ** rng.uniform(-4.0, np.log10(gmax), P)
    law = lc._step_law(L, T, (T / gamma) ** 2, va, vb)
    assert "lite" in law._c
    return law


@needs_core
@pytest.mark.parametrize("gmax", [1e-3, 0.05, 0.5, 2.0])
def test_tod_every_block_tail(gmax):
    rng = np.random.default_rng(int(4100 + 1000 * gmax))
    for N in list(range(1, 18)) + [31, 32, 33, 255, 256, 257, 263]:
        law = _tod_laws(rng, N, gmax)
        x = law.L * rng.uniform(-0.1, 1.1, N)
        t, v = lc._tod_core(CORE, law, x)
        t_ref = lc._time_of_distance(law, x)
        assert _same(t, t_ref) and _same(v, lc._eval(law, t_ref, "v")[1]), (gmax, N)
        pj = rng.integers(0, N, N + 3)
        xs = law.L[pj] * rng.uniform(-0.1, 1.1, pj.size)
        ta, va = lc._tod_core_at(CORE, law, pj, xs)
        sub = law.take(pj)
        t_ref = lc._time_of_distance(sub, xs)
        assert _same(ta, t_ref) and _same(va, lc._eval(sub, t_ref, "v")[1]), (gmax, N)
