"""The report's figures, from the firmware model playing the original and the processed file.

``build_report(orig_path, new_path, profile, summary=None)`` returns ``(data, ctx)``:
``data`` is the JSON-ready dict (keys documented in the README, schema "gcode-opt-report/1"),
``ctx`` keeps the two traces and the fences for the plots.  Everything is re-derived from the
two files on disk (fences pair each re-timed block with the original lines it replaced); the
pipeline's summary, when given, only adds what the files cannot tell (candidates, reasons a
stroke was skipped, the law's own time and int a^2, the options).

Units: mm, s; int_a2 in mm^2/s^3, int_v2 in mm^2/s; energies in J*s (kg m^2/s).
"""
from __future__ import annotations

import math
from collections import defaultdict

import numpy as np

from .. import state as st
from .fences import parse_fences
from .stroke_table import StrokeTable
from .trace import count_lines, disjoint_spans, trace_fences, trace_file

SCHEMA = "gcode-opt-report/1"
MM2_TO_M2 = 1e-6
DEFAULT_BUDGET_R = 0.03          # the CLI's default --max-slowdown, used when no summary says otherwise
SEGMENT_RATE_WARN_R = 0.8        # warn at this fraction of the profile's max_segment_rate
OVERSHOOT_EPS_R = 1e-3           # speed above F by less than this is rounding
CURVE_MAX_TURN_DEG = 30.0        # polyline vertices turning less than this belong to one curve
CURVE_MIN_MOVES = 6
CURVE_MIN_LENGTH_D = 5.0


def ratio(after, before):
    """after/before - 1, None when before is 0 or missing."""
    if before is None or after is None or not before:
        return None
    return after / before - 1.0


def bac(before, after, **extra):
    d = {"before": before, "after": after, "change": ratio(after, before)}
    d.update(extra)
    return d


def mass_kg(profile, ux, uy):
    return profile.moving_mass_x_kg * ux * ux + profile.moving_mass_y_kg * uy * uy


def _finite(x):
    return x is not None and isinstance(x, (int, float)) and math.isfinite(x)


class Context:
    """What the plots need beyond the JSON: both traces, the fences, the summary."""

    def __init__(self, tr0, tr1, fences, summary, profile):
        self.tr0, self.tr1, self.fences, self.summary, self.profile = tr0, tr1, fences, summary, profile
        # original line -> output line for lines outside fences
        self._starts = np.array([f.orig_first for f in fences], dtype=int)
        self._shift = np.cumsum([0] + [(f.out_last - f.out_first + 1) - f.n_orig for f in fences])

    def out_line_of(self, orig_idx):
        """0-based output line of an original line that no fence replaced."""
        k = int(np.searchsorted(self._starts, orig_idx, side="right"))
        return orig_idx + int(self._shift[k])


# --------------------------------------------------------------------------- per stroke
KINDS = ("line", "curve", "arc")
STRAIGHT_COS = 0.99999            # consecutive moves closer than this in direction are one straight line


def stroke_kind(fence, summary_row, tr0):
    """line | curve | arc, as the pipeline classified the stroke: the block header's kind=
    (written by the pipeline), else the summary's, else from the original moves (an arc move;
    a run whose direction turns is a curve; a straight run is a line)."""
    for k in (fence.kind, (summary_row or {}).get("kind")):
        if k in KINDS:
            return k
    o0, o1 = fence.orig_first, fence.orig_last
    moves = [tr0.moves[i] for i in range(o0, o1 + 1) if i in tr0.moves]
    if any(m.kind == st.ARC for m in moves):
        return "arc"
    dirs = []
    for m in moves:
        d = math.hypot(m.x1 - m.x0, m.y1 - m.y0)
        if d > 0:
            dirs.append(((m.x1 - m.x0) / d, (m.y1 - m.y0) / d))
    turns = any(a[0] * b[0] + a[1] * b[1] < STRAIGHT_COS for a, b in zip(dirs, dirs[1:]))
    return "curve" if turns else "line"


def _summary_row_at(summary):
    """line -> the summary's per_stroke row of the stroke starting there (or None): a
    StrokeRows (the command line's --report) looked up in its columns, a row made a call;
    a list of rows by a dict (of several on one line, the last)."""
    rows = (summary or {}).get("per_stroke", [])
    if hasattr(rows, "row_at_line"):
        return rows.row_at_line
    return {p["line"]: p for p in rows}.get


class StrokeHeads:
    """What the stroke rows take of the original file alone, known before the processed file
    is played: each fence's kind, length (mm), layer and int a^2 before (mm^2/s^3)."""

    def __init__(self, tr0, fences, summary):
        row_at = _summary_row_at(summary)
        self.kinds, self.lengths, self.layers, self.a2_before = [], [], [], []
        for f in fences:
            o0, o1 = f.orig_first, f.orig_last
            mv = tr0.moves
            m0 = mv.get(o0)
            self.lengths.append(sum(map(mv.length_at, mv.rows_of(o0, o1))))
            # (the block header's kind first, as stroke_kind reads it: the summary's row made only without it)
            self.kinds.append(f.kind if f.kind in KINDS else stroke_kind(f, row_at(o0 + 1), tr0))
            self.layers.append(m0.layer if m0 is not None else -1)
            self.a2_before.append(tr0.line_sum(o0, o1, "int_a2") + tr0.line_sum(o0, o1, "int_a2_j"))


def _stroke_rows(tr0, tr1, fences, summary, profile, heads):
    row_at = _summary_row_at(summary)
    min_seg_t = profile.min_segment_time_t
    rows = StrokeTable()
    for f, kind, length, a2_before in zip(fences, heads.kinds, heads.lengths, heads.a2_before):
        o0, o1 = f.orig_first, f.orig_last
        m0 = tr0.moves.get(o0)
        sp = row_at(o0 + 1)
        if kind == "arc" and m0 is not None and m0.kind == st.ARC:   # mass along the arc: mean over tangents
            th = m0.arc.theta0 + m0.arc.sweep * np.linspace(0.0, 1.0, 65)
            m_kg = float(np.mean(mass_kg(profile, np.sin(th), np.cos(th))))
        elif length > 0:                        # lines and curves: length-weighted over the moves
            m_kg = 0.0
            mv = tr0.moves
            for k in mv.rows_of(o0, o1):
                length_d = mv.length_at(k)
                if length_d > 0:
                    x0, y0, _, x1, y1, _ = mv.xyz_at(k)
                    d = math.hypot(x1 - x0, y1 - y0) or 1.0
                    m_kg += mass_kg(profile, (x1 - x0) / d, (y1 - y0) / d) * length_d / length
        else:
            m_kg = mass_kg(profile, 1.0, 0.0)
        n_blocks, shortest_t, below = tr1.span_blocks(f.out_first, f.out_last, min_seg_t)
        t_after = tr1.line_sum(f.out_first, f.out_last, "time_t")
        segments = f.segments or n_blocks
        beta = f.marker_beta_s2
        if sp is not None:
            beta = sp.get("beta_s2")
            beta = math.inf if beta is None else beta
        feed = m0.v if m0 is not None else 0.0
        peak_after = tr1.line_max(f.out_first, f.out_last, "peak_v")
        row = {
            "line": o0 + 1, "lines": f.n_orig, "out_line": f.out_first + 1,
            "out_lines": f.out_last - f.out_first + 1, "segments": segments,
            "kind": kind,
            "feature": m0.feature if m0 is not None else "?", "layer": m0.layer if m0 is not None else -1,
            "length_mm": length, "feed_mm_s": feed,
            "v0_mm_s": tr0.lines.value(o0, "start_v", 0.0),
            "v1_mm_s": tr0.lines.value(o1, "end_v", 0.0),
            "mass_kg": m_kg,
            "beta_s2": beta if _finite(beta) else None,
            "time_s": {"before": tr0.line_sum(o0, o1, "time_t"), "after": t_after},
            # the junction halves belong to the stroke (vertices inside a curve, sub-arc ends),
            # as the pipeline's summary counts them
            "int_a2_mm2_s3": {"before": a2_before,
                              "after": tr1.line_sum(f.out_first, f.out_last, "int_a2")
                              + tr1.line_sum(f.out_first, f.out_last, "int_a2_j")},
            "int_v2_mm2_s": {"before": tr0.line_sum(o0, o1, "int_v2"),
                             "after": tr1.line_sum(f.out_first, f.out_last, "int_v2")},
            "peak_v_mm_s": {"before": tr0.line_max(o0, o1, "peak_v"), "after": peak_after},
            "peak_a_mm_s2": {"before": tr0.line_max(o0, o1, "peak_a"),
                             "after": tr1.line_max(f.out_first, f.out_last, "peak_a")},
            "overshoot": ratio(peak_after, feed) if feed > 0 else None,
            "segment_rate_hz": segments / t_after if t_after > 0 else None,
            "shortest_segment_s": shortest_t,
            # the firmware's own test (Marlin DEFAULT_MINSEGMENTTIME): length / nominal speed
            "below_min_segment_time": below,
        }
        if sp is not None:
            row["time_s"]["law"] = sp["time_s"]["law"]
            row["int_a2_mm2_s3"]["law"] = sp["int_a2"]["law"]
        rows.append(row)
    return rows


def _group(rows, key):
    acc = defaultdict(lambda: {"strokes": 0, "length_mm": 0.0, "tb": 0.0, "ta": 0.0, "ab": 0.0, "aa": 0.0})
    for k, length, tb, ta, ab, aa in zip(rows.col(key), rows.col("length_mm"), *_before_after(rows, "time_s"),
                                          *_before_after(rows, "int_a2_mm2_s3")):
        g = acc[k]
        g["strokes"] += 1
        g["length_mm"] += length
        g["tb"] += tb
        g["ta"] += ta
        g["ab"] += ab
        g["aa"] += aa
    out = []
    for k in sorted(acc):
        g = acc[k]
        out.append({key: k, "strokes": g["strokes"], "length_mm": g["length_mm"],
                    "time_s": bac(g["tb"], g["ta"]), "int_a2_mm2_s3": bac(g["ab"], g["aa"])})
    return out


# --------------------------------------------------------------------------- whole file
def _kinetic_whole(tr, profile):
    terms = tr.kinetic_terms(lambda ux, uy: mass_kg(profile, ux, uy))
    if not len(terms):
        return 0.0
    return float(0.5 * np.sum(terms) * MM2_TO_M2)


def _before_after(rows, key):
    return rows.col(key, "before"), rows.col(key, "after")


def _headline(rows, tr0, tr1, summary, profile, lines_before, orig_path, new_path):
    import os
    r0, r1 = tr0.res, tr1.res
    sb = lambda k: float(sum(rows.col(k, "before")))   # noqa: E731
    sa = lambda k: float(sum(rows.col(k, "after")))    # noqa: E731
    mass = rows.col("mass_kg")
    v2 = dict(zip(("before", "after"), _before_after(rows, "int_v2_mm2_s")))
    a2 = dict(zip(("before", "after"), _before_after(rows, "int_a2_mm2_s3")))
    kin_b = sum(0.5 * m * v for m, v in zip(mass, v2["before"])) * MM2_TO_M2
    kin_a = sum(0.5 * m * v for m, v in zip(mass, v2["after"])) * MM2_TO_M2
    beta = rows.col("beta_s2")
    with_beta = [i for i, b in enumerate(beta) if b is not None]
    J = None
    if with_beta:
        def j(side):
            return sum(0.5 * mass[i] * (v2[side][i] + beta[i] * a2[side][i]) for i in with_beta) * MM2_TO_M2
        J = bac(j("before"), j("after"), strokes=len(with_beta))
    law = None
    if summary and rows and rows.has("time_s", "law"):
        law = {"time_s": float(sum(rows.col("time_s", "law"))),
               "int_a2_mm2_s3": float(sum(rows.col("int_a2_mm2_s3", "law")))}
    bytes_b, bytes_a = os.path.getsize(orig_path), os.path.getsize(new_path)
    lines_a = tr1.n_lines
    st_sum = (summary or {}).get("strokes", {})
    return {
        "print_time_s": bac(r0.time_t, r1.time_t),
        "retimed_time_s": bac(sb("time_s"), sa("time_s"), law=law["time_s"] if law else None),
        "int_a2_retimed_mm2_s3": bac(sb("int_a2_mm2_s3"), sa("int_a2_mm2_s3"),
                                     law=law["int_a2_mm2_s3"] if law else None),
        "int_a2_whole_mm2_s3": bac(r0.int_a2, r1.int_a2),
        "int_v2_retimed_mm2_s": bac(sb("int_v2_mm2_s"), sa("int_v2_mm2_s")),
        "kinetic_retimed_J_s": bac(kin_b, kin_a),
        "kinetic_whole_J_s": bac(_kinetic_whole(tr0, profile), _kinetic_whole(tr1, profile)),
        "J_retimed_J_s": J,
        "peak_speed_mm_s": bac(r0.peak_v, r1.peak_v),
        "peak_accel_mm_s2": bac(r0.peak_a, r1.peak_a),
        "peak_speed_retimed_mm_s": bac(max(rows.col("peak_v_mm_s", "before"), default=0.0),
                                       max(rows.col("peak_v_mm_s", "after"), default=0.0)),
        "peak_accel_retimed_mm_s2": bac(max(rows.col("peak_a_mm_s2", "before"), default=0.0),
                                        max(rows.col("peak_a_mm_s2", "after"), default=0.0)),
        "strokes": {"retimed": len(rows), "candidates": st_sum.get("candidates"),
                    "not_retimed": st_sum.get("not_retimed")},
        "file": {"bytes": bac(bytes_b, bytes_a), "lines": bac(lines_before, lines_a)},
        "corners": bac(r0.corners, r1.corners),
        "corner_dv2_mm2_s2": bac(r0.corner_dv2, r1.corner_dv2),
        "full_stops": bac(r0.full_stops, r1.full_stops),
        "short_segments": bac(r0.short_segments, r1.short_segments),
    }


# --------------------------------------------------------------------------- warnings
def _warn(out, code, level, message, lines=()):
    """lines: the first lines of the strokes warned about (all of them: their count)."""
    out.append({"code": code, "level": level, "message": message, "count": len(lines) if lines else None,
                "lines": list(lines[:10])})


def _warnings(rows, head, summary, profile):
    w = []
    opts = (summary or {}).get("options") or {}
    budget = opts.get("max_slowdown", DEFAULT_BUDGET_R)
    allowed = opts.get("overshoot")
    pt = head["print_time_s"]["change"]
    if pt is not None and pt > budget + 1e-9:
        _warn(w, "print_time_over_budget", "warning",
              f"print time grows by {pt * 100:.2f} %, more than the {budget * 100:g} % time budget "
              f"(--max-slowdown)")
    line = rows.col("line")
    tb, ta = _before_after(rows, "time_s")
    slow = sorted((i for i in range(len(rows)) if (ratio(ta[i], tb[i]) or 0) > budget),
                  key=lambda i: -(ta[i] / tb[i]))
    if slow:
        worst = slow[0]
        _warn(w, "strokes_stretched", "info",
              f"{len(slow)} re-timed strokes take more than {budget * 100:g} % longer than before "
              f"(worst: line {line[worst]}, "
              f"{ratio(ta[worst], tb[worst]) * 100:+.1f} %)", [line[i] for i in slow])
    rate_lim = profile.max_segment_rate
    rate = rows.col("segment_rate_hz")
    fast = sorted((i for i in range(len(rows)) if rate[i] and rate[i] >= SEGMENT_RATE_WARN_R * rate_lim),
                  key=lambda i: -rate[i])
    if fast:
        _warn(w, "segment_rate_near_limit", "warning",
              f"{len(fast)} re-timed strokes send segments at >= {SEGMENT_RATE_WARN_R * 100:.0f} % of the "
              f"firmware's {rate_lim:g} segments/s (max {rate[fast[0]]:.0f}/s at line "
              f"{line[fast[0]]}): the planner may starve and stutter", [line[i] for i in fast])
    short = [n for n, below in zip(line, rows.col("below_min_segment_time")) if below]
    if short:
        _warn(w, "segments_below_min_time", "warning",
              f"{len(short)} re-timed strokes have segments shorter than the firmware's minimum segment "
              f"time {profile.min_segment_time_t * 1000:g} ms (length / F; Marlin slows such moves down when its "
              f"planner buffer runs low, e.g. while the host or SD card stalls)",
              short)
    ov = rows.col("overshoot")
    over = sorted((i for i in range(len(rows)) if ov[i] is not None and ov[i] > OVERSHOOT_EPS_R),
                  key=lambda i: -ov[i])
    if over:
        lim = f" (allowed: --overshoot {allowed * 100:g} %)" if allowed is not None else ""
        _warn(w, "speed_overshoot", "info",
              f"{len(over)} re-timed strokes run faster than the slicer's F, by up to "
              f"{ov[over[0]] * 100:.1f} % (line {line[over[0]]}){lim}", [line[i] for i in over])
    ab, aa = _before_after(rows, "int_a2_mm2_s3")
    worse = [n for n, b, a in zip(line, ab, aa) if a > b * (1 + 1e-9)]
    if worse:
        _warn(w, "int_a2_increased", "warning",
              f"{len(worse)} re-timed strokes have a larger int|a|^2 dt after than before", worse)
    fs = head["full_stops"]
    if fs["after"] > fs["before"]:
        _warn(w, "more_full_stops", "warning",
              f"full stops grow from {fs['before']} to {fs['after']}")
    if summary is not None and summary.get("strokes", {}).get("retimed") not in (None, len(rows)):
        _warn(w, "summary_mismatch", "warning",
              f"the summary counts {summary['strokes']['retimed']} re-timed strokes, the processed file "
              f"has {len(rows)} fenced blocks")
    return w


# --------------------------------------------------------------------------- pictures' subjects
def _curved_runs(tr):
    """(first_idx, last_idx, length) of the longest smooth polyline of extruding moves."""
    best = None
    cos_max = math.cos(math.radians(CURVE_MAX_TURN_DEG))
    run = []

    def close():
        nonlocal best
        if len(run) >= CURVE_MIN_MOVES:
            turns = 0
            for a, b in zip(run, run[1:]):
                turns += 1 if (a[1] * b[1] + a[2] * b[2]) < 0.99999 else 0
            length = sum(r[3] for r in run)
            if turns >= len(run) // 2 and length >= CURVE_MIN_LENGTH_D and (best is None or length > best[2]):
                best = (run[0][0], run[-1][0], length)
        run.clear()

    prev_idx = None
    for m in tr.moves.values():
        idx = m.idx
        ok = m.kind == st.LINE and m.e > 0 and m.z0 == m.z1
        d = math.hypot(m.x1 - m.x0, m.y1 - m.y0) if ok else 0.0
        if not ok or d <= 0:
            close()
            prev_idx = None
            continue
        u = (idx, (m.x1 - m.x0) / d, (m.y1 - m.y0) / d, d, m.feature, m.v)
        if run and (prev_idx != idx - 1 or run[-1][4] != m.feature or run[-1][5] != m.v
                    or run[-1][1] * u[1] + run[-1][2] * u[2] < cos_max):
            close()
        run.append(u)
        prev_idx = idx
    close()
    return best


def _representatives(rows, plan):
    """The representative strokes of _rep_plan, the re-timed ones from their rows."""
    reps = []
    for p in plan:
        if isinstance(p, dict):
            reps.append(p)
            continue
        role, i = p
        r = rows[i]
        reps.append({"role": role, "line": r["line"], "lines": r["lines"], "retimed": True,
                     "length_mm": r["length_mm"], "feature": r["feature"], "layer": r["layer"], "note": ""})
    return reps


def _rep_plan(kinds, length, tr0):
    """The representative strokes (known from the original file alone): (role, row position)
    of the re-timed ones, the entry itself of the others."""
    reps = []

    def of_kind(kind):                   # the rows (by position) of a kind
        return [i for i, k in enumerate(kinds) if k == kind]

    def longest(idx):
        return max(idx, key=length.__getitem__)
    line_i = of_kind("line")
    if line_i:
        long_i, short_i = longest(line_i), min(line_i, key=length.__getitem__)
        for role, i in (("long line", long_i), ("short line", short_i)):
            reps.append((role, i))
            if long_i == short_i:
                break
    arc_i = of_kind("arc")
    arcs = [m for m in (tr0.moves[i] for i in tr0.moves.arcs) if m.kind == st.ARC]
    if arc_i:
        reps.append(("arc", longest(arc_i)))
    elif arcs:
        a = max(arcs, key=lambda m: m.length_d)
        reps.append({"role": "arc", "line": a.idx + 1, "lines": 1, "retimed": False, "length_mm": a.length_d,
                     "feature": a.feature, "layer": a.layer,
                     "note": "no arc (G2/G3) was re-timed; firmware profile, unchanged "
                             "in the output, against the optimal circle law at the same duration"})
    else:
        reps.append({"role": "arc", "line": None, "note": "the file has no arcs (G2/G3)"})
    curve_i = of_kind("curve")
    c = None if curve_i else _curved_runs(tr0)
    if curve_i:
        reps.append(("curve", longest(curve_i)))
    elif c:
        m = tr0.moves[c[0]]
        reps.append({"role": "curve", "line": c[0] + 1, "lines": c[1] - c[0] + 1, "retimed": False,
                     "length_mm": c[2], "feature": m.feature, "layer": m.layer,
                     "note": "no curve was re-timed in this file (not a selected feature, or no law beat the "
                             "original within the budget); firmware profile, unchanged in the output, against "
                             "the optimal law along the same curve at the same duration"})
    else:
        reps.append({"role": "curve", "line": None,
                     "note": "the file has no curved stroke (a smooth polyline of at least "
                             f"{CURVE_MIN_MOVES} moves, turns under {CURVE_MAX_TURN_DEG:g} deg)"})
    return reps


def _middle_layer(tr0):
    """The layer map's layer when no stroke was re-timed."""
    layers = np.unique(tr0.moves.np("layer")).tolist()
    return layers[len(layers) // 2] if layers else 0


def _gain_key(gain):
    return lambda k: (-gain[k], k)


def _map_layer(rows, tr0, layer=None):
    row_layer, (ab, aa) = rows.col("layer"), _before_after(rows, "int_a2_mm2_s3")
    if layer is None:
        gain = defaultdict(float)          # the layer where re-timing removed the most int a^2
        for k, b, a in zip(row_layer, ab, aa):
            gain[k] += b - a
        layer = min(gain, key=_gain_key(gain)) if gain else _middle_layer(tr0)
    mv = tr0.moves
    zs = mv.np("z0")[(mv.np("layer") == layer) & (mv.np("e") > 0)].tolist()
    in_layer = [i for i, k in enumerate(row_layer) if k == layer]
    return {"layer": layer, "z_mm": float(np.median(zs)) if zs else None, "retimed_strokes": len(in_layer),
            "int_a2_retimed_mm2_s3": bac(float(sum(ab[i] for i in in_layer)),
                                         float(sum(aa[i] for i in in_layer)))}


class LayerPick:
    """The layers _map_layer may still choose while the processed file is played (its blocks
    of the others need not be kept): the one asked for; with no re-timed stroke, the
    original's middle one; else the strokes' layers, each gone once its gain (int a^2
    removed, summed in row order as _map_layer sums it) is final -- the span of its last
    stroke is behind the pass -- and another final layer's beats it.  A gain that is not a
    number beats nothing and is beaten by nothing: min() never takes a layer beaten so."""

    def __init__(self, layer, heads=None, tr0=None):
        """heads (StrokeHeads) and tr0 (the original's trace) when layer is None."""
        self.row_layers, self.a2_before = (heads.layers, heads.a2_before) if heads is not None else ([], [])
        self.fixed = layer if layer is not None else (None if self.row_layers else _middle_layer(tr0))
        self.alive = set(self.row_layers) if self.fixed is None else {self.fixed}
        self.left = defaultdict(int)           # strokes of each layer whose span is not final
        for k in self.row_layers:
            self.left[k] += 1
        self.gain = defaultdict(float)
        self.best = None                       # the best final layer so far

    def wanted(self, layer) -> bool:
        return layer in self.alive

    def closed(self, k, a2_after):
        """Stroke k's span is final (a2_after: its int a^2 after); returns the layers gone."""
        if self.fixed is not None:
            return ()
        layer = self.row_layers[k]
        self.gain[layer] += self.a2_before[k] - a2_after
        self.left[layer] -= 1
        if self.left[layer]:
            return ()
        if self.best is None:
            self.best = layer
            return ()
        key = _gain_key(self.gain)
        if key(layer) < key(self.best):
            gone, self.best = self.best, layer
        elif key(self.best) < key(layer):
            gone = layer
        else:
            return ()
        self.alive.discard(gone)
        return (gone,)


# --------------------------------------------------------------------------- coverage
def _coverage(tr0, tr1, fences, summary):
    """The whole-file lead (issue 9 item 5), from the report's own trace of the original:
    the share of its int|a|^2 dt and time in the lines that were re-timed (the fences), and
    the rest by feature (an XY move without extrusion is travel), each with its share; the
    pipeline's reasons for candidates left as sliced come from the summary when given."""
    total_a2, total_t = tr0.res.int_a2, tr0.res.time_t
    (a2_in, t_in), rest = _line_shares(tr0.lines, tr0.moves, fences)
    selected = set(((summary or {}).get("options") or {}).get("features") or ())
    left = [{"feature": f, "moves": n, "selected": (f in selected) if selected else None,
             "int_a2_share": ratio_share(a2, total_a2), "time_share": ratio_share(t, total_t)}
            for f, (n, a2, t) in rest.items()]
    left.sort(key=lambda g: -(g["int_a2_share"] or 0.0))
    cov = (summary or {}).get("coverage") or {}
    return {
        "whole_file": {"int_a2_change": ratio(tr1.res.int_a2, total_a2), "time_change": ratio(tr1.res.time_t, total_t)},
        "retimed": {"strokes": len(fences), "int_a2_share": ratio_share(a2_in, total_a2),
                    "time_share": ratio_share(t_in, total_t)},
        "left_by_feature": left,
        "left_by_reason": cov.get("left"),
        "features": (summary or {}).get("features"),
    }


def _line_shares(lines, moves, fences):
    """((int a^2, time) of the moving lines inside the fences, {group: [lines, int a^2, time]}
    of the others), int a^2 being int_a2 + int_a2_j, each sum added line by line in line
    order from 0.0 (as a Python loop adds), the groups in the order of their first line;
    a line's group is its move's feature, "travel" (no extrusion) or "other" (no move).
    Made a LineTable chunk at a time on array views: the loop over Python floats and a set
    of every fenced line took the gyroid plate's `--report` heap up ~18 MB."""
    inside = _fenced_lines(fences, (lines.idx[-1] + 1) if len(lines.idx) else 0)
    mv_idx = np.frombuffer(moves.idx, np.int64) if len(moves.idx) else np.zeros(0, np.int64)
    mv_extrudes = _column_where(moves, "e", lambda e: e > 0.0)
    mv_feature = np.frombuffer(moves.feature, np.uint16) if len(moves.feature) else np.zeros(0, np.uint16)
    names = list(moves.features) + ["travel", "other"]
    travel, other = len(names) - 2, len(names) - 1
    in_sums = np.zeros(2)
    rest = {}                     # group code -> [lines, int a^2, time], in first-line order
    ja2, ja2j, jt, w, C = lines._j["int_a2"], lines._j["int_a2_j"], lines._j["time_t"], lines._w, lines.CHUNK
    for c, chunk in enumerate(lines._chunks):
        if not len(chunk):
            continue
        rows = np.frombuffer(chunk, dtype=float).reshape(-1, w)
        idx = np.frombuffer(lines.idx, np.int64, count=len(rows), offset=8 * c * C)
        a2 = rows[:, ja2] + rows[:, ja2j]
        t = rows[:, jt]
        fenced = inside[idx]
        in_sums[0] = _added(in_sums[0], a2[fenced])
        in_sums[1] = _added(in_sums[1], t[fenced])
        out = ~fenced
        idx, a2, t = idx[out], a2[out], t[out]
        if len(mv_idx):
            k = np.minimum(np.searchsorted(mv_idx, idx), len(mv_idx) - 1)
            code = np.where(mv_idx[k] == idx, np.where(mv_extrudes[k], mv_feature[k], travel), other)
        else:
            code = np.full(len(idx), other)
        codes, first = np.unique(code, return_index=True)
        for g in codes[np.argsort(first, kind="stable")].tolist():
            sel = code == g
            r = rest.setdefault(g, [0, 0.0, 0.0])
            r[0] += int(np.count_nonzero(sel))
            r[1] = _added(r[1], a2[sel])
            r[2] = _added(r[2], t[sel])
    return (float(in_sums[0]), float(in_sums[1])), {names[g]: r for g, r in rest.items()}


def _fenced_lines(fences, n):
    """Bool by source line 0..n-1 (a line past n counts as outside): in any fence's span."""
    d = np.zeros(n + 1, np.int64)
    if fences:
        lo = np.minimum(np.fromiter((f.orig_first for f in fences), np.int64, len(fences)), n)
        hi = np.minimum(np.fromiter((f.orig_last + 1 for f in fences), np.int64, len(fences)), n)
        np.add.at(d, lo, 1)
        np.add.at(d, hi, -1)
    return np.cumsum(d[:n]) > 0


def _column_where(table, attr, test):
    """test(column) of a _Rows table's attr, as bools by row (made chunk by chunk: no copy of
    the whole column)."""
    j, w = table._j[attr], table._w
    parts = [test(np.frombuffer(c, dtype=float).reshape(-1, w)[:, j]) for c in table._chunks if len(c)]
    return np.concatenate(parts) if parts else np.zeros(0, bool)


def _added(start, vals):
    """start + vals[0] + vals[1] + ... added left to right (a Python loop's sum: numpy's
    sum pairs its terms, other bits)."""
    if not len(vals):
        return start
    return float(np.add.accumulate(np.concatenate(([start], vals)))[-1])


def ratio_share(part, whole):
    return None if not whole else float(part) / float(whole)


def _traced(path, profile, ring, processed=False, spans=None):
    """trace_file of one file; with ring (a RingingRows), its ringing rows go into ring's
    section (figures, the summary's when it has them, and the stretch plot's samples, over
    the commanded motion of this pass) and leave: the original's are gone before the
    processed file is played."""
    tr = trace_file(path, profile, ringing=ring is not None, processed=processed, spans=spans)
    if ring is not None:
        items, tr.ring_rows = tr.ring_rows, None
        ring.add(items, "after" if processed else "before")
    return tr


def _traced_processed(path, profile, ring, fences, heads, plan, layer, tr0):
    """The processed file's trace: with disjoint fences a FenceTrace (what the report reads,
    kept as the pass goes: the fences' figures, the representative strokes' blocks, the
    layer map's candidate layers), its ringing rows into ring's sink (the stretch's window);
    else (never from the pipeline) trace_file's whole trace."""
    spans = [(f.out_first, f.out_last) for f in fences]
    if not disjoint_spans(spans):
        return _traced(path, profile, ring, processed=True)
    keep = [p[1] for p in plan if not isinstance(p, dict)]
    sink = ring.sink() if ring is not None else None
    tr = trace_fences(path, profile, spans, keep, LayerPick(layer, heads, tr0),
                      (profile.moving_mass_x_kg, profile.moving_mass_y_kg), sink)
    if ring is not None:
        ring.add_sink(sink)
    return tr


def _replayed(tr0, path, profile, reps, layer, ring):
    """The original's blocks the plots draw (the representative strokes', the layer map's)
    and, with ring (a RingingRows), its ringing stretch, from a replay of it (its first pass
    kept neither)."""
    spans = []
    for r in sorted((r["line"] - 1, r["line"] + r["lines"] - 2) for r in reps if r.get("line") is not None):
        if spans and r[0] <= spans[-1][1]:
            spans[-1] = (spans[-1][0], max(spans[-1][1], r[1]))
        else:
            spans.append(r)
    sink = ring.stretch_sink() if ring is not None else None
    ft = trace_fences(path, profile, spans, range(len(spans)), LayerPick(layer),
                      (profile.moving_mass_x_kg, profile.moving_mass_y_kg), sink)
    tr0.take_blocks(ft, layer)
    if ring is not None:
        ring.add_sink(sink, "before")


# --------------------------------------------------------------------------- entry point
def build_report(orig_path, new_path, profile, summary=None, layer=None, ringing=True):
    """ringing: add the ringing section (figures from the summary's "ringing" when it has
    them, the stretch from the report's own firmware-model passes)."""
    fences, n_orig = parse_fences(new_path)
    lines_before = count_lines(orig_path)
    if n_orig != lines_before:
        raise ValueError(f"{new_path} does not come from {orig_path}: its fences account for {n_orig} "
                         f"original lines, the original has {lines_before}")
    ring = None
    if ringing:
        from .ringing import RingingRows
        ring = RingingRows(profile, figures=(summary or {}).get("ringing"))
    # the original's blocks: their kinetic terms now, those the plots draw in a replay
    # (_replayed); its ringing rows: its figures and where it rings most now, its stretch
    # in the replay
    sink = ring.busiest_sink() if ring is not None else None
    tr0 = trace_file(orig_path, profile, ringing=sink or False,
                     mass_xy=(profile.moving_mass_x_kg, profile.moving_mass_y_kg))
    if ring is not None:
        ring.add_sink(sink)
    heads = StrokeHeads(tr0, fences, summary)
    plan = _rep_plan(heads.kinds, heads.lengths, tr0)
    tr1 = _traced_processed(new_path, profile, ring, fences, heads, plan, layer, tr0)
    rows = _stroke_rows(tr0, tr1, fences, summary, profile, heads)
    del heads
    head = _headline(rows, tr0, tr1, summary, profile, lines_before, orig_path, new_path)
    reps = _representatives(rows, plan)
    lm = _map_layer(rows, tr0, layer)
    _replayed(tr0, orig_path, profile, reps, lm["layer"], ring)
    if ring is not None:
        ring = ring.data()
        h = ring["headline"]
        head["ringing_rms_um"] = bac(h["rms_um"]["before"], h["rms_um"]["after"])
        head["ringing_peak_um"] = bac(h["peak_um"]["before"], h["peak_um"]["after"])
    data = {
        "schema": SCHEMA,
        "original": str(orig_path), "processed": str(new_path),
        "profile": profile.name, "flavour": profile.flavour,
        "mass_kg": {"x": profile.moving_mass_x_kg, "y": profile.moving_mass_y_kg},
        "limits": {"max_segment_rate_hz": profile.max_segment_rate,
                   "min_segment_time_s": profile.min_segment_time_t},
        "options": (summary or {}).get("options"),
        "coverage": _coverage(tr0, tr1, fences, summary),
        "headline": head,
        "by_feature": _group(rows, "feature"),
        "by_layer": _group(rows, "layer"),
        "by_kind": _group(rows, "kind"),
        "warnings": _warnings(rows, head, summary, profile),
        "representative": reps,
        "layer_map": lm,
        "whole_file": {"before": tr0.res.as_dict(), "after": tr1.res.as_dict()},
    }
    if ring is not None:
        data["ringing"] = ring
    data["per_stroke"] = rows
    return data, Context(tr0, tr1, fences, summary, profile)
