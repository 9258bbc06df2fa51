"""Session 41 (chain41): the time-of-distance iteration (tod_iterate in laws/_chaincore.c: tod_at,
tod_at_into, tod_solve) gathers each law's T, γ, n, sh2, wbar, A, δ once, in the order of its
active laws, and moves them up with the laws going, instead of gathering them chunk by chunk
at every step.  The same numbers: on the batches real chains of the bundled full-speed gyroid
hand _tod_core_at (both junction laws), whole, cut short after a few steps, scrambled with
repeats (the compaction then runs out of the laws' order) and through tod_solve with act not
0..N-1 (its copies), each law's t and ṡ must be the numpy reference's (_time_of_distance,
_eval) bit for bit.  Also _step_law_core's law: its gs the γ array itself (the same bits as
the copy it was), and _at_times' end accelerations, made after the vertices now, the same."""
import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.laws import chain as lc

pytestmark = pytest.mark.skipif(lc.CORE_MOD is None, reason=f"the chain core is not used here ({lc.CORE_WHY})")

from test_speed_chains import _chain_problems  # noqa: E402


def _bits(x):
    return np.asarray(x, float).view(np.int64)


def _batches(prof, monkeypatch):
    sts, T0, profile = _chain_problems(prof)
    got = []
    orig = lc._tod_core_at

    def rec(core, law, pj, x, max_iter=200):
        got.append((law, np.array(pj), np.array(x)))
        return orig(core, law, pj, x, max_iter)
    monkeypatch.setattr(lc, "_tod_core_at", rec)
    for r in (1.0, 1.1):
        T = T0 * r
        lc.solve_chains(chains._problems(sts, T, (T / chains.GAMMA_MIN) ** 2, profile))
    monkeypatch.undo()
    return got


def _ref(law, pj, s, max_iter=200):
    sub = law.take(pj)
    t = lc._time_of_distance(sub, s, max_iter)
    return t, lc._eval(sub, t, "v")[1]


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_tod_at_gathered_once_same_bits_as_numpy(prof, monkeypatch):
    batches = _batches(prof, monkeypatch)
    assert len(batches) >= 4 and max(pj.size for _, pj, _ in batches) > 256
    rng = np.random.default_rng(7)
    for law, pj, x in batches:
        pj = np.ascontiguousarray(pj, np.int64)
        x = np.ascontiguousarray(x, float)
        t, v = lc._tod_core_at(lc.CORE_MOD, law, pj, x)
        tr, vr = _ref(law, pj, x)
        assert np.array_equal(_bits(t), _bits(tr)) and np.array_equal(_bits(v), _bits(vr))
        # scrambled, with repeats: the laws end at other steps, the compaction moves them out of order
        q = np.ascontiguousarray(rng.integers(0, law.T.size, 2 * pj.size + 5), np.int64)
        s = rng.uniform(0.0, 1.0, q.size) * law.L[q]
        t, v = lc._tod_core_at(lc.CORE_MOD, law, q, s)
        tr, vr = _ref(law, q, s)
        assert np.array_equal(_bits(t), _bits(tr)) and np.array_equal(_bits(v), _bits(vr))


def test_tod_solve_act_not_in_order_same_bits(monkeypatch):
    """tod_solve with act a permutation (tod_iterate's copies of target .. hi, and its laws
    gathered in act's order): each law's t and ṡ as with act in order."""
    law, pj, x = max(_batches("voron24", monkeypatch), key=lambda b: b[1].size)
    sub = law.take(np.ascontiguousarray(pj, np.int64))
    core = lc.CORE_MOD
    N = pj.size

    def run(act):
        c, f = sub._c, np.ascontiguousarray
        T, gs, n, sh2, wbar, A, dl = (f(a, float) for a in (sub.T, c["gs"], c["n"], c["sh2"], sub._wbar, sub._A,
                                                            sub._delta))
        target = np.clip(x, np.minimum(0.0, sub.L), np.maximum(0.0, sub.L))
        sgn = np.where(sub.L < 0, -1.0, 1.0)
        lo, hi = np.zeros(N), T.copy()
        t = lo + (hi - lo) * np.where(sub.L != 0, target / sub.L, 0.5)
        scale = np.maximum(np.abs(sub.L), 1e-300)
        out, vout = t.copy(), np.empty(N)
        act = np.ascontiguousarray(act, np.int64)
        na = core.tod_solve(t, T, gs, n, sh2, wbar, A, dl, f(target), sgn, lo, hi, scale, act, out, vout,
                            lc._S1_COEF_C, lc._S1_ZMAX_C, lc._SINH_COEF_C, 200)
        assert na == 0
        return out, vout
    t0, v0 = run(np.arange(N))
    t1, v1 = run(np.random.default_rng(3).permutation(N))
    tr, vr = _ref(law, np.ascontiguousarray(pj, np.int64), x)
    for t, v in ((t0, v0), (t1, v1)):
        assert np.array_equal(_bits(t), _bits(tr)) and np.array_equal(_bits(v), _bits(vr))


def test_step_law_gs_is_gamma_and_accels_the_same():
    rng = np.random.default_rng(11)
    P = 500
    L, T = rng.uniform(0.1, 5.0, P), rng.uniform(0.01, 0.2, P)
    beta = (T / rng.uniform(0.02, 0.15, P)) ** 2
    va, vb = rng.uniform(0.0, 80.0, P), rng.uniform(0.0, 80.0, P)
    law = lc._step_law_core(lc.CORE_MOD, L, T, beta, va, vb)
    assert law._c["gs"] is law.gamma
    g = T / np.sqrt(beta)
    assert np.array_equal(_bits(law._c["gs"]), _bits(np.minimum(g, lc._GAMMA_SWITCH)))
    assert np.array_equal(_bits(law._c["sh2"]), _bits(lc._shc(g / 2)))
    ref = lc.LineLaw(L, T, beta, va, vb)
    for a, b in zip(lc._end_accels(law), ref.end_accels()):
        assert np.array_equal(_bits(a), _bits(b))
