"""summary.build_summary's per-stroke rows and by-kind sums (one loop on Python floats,
no cyclic GC inside it) and coverage's candidate moves by feature (one pass over the
strokes) against the ddecd40 code, kept here verbatim (ref_build_summary, ref_coverage):
on real runs (every row, every float's bits) and on those runs' inputs altered (numpy
scalars in the strokes, NaN / inf betas and figures, no re-timed stroke, GC off)."""
from __future__ import annotations

import gc
import math
import os
import random
from collections import Counter

import numpy as np
import pytest

from gcode_opt import summary as sm
from strokes_kept import _strokes_kept
from gcode_opt.pipeline import Options, process
from gcode_opt.profile import load_profile
from gcode_opt.summary import FAULT_PREFIXES, DWELL, NOT_CANDIDATE, _ratio, _share, count_lines, ringing_section

SAMPLES = "sample_gcode/"
CASES = [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24"),
         ("cura_box.gcode", "ender3"), ("prusa_gyroid_arcs.gcode", "prusa-mk3s")]


# ---------------------------------------------------------------- ddecd40, verbatim
def ref_coverage(strokes, pin, plan, sim0, sim1, idx, opts=None):
    """The whole-file headline (issue 9 item 5): what share of the original file's
    int|a|^2 dt and print time the re-timed strokes carried, what the whole file gained,
    and what was left as sliced, by reason -- each with its count and its share of the
    original's int|a|^2 dt and time (firmware model on the original).

    Candidates not re-timed are counted by plan.reason.  The moves outside every candidate
    stroke are what the original's totals leave after the candidates and the dwells: by
    feature when the analyse pass totalled the original by feature (opts.by_feature:
    feature -> [moves, time_t, int_a2] over every moving line), else as one bucket."""
    total_a2, total_t = float(sim0.int_a2), float(sim0.time_t)
    n = len(strokes)
    T0 = np.nan_to_num(np.asarray(pin.T_orig[:n], dtype=float), nan=0.0, posinf=0.0, neginf=0.0)
    I0 = np.nan_to_num(np.asarray(pin.I_orig[:n], dtype=float), nan=0.0, posinf=0.0, neginf=0.0)
    retimed = np.zeros(n, dtype=bool)
    retimed[np.asarray(idx, dtype=int)] = True
    left = {}

    def add(reason, count, unit, a2, t):
        g = left.setdefault(reason, {"count": 0, "unit": unit, "int_a2": 0.0, "time_s": 0.0})
        g["count"] += int(count)
        g["int_a2"] += float(a2)
        g["time_s"] += float(t)

    reasons = np.array([str(r) for r in plan.reason[:n]], dtype=object)
    for r in sorted(set(reasons[~retimed])):
        m = (reasons == r) & ~retimed
        add(r or "not planned", m.sum(), "strokes", I0[m].sum(), T0[m].sum())
    dwell_t = float(getattr(sim0, "barrier_dwell_t", 0.0) or 0.0)
    by_feature = getattr(opts, "by_feature", None)
    if by_feature:
        selected = set(getattr(opts, "features", ()) or ())
        feats = np.array([s.feature for s in strokes], dtype=object)
        for f, (moves, t, a2) in sorted(by_feature.items()):
            m = feats == f                                        # candidates of this feature
            moves -= sum(s.n_moves for s, k in zip(strokes, m) if k)
            t, a2 = t - float(T0[m].sum()), a2 - float(I0[m].sum())
            if moves <= 0 and t <= 1e-9 * total_t:
                continue
            why = (f"feature not selected: {f}" if f not in selected else
                   f"{f}: selected, in no stroke (shorter than --min-length, sharp corners, not re-timable)")
            add(why, max(moves, 0), "moves", max(a2, 0.0), max(t, 0.0))
    else:
        rest_a2 = max(total_a2 - float(I0.sum()), 0.0)
        rest_t = max(total_t - float(T0.sum()) - dwell_t, 0.0)
        if rest_a2 > 0.0 or rest_t > 0.0:
            add(NOT_CANDIDATE, 0, "moves", rest_a2, rest_t)
    if dwell_t > 0.0:
        add(DWELL, 0, "", 0.0, dwell_t)
    for g in left.values():
        g["int_a2_share"] = _share(g["int_a2"], total_a2)
        g["time_share"] = _share(g["time_s"], total_t)
    left = dict(sorted(left.items(), key=lambda kv: (-(kv[1]["int_a2_share"] or 0.0), -(kv[1]["time_share"] or 0.0))))
    a2_in, t_in = float(I0[retimed].sum()), float(T0[retimed].sum())
    return {
        "int_a2_before": total_a2, "time_s_before": total_t,
        "retimed": {"strokes": int(retimed.sum()), "int_a2_share": _share(a2_in, total_a2),
                    "time_share": _share(t_in, total_t)},
        "whole_file": {"int_a2_change": _ratio(float(sim1.int_a2), total_a2),
                       "time_change": _ratio(float(sim1.time_t), total_t)},
        "left": left,
    }


def ref_build_summary(in_path, out_path, written_path, size_before, profile, opts, strokes, pin, plan, sim0, sim1,
                  out_ranges, t_after, a2_after, v2_after, elapsed_t, ringing=None):
    """ringing: None, or (before, after) ringing figure dicts (the firmware-model passes over
    the original and the written file fed ringing.Collector): the summary's "ringing" key."""
    idx = np.array([r[2] for r in out_ranges], dtype=int)
    T0 = pin.T_orig[idx] if len(idx) else np.zeros(0)
    I0 = pin.I_orig[idx] if len(idx) else np.zeros(0)
    V0 = np.array([strokes[i].int_v2 for i in idx]) if len(idx) else np.zeros(0)
    per_stroke = []
    for k, i in enumerate(idx):
        s = strokes[i]
        per_stroke.append({
            "line": s.first_idx + 1, "lines": s.n_moves, "kind": getattr(s, "kind", "line"), "out_line": out_ranges[k][0] + 1,
            "feature": s.feature, "layer": s.layer, "length_mm": round(s.length_d, 4),
            "v0_mm_s": round(s.v0, 3), "v1_mm_s": round(s.v1, 3), "feed_mm_s": round(s.v_feed, 3),
            "time_s": {"before": T0[k], "law": float(plan.T[i]), "after": float(t_after[k])},
            "int_a2": {"before": I0[k], "law": float(plan.I_law[i]), "after": float(a2_after[k])},
            "beta_s2": None if not np.isfinite(plan.beta[i]) else float(plan.beta[i]),
        })
    by_kind = {}
    for k, i in enumerate(idx):
        kind = getattr(strokes[i], "kind", "line")
        g = by_kind.setdefault(kind, {"retimed": 0, "time_s": {"before": 0.0, "law": 0.0, "after": 0.0},
                                      "int_a2": {"before": 0.0, "law": 0.0, "after": 0.0}})
        g["retimed"] += 1
        for key, vals in (("time_s", (T0[k], plan.T[i], t_after[k])), ("int_a2", (I0[k], plan.I_law[i], a2_after[k]))):
            for name, v in zip(("before", "law", "after"), vals):
                g[key][name] += float(v)
    for g in by_kind.values():
        g["int_a2"]["change"] = _ratio(g["int_a2"]["after"], g["int_a2"]["before"])
        g["time_s"]["change"] = _ratio(g["time_s"]["after"], g["time_s"]["before"])
    reasons = Counter(str(r) for r in plan.reason)
    law_T = float(plan.T[idx].sum()) if len(idx) else 0.0
    law_I = float(plan.I_law[idx].sum()) if len(idx) else 0.0
    lines_before = count_lines(in_path)
    lines_after = count_lines(written_path)
    size_after = os.path.getsize(written_path)
    out = {
        "input": in_path, "output": out_path, "profile": profile.name, "flavour": profile.flavour,
        "options": {"alpha": opts.alpha, "features": list(opts.features), "overshoot": opts.overshoot_r,
                    "max_slowdown": opts.max_slowdown_r, "max_segments": opts.max_segments},
        "strokes": {"candidates": len(strokes), "retimed": int(len(idx)),
                    "not_retimed": {k: v for k, v in reasons.items() if k != "retimed"},
                    # the part of not_retimed that is a fault kept out of the file (planning,
                    # segments or emission raised, a non-finite number, the validator refused)
                    "faults": sum(v for k, v in reasons.items() if k.startswith(FAULT_PREFIXES))},
        "print_time_s": {"before": sim0.time_t, "after": sim1.time_t,
                         "change": _ratio(sim1.time_t, sim0.time_t)},
        "retimed_strokes": {
            "time_s": {"before": float(T0.sum()), "law": law_T, "after": float(t_after.sum())},
            "int_a2": {"before": float(I0.sum()), "law": law_I, "after": float(a2_after.sum()),
                       "change": _ratio(float(a2_after.sum()), float(I0.sum()))},
            "int_v2": {"before": float(V0.sum()), "after": float(v2_after.sum())},
            "firmware_vs_law": {"time": _ratio(float(t_after.sum()), law_T),
                                "int_a2": _ratio(float(a2_after.sum()), law_I)},
            "by_kind": by_kind,
        },
        # the headline: share of the file re-timed, the whole file's change, what was left and why
        "coverage": ref_coverage(strokes, pin, plan, sim0, sim1, idx, opts),
        "whole_file": {"before": sim0.as_dict(), "after": sim1.as_dict(),
                       "int_a2_change": _ratio(sim1.int_a2, sim0.int_a2),
                       "corner_dv2_change": _ratio(sim1.corner_dv2, sim0.corner_dv2)},
        "file": {"bytes_before": size_before, "bytes_after": size_after, "lines_before": lines_before,
                 "lines_after": lines_after},
        "elapsed_s": elapsed_t,
        # where the feature labels came from (the file's comments, or none: see features.selection_info)
        "features": getattr(opts, "feature_info", None),
        "per_stroke": per_stroke,
    }
    if ringing is not None:                        # ahead of the long per-stroke list
        out["ringing"] = ringing_section(*ringing)
        out["per_stroke"] = out.pop("per_stroke")
    return out


# ---------------------------------------------------------------- the comparison
def same(a, b, where="summary"):
    """Equal values of equal kinds; floats (numpy's or Python's) bit for bit."""
    if isinstance(a, float) or isinstance(b, float):
        assert isinstance(a, float) and isinstance(b, float), (where, a, b)
        assert np.float64(a).tobytes() == np.float64(b).tobytes(), (where, a, b)
    elif isinstance(a, dict):
        assert isinstance(b, dict) and list(a) == list(b), (where, list(a), list(b))
        for k in a:
            same(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, (list, tuple)):
        assert type(a) is type(b) and len(a) == len(b), (where, len(a), len(b))
        for k, (x, y) in enumerate(zip(a, b)):
            same(x, y, f"{where}[{k}]")
    else:
        assert type(a) is type(b) and a == b, (where, a, b)


def both(args):
    args = list(args)
    want = ref_build_summary(*args, ringing=None)
    got = sm.build_summary(*args, ringing=None)
    for d in (want, got):
        d.pop("elapsed_s")
    same(got, want)
    return got


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """build_summary's arguments of real runs (the written file kept beside)."""
    d = tmp_path_factory.mktemp("sum")
    got = {}
    keep = sm.build_summary

    for name, prof in CASES:
        cap = []

        def spy(*a, **k):
            cap.append(a)
            return keep(*a, **k)
        sm.build_summary = spy
        try:
            dst = str(d / name)
            with _strokes_kept() as strokes:
                process(SAMPLES + name, dst, load_profile(prof), Options())
        finally:
            sm.build_summary = keep
        a = list(cap[0])
        a[2] = dst                       # the temporary file is the output now
        a[6] = strokes[0]                # the strokes (the run hands build_summary their StrokeColumns)
        got[name] = a
    return got


@pytest.mark.parametrize("name", [c[0] for c in CASES])
def test_real_runs(runs, name):
    out = both(runs[name])
    assert out["strokes"]["retimed"] > 10
    assert out["coverage"]["left"]


def _altered(args, rng):
    """The run's inputs with other values where the new code takes another path: numpy
    scalars and odd floats in the strokes, NaN and inf in the plan and the figures."""
    import copy
    a = list(args)
    strokes = [copy.copy(s) for s in a[6]]
    for s in strokes:
        r = rng.random()
        if r < 0.2:
            s.length_d, s.v0, s.v1, s.v_feed = (np.float64(x) for x in (s.length_d, s.v0, s.v1, s.v_feed))
        elif r < 0.3:
            s.length_d = s.length_d * (1.0 + rng.choice([1e-16, -1e-16, 0.5e-4]))
            s.v0 = rng.choice([0.0, -0.0, 1e-300, 0.0005, 0.0015, 2.5e-3, math.inf, 1e300])
        if rng.random() < 0.1:
            s.feature = rng.choice([None, "perimeter", "travel", "gyroid"])
    a[6] = strokes
    pin, plan = copy.copy(a[7]), copy.copy(a[8])
    for obj, names in ((pin, ("T_orig", "I_orig")), (plan, ("T", "I_law", "beta"))):
        for nm in names:
            v = np.array(getattr(obj, nm), float)
            m = np.array([rng.random() < 0.05 for _ in range(len(v))])
            v[m] = np.array([rng.choice([np.nan, np.inf, -np.inf, 0.0, -0.0, 5e-324, 1e308]) for _ in range(m.sum())])
            setattr(obj, nm, v)
    a[7], a[8] = pin, plan
    for j in (12, 13, 14):
        v = np.array(a[j], float)
        v[rng.randrange(len(v))] = rng.choice([np.nan, np.inf, -0.0])
        a[j] = v
    return a


@pytest.mark.parametrize("seed", range(6))
def test_altered_inputs(runs, seed):
    rng = random.Random(seed)
    name = CASES[seed % len(CASES)][0]
    both(_altered(runs[name], rng))


def test_no_retimed_stroke_and_gc_state(runs):
    a = list(runs["prusa_gyroid.gcode"])
    n = 0
    a[11] = a[11][:n]
    a[12], a[13], a[14] = a[12][:n], a[13][:n], a[14][:n]
    assert both(a)["per_stroke"] == []
    # the loop turns the cyclic GC off and back on; off it stays off
    b = list(runs["cura_box.gcode"])
    assert gc.isenabled()
    both(b)
    assert gc.isenabled()
    gc.disable()
    try:
        both(b)
        assert not gc.isenabled()
    finally:
        gc.enable()


def test_some_rows_only(runs):
    """A subset of the re-timed strokes, out of file order (the rows follow out_ranges)."""
    a = list(runs["prusa_klipper.gcode"])
    rng = random.Random(5)
    keep = sorted(rng.sample(range(len(a[11])), len(a[11]) // 2))
    rng.shuffle(keep)
    a[11] = [a[11][k] for k in keep]
    a[12], a[13], a[14] = (np.asarray(a[j])[keep] for j in (12, 13, 14))
    both(a)
