"""Session 38, the ringing's CPU (helper "ringc"): ring_int_r2_run's pieces of length +0.

About half a file's pieces last 0 (a block without cruise: two events at one time).  Such a
piece, once its exp(q 0) is 1 + 0i and its decay2 is 1, has v = +0 exactly for |c| below
RING_ZERO_BIG (1e150), and is a max_abs_r candidate as before (its |c| made only where a
bound does not rule it out).  Held here to the code it replaces, bit for bit:

- ring_int_r2's per-piece values (its work array) against the same pieces each in a call
  of its own (the first zero-length piece of a call takes the general steps): zeros of
  both signs in c and dur, |c| on both sides of 1e150, infinities, a decay2 that is not 1
  at a zero-length piece, with and without the memo's out part.
(ring_solve's own zero-length pieces since session 46: tests/test_speed46_ring46_recursion.py.)
"""
import numpy as np
import pytest

from gcode_opt.firmware import resonance as res
from gcode_opt.firmware import simulate as fw
from gcode_opt.firmware.resonance import Oscillator

CORE = fw._core
need_core = pytest.mark.skipif(CORE is None or not hasattr(CORE, "ring_solve"),
                               reason="the compiled firmware core is not built here")


def _amps(rng, n, zero_share):
    """n complex amplitudes of varied sizes and both zeros; n durations, zero_share of them +0."""
    c = (rng.normal(size=n) + 1j * rng.normal(size=n)) * np.exp(rng.normal(size=n) * 8.0)
    k = rng.uniform(size=n)
    c[k < 0.03] = complex(0.0, 0.0)
    c[(k >= 0.03) & (k < 0.06)] = complex(-0.0, -0.0)
    c.real[(k >= 0.06) & (k < 0.09)] = -0.0
    c.imag[(k >= 0.09) & (k < 0.12)] = 0.0
    big = (k >= 0.12) & (k < 0.2)        # about RING_ZERO_BIG: both sides
    c[big] = (rng.choice([1.0, -1.0], big.sum()) * 1e150 * rng.choice([0.999999, 1.0, 1.000001, 1e5], big.sum())
              + 1j * rng.normal(size=big.sum()))
    swap = big & (rng.uniform(size=n) < 0.5)
    c[swap] = 1j * c[swap]
    dur = rng.exponential(0.01, n)
    dur[rng.uniform(size=n) < zero_share] = 0.0
    dur[rng.uniform(size=n) < 0.02] = -0.0
    return c, dur


@need_core
@pytest.mark.parametrize("seed", range(4))
def test_int_r2_values_are_the_general_steps(seed):
    rng = np.random.default_rng(3800 + seed)
    osc = Oscillator(float(rng.uniform(20.0, 120.0)), float(rng.uniform(0.02, 0.5)))
    args = res._int_r2_args(osc.s, osc.lam)
    for trial in range(12):
        n = int(rng.integers(2, 800))
        c, dur = _amps(rng, n, (0.5, 0.9, 0.1)[trial % 3])
        decay2 = np.exp(-2.0 * osc.s * dur)
        if trial % 4 == 3:              # a decay2 not 1 at some zero-length pieces: no shortcut there
            odd = (dur == 0.0) & (rng.uniform(size=n) < 0.3)
            decay2[odd] = rng.choice([0.5, 1.0 - 2.0 ** -52, 1.0 + 2.0 ** -52], odd.sum())
        if trial % 6 == 5:              # an infinite |c| at a zero-length piece (checks: None)
            c[int(np.flatnonzero(dur == 0.0)[-1])] = complex(np.inf, 1.0)
        ts = np.cumsum(rng.exponential(0.01, n)) if trial % 2 else None
        extra = (ts, None, None, None, np.empty(3 * n)) if ts is not None else ()
        work = np.empty(n)
        got = CORE.ring_int_r2(c, dur, decay2, *args, work, *extra)
        # the reference: each piece alone (its own call: the general steps for every piece)
        want = np.empty(n)
        want_ov = np.empty(3 * n)
        want_ok = True
        for i in range(n):
            one = np.empty(1)
            e1 = (ts[i:i + 1], None, None, None, want_ov[3 * i:3 * i + 3]) if ts is not None else ()
            r = CORE.ring_int_r2(c[i:i + 1], dur[i:i + 1], decay2[i:i + 1], *args, one, *e1)
            if r is None:
                want_ok = False
                break
            want[i] = one[0]
        if not want_ok:
            assert got is None
            continue
        assert got is not None
        assert work.tobytes() == want.tobytes()
        if ts is not None:
            assert extra[4].tobytes() == want_ov.tobytes()
        assert (dur == 0.0).sum() > 1 and (want == 0.0).any()       # (zero-length pieces were there)
