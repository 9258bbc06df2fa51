"""The whole job, in three streamed passes over the file.

  1. analyse: read -> machine state -> strokes, with the firmware model playing the
     original file alongside: each stroke learns the speeds the original reaches at its
     ends, its duration and its inertia norm.
  2. plan (in memory, a few numbers per stroke) and rewrite: read again, copy every line
     that is not in a re-timed stroke byte for byte, replace re-timed strokes by segments;
     written to a temporary file in the target's folder, then renamed into place.
  3. measure: the firmware model plays the re-timed file; before/after figures come from
     the same model on both files.
Memory holds a few floats per stroke, never the file's lines.

One bad stroke never aborts the file: planning and segmenting run vectorised, and a batch
that raises is retried in halves down to the stroke at fault (plan.isolate); a stroke with
a non-finite input, candidate, plan or segment, or whose block raises while it is written
or fails the output validator (validate.py), keeps its original lines, counted by reason
in the summary (strokes.not_retimed, strokes.faults).
"""
from __future__ import annotations

import math
import os
import sys
import tempfile
import time

import numpy as np

from . import arcs
from . import curves
from . import features as feat
from .emit import StrokeText, emit_arc, emit_stroke
from .firmware.simulate import simulate_events
from .plan import (T_RATIOS, Plan, PlanInput, candidates_auto, input_faults, isolate, plan_auto,
                   plan_fixed_alpha, scatter_candidates)
from .profile import Profile
from .segments import SegmentRules, plan_segments
from .state import MachineState, events, read_lines
from .strokes import K_ARC, K_CURVE, K_LINE, group_strokes
from .validate import BlockInvalid, Geometry, validate_block
from .words import param_texts, split_comment, strip_checksum


class Options:
    def __init__(self, alpha="auto", features=feat.DEFAULT_SELECTED, overshoot_r=0.25,
                 max_slowdown_r=0.03, max_segments=10, min_length_d=2.0, progress=None, max_turn_deg=30.0):
        self.alpha = alpha                  # "auto" or a float in s^2/kg
        self.features = tuple(features)
        self.overshoot_r = overshoot_r      # allowed peak speed above the slicer's F
        self.max_slowdown_r = max_slowdown_r  # print-time budget, fraction of the whole file
        self.max_segments = max_segments
        self.min_length_d = min_length_d
        self.progress = progress            # Progress or None
        self.max_turn_deg = max_turn_deg    # polyline vertices turning <= this are inside a curve (0: no curves)


class Progress:
    """A one-line progress bar on stderr, only when stderr is a terminal."""

    def __init__(self, total_bytes, enabled=None):
        self.total = max(total_bytes, 1)
        self.enabled = sys.stderr.isatty() if enabled is None else enabled
        self.done = 0
        self.phase = ""
        self._last = 0.0

    def start(self, phase):
        if self.phase:
            self._draw(1.0)                 # finish the previous phase's bar
        self.phase, self.done, self._last = phase, 0, 0.0

    def advance(self, nbytes):
        self.done += nbytes
        if self.enabled:
            now = time.monotonic()
            if now - self._last > 0.2:
                self._last = now
                self._draw(min(self.done / self.total, 1.0))

    def _draw(self, r):
        if self.enabled:
            sys.stderr.write(f"\r{self.phase:<10} [{'#' * int(r * 30):<30}] {r * 100:5.1f}%")
            sys.stderr.flush()

    def finish(self):
        if self.enabled:
            self._draw(1.0)
            sys.stderr.write("\r" + " " * 60 + "\r")
            sys.stderr.flush()


def _counted(it, progress):
    if progress is None:
        yield from it
        return
    for item in it:
        progress.advance(len(item[1]))
        yield item


# ---------------------------------------------------------------- pass 1: analyse
def analyse(path, profile: Profile, opts: Options):
    """Strokes of the original file with the firmware model's figures for each."""
    strokes = []
    owner = {}          # line idx -> stroke still waiting for that line's record
    early = {}          # records that arrived before their stroke closed

    def apply(st, r):
        if r.idx == st.first_idx:
            st.v0 = r.start_v
        if r.idx == st.last_idx:
            st.v1 = r.end_v
        st.time_t += r.time_t
        st.int_a2 += r.int_a2 + r.int_a2_j     # junction halves: vertices of curves, sub-arc ends
        st.int_v2 += r.int_v2

    pending_idx = set()
    split = curves.vertex_splitter(profile) if opts.max_turn_deg > 0 else None

    def feed():
        for item in group_strokes(_counted(events(path, profile), opts.progress), opts.features,
                                  opts.min_length_d, opts.max_turn_deg, split):
            if item[0] == "line":
                _, idx, raw, ev = item
                pending_idx.add(idx)
                yield idx, raw, ev
            else:
                st = item[1]
                strokes.append(st)
                for i in range(st.first_idx, st.last_idx + 1):
                    r = early.pop(i, None)
                    if r is not None:
                        apply(st, r)
                    else:
                        owner[i] = st
                    pending_idx.discard(i)
                # records of lines up to this stroke's end that no stroke claimed are garbage;
                # several strokes can close at once (a run split into strokes), in file order,
                # so the lines after this one must keep their early records
                for i in [i for i in pending_idx if i <= st.last_idx]:
                    pending_idx.discard(i)
                    early.pop(i, None)

    def on_line(r):
        st = owner.pop(r.idx, None)
        if st is not None:
            apply(st, r)
        elif r.idx in pending_idx:
            early[r.idx] = r

    sim = simulate_events(feed(), profile, on_line=on_line)
    return strokes, sim


def plan_inputs(strokes, profile: Profile, opts: Options) -> PlanInput:
    n = len(strokes)
    with np.errstate(all="ignore"):           # non-finite inputs are caught per stroke below
        L = np.array([s.length_d for s in strokes], float)
        ux = np.array([s.ux for s in strokes], float)
        uy = np.array([s.uy for s in strokes], float)
        v_feed = np.array([s.v_feed for s in strokes], float)
        v_lim = np.array([min(s.lim.v_max, profile.max_velocity_v) for s in strokes], float)
        area = math.pi * (profile.filament_diameter_d / 2) ** 2
        e_mm = np.array([s.e_per_mm for s in strokes], float)
        v_flow = np.where(e_mm > 0, profile.max_volumetric_flow / np.maximum(e_mm * area, 1e-12), np.inf)
        v_cap = np.minimum(np.minimum(v_feed * (1 + opts.overshoot_r), v_lim), v_flow)
        v_cap = np.maximum(v_cap, np.minimum(v_feed, v_lim))    # never below what the slicer asked
        # firmware caps each axis' share of the acceleration (Marlin M201, Klipper max_accel)
        ax = np.array([s.lim.ax_max for s in strokes], float)
        ay = np.array([s.lim.ay_max for s in strokes], float)
        a_axis = np.minimum(np.where(abs(ux) > 1e-12, ax / abs(ux), np.inf),
                            np.where(abs(uy) > 1e-12, ay / abs(uy), np.inf))
        a_cap = np.minimum(np.array([s.accel for s in strokes], float), a_axis)
        m = profile.moving_mass_x_kg * ux ** 2 + profile.moving_mass_y_kg * uy ** 2
        m2 = profile.moving_mass_x_kg ** 2 * ux ** 2 + profile.moving_mass_y_kg ** 2 * uy ** 2
        seg_t = max(profile.min_segment_time_t, 1.0 / profile.max_segment_rate)
        pin = PlanInput(L, np.array([s.v0 for s in strokes], float), np.array([s.v1 for s in strokes], float),
                        v_cap, a_cap, np.array([s.time_t for s in strokes], float),
                        np.array([s.int_a2 for s in strokes], float), m2 / m, np.full(n, 3 * seg_t))
    pin.v_cap, pin.a_cap, pin.mass_r = pin.v_cap.astype(float), pin.a_cap.astype(float), pin.mass_r.astype(float)
    failed = {}
    arc_rows = [i for i, s in enumerate(strokes) if s.kind == K_ARC]
    isolate(lambda r: arcs.adjust_plan_inputs(pin, strokes, r, profile), arc_rows, "planning", failed)
    curve_rows = [i for i, s in enumerate(strokes) if s.kind == K_CURVE]
    isolate(lambda r: curves.adjust_plan_inputs(pin, strokes, r, profile), curve_rows, "planning", failed)
    pin.fault = input_faults(pin)             # reason per stroke, "" = fine
    for i, why in failed.items():
        pin.fault[i] = why
    return pin


def _rows_by_kind(strokes):
    kinds = np.array([s.kind for s in strokes], dtype=object)
    return {k: np.flatnonzero(kinds == k) for k in (K_LINE, K_ARC, K_CURVE)}


def _candidates(strokes, pin, profile, opts, rows, failed):
    """Candidate tables (auto) or the fixed-alpha plan of every stroke, each kind's batch
    isolated: a stroke whose planning raises or gives non-finite numbers is dropped alone."""
    n = len(strokes)
    ok = {k: np.array([i for i in r if i not in failed], int) for k, r in rows.items()}
    if opts.alpha == "auto":
        pieces = isolate(lambda r: candidates_auto(pin.take(r)), ok[K_LINE], "planning", failed)
        pieces += isolate(lambda r: arcs.candidates_arc(pin, r, strokes), ok[K_ARC], "planning", failed)
        pieces += isolate(lambda r: curves.candidates_curve(pin, r, strokes, profile), ok[K_CURVE],
                          "planning", failed)
        T, beta, I, KE, nonfinite = scatter_candidates(n, pieces, pin.T_orig[:, None] * T_RATIOS[None, :])
        for i in nonfinite:
            failed.setdefault(int(i), "error: planning (non-finite)")
        I[nonfinite] = np.inf
        return (T, beta, I, KE), None
    alpha = float(opts.alpha)
    fixed = Plan(n)
    fixed.T = pin.T_orig.copy()
    fixed.I_law = pin.I_orig.copy()
    fixed.reason[:] = "no law within limits"
    for sub, p in isolate(lambda r: plan_fixed_alpha(pin.take(r), alpha), ok[K_LINE], "planning", failed):
        fixed.put(sub, p)
    isolate(lambda r: arcs.fixed_alpha_arc(fixed, pin, r, strokes, alpha), ok[K_ARC], "planning", failed)
    isolate(lambda r: curves.fixed_alpha_curve(fixed, pin, r, strokes, profile, alpha), ok[K_CURVE],
            "planning", failed)
    return None, fixed


def _plan_fault(plan):
    """Rows of a plan chosen for re-timing whose figures are not finite numbers."""
    with np.errstate(invalid="ignore"):
        bad = ~np.isfinite(plan.T) | ~(plan.T > 0) | ~np.isfinite(plan.I_law) | np.isnan(plan.beta)
    return plan.retime & bad


def seg_fault(seg):
    """Why a segment plan must not be written ("" = fine): every knot, speed, acceleration
    and feed finite, knots strictly increasing, accelerations and feeds above 0."""
    try:
        s, v, a, f = (np.asarray(x, float) for x in (seg.s, seg.v, seg.accel, seg.feed))
    except (TypeError, ValueError):
        return "error: segments (malformed)"
    if not (np.isfinite(s).all() and np.isfinite(v).all() and np.isfinite(a).all() and np.isfinite(f).all()
            and math.isfinite(seg.time_t) and math.isfinite(seg.int_a2)):
        return "error: segments (non-finite)"
    if len(s) < 2 or a.size != len(s) - 1 or f.size != len(s) - 1:
        return "error: segments (malformed)"
    if not (np.diff(s) > 0).all():
        return "error: segments (knots not increasing)"
    if not ((a > 0).all() and (f > 0).all() and (v >= 0).all()):
        return "error: segments (acceleration, feed or speed not above 0)"
    return ""


def plan_strokes(strokes, pin, profile, opts, budget_t):
    """Law per stroke (plan.py), then its segments as the firmware will execute them
    (segments.py).  The segments' predicted time, not the law's, is what the print takes:
    the budget is re-spent once with the difference taken off, and a stroke whose
    segments would not beat the original trapezoid is left alone.

    Fault isolation: a stroke whose inputs are not finite, whose planning or segmenting
    raises, or whose plan holds a non-finite number keeps its original lines, with the
    reason in plan.reason (the summary counts them)."""
    rules = SegmentRules.for_profile(profile, opts.max_segments)
    rows = _rows_by_kind(strokes)
    cached = getattr(pin, "cached", None)    # the same strokes planned again: reuse
    if cached is None:
        fault = getattr(pin, "fault", None)
        failed = {} if fault is None else {i: str(r) for i, r in enumerate(fault) if r}
        cands, fixed = _candidates(strokes, pin, profile, opts, rows, failed) if len(strokes) else (None, None)
        cached = pin.cached = (cands, fixed, failed)
    cands, fixed, failed = cached
    failed_rows = np.array(sorted(failed), int)

    # failed strokes stay out of the budget's allocation (their figures may be NaN)
    groups = [np.setdiff1d(rows[k], failed_rows) for k in (K_LINE, K_ARC, K_CURVE)]

    def run(budget):
        plan = plan_auto(pin, budget, cands, groups) if opts.alpha == "auto" else fixed.copy()
        plan.retime[failed_rows] = False
        for i in failed_rows:
            plan.reason[i] = failed[i]
        bad = _plan_fault(plan)
        plan.retime[bad] = False
        plan.reason[bad] = "error: planning (non-finite)"
        plan.segs = [None] * len(strokes)
        plan.t_pred = pin.T_orig.copy()
        plan.a2_pred = pin.I_orig.copy()
        idx = np.flatnonzero(plan.retime)
        kind = np.array([strokes[i].kind for i in idx], dtype=object)
        segs = {}
        seg_failed = {}
        planners = {
            K_LINE: lambda sts, T, b: plan_segments(sts, T, b, rules),
            K_ARC: lambda sts, T, b: arcs.plan_arc_segments(sts, T, b, rules, profile),
            K_CURVE: lambda sts, T, b: curves.plan_curve_segments(sts, T, b, rules, profile),
        }
        for k_name, fn in planners.items():
            ii = idx[kind == k_name]
            for sub, res in isolate(lambda r: fn([strokes[i] for i in r], plan.T[r], plan.beta[r]),
                                    ii, "segments", seg_failed):
                segs.update(zip(sub.tolist(), res))
        for i in idx:
            seg = segs.get(int(i))
            why = seg_failed.get(int(i)) or ("" if seg is None else seg_fault(seg))
            if why:
                plan.retime[i] = False
                plan.reason[i] = why
                continue
            if seg is None or seg.int_a2 >= strokes[i].int_a2:
                plan.retime[i] = False
                plan.reason[i] = "segments would not beat the original"
                continue
            plan.segs[i] = seg
            plan.t_pred[i], plan.a2_pred[i] = seg.time_t, seg.int_a2
        return plan

    plan = run(budget_t)
    if opts.alpha == "auto":
        budget = budget_t
        for _ in range(3):                # the set of strokes changes with the budget: iterate
            over = float(np.sum(plan.t_pred - pin.T_orig, where=plan.retime)) - budget_t
            if over <= 1e-3 * budget_t + 1e-9:
                break
            budget -= over
            plan = run(budget)
    return plan


# ---------------------------------------------------------------- pass 2: rewrite
def rewrite(path, out_fh, strokes, plan, profile: Profile, opts: Options):
    """Copy the file to out_fh, re-timed strokes replaced.  Returns the output line
    range of each re-timed stroke: list of (out_first, out_last, stroke_index).

    Each block is validated (validate.py) before it is written; a block whose emission
    raises or fails validation is replaced by the stroke's original lines, and the
    stroke counted with the reason (plan.retime/plan.reason updated)."""
    chosen = {strokes[i].first_idx: i for i in np.flatnonzero(plan.retime)}
    st = MachineState(profile, path)
    out_ranges = []
    out_line = 0
    buf = None
    cur = None
    for idx, raw in _counted(read_lines(path), opts.progress):
        if buf is None and idx in chosen:
            i = chosen[idx]
            # the acceleration to restore is the one of this stroke's kind (print vs travel)
            cur = (i, strokes[i], st.x, st.y, st.e, st.accel_for(strokes[i].feature != feat.TRAVEL, True),
                   st.lim.mcr)
            buf = []
        if buf is not None:
            buf.append(raw)
            st.step(idx, raw)
            if idx == cur[1].last_idx:
                i, s, x0, y0, e0, accel0, mcr0 = cur
                try:
                    with np.errstate(all="ignore"):
                        text = _stroke_block(s, buf, plan.segs[i], plan.beta[i], x0, y0, e0, accel0, mcr0,
                                             profile)
                    _validate(text, s, buf, x0, y0, accel0, profile)
                except BlockInvalid as e:
                    text = None
                    plan.reason[i] = str(e)
                except Exception as e:        # noqa: BLE001 -- this stroke's failure only
                    text = None
                    plan.reason[i] = f"error: emission ({type(e).__name__})"
                if text is None:
                    plan.retime[i] = False
                    plan.segs[i] = None
                    out_fh.write("".join(buf))
                    out_line += len(buf)
                else:
                    out_fh.write(text)
                    n_out = text.count("\n")
                    out_ranges.append((out_line, out_line + n_out - 1, i))
                    out_line += n_out
                buf = None
            continue
        st.step(idx, raw)
        out_fh.write(raw)
        out_line += 1
    if buf:                       # file ended inside a stroke (cannot happen: strokes close)
        out_fh.write("".join(buf))
    return out_ranges


def _validate(text, s, raws, x0, y0, accel0, profile):
    """validate.py on one block; the path and the filament are the original's own (its raw
    X/Y/E words)."""
    pts = [(x0, y0)]
    e_words = []
    for raw in raws:
        p = param_texts(strip_checksum(split_comment(raw.rstrip("\r\n"))[0])[0])
        pts.append((float(p.get("X", pts[-1][0])), float(p.get("Y", pts[-1][1]))))
        if "E" in p:
            e_words.append(float(p["E"]))
    extruding = s.feature != feat.TRAVEL
    e_check = None
    if extruding and e_words:
        e_check = (True, math.fsum(e_words)) if s.e_rel else (False, e_words[-1])
    arc = None if s.kind != K_ARC else (s.arc.cx, s.arc.cy, s.arc.r, s.arc.theta0, s.arc.sweep)
    # a restore of the acceleration the slicer had in force is as acceptable as the original line
    accel_max_a = max(profile.max_accel_a, accel0) if math.isfinite(accel0) else profile.max_accel_a
    validate_block(text, profile.flavour, accel_max_a, Geometry([pts[0], pts[-1]] if arc else pts, arc),
                   extruding=extruding, kind=s.kind, e_check=e_check)


def _stroke_block(s, raws, seg, beta, x0, y0, e0, accel0, mcr0, profile):
    """G-code text replacing one stroke, from its segment plan `seg`.  The header names
    the kind (line, curve, arc) after "replaces N lines" (verify.py and the report read it)."""
    dec = 8
    beta_txt = "inf" if not np.isfinite(beta) else f"{beta:.4g}"
    if s.kind == K_ARC:
        header = (f": replaces {len(raws)} lines, kind={s.kind}, {len(seg.s) - 1} sub-arcs, T={seg.time_t:.4f}s "
                  f"(was {s.time_t:.4f}s), beta={beta_txt}s^2")
        return emit_arc(raws[0], f"{x0:.{dec}f}", f"{y0:.{dec}f}", e0, s.arc, seg.s, seg.accel, seg.feed,
                        e_rel=s.e_rel, flavour=profile.flavour, accel_restore=accel0, mcr_restore=mcr0,
                        feed_restore_v=s.v_feed, header=header)
    st_text = StrokeText(raws, f"{x0:.{dec}f}", f"{y0:.{dec}f}", 0)
    st_text.e_start_units = int(round(e0 * 10 ** st_text.dec_e))
    header = (f": replaces {len(raws)} lines, kind={s.kind}, {len(seg.s) - 1} segments, T={seg.time_t:.4f}s "
              f"(was {s.time_t:.4f}s), beta={beta_txt}s^2")
    return emit_stroke(st_text, s.ends_d, seg.s, seg.v, seg.accel, seg.feed, x0_text=f"{x0:.{dec}f}",
                       y0_text=f"{y0:.{dec}f}", e_rel=s.e_rel, flavour=profile.flavour, accel_restore=accel0,
                       mcr_restore=mcr0, feed_restore_v=s.v_feed, extruding=s.feature != feat.TRAVEL,
                       header=header)


# ---------------------------------------------------------------- pass 3: measure
def measure(path, profile, out_ranges, opts):
    """Firmware model on the re-timed file; per re-timed stroke (time, int a^2)."""
    n = len(out_ranges)
    t = np.zeros(n)
    a2 = np.zeros(n)
    v2 = np.zeros(n)
    pos = [0]

    def on_line(r):
        k = pos[0]
        while k < n and r.idx > out_ranges[k][1]:
            k += 1
        pos[0] = k
        if k < n and out_ranges[k][0] <= r.idx:
            t[k] += r.time_t
            a2[k] += r.int_a2 + r.int_a2_j
            v2[k] += r.int_v2

    ev = _counted(events(path, profile), opts.progress)
    sim = simulate_events(ev, profile, on_line=on_line)
    return sim, t, a2, v2


# ---------------------------------------------------------------- the job
def process(in_path, out_path, profile: Profile, opts: Options, before_replace=None):
    """Re-time in_path into out_path (may be the same path: atomic replace, see outfile.py).
    Returns the summary dict.  before_replace(in_path, new_path, summary), if given, runs
    while both files still exist (the report compares them); if it raises, nothing is
    replaced.  A file the firmware model sees no move in is not rewritten: the summary
    says "unchanged" (with -o elsewhere, the input is copied there)."""
    from .outfile import AtomicOutput, OutputError, describe
    t_start = time.monotonic()
    size = os.path.getsize(in_path)
    prog = opts.progress
    if prog:
        prog.start("analyse")
    strokes, sim0 = analyse(in_path, profile, opts)
    if sim0.n_moves == 0:
        if prog:
            prog.finish()
        return _unchanged(in_path, out_path, profile, "no moves to re-time")
    pin = plan_inputs(strokes, profile, opts)
    budget_t = opts.max_slowdown_r * sim0.time_t
    try:
        with AtomicOutput(out_path) as out:
            tmp = out.tmp
            # The plan budgets with the segments' predicted times; the firmware model has the
            # last word.  If the written file overruns the budget, plan once more with the
            # overrun taken off (one more rewrite + measure, only then).
            for _ in range(2):
                plan = plan_strokes(strokes, pin, profile, opts, budget_t)
                if prog:
                    prog.start("rewrite")
                try:
                    with open(tmp, "w", encoding="utf-8", errors="surrogateescape", newline="") as fh:
                        out_ranges = rewrite(in_path, fh, strokes, plan, profile, opts)
                        fh.flush()
                        os.fsync(fh.fileno())
                except OSError as e:         # disk full, ulimit -f: say so, keep the input
                    if e.filename not in (None, tmp):
                        raise
                    raise OutputError(describe(e, out_path)) from None
                if prog:
                    prog.start("measure")
                sim1, t1, a21, v21 = measure(tmp, profile, out_ranges, opts)
                over_t = (sim1.time_t - sim0.time_t) - opts.max_slowdown_r * sim0.time_t
                if opts.alpha != "auto" or over_t <= 5e-4 * sim0.time_t:
                    break
                budget_t -= 1.2 * over_t
            from .summary import build_summary
            summary = build_summary(in_path, out_path, tmp, size, profile, opts, strokes, pin, plan, sim0, sim1,
                                    out_ranges, t1, a21, v21, time.monotonic() - t_start)
            if before_replace is not None:
                before_replace(in_path, tmp, summary)
            out.commit()
    finally:
        if prog:
            prog.finish()
    return summary


def _unchanged(in_path, out_path, profile, why):
    """Summary of a file left as it is; with out_path elsewhere the input is copied there."""
    import shutil

    from .outfile import AtomicOutput, OutputError, describe, target_of
    if target_of(out_path) != target_of(in_path):
        with AtomicOutput(out_path) as out:
            try:
                shutil.copyfile(in_path, out.tmp)
            except OSError as e:
                if e.filename not in (None, out.tmp):
                    raise
                raise OutputError(describe(e, out_path)) from None
            out.commit()
    return {"input": in_path, "output": out_path, "profile": profile.name, "flavour": profile.flavour,
            "unchanged": why, "strokes": {"candidates": 0, "retimed": 0, "not_retimed": {}}}
