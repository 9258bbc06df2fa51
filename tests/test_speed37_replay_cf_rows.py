"""Issue 8 (s37, replay): the chain core's cf_rows reads each stroke's and each limits
object's numbers by their types' data descriptors, looked up once a call (a limits type's
again for each new type of lim), not by PyObject_GetAttr a read; where a type's getattr
is not the generic one or a name is not a data descriptor there, by PyObject_GetAttr as
before.  Held to chains._cf_row (Python's own attribute reads) bit for bit: real chains
whose lim objects are of several types in one call (each switch of type looks its
descriptors up again), limits whose numbers are in an instance dict or a property, a
limits type and a stroke type whose __getattribute__ gives other numbers than their
slots (the descriptors must not be read then)."""
import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.laws import chain as chain_law
from gcode_opt.state import Limits

from chain_cases import chain_strokes, float_bits

CASE = ("sample_gcode/prusa_gyroid_fullspeed_klipper.gcode", "voron24")
_FIELDS = ("jerk_x", "jerk_y", "scv", "ax_max", "ay_max")

needs_core = pytest.mark.skipif(chain_law.CORE_MOD is None, reason="chain core not built")


class _DictLim:
    """Limits whose numbers are in the instance dict (no descriptor on the type)."""

    def __init__(self, lim):
        for f in _FIELDS:
            setattr(self, f, getattr(lim, f))


class _PropLim:
    """Limits whose numbers are properties (data descriptors that run Python code)."""

    def __init__(self, lim):
        self._v = {f: getattr(lim, f) for f in _FIELDS}

    jerk_x = property(lambda self: self._v["jerk_x"])
    jerk_y = property(lambda self: self._v["jerk_y"])
    scv = property(lambda self: self._v["scv"])
    ax_max = property(lambda self: self._v["ax_max"])
    ay_max = property(lambda self: self._v["ay_max"] * 0.5)


class _OddLim(Limits):
    """Limits whose __getattribute__ gives other numbers than its slots hold."""
    __slots__ = ()

    def __getattribute__(self, name):
        v = object.__getattribute__(self, name)
        return v * 0.75 + 1.0 if name in _FIELDS else v


class _SubLim(Limits):
    """Limits whose scv is a class attribute over the slot (not a data descriptor)."""
    __slots__ = ()


def _ref_rows(sts):
    return np.array([chains._cf_row(st) for st in sts], float).reshape(len(sts), chains._CF_ROW)


def _core_rows(sts, stype=chains.Stroke):
    Q = np.full((len(sts), chains._CF_ROW), -1.0)
    assert chain_law.CORE_MOD.cf_rows(list(sts), stype, Q) == 1            # not declined
    return Q


def _sts():
    strokes, pin, rows, prof = chain_strokes(*CASE)
    return [strokes[i] for i in rows.tolist()[:400]]


@needs_core
def test_cf_rows_reads_by_descriptors_across_lim_types():
    sts = _sts()
    saved = [st.lim for st in sts]
    rng = np.random.default_rng(37)
    makers = [lambda lim: lim,
              lambda lim: _DictLim(lim),
              lambda lim: _PropLim(lim),
              lambda lim: _OddLim(*(getattr(lim, s) for s in Limits.__slots__)),
              lambda lim: Limits(*(getattr(lim, s) * 1.5 for s in Limits.__slots__))]
    try:
        # runs of one type and single ones, every type after every other
        for q, st in enumerate(sts):
            k = int(rng.integers(0, len(makers))) if q % 7 else (q // 7) % len(makers)
            st.lim = makers[k](saved[q])
        assert len({type(st.lim) for st in sts}) == len(makers) - 1          # (two of Limits)
        want = _ref_rows(sts)
        assert float_bits(_core_rows(sts)) == float_bits(want)
        assert float_bits(chains._cf_rows(sts)) == float_bits(want)
        # (the odd and the property types' numbers are not their slots': read as Python reads them)
        odd = [q for q, st in enumerate(sts) if type(st.lim) is _OddLim]
        assert all(want[q, 4] == saved[q].jerk_x * 0.75 + 1.0 for q in odd)
    finally:
        for st, lim in zip(sts, saved):
            st.lim = lim


@needs_core
def test_cf_rows_class_attribute_over_a_slot():
    sts = _sts()[:60]
    saved = [st.lim for st in sts]
    try:
        for st, lim in zip(sts, saved):
            st.lim = _SubLim(*(getattr(lim, s) for s in Limits.__slots__))
        _SubLim.scv = 123.25            # a class attribute: not a data descriptor (getattr then)
        want = _ref_rows(sts)
        assert (want[:, 6] == 123.25).all()
        assert float_bits(_core_rows(sts)) == float_bits(want)
    finally:
        del _SubLim.scv
        for st, lim in zip(sts, saved):
            st.lim = lim


@needs_core
def test_cf_rows_stroke_type_with_own_getattribute():
    class OddStroke(chains.Stroke):
        __slots__ = ()

        def __getattribute__(self, name):
            v = chains.Stroke.__getattribute__(self, name)
            return v + 0.5 if name in ("v_feed", "v0", "v1") else v

    sts = _sts()[:80]
    saved = [type(st) for st in sts]
    try:
        for st in sts:
            st.__class__ = OddStroke
        want = _ref_rows(sts)
        assert float_bits(_core_rows(sts, OddStroke)) == float_bits(want)
        for st in sts:
            st.__class__ = chains.Stroke
        assert float_bits(_core_rows(sts)) != float_bits(want)              # (they differ indeed)
    finally:
        for st, t in zip(sts, saved):
            st.__class__ = t
