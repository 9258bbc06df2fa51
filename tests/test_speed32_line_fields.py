"""segments.line_classes reads the strokes' fields through the compiled core
(firmware/_core.c stroke_fields: the doubles and the kind of each field of every stroke, no
Python object a field; issue 8, session 32).  The classes must be the ones e9d4ed5's
line_classes (kept below verbatim, every field read by attribute) gives, on real strokes and
on strokes whose fields hold other types (np.float64, int, bool, None, unset); and
stroke_fields' values and kinds must be what the attributes read."""
from __future__ import annotations

import copy
import os
import random
import struct

import numpy as np
import pytest

from gcode_opt import features as feat
from gcode_opt import schedule as sc
from gcode_opt import segments as sg
from gcode_opt import strokes as stk
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.segments import (_ENDS, _IS_NONE, _IS_NOT_NONE, _LIM, _LIM_FIELDS, _LINE_FLOATS, _LINE_MAYBE,
                                _NONE_TYPE, _NOT_FLOAT, Stroke, attrgetter, line_spans, row_classes)
from gcode_opt.strokes import K_LINE

needs_core = pytest.mark.skipif(stk._CORE is None or not hasattr(stk._CORE, "stroke_fields"),
                                reason="the compiled firmware core is not built")
S = "sample_gcode/"
PLATE = os.path.expanduser("~/.cache/gcode-opt-corpus/plate_rectilinear.gcode")


def ref_line_classes(strokes):
    """segments.line_classes of e9d4ed5, verbatim (every field read by attribute)."""
    m = len(strokes)
    if m == 0:
        return np.zeros(0, np.int64)
    if set(map(type, strokes)) != {Stroke}:
        return np.arange(m, dtype=np.int64)
    first, last = line_spans(strokes)
    alone = last != first
    alone |= np.fromiter(map(_IS_NOT_NONE, map(_ENDS, strokes)), bool, m)
    cols = []                               # float64 columns, compared by their bytes
    for name in _LINE_FLOATS + _LINE_MAYBE:
        vals = list(map(attrgetter(name), strokes))
        types = set(map(type, vals))
        if types == {float}:
            cols.append(np.fromiter(vals, float, m))
        elif types == {_NONE_TYPE}:
            continue                        # (all None: nothing apart)
        elif types == {bool}:
            cols.append(np.fromiter(vals, bool, m).astype(float))
        elif types == {float, _NONE_TYPE}:
            # None apart from any float (NaN included): a column of which are None
            cols.append(np.array(vals, float))
            cols.append(np.fromiter(map(_IS_NONE, vals), bool, m).astype(float))
        else:                               # (values of other or mixed types: those strokes alone)
            odd = np.fromiter(map(_NOT_FLOAT, vals), bool, m)
            alone |= odd
            cols.append(np.array([0.0 if o else v for v, o in zip(vals, odd.tolist())], float))
    # lim: by its values (few distinct objects)
    lims = list(map(_LIM, strokes))
    by_id, by_val = {}, {}
    for lim in dict(zip(map(id, lims), lims)).values():
        try:
            key = tuple((type(v), np.float64(v).tobytes() if isinstance(v, float) else v)
                        for v in (getattr(lim, f) for f in _LIM_FIELDS))    # (floats by their bytes)
            by_id[id(lim)] = by_val.setdefault(key, len(by_val))
        except (AttributeError, TypeError):
            by_id[id(lim)] = -1
    lim_k = np.fromiter(map(by_id.__getitem__, map(id, lims)), np.int64, m)
    alone |= lim_k < 0
    X = np.empty((m, len(cols) + 1))
    for j, c in enumerate(cols):
        X[:, j] = c
    X.view(np.int64)[:, -1] = lim_k
    out = row_classes(X.view(np.int64))
    k = np.flatnonzero(alone)
    out[k] = out.max() + 1 + np.arange(k.size)      # each a class of its own
    return out



def _lines(path, profile, corners):
    prof = load_profile(profile)
    opts = Options(max_slowdown_r=0.05, features=feat.parse_feature_list("all")) if corners else Options()
    if corners:
        opts.corner_budget_r = 1.0
    strokes, _ = analyse(path, prof, opts)
    sc.plan_inputs(strokes, prof, opts)           # (corners.py sets v0_fw, corner_cmd0, ...)
    return [s for s in strokes if s.kind == K_LINE]


def _outcome(f, sts):
    try:
        return f(sts).tolist(), None
    except Exception as e:                        # noqa: BLE001 -- the same exception, whatever it is
        return None, type(e).__name__


@needs_core
@pytest.mark.parametrize("name,profile,corners", [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", True),
                                                  ("prusa_gyroid.gcode", "voron24", True),
                                                  ("cura_box.gcode", "ender3", False),
                                                  ("prusa_gyroid.gcode", "prusa-mk3s", False)])
def test_line_classes_are_the_reference(name, profile, corners):
    sts = _lines(S + name, profile, corners)
    assert len(sts) > 100
    got = sg.line_classes(sts)
    assert got.tolist() == ref_line_classes(sts).tolist()
    assert np.unique(got).size < len(sts)         # (some lines repeat: classes are compared)


@needs_core
@pytest.mark.skipif(not os.path.exists(PLATE), reason="corpus not downloaded")
def test_line_classes_are_the_reference_plate():
    sts = _lines(PLATE, "prusa-mk3s", False)
    assert sg.line_classes(sts).tolist() == ref_line_classes(sts).tolist()


_ODD = [np.float64(1.5), 2, True, False, None, 0.0, -0.0, float("nan"), 1e300, "x", (1.0, 2.0)]


@needs_core
@pytest.mark.parametrize("seed", range(8))
def test_line_classes_odd_fields_are_the_reference(seed):
    """Copies of real lines with fields set to values of other types (or deleted): the same
    classes, or the same exception, as the reference."""
    rng = random.Random(seed)
    base = _lines(S + "prusa_mk3s_rectilinear.gcode", "prusa-mk3s", True)[:300]
    names = _LINE_FLOATS + _LINE_MAYBE
    sts = [copy.copy(s) for s in base] + [copy.copy(s) for s in base[:50]]
    for _ in range(rng.choice([1, 3, 20])):
        st, name = rng.choice(sts), rng.choice(names + ("_ends",))
        r = rng.random()
        if r < 0.05:
            try:
                delattr(st, name)
            except AttributeError:
                pass
        elif name == "_ends":
            st._ends = rng.choice([None, stk.array("d", [st.length_d]), None])
        else:
            setattr(st, name, rng.choice(_ODD))
    assert _outcome(sg.line_classes, sts) == _outcome(ref_line_classes, sts)


@needs_core
def test_stroke_fields_are_the_attributes():
    sts = _lines(S + "prusa_gyroid.gcode", "voron24", True)
    sts = [copy.copy(s) for s in sts[:200]]
    sts[3].v0_fw, sts[4].corner_cmd0, sts[5].ux, sts[6]._pux = 2.5, True, np.float64(0.5), None
    del sts[7].v1_fw
    names = _LINE_FLOATS + _LINE_MAYBE + ("_ends",)
    vals, kinds = stk.stroke_fields(sts, names)
    for i, s in enumerate(sts):
        for j, name in enumerate(names):
            k = kinds[i, j]
            try:
                v = getattr(s, name)
            except AttributeError:
                assert k in (3, 4), (i, name)
                continue
            if type(v) is float:
                assert k == 0 and struct.pack("<d", vals[i, j]) == struct.pack("<d", v), (i, name)
            elif v is None:
                assert k == 1 and struct.pack("<d", vals[i, j]) == struct.pack("<d", np.array([None], float)[0])
            elif type(v) is bool:
                assert k == 2 and vals[i, j] == float(v), (i, name)
            else:
                assert k == 3, (i, name, v)
    assert stk.stroke_fields(sts, ("ux", "no_such_field")) is None
    assert stk.stroke_fields(sts + [object()], ("ux",)) is None
