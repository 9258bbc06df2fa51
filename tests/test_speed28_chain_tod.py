"""Session 28 (chaincpu): tod_solve (laws/_chaincore.c) makes each law's τ = clip(t / T) once a
step, where the step moves t, and keeps it beside act for the next step (the pass that found the
S1 terms' count from τ is gone), and selects the bracket instead of branching.  The same
operations on the same numbers: its times and speeds must be the numpy code's bits
(chain._time_of_distance and chain._eval with the deterministic primitives), on the batches
that real chains of the bundled full-speed gyroid hand it (cold and warm, both junction laws),
whole and cut short after a few steps (the laws still going, their last t), and across the
chunks of CHUNK (256) laws its steps gather."""
import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.laws import chain as lc

pytestmark = pytest.mark.skipif(lc.CORE_MOD is None, reason=f"the chain core is not used here ({lc.CORE_WHY})")

from test_speed_chains import _chain_problems  # noqa: E402


def _bits(x):
    return np.asarray(x, float).view(np.int64)


def _tod_batches(prof, monkeypatch):
    """(law, s_targets) of every time-of-distance batch the active-set steps ask for."""
    sts, T0, profile = _chain_problems(prof)
    got = []
    orig = lc._times_and_speeds

    def rec(law, x, core=None):
        got.append((law, np.array(x)))
        return orig(law, x, core)
    monkeypatch.setattr(lc, "_times_and_speeds", rec)
    for r in (1.0, 1.1):
        T = T0 * r
        lc.solve_chains(chains._problems(sts, T, (T / chains.GAMMA_MIN) ** 2, profile))
    monkeypatch.undo()
    return got


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_tod_solve_same_bits_as_numpy_on_real_batches(prof, monkeypatch):
    batches = _tod_batches(prof, monkeypatch)
    assert len(batches) >= 4 and max(x.size for _, x in batches) > 256      # several chunks a step
    for law, x in batches:
        t, v = lc._tod_core(lc.CORE_MOD, law, x)
        t_ref = lc._time_of_distance(law, x)
        v_ref = lc._eval(law, t_ref, "v")[1]
        assert np.array_equal(_bits(t), _bits(t_ref))
        assert np.array_equal(_bits(v), _bits(v_ref))


@pytest.mark.parametrize("steps", [1, 2, 3, 5])
def test_tod_solve_cut_short_same_bits(steps, monkeypatch):
    """Out of steps: the laws still going keep their last t (and the speed there), as the
    numpy iteration leaves them; the others are done on the step they were done on."""
    law, x = max(_tod_batches("prusa-mk3s", monkeypatch), key=lambda b: b[1].size)
    t, v = lc._tod_core(lc.CORE_MOD, law, x, max_iter=steps)
    t_ref = lc._time_of_distance(law, x, max_iter=steps)
    assert np.array_equal(_bits(t), _bits(t_ref))
    assert np.array_equal(_bits(v), _bits(lc._eval(law, t_ref, "v")[1]))
    if steps == 1:      # (some laws were still going: the cut mattered)
        assert not np.array_equal(_bits(t), _bits(lc._time_of_distance(law, x)))


def test_tod_solve_taken_laws_same_bits(monkeypatch):
    """_tod_core_at (tod_at reading the laws pj where they are, as solve_fixed calls it) gives
    _times_and_speeds' bits on the taken laws, in a scrambled order with repeats, so that act's
    compaction and the kept τ are exercised out of the laws' order."""
    law, x = max(_tod_batches("voron24", monkeypatch), key=lambda b: b[1].size)
    rng = np.random.default_rng(28)
    pj = rng.integers(0, law.T.size, 3 * law.T.size + 7)
    s = rng.uniform(0.0, 1.0, pj.size) * law.L[pj]
    t, v = lc._tod_core_at(lc.CORE_MOD, law, pj, s)
    sub = law.take(pj)
    t_ref = lc._time_of_distance(sub, s)
    assert np.array_equal(_bits(t), _bits(t_ref))
    assert np.array_equal(_bits(v), _bits(lc._eval(sub, t_ref, "v")[1]))
    # and a wrong target is seen (the comparison can fail)
    t2, _ = lc._tod_core_at(lc.CORE_MOD, law, pj, s * (1 + 1e-9))
    assert not np.array_equal(_bits(t2), _bits(t_ref))
