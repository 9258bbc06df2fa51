"""stroke_run (_emit.c) reads a compiled StrokeBase's doubles and ints (x0, y0, time_t, _ss_e,
length_d, first_idx, last_idx) in place, through the firmware core's _STROKE_FIELDS
capsule, where the attribute's slot holds that core's getter: field_read gives that
read, which must be getattr's value (the same bits, None for a None-able double without
one) wherever it is taken, and not be taken where the field holds another object (the
getters' odd fields: np.float64, an int) or is unset."""
from __future__ import annotations

import random

import numpy as np
import pytest

from gcode_opt import emit, strokes
from gcode_opt.firmware import simulate

CORE = emit.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "field_read")
                                or simulate.CORE != "c" or not hasattr(simulate._core, "_STROKE_FIELDS"),
                                reason="no compiled emit and firmware cores")

DOUBLES = ["x0", "y0", "time_t", "_ss_e", "length_d"]
INTS = ["first_idx", "last_idx"]


def _values(rng, name):
    if name in INTS:
        return [rng.randrange(-10**6, 10**6), 0, 2**62, np.int64(5), 1.5]
    return [rng.uniform(-1e3, 1e3), -0.0, 0.0, float("inf"), float("nan"), None, np.float64(rng.random()), 3]


def _bits(v):
    return np.float64(v).tobytes()


def test_in_place_reads_are_getattrs():
    rng = random.Random(64)
    taken = 0
    for _ in range(400):
        s = strokes.Stroke.__new__(strokes.Stroke)
        for name in DOUBLES + INTS:
            if rng.random() < 0.9:
                try:
                    setattr(s, name, rng.choice(_values(rng, name)))
                except (TypeError, ValueError, OverflowError):
                    pass
            if rng.random() < 0.05:
                try:
                    delattr(s, name)
                except AttributeError:
                    pass
        for name in rng.sample(DOUBLES + INTS, len(DOUBLES + INTS)) * 2:
            CORE.attr_read(s, name) if hasattr(s, name) else None     # (fills the attribute's slot)
            got, v = CORE.field_read(s, name)
            if not got:
                continue
            taken += 1
            want = getattr(s, name)
            assert type(v) is type(want), (name, v, want)
            if isinstance(want, float):
                assert _bits(v) == _bits(want), (name, v, want)
            else:
                assert v == want, (name, v, want)
    assert taken > 1000


def test_not_taken_for_other_types():
    class Plain:
        __slots__ = tuple(DOUBLES + INTS)

    o = Plain()
    for name in DOUBLES + INTS:
        setattr(o, name, 1.5)
        CORE.attr_read(o, name)
        assert CORE.field_read(o, name) == (False, None)
    s = strokes.Stroke.__new__(strokes.Stroke)
    s.x0 = np.float64(2.5)              # an odd value: kept as the object itself
    CORE.attr_read(s, "x0")
    assert CORE.field_read(s, "x0") == (False, None)
    s.x0 = 2.5
    assert CORE.field_read(s, "x0") == (True, 2.5)
