"""Session 35 (chains): tod_at (laws/_chaincore.c) is tod_prep and tod_solve in one call, reading
each law's numbers where the step's laws hold them (at pj[i]) instead of copying them out for
the free vertices first and gathering from the copies at every step.  The same operations on
the same numbers: on the batches real chains of the bundled full-speed gyroid hand
_tod_core_at (both junction laws), its times, speeds and laws still going must be those of
tod_prep then tod_solve, bit for bit, whole and cut short after a few steps; and the whole
path (_tod_core_at) the numpy reference's."""
import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.laws import chain as lc

pytestmark = pytest.mark.skipif(lc.CORE_MOD is None, reason=f"the chain core is not used here ({lc.CORE_WHY})")

from test_speed_chains import _chain_problems  # noqa: E402


def _bits(x):
    return np.asarray(x, float).view(np.int64)


def _at_batches(prof, monkeypatch):
    """(law, pj, s_targets) of every _tod_core_at call the active-set steps make."""
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


def _laws(law):
    c, f = law._c, np.ascontiguousarray
    return tuple(f(a, float) for a in (law.T, law.L, c["gs"], c["n"], c["sh2"], law._wbar, law._A, law._delta))


def _prep_solve(core, law, pj, s, max_iter):
    """(out, vout, act, laws still going) by tod_prep then tod_solve (tod_at's reference)."""
    N = pj.size
    Tc, gs, n, sh2, wbar, A, dl, target, sgn, lo, hi, t, scale, out, vout = (np.empty(N) for _ in range(15))
    act = np.empty(N, np.int64)
    core.tod_prep(*_laws(law), pj, s, Tc, gs, n, sh2, wbar, A, dl, target, sgn, lo, hi, t, scale, out, act)
    na = core.tod_solve(t, Tc, gs, n, sh2, wbar, A, dl, target, sgn, lo, hi, scale, act, out, vout,
                        lc._S1_COEF_C, lc._S1_ZMAX_C, lc._SINH_COEF_C, max_iter)
    return out, vout, act, na


def _at(core, law, pj, s, max_iter):
    N = pj.size
    out, vout, act = np.empty(N), np.empty(N), np.empty(N, np.int64)
    na = core.tod_at(*_laws(law), pj, s, out, vout, act, lc._S1_COEF_C, lc._S1_ZMAX_C, lc._SINH_COEF_C, max_iter)
    return out, vout, act, na


def _same(a, b):
    """Two (out, vout, act, na): the same t of every law, ṡ of the laws done, laws still going."""
    out, vout, act, na = a
    out2, vout2, act2, na2 = b
    done = np.ones(out.size, bool)
    done[act[:na]] = False
    return (na == na2 and np.array_equal(act[:na], act2[:na2]) and np.array_equal(_bits(out), _bits(out2))
            and np.array_equal(_bits(vout[done]), _bits(vout2[done])))


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_tod_at_same_bits_as_prep_then_solve(prof, monkeypatch):
    batches = _at_batches(prof, monkeypatch)
    assert len(batches) >= 4 and max(pj.size for _, pj, _ in batches) > 256      # several chunks a step
    core = lc.CORE_MOD
    for law, pj, x in batches:
        pj = np.ascontiguousarray(pj, np.int64)
        x = np.ascontiguousarray(x, float)
        got = _at(core, law, pj, x, 200)
        assert got[3] == 0
        assert _same(got, _prep_solve(core, law, pj, x, 200))
        # and the whole path, the numpy reference's numbers
        t, v = lc._tod_core_at(core, law, pj, x)
        sub = law.take(pj)
        t_ref = lc._time_of_distance(sub, x)
        assert np.array_equal(_bits(t), _bits(t_ref))
        assert np.array_equal(_bits(v), _bits(lc._eval(sub, t_ref, "v")[1]))


@pytest.mark.parametrize("steps", [0, 1, 2, 3])
def test_tod_at_cut_short_same_bits(steps, monkeypatch):
    """Out of steps: the laws still going (act's first ones, in the order tod_solve leaves
    them) and their last t, as tod_prep then tod_solve leave them; in a scrambled order with
    repeats of the laws, so that act's compaction runs out of the laws' order."""
    law, pj, x = max(_at_batches("voron24", monkeypatch), key=lambda b: b[1].size)
    rng = np.random.default_rng(35)
    pj = np.ascontiguousarray(rng.integers(0, law.T.size, 3 * law.T.size + 7), np.int64)
    s = rng.uniform(0.0, 1.0, pj.size) * law.L[pj]
    core = lc.CORE_MOD
    got = _at(core, law, pj, s, steps)
    assert got[3] > 0                      # (laws were still going: the cut mattered)
    assert _same(got, _prep_solve(core, law, pj, s, steps))
    # a wrong target is seen (the comparison can fail)
    assert not _same(_at(core, law, pj, s * (1 + 1e-9), 200), _prep_solve(core, law, pj, s, 200))


def test_tod_at_refuses_a_piece_out_of_range(monkeypatch):
    law, pj, x = _at_batches("prusa-mk3s", monkeypatch)[0]
    pj = np.ascontiguousarray(pj, np.int64).copy()
    pj[-1] = law.T.size
    with pytest.raises(ValueError, match="tod_at: shapes"):
        _at(lc.CORE_MOD, law, pj, np.ascontiguousarray(x, float), 200)
