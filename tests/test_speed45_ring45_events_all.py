"""Session 45, the ringing's CPU (helper "ring45"): ring_events without the parts (all_only,
a Collector(parts=False): the command line without --json, --report or --corners auto) keeps
an event where dr != 0.0 or drp != 0.0 by the two numbers' bits (ring_either_nonzero: an OR
and a shift, zeros of both signs out, NaN in), not by two compares.

Held to the code it replaces -- the parts' run (ring_events' "all" there still by the two
compares: the same streams either way) and test_speed_rw9_ring_events' _ref_events (the
ddecd40 numpy steps: "all"'s mask ramp | jump) -- every "all" stream's times, dr and drp bit
for bit, and the carry, on real files' rows in chunks, rows made to give dr and drp of
every kind, and random rows with zeros of both signs, NaN, inf and subnormals in every
column.  (On those the numpy steps are not held: a NaN's sign there is numpy's, not the
core's, before this change as after it -- the parts' run is.)
"""
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(__file__))
from test_speed_rw9_ring_events import MODELS, _random_rows, _ref_events, _rows  # noqa: E402

from gcode_opt import ringing as rg  # noqa: E402
from gcode_opt.firmware import simulate as fw  # noqa: E402
from gcode_opt.ringing import _Carry  # noqa: E402

CORE = fw._core
need_core = pytest.mark.skipif(CORE is None or not hasattr(CORE, "ring_events"),
                               reason="the compiled firmware core is not built here")


def _same_carry(c_ref, c):
    for key in ("t", "ux", "uy", "isb"):
        assert np.float64(getattr(c_ref, key)).tobytes() == np.float64(getattr(c, key)).tobytes(), key
    assert c_ref.vel_end.tobytes() == c.vel_end.tobytes() and c_ref.acc.tobytes() == c.acc.tobytes()


def _same_all(m, model, c_ref, c_new, c_parts, numpy=True):
    """"all"'s events of rows m without the parts, against the parts' run and (numpy) the
    numpy steps; the number of events."""
    got = rg._events(m, c_new, model, False)
    parts = rg._events(m, c_parts, model, True)
    want = _ref_events(m, c_ref, model) if numpy else None
    assert sorted(got) == [("x", "all"), ("y", "all")]
    for k in got:
        for j, (a, p) in enumerate(zip(got[k], parts[k])):
            assert a.dtype == p.dtype and a.tobytes() == p.tobytes(), k
            if numpy:
                assert a.tobytes() == want[k][j].tobytes(), k
    _same_carry(c_parts, c_new)
    if numpy:
        _same_carry(c_ref, c_new)
    return sum(len(got[k][0]) for k in got)


def _chunks(m, model, size, numpy=True):
    carries = (_Carry(), _Carry(), _Carry())
    n = 0
    for lo in range(0, len(m), size):
        n += _same_all(m[lo:lo + size].copy(), model, *carries, numpy)
    return n


@need_core
@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "prusa-mk3s"), ("cura_box.gcode", "ender3")])
@pytest.mark.parametrize("chunk", [1, 97, 5000])
def test_real_rows_in_chunks(name, prof, chunk):
    m = _rows(name, prof)
    idle = np.array([rg.IDLE])
    m = np.vstack([idle, m, idle])
    for model in MODELS:
        assert _chunks(m, model, chunk) > 0


@need_core
@pytest.mark.parametrize("seed", range(8))
def test_random_and_degenerate_rows(seed):
    rng = np.random.default_rng(4520 + seed)
    m = _random_rows(rng, int(rng.integers(1, 3000)))
    # more odd numbers: zeros of both signs, NaN, infinities, subnormals in the speeds,
    # accelerations and directions (dr = da / w^2 and drp = -dv of every sign and kind)
    for _ in range(max(len(m) // 20, 1)):
        m[rng.integers(len(m)), rng.integers(9)] = rng.choice([np.nan, -np.nan, np.inf, -np.inf, 0.0, -0.0,
                                                               5e-324, -5e-324, 1e308])
    for model in MODELS:
        _chunks(m, model, 701, numpy=False)


@need_core
def test_zero_signs_and_nan_keep_as_the_masks_do():
    """Rows made so a piece's dr or drp is exactly +0, -0, a subnormal or NaN: the same events."""
    m = np.zeros((8, 12))
    m[:, 0], m[:, 1] = 1.0, 0.0
    m[:, 11] = 1.0
    m[:, 6:9] = 0.01
    m[:, 2] = [0.0, -0.0, 5e-324, np.nan, 1.0, 0.0, -0.0, 2.0]      # start speeds: the jumps
    m[:, 3] = m[:, 2]
    m[:, 5] = [0.0, -0.0, 0.0, 5e-324, np.nan, -0.0, 1e-300, 0.0]   # accelerations: the ramps
    m[:, 10] = np.arange(8)
    for model in MODELS:
        _chunks(m, model, 8)
        _chunks(m, model, 1)
