"""Session 40, the ringing's solve (helper "ringsolve"): ring_solve's steps with fewer
instructions, the same bits.

- The ring kernels' exp is glibc's __exp_finite where there is one: the function libm's
  exp wraps (errno aside), so the same numbers -- held here to libm's exp itself (ctypes),
  on arguments over the whole range (overflow, underflow, subnormal results, zeros).
- amplitudes' running sum starts from -0.0 (-0.0 + p is p) instead of copying the first
  term: held to numpy's amplitudes on events whose restarts start with amplitudes of
  zeros of both signs (long pauses: the carried amplitude underflows to a signed zero).
(A zero-length piece's decay tested once a call in ring_solve: gone with its restarts in
session 46, tests/test_speed46_ring46_recursion.py.)
"""
import ctypes
import ctypes.util
import platform

import numpy as np
import pytest

from gcode_opt.firmware import resonance as res
from gcode_opt.firmware import simulate as fw
from gcode_opt.firmware.resonance import Oscillator

CORE = fw._core
need_core = pytest.mark.skipif(CORE is None or not hasattr(CORE, "ring_solve"),
                               reason="the compiled firmware core is not built here")


def _libm_exp():
    name = ctypes.util.find_library("m")
    if name is None:
        return None
    try:
        f = ctypes.CDLL(name).exp
    except (OSError, AttributeError):
        return None
    f.restype, f.argtypes = ctypes.c_double, [ctypes.c_double]
    return f


def _bits(a):
    return np.ascontiguousarray(a).view(np.uint64)


@need_core
@pytest.mark.parametrize("seed", range(3))
def test_kernel_exp_is_libm_exp(seed):
    libm_exp = _libm_exp()
    if libm_exp is None:
        pytest.skip("no libm to load here")
    rng = np.random.default_rng(4000 + seed)
    x = np.concatenate([
        rng.uniform(-800.0, 800.0, 4000),
        rng.uniform(-1.0, 1.0, 2000) * 10.0 ** rng.uniform(-320.0, 0.0, 2000),
        709.782712893384 + rng.uniform(-1e-9, 1e-9, 200),      # about the overflow
        -745.1332191019412 + rng.uniform(-1e-9, 1e-9, 200),    # about the underflow
        rng.uniform(-745.2, -708.0, 1000),                     # subnormal results
        [0.0, -0.0, 5e-324, -5e-324, 1e-300, 709.0, 710.0, -744.0, -746.0, 1e300, -1e300],
    ])
    out = np.empty(len(x), complex)
    # ring_exp's argument is a t - b 0 = t for a = 1, b = 0: its real part is exp(t) cos(0)
    assert CORE.ring_exp(x, 1.0, 0.0, out)
    want = np.array([libm_exp(float(v)) for v in x])
    assert (_bits(out.real) == _bits(want)).all()


def _events(rng, n, span):
    """n event times over ~8 restarts of span, with long pauses (the carried amplitude
    underflows to zeros) and runs of equal times; amplitudes with zeros of both signs."""
    gaps = rng.exponential(span / 200.0, n) * (rng.uniform(size=n) < 0.6)
    gaps[rng.uniform(size=n) < 0.01] = span * rng.uniform(3.0, 30.0)
    t = np.cumsum(gaps)
    dc = rng.normal(size=n) + 1j * rng.normal(size=n)
    k = rng.uniform(size=n)
    dc[k < 0.15] = complex(-0.0, -0.0)
    dc[(k >= 0.15) & (k < 0.25)] = complex(0.0, -0.0)
    dc[(k >= 0.25) & (k < 0.35)] = complex(-0.0, 0.0)
    return t, dc


@need_core
@pytest.mark.parametrize("seed", range(6))
def test_amps_running_sum_from_minus_zero(seed):
    rng = np.random.default_rng(4010 + seed)
    osc = Oscillator(float(rng.uniform(20.0, 120.0)), float(rng.uniform(0.02, 0.5)))
    span = res.CHUNK_DECAY / osc.s
    if res._kernel_for(("pair", osc.s, osc.wd), span) is None:
        pytest.skip("numpy's complex exp is not libm's here")
    fused = res._amps_mode(CORE, osc.s, osc.wd, span)
    # (where numpy's complex product is one of the core's two modes, as on x86-64, a core
    # whose amplitudes fail their probe is broken, not skipped)
    if fused is None and platform.machine() not in ("x86_64", "AMD64"):
        pytest.skip("the core's amplitudes are not numpy's here")
    assert fused is not None
    for trial in range(6):
        t, dc = _events(rng, int(rng.integers(2, 3000)), span)
        want = res._amps_numpy(osc, t, dc)
        for carry in (0j, complex(-0.0, -0.0), complex(1e-300, -1e-300), complex(rng.normal(), rng.normal())):
            got = np.empty(len(t), complex)
            # (a carry from just before the first event, or from far back: it underflows)
            t_carry = float(t[0]) - (span * 40.0 if trial % 2 else 1e-3)
            end = CORE.ring_amps(t, dc, osc.s, osc.wd, span, 1 << 30, 0, carry, t_carry, got, fused)
            assert end == len(t)
            assert got.tobytes() == _ref_amps(osc, t, dc, carry, t_carry).tobytes()
        got = np.empty(len(t), complex)
        assert CORE.ring_amps(t, dc, osc.s, osc.wd, span, 1 << 30, 0, 0j, float(t[0]), got, fused) == len(t)
        assert got.tobytes() == want.tobytes()


def _ref_amps(osc, t_ev, dc, carry, t_carry):
    """Oscillator.amplitudes' numpy steps from a carried amplitude (its restart loop)."""
    lam, span = osc.lam, res.CHUNK_DECAY / osc.s
    n = len(t_ev)
    c = np.empty(n, complex)
    start = 0
    while start < n:
        t0 = float(t_ev[start])
        stop = max(int(np.searchsorted(t_ev, t0 + span, side="right")), start + 1)
        tt = t_ev[start:stop] - t0
        g = np.cumsum(dc[start:stop] * np.exp(-lam * tt))
        c0 = carry * np.exp(lam * (t0 - t_carry))
        c[start:stop] = (c0 + g) * np.exp(lam * tt)
        carry, t_carry = c[stop - 1], float(t_ev[stop - 1])
        start = stop
    return c


def _set_of(dur):
    """The set (of 8 k, two slots each) _core.c's table of the pieces' exponentials gives a
    length: its bits times the golden-ratio constant, the top 13 bits."""
    bits = np.ascontiguousarray(dur).view(np.uint64)
    with np.errstate(over="ignore"):
        return (bits * np.uint64(0x9E3779B97F4A7C15)) >> np.uint64(51)


@need_core
@pytest.mark.parametrize("seed", range(3))
def test_two_way_table_lengths_of_one_set(seed, monkeypatch):
    """Lengths that share a set, taken in orders that hit either slot, move a slot to the
    front and evict the older: each piece's integral is numpy's."""
    osc = Oscillator(50.0 + seed, 0.1)
    q = 2.0 * osc.lam
    if res._kernel_for(("one", q.real, q.imag), 1e4) is None:
        pytest.skip("numpy's complex exp is not libm's here (its own SIMD loops)")
    rng = np.random.default_rng(4030 + seed)
    pool = rng.exponential(0.02, 200000)
    sets = _set_of(pool)
    order = np.argsort(sets, kind="stable")
    groups = np.split(pool[order], np.flatnonzero(np.diff(sets[order])) + 1)
    groups = [g[:4] for g in groups if len(g) >= 4][:40]
    assert len(groups) == 40
    # per set: A B A (hit the back slot) B C A (miss evicting the back) C D ... as a random walk
    dur = np.concatenate([g[rng.integers(0, 4, 60)] for g in groups for _ in range(2)])
    dur = dur[rng.permutation(len(dur))] if seed == 2 else dur
    n = len(dur)
    c = (rng.normal(size=n) + 1j * rng.normal(size=n)) * 1e-3
    with monkeypatch.context() as mp:
        mp.setattr(res, "USE_KERNEL", False)       # numpy's own exponentials, no table
        want = osc.integral_r2_fin(c, dur)
    CORE.ring_release()                            # cold, then warm (the same pieces again)
    for _ in range(2):
        work = np.empty(n)
        got = CORE.ring_int_r2(c, dur, np.exp(-2.0 * osc.s * dur), *res._int_r2_args(osc.s, osc.lam), work)
        assert got is not None
        assert work.tobytes() == want.tobytes()


@need_core
@pytest.mark.parametrize("seed", range(3))
def test_zero_pieces_by_the_sum_of_parts(seed, monkeypatch):
    """A zero-length piece takes the +0 shortcut where |Re c| + |Im c| is below 1e150; the
    others (each part below it or not, c^2 finite or overflowing) the general steps: each
    piece's integral as numpy's (NaN where numpy's is)."""
    osc = Oscillator(45.0 + 7.0 * seed, 0.1)
    if res._int_r2_core(osc.s, osc.wd) is None:
        pytest.skip("the core's integral is not numpy's here")
    rng = np.random.default_rng(4040 + seed)
    n = 4000
    mag = 10.0 ** rng.choice([-3.0, 149.7, 149.9, 150.0, 152.0, 154.5, 160.0], n)
    c = np.empty(n, complex)
    c.real = rng.choice([1.0, -1.0], n) * mag * rng.uniform(0.3, 1.0, n)
    c.imag = rng.choice([1.0, -1.0], n) * mag * rng.uniform(0.0, 1.0, n) * (rng.uniform(size=n) < 0.8)
    swap = rng.uniform(size=n) < 0.3
    c[swap] = 1j * c[swap]
    dur = np.where(rng.uniform(size=n) < 0.8, 0.0, rng.exponential(0.01, n))
    dur[0], c[0] = 0.0, 1e-3         # (the call's first zero-length piece: the general steps)
    decay2 = np.exp(-2.0 * osc.s * dur)
    with monkeypatch.context() as mp, np.errstate(all="ignore"):
        mp.setattr(res, "USE_KERNEL", False)
        want = osc.integral_r2_fin(c, dur)
    work = np.empty(n)
    with np.errstate(all="ignore"):
        CORE.ring_int_r2(c, dur, decay2, *res._int_r2_args(osc.s, osc.lam), work)
    nan = np.isnan(want)
    assert (np.isnan(work) == nan).all() and nan.any()
    assert work[~nan].tobytes() == want[~nan].tobytes()
