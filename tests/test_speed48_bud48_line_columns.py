"""segments.line_classes reads the strokes' fields as contiguous rows (session 48:
_stroke_columns, stroke_fields by chunks of FIELD_ROWS strokes transposed) and takes a
field of floats only without a bincount (_core_column).  The classes must be the ones the
reference of tests/test_speed32_line_fields.py gives (an older line_classes, every field
read by attribute), for chunks that split the strokes anywhere, on real lines (with and
without corners.py's fields set) and on lines whose fields hold other types; and the
transposed tables must be stroke_fields' own values and kinds."""
import copy
import random

import numpy as np
import pytest

from gcode_opt import segments as sg
from gcode_opt import strokes as stk
from gcode_opt.segments import _LINE_FLOATS, _LINE_MAYBE

import test_speed32_line_fields as t32

needs_core = pytest.mark.skipif(stk._CORE is None or not hasattr(stk._CORE, "stroke_fields"),
                                reason="the compiled firmware core is not built")
NAMES = _LINE_FLOATS + _LINE_MAYBE + ("_ends",)


@needs_core
@pytest.mark.parametrize("rows", [1, 7, 300, 4096])
@pytest.mark.parametrize("name,profile,corners", [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", True),
                                                  ("prusa_gyroid.gcode", "prusa-mk3s", False)])
def test_chunked_classes_are_the_reference(monkeypatch, rows, name, profile, corners):
    sts = t32._lines(t32.S + name, profile, corners)
    monkeypatch.setattr(sg, "FIELD_ROWS", rows)
    vals, kinds = stk.stroke_fields(sts, NAMES)
    got_v, got_k = sg._stroke_columns(sts, NAMES)
    assert got_v.flags.c_contiguous and got_k.flags.c_contiguous
    assert got_v.tobytes() == np.ascontiguousarray(vals.T).tobytes()
    assert got_k.tobytes() == np.ascontiguousarray(kinds.T).tobytes()
    assert sg.line_classes(sts).tolist() == t32.ref_line_classes(sts).tolist()


@needs_core
@pytest.mark.parametrize("seed", range(6))
def test_chunked_odd_fields_are_the_reference(monkeypatch, seed):
    """Lines with fields of other types, None or unset, past the first chunks: the same
    classes (or the same exception) as the reference."""
    monkeypatch.setattr(sg, "FIELD_ROWS", 64)
    rng = random.Random(480 + seed)
    base = t32._lines(t32.S + "prusa_mk3s_rectilinear.gcode", "prusa-mk3s", True)[:300]
    sts = [copy.copy(s) for s in base] + [copy.copy(s) for s in base[:80]]
    for _ in range(rng.choice([1, 3, 20])):
        st, name = rng.choice(sts[100:]), rng.choice(NAMES)
        if name == "_ends":
            st._ends = rng.choice([None, stk.array("d", [st.length_d])])
        elif rng.random() < 0.05:
            try:
                delattr(st, name)
            except AttributeError:
                pass
        else:
            setattr(st, name, rng.choice(t32._ODD))
    for st in rng.sample(sts, 30):                 # a field that is None on some strokes only
        st._nux = None
    assert t32._outcome(sg.line_classes, sts) == t32._outcome(t32.ref_line_classes, sts)
