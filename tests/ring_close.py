"""Ringing figures compared to rounding, not bit for bit.

Since session 46 the core's ring_solve makes a chunk's amplitudes by their recursion
(c_k = c_(k-1) exp(lam d) + dc_k, each piece length's numbers made once), not by numpy's
restarts of a cumulative sum: the same figures to ~1e-14 relative (closer to the exact ones:
tests/test_speed46_ring46_recursion.py), not their bits.  The tests that held the core's
solve to numpy's steps (or to an older copy of them) bit for bit compare with this instead."""
import math

import numpy as np

# the figures of the two solves differ by ~4e-14 relative on the plates and samples (the
# numpy steps' own error: the recursion's is ~2e-16); a figure's "change" (after / before - 1)
# is held to REL absolute (its shift is at most the sum of its two figures' relative ones)
REL = 1e-12


def flat(d, pre=""):
    """{dotted key: leaf} of a nested dict of figures."""
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(flat(v, pre + str(k) + "."))
        else:
            out[pre + str(k)] = v
    return out


def close(got, want, rel=REL):
    """got is want to rel relative (at least rel absolute), NaN where want is."""
    if isinstance(want, float) and math.isnan(want):
        return isinstance(got, float) and math.isnan(got)
    return abs(got - want) <= rel * max(abs(want), 1.0)


def assert_figures_close(got, ref, rel=REL):
    """Two figure dicts (ringing.figures / summary_of's) with the same keys, every float to
    rel (close), every other leaf equal."""
    g, r = flat(got), flat(ref)
    assert g.keys() == r.keys()
    for k, v in r.items():
        if isinstance(v, float) and not isinstance(v, bool):
            assert close(g[k], v, rel), (k, g[k], v)
        else:
            assert g[k] == v, k


def random_events(rng, n):
    """(t, dr, drp): n events of a ring_solve call, 30 % at the time of the one before (a
    block without cruise), 1 % after a long pause, zero jumps of either kind."""
    gaps = rng.exponential(0.01, n) * (rng.uniform(size=n) < 0.7)
    gaps[rng.uniform(size=n) < 0.01] *= 1e3
    t = np.cumsum(gaps) + rng.uniform(-5, 5)
    dr = rng.normal(size=n) * 1e-4 * (rng.uniform(size=n) < 0.8)
    drp = rng.normal(size=n) * 10.0 * (rng.uniform(size=n) < 0.5)
    return t, dr, drp
