"""The ringing probes' amplitudes set part by part (resonance._complex_of, session 39b)
against the complex expression they replace: _peak_ok's probe (_peak_probe) and
_int_r2_probe's are the old formulas' numbers, bit for bit (zeros and signs included)."""
import math

import numpy as np
import pytest

from gcode_opt.firmware import resonance as R
from gcode_opt.probe_rng import ProbeRng


def _old_peak_probe(s, wd):
    """_peak_ok's numbers as it drew them before _peak_probe."""
    rng = ProbeRng(19)
    n = R.PEAK_PROBE_N
    c = rng.normal(size=n) * np.exp(rng.normal(size=n) * 4.0) \
        + 1j * rng.normal(size=n) * np.exp(rng.normal(size=n) * 4.0)
    c[rng.uniform(size=n) < 0.03] = 0.0
    c.imag[rng.uniform(size=n) < 0.03] = 0.0
    c.real[rng.uniform(size=n) < 0.03] = -0.0
    dur = rng.exponential(math.pi / wd, n) * (rng.uniform(size=n) < 0.95)
    dur[:200] = np.geomspace(1e-12, 100.0 / s, 200)
    return c, dur


@pytest.mark.parametrize("freq_hz,damping_r", [(50.0, 0.1), (37.5, 0.05), (81.0, 0.3), (12.0, 0.6)])
def test_peak_probe_is_the_old_draw(freq_hz, damping_r):
    osc = R.Oscillator(freq_hz, damping_r)
    c, dur = R._peak_probe(osc.s, osc.wd)
    c0, dur0 = _old_peak_probe(osc.s, osc.wd)
    assert c.dtype == c0.dtype and c.tobytes() == c0.tobytes()
    assert dur.tobytes() == dur0.tobytes()
    # the probe still has its edge cases
    assert (c == 0).sum() > 100 and (np.signbit(c.real) & (c.real == 0)).sum() > 100
    assert ((c.imag == 0) & (c.real != 0)).sum() > 100 and (dur == 0).sum() > 100


@pytest.mark.parametrize("seed,scale", [(13, 4.0), (19, 4.0), (17, 6.0), (3, 1.0)])
def test_complex_of_is_the_expression(seed, scale):
    rng = ProbeRng(seed)
    for n in (1, 2, 7, 4000, 36602):
        a, b, d, e = (rng.normal(size=n) for _ in range(4))
        re, x, y = a * np.exp(b * scale), d, np.exp(e * scale)
        want = re + 1j * x * y
        got = R._complex_of(re, x * y)
        assert got.dtype == want.dtype and got.tobytes() == want.tobytes()
