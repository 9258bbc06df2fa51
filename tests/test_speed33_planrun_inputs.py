"""Issue 8 (s33, planrun): schedule.plan_inputs reads the strokes' floats through the
compiled core (strokes.stroke_fields, one pass), each Limits object's fields once, and the
kinds by map (plan_kinds), not an attribute read or a call a stroke.  The arrays must be
the ones e19044c's reads (kept below verbatim) give, bit for bit, on real strokes and on
strokes whose fields hold values of other types; and plan_kinds must be chains.plan_kind
of every stroke."""
from __future__ import annotations

import copy
import random

import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt import schedule as sc
from gcode_opt import strokes as stk
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile

S = "sample_gcode/"


def ref_floats(strokes, profile):
    """plan_inputs' reads at e19044c, verbatim but for the names."""
    return {
        "length_d": np.array([s.length_d for s in strokes], float),
        "ux": np.array([s.ux for s in strokes], float),
        "uy": np.array([s.uy for s in strokes], float),
        "v_feed": np.array([s.v_feed for s in strokes], float),
        "v_lim": np.array([min(s.lim.v_max, profile.max_velocity_v) for s in strokes], float),
        "e_per_mm": np.array([s.e_per_mm for s in strokes], float),
        "ax": np.array([s.lim.ax_max for s in strokes], float),
        "ay": np.array([s.lim.ay_max for s in strokes], float),
        "accel": np.array([s.accel for s in strokes], float),
        "v0": np.array([s.v0 for s in strokes], float),
        "v1": np.array([s.v1 for s in strokes], float),
        "time_t": np.array([s.time_t for s in strokes], float),
        "int_a2": np.array([s.int_a2 for s in strokes], float),
    }


def got_floats(strokes, profile):
    col = sc._float_columns(strokes, sc._PIN_FLOATS)
    col["v_lim"], col["ax"], col["ay"] = sc._lim_columns(strokes, profile)
    return col


def _bits(a):
    return np.ascontiguousarray(a, float).view(np.int64).tolist()


def _outcome(f, *args):
    try:
        return {k: _bits(v) for k, v in f(*args).items()}, None
    except Exception as e:                        # noqa: BLE001 -- the same exception, whatever it is
        return None, type(e).__name__


def _strokes(name, profile):
    prof = load_profile(profile)
    strokes, _ = analyse(S + name, prof, Options())
    return strokes, prof


@pytest.mark.parametrize("name,profile", [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_gyroid_arcs.gcode", "voron24"),
                                          ("cura_box.gcode", "ender3")])
def test_columns_are_the_reference(name, profile):
    strokes, prof = _strokes(name, profile)
    assert len(strokes) > 100
    assert _outcome(got_floats, strokes, prof) == _outcome(ref_floats, strokes, prof)
    if stk._CORE is not None:             # (the compiled reading took every column)
        assert stk.stroke_fields(strokes, sc._PIN_FLOATS) is not None


_ODD = [np.float64(1.5), 2, True, False, None, 0.0, -0.0, float("nan"), float("inf"), 1e300, "x"]


@pytest.mark.parametrize("seed", range(8))
def test_odd_fields_are_the_reference(seed):
    """Copies of real strokes with fields set to values of other types: the same arrays,
    or the same exception, as the reference."""
    rng = random.Random(seed)
    base, prof = _strokes("prusa_gyroid.gcode", "prusa-mk3s")
    sts = [copy.copy(s) for s in base[:300]]
    for _ in range(rng.choice([1, 3, 20])):
        st, name = rng.choice(sts), rng.choice(sc._PIN_FLOATS)
        try:
            setattr(st, name, rng.choice(_ODD))
        except (TypeError, AttributeError):
            pass
    if rng.random() < 0.5:                 # a Limits of its own on some strokes
        for st in rng.sample(sts, 5):
            st.lim = st.lim.replace(v_max=rng.choice([50.0, 2, float("nan")]), ax_max=rng.choice([900.0, 1e9]))
    assert _outcome(got_floats, sts, prof) == _outcome(ref_floats, sts, prof)


def test_empty():
    prof = load_profile("prusa-mk3s")
    assert _outcome(got_floats, [], prof) == _outcome(ref_floats, [], prof)
    assert sc.plan_kinds([]).tolist() == []


@pytest.mark.parametrize("name,profile", [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_gyroid_arcs.gcode", "voron24")])
def test_plan_kinds_are_plan_kind(name, profile):
    strokes, prof = _strokes(name, profile)
    sc.plan_inputs(strokes, prof, Options())          # (classify marks the chains)
    want = [chains.plan_kind(s) for s in strokes]
    assert sc.plan_kinds(strokes).tolist() == want
    assert len(set(want)) >= 3                        # (lines, curves and chains at least)
    # a chain memo on a stroke that is no curve leaves its kind alone
    odd = [copy.copy(s) for s in strokes[:200]]
    for st in odd[::7]:
        st.chain_T = chains.ChainMemo()
    assert sc.plan_kinds(odd).tolist() == [chains.plan_kind(s) for s in odd]
