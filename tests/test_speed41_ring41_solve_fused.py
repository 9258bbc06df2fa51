"""Session 41, the ringing's solve (helper "ring41"): ring_solve's loops with fewer
instructions, the same bits.

- The events' jumps (jump_amplitude) are made in the amplitudes' loop, event by event,
  instead of in a pass of their own; e_dn and e_up (the exponentials' products) once a
  time, not once an event; a loop for each numpy product mode and memo out.
- The pieces' loop is a function of its own, with a copy for each memo out and decay2 case;
  a zero-length piece's shortcut no longer copies the zero length's exponentials.

Held here to other code, bit for bit (numpy's jump_amplitude and integral_r2_fin sum, the
core's ring_amps restart loop and ring_peak, libm's exponentials of the pieces): the sum,
the peak, the last amplitude and the memo outs (the amplitudes' and the pieces'
exponentials kept for the next stream), with and without a carried amplitude, memos to
read, numpy's decay2, for both product modes and both branches of _real_quotient, on events
with runs at one time (zero-length pieces).
"""
import math

import numpy as np
import pytest

from gcode_opt.firmware import resonance as res
from gcode_opt.firmware import simulate as fw
from gcode_opt.firmware.resonance import Oscillator

CORE = fw._core
need_core = pytest.mark.skipif(CORE is None or not hasattr(CORE, "ring_solve"),
                               reason="the compiled firmware core is not built here")


def _events(rng, n, span):
    """n event times (runs at one time, long pauses, over a few restarts) and their jumps."""
    gaps = rng.exponential(span / 300.0, n) * (rng.uniform(size=n) < 0.55)
    gaps[rng.uniform(size=n) < 0.005] = span * rng.uniform(1.5, 40.0)
    t = 3.0 + np.cumsum(gaps)
    dr = rng.normal(size=n) * 1e-4 * np.exp(rng.normal(size=n) * 2.0) * (rng.uniform(size=n) < 0.8)
    drp = rng.normal(size=n) * (rng.uniform(size=n) < 0.7)
    for a in (dr, drp):
        a[rng.uniform(size=n) < 0.05] = -0.0
    return t, dr, drp


def _core_decay(s, dur):
    out = np.empty(len(dur), complex)
    CORE.ring_exp(np.ascontiguousarray(dur), -2.0 * s, 0.0, out)
    return np.ascontiguousarray(out.real)


def _libm_pieces(qr, qi, dur):
    """The pieces' exponentials as ring_solve keeps them: (exp(qr d), cos(qi d), sin(qi d)) of
    the arguments it makes (qr d - qi 0, qr 0 + qi d), by libm (Python's math)."""
    out = np.empty(3 * len(dur))
    for i, d in enumerate(dur.tolist()):
        x, y = qr * d - qi * 0.0, qr * 0.0 + qi * d
        out[3 * i:3 * i + 3] = (math.exp(x), math.cos(y), math.sin(y))
    return out


def _reference(osc, fused, t, dr, drp, first, decay2, amps_memo, pieces_memo):
    """ring_solve's result and memo outs by other code: numpy's jump_amplitude and
    integral_r2_fin (its sum), the core's ring_amps (its own restart loop, memo in and out),
    ring_peak, libm's exponentials for the pieces' memo."""
    s, wd = osc.s, osc.wd
    span = res.CHUNK_DECAY / s
    n = len(t)
    dc = dr - 1j * (drp + s * dr) / wd
    if first is not None:
        dc = np.concatenate([[first], dc])
    c = np.empty(n, complex)
    ot0, ov = np.full(n, np.nan), np.empty(4 * n)
    got = CORE.ring_amps(t, dc, s, wd, span, 1 << 30, 0, 0j, float(t[0]), c, fused,
                         *(amps_memo or (None, None, None)), ot0, ov)
    assert got == n
    dur = np.diff(t)
    d2 = _core_decay(s, dur) if decay2 is None else decay2
    cp = c[:-1]
    q = 2.0 * osc.lam
    v = np.abs(cp) ** 2 * (1.0 - d2) / (4.0 * s) + res._real_quotient(cp * cp * (np.exp(q * dur) - 1.0), 4.0 * osc.lam)
    pk, pa = np.empty(n - 1), np.empty(n - 1)
    assert CORE.ring_peak(cp, dur, -s, wd, wd, fused, pk, pa)
    lo = np.abs(cp.real).max()
    keep = ~(pa * (1.0 + 1e-9) < lo)
    peak = float(np.maximum(lo, pk[keep].max()))
    return (float(v.sum()), peak, complex(c[-1])), (ot0, ov, dur, _libm_pieces(q.real, q.imag, dur))


def _bits(x):
    return np.ascontiguousarray(x).tobytes()


@need_core
@pytest.mark.parametrize("seed", range(6))
def test_solve_is_the_separate_kernels(seed):
    rng = np.random.default_rng(4100 + seed)
    # (damping 0.8: |Re 4 lam| > |Im 4 lam|, _real_quotient's other branch)
    osc = Oscillator(float(rng.uniform(20.0, 120.0)), (0.1, 0.8)[seed % 2])
    got = res._solve_core(osc.s, osc.wd)
    if got is None:
        pytest.skip("the core's solve is not numpy's here")
    # (the core's own peak (ring_peak's steps) either way: numpy_peak False)
    core, span, fused, _np_decay, _np_peak = got
    args = res._int_r2_args(osc.s, osc.lam)
    compared = 0
    memo_a = memo_p = None
    for trial in range(10):
        n = int(rng.integers(3, 3000))
        t, dr, drp = _events(rng, n, span)
        first = complex(rng.normal(), rng.normal()) * 1e-4 if trial % 2 else None
        if first is not None:
            dr, drp = dr[1:], drp[1:]
        decay2 = np.exp(-2.0 * osc.s * np.diff(t)) if trial % 3 == 2 else None
        for mode in (fused, not fused):
            # (the memos: the last trial's outs, read for events of their own; every second
            # trial reads none)
            am = memo_a if trial % 2 == 0 else None
            pm = memo_p if trial % 2 == 0 else None
            want, (ot0, ov, dur, pv) = _reference(osc, mode, t, dr, drp, first, decay2, am, pm)
            o_t0, o_v = np.full(n, np.nan), np.empty(4 * n)
            o_dur, o_pv = np.empty(n - 1), np.empty(3 * (n - 1))
            ret = core.ring_solve(t, dr, drp, first, osc.s, osc.wd, span, 1 << 30, mode, *args,
                                  am, (o_t0, o_v), pm, (o_dur, o_pv), decay2, False, 0.0)
            assert ret is not None
            i_r2, peak, c_last = ret
            assert (_bits(np.float64(i_r2)), _bits(np.float64(peak)), _bits(np.complex128(c_last))) == \
                (_bits(np.float64(want[0])), _bits(np.float64(want[1])), _bits(np.complex128(want[2])))
            assert _bits(o_t0) == _bits(ot0) and _bits(o_v) == _bits(ov)
            assert _bits(o_dur) == _bits(dur) and _bits(o_pv) == _bits(pv)
            # (without the outs: the loops without the memo's stores)
            ret2 = core.ring_solve(t, dr, drp, first, osc.s, osc.wd, span, 1 << 30, mode, *args,
                                   am, None, pm, None, decay2, False, 0.0)
            assert _bits(np.float64(ret2[0])) == _bits(np.float64(i_r2))
            assert _bits(np.float64(ret2[1])) == _bits(np.float64(peak))
            assert _bits(np.complex128(ret2[2])) == _bits(np.complex128(c_last))
            compared += 1
        memo_a, memo_p = (t, o_t0, o_v), (t[:-1], o_dur, o_pv)
    assert compared == 20
