"""get_attr (_emit.c: run_block's ~17 attribute reads a stroke) reads an object member
(a __slots__ slot) by its offset and calls a C getter (the compiled StrokeBase's doubles)
directly, without the descriptor's __get__: its reads against getattr's -- the same object
(members), the same value and type (getters), the same exception (an unset slot, a foreign
descriptor) -- on strokes, segment plans, pure-Python slot classes, properties, and types
changed after they were read."""
from __future__ import annotations

import random

import numpy as np
import pytest

from gcode_opt import emit, segments, strokes

CORE = emit.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "attr_read"),
                                reason=f"no compiled emit core: {emit.CORE_WHY}")

STROKE_NAMES = ["first_idx", "last_idx", "kind", "x0", "y0", "_ss_e", "_ss_a", "_ss_c", "_ends", "length_d",
                "e_rel", "feature", "v_feed", "time_t"]
PLAN_NAMES = ["_s", "_accel", "_feed", "first_cmds", "time_t", "_row"]


def _outcome(fn):
    try:
        return "ok", fn()
    except Exception as exc:        # the same exception, type and message
        return "raised", (type(exc), str(exc))


def _same(o, name):
    got = _outcome(lambda: CORE.attr_read(o, name))
    want = _outcome(lambda: getattr(o, name))
    assert got[0] == want[0], (name, got, want)
    if got[0] == "raised":
        assert got[1] == want[1], name
        return
    a, b = got[1], want[1]
    assert type(a) is type(b), name
    if isinstance(a, float):
        assert np.float64(a).tobytes() == np.float64(b).tobytes(), name
    elif isinstance(a, int) or a is None:
        assert a == b, name
    else:
        assert a is b, name             # a member's own object


def _values(rng):
    return [rng.uniform(-1e3, 1e3), -0.0, 0.0, rng.randrange(-10**20, 10**20), None, "perimeter",
            np.arange(rng.randrange(5)) * 0.5, [1.0, 2.0], np.float64(rng.random()), (1, 2)]


def test_strokes():
    rng = random.Random(43)
    for trial in range(300):
        s = strokes.Stroke.__new__(strokes.Stroke)
        for name in STROKE_NAMES:
            if rng.random() < 0.8:
                try:
                    setattr(s, name, rng.choice(_values(rng)))
                except (TypeError, ValueError, OverflowError):
                    pass
            if rng.random() < 0.1:
                try:
                    delattr(s, name)
                except AttributeError:
                    pass
        for name in rng.sample(STROKE_NAMES, len(STROKE_NAMES)) * 2:
            _same(s, name)


def test_plans_and_python_slots():
    rng = random.Random(8)

    class Slots:
        __slots__ = tuple(STROKE_NAMES)

    class Sub(Slots):
        __slots__ = ("extra",)

    plan_types = [segments.SegmentPlan, segments.RowPlan]
    for trial in range(300):
        objs = [Slots(), Sub()] + [tp.__new__(tp) for tp in plan_types]
        for o in objs:
            for name in STROKE_NAMES + PLAN_NAMES:
                if rng.random() < 0.7:
                    try:
                        setattr(o, name, rng.choice(_values(rng)))
                    except AttributeError:
                        pass
        for o in rng.sample(objs, len(objs)):
            for name in rng.sample(STROKE_NAMES + PLAN_NAMES, len(STROKE_NAMES + PLAN_NAMES)):
                _same(o, name)


def test_properties_foreign_descriptors_and_changed_types():
    class A:
        __slots__ = ("kind", "feature")

    class B:                            # the same layout: A's descriptor would read B's slot
        __slots__ = ("x", "y")

    b = B()
    b.x, b.y = "b.x", "b.y"
    a = A()
    a.kind, a.feature = "a.kind", "a.feature"
    B.kind = A.__dict__["kind"]         # A's member on B: its __get__ refuses a B
    B.feature = A.__dict__["feature"]
    for _ in range(3):
        _same(a, "kind")
        _same(b, "kind")
        _same(b, "feature")

    class P:
        __slots__ = ("kind",)
    p = P()
    p.kind = "slot"
    for _ in range(3):
        _same(p, "kind")
    P.kind = property(lambda self: "property")      # the type changed: its tag too
    for _ in range(3):
        _same(p, "kind")
    del P.kind
    _same(p, "kind")

    class Q(P):
        __slots__ = ("feature",)
    q = Q()
    q.feature = "q"
    _same(q, "feature")
    _same(q, "kind")
    Q.feature = property(lambda self: 5.0)
    _same(q, "feature")
