"""Session 41: _npsum.h's np_pairwise_sum with numpy's eight partial sums held as four pairs of
vector lanes (gcc/clang) instead of an array gcc kept on the stack -- the one pairwise sum of
the three compiled cores (tests/test_native_headers.py), here reached through the firmware
core's ringing sums: ring_int_r2's integral and ring_rows_time's time.

Held to numpy's own sums, bit for bit, over every length about numpy's blocks (below 8, the
8-blocks up to 128, the halving above it), numbers of mixed magnitudes and signs, zeros of
both signs.  (The chain and curve cores' sums are held to numpy's by their own tests.)
"""
import numpy as np
import pytest

from gcode_opt.firmware import resonance as res
from gcode_opt.firmware import simulate as fw
from gcode_opt.firmware.resonance import Oscillator

CORE = fw._core
need_core = pytest.mark.skipif(CORE is None or not hasattr(CORE, "ring_int_r2"),
                               reason="the compiled firmware core is not built here")

LENGTHS = list(range(1, 140)) + [255, 256, 257, 1000, 1023, 1024, 1025, 4097, 10007, 65537]


def _bits(x):
    return np.float64(x).tobytes()


@need_core
@pytest.mark.parametrize("seed", range(3))
def test_int_r2_sum_is_numpys_sum(seed):
    rng = np.random.default_rng(4150 + seed)
    osc = Oscillator(float(rng.uniform(20.0, 120.0)), 0.1)
    args = res._int_r2_args(osc.s, osc.lam)
    for n in LENGTHS:
        # (amplitudes over many magnitudes: the pieces' values cancel and round)
        c = (rng.normal(size=n) + 1j * rng.normal(size=n)) * np.exp(rng.normal(size=n) * 6.0)
        dur = rng.exponential(0.02, n) * (rng.uniform(size=n) < 0.7)
        work = np.empty(n)
        got = CORE.ring_int_r2(c, dur, np.exp(-2.0 * osc.s * dur), *args, work)
        assert got is not None
        assert _bits(got) == _bits(work.sum()), n


@need_core
@pytest.mark.parametrize("seed", range(2))
def test_rows_time_is_numpys_sum(seed):
    rng = np.random.default_rng(4160 + seed)
    m = np.zeros((30000, 12))
    m[:, 6:9] = rng.uniform(0.0, 1.0, (len(m), 3)) * rng.choice([1e-9, 1e-3, 1.0, 1e3, -1.0], (len(m), 3))
    m[rng.uniform(size=len(m)) < 0.05, 7] = -0.0
    for n in LENGTHS[:150:3] + [2730, 2731, 2732, 5461, 20000, 29999]:
        a = int(rng.integers(0, 3))
        b = min(a + n, len(m))
        assert _bits(CORE.ring_rows_time(m, a, b)) == _bits(m[a:b, 6:9].sum()), n
