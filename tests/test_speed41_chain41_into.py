"""Session 41 (chain41): tod_at_into (laws/_chaincore.c) is tod_at with its answers put where
_Flat._at_times keeps them: law i's ṡ to v[free[i]] and its t added to t[free[i]] as it ends,
instead of out and vout then numpy's `tl, v[free] = out, vout; t[free] += tl`.  On the
batches real chains of the bundled full-speed gyroid hand _tod_core_at (both junction laws),
v and t must be those of tod_at then the numpy scatters, bit for bit, whole and cut short
after a few steps (the laws still going: their last t and act as tod_at leaves them); and
solve_chains' laws the same with and without it."""
import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.laws import chain as lc

pytestmark = pytest.mark.skipif(lc.CORE_MOD is None, reason=f"the chain core is not used here ({lc.CORE_WHY})")

from test_speed_chains import _chain_problems  # noqa: E402


def _bits(x):
    return np.asarray(x, float).view(np.int64)


def _at_batches(prof, monkeypatch):
    """(law, pj, s_targets) of every _tod_core_at call the active-set steps make (the recorder
    is a stand-in: _at_times then calls it, not tod_at_into)."""
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


def _places(rng, N):
    """free (N places without repeats, scrambled, among 2N + 3) and v, t there."""
    n = 2 * N + 3
    free = np.ascontiguousarray(rng.permutation(n)[:N], np.int64)
    return free, rng.uniform(1.0, 2.0, n), rng.uniform(0.0, 5.0, n)


def _ref(core, law, pj, s, free, v, t, max_iter):
    """tod_at, then _at_times' numpy scatters: (v, t, act[:na], the laws still going' last t)."""
    N = pj.size
    out, vout, act = np.empty(N), np.empty(N), np.empty(N, np.int64)
    na = core.tod_at(*_laws(law), pj, s, out, vout, act, lc._S1_COEF_C, lc._S1_ZMAX_C, lc._SINH_COEF_C, max_iter)
    done = np.ones(N, bool)
    done[act[:na]] = False
    v, t = v.copy(), t.copy()
    v[free[done]] = vout[done]
    t[free[done]] += out[done]
    return v, t, act[:na].copy(), out[act[:na]]


def _into(core, law, pj, s, free, v, t, max_iter):
    v, t = v.copy(), t.copy()
    act = np.empty(pj.size, np.int64)
    rest = core.tod_at_into(*_laws(law), pj, s, free, v, t, act, lc._S1_COEF_C, lc._S1_ZMAX_C, lc._SINH_COEF_C,
                            max_iter)
    return v, t, act[:len(rest)].copy(), np.array(rest, float)


def _same(a, b):
    return (all(np.array_equal(_bits(x), _bits(y)) for x, y in ((a[0], b[0]), (a[1], b[1]), (a[3], b[3])))
            and np.array_equal(a[2], b[2]))


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_tod_at_into_same_bits_as_tod_at_then_scatters(prof, monkeypatch):
    batches = _at_batches(prof, monkeypatch)
    assert len(batches) >= 4 and max(pj.size for _, pj, _ in batches) > 256      # several chunks a step
    core = lc.CORE_MOD
    rng = np.random.default_rng(41)
    for law, pj, x in batches:
        pj = np.ascontiguousarray(pj, np.int64)
        x = np.ascontiguousarray(x, float)
        free, v, t = _places(rng, pj.size)
        got = _into(core, law, pj, x, free, v, t, 200)
        assert got[2].size == 0
        assert _same(got, _ref(core, law, pj, x, free, v, t, 200))
        # and _tod_core_into, the numpy reference's numbers where _at_times puts them
        v2, t2 = v.copy(), t.copy()
        assert lc._tod_core_into(core, law, pj, x, free, v2, t2)
        sub = law.take(pj)
        t_ref = lc._time_of_distance(sub, x)
        v3, t3 = v.copy(), t.copy()
        v3[free] = lc._eval(sub, t_ref, "v")[1]
        t3[free] += t_ref
        assert np.array_equal(_bits(v2), _bits(v3)) and np.array_equal(_bits(t2), _bits(t3))


@pytest.mark.parametrize("steps", [0, 1, 2, 3])
def test_tod_at_into_cut_short_same_bits(steps, monkeypatch):
    """Out of steps: the laws still going (act's first ones) and their last t as tod_at leaves
    them, v and t not written there; in a scrambled order with repeats of the laws, so that
    act's compaction runs out of the laws' order.  And _tod_core_into's numpy end of them."""
    law, pj, x = max(_at_batches("voron24", monkeypatch), key=lambda b: b[1].size)
    rng = np.random.default_rng(41 + steps)
    pj = np.ascontiguousarray(rng.integers(0, law.T.size, 3 * law.T.size + 7), np.int64)
    s = rng.uniform(0.0, 1.0, pj.size) * law.L[pj]
    free, v, t = _places(rng, pj.size)
    core = lc.CORE_MOD
    got = _into(core, law, pj, s, free, v, t, steps)
    assert got[2].size > 0                 # (laws were still going: the cut mattered)
    assert _same(got, _ref(core, law, pj, s, free, v, t, steps))
    # a wrong target is seen (the comparison can fail)
    assert not _same(_into(core, law, pj, s * (1 + 1e-9), free, v, t, 200), _ref(core, law, pj, s, free, v, t, 200))
    # the Python end: the laws still going evaluated as _at_times' numpy lines evaluate them
    v2, t2 = v.copy(), t.copy()
    assert lc._tod_core_into(core, law, pj, s, free, v2, t2, max_iter=steps)
    out, vout, act = np.empty(pj.size), np.empty(pj.size), np.empty(pj.size, np.int64)
    na = core.tod_at(*_laws(law), pj, s, out, vout, act, lc._S1_COEF_C, lc._S1_ZMAX_C, lc._SINH_COEF_C, steps)
    rest = act[:na]
    vout[rest] = lc._eval(law.take(pj[rest]), out[rest], "v")[1]
    v3, t3 = v.copy(), t.copy()
    v3[free] = vout
    t3[free] += out
    assert np.array_equal(_bits(v2), _bits(v3)) and np.array_equal(_bits(t2), _bits(t3))


def test_tod_at_into_refuses_a_place_out_of_range(monkeypatch):
    law, pj, x = _at_batches("prusa-mk3s", monkeypatch)[0]
    pj = np.ascontiguousarray(pj, np.int64)
    free, v, t = _places(np.random.default_rng(1), pj.size)
    free[-1] = v.size
    with pytest.raises(ValueError, match="tod_at_into: shapes"):
        _into(lc.CORE_MOD, law, pj, np.ascontiguousarray(x, float), free, v, t, 200)


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_solve_chains_same_with_and_without_into(prof, monkeypatch):
    sts, T0, profile = _chain_problems(prof)
    probs = chains._problems(sts, T0, (T0 / chains.GAMMA_MIN) ** 2, profile)
    calls = []
    orig = lc._tod_core_into

    def count(*a, **k):
        calls.append(1)
        return orig(*a, **k)
    monkeypatch.setattr(lc, "_tod_core_into", count)
    got = lc.solve_chains(probs)
    assert calls                           # (the C path ran)
    monkeypatch.setattr(lc, "_tod_core_into", lambda *a, **k: False)
    want = lc.solve_chains(probs)
    for g, w in zip(got, want):
        assert np.array_equal(_bits(g.vert_v), _bits(w.vert_v)) and np.array_equal(_bits(g.vert_t), _bits(w.vert_t))
        assert np.array_equal(_bits(g.knot_t), _bits(w.knot_t)) and g.iv == w.iv
