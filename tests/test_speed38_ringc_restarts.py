"""Session 38, the ringing's CPU (helper "ringc"): a guard on the amplitudes' restarts
(ring_amps_run: ring_amps', and ring_solve's until session 46, whose recursion has no
restarts: tests/test_speed46_ring46_recursion.py) for whoever changes them next.

Tried this session and dropped: the exponentials' products (ex1 (cos, -sin), ex2 (cos,
sin)) made once a time instead of once an event, a copy of ring_solve's restart loop for
each product mode and for keeping the exponentials or not, integral_r2's osc2 - 1 once a
length.  Each gave more instructions, not fewer (gcc's code for the loops, callgrind);
and with the products made once a time gcc's SLP vectorizer made the unfused mode's
second product a vfmaddsub -- a fused multiply-add despite -ffp-contract=off -- which
only the restarts written out in Python below caught (the probes turn such a core off, so
the tests held to numpy skip).

Held here bit for bit: ring_amps' amplitudes in both product modes against the restarts
in Python (libm's exp, cos, sin through math; fma rounded once by exact rationals)."""
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
    """ring_amps (no memo) against the restarts in Python: the same amplitudes in both
    product modes, bit for bit."""
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
        assert len(set(t0s.tolist())) > 1                                # restarts were made
