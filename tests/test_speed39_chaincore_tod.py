"""Session 39 (chaincore): the time-of-distance iteration (tod_iterate, laws/_chaincore.c, under
tod_at and tod_solve) keeps each active law's own numbers (t, lo, hi, τ, shc(γ/4), sgn, target,
scale, its place in the law arrays) in act's order, and makes each step's bracket, done and
next t in a vector pass (tod_step), where it gathered them through act and ran that part one law
at a time; the laws done stay in place, marked, until they are more than an eighth of the
entries, when the laws going are moved up in order.  The same operations on the same numbers:
its times, speeds and laws still going must be the numpy reference's bits
(chain._time_of_distance and chain._eval), for laws taken in a scrambled order with repeats,
targets at, inside and beyond the laws' ends, whole and cut short after each number of steps;
and tod_solve handed an act that is not 0..N-1 (its copies in act's order) must give what it
gives in order."""
import numpy as np
import pytest

from gcode_opt.laws import chain as lc

pytestmark = pytest.mark.skipif(lc.CORE_MOD is None, reason=f"the chain core is not used here ({lc.CORE_WHY})")

from test_speed28_chain_tod import _tod_batches  # noqa: E402


def _bits(x):
    return np.asarray(x, float).view(np.int64)


@pytest.fixture(scope="module")
def batch():
    mp = pytest.MonkeyPatch()
    try:
        law, _ = max(_tod_batches("voron24", mp), key=lambda b: b[1].size)
    finally:
        mp.undo()
    return law


def _targets(law, pj, seed):
    """Distances into the laws pj: mostly inside, some at 0 and at L, some beyond both ends."""
    rng = np.random.default_rng(seed)
    L = law.L[pj]
    u = rng.uniform(0.0, 1.0, pj.size)
    kind = rng.integers(0, 8, pj.size)
    u = np.where(kind == 0, 0.0, np.where(kind == 1, 1.0, np.where(kind == 2, rng.uniform(1.0, 1.5, pj.size),
                                                                      np.where(kind == 3, -0.3, u))))
    return u * L


def _ref(law, pj, s, steps):
    sub = law.take(pj)
    t = lc._time_of_distance(sub, s, max_iter=steps)
    return t, lc._eval(sub, t, "v")[1]


@pytest.mark.parametrize("steps", [0, 1, 2, 3, 4, 5, 6, 200])
def test_tod_at_same_bits_as_numpy_scrambled(batch, steps):
    law = batch
    rng = np.random.default_rng(39 + steps)
    pj = np.ascontiguousarray(rng.integers(0, law.T.size, 2 * law.T.size + 301), np.int64)
    s = _targets(law, pj, steps)
    N = pj.size
    out, vout, act = np.empty(N), np.empty(N), np.empty(N, np.int64)
    laws = tuple(np.ascontiguousarray(a, float) for a in (law.T, law.L, law._c["gs"], law._c["n"], law._c["sh2"],
                                                            law._wbar, law._A, law._delta))
    na = lc.CORE_MOD.tod_at(*laws, pj, s, out, vout, act, lc._S1_COEF_C, lc._S1_ZMAX_C, lc._SINH_COEF_C, steps)
    t_ref, v_ref = _ref(law, pj, s, steps)
    assert np.array_equal(_bits(out), _bits(t_ref))
    going = act[:na]
    if 0 < steps < 200:
        assert 0 < na < N                   # (the cut mattered, and some laws were done)
    assert np.array_equal(going, np.sort(going))          # the laws going keep their order
    done = np.ones(N, bool)
    done[going] = False
    assert np.array_equal(_bits(vout[done]), _bits(v_ref[done]))
    # the laws done stay where they are in the reference's next step
    if steps < 200:
        t_more, _ = _ref(law, pj, s, steps + 1)
        assert np.array_equal(_bits(t_more[done]), _bits(t_ref[done]))


def _solve(law, pj, s, order, steps):
    """tod_prep then tod_solve with act = order (a permutation of 0..N-1)."""
    core = lc.CORE_MOD
    N = pj.size
    Tc, gs, n, sh2, wbar, A, dl, target, sgn, lo, hi, t, scale, out, vout = (np.empty(N) for _ in range(15))
    act = np.empty(N, np.int64)
    laws = tuple(np.ascontiguousarray(a, float) for a in (law.T, law.L, law._c["gs"], law._c["n"], law._c["sh2"],
                                                            law._wbar, law._A, law._delta))
    core.tod_prep(*laws, pj, s, Tc, gs, n, sh2, wbar, A, dl, target, sgn, lo, hi, t, scale, out, act)
    act[:] = order
    vout[:] = np.nan
    na = core.tod_solve(t, Tc, gs, n, sh2, wbar, A, dl, target, sgn, lo, hi, scale, act, out, vout,
                        lc._S1_COEF_C, lc._S1_ZMAX_C, lc._SINH_COEF_C, steps)
    return out, vout, act[:na].copy()


@pytest.mark.parametrize("steps", [0, 2, 4, 200])
def test_tod_solve_act_out_of_order(batch, steps):
    law = batch
    rng = np.random.default_rng(139 + steps)
    pj = np.ascontiguousarray(rng.integers(0, law.T.size, law.T.size + 517), np.int64)
    s = _targets(law, pj, 1000 + steps)
    N = pj.size
    perm = rng.permutation(N)
    out0, vout0, going0 = _solve(law, pj, s, np.arange(N), steps)
    out1, vout1, going1 = _solve(law, pj, s, perm, steps)
    t_ref, v_ref = _ref(law, pj, s, steps)
    assert np.array_equal(_bits(out0), _bits(t_ref))
    assert np.array_equal(_bits(out1), _bits(t_ref))
    # the same laws still going, in act's order
    assert np.array_equal(np.sort(going0), np.sort(going1))
    assert np.array_equal(going1, perm[np.isin(perm, going0)])
    done = np.ones(N, bool)
    done[going0] = False
    assert np.array_equal(_bits(vout0[done]), _bits(v_ref[done]))
    assert np.array_equal(_bits(vout1[done]), _bits(v_ref[done]))
    if 0 < steps < 200:
        assert 0 < going0.size < N
