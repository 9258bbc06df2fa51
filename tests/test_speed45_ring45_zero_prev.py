"""Session 45, the ringing's CPU (helper "ring45"): a piece of length +0 on ring_int_r2_run's
short path leaves the length before it (d_prev) and its exponentials as they were.

Before, that path set d_prev to the zero's bits (an instruction a zero-length piece: about
half the pieces); now the piece after it, if it has the length of the piece before it (a ramp,
no cruise, a ramp as long), takes the exponentials it has at hand -- those of that very
length.  Held here to the code it replaces, bit for bit, on pieces of a few lengths with
zeros between them (so that length, zero, the same length comes often):

- ring_int_r2's per-piece values and the exponentials it keeps (out_v) against each piece in
  a call of its own (the general steps, no previous piece).
(ring_solve's pieces since session 46: tests/test_speed46_ring46_recursion.py.)
"""
import numpy as np
import pytest

from gcode_opt.firmware import resonance as res
from gcode_opt.firmware import simulate as fw
from gcode_opt.firmware.resonance import Oscillator

CORE = fw._core
need_core = pytest.mark.skipif(CORE is None or not hasattr(CORE, "ring_solve"),
                               reason="the compiled firmware core is not built here")


def _lengths(rng, n):
    """n piece lengths drawn from four (one of them +0) and, now and then, another: runs of
    length, zero, the same length, and zeros in a row."""
    few = np.array([0.0, float(rng.exponential(0.01)), float(rng.exponential(0.01)), float(rng.exponential(0.05))])
    dur = few[rng.choice(4, n, p=[0.45, 0.25, 0.2, 0.1])]
    odd = rng.uniform(size=n) < 0.05
    dur[odd] = rng.exponential(0.01, int(odd.sum()))
    return dur


def _amps(rng, n):
    c = (rng.normal(size=n) + 1j * rng.normal(size=n)) * np.exp(rng.normal(size=n) * 4.0)
    c[rng.uniform(size=n) < 0.03] = 0j
    return c


def _after_zero_same(dur):
    """How many pieces follow a zero-length one and have the length of the piece before it."""
    return int(((dur[1:-1] == 0.0) & (dur[2:] == dur[:-2]) & (dur[2:] != 0.0)).sum())


@need_core
@pytest.mark.parametrize("seed", range(4))
def test_int_r2_values_against_each_piece_alone(seed):
    rng = np.random.default_rng(4500 + seed)
    osc = Oscillator(float(rng.uniform(20.0, 120.0)), float(rng.uniform(0.02, 0.5)))
    args = res._int_r2_args(osc.s, osc.lam)
    seen = 0
    for trial in range(10):
        n = int(rng.integers(50, 900))
        dur = _lengths(rng, n)
        c = _amps(rng, n)
        decay2 = np.exp(-2.0 * osc.s * dur)
        ts = np.cumsum(rng.exponential(0.01, n))
        out_v = np.empty(3 * n)
        work = np.empty(n)
        got = CORE.ring_int_r2(c, dur, decay2, *args, work, ts, None, None, None, out_v)
        assert got is not None
        want, want_ov = np.empty(n), np.empty(3 * n)
        for i in range(n):
            one = np.empty(1)
            assert CORE.ring_int_r2(c[i:i + 1], dur[i:i + 1], decay2[i:i + 1], *args, one, ts[i:i + 1],
                                    None, None, None, want_ov[3 * i:3 * i + 3]) is not None
            want[i] = one[0]
        assert work.tobytes() == want.tobytes()
        assert out_v.tobytes() == want_ov.tobytes()
        seen += _after_zero_same(dur)
    assert seen > 100, seen
