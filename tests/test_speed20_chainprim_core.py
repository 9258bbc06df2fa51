"""Session 20 (chainprim, issue 8): the chains' Newton loops wholly in C.

laws/_chaincore.c's share_time (the whole of _share_time_numpy's iteration) and tod_solve
(the whole of _time_of_distance's, with the speeds at the roots) give the numpy code's
bits, the numpy code now using the deterministic sinh and cube of laws/prims.py; checked
on the batches real chains of the bundled full-speed gyroid hand them (classic jerk and
square-corner velocity), with mutants the checks see; neither loop calls np.sinh or
np.power (numpy's can differ between machines), with the core or without."""
import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.laws import chain as lc
from gcode_opt.laws import prims

from test_speed_chains import _chain_problems, _same  # noqa: E402

needs_core = pytest.mark.skipif(lc.CORE_MOD is None, reason=f"the chain core is not used here ({lc.CORE_WHY})")


def _bits(x):
    x = np.asarray(x)
    return x.view(np.uint8) if x.dtype == bool else x.view(np.int64)


def _batches(prof, monkeypatch):
    """The arguments of every _share_time and _times_and_speeds call of a cold solve and a
    warm one at a nearby duration."""
    sts, T0, profile = _chain_problems(prof)
    share, tod = [], []
    o_share, o_tod = lc._share_time, lc._times_and_speeds

    def rec_share(*a, **k):
        share.append([np.array(x) for x in a])
        return o_share(*a, **k)

    def rec_tod(law, x, core=None):
        tod.append((law, np.array(x)))
        return o_tod(law, x, core)
    monkeypatch.setattr(lc, "_share_time", rec_share)
    monkeypatch.setattr(lc, "_times_and_speeds", rec_tod)
    T = T0 * 1.03
    laws = lc.solve_chains(chains._problems(sts, T, (T / chains.GAMMA_MIN) ** 2, profile))
    T2 = T * 1.02
    lc.solve_chains(chains._problems(sts, T2, (T2 / chains.GAMMA_MIN) ** 2, profile),
                    init_binding=[lw.binding for lw in laws], init_vert_t=[lw.vert_t * 1.02 for lw in laws])
    monkeypatch.undo()
    return share, tod


@needs_core
@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_share_time_and_tod_in_c_same_bits_with_mutants(prof, monkeypatch):
    share, tod = _batches(prof, monkeypatch)
    assert len(share) >= 4 and sum(a[0].size for a in share) > 1000
    assert len(tod) >= 4 and sum(x.size for _, x in tod) > 500
    core = lc.CORE_MOD
    for a in share:
        got = lc._share_time_core(core, *a)
        assert got is not None
        for x, y in zip(got, lc._share_time_numpy(*a), strict=True):
            assert np.array_equal(_bits(x), _bits(y))
    for law, x in tod:
        t, v = lc._tod_core(core, law, x)
        want_t = lc._time_of_distance(law, x)
        assert np.array_equal(_bits(t), _bits(want_t))
        assert np.array_equal(_bits(v), _bits(lc._eval(law, want_t, "v")[1]))
    # mutant: the sinh series' first coefficient 1e-10 off in the C calls only; the checks above see it
    bad = prims.SINH_COEF.copy()
    bad[0] *= 1 + 1e-10
    monkeypatch.setattr(lc, "_SINH_COEF_C", bad)
    a = max(share, key=lambda a: a[0].size)
    assert not np.array_equal(_bits(lc._share_time_core(core, *a)[0]), _bits(lc._share_time_numpy(*a)[0]))
    law, x = max(tod, key=lambda c: c[1].size)
    t, v = lc._tod_core(core, law, x)
    want_t = lc._time_of_distance(law, x)
    assert not (np.array_equal(_bits(t), _bits(want_t))
                and np.array_equal(_bits(v), _bits(lc._eval(law, want_t, "v")[1])))


@pytest.mark.parametrize("with_core", [True, False])
def test_newton_loops_call_no_numpy_sinh_or_power(with_core, monkeypatch):
    """np.sinh and np.power raise inside _share_time and _times_and_speeds (the Newton
    loops): the solves go through, with the core and in the numpy code."""
    if with_core and lc.CORE_MOD is None:
        pytest.skip("no chain core")
    sts, T0, profile = _chain_problems("prusa-mk3s")
    if not with_core:
        monkeypatch.setattr(lc, "CORE_MOD", None)
    o_share, o_tod = lc._share_time, lc._times_and_speeds
    sinh, power = np.sinh, np.power
    calls = []

    def boom(*a, **k):
        raise AssertionError("np.sinh or np.power in a chain Newton loop")

    def guarded(f):
        def g(*a, **k):
            calls.append(f.__name__)
            np.sinh, np.power = boom, boom
            try:
                return f(*a, **k)
            finally:
                np.sinh, np.power = sinh, power
        return g
    monkeypatch.setattr(lc, "_share_time", guarded(o_share))
    monkeypatch.setattr(lc, "_times_and_speeds", guarded(o_tod))
    probs = chains._problems(sts[:40], T0[:40], (T0[:40] / chains.GAMMA_MIN) ** 2, profile)
    laws = lc.solve_chains(probs)
    assert np.sinh is sinh and np.power is power
    assert "_share_time" in calls and "_times_and_speeds" in calls
    assert all(lw.converged for lw in laws[:5])


@needs_core
def test_pure_python_and_core_solves_same_bits(monkeypatch):
    sts, T0, profile = _chain_problems("voron24")
    T = T0 * 1.07
    probs = chains._problems(sts, T, (T / chains.GAMMA_MIN) ** 2, profile)
    got = lc.solve_chains(probs)
    monkeypatch.setattr(lc, "CORE_MOD", None)
    want = lc.solve_chains(probs)
    for a, b in zip(got, want, strict=True):
        _same(a, b)


@needs_core
def test_share_time_rejects_bad_shapes():
    core = lc.CORE_MOD
    P, n_c = 4, 2
    z = np.zeros(P)
    poff = np.array([0, 2, 4], np.int64)
    args = [z + 1, z + 1, z, z, z + 1, poff, np.full(n_c, 2.0), np.ones(n_c), np.ones(P), np.zeros(n_c),
            np.zeros(n_c, np.uint8), lc._COEF_C, lc._ZMAX_C, prims.SINH_COEF, 5]
    bad = list(args)
    bad[5] = np.array([0, 3, 4], np.int64)[:2]              # offsets not ending at P
    with pytest.raises(ValueError):
        core.share_time(*bad)
    bad = list(args)
    bad[8] = np.ones(P + 1)                                 # T of another size
    with pytest.raises(ValueError):
        core.share_time(*bad)


def test_newton_code_has_no_libm_power_or_sinh(monkeypatch):
    """The ** 3 the check above cannot catch (the operator calls the ufunc itself): none in
    the chains' Newton code (prims.cube instead), nor a np.sinh, np.power; and the line
    law's evaluation, which the chains share, takes its series branch's sinh and cube from
    prims when the chains call it (line._shc and line._cube made to fail are not called)."""
    import inspect
    from gcode_opt.laws import line
    for f in (lc._J3, lc._coeffs, lc._small_int_coeffs, lc._share_time_numpy, lc._eval,
              lc._time_of_distance, lc._tod_core, lc._share_time_core):
        src = inspect.getsource(f)
        for bad in ("** 3", "**3", "np.sinh", "np.power", "_shc("):
            assert bad not in src.replace("prims.shc(", "prims.SHC("), (f.__name__, bad)
    law = line.line_law(np.array([2.0, 3.0, 5.0]), np.array([0.05, 0.06, 0.1]), np.array([0.25, 0.36, 1.0]),
                        np.array([10.0, 20.0, 0.0]), np.array([30.0, 5.0, 0.0]))
    assert law._c["small"].all()
    want_t = lc._time_of_distance(law, law.L * 0.4)
    want = lc._eval(law, want_t, "sva")

    def fail(*a):
        raise AssertionError("numpy's primitive called")
    monkeypatch.setattr(line, "_shc", fail)
    monkeypatch.setattr(line, "_cube", fail)
    got_t = lc._time_of_distance(law, law.L * 0.4)
    got = lc._eval(law, got_t, "sva")
    assert np.array_equal(_bits(got_t), _bits(want_t))
    for a, b in zip(got, want):
        assert np.array_equal(_bits(a), _bits(b))
    with pytest.raises(AssertionError, match="numpy's primitive"):
        law.eval(want_t, "sva")                       # the line law's own path does call them
