"""probe_draws.Draws: the run-time probes' draws (firmware/resonance.py, laws/circle.py) without
numpy.random's import.  Repeatable per seed, apart between seeds, and spread as the calls say
(moments against the distributions' own, over 2e5 draws; the uniform's 53 bits)."""
import math

import numpy as np
import pytest

from gcode_opt.probe_draws import Draws


def test_repeatable_and_seeds_apart():
    a, b = Draws(11).normal(1000), Draws(11).normal(1000)
    assert a.tobytes() == b.tobytes()
    c = Draws(12).normal(1000)
    assert not np.any(a == c)
    d = Draws(11)
    first, second = d.uniform(size=500), d.uniform(size=500)     # the stream goes on between calls
    assert not np.any(first == second)


@pytest.mark.parametrize("seed", [0, 7, 2 ** 64 - 1])
def test_spread(seed):
    n = 200_000
    d = Draws(seed)
    u = d.uniform(2.0, 5.0, n)
    assert u.min() >= 2.0 and u.max() < 5.0
    assert abs(u.mean() - 3.5) < 0.02 and abs(u.var() - 0.75) < 0.01
    z = d.normal(n)
    assert np.isfinite(z).all()
    assert abs(z.mean()) < 0.01 and abs(z.std() - 1.0) < 0.01
    assert abs(np.mean(z ** 4) - 3.0) < 0.1                       # a normal's kurtosis
    e = d.exponential(0.5, n)
    assert e.min() >= 0.0 and abs(e.mean() - 0.5) < 0.01 and abs(np.median(e) - 0.5 * math.log(2)) < 0.01
    # the unit draws use 53 bits: many distinct low bits
    k = (d.uniform(size=4096) * 2.0 ** 53).astype(np.int64)
    assert len(np.unique(k & 0xFF)) > 200


def test_shapes_as_numpy_reads_them():
    d = Draws(3)
    assert d.normal(size=(2, 3, 4)).shape == (2, 3, 4)
    assert d.uniform(size=7).shape == (7,)
    assert d.exponential(1.0, 5).shape == (5,)
