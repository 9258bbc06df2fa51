"""curves._neighbour_dirs, curves._block_geoms' accel column and schedule.plan_kind_codes'
chain_T test read the strokes' fields in one pass of the compiled core (strokes.stroke_fields)
in place of an attribute read a stroke and field (issue 8, session 39).  Their values must be
the ones 091567e's reads (kept below verbatim) give, bit for bit, on real strokes and on copies
whose fields hold other types (np.float64, int, bool, None, NaN, -0.0, unset), or the same
exception; and with no core (stroke_fields None) the same again."""
from __future__ import annotations

import copy
import math
import random

import numpy as np
import pytest

from gcode_opt import curves as cv
from gcode_opt import features as feat
from gcode_opt import schedule as sc
from gcode_opt import strokes as stk
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile

needs_core = pytest.mark.skipif(stk._CORE is None or not hasattr(stk._CORE, "stroke_fields"),
                                reason="the compiled firmware core is not built")
S = "sample_gcode/"


def ref_neighbour_dirs(sts):
    """curves._neighbour_dirs of 091567e, verbatim."""
    try:
        rows = list(map(cv._NDIRS, sts))
    except AttributeError:
        nan2 = (math.nan, math.nan)
        pu = [nan2 if st.prev_u is None else st.prev_u for st in sts]
        nu = [nan2 if st.next_u is None else st.next_u for st in sts]
        return np.array(pu, float).reshape(-1, 2).T, np.array(nu, float).reshape(-1, 2).T
    a = np.array(rows, float).reshape(len(sts), 4).T
    return a[:2], a[2:]


def ref_accels(sts):
    """_block_geoms' accel column of 091567e."""
    return cv.floats_of(map(cv._ACCEL, sts), len(sts))


def ref_plan_kind_codes(strokes):
    """schedule.plan_kind_codes of 091567e (codes None), verbatim."""
    n = len(strokes)
    codes = sc._kind_codes(strokes)
    chain = np.fromiter(map(sc._IS_NOT_NONE, map(sc._CHAIN_T, strokes)), bool, n)
    if chain.any():
        codes[chain & (codes == sc.C_CURVE)] = sc.C_CHAIN
    return codes


def _bits(x):
    """An array or tuple of arrays as (shape, bytes) each: NaN and -0.0 told apart."""
    if isinstance(x, tuple):
        return tuple(_bits(a) for a in x)
    x = np.asarray(x)
    return x.shape, x.dtype.str, np.ascontiguousarray(x).tobytes()


def _outcome(f, sts):
    try:
        return _bits(f(sts)), None
    except Exception as e:                        # noqa: BLE001 -- the same exception, whatever it is
        return None, type(e).__name__


_CACHE = {}


def _strokes():
    if "s" not in _CACHE:
        prof = load_profile("voron24")
        opts = Options(max_slowdown_r=0.05, features=feat.parse_feature_list("all"))
        opts.corner_budget_r = 1.0
        strokes, _ = analyse(S + "prusa_gyroid.gcode", prof, opts)
        sc.plan_inputs(strokes, prof, opts)
        _CACHE["s"] = strokes
    return _CACHE["s"]


PAIRS = [(cv._neighbour_dirs, ref_neighbour_dirs), (cv._accels, ref_accels),
         (sc.plan_kind_codes, ref_plan_kind_codes)]


@needs_core
@pytest.mark.parametrize("new,ref", PAIRS)
def test_real_strokes_are_the_reference(new, ref):
    sts = _strokes()
    assert len(sts) > 1000
    assert any(s._pux is None for s in sts) and any(s._pux is not None for s in sts)
    got = _outcome(new, sts)
    assert got[1] is None and got == _outcome(ref, sts)
    assert _outcome(new, []) == _outcome(ref, [])


_ODD = [np.float64(1.5), 2, True, False, None, 0.0, -0.0, float("nan"), 1e300, "x", object()]
_NAMES = ("_pux", "_puy", "_nux", "_nuy", "accel", "chain_T")


@needs_core
@pytest.mark.parametrize("seed", range(12))
def test_odd_fields_are_the_reference(seed):
    """Copies of real strokes with fields set to values of other types (or deleted): the
    same values, or the same exception, as the reference."""
    rng = random.Random(seed)
    base = _strokes()
    sts = [copy.copy(s) for s in rng.sample(base, 400)]
    for _ in range(rng.choice([1, 3, 20])):
        st, name = rng.choice(sts), rng.choice(_NAMES)
        if rng.random() < 0.05:
            try:
                delattr(st, name)
            except (AttributeError, TypeError):
                pass
        else:
            try:
                setattr(st, name, rng.choice(_ODD))
            except (TypeError, ValueError):
                pass
    for new, ref in PAIRS:
        assert _outcome(new, sts) == _outcome(ref, sts), new.__name__


@pytest.mark.parametrize("new,ref", PAIRS)
def test_no_core_is_the_reference(new, ref, monkeypatch):
    """Without the core's reader (stroke_fields None, as with no core): the attribute reads."""
    monkeypatch.setattr(cv, "stroke_fields", lambda strokes, names: None)
    monkeypatch.setattr(sc, "stroke_fields", lambda strokes, names: None)
    sts = _strokes()[:500]
    assert _outcome(new, sts) == _outcome(ref, sts)
