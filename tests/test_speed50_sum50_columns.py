"""The steps after planning read the strokes' compact columns (stroke_columns.StrokeColumns,
issue 8, session 50), not the stroke objects:

- the columns against getattr over the strokes, on real files (values and their types);
  the fallback reads (objects not StrokeBase, a value not a float, a stroke without kind);
- build_summary on the columns against the a0c8d7a code that read the strokes (kept here
  verbatim, the functions renamed ref_*): the same summary, floats bit for bit, on real
  runs and on altered strokes;
- stroke_lines / _stroke_lines_loop / _first_line_order on the columns against the a0c8d7a
  loop (verbatim: ref_stroke_lines_loop) on the strokes.
Same bits: nothing is compared to a tolerance."""
from __future__ import annotations

import copy
import gc
import math
import os
import random
import struct
from itertools import compress
from operator import attrgetter
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import objfields
from gcode_opt import pipeline as pl
from gcode_opt import summary as sm
from gcode_opt.distinct import value_codes
from gcode_opt.outranges import columns as range_columns
from gcode_opt.pipeline import Options, analyse, plan_inputs
from gcode_opt.profile import load_profile
from gcode_opt.stroke_columns import FLOATS, CODED, StrokeColumns
from gcode_opt.strokes import Stroke, line_spans
from gcode_opt.summary import (DWELL, FAULT_PREFIXES, NOT_CANDIDATE, _as_list, _by_kind_rows, _ratio, _reason_codes,
                               _reason_counts, _share, count_lines, ringing_section, round_list)
from strokes_kept import _strokes_kept

SAMPLES = Path(__file__).resolve().parents[1] / "sample_gcode"
CORPUS = Path.home() / ".cache" / "gcode-opt-corpus"
CASES = [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"),
         ("prusa_concentric_arcs.gcode", "voron24"), ("prusa_klipper.gcode", "voron24")]

_STROKE_ONLY = {Stroke}
_KIND = attrgetter("kind")
_INF = math.inf


# ---------------------------------------------------------------- a0c8d7a's code, verbatim (renamed ref_*)
def ref_coverage(strokes, pin, plan, sim0, sim1, idx, opts=None, reason_codes=None):
    """The whole-file headline (issue 9 item 5): what share of the original file's
    int|a|^2 dt and print time the re-timed strokes carried, what the whole file gained,
    and what was left as sliced, by reason -- each with its count and its share of the
    original's int|a|^2 dt and time (firmware model on the original).

    Candidates not re-timed are counted by plan.reason.  The moves outside every candidate
    stroke are what the original's totals leave after the candidates and the dwells: by
    feature when the analyse pass totalled the original by feature (opts.by_feature:
    feature -> [moves, time_t, int_a2] over every moving line), else as one bucket.

    reason_codes: _reason_codes(plan.reason) where the caller has them (build_summary)."""
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

    # each reason's strokes left as sliced: the re-timed ones coded past every reason
    if reason_codes is None:
        reason_codes = _reason_codes(plan.reason[:n])
    # (codes past n, if any, and their reasons' keys drop out: counted 0 below)
    code_of, code = reason_codes[0], reason_codes[1][:n].copy()
    code[retimed] = len(code_of)
    left_reasons = compress(code_of, (np.bincount(code, minlength=len(code_of) + 1)[:-1] > 0).tolist())
    for r in sorted(left_reasons):
        m = code == code_of[r]
        add(r or "not planned", m.sum(), "strokes", I0[m].sum(), T0[m].sum())
    dwell_t = float(getattr(sim0, "barrier_dwell_t", 0.0) or 0.0)
    by_feature = getattr(opts, "by_feature", None)
    if by_feature:
        selected = set(getattr(opts, "features", ()) or ())
        feat_code_of, feat_code = ref_feature_codes(strokes)
        nm = ref_n_moves(strokes)                                    # the candidates' moves
        for f, (moves, t, a2) in sorted(by_feature.items()):
            m = feat_code == feat_code_of.get(f, -1)              # candidates of this feature
            moves -= int(nm[m].sum())                             # (integers: the loop's sum)
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


def ref_feature_codes(strokes):
    """value_codes(list(map(attrgetter("feature"), strokes))): the features read and coded
    in one compiled pass where it can (a list of strokes), not a list of them made first."""
    code_of = {}
    code = objfields.codes(strokes, "feature", code_of, add=True)
    if code is not None:
        return code_of, code
    return value_codes(list(map(attrgetter("feature"), strokes)))


def ref_build_summary(in_path, out_path, written_path, size_before, profile, opts, strokes, pin, plan, sim0, sim1,
                  out_ranges, t_after, a2_after, v2_after, elapsed_t, ringing=None):
    """ringing: None, or (before, after) ringing figure dicts (the firmware-model passes over
    the original and the written file fed ringing.Collector): the summary's "ringing" key."""
    out_first, _, idx = range_columns(out_ranges)
    idx_list = idx.tolist()
    T0 = pin.T_orig[idx] if len(idx) else np.zeros(0)
    I0 = pin.I_orig[idx] if len(idx) else np.zeros(0)
    V0 = objfields.float_col(list(map(strokes.__getitem__, idx_list)), "int_v2")     # (one compiled pass)
    if V0 is None:
        V0 = np.fromiter(map(attrgetter("int_v2"), map(strokes.__getitem__, idx_list)), float, len(idx_list))
    # the per-stroke rows only where something reads them (Options.summary_rows: the command
    # line asks for them with --json or --report; its text summary has none)
    per_stroke = [] if getattr(opts, "summary_rows", True) else None
    by_kind = {}
    gc_was = gc.isenabled()
    gc.disable()              # ~70 k new dicts, none in a cycle: no collection passes over the live heap
    try:
        ref_per_stroke_rows(idx_list, out_first, T0, I0, plan.T[idx], plan.I_law[idx], np.asarray(t_after),
                         np.asarray(a2_after), plan.beta[idx], strokes, per_stroke, by_kind)
    finally:
        if gc_was:
            gc.enable()
    for g in by_kind.values():
        g["int_a2"]["change"] = _ratio(g["int_a2"]["after"], g["int_a2"]["before"])
        g["time_s"]["change"] = _ratio(g["time_s"]["after"], g["time_s"]["before"])
    reason_codes = _reason_codes(plan.reason)
    reasons = _reason_counts(reason_codes)
    law_T = float(plan.T[idx].sum()) if len(idx) else 0.0
    law_I = float(plan.I_law[idx].sum()) if len(idx) else 0.0
    # the passes' counts where they made them (analyse's, the last full measure's): the same
    # numbers without reading both files again
    lines_before = getattr(opts, "lines_in", None)
    if lines_before is None:
        lines_before = count_lines(in_path)
    lines_after = getattr(opts, "lines_out", None)
    if lines_after is None:
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
        "coverage": ref_coverage(strokes, pin, plan, sim0, sim1, idx, opts, reason_codes),
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
    if per_stroke is None:
        del out["per_stroke"]
    if ringing is not None:                        # ahead of the long per-stroke list
        out["ringing"] = ringing_section(*ringing)
        if per_stroke is not None:
            out["per_stroke"] = out.pop("per_stroke")
    return out


def ref_n_moves(strokes):
    """Every stroke's n_moves, an int64 array (Stroke's from its lines in rows; another
    kind of stroke: its own n_moves)."""
    n = len(strokes)
    if n and set(map(type, strokes)) == _STROKE_ONLY:       # (the type test in C: ~35 k strokes)
        lo, hi = line_spans(strokes)
        return hi - lo + 1
    return np.fromiter((s.n_moves for s in strokes), np.int64, n)


def ref_kind_of(s):
    return getattr(s, "kind", "line")


def ref_kinds_of(ss):
    """[ref_kind_of(s) for s in ss]: read by attrgetter in C where every one has a kind (a
    Python call a stroke was ~6 M instructions on the rectilinear plate)."""
    try:
        return list(map(_KIND, ss))
    except AttributeError:
        return list(map(ref_kind_of, ss))


def ref_per_stroke_rows(idx, out_first, t0, i0, t_law, i_law, t1, a21, beta, strokes, per_stroke, by_kind):
    """build_summary's per-stroke rows (appended to per_stroke; per_stroke None: the by_kind
    sums alone) and by_kind sums, in the order of idx (columns by row: lists, or arrays,
    whose rows are built on Python floats (tolist: the arrays' values) rather than numpy
    scalars: the same numbers, the same sums in the same order)."""
    ss = list(map(strokes.__getitem__, idx))
    kinds = ref_kinds_of(ss)
    if per_stroke is not None:
        ref_rows(ss, kinds, *map(_as_list, (out_first, t0, i0, t_law, i_law, t1, a21, beta)), per_stroke)
    _by_kind_rows(kinds, (t0, t_law, t1, i0, i_law, a21), by_kind)


def ref_rows(ss, kinds, out_first, t0, i0, t_law, i_law, t1, a21, beta, per_stroke):
    """The per-stroke rows: each column made in one pass (map: the same round() of each
    value), then the rows zip them."""
    get = attrgetter
    r4 = round_list(list(map(get("length_d"), ss)), 4)
    rv0 = round_list(list(map(get("v0"), ss)), 3)
    rv1 = round_list(list(map(get("v1"), ss)), 3)
    rvf = round_list(list(map(get("v_feed"), ss)), 3)
    n_moves = ref_n_moves(ss).tolist()
    per_stroke.extend([
        {"line": s.first_idx + 1, "lines": nm, "kind": kind, "out_line": of + 1,
         "feature": s.feature, "layer": s.layer, "length_mm": ln,
         "v0_mm_s": a, "v1_mm_s": b, "feed_mm_s": f,
         "time_s": {"before": x0, "law": xl, "after": x1},
         "int_a2": {"before": y0, "law": yl, "after": y1},
         "beta_s2": be if -_INF < be < _INF else None}     # (math.isfinite: NaN and +-inf are None)
        for s, nm, kind, of, ln, a, b, f, x0, xl, x1, y0, yl, y1, be
        in zip(ss, n_moves, kinds, out_first, r4, rv0, rv1, rvf, t0, t_law, t1, i0, i_law, a21, beta)])


def ref_stroke_lines_loop(strokes, order, out_ranges):
    """stroke_lines stroke by stroke (the code before the rows; the tests' reference)."""
    n = len(strokes)
    first, last = np.zeros(n, np.int64), np.zeros(n, np.int64)
    block = {i: (a, z) for a, z, i in out_ranges}
    off = 0                   # output line - input line, between blocks
    prev_last = -1
    for i in order:
        s = strokes[i]
        r = block.get(i)
        if r is None:
            a, z = s.first_idx + off, s.last_idx + off
        else:
            a, z = r
            if a != s.first_idx + off:
                return None
            off += (z - a) - (s.last_idx - s.first_idx)
        if a <= prev_last or z < a:
            return None
        first[i], last[i], prev_last = a, z, z
    return first, last


# ---------------------------------------------------------------- helpers
def _bits(x):
    """x with every float as its bytes and every leaf's type kept: equal only bit for bit."""
    if isinstance(x, float):
        return ("f", type(x).__name__, struct.pack("<d", x))
    if isinstance(x, dict):
        return {k: _bits(v) for k, v in x.items()}, list(x)
    if isinstance(x, (list, tuple)):
        return [_bits(v) for v in x]
    return (type(x).__name__, x)


def _planned(name, prof):
    """The strokes of a file as planning leaves them (plan_inputs lowers v0 / v1)."""
    p = load_profile(prof)
    opts = Options()
    strokes, _ = analyse(str(name), p, opts)
    plan_inputs(strokes, p, opts)
    return strokes


def _check_columns(strokes, cols):
    n = len(strokes)
    rows = np.arange(n, dtype=np.intp)
    assert len(cols) == n
    assert cols.first_idx.tolist() == [s.first_idx for s in strokes]
    assert cols.last_idx.tolist() == [s.last_idx for s in strokes]
    assert cols.n_moves.tolist() == [s.n_moves for s in strokes]
    for name in FLOATS:
        assert _bits(cols.float_values(name, rows)) == _bits([getattr(s, name) for s in strokes]), name
        assert cols.float_array(name, rows).tobytes() == np.array([getattr(s, name) for s in strokes],
                                                                  float).tobytes(), name
    for name in CODED:
        want = [getattr(s, name, "line") if name == "kind" else getattr(s, name) for s in strokes]
        assert _bits(cols.values(name, rows)) == _bits(want), name
    # a few rows out of order, and none
    some = np.array(random.Random(n).sample(range(n), min(n, 50)), np.intp)
    for name in FLOATS:
        assert _bits(cols.float_values(name, some)) == _bits([getattr(strokes[i], name) for i in some.tolist()])
    assert cols.values("feature", some[:0]) == [] and cols.float_values("v0", some[:0]) == []


# ---------------------------------------------------------------- the columns
@pytest.mark.parametrize("name,prof", CASES)
def test_columns_against_the_strokes(name, prof):
    strokes = _planned(SAMPLES / name, prof)
    assert len(strokes) > 100
    cols = StrokeColumns(strokes)
    assert all(isinstance(c, np.ndarray) for c in cols.floats.values())    # the compiled reads, where built
    _check_columns(strokes, cols)


@pytest.mark.skipif(not (CORPUS / "plate_rectilinear.gcode").exists(), reason="corpus plate not here")
def test_columns_on_the_rectilinear_plate():
    strokes = _planned(CORPUS / "plate_rectilinear.gcode", "prusa-mk3s")
    assert len(strokes) > 50000
    _check_columns(strokes, StrokeColumns(strokes))


class _Odd:
    """A stroke that is not a StrokeBase: the columns' Python reads."""

    def __init__(self, rng, i):
        self.first_idx = 3 * i
        self.last_idx = 3 * i + rng.randrange(3)
        self.n_moves = self.last_idx - self.first_idx + 1
        for f in FLOATS:
            setattr(self, f, rng.uniform(0.0, 90.0))
        self.feature, self.layer = rng.choice(("perimeter", "gap_fill", None)), rng.choice((1, 2, None))
        if rng.random() < 0.7:
            self.kind = rng.choice(("line", "curve", "arc"))


def test_columns_of_odd_strokes():
    rng = random.Random(50)
    ss = [_Odd(rng, i) for i in range(300)]
    _check_columns(ss, StrokeColumns(ss))                       # (a stroke without kind: "line")
    for s in ss[::7]:
        s.v0, s.v_feed, s.length_d = np.float64(s.v0), 7, None
    cols = StrokeColumns(ss)
    assert isinstance(cols.floats["v0"], list) and isinstance(cols.floats["v1"], np.ndarray)
    rows = np.arange(len(ss), dtype=np.intp)
    for f in ("v0", "v_feed", "length_d"):
        assert _bits(cols.float_values(f, rows)) == _bits([getattr(s, f) for s in ss])
    # the real strokes, some values not a float (kept as objects by StrokeBase), a field at a
    # time: None, a bool (an object field: the core's kinds 1, 2), an int, an np.float64
    strokes = [copy.copy(s) for s in _planned(SAMPLES / "prusa_gyroid.gcode", "prusa-mk3s")]
    for value in (None, True, 7, np.float64(2.5)):
        ss = [copy.copy(s) for s in strokes]
        for s in ss[3::13]:
            s.v_feed = value
        for s in ss[4::11]:
            s.v1 = 7 if value is None else value
        _check_columns(ss, StrokeColumns(ss))
    assert StrokeColumns.of(strokes).n == len(strokes) and StrokeColumns.of(cols) is cols
    _check_columns([], StrokeColumns([]))


# ---------------------------------------------------------------- the summary
@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """build_summary's arguments of real runs (the written file kept beside), with the
    run's strokes: args[6] the columns the run made, strokes the list."""
    d = tmp_path_factory.mktemp("sum50")
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
                pl.process(str(SAMPLES / name), dst, load_profile(prof), Options())
        finally:
            sm.build_summary = keep
        a = list(cap[0])
        a[2] = dst                       # the temporary file is the output now
        got[name] = (a, strokes[0])
    return got


def _same_summaries(args, strokes, opts=None):
    args = list(args)
    if opts is not None:
        args[5] = opts
    want = ref_build_summary(*args[:6], strokes, *args[7:], ringing=None)
    got = sm.build_summary(*args, ringing=None)
    for d in (want, got):
        d.pop("elapsed_s")
    assert _bits(got) == _bits(want)
    return got


@pytest.mark.parametrize("name", [c[0] for c in CASES])
def test_summary_on_the_columns_is_the_old_one(runs, name):
    args, strokes = runs[name]
    assert isinstance(args[6], StrokeColumns)
    _check_columns(strokes, args[6])                          # the run's columns: the strokes' final values
    got = _same_summaries(args, strokes)
    assert got["strokes"]["retimed"] > 10 and len(got["per_stroke"]) == got["strokes"]["retimed"]
    assert got["coverage"]["left"]
    opts = copy.copy(args[5])                                 # without the rows, without by_feature
    opts.summary_rows, opts.by_feature = False, None
    _same_summaries(args, strokes, opts)


@pytest.mark.parametrize("seed", range(3))
def test_summary_on_altered_strokes(runs, seed):
    """numpy scalars, ints and odd floats in the strokes, kinds changed: the columns keep
    the objects (the lists' path), the same summary."""
    rng = random.Random(seed)
    args, strokes = runs["prusa_gyroid.gcode"]
    strokes = [copy.copy(s) for s in strokes]
    for s in strokes:
        r = rng.random()
        if r < 0.2:
            s.length_d, s.v0, s.v1, s.v_feed = (np.float64(x) for x in (s.length_d, s.v0, s.v1, s.v_feed))
        elif r < 0.3:
            s.v0 = rng.choice([0.0, -0.0, 1e-300, 0.0005, 0.0015, 2.5e-3, math.inf, 1e300, 7])
        elif r < 0.35:
            s.kind = rng.choice(["arc", "curve", "chain"])
        elif r < 0.4:
            s.feature = rng.choice(["perimeter", "x", None])
    args = list(args)
    args[6] = StrokeColumns(strokes)
    _same_summaries(args, strokes)


# ---------------------------------------------------------------- the output lines
@pytest.mark.parametrize("n", [1, 7, 40])
def test_stroke_lines_on_columns_random(n):
    """The loop and the rows on the columns against the old loop on the strokes (inputs
    broken now and then: test_speed24_front_rows' cases)."""
    from test_speed24_front_rows import _random_case, _same_lines
    rng = random.Random(n)
    seen = set()
    for _ in range(800):
        strokes, order, out_ranges = _random_case(rng, rng.randrange(1, n + 1))
        want = ref_stroke_lines_loop(strokes, order, out_ranges)
        cols = StrokeColumns([_full(s) for s in strokes])
        for x in (strokes, cols):
            assert _same_lines(pl._stroke_lines_loop(x, order, out_ranges), want)
            assert _same_lines(pl.stroke_lines(x, order, out_ranges), want)
        seen.add(want is None)
    assert seen == {True, False}


def _full(s):
    """A stroke of s's lines with every field the columns read."""
    o = _Odd(random.Random(s.first_idx), 0)
    o.first_idx, o.last_idx, o.n_moves = s.first_idx, s.last_idx, s.last_idx - s.first_idx + 1
    return o


def test_order_and_lines_of_a_real_run(runs):
    args, strokes = runs["prusa_mk3s_rectilinear.gcode"]
    cols, out_ranges = args[6], args[11]
    order = pl._first_line_order(cols)
    assert order == pl._first_line_order(strokes)
    want = ref_stroke_lines_loop(strokes, order, out_ranges)
    assert want is not None
    for f in (pl.stroke_lines, pl._stroke_lines_loop):
        got = f(cols, order, out_ranges)
        assert all(np.array_equal(g, w) and g.dtype == w.dtype for g, w in zip(got, want))


# ---------------------------------------------------------------- the strokes let go
def test_no_stroke_alive_at_the_summary(tmp_path, monkeypatch):
    """The summary reads the columns: _process lets the strokes go before it (with
    --json the summary's rows were the run's peak, the strokes still held)."""
    def n_strokes():
        gc.unfreeze()                  # (the strokes were frozen: get_objects does not list those)
        return sum(isinstance(o, Stroke) for o in gc.get_objects())
    alive, before = [], n_strokes()    # (other tests' fixtures may hold strokes)
    keep = sm.build_summary

    def spy(*a, **k):
        alive.append(n_strokes() - before)
        return keep(*a, **k)
    monkeypatch.setattr(sm, "build_summary", spy)
    s = pl.process(str(SAMPLES / "prusa_gyroid.gcode"), str(tmp_path / "out.gcode"), load_profile("prusa-mk3s"),
                   Options())
    # (one stroke, by an untracked reference: the analyse pass's last, seen on this sample)
    assert s["strokes"]["candidates"] > 100 and len(alive) == 1 and alive[0] <= 1
