"""The ringing probes' amplitudes set part by part (resonance._complex_of, session 39b)
against the complex expression they replace: _int_r2_probe's are the old formula's numbers,
bit for bit (zeros and signs included).  (_peak_ok's probe went with it in session 46: the
core's ring_solve solves the peak unprobed.)"""
import numpy as np
import pytest

from gcode_opt.firmware import resonance as R
from gcode_opt.probe_rng import ProbeRng


@pytest.mark.parametrize("seed,scale", [(13, 4.0), (19, 4.0), (17, 6.0), (3, 1.0)])
def test_complex_of_is_the_expression(seed, scale):
    rng = ProbeRng(seed)
    for n in (1, 2, 7, 4000, 36602):
        a, b, d, e = (rng.normal(size=n) for _ in range(4))
        re, x, y = a * np.exp(b * scale), d, np.exp(e * scale)
        want = re + 1j * x * y
        got = R._complex_of(re, x * y)
        assert got.dtype == want.dtype and got.tobytes() == want.tobytes()
