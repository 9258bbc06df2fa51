"""The budget runs a window at a time (issue 8, runs52): schedule.plan_strokes over a
stored_strokes.StoredStrokes (the strokes spilled to a StrokeStore, plan_inputs and the
candidates made a window at a time, the line classes read a chunk at a time, the rows of
schedule.WINDOW_KINDS segmented a window of rows at a time) gives the plan the list gives,
bit for bit: T, beta, retime, reason, t_pred, a2_pred and every row's segment plan (its four
arrays' bytes, figures, shape), windows of 1, a few and many strokes."""
import hashlib

import numpy as np
import pytest

from gcode_opt import features as feat
from gcode_opt import pipeline as pl
from gcode_opt import schedule as sc
from gcode_opt.profile import load_profile
from gcode_opt.stored_strokes import StoredStrokes, curve_geometry, join_plan_inputs
from gcode_opt.stroke_store import StrokeStore
from gcode_opt.strokes import K_ARC, K_CHAIN, K_CURVE, K_LINE

SAMPLES = "sample_gcode/"
ALL_KINDS = (K_LINE, K_ARC, K_CURVE, K_CHAIN)


def _digest(x):
    h = hashlib.blake2b(digest_size=12)
    h.update(np.ascontiguousarray(x).tobytes() if isinstance(x, np.ndarray) and x.dtype != object
             else repr(list(x)).encode())
    return h.hexdigest()


def seg_bits(p):
    """A segment plan's bits (None: None)."""
    if p is None:
        return None
    return (type(p).__name__, tuple(np.ascontiguousarray(a, float).tobytes() for a in (p.s, p.v, p.accel, p.feed)),
            float(p.time_t).hex(), float(p.int_a2).hex(), p.shape, repr(p.first_cmds))


def plan_bits(plan):
    out = {k: _digest(getattr(plan, k)) for k in ("T", "beta", "retime", "t_pred", "a2_pred")}
    out["reason"] = _digest(np.asarray(plan.reason, object))
    out["segs"] = [seg_bits(p) for p in plan.segs]
    return out


def runs(name, prof_name, window, stored=True):
    """The plan of the budget runs on the sample: the strokes a StoredStrokes of that
    window (plan_inputs and candidates by windows, as benchmarks/win52/runs.py), or a list
    (stored False; the candidates on the same windows' bounds)."""
    path = SAMPLES + name
    prof = load_profile(prof_name)
    opts = pl.Options(features=feat.default_selection(path)[0])
    store = None
    if not stored:
        strokes, sim0 = pl.analyse(path, prof, opts)
        pin = sc.plan_inputs(strokes, prof, opts)
    else:
        store = StrokeStore(in_memory=True)
        store, sim0 = pl.analyse(path, prof, opts, store)
        parts = []
        for lo in range(0, len(store), window):
            sts = store.load(lo, lo + window)
            parts.append(sc.plan_inputs(sts, prof, opts))
            store.rewrite(np.arange(lo, lo + len(sts), dtype=np.int64), sts)
        pin = join_plan_inputs(parts)
        strokes = StoredStrokes(store, window, on_load=curve_geometry(pin.plan_kind_codes, prof), keep=("chain_T",))
    rows = sc._rows_by_kind(strokes, sc._plan_kind_codes_of(strokes, pin))
    failed = sc._faults_of(pin.fault)
    bounds = list(range(0, len(strokes), window)) + [len(strokes)]
    cands, nonfinite = sc.candidates_in_windows(strokes, pin, prof, opts, rows, failed, bounds)
    for i in nonfinite:
        failed.setdefault(int(i), "error: planning (non-finite)")
    pin.cached = (cands, None, failed)
    if store is not None:
        strokes.on_load = None      # (the runs make a window's curve geometry as they segment it)
    plan = sc.plan_strokes(strokes, pin, prof, opts, opts.max_slowdown_r * sim0.time_t)
    if store is not None:
        # the lines' plans the runs let go (plans53) made again, every row at once
        sc.segs_for(plan, np.arange(len(strokes)), strokes)
        store.close()
    return plan


@pytest.fixture
def all_kinds(monkeypatch):
    monkeypatch.setattr(sc, "WINDOW_KINDS", ALL_KINDS)


_REF = {}


def _ref(name, prof_name, window):
    if (name, prof_name, window) not in _REF:
        _REF[name, prof_name, window] = plan_bits(runs(name, prof_name, window, stored=False))
    return _REF[name, prof_name, window]


@pytest.mark.parametrize("name,prof_name", [("prusa_gyroid_arcs.gcode", "prusa-mk3s"),
                                            ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"),
                                            ("prusa_benchy_like.gcode", "voron24")])
@pytest.mark.parametrize("window", [1, 37, 4096])
def test_windowed_runs_are_the_lists(name, prof_name, window, all_kinds):
    got = plan_bits(runs(name, prof_name, window))
    ref = _ref(name, prof_name, window)
    assert got["segs"] == ref["segs"]
    assert got == ref
    assert any(p is not None for p in got["segs"])          # (some strokes re-timed: plans compared)


def test_window_kinds_are_every_kind():
    """Every kind's rows are segmented a window at a time (each one's plans are its rows' own:
    test_speed52_runs52_rowown.py)."""
    assert set(sc.WINDOW_KINDS) == set(ALL_KINDS)


def test_by_windows_cuts_at_window_multiples():
    seen = []

    def fn(r):
        seen.append(r.tolist())
        return [i * 10 for i in r.tolist()]
    got = sc._by_windows(fn, 4)(np.array([0, 1, 3, 4, 9, 10, 11, 12, 30]))
    assert got == [0, 10, 30, 40, 90, 100, 110, 120, 300]
    assert seen == [[0, 1, 3], [4], [9, 10, 11], [12], [30]]
    assert sc._by_windows(fn, 4)(np.array([5])) == [50]
