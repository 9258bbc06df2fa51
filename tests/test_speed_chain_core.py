"""The chains' compiled Newton steps (laws/_chaincore.c, module _gcode_opt_chaincore) give
the numpy code's bits: _share_time with the core and _share_time_numpy on the batches that
real chains of the bundled full-speed gyroid (classic jerk and square-corner velocity
profiles, cold and warm) hand it, whole solves compared law by law, and the inputs where
the core declines (the numpy code then runs: its errors, its other γ branch).

Since session 20 (chainprim) both loops are whole C calls (share_time, tod_solve) and the
numpy code they match uses the deterministic sinh and cube of laws/prims.py
(chain._time_of_distance and chain._eval: the line law's time_of_distance and eval with
those); the line law's own (np.sinh, ** 3) is now only a tolerance check (_close_to_line)."""
import os
import subprocess
import sys

import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.laws import chain as lc
from gcode_opt.laws.line import time_of_distance

pytestmark = pytest.mark.skipif(lc.CORE_MOD is None, reason=f"the chain core is not used here ({lc.CORE_WHY})")

from test_speed_chains import _chain_problems, _same  # noqa: E402


def _bits(x):
    x = np.asarray(x)
    return x.view(np.uint8) if x.dtype == bool else x.view(np.int64)


def _record(monkeypatch):
    calls = []
    orig = lc._share_time

    def rec(*a, **k):
        calls.append([np.array(x) for x in a])
        return orig(*a, **k)
    monkeypatch.setattr(lc, "_share_time", rec)
    return calls


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_share_time_core_equals_numpy_on_real_batches(prof, monkeypatch):
    sts, T0, profile = _chain_problems(prof)
    calls = _record(monkeypatch)
    for r in (1.0, 1.25):
        T = T0 * r
        lc.solve_chains(chains._problems(sts, T, (T / chains.GAMMA_MIN) ** 2, profile))
    assert len(calls) >= 4 and sum(c[0].size for c in calls) > 1000
    for a in calls:
        got = lc._share_time_core(lc.CORE_MOD, *a)
        want = lc._share_time_numpy(*a)
        assert got is not None
        for x, y in zip(got, want, strict=True):
            assert np.array_equal(_bits(x), _bits(y))


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_solves_with_and_without_the_core_are_the_same(prof, monkeypatch):
    sts, T0, profile = _chain_problems(prof)
    T = T0 * 1.02
    probs = chains._problems(sts, T, (T / chains.GAMMA_MIN) ** 2, profile)
    got = lc.solve_chains(probs)
    monkeypatch.setattr(lc, "CORE_MOD", None)
    want = lc.solve_chains(probs)
    for a, b in zip(got, want, strict=True):
        _same(a, b)


def _toy(n_c=5, k=4, seed=3):
    rng = np.random.default_rng(seed)
    owner = np.repeat(np.arange(n_c), k)
    L = rng.uniform(0.3, 1.0, owner.size)
    va, vb = rng.uniform(10, 50, owner.size), rng.uniform(10, 50, owner.size)
    T_total = np.bincount(owner, L, n_c) / 40.0
    T_init = T_total[owner] / k
    beta = (T_total[owner] / 0.1) ** 2
    return L, beta, va, vb, owner, T_total, T_init


def test_toy_batch_same_bits():
    a = _toy()
    for x, y in zip(lc._share_time_core(lc.CORE_MOD, *a), lc._share_time_numpy(*a), strict=True):
        assert np.array_equal(_bits(x), _bits(y))


def test_core_declines_the_large_gamma_branch_and_bad_durations():
    L, beta, va, vb, owner, T_total, T_init = _toy()
    small_beta = beta * 1e-6                        # γ = T/√β ~ 100: the exponential branch
    assert lc._share_time_core(lc.CORE_MOD, L, small_beta, va, vb, owner, T_total, T_init) is None
    for x, y in zip(lc._share_time(L, small_beta, va, vb, owner, T_total, T_init),
                    lc._share_time_numpy(L, small_beta, va, vb, owner, T_total, T_init), strict=True):
        assert np.array_equal(_bits(x), _bits(y), )
    bad = T_init.copy()
    bad[2] = -1.0
    assert lc._share_time_core(lc.CORE_MOD, L, beta, va, vb, owner, T_total, bad) is None
    with pytest.raises(ValueError, match="T must be finite and > 0"):
        lc._share_time(L, beta, va, vb, owner, T_total, bad)
    with pytest.raises(ValueError, match="beta must be > 0"):
        lc._share_time(L, beta * 0.0, va, vb, owner, T_total, T_init)


def test_pure_python_switch_and_stale_build_check(tmp_path):
    code = "from gcode_opt.laws import chain as c; print(c.CORE, '|', c.CORE_WHY)"
    env = dict(os.environ, GCODE_OPT_PURE_PYTHON="1")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.startswith("python | GCODE_OPT_PURE_PYTHON")
    from gcode_opt import native
    other = tmp_path / "_chaincore.c"
    other.write_text("/* another source */\n")
    mod, why = native.load("_gcode_opt_chaincore", str(other), "chain core")
    assert mod is None and "another _chaincore.c" in why


def _tod_batches(monkeypatch, prof):
    sts, T0, profile = _chain_problems(prof)
    calls = []
    orig = lc._times_and_speeds

    def rec(law, x, core=None):
        calls.append((law, np.array(x)))
        return orig(law, x, core)
    monkeypatch.setattr(lc, "_times_and_speeds", rec)
    for r in (1.05, 1.25):      # (1.05 alone until session 29: its cold start now takes fewer steps)
        T = T0 * r
        lc.solve_chains(chains._problems(sts, T, (T / chains.GAMMA_MIN) ** 2, profile))
    return calls


def _close_to_line(law, x, got):
    """The line law's time_of_distance and eval (np.sinh, ** 3) vs the chains' (prims): the
    same roots to the Newton's resolution (4 eps of the length or the duration) plus the
    last bits of s(t) and ṡ(t), so within 1e-12 of the duration and of the speed scale."""
    t = time_of_distance(law, x)
    v = law.eval(t, "v")[1]
    assert np.all(np.abs(got[0] - t) <= 1e-12 * law.T)
    vs = np.maximum(np.abs(law.v0), np.abs(law.v1)) + np.abs(law.L) / law.T
    assert np.all(np.abs(got[1] - v) <= 1e-12 * vs)


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_time_of_distance_core_equals_numpy_on_real_batches(prof, monkeypatch):
    calls = _tod_batches(monkeypatch, prof)
    assert len(calls) >= 3 and sum(x.size for _, x in calls) > 500
    for law, x in calls:
        got = lc._tod_core(lc.CORE_MOD, law, x)
        want_t = lc._time_of_distance(law, x)
        want_v = lc._eval(law, want_t, "v")[1]
        assert np.array_equal(_bits(got[0]), _bits(want_t)) and np.array_equal(_bits(got[1]), _bits(want_v))
        _close_to_line(law, x, got)


def test_time_of_distance_core_out_of_steps_and_edges(monkeypatch):
    from gcode_opt.laws.line import LineLaw
    time_of_distance = lc._time_of_distance
    calls = _tod_batches(monkeypatch, "prusa-mk3s")
    law, x = max(calls, key=lambda c: c[1].size)
    for it in (1, 2, 3):          # stopped early: the laws still going are evaluated where they stopped
        got = lc._tod_core(lc.CORE_MOD, law, x, max_iter=it)
        want_t = time_of_distance(law, x, max_iter=it)
        assert np.array_equal(_bits(got[0]), _bits(want_t))
        assert np.array_equal(_bits(got[1]), _bits(lc._eval(law, want_t, "v")[1]))
    # targets at and beyond the ends (clamped), a reversed law (L < 0), a zero-length one
    L = np.array([1.0, 1.0, 1.0, -0.8, 0.0, 0.6])
    T = np.array([0.02, 0.02, 0.02, 0.03, 0.01, 0.015])
    law = LineLaw(L, T, (T / 0.1) ** 2, np.array([40, 40, 40, 10, 5, 0.0]), np.array([30, 30, 30, 20, 5, 30.0]))
    x = np.array([0.0, 1.0, 1.7, -0.3, 0.0, 0.2])
    got = lc._tod_core(lc.CORE_MOD, law, x)
    want_t = time_of_distance(law, x)
    assert np.array_equal(_bits(got[0]), _bits(want_t))
    assert np.array_equal(_bits(got[1]), _bits(lc._eval(law, want_t, "v")[1]))
    _close_to_line(law, x, got)
