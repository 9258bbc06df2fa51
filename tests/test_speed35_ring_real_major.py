"""ring_solve's integral loop in two copies (issue 8, round 35): the branch of
_real_quotient it takes (real_major: |Re 4 lam| >= |Im 4 lam|, i.e. a damping ratio of at
least 1/sqrt(2)) is a constant of each copy instead of a test a piece.  Every other ring_solve
test draws dampings below 0.5 (one copy only): here both copies against numpy's steps bit
for bit, alone and with a memo kept by one stream and read by the next."""
import math

import numpy as np
import pytest

from gcode_opt.firmware import resonance as res
from gcode_opt.firmware.resonance import Oscillator
from test_speed20_ring_solve import _same, _steps, need_solve  # noqa: E402


def _random_stream(rng):
    """(t, dr, drp, first) as test_speed20_ring_solve's random streams: events at one time,
    zero jumps of both signs, long pauses, a carried amplitude or none."""
    n = int(rng.integers(2, 3000))
    gaps = rng.exponential(0.01, n) * (rng.uniform(size=n) < 0.7)
    gaps[rng.uniform(size=n) < 0.01] *= 1e3
    t = np.cumsum(gaps) + rng.uniform(-5, 5)
    dr = rng.normal(size=n) * 1e-4 * (rng.uniform(size=n) < 0.8)
    drp = rng.normal(size=n) * 10.0 * (rng.uniform(size=n) < 0.5)
    dr[rng.uniform(size=n) < 0.05] = -0.0
    first = complex(rng.normal(), rng.normal()) * 1e-3 if rng.uniform() < 0.7 else None
    if first is not None:
        t = np.concatenate([[t[0] - rng.exponential(0.01)], t])
    return t, dr, drp, first


@need_solve
@pytest.mark.parametrize("damping_r", (0.1, 0.6, 0.75, 0.95))
def test_ring_solve_is_the_steps_on_both_sides_of_the_quotient_branch(damping_r):
    osc = Oscillator(50.0, damping_r)
    real_major = res._int_r2_args(osc.s, osc.lam)[5]
    assert real_major == (damping_r > math.sqrt(0.5))      # the copy this damping takes
    rng = np.random.default_rng(round(damping_r * 100))
    for _ in range(6):
        t, dr, drp, first = _random_stream(rng)
        want = _steps(osc, t, dr, drp, first)
        got = osc.solve(t, dr, drp, first)
        assert got is not None and _same(got, want)
        memo = res.RingMemo()
        assert _same(osc.solve(t, dr, drp, first, memo, True), want)     # keeps its exponentials
        assert _same(osc.solve(t, dr, drp, first, memo, False), want)    # takes them
