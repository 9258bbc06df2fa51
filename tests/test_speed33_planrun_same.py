"""Issue 8 (s33, planrun): schedule.plan_inputs reads the strokes' floats through the
compiled core (strokes.stroke_fields, one pass), each Limits object's fields once, and the
kinds by map (plan_kind_codes), not an attribute read or a call a stroke.  The arrays must be
the ones e19044c's reads (kept below verbatim) give, bit for bit, on real strokes and on
strokes whose fields hold values of other types; and plan_kind_codes must be the codes of
chains.plan_kind of every stroke.  segments.plan_once keys its strokes by a hash of their (T, beta, class)
bytes (segments.row_classes), not np.unique's sort of 24-byte records: the same rows
planned and the same plan for each row as e19044c's keys (kept below verbatim)."""
from __future__ import annotations

import copy
import random

import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt import schedule as sc
from gcode_opt import segments as sg
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
    assert sc.plan_kind_codes([]).tolist() == []


@pytest.mark.parametrize("name,profile", [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_gyroid_arcs.gcode", "voron24")])
def test_plan_kinds_are_plan_kind(name, profile):
    strokes, prof = _strokes(name, profile)
    sc.plan_inputs(strokes, prof, Options())          # (classify marks the chains)
    want = [chains.plan_kind(s) for s in strokes]
    assert sc.plan_kind_codes(strokes).tolist() == [sc.KIND_CODE[k] for k in want]
    assert len(set(want)) >= 3                        # (lines, curves and chains at least)
    # a chain memo on a stroke that is no curve leaves its kind alone
    odd = [copy.copy(s) for s in strokes[:200]]
    for st in odd[::7]:
        st.chain_T = chains.ChainMemo()
    # a kind the planner has none of: in no kind's rows
    for st in odd[3::11]:
        st.kind = "spline"
    assert sc.plan_kind_codes(odd).tolist() == [sc.KIND_CODE.get(chains.plan_kind(s), sc.NO_KIND) for s in odd]
    rows = sc._rows_by_kind(odd)
    assert sorted(np.concatenate(list(rows.values())).tolist()) == [i for i, s in enumerate(odd) if s.kind != "spline"]


# ---------------------------------------------------------------- segments.plan_once
def ref_plan_once_groups(T, beta, same):
    """plan_once's keys at e19044c, verbatim: (the rows planned, each row's place among
    them), or None where it declines."""
    m = len(T)
    key = np.empty((m, 3))
    key[:, 0], key[:, 1], key[:, 2] = T, beta, 0.0
    key.view(np.int64)[:, 2] = same
    _, first, inv = np.unique(key.view(np.dtype((np.void, 24))).ravel(), return_index=True, return_inverse=True)
    if first.size > sg.SAME_MAX_R * m:
        return None
    order = np.argsort(first)
    rows = first[order]
    place = np.empty_like(order)
    place[order] = np.arange(order.size)
    return rows.tolist(), place[inv.ravel()].tolist()


def _groups(T, beta, same):
    """plan_once's (rows planned, each row's place among them) as it plans now."""
    seen = []

    def fn(sts, T_, b_):
        seen.append(list(sts))
        return list(range(len(sts)))
    out = sg.plan_once(fn, list(range(len(T))), T, beta, same)
    return None if out is None else (seen[0], out)


@pytest.mark.parametrize("seed", range(6))
def test_plan_once_groups_are_the_reference(seed):
    """Keys repeating in any of their three parts, signed zeros and NaNs of other bits
    (keys equal in their bytes only), few or many distinct: the same rows planned and the
    same plan taken by each row."""
    rng = np.random.default_rng(seed)
    m = int(rng.integers(2, 3000))
    k = int(rng.integers(1, m + 1))
    T = rng.choice([1.0, 2.0, 0.0, -0.0, np.nan, 3.5, 1e-300], k)[rng.integers(0, k, m)]
    beta = rng.choice([np.inf, 1.0, 2.0, -0.0, 0.0], k)[rng.integers(0, k, m)]
    same = rng.integers(0, [3, 40, 400][seed % 3], m).astype(np.int64)
    if seed % 2:
        T.view(np.int64)[rng.integers(0, m, 5)] = 0x7FF8000000000001      # a NaN of other bits
    want = ref_plan_once_groups(T, beta, same)
    assert _groups(T, beta, same) == want
    if seed % 3 == 0:
        assert want is not None and len(want[0]) < m     # (rows share plans: the groups compared)


# ---------------------------------------------------------------- _not_failed, _faults_of
@pytest.mark.parametrize("seed", range(4))
def test_failed_rows_are_the_reference(seed):
    """schedule._not_failed and _faults_of against plan_strokes' and _candidates' list
    comprehensions of e19044c (kept here verbatim)."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(0, 500))
    fault = np.empty(n, dtype=object)
    fault[:] = ""
    for i in rng.integers(0, max(n, 1), int(rng.integers(0, 6))).tolist() if n else []:
        fault[i] = rng.choice(["error: planning (ValueError)", "error: non-finite plan input"])
    want = {i: str(r) for i, r in enumerate(fault) if r}
    got = sc._faults_of(fault)
    assert got == want and list(got) == list(want)
    assert sc._faults_of(list(fault)) == want
    for failed in (want, {}, {int(i): "x" for i in rng.integers(0, max(n, 1), 3)}):
        rows = np.sort(rng.choice(max(n, 1), size=min(n, 100), replace=False)) if n else np.zeros(0, int)
        ref = np.array([i for i in rows if i not in failed], int)
        new = sc._not_failed(rows, failed)
        assert new.dtype == ref.dtype and new.tolist() == ref.tolist()
        assert new is not rows
