"""Session 38, the ringing's CPU (helper "ringc"): a guard on the amplitudes' restarts
(ring_amps_run, shared by ring_amps and ring_solve) for whoever changes them next.

Tried this session and dropped: the exponentials' products (ex1 (cos, -sin), ex2 (cos,
sin)) made once a time instead of once an event, a copy of ring_solve's restart loop for
each product mode and for keeping the exponentials or not, integral_r2's osc2 - 1 once a
length.  Each gave more instructions, not fewer (gcc's code for the loops, callgrind);
and with the products made once a time gcc's SLP vectorizer made the unfused mode's
second product a vfmaddsub -- a fused multiply-add despite -ffp-contract=off -- which
only the restarts written out in Python below caught (the probes turn such a core off, so
the tests held to numpy skip).

Held here bit for bit: ring_solve in both product modes against ring_amps' amplitudes (the
mode a runtime argument there) and ring_int_r2's sum of them, with the carried amplitude
or without, with another stream's exponentials and without; the amplitudes in numpy's own
mode against numpy's steps; both modes, and the exponentials kept for the next stream,
against the restarts in Python (libm's exp, cos, sin through math; fma rounded once by
exact rationals)."""
import math

import numpy as np
import pytest

from gcode_opt.firmware import resonance as res
from gcode_opt.firmware import simulate as fw
from gcode_opt.firmware.resonance import Oscillator

CORE = fw._core
need_core = pytest.mark.skipif(CORE is None or not hasattr(CORE, "ring_solve"),
                               reason="the compiled firmware core is not built here")


def _events(rng, n, same):
    """n events, a share `same` of them at the time of the one before."""
    gaps = rng.exponential(0.004, n) * (rng.uniform(size=n) >= same)
    gaps[rng.uniform(size=n) < 0.005] *= 400.0
    t = np.cumsum(gaps) + rng.uniform(-3, 3)
    dr = rng.normal(size=n) * 1e-4 * (rng.uniform(size=n) < 0.8)
    drp = rng.normal(size=n) * 10.0 * (rng.uniform(size=n) < 0.6)
    return t, dr, drp


def _amps(osc, t, dr, drp, first, fused, memo=None):
    """ring_amps' amplitudes of ring_solve's events (its jumps, after `first`)."""
    s, wd = osc.s, osc.wd
    dc = np.empty(len(dr), complex)
    assert CORE.ring_jumps(dr, drp, s, wd, dc)
    if first is not None:
        dc = np.concatenate([[first], dc])
    c = np.empty(len(t), complex)
    extra = tuple(memo) + (None, None) if memo is not None else ()
    got = CORE.ring_amps(t, dc, s, wd, res.CHUNK_DECAY / s, res.ELIDE_BYTES // 16, 0, 0j, float(t[0]), c,
                         fused, *extra)
    assert got == len(t)
    return c


@need_core
@pytest.mark.parametrize("seed", range(4))
def test_solve_is_ring_amps_in_both_modes(seed):
    rng = np.random.default_rng(3850 + seed)
    osc = Oscillator(float(rng.uniform(20.0, 120.0)), float(rng.uniform(0.03, 0.4)))
    s, wd = osc.s, osc.wd
    span = res.CHUNK_DECAY / s
    args = res._int_r2_args(s, osc.lam)
    for trial in range(10):
        n = int(rng.integers(2, 3000))
        t, dr, drp = _events(rng, n, (0.75, 0.3, 0.0, 0.95)[trial % 4])
        first = complex(rng.normal(), rng.normal()) * 1e-3 if trial % 3 else None
        if first is not None:
            dr, drp = dr[1:], drp[1:]
        dur = np.diff(t)
        decay2 = np.exp(-2.0 * s * dur)
        # a memo of another stream's exponentials (half the events shared, restarts at the same
        # times where they begin at a shared event)
        amps_out = (np.empty(n), np.empty(4 * n))
        for fused in (True, False):
            memo = None
            if trial % 2:
                keep = rng.uniform(size=n) < 0.5
                keep[0] = True
                t2 = t[keep]
                d2r, d2p = rng.normal(size=len(t2) - 1) * 1e-4, rng.normal(size=len(t2) - 1)
                o = (np.empty(len(t2)), np.empty(4 * len(t2)))
                assert CORE.ring_solve(t2, d2r, d2p, 1e-3j, s, wd, span, res.ELIDE_BYTES // 16, fused, *args,
                                       None, o, None, None) is not None
                memo = (t2, o[0], o[1])
            c = _amps(osc, t, dr, drp, first, fused, memo)
            ret = CORE.ring_solve(t, dr, drp, first, s, wd, span, res.ELIDE_BYTES // 16, fused, *args,
                                  memo, amps_out, None, None, decay2, True, 0.0)
            assert ret is not None
            i_r2, lo, c_last, kc, kd = ret
            assert np.complex128(c_last).tobytes() == c[-1:].tobytes()
            want = CORE.ring_int_r2(c[:-1], dur, decay2, *args, np.empty(n - 1))
            assert np.float64(i_r2).tobytes() == np.float64(want).tobytes()
            cp = c[:-1]
            lo_w = np.abs(cp.real).max()
            keepk = ~(np.abs(cp) * (1.0 + 1e-9) < lo_w)
            assert kc == cp[keepk].tobytes() and kd == dur[keepk].tobytes()
            # the exponentials kept for the next stream: each event's (ex1, ex2, cos, sin) are
            # those of its time's first event in its restart
            v = amps_out[1].reshape(-1, 4)
            same = np.flatnonzero(np.diff(t) == 0.0) + 1
            same = same[amps_out[0][same] == amps_out[0][same - 1]]
            assert v[same].tobytes() == v[same - 1].tobytes()


@need_core
@pytest.mark.parametrize("seed", range(3))
def test_amplitudes_are_numpys_with_many_events_at_one_time(seed):
    """In the product mode the probe found numpy's (Oscillator.solve's), ring_solve's last
    amplitude and the pieces it hands back are numpy's steps'."""
    osc = Oscillator((50.0, 37.0, 80.0)[seed], (0.1, 0.03, 0.4)[seed])
    got = res._solve_core(osc.s, osc.wd)
    if got is None:
        pytest.skip("the core's solve is not checked for this oscillator here")
    core, span, fused, _d, _p = got
    rng = np.random.default_rng(3860 + seed)
    s, wd = osc.s, osc.wd
    for trial in range(8):
        n = int(rng.integers(2, 2500))
        t, dr, drp = _events(rng, n, 0.75)
        keep_k, res.USE_KERNEL = res.USE_KERNEL, False
        try:
            c = osc.amplitudes(t, osc.jump_amplitude(dr, drp))
            want_sum = float(osc.integral_r2_fin(c[:-1], np.diff(t)).sum())
        finally:
            res.USE_KERNEL = keep_k
        dur = np.diff(t)
        ret = core.ring_solve(t, dr, drp, None, s, wd, span, res.ELIDE_BYTES // 16, fused,
                              *res._int_r2_args(s, osc.lam), None, None, None, None, np.exp(-2.0 * s * dur), True)
        assert ret is not None
        assert np.complex128(ret[2]).tobytes() == c[-1:].tobytes()
        assert np.float64(ret[0]).tobytes() == np.float64(want_sum).tobytes()
        cp = c[:-1]
        keepk = ~(np.abs(cp) * (1.0 + 1e-9) < np.abs(cp.real).max())
        assert ret[3] == cp[keepk].tobytes()


def _fma(a, b, c):
    """fma(a, b, c) of doubles, rounded once (exact rationals; zeros' signs as IEEE's)."""
    from fractions import Fraction
    exact = Fraction(a) * Fraction(b) + Fraction(c)
    if exact == 0:
        return a * b + c if (a == 0.0 or b == 0.0) else 0.0
    return float(exact)


def _cmul(fused, ar, ai, br, bi):
    if fused:
        return _fma(ar, br, -(ai * bi)), _fma(ar, bi, ai * br)
    return ar * br - ai * bi, ar * bi + ai * br


def _ref_amps(t, dc, s, wd, span, fused):
    """Oscillator.amplitudes' restarts as the core makes them, in Python's doubles and libm's
    exp, cos, sin (math's): every exponential and product made afresh for each event."""
    import bisect
    t = [float(x) for x in t]
    n = len(t)
    c = [None] * n
    t0s = [None] * n            # each event's restart's start
    start, cr, ci, t_carry = 0, 0.0, 0.0, t[0]
    while start < n:
        t0 = t[start]
        stop = max(bisect.bisect_right(t, t0 + span), start + 1)
        dt = t0 - t_carry
        x, y = -s * dt - wd * 0.0, -s * 0.0 + wd * dt
        ex = math.exp(x)
        er, ei = ex * math.cos(y), ex * math.sin(y)
        c0r, c0i = cr * er - ci * ei, cr * ei + ci * er
        gr = gi = 0.0
        for i in range(start, stop):
            t0s[i] = t0
            tt = t[i] - t0
            y2 = wd * tt
            y1 = 0.0 - y2
            ex1, ex2 = math.exp(s * tt + 0.0), math.exp(-s * tt)
            c2, s2 = math.cos(y2), math.sin(y2)
            s1 = -s2 if y2 != 0.0 else y1
            pr, pi = _cmul(fused, dc[i].real, dc[i].imag, ex1 * c2, ex1 * s1)
            if i == start:
                gr, gi = pr, pi
            else:
                gr, gi = gr + pr, gi + pi
            c[i] = _cmul(fused, c0r + gr, c0i + gi, ex2 * c2, ex2 * s2)
        cr, ci = c[stop - 1]
        t_carry = t[stop - 1]
        start = stop
    return np.array([complex(a, b) for a, b in c]), np.array(t0s)


@need_core
@pytest.mark.parametrize("fused", [True, False])
@pytest.mark.parametrize("seed", range(2))
def test_amplitudes_against_python(seed, fused):
    """ring_amps and ring_solve (the memo neither read nor written) against the restarts
    in Python: the same amplitudes in both product modes, bit for bit."""
    rng = np.random.default_rng(3870 + seed)
    osc = Oscillator(float(rng.uniform(20.0, 120.0)), float(rng.uniform(0.03, 0.4)))
    s, wd = osc.s, osc.wd
    span = res.CHUNK_DECAY / s
    for trial in range(4):
        n = int(rng.integers(50, 600))
        t, dr, drp = _events(rng, n, (0.75, 0.3)[trial % 2])
        t[rng.integers(n // 2, n):] += rng.uniform(0.5, 3.0) * span     # restarts after a pause
        dc = np.empty(n, complex)
        assert CORE.ring_jumps(dr, drp, s, wd, dc)
        want, t0s = _ref_amps(t, dc, s, wd, span, fused)
        assert _amps(osc, t, dr, drp, None, fused).tobytes() == want.tobytes()
        # the exponentials kept (amps_out: each event's restart start and ex1, ex2, cos, sin) or not
        for out in (None, (np.empty(n), np.empty(4 * n))):
            ret = CORE.ring_solve(t, dr, drp, None, s, wd, span, res.ELIDE_BYTES // 16, fused,
                                  *res._int_r2_args(s, osc.lam), None, out, None, None, None, True, 0.0)
            assert np.complex128(ret[2]).tobytes() == want[-1:].tobytes()
            cp = want[:-1]
            keepk = ~(np.abs(cp) * (1.0 + 1e-9) < np.abs(cp.real).max())
            assert ret[3] == cp[keepk].tobytes()
            if out is not None:
                assert out[0].tobytes() == t0s.tobytes()
                tt = t - t0s
                want_v = np.array([[math.exp(s * x + 0.0), math.exp(-s * x), math.cos(wd * x), math.sin(wd * x)]
                                   for x in tt])
                assert out[1].tobytes() == want_v.tobytes()
