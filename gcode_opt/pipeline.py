"""The whole job, in three streamed passes over the file.

  1. analyse: read -> machine state -> strokes, with the firmware model playing the
     original file alongside: each stroke learns the speeds the original reaches at its
     ends, its duration and its inertia norm.
  2. plan (in memory, a few numbers per stroke) and rewrite: read again, copy the line
     ranges between re-timed strokes in bulk, byte for byte (no tokenising, no machine
     state: analyse recorded what a block needs at its stroke's start), replace re-timed
     strokes by segments; written to a temporary file in the target's folder, then
     renamed into place.
  3. measure: the firmware model plays the re-timed file; before/after figures come from
     the same model on both files.  It records where it stood empty (after each stop: an
     E-only move, a barrier) with the reader's state there (firmware.simulate.Ledger).
     The ringing figures ride on the passes over both files (ringing.Collector): the
     original's on analyse, the written file's on the last measure pass that played all
     of it (else, after a second pass that played only what changed, a pass of their own).
When the written file overruns the time budget, the budget is re-spent and the file
written once more: blocks whose segment plan did not change are copied from the first
file, and the firmware model plays only the stretches, stop to stop, that hold a block
whose text changed; the rest of its figures are the first pass's (remeasure).
Memory holds a few floats per stroke and per stop, never the file's lines.

One bad stroke never aborts the file: planning and segmenting run vectorised, and a batch
that raises is retried in halves down to the stroke at fault (plan.isolate); a stroke with
a non-finite input, candidate, plan or segment, or whose block raises while it is written
or fails the output validator (validate.py), keeps its original lines, counted by reason
in the summary (strokes.not_retimed, strokes.faults).
"""
from __future__ import annotations

import contextlib
import math
import os
import sys
import time
from array import array
from bisect import bisect_right
from collections import deque
from functools import partial

try:                          # what hashlib.blake2b is; importing hashlib would load OpenSSL (~3.5 MB resident)
    from _blake2 import blake2b as _blake2b
except ImportError:
    from hashlib import blake2b as _blake2b

import numpy as np

from .rss import peak_rss_mb
from .distinct import distinct
from . import vertex_filter
from . import features as feat
from . import emit as emit_mod
from .emit import StrokeText, emit_arc, emit_stroke
from . import state as reader
from .firmware import simulate as fwsim
from .laws import chain as chain_law
from .laws import circle as circle_law
from .outranges import Digests, OutRanges, columns as range_columns
from .firmware.simulate import LineRanges, ReplayMismatch, replay_runs, simulate_file, simulate_ledger
from .profile import Profile
from .schedule import drop_cached, plan_inputs, plan_strokes, segs_for, set_aside_for_rewrite
from .segments import RowPlan, SegmentPlan
from .state import Barrier, MachineState, Move
from .strokes import K_ARC, MIN_FEED_V, NOT_OPEN, Stroke, group_lines, line_spans, put_sums
from .stored_strokes import StoredStrokes, stored_rows
from .stroke_columns import StrokeColumns, first_lines, line_columns
from . import validate as _validate_mod
from .validate import BlockInvalid, Geometry, validate_block
from .words import param_texts, split_comment, strip_checksum


class Options:
    def __init__(self, alpha="auto", features=feat.DEFAULT_SELECTED, overshoot_r=0.25,
                 max_slowdown_r=0.03, max_segments=10, min_length_d=0.2, progress=None, max_turn_deg=30.0,
                 corner_budget_r=0.0):
        self.alpha = alpha                  # "auto" or a float in s^2/kg
        self.features = tuple(features)
        self.overshoot_r = overshoot_r      # allowed peak speed above the slicer's F
        self.max_slowdown_r = max_slowdown_r  # print-time budget, fraction of the whole file
        self.max_segments = max_segments
        self.min_length_d = min_length_d
        self.progress = progress            # Progress or None
        self.max_turn_deg = max_turn_deg    # polyline vertices turning <= this are inside a curve (0: no curves)
        self.reader_warnings = []           # (idx, text) the reader noted in the analyse pass
        self.ringing = True                 # resonance figures before/after in the summary (ringing.py)
        self.ringing_parts = True           # and their ramp / corner / turn parts (the command line: where shown)
        self.summary_rows = True            # per_stroke rows: True a list, "table" a summary.StrokeRows, False none
        self.corner_budget_r = corner_budget_r  # share of max_slowdown slower corners may take (corners.py); 0 off, "auto"
        self.by_feature = None              # analyse: the original's {feature: [moves, time_t, int_a2]}
        self.peak_rss_mb = None             # process: {phase: peak RSS (MB) at its end} (--profile-time)
        self.lines_in = None                # analyse: the input's lines as summary.count_lines counts them, if known
        self.lines_out = None               # measure: the written file's, if the last pass played all of it


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


# ---------------------------------------------------------------- pass 1: analyse
def analyse(path, profile: Profile, opts: Options, store=None):
    """Strokes of the original file with the firmware model's figures for each.

    The model plays each line as it is read, before the strokes see it.  Its records (one
    a moving line, in file order) go to strokes by index ranges: strokes close in file
    order, so a record goes to the oldest closed stroke still due, or waits (early) while
    its line is in the run still open, or belongs to no stroke.  With the compiled model
    the records go into its RecordLog instead (no Python call a record), which sums them
    per stroke and per feature, in the same order (_LogSums: a prefix at a time during the
    pass, the log dropping the records summed, the rest after it).

    store (a stroke_store.StrokeStore, a plan_windows.SpilledInputs, or None): the finished
    strokes are appended to it at each of the log's flushes and dropped (they never all
    exist at once), the rest at the end; returns (store, sim's result) then.  Only with the compiled RecordLog (the Python
    model's records come one by one: the list is kept and appended at the end)."""
    log = _record_log()
    strokes = []
    due = deque()       # closed strokes, in file order, whose last line's record has not come
    early = deque()     # records of lines in the open run (or of one that closed), in file order
    opened = [NOT_OPEN]  # group_lines: first line of the run / arc stroke still open

    split = vertex_filter.splitter(profile) if opts.max_turn_deg > 0 else None
    state = MachineState(profile, path)
    state.warnings = opts.reader_warnings = []     # arcs off their circle, ignored M205 J, ...
    e_before = [0.0]       # logical E before the line the stream is at (the generators are lazy)

    seen = [False]         # a slicer feature comment (";TYPE:", "; FEATURE:", ...) was read
    by_feature = opts.by_feature = {}   # the original's moves, time and int a^2 by feature (summary)
    feat_at = deque()      # (idx, feature) of each move whose feature is not the move's before

    def start_state():
        """What rewrite needs where a run of moves starts (it copies the file without
        re-reading it): E before the line, and the accelerations and cruise ratio in force
        (a G0-G3 line leaves those as they were, so the state after it is the one before)."""
        return e_before[0], state.accel_for(True, True), state.accel_for(False, True), state.lim.mcr

    if type(state).accel_for is MachineState.accel_for and isinstance(getattr(state, "_one_accel", None), bool):
        one_accel = state._one_accel      # the flavour's (fixed for the run): accel_for inlined

        def start_state():        # noqa: F811 -- the same values, fewer calls (one a run of moves)
            a = state.accel_print
            return e_before[0], a, (a if one_accel else state.accel_travel), state.lim.mcr

    def on_stroke(st):
        """A stroke closed: the records of its lines that came already are early's first
        (those before it belong to no stroke)."""
        strokes.append(st)
        if log is not None:       # summed after the pass
            return
        lo, hi = st.first_idx, st.last_idx
        while early and early[0].idx < lo:
            early.popleft()
        got = -1
        while early and early[0].idx <= hi:
            r = early.popleft()
            apply(st, r)
            got = r.idx
        if got < hi:
            due.append(st)

    def apply(st, r):
        i = r.idx
        if i == st.first_idx:
            st.v0 = r.start_v
        if i == st.last_idx:
            st.v1 = r.end_v
        st.time_t += r.time_t
        st.int_a2 += r.int_a2 + r.int_a2_j     # junction halves: vertices of curves, sub-arc ends
        st.int_v2 += r.int_v2

    tally = [NOT_OPEN, None]   # feat_at's first line (NOT_OPEN: none), the totals of the feature before

    def on_line(r):
        i = r.idx
        if i >= tally[0]:
            while feat_at and feat_at[0][0] <= i:
                f = feat_at.popleft()[1]
            tot = by_feature.get(f)
            if tot is None:
                tot = by_feature[f] = [0, 0.0, 0.0]
            tally[0] = feat_at[0][0] if feat_at else NOT_OPEN
            tally[1] = tot
        tot = tally[1]
        tot[0] += 1
        tot[1] += r.time_t
        tot[2] += r.int_a2 + r.int_a2_j
        while due:
            st = due[0]
            if st.last_idx < i:         # its last lines had no record
                due.popleft()
                continue
            if st.first_idx <= i:
                apply(st, r)
                if i == st.last_idx:
                    due.popleft()
            return
        if i >= opened[0]:
            while early and early[0].idx < opened[0]:   # of a run that closed with no stroke
                early.popleft()
            early.append(r)

    records = on_line if log is None else log     # what the model hands each record to
    sums = _LogSums(log, strokes, feat_at, by_feature) if log is not None else None
    ring = None
    opts.ringing_before = None
    if getattr(opts, "ringing", True):
        # the original's ringing rides on this pass (streamed: bounded memory)
        from . import ringing as rg
        ring = rg.Collector(profile, parts=getattr(opts, "ringing_parts", True))
        ring_line, ring_block, ring_dwell = rg.hooks(ring)

        def on_line_both(r):
            records(r)
            ring_line(r)
        sim = fwsim.new_sim(profile, records, ring_block)
        if not getattr(getattr(ring_dwell, "__self__", None), "sim_rests", False):
            # not the compiled model writing the rests into the Collector's sink itself
            # (see ringing.wrap_events): the hooks write them, E-only records through on_line
            sim = fwsim.new_sim(profile, on_line_both, ring_block)
    else:
        sim = fwsim.new_sim(profile, records)

    cur = [[], 0, 0]       # the chunk being read: its lines, the next one's position, the first's idx
    cr_seen = [False]      # the file may hold a "\r" (line_chunks)
    last_f = [None]        # the feature of the last move read

    def read():
        """The file's (idx, raw, event), each played by the model as it is read (what
        simulate_events and, with ringing, ringing.wrap_events do).  Read in chunks (as
        read_chunks reads them: the progress told a chunk at a time); a line read is
        cur[1]'s, which group_lines' fast (the model's run_lines) moves past the lines it
        reads itself (those are not yielded: the moves of a run's common lines, played)."""
        step = state.step
        move, barrier = sim.move, sim.barrier
        prog = opts.progress.advance if opts.progress is not None else None
        for idx0, lines in reader.line_chunks(path, prog, cr_seen):
            if sums is not None and log.rows >= LOG_FLUSH_ROWS:
                sums.flush(opened[0])
                if store is not None:
                    _spill_finished(store, strokes, sums)
            cur[0], cur[2] = lines, idx0
            n = len(lines)
            i = cur[1] = 0
            while i < n:
                cur[1] = i + 1
                raw = lines[i]
                idx = idx0 + i
                e_before[0] = state.e
                if not seen[0] and raw.lstrip()[:1] == ";" and feat.feature_from_comment(raw) is not None:
                    seen[0] = True
                ev = step(idx, raw)
                cls = type(ev)
                if cls is Move:
                    if ev.feature != last_f[0]:
                        last_f[0] = f = ev.feature
                        if not feat_at:
                            tally[0] = idx
                        feat_at.append((idx, f))
                    move(ev)
                elif cls is Barrier:
                    barrier(ev)
                    if ring is not None:
                        ring_dwell(ev.dwell_t)
                yield idx, raw, ev
                i = cur[1]

    # the compiled model reads a run's common lines itself (Sim.run_lines: the reader's
    # fused loop, its records into the RecordLog), and the lines between runs that change
    # nothing but the model (Sim.gap_lines): no Python a line there
    fast = gap = None
    if log is not None and hasattr(sim, "run_lines"):
        fast = partial(sim.run_lines, cur, state.step)
        gap = partial(sim.gap_lines, cur, state.step, last_f, frozenset(opts.features), "travel", MIN_FEED_V,
                      feat_at)
    # the pass makes no reference cycles a line: the cyclic collector would only walk the
    # strokes it keeps (~50 k objects on the gyroid plate, ~0.05 s of the pass); it runs
    # again, as before, once the strokes are made
    import gc
    collecting = gc.isenabled()
    gc.disable()
    try:
        for _ in group_lines(read(), opts.features, strokes.append if log is not None else on_stroke,
                         opts.min_length_d, opts.max_turn_deg, split,
                             start_state, opened, fast, gap):
            pass
    finally:
        if collecting:
            gc.enable()
    sim.stop()
    # the lines read are the lines summary.count_lines would count again where no "\r" ends one
    opts.lines_in = None if cr_seen[0] else cur[2] + len(cur[0])
    if log is not None:
        sums.finish()
    if ring is not None:
        opts.ringing_before = ring.figures()
    # (state.feature_seen: a feature comment the compiled reader read, also in its own loops)
    opts.feature_info = feat.selection_info(seen[0] or state.feature_seen is True, opts.features)
    if store is not None:
        store.append(strokes)
        strokes.clear()
        return store, sim.res
    return strokes, sim.res


def _spill_finished(store, strokes, sums):
    """The strokes whose sums are final (sums.done) appended to store and dropped from the
    list, but the last one closed, as a guard: group_lines gives a stroke closed by a line
    that is no event its next_u at the next event (a summed stroke has a later move's
    record, so that event came already; the tests find no stroke where it matters)."""
    k = min(sums.done, len(strokes) - 1)
    if k > 0:
        store.append(strokes[:k])
        del strokes[:k]
        sums.done -= k


def spill_analyse():
    """GCODE_OPT_SPILL_ANALYSE=1: analyse spills its finished strokes to a StrokeStore window
    by window (its peak holds no stroke list), and _process loads them back for planning
    (the same bits; a measurement of the windowed pipeline's first step, benchmarks/win51)."""
    return os.environ.get("GCODE_OPT_SPILL_ANALYSE", "") not in ("", "0")


def _analysed(in_path, profile, opts, freeze, timing, store=None):
    """analyse's (strokes, sim's result), its phase lapped; with spill_analyse() through a
    StrokeStore (the strokes loaded back after the lap: planning's phase).  store (the
    windowed pipeline's): the strokes spilled to it and left there, (store, sim's result)."""
    if store is not None:
        with _young_frozen(freeze):
            got = analyse(in_path, profile, opts, store)
        timing.lap("analyse")
        return got
    if not spill_analyse():
        with _young_frozen(freeze):      # (analyse leaves the collector off then: its strokes are frozen)
            got = analyse(in_path, profile, opts)
        timing.lap("analyse")
        return got
    from .stroke_store import StrokeStore
    with StrokeStore() as store:
        with _young_frozen(freeze):
            store, res = analyse(in_path, profile, opts, store)
        timing.lap("analyse")
        with _young_frozen(freeze):      # (load makes them with the collector paused; frozen as analyse's)
            return store.load(0, len(store)), res


def _record_log():
    """The compiled model's RecordLog for the analyse pass, or None (the Python model, or a
    core without it: analyse's per-record on_line then)."""
    if fwsim.CORE != "c" or not hasattr(fwsim._core, "RecordLog"):
        return None
    return fwsim._core.RecordLog()


LOG_FLUSH_ROWS = 1 << 15     # records the RecordLog gathers before analyse sums and drops them


class _LogSums:
    """What analyse's on_line and apply() do record by record, from the RecordLog: each
    stroke's v0 (the record at its first line), v1 (at its last line) and its records'
    time, int a^2 and int v^2 summed in file order; the feature tally (feat_at: (line,
    feature) where the moves' feature changes) per feature, in the order the features'
    first records came (by_feature is filled in that order, as on_line fills it).

    Taken a prefix of the records at a time during the pass (flush), which the log then
    drops: it holds a few thousand records, not the whole file's (~48 bytes a record: 21 MB
    on the 461 k-line gyroid plate).  A stroke's sums are its own records' from 0.0, and
    the feature sums go on in the same accumulators in file order: the same bits as one
    pass over the whole log after the file (finish)."""

    def __init__(self, log, strokes, feat_at, by_feature):
        self.log, self.strokes, self.feat_at, self.by_feature = log, strokes, feat_at, by_feature
        self.done = 0          # strokes[:done] have their sums
        self.last_hi = -1      # the last of those's last line
        self.dropped = 0       # records summed (features) and dropped from the log
        self.ids = {}          # feature -> its number, in feat_at's order
        # feat_at's entries taken so far (taken out of it) from the one in force at the log's
        # first record on: their lines, their feature numbers (int64: feature_sums reads them
        # as they are, not copied into arrays each flush)
        self.starts, self.fid = array("q"), array("q")
        nf = 8
        self.count, self.first = np.zeros(nf, np.int64), np.full(nf, -1, np.int64)
        self.ft, self.fa2 = np.zeros(nf), np.zeros(nf)

    def flush(self, open_line):
        """Sum what the records so far settle, drop those records.  open_line: the first
        line of the run or arc stroke still open (NOT_OPEN if none).  Records of lines
        before the log's last record's line have all come (file order); a stroke that
        ends before that and before open_line gets its sums; the records before the first
        line of every stroke still to come or to sum are tallied by feature and dropped."""
        log = self.log
        line = min(open_line, log.last)
        rest = self.strokes[self.done:]       # the closed strokes without their sums, in file order
        lo, hi = line_spans(rest)
        self._file_order(lo, hi, self.last_hi)
        k = int(np.searchsorted(hi, line))    # those that end before line (hi rises: file order)
        self._strokes(self.done + k, (lo[:k], hi[:k]))
        if k < len(rest):
            line = min(line, int(lo[k]))
        self._features(log.below(line), line)

    def finish(self):
        """The rest, after the pass: every stroke, every record."""
        self._strokes(len(self.strokes))
        self._features(self.log.rows)
        ft, fa2, count, first = self.ft, self.fa2, self.count, self.first
        feats = list(self.ids)
        for k in sorted((k for k in range(len(feats)) if first[k] >= 0), key=lambda k: first[k]):
            self.by_feature[feats[k]] = [int(count[k]), float(ft[k]), float(fa2[k])]

    def _strokes(self, stop, spans=None):
        """strokes[done:stop]'s sums from the log (all their records are in it); spans:
        their line_spans if known (flush's, checked in file order)."""
        batch = self.strokes[self.done:stop]
        n = len(batch)
        if not n:
            return
        if spans is None:
            lo, hi = spans = line_spans(batch)
            self._file_order(lo, hi, self.last_hi)
        lo, hi = spans
        self.done, self.last_hi = stop, int(hi[-1])
        got = np.zeros(n, np.int64)
        v0, v1, t, a2, v2 = (np.zeros(n) for _ in range(5))
        self.log.stroke_sums(lo, hi, got, v0, v1, t, a2, v2)
        put_sums(batch, got, v0, v1, t, a2, v2)

    @staticmethod
    def _file_order(lo, hi, last_hi):
        """Strokes' line spans (line_spans) are in file order after the line last_hi, or
        AssertionError: group_lines closes them in order, _strokes sums them so."""
        if len(lo) and not (np.all(hi >= lo) and np.all(lo[1:] > hi[:-1]) and lo[0] > last_hi):
            raise AssertionError("strokes out of file order")

    def _features(self, rows, line=None):
        """The first rows records added to the feature tally, then dropped from the log.
        line, if given: every record left is of this line or later (flush's cut), so the
        feature changes before the one in force at it are looked up no more and go."""
        if not rows:
            return
        feat_at, ids, fid, starts = self.feat_at, self.ids, self.fid, self.starts
        if feat_at:               # its new entries (analyse's read and gap_lines append to it)
            lines, feats = zip(*feat_at)
            feat_at.clear()
            for f in dict.fromkeys(feats):     # new features numbered in the order they came
                ids.setdefault(f, len(ids))
            # (the int64s joined as bytes, np.fromiter's: array("q").extend parses each int,
            # ~0.25 k instructions more an entry, ~20 k changes of feature on the rectilinear plate)
            starts.frombytes(np.fromiter(lines, np.int64, len(lines)).tobytes())
            fid.frombytes(np.fromiter(map(ids.__getitem__, feats), np.int64, len(feats)).tobytes())
        nf = len(ids)
        if nf > len(self.count):           # more features: the sums so far kept as they are
            grow = max(nf, 2 * len(self.count)) - len(self.count)
            self.count = np.concatenate((self.count, np.zeros(grow, np.int64)))
            self.first = np.concatenate((self.first, np.full(grow, -1, np.int64)))
            self.ft = np.concatenate((self.ft, np.zeros(grow)))
            self.fa2 = np.concatenate((self.fa2, np.zeros(grow)))
        first = np.full(len(self.count), -1, np.int64)     # positions in this prefix
        self.log.feature_sums(starts, fid, self.count, self.ft, self.fa2, first, rows)
        new = (self.first < 0) & (first >= 0)
        self.first[new] = first[new] + self.dropped
        self.log.drop(rows)
        self.dropped += rows
        if line is not None:
            k = bisect_right(starts, line) - 1      # the change in force at line (-1: none yet)
            if k > 0:
                del starts[:k], fid[:k]


def _apply_log(log, strokes, feat_at, by_feature):
    """_LogSums over the whole log at once (the strokes' and the feature sums)."""
    _LogSums(log, strokes, feat_at, by_feature).finish()


# ---------------------------------------------------------------- pass 2: rewrite
def rewrite(path, out_fh, strokes, plan, profile: Profile, opts: Options, digests=None, reuse=None):
    """Copy the file to out_fh, re-timed strokes replaced.  Returns the output line
    range of each re-timed stroke: an OutRanges of (out_first, out_last, stroke_index).

    Each block is validated (validate.py) before it is written; a block whose emission
    raises or fails validation is replaced by the stroke's original lines, and the
    stroke counted with the reason (plan.retime/plan.reason updated).  `digests` (a
    Digests, or a dict), if given, receives a digest of each written block's text by stroke index (a second
    pass re-measures only the blocks whose text changed).  `reuse` (a _Reuse of the first
    pass's file) gives the blocks whose segment plan is the one the first pass wrote: they
    are copied from that file, not emitted and validated again.

    With the compiled rewrite core and a binary file under out_fh, the file is copied as
    bytes (_rewrite_bytes: untouched line ranges as they are, a line stroke's block read,
    written and checked by one call of the core); else line by line as text (_rewrite_text).
    The same bytes either way: the file is read as UTF-8 with surrogateescape, which gives
    back every byte as it was."""
    core = emit_mod.CORE_MOD
    raw = getattr(out_fh, "buffer", None)
    if core is None or not hasattr(core, "stroke_block") or raw is None:
        return _rewrite_text(path, out_fh, strokes, plan, profile, opts, digests, reuse)
    return _rewrite_bytes(path, out_fh, raw, core, strokes, plan, profile, opts, digests, reuse)


_CHUNK = 1 << 20


def _HEAD_TEXT(begin, n_lines, kind, n_segs, t, t_was, beta, svl):
    """The head line of a line stroke's block (_block_header's text) with svl after it."""
    return (f"{begin}: replaces {n_lines} lines, kind={kind}, {n_segs} segments, "
            f"T={t:.4f}s (was {t_was:.4f}s), "
            f"beta={f'{beta:.4g}' if math.isfinite(beta) else 'inf'}s^2\n{svl}")


class _ByteLines:
    """The input read as bytes, a chunk at a time, and cut into lines as the text reading
    (newline="") cuts them: "\\n", "\\r\\n" and a lone "\\r" end a line.  A chunk never ends
    in the "\\r" of a "\\r\\n" (one more byte is read), so a line end is never split."""

    def __init__(self, fh, skip):
        self.fh, self.skip = fh, skip
        self.data = b""
        self.pos = 0
        self.eof = False
        self.seek = fh.seekable()

    def _read(self):
        chunk = self.fh.read(_CHUNK)
        while chunk.endswith(b"\r"):
            more = self.fh.read(1)
            if not more:
                break
            chunk += more
        if not chunk:
            self.eof = True
        return chunk

    def drop(self, n):
        """Pass over the next n lines (fewer at the end of the file): copy() writing nothing."""
        while n > 0:
            self.pos, got = self.skip(self.data, self.pos, n, self.eof)
            n -= got
            if n > 0:
                if self.eof:
                    return
                self.data, self.pos = self._read(), 0

    def copy(self, n, write):
        """Write the next n lines (fewer at the end of the file).  A line cut by the end of
        a chunk is written in two pieces."""
        while n > 0:
            end, got = self.skip(self.data, self.pos, n, self.eof)
            if end > self.pos:
                write(self.data[self.pos:end] if self.pos or end < len(self.data) else self.data)
            self.pos = end
            n -= got
            if n > 0:
                if self.eof:
                    return
                self.data, self.pos = self._read(), 0

    def take(self, n):
        """(data, start, stop, got): the next n lines are data[start:stop], got of them
        (fewer at the end of the file)."""
        while True:
            end, got = self.skip(self.data, self.pos, n, self.eof)
            if got == n or self.eof:
                start, self.pos = self.pos, end
                return self.data, start, end, got
            if self.pos and self.seek:
                # the lines from pos on are read again with the next chunk (a seek back)
                # rather than copied and joined to it (two copies of a chunk)
                self.fh.seek(self.pos - len(self.data), 1)
                self.data, self.pos = self._read(), 0
            else:
                self.data, self.pos = self.data[self.pos:] + self._read(), 0

    def copy_take(self, n_copy, n, write):
        """copy(n_copy, write) then take(n), in one call (the same pieces written, the same
        (data, start, stop, got))."""
        if n_copy:
            self.copy(n_copy, write)
        end, got = self.skip(self.data, self.pos, n, self.eof)
        if got == n or self.eof:
            start, self.pos = self.pos, end
            return self.data, start, end, got
        return self.take(n)

    def rest(self, write):
        if self.pos < len(self.data):
            write(self.data[self.pos:])
        self.data, self.pos = b"", 0
        while not self.eof:
            chunk = self.fh.read(_CHUNK)
            if not chunk:
                break
            write(chunk)


def _rewrite_bytes(path, out_fh, raw, core, strokes, plan, profile, opts, digests, reuse):
    """rewrite() on bytes.  A line stroke (not an arc) whose lines are all plain "G1 X Y [E]"
    lines ending in "\\n" has its block written and validated by core.stroke_block; any
    other stroke, or one the core declines, takes the Python path (_stroke_text,
    _stroke_block, _validate on the lines as text), as _rewrite_text does.  A run of such
    line strokes goes through one call of core.stroke_run (the same per stroke, its
    attribute reads, head, closing, out_ranges row and digest made in C) until the first
    stroke it does not take, which the loop below takes."""
    import io
    import types
    # sorted(flatnonzero(retime), key=first_idx) in rows (a stable sort: the same order, numpy ints)
    sel = np.flatnonzero(plan.retime)
    order = sel[np.argsort(first_lines(strokes)[sel], kind="stable")]
    # strokes kept in a StrokeStore: the re-timed rows' strokes made a window at a time,
    # indexed as the list's (held.slots); a list: itself, one window
    held = stored_rows(strokes)
    objs, win_ends = (strokes, [len(order)]) if held is None else (held.slots, held.ends(order))
    out_ranges = OutRanges()
    # the core's rows go straight into out_ranges' three array('q') columns (no tuple a row)
    run_rows = (out_ranges.first, out_ranges.last, out_ranges.stroke)
    run_digests = digests if digests is None or type(digests) is dict else {}    # (the core fills a dict)
    out_line = 0
    pos = 0                       # next line of the input to copy
    out_fh.flush()                # (nothing is buffered: the bytes go after what was written)
    write = raw.write
    # the one-call path, unless a piece of the Python path is replaced (the tests' injected
    # faults and recordings) or the core is switched off for validation
    block = core.stroke_block
    if (_stroke_block is not _STROKE_BLOCK or _validate is not _VALIDATE or _stroke_text is not _STROKE_TEXT
            or validate_block is not _VALIDATE_BLOCK or _validate_mod._FAST_BODY is None):
        block = None
    flavour = profile.flavour
    max_accel_a = profile.max_accel_a
    min_move_d = getattr(profile, "min_move_d", 0.0)
    limit = _validate_mod.MAX_CMD_BYTES.get(flavour, 0)
    klipper = flavour == "klipper"
    plain_word = flavour in ("klipper", "marlin-legacy")
    ctx = {ex: ("M204 S" if plain_word else ("M204 P" if ex else "M204 T"),
                "S" if plain_word else ("P" if ex else "T"), klipper, limit, float(min_move_d))
           for ex in (True, False)}
    svl = "SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=0\n" if klipper else ""
    head_spec = emit_mod.BEGIN == "; gcode-opt begin"     # the core's head text (else the text made here)
    closing_text = emit_mod._closing_text
    segs, betas = plan.segs, plan.beta
    beta_list = betas.tolist() if isinstance(betas, np.ndarray) else list(betas)   # Python floats: the same texts
    isfinite = math.isfinite
    travel = feat.TRAVEL
    begin = emit_mod.BEGIN
    blake2b = _blake2b
    seg_type = SegmentPlan
    stroke_type = Stroke
    # the whole run of line strokes in one call of the core (stroke_run: the loop below's
    # one-call path, stroke after stroke, into one buffer): it stops at a stroke it does
    # not take (an arc, a block it declines, lines past the chunk read, ...), which the
    # loop below then takes as before, and goes on after it
    # (not through a stand-in for the core: the tests' counting wrappers see each stroke_block)
    run = getattr(core, "stroke_run", None) if _STROKE_RUN and isinstance(core, types.ModuleType) else None
    if (block is None or reuse is not None or not head_spec or type(max_accel_a) is not float
            or type(segs) is not list or type(objs) is not list):
        run = None
    n_order = len(order)
    k = k_end = w = 0             # k_end: the end (in order) of the window held
    k_order = order
    empty_digest = blake2b(digest_size=16)       # (stroke_run: its copy updated with a block)
    with open(path, "rb") as fh, np.errstate(all="ignore"):
        src = _ByteLines(fh, core.skip_lines)
        copy_take = src.copy_take
        skip = core.skip_lines
        while k < n_order:
            if k >= k_end:            # the next window's strokes (the run stops at its end)
                k_end, w = win_ends[w], w + 1
                _window_ready(held, plan, order[k:k_end], objs)
                k_order = order if k_end == n_order else order[:k_end]
            if run is not None:
                try:
                    k, src.pos, pos, out_line = run(
                        src.data, src.pos, pos, k_order, k, out_line, run_rows, objs, segs, beta_list, stroke_type,
                        (seg_type, RowPlan), K_ARC, travel, closing_text, flavour, svl, ctx[False], ctx[True],
                        max_accel_a, run_digests, empty_digest, write)
                finally:
                    if run_digests is not digests:
                        digests.take(run_digests)
                if k >= k_end:
                    continue
            i = order[k]
            k += 1
            s = objs[i]
            first_idx = s.first_idx
            n_copy = first_idx - pos
            if n_copy < 0:        # overlapping strokes cannot happen: keep the original
                plan.retime[i], plan.segs[i], plan.reason[i] = False, None, "error: emission (overlap)"
                continue
            # untouched lines: copied as they are, in bulk (no tokenising, no state); then
            # the stroke's own lines
            n_take = s.last_idx - first_idx + 1
            # copy_take's common case inline: both line runs inside the chunk read (the same
            # pieces written, the same (data, a, z, n_lines)); else copy_take itself
            data, a = src.data, src.pos
            end, got = skip(data, a, n_copy, False)
            if got == n_copy:
                z, n_lines = skip(data, end, n_take, False)
                if n_lines == n_take:
                    if end > a:
                        write(data[a:end] if a or end < len(data) else data)
                    src.pos = z
                    a = end
                else:
                    data, a, z, n_lines = copy_take(n_copy, n_take, write)
            else:
                data, a, z, n_lines = copy_take(n_copy, n_take, write)
            out_line += n_copy
            pos = first_idx + n_lines
            x0, y0 = s.x0, s.y0
            if reuse is not None:
                text = reuse.block(i, segs[i], betas[i])
                if text is not None:  # the first pass wrote this very block (and validated it)
                    write(text.encode("utf-8", "surrogateescape"))
                    if digests is not None:
                        digests[i] = reuse.digests[i]
                    n_out = text.count("\n")
                    out_ranges.append((out_line, out_line + n_out - 1, i))
                    out_line += n_out
                    continue
            got = None
            if block is not None and s.kind != K_ARC and n_lines:
                try:
                    seg = segs[i]
                    if type(s) is stroke_type:    # (start_state's and ends_d's slots, not the properties)
                        e0, accel0, mcr0 = s._ss_e, s._ss_a, s._ss_c
                        if e0 is None:
                            raise TypeError("no start state")
                        ends = s._ends
                        if ends is None:          # one move: ends_d's (length_d,), as a list (no array made)
                            ends = [s.length_d]
                    else:
                        e0, accel0, mcr0 = s.start_state
                        ends = s.ends_d
                    beta = beta_list[i]
                    extruding = s.feature != travel
                    if type(seg) is seg_type:      # (its fields, not through the properties)
                        knots, seg_a, seg_f, fc = seg._s, seg._accel, seg._feed, seg.first_cmds
                    else:
                        knots, seg_a, seg_f, fc = seg.s, seg.accel, seg.feed, getattr(seg, "first_cmds", None)
                    # _block_header's text, as it writes it, made by the core from these
                    # (_HEAD_TEXT, the f-string it stands for), and the start's texts too
                    # (x0_text, y0_text None: f"{x0:.8f}", f"{y0:.8f}")
                    head = (s.kind, len(knots) - 1, seg.time_t, s.time_t, beta, svl) if head_spec else (
                        _HEAD_TEXT(begin, n_lines, s.kind, len(knots) - 1, seg.time_t, s.time_t, beta, svl))
                    before = after = None
                    if fc and len(knots) >= 2:
                        before, after = fc[0] + "\n", fc[1] + "\n"
                    got = block(data, a, z, n_lines, head,
                                closing_text(flavour, accel0, extruding, mcr0, s.v_feed, "\n"), before, after,
                                None, None, x0, y0, e0, knots, seg_a, seg_f, ends, s.e_rel,
                                extruding, ctx[extruding],
                                max(max_accel_a, accel0) if isfinite(accel0) else max_accel_a)
                except Exception:     # noqa: BLE001 -- the Python path below says what
                    got = None
            if got is not None:
                write(got)
                if digests is not None:
                    digests[i] = blake2b(got, digest_size=16).digest()
                n_out = got.count(b"\n")
                out_ranges.append((out_line, out_line + n_out - 1, i))
                out_line += n_out
                continue
            # the Python path, on the lines as text (as _rewrite_text reads them)
            buf = list(io.StringIO(data[a:z].decode("utf-8", "surrogateescape"), newline=""))
            text = _python_block(s, buf, plan, i, profile)
            if text is None:
                plan.retime[i] = False
                plan.segs[i] = None
                write(data[a:z])
                out_line += n_lines
            else:
                write(text.encode("utf-8", "surrogateescape"))
                if digests is not None:
                    digests[i] = _digest(text)
                n_out = text.count("\n")
                out_ranges.append((out_line, out_line + n_out - 1, i))
                out_line += n_out
        src.rest(write)               # the rest of the file, in bulk
    return out_ranges


def _rewrite_text(path, out_fh, strokes, plan, profile: Profile, opts: Options, digests=None, reuse=None):
    """rewrite() line by line on text (the code before _rewrite_bytes): without the compiled
    core (GCODE_OPT_PURE_PYTHON), or into a text stream without a binary file under it."""
    from itertools import islice
    held = stored_rows(strokes)
    if held is None:
        order = sorted(np.flatnonzero(plan.retime), key=lambda i: strokes[i].first_idx)
        objs, win_ends = strokes, [len(order)]
    else:                         # (as _rewrite_bytes: the re-timed rows made a window at a time)
        order = sorted(np.flatnonzero(plan.retime), key=first_lines(strokes).__getitem__)
        objs, win_ends = held.slots, held.ends(order)
    k_end = w = 0
    out_ranges = OutRanges()
    out_line = 0
    pos = 0                       # next line of the input to copy
    with open(path, "r", encoding="utf-8", errors="surrogateescape", newline="") as fh, np.errstate(all="ignore"):
        lines = iter(fh)
        write = out_fh.write
        for k, i in enumerate(order):
            if k >= k_end:        # the next window's strokes
                k_end, w = win_ends[w], w + 1
                _window_ready(held, plan, order[k:k_end], objs)
            s = objs[i]
            n_copy = s.first_idx - pos
            if n_copy < 0:        # overlapping strokes cannot happen: keep the original
                plan.retime[i], plan.segs[i], plan.reason[i] = False, None, "error: emission (overlap)"
                continue
            # untouched lines: copied as they are, in bulk (no tokenising, no state)
            out_fh.writelines(islice(lines, n_copy))
            out_line += n_copy
            buf = list(islice(lines, s.n_moves))
            pos = s.first_idx + len(buf)
            text = None if reuse is None else reuse.block(i, plan.segs[i], plan.beta[i])
            if text is not None:  # the first pass wrote this very block (and validated it)
                write(text)
                if digests is not None:
                    digests[i] = reuse.digests[i]
                n_out = text.count("\n")
                out_ranges.append((out_line, out_line + n_out - 1, i))
                out_line += n_out
                continue
            # (numpy's warnings are off around the whole loop: errstate costs more than a block)
            text = _python_block(s, buf, plan, i, profile)
            if text is None:
                plan.retime[i] = False
                plan.segs[i] = None
                write("".join(buf))
                out_line += len(buf)
            else:
                write(text)
                if digests is not None:
                    digests[i] = _digest(text)
                n_out = text.count("\n")
                out_ranges.append((out_line, out_line + n_out - 1, i))
                out_line += n_out
        for chunk in iter(lambda: fh.read(1 << 20), ""):   # the rest of the file, in bulk
            write(chunk)
    return out_ranges


def _window_ready(held, plan, rows, objs):
    """The rewrite's next window: its strokes rows held (held: a HeldRows; None: the list,
    every stroke in objs already) and their segment plans made again where a windowed run
    let them go (segs_for).  With held, the collector is off meanwhile and what is then
    alive frozen after (_young_frozen with the pipeline's freeze): the plans read back
    hold no cycle (the gyroid plate's ~16 k chains' RowPlans), and the young collections
    walked each of them two or three times."""
    if held is None:
        segs_for(plan, rows, objs)
        return
    with _young_frozen(held.freeze):
        held.hold(rows)
        segs_for(plan, rows, objs)      # (a windowed run's plans let go: made again)


class _Reuse:
    """The blocks a first rewrite wrote, read back from its file in order: block(i, seg,
    beta) is stroke i's text if the first pass wrote it from this same segment plan (the
    same object, which schedule's SegmentCache hands back when a line's law is unchanged,
    or the same numbers) and beta, else None.  The text is a function of the stroke, its plan and
    beta only (_stroke_block)."""

    def __init__(self, path, out_ranges, segs, beta, digests):
        self.fh = open(path, "r", encoding="utf-8", errors="surrogateescape", newline="")
        self.lines = enumerate(self.fh)
        self.pos = -1
        self.blocks = {i: (a, z, segs[i], float(beta[i])) for a, z, i in out_ranges}
        self.digests = digests

    @staticmethod
    def _same_plan(a, b):
        """The same segment plan: the same object, or (arcs and curves are solved in batches,
        so a re-plan makes new objects) the same numbers, bit for bit, in every field the
        emitter reads."""
        if a is b:
            return True
        if a is None or b is None or type(a) is not type(b) or a.time_t != b.time_t:
            return False
        for f in ("s", "v", "accel", "feed"):
            x, y = getattr(a, f, None), getattr(b, f, None)
            if (x is None) != (y is None):
                return False
            if x is None:
                continue
            if type(x) is type(y) is np.ndarray:
                # the same bits (a byte compare: ~10x quicker than array_equal on these short
                # rows, and stricter: -0.0 against 0.0 is written anew, not taken for it)
                if x.dtype != y.dtype or x.shape != y.shape or x.tobytes() != y.tobytes():
                    return False
            elif not np.array_equal(x, y):
                return False
        return True

    def block(self, i, seg, beta):
        got = self.blocks.get(i)
        if got is None or not self._same_plan(got[2], seg):
            return None
        a, z, _, beta1 = got
        if not (beta1 == beta or (math.isinf(beta1) and math.isinf(beta))) or a <= self.pos:
            return None
        from itertools import islice
        for self.pos, _ in self.lines:
            if self.pos >= a - 1:
                break
        if self.pos != a - 1:
            return None
        text = "".join(raw for _, raw in islice(self.lines, z - a + 1))
        self.pos = z
        return text

    def close(self):
        self.fh.close()


def _digest(text):
    return _blake2b(text.encode("utf-8", "surrogateescape"), digest_size=16).digest()


def block_digests(path, out_ranges, n):
    """The Digests rewrite gives the blocks of the file it wrote (out_ranges: its blocks'
    lines, in file order), read back from that file: each block's bytes are the ones
    written (the lines cut as the rewrite and _Reuse cut them: "\\n", "\\r\\n", a lone
    "\\r"), so each digest is the one rewrite would have made.  The first pass leaves them
    to this (only a second pass compares blocks): ~0.2 G instructions of blake2b on the
    gyroid plate that a run of one pass does not need."""
    digests = Digests(n)
    blake2b = _blake2b
    core = emit_mod.CORE_MOD
    if core is None or not hasattr(core, "skip_lines"):
        with open(path, "r", encoding="utf-8", errors="surrogateescape", newline="") as fh:
            lines = enumerate(fh)
            for a, z, i in out_ranges:
                text = []
                for k, raw in lines:
                    if k >= a:
                        text.append(raw)
                        if k >= z:
                            break
                digests[i] = _digest("".join(text))
        return digests
    pos = 0
    with open(path, "rb") as fh:
        src = _ByteLines(fh, core.skip_lines)
        for a, z, i in out_ranges:
            src.drop(a - pos)
            data, start, stop, _ = src.take(z - a + 1)
            digests[i] = blake2b(memoryview(data)[start:stop], digest_size=16).digest()
            pos = z + 1
    return digests


def _validate(text, s, raws, x0, y0, accel0, profile, parsed=None):
    """validate.py on one block; the path and the filament are the original's own (its raw
    X/Y/E words; `parsed`, the emitter's StrokeText of the same lines, saves reading them
    twice)."""
    pts = [(x0, y0)]
    e_words = []
    geometry = None
    if parsed is not None and parsed.values is not None and s.kind != K_ARC:
        # every line has its own X and Y (emit._plain_moves): their values, read there
        xs, ys, e_words = parsed.values
        geometry = Geometry.polyline([float(x0)] + xs, [float(y0)] + ys)
    elif parsed is not None:
        x_start, y_start = parsed.x_start_text, parsed.y_start_text
        for xt, yt, et, has_e in zip(parsed.x_texts, parsed.y_texts, parsed.e_texts, parsed.e_given):
            # a line without X keeps the text before it: the start's (x0 itself) or a word's
            pts.append((x0 if xt is x_start else float(xt), y0 if yt is y_start else float(yt)))
            if has_e:
                e_words.append(float(et))
    else:
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
    if geometry is None:
        geometry = Geometry([pts[0], pts[-1]] if arc else pts, arc)
    validate_block(text, profile.flavour, accel_max_a, geometry,
                   extruding=extruding, kind=s.kind, e_check=e_check,
                   min_move_d=getattr(profile, "min_move_d", 0.0))


def _stroke_block(s, raws, seg, beta, x0, y0, e0, accel0, mcr0, profile, parsed=None):
    """G-code text replacing one stroke, from its segment plan `seg`.  The header names
    the kind (line, curve, arc) after "replaces N lines" (verify.py and the report read it)."""
    dec = 8
    if s.kind == K_ARC:
        header = _block_header(s, len(raws), "sub-arcs", seg, beta)
        return emit_arc(raws[0], f"{x0:.{dec}f}", f"{y0:.{dec}f}", e0, s.arc, seg.s, seg.accel, seg.feed,
                        e_rel=s.e_rel, flavour=profile.flavour, accel_restore=accel0, mcr_restore=mcr0,
                        feed_restore_v=s.v_feed, header=header)
    st_text = parsed if parsed is not None else _stroke_text(raws, x0, y0)
    st_text.e_start_units = int(round(e0 * 10 ** st_text.dec_e))
    header = _block_header(s, len(raws), "segments", seg, beta)
    # the start's text as _stroke_text wrote it (the same f"{x0:.8f}")
    return emit_stroke(st_text, s.ends_d, seg.s, seg.v, seg.accel, seg.feed, x0_text=st_text.x_start_text,
                       y0_text=st_text.y_start_text, e_rel=s.e_rel, flavour=profile.flavour, accel_restore=accel0,
                       mcr_restore=mcr0, feed_restore_v=s.v_feed, extruding=s.feature != feat.TRAVEL,
                       header=header, first_cmds=getattr(seg, "first_cmds", None))


def _block_header(s, n_lines, pieces, seg, beta):
    """The block header after BEGIN: what it replaces, the kind (verify.py and the report
    read it), the pieces, the times and beta."""
    beta_txt = "inf" if not math.isfinite(beta) else f"{beta:.4g}"
    return (f": replaces {n_lines} lines, kind={s.kind}, {len(seg.s) - 1} {pieces}, T={seg.time_t:.4f}s "
            f"(was {s.time_t:.4f}s), beta={beta_txt}s^2")


def _python_block(s, buf, plan, i, profile):
    """One stroke's block by the Python path (emitter and validator on its lines as text),
    or None with the reason in plan.reason[i]: this stroke's failure only."""
    x0, y0 = s.x0, s.y0
    try:
        e0, accel0, mcr0 = s.start_state     # recorded by analyse (group_strokes)
        # the original lines read once, for the emitter and the validator
        parsed = None if s.kind == K_ARC else _stroke_text(buf, x0, y0)
        text = _stroke_block(s, buf, plan.segs[i], plan.beta[i], x0, y0, e0, accel0, mcr0, profile, parsed)
        _validate(text, s, buf, x0, y0, accel0, profile, parsed)
        return text
    except BlockInvalid as e:
        plan.reason[i] = str(e)
    except Exception as e:        # noqa: BLE001 -- this stroke's failure only
        plan.reason[i] = f"error: emission ({type(e).__name__})"
    return None


def _stroke_text(raws, x0, y0):
    """The emitter's reading of a stroke's original lines (StrokeText), start point
    written with 8 decimals as _stroke_block writes it."""
    return StrokeText(raws, f"{x0:.8f}", f"{y0:.8f}", 0)


# the Python path's pieces as this module defines them: _rewrite_bytes takes its one-call
# path only while they are these (a test that replaces one sees every block go through it)
_STROKE_BLOCK, _VALIDATE, _STROKE_TEXT, _VALIDATE_BLOCK = _stroke_block, _validate, _stroke_text, validate_block
# _rewrite_bytes runs the core's stroke_run over the strokes it takes (False: the loop
# calls stroke_block stroke by stroke, as before; the tests compare the two)
_STROKE_RUN = True


# ---------------------------------------------------------------- pass 3: measure
def _per_stroke(out_ranges, t, a2, v2):
    """on_line for the firmware model on a re-timed file: each line's record added to the
    re-timed stroke (out_ranges, in file order) whose block holds the line.  The records
    come in file order: the stroke being played is summed in floats (the same additions in
    the same order as into t[k], a2[k], v2[k]) and written out when the records leave it;
    call on_line.flush() after the pass for the last one."""
    n = len(out_ranges)
    if type(out_ranges) is OutRanges:
        first_of, last_of = out_ranges.first, out_ranges.last
    else:
        first_of, last_of = [r[0] for r in out_ranges], [r[1] for r in out_ranges]
    k, lo, hi = 0, -1, -1          # the stroke the records are at, its output lines
    live = False                   # a record was added to it
    s_t = s_a2 = s_v2 = 0.0

    def flush():
        nonlocal live
        if live:
            t[k], a2[k], v2[k] = s_t, s_a2, s_v2
            live = False

    def on_line(r):
        nonlocal k, lo, hi, live, s_t, s_a2, s_v2
        i = r.idx
        if i > hi:
            if live:
                t[k], a2[k], v2[k] = s_t, s_a2, s_v2
                live = False
            while k < n and i > last_of[k]:
                k += 1
            if k >= n:
                lo = hi = NOT_OPEN
                return
            lo, hi = first_of[k], last_of[k]
            s_t = s_a2 = s_v2 = 0.0
        if lo <= i:
            live = True
            s_t += r.time_t
            s_a2 += r.int_a2 + r.int_a2_j
            s_v2 += r.int_v2
    on_line.flush = flush
    return on_line


def _stroke_sums(out_ranges, t, a2, v2, also=None):
    """_per_stroke as the compiled core's StrokeSums (the same sums, in C, no LineRecord
    made unless also(rec) is given), or None where the Python model plays."""
    if fwsim.CORE != "c" or not hasattr(fwsim._core, "StrokeSums"):
        return None
    lo, hi, _ = range_columns(out_ranges)
    return fwsim._core.StrokeSums(lo, hi, t, a2, v2, also)


def measure(path, profile, out_ranges, opts, watch=None, ring=None):
    """Firmware model on the re-timed file; per re-timed stroke (time, int a^2, int v^2).
    With `watch` (every stroke's output lines, sorted), also the Ledger a second pass
    re-measures from (remeasure); else None.  `ring`, a ringing.Collector, rides on the
    pass (the written file's ringing without a pass of its own).  With the compiled core
    the file is read in chunks and played in C (Sim.play), the per-stroke sums too."""
    n = len(out_ranges)
    t, a2, v2 = np.zeros(n), np.zeros(n), np.zeros(n)
    ring_line = on_block = on_dwell = None
    if ring is not None:
        from . import ringing as rg
        ring_line, on_block, on_dwell = rg.hooks(ring)
    # a compiled Sim writes a RowSink's rests itself: the sink's line() does nothing then
    sink_rests = on_block is not None and type(on_block) is getattr(fwsim._core, "RowSink", None)
    on_line = per_stroke = _stroke_sums(out_ranges, t, a2, v2, None if sink_rests else ring_line)
    progress = opts.progress.advance if opts.progress is not None else None
    if per_stroke is None:
        per_stroke = _per_stroke(out_ranges, t, a2, v2)
        if ring_line is None:
            on_line = per_stroke
        else:
            def on_line(r, _a=per_stroke, _b=ring_line):
                _a(r)
                _b(r)
    opts.lines_out = None
    counted = partial(setattr, opts, "lines_out")    # the written file's lines, where the pass counts them
    if watch is None:
        sim = simulate_file(path, profile, on_line=on_line, on_block=on_block, on_barrier=on_dwell,
                            progress=progress, on_count=counted)
        per_stroke.flush()
        return sim, t, a2, v2, None
    sim, led = simulate_ledger(path, profile, watch, on_line=on_line, on_block=on_block,
                               on_barrier=on_dwell, progress=progress, on_count=counted)
    per_stroke.flush()
    return sim, t, a2, v2, led


def _first_line_order(strokes):
    """The strokes' indices by first line, a stable sort (sorted(range(n), key=first_idx)'s
    order), as an array of int64 (its items read as ints: a list of ints took ~36 bytes a
    stroke, 1.4 MB on the gyroid plate, 8 here).  Only measure reads it: made once the first
    plan is written, not held through planning (0.28 MB on the gyroid plate, 0.42 on the
    rectilinear, at planning's peak).  strokes: their StrokeColumns, or the list."""
    return array("q", np.argsort(line_columns(strokes)[0], kind="stable").astype(np.int64).tobytes())


def stroke_lines(strokes, order, out_ranges):
    """First and last output line of every stroke (arrays by stroke index): a re-timed
    stroke's block, or its original lines where they were copied.  None if the ranges are
    not in file order (then nothing can be re-measured in part).

    In rows (numpy, int64): the offset output line - input line before each stroke of
    `order` is the sum of the re-timed ones' line changes before it; the same figures and
    the same refusals as _stroke_lines_loop, which takes the odd inputs (a stroke twice in
    out_ranges, an index out of range, no strokes).  strokes: their StrokeColumns, or the
    list."""
    n, m = len(strokes), len(order)
    if not n or not m:
        return _stroke_lines_loop(strokes, order, out_ranges)
    ra, rz, ri = range_columns(out_ranges)
    o = np.asarray(order, np.int64)
    if (len(ri) and (ri.min() < 0 or ri.max() >= n or len(distinct(ri)) != len(ri))) or o.min() < 0 or o.max() >= n:
        return _stroke_lines_loop(strokes, order, out_ranges)
    lo, hi = line_columns(strokes)
    fi, li = lo[o], hi[o]
    block_a, block_z = np.full(n, -1, np.int64), np.zeros(n, np.int64)
    has = np.zeros(n, bool)
    block_a[ri], block_z[ri], has[ri] = ra, rz, True
    h, ba, bz = has[o], block_a[o], block_z[o]
    delta = np.where(h, (bz - ba) - (li - fi), 0)
    off = np.cumsum(delta) - delta                 # the loop's off when it reaches each stroke
    a = np.where(h, ba, fi + off)
    z = np.where(h, bz, li + off)
    prev = np.empty(m, np.int64)
    prev[0], prev[1:] = -1, z[:-1]
    if np.any(h & (ba != fi + off)) or np.any(a <= prev) or np.any(z < a):
        return None
    first, last = np.zeros(n, np.int64), np.zeros(n, np.int64)
    first[o], last[o] = a, z
    return first, last


def lines_by_stroke(watch, order, n):
    """stroke_lines' (first, last) of n strokes again, from the LineRanges made of them at
    `order` (_first_line_order's): the same int64 arrays."""
    o = np.frombuffer(order, np.int64) if isinstance(order, array) else np.asarray(order, np.int64)
    first, last = np.zeros(n, np.int64), np.zeros(n, np.int64)
    first[o] = np.frombuffer(watch.first, np.int64)
    last[o] = np.frombuffer(watch.last, np.int64)
    return first, last


def _stroke_lines_loop(strokes, order, out_ranges):
    """stroke_lines stroke by stroke (the code before the rows; the tests' reference), on
    the strokes' first and last lines (line_columns) as ints."""
    n = len(strokes)
    first, last = np.zeros(n, np.int64), np.zeros(n, np.int64)
    block = {i: (a, z) for a, z, i in out_ranges}
    lo, hi = (c.tolist() for c in line_columns(strokes))
    off = 0                   # output line - input line, between blocks
    prev_last = -1
    for i in order:
        fi, li = lo[i], hi[i]
        r = block.get(i)
        if r is None:
            a, z = fi + off, li + off
        else:
            a, z = r
            if a != fi + off:
                return None
            off += (z - a) - (li - fi)
        if a <= prev_last or z < a:
            return None
        first[i], last[i], prev_last = a, z, z
    return first, last


LAZY_DIGESTS = True      # tests turn it off: the first pass makes its blocks' digests as it writes them

LAST_REMEASURE = {}      # what the last remeasure played (lines of the first pass's file): for the benchmark


def remeasure(path, profile, strokes, order, led, lines1, lines2, changed, out_ranges1, fig1, out_ranges2, opts):
    """The firmware model on a second rewrite that differs from the first only in the
    strokes `changed` (bool by stroke index): each changed stroke's stretch, from the stop
    before it to the stop after it, is played again (firmware.simulate.replay_runs); the
    rest of the figures are the first pass's.  Returns what measure returns, or None when
    the files do not line up as the ledger says (the caller then measures the whole file).
    strokes: their StrokeColumns (not read: the lines and the ledger say it all)."""
    if not led.ok or len(led.lo) != len(order) or len(led.hi) != len(order):
        return None
    first1, last1 = lines1
    first2, last2 = lines2
    # runs of ledger stretches holding a changed stroke (order = the ledger's watch order)
    runs = []                 # [lo, hi, delta lines]
    for w, i in enumerate(order):
        if not changed[i]:
            continue
        lo, hi = led.lo[w], led.hi[w]
        d = int((last2[i] - first2[i]) - (last1[i] - first1[i]))
        if runs and lo < runs[-1][1]:
            runs[-1][1] = max(runs[-1][1], hi)
            runs[-1][2] += d
        else:
            runs.append([lo, hi, d])
    # every stroke outside the runs must sit where the first pass had it, shifted by the
    # runs before it
    r, off = 0, 0
    for w, i in enumerate(order):
        while r < len(runs) and led.lo[w] >= runs[r][1]:
            off += runs[r][2]
            r += 1
        if r < len(runs) and runs[r][0] <= led.lo[w] and led.hi[w] <= runs[r][1]:
            continue
        if changed[i] or first2[i] - first1[i] != off or last2[i] - last1[i] != off:
            return None
    spans, off = [], 0
    for lo, hi, d in runs:
        spans.append((lo, hi, led.line[lo] + 1 + off, led.line[hi] + off + d))
        off += d
    n = len(out_ranges2)
    t, a2, v2 = np.zeros(n), np.zeros(n), np.zeros(n)
    try:
        per_stroke = _stroke_sums(out_ranges2, t, a2, v2) or _per_stroke(out_ranges2, t, a2, v2)
        sim, played = replay_runs(path, profile, led, spans, on_line=per_stroke)
        per_stroke.flush()
    except ReplayMismatch:
        return None
    LAST_REMEASURE["played_lines"] = sum(led.line[hi] - led.line[lo] for lo, hi in played)
    # the strokes outside the stretches played keep the first pass's figures
    k1 = {i: k for k, (_, _, i) in enumerate(out_ranges1)}
    pos = {i: w for w, i in enumerate(order)}
    los = np.array([lo for lo, _ in played], np.int64)
    his = np.array([hi for _, hi in played], np.int64)
    for k, (_, _, i) in enumerate(out_ranges2):
        w = pos[i]
        r = int(np.searchsorted(his, led.hi[w]))     # the first stretch ending at or after it
        if r < len(his) and los[r] <= led.lo[w]:
            continue
        j = k1.get(i)
        if j is None:
            return None
        t[k], a2[k], v2[k] = fig1[0][j], fig1[1][j], fig1[2][j]
    return sim, t, a2, v2, led


# ---------------------------------------------------------------- the job
def process(in_path, out_path, profile: Profile, opts: Options, before_replace=None):
    """Re-time in_path into out_path (may be the same path: atomic replace, see outfile.py).
    Returns the summary dict.  before_replace(in_path, new_path, summary), if given, runs
    while both files still exist (the report compares them); if it raises, nothing is
    replaced.  A file the firmware model sees no move in is not rewritten: the summary
    says "unchanged" (with -o elsewhere, the input is copied there).

    OpenBLAS runs on one thread for the whole job: its calls here are many small ones
    (the circle law's 32 x 32 solves, the chains' small products), where a second thread
    only adds synchronisation (~2x their CPU) and takes the core the slicer may need;
    the results are the same bits (blas.py)."""
    from .blas import blas_one_thread
    with blas_one_thread(), _strokes_frozen() as freeze:
        return _process(in_path, out_path, profile, opts, before_replace, freeze)


@contextlib.contextmanager
def _strokes_frozen():
    """Yields freeze(): called once the strokes are built (and again after planning's inputs,
    after each plan and after the summary's rows), it moves every object then alive (the strokes, the
    modules) out of the garbage collector's view until the job ends.
    The passes after analyse make and drop many short-lived containers; each full
    collection they trigger walked the ~10^6 long-lived objects again (gyroid plate: GC
    0.24 -> 0.14 s CPU).  Frozen objects are still freed by their reference counts; only
    a cycle among them waits for the unfreeze.  Left alone when the caller froze objects
    already (gc.unfreeze would thaw those too).  freeze() may be called again: each call
    freezes what is alive then (see _young_frozen)."""
    import gc
    mine = gc.get_freeze_count() == 0
    done = []

    def freeze():
        if mine:
            gc.freeze()
            done.append(True)
    try:
        yield freeze
    finally:
        if done:
            gc.unfreeze()


@contextlib.contextmanager
def _young_frozen(freeze):
    """The collector off for a stretch that makes many objects that live on and no cycles
    (analyse's strokes, planning's tables and segment plans, the summary's rows), then freeze() (_strokes_frozen) before it is
    on again: the objects made while it was off are all in the youngest generation, and
    the first collection after it walked them all (~0.06 s after analyse, ~0.015 s after
    the summary on the rectilinear plate).  Without freeze (None) nothing is changed."""
    import gc
    off = freeze is not None and gc.isenabled()
    if off:
        gc.disable()
    try:
        yield
    finally:
        if off:
            freeze()
            gc.enable()


def _process(in_path, out_path, profile: Profile, opts: Options, before_replace=None, freeze=None):
    """The job on the strokes as a list (the default), or with GCODE_OPT_WINDOWED=1 kept in a
    StrokeStore and read a window at a time (plan_windows: a StoredStrokes, which the passes
    below index and iterate as they do the list)."""
    from .plan_windows import window_size
    window = window_size()
    if window is None or _corners_on(opts):
        summary = _process_strokes(in_path, out_path, profile, opts, before_replace, freeze)
    else:
        from .stroke_store import StrokeStore
        # the spill beside the output, as its temporary file: on the output's disk, not in a
        # /tmp that may be tmpfs (RAM the process's RSS does not show)
        with StrokeStore(folder=os.path.dirname(os.path.abspath(out_path))) as store:
            summary = _process_strokes(in_path, out_path, profile, opts, before_replace, freeze, store, window)
    # the passes' and the summary's freed arrays (~12 MB of heap on the rectilinear plate,
    # windowed): the summary's writing (--json, --report) grows on live memory only
    trim_heap()
    return summary


def _corners_on(opts):
    """--corners asked for (a share, or "auto"): the job then takes the list path even
    when windowed.  Slower corners pair each stroke with its neighbour across the whole
    file (corners.lower_corners' junctions) and the runs change strokes in place
    (schedule._own_lead_out clears a stroke's corner_cmd1), which a window's decoded
    copies would forget: the windowed runs then segmented the same lead-outs over and
    over (prusa_gyroid_fullspeed, --corners 0.3, window 37: not done after 100 s of CPU)."""
    r = getattr(opts, "corner_budget_r", 0.0) or 0.0
    return r == "auto" or float(r) > 0.0


def _planned(strokes, profile, opts, freeze, window):
    """(PlanInput, the strokes planning reads): plan_inputs of the list, or (strokes a
    StrokeStore) plan_windows.planned_strokes: its StoredStrokes, the candidates made."""
    if window is None:
        with _young_frozen(freeze):      # (planning's ~10^5 containers live on, with no cycles)
            return plan_inputs(strokes, profile, opts), strokes
    from .plan_windows import planned_strokes
    with _young_frozen(freeze):
        got = planned_strokes(strokes, profile, opts, window)
    got[1].freeze = freeze        # (the rewrite's strokes frozen as they are made: stored_strokes.HeldRows)
    trim_heap()                   # (the candidates' transients: the runs grow on live memory only)
    return got


def _process_strokes(in_path, out_path, profile, opts, before_replace=None, freeze=None, store=None, window=None):
    from .outfile import AtomicOutput, OutputError, describe
    t_start = time.monotonic()
    timing = _Timing()
    size = os.path.getsize(in_path)
    prog = opts.progress
    if prog:
        prog.start("analyse")
    if store is not None:     # (analyse makes the plan inputs of the strokes as it spills them)
        from .plan_windows import SpilledInputs, window_fixed
        store = SpilledInputs(store, profile, opts, window, adapt=not window_fixed())
    strokes, sim0 = _analysed(in_path, profile, opts, freeze, timing, store)
    if sim0.n_moves == 0:
        if prog:
            prog.finish()
        return _unchanged(in_path, out_path, profile, "no moves to re-time")
    pin, strokes = _planned(strokes, profile, opts, freeze, window)
    timing.lap("plan")
    budget_t = opts.max_slowdown_r * sim0.time_t
    try:
        with AtomicOutput(out_path) as out:
            tmp = out.tmp
            # The plan budgets with the segments' predicted times; the firmware model has the
            # last word.  If the written file overruns the budget, plan once more with the
            # overrun taken off (one more rewrite; the firmware model plays again only the
            # stretches around the blocks that changed: remeasure).
            order = None              # the strokes by first line (_first_line_order): made after the first plan
            cols = None               # the strokes' StrokeColumns, what the steps after planning read
            first = None              # the first pass: _FirstPass
            restore = plan = None     # restore: strokes the second pass puts back to their lines, the plan kept
            for pass_i in range(2):
                # the collector off while planning (~135 young collections a run walked the
                # plans for ~300 objects of garbage) and the plan's objects frozen after it:
                # rewrite's collections walked them too (rectilinear plate: ~0.03 s)
                if restore is not None:
                    plan = _restored(plan, pin, restore)
                else:
                    with _young_frozen(freeze):
                        plan = plan_strokes(strokes, pin, profile, opts, budget_t)
                    set_aside_for_rewrite(pin, os.path.dirname(tmp) or None, last=pass_i == 1)
                    if type(strokes) is StoredStrokes:      # (the chains' memos' rows: a re-plan reads them back)
                        strokes.set_aside_memos(os.path.dirname(tmp) or None)
                trim_heap()           # planning's freed temporaries: rewrite and measure grow on live memory only
                timing.lap("plan")
                if prog:
                    prog.start("rewrite")
                # the blocks' digests: only a second pass compares them (the first pass's
                # are read back from its file when a second pass comes: block_digests)
                digests = None if first is None and LAZY_DIGESTS else Digests(len(strokes))
                # a second pass copies the blocks it shares with the first from the first's
                # file, so it writes beside it and then takes its place
                dest = tmp if first is None else tmp + ".pass2"
                reuse = None
                try:
                    if first is not None:
                        if first.digests is None:
                            first.digests = block_digests(tmp, first.out_ranges, len(strokes))
                        reuse = _Reuse(tmp, first.out_ranges, first.segs, first.beta, first.digests)
                    with open(dest, "w", encoding="utf-8", errors="surrogateescape", newline="") as fh:
                        out_ranges = rewrite(in_path, fh, strokes, plan, profile, opts, digests, reuse)
                        fh.flush()
                        os.fsync(fh.fileno())
                    if reuse is not None:
                        reuse.close()
                        os.replace(dest, tmp)
                except OSError as e:         # disk full, ulimit -f: say so, keep the input
                    if e.filename not in (None, tmp, dest):
                        raise
                    raise OutputError(describe(e, out_path)) from None
                finally:
                    if reuse is not None:
                        reuse.close()
                        if os.path.exists(dest):
                            os.unlink(dest)
                timing.lap("rewrite")
                # the curve geometry is planning's alone: measure peaks above planning with
                # it still held (~9 MB on the gyroid plate); a re-plan rebuilds it in one
                # batch (schedule._rebuild_geometry, the same bits)
                if type(strokes) is list:       # (a StoredStrokes' windows were let go by the rewrite)
                    for st in strokes:
                        st.curv = None
                trim_heap()
                if prog:
                    prog.start("measure")
                if order is None:
                    cols = StrokeColumns(strokes, fields=False)     # (the summary's fields: after the passes)
                    order = _first_line_order(cols)
                lines = stroke_lines(cols, order, out_ranges)
                trim_heap()           # (its temporaries, ~5 MB on the rectilinear plate: measure grows on live memory)
                got = None
                opts.lines_out = None     # (measure counts the written file's lines; a remeasure does not)
                if first is not None and first.lines is not None and lines is not None and first.led is not None:
                    changed = (np.asarray(plan.retime, bool) != np.asarray(first.retime, bool)) | digests.differ(first.digests)
                    got = remeasure(tmp, profile, cols, order, first.led, first.lines, lines, changed,
                                    first.out_ranges, first.figures, out_ranges, opts)
                ring_after = None     # the written file's ringing, when this pass played all of it
                if got is None:
                    # (as LineRanges: two int64 arrays, not ~52 k tuples held through measure)
                    watch = None if lines is None or pass_i else LineRanges.of_rows(lines[0][order],
                                                                                   lines[1][order])
                    if watch is not None:
                        lines = None  # (held through measure as the watch alone: ~0.8 MB on the rectilinear plate)
                    ring = _ring_collector(profile, opts)
                    got = measure(tmp, profile, out_ranges, opts, watch, ring)
                    ring_after = ring
                    ring = None       # a second pass's remeasure must not keep this one's buffers
                    if watch is not None:
                        lines, watch = lines_by_stroke(watch, order, len(cols)), None
                sim1, t1, a21, v21, led = got
                first = _FirstPass(plan, digests, lines, out_ranges, (t1, a21, v21), led)
                timing.lap("measure")
                timing.passes += 1
                over_t = (sim1.time_t - sim0.time_t) - opts.max_slowdown_r * sim0.time_t
                departed = _departures(plan, out_ranges, t1)
                if departed:               # the firmware would not play these as planned: keep them as sliced
                    failed = pin.cached[2]
                    for i in departed:
                        failed[i] = "firmware model departs from the plan"
                    # what putting them back to their lines gives back; where that alone brings the
                    # file within the budget (or the laws are fixed: a re-plan would make the same
                    # plans), the plan stands without them: no re-plan, the other blocks copied
                    over_t -= _departed_excess_t(pin, out_ranges, t1, departed)
                    if opts.alpha != "auto" or over_t <= 5e-4 * sim0.time_t:
                        restore = departed
                        continue
                elif opts.alpha != "auto" or over_t <= 5e-4 * sim0.time_t:
                    break
                if over_t > 0.0:
                    budget_t -= 1.2 * over_t
            # what only the passes needed (the passes' ledgers, output lines, line order and
            # digests, the segment plans and their cache, the candidate tables, the strokes
            # themselves: the summary reads their columns, cols) goes before the summary is
            # built (rectilinear plate, windowed: ~5 MB of the ledger and the lines alone)
            first = got = led = lines = order = watch = digests = changed = None
            plan.segs = None
            pin.seg_cache = None
            drop_cached(pin)
            # the written file's ringing first: its Collector's buffers (~3 MB on the
            # rectilinear plate) go before the summary's columns are made
            ringing, ringing_error = _ringing_after(tmp, profile, opts, ring_after, in_path)
            ring_after = None
            timing.lap("ringing")
            trim_heap()               # (first: the summary's columns grow on live memory only)
            cols.add_fields(strokes)  # (final: corners.py set v0 / v1 in plan_inputs, nothing since)
            strokes = None            # (their curve geometry and chains' plans with them)
            trim_heap()
            from .summary import build_summary
            with _young_frozen(freeze):      # (~70 k rows' dicts: frozen, not walked by the next collection)
                summary = build_summary(in_path, out_path, tmp, size, profile, opts, cols, pin, plan, sim0,
                                        sim1, out_ranges, t1, a21, v21, time.monotonic() - t_start, ringing=ringing)
            if ringing_error:
                summary["ringing_error"] = ringing_error
            timing.lap("summary")
            summary["timing_s"] = timing.as_dict()
            summary["firmware_core"] = fwsim.CORE     # "c" or "python": which firmware model played
            summary["reader_core"] = reader.CORE      # and which reader read the common lines
            summary["chain_core"] = chain_law.CORE    # and which code solved the chains' Newton steps
            summary["emit_core"] = emit_mod.CORE      # and which code read, wrote and checked the blocks
            summary["curve_core"] = circle_law.CORE   # and which code ran the circle law's iteration and curve kernels
            opts.peak_rss_mb = dict(timing.peak_mb)       # --profile-time prints it (not in the JSON)
            summary["rewrite_passes"] = timing.passes
            summary["warnings"] = _warnings_json(opts.reader_warnings)
            if before_replace is not None:
                # what only the summary read goes before the hook (the report plays both files
                # again: gyroid plate, list path, ~17 MB less under its peak)
                pin = plan = cols = sim0 = sim1 = out_ranges = t1 = a21 = v21 = ringing = None
                trim_heap()
                before_replace(in_path, tmp, summary)
            out.commit()
    finally:
        if prog:
            prog.finish()
    return summary


def _ring_collector(profile, opts):
    """A ringing Collector to ride on a full measure pass, or None (--no-ringing, or the
    original's figures failed: then the written file's are not wanted either)."""
    if getattr(opts, "ringing_before", None) is None:
        return None
    from . import ringing as rg
    return rg.Collector(profile, parts=getattr(opts, "ringing_parts", True))


def _ringing_after(written, profile, opts, ring=None, original=None):
    """(before, after) ringing figures, or None: the original's came with the analyse pass;
    the written file's came with the last measure pass if it played the whole file (`ring`,
    its Collector), else (a second pass played only the stretches that changed) they take
    one more firmware-model pass, unless the written file is the original byte for byte.
    A failure costs the figures, never the output."""
    before = getattr(opts, "ringing_before", None)
    if before is None:
        return None, None
    try:
        if ring is not None:
            return (before, ring.figures()), None
        if original is not None and same_bytes(original, written):
            return (before, before), None
        from . import ringing as rg
        return (before, rg.figures(written, profile, parts=getattr(opts, "ringing_parts", True))), None
    except Exception as e:          # noqa: BLE001 - the G-code output comes first
        return None, f"{type(e).__name__}: {e}"


def same_bytes(a, b):
    """Two files with the same bytes (sizes first: a re-timed file seldom keeps its size)."""
    import filecmp
    return os.path.getsize(a) == os.path.getsize(b) and filecmp.cmp(a, b, shallow=False)


class _FirstPass:
    """What the second pass reuses of the first: which strokes it re-timed with which
    segment plan and beta, the digests of its blocks, every stroke's output lines, the
    re-timed strokes' output ranges and firmware-model figures, and the model's Ledger."""

    def __init__(self, plan, digests, lines, out_ranges, figures, led):
        # the plan's own arrays, not copies (~0.9 MB on the rectilinear plate, made at its
        # measure's peak): nothing changes a plan once written -- a second pass makes a new
        # one (plan_strokes, or _restored's copy)
        self.retime, self.segs, self.beta = plan.retime, plan.segs, plan.beta
        self.digests, self.lines, self.out_ranges, self.figures, self.led = digests, lines, out_ranges, figures, led


DEPART_R, DEPART_T = 1.5, 0.05     # a re-timed stroke the model plays > 1.5 x its plan + 50 ms


def _departures(plan, out_ranges, t1):
    """Strokes whose measured time in the written file is far from their plan's: the
    segments did not make the firmware follow the law (seen on a purge line whose first
    segment's acceleration the firmware could not use).  In rows where both are float64
    arrays (the same double operations on the same values as the loop)."""
    t_pred = plan.t_pred
    n = len(out_ranges)
    if (n and type(t_pred) is np.ndarray and type(t1) is np.ndarray and t_pred.dtype == np.float64
            and t1.dtype == np.float64 and t1.ndim == 1 and len(t1) >= n):
        ii = range_columns(out_ranges)[2]
        hit = np.flatnonzero(t1[:n] > DEPART_R * t_pred[ii] + DEPART_T)
        return ii[hit].tolist()
    return [i for k, (_, _, i) in enumerate(out_ranges)
            if t1[k] > DEPART_R * t_pred[i] + DEPART_T]



def _departed_excess_t(pin, out_ranges, t1, departed):
    """The time (s) the firmware model played the departed strokes (stroke indices) beyond
    their original lines' time: what keeping them as sliced gives back."""
    ii = range_columns(out_ranges)[2]
    at = {int(i): k for k, i in enumerate(ii.tolist())}
    return float(sum(t1[at[i]] - pin.T_orig[i] for i in departed if i in at))


def _restored(plan, pin, rows):
    """A copy of plan (segment plans and predictions included) with the strokes `rows` left
    as sliced, each with its reason from the failed strokes (pin.cached[2], where _process
    put it).  The first
    pass's plan stays as it was written: the second pass compares against it."""
    from .schedule import _as_sliced
    new = plan.copy()
    new.segs = list(plan.segs)
    new.t_pred, new.a2_pred = plan.t_pred.copy(), plan.a2_pred.copy()
    failed = pin.cached[2]
    for i in rows:
        _as_sliced(new, pin, i, failed[i])
    return new


class _Timing:
    """CPU seconds per phase of process() (summary["timing_s"]): analyse = read + machine
    state + strokes + firmware model on the original (one stream); plan; rewrite; measure =
    firmware model on the output; summary.  A re-plan adds to plan, rewrite and measure
    (summary["rewrite_passes"] counts the rewrite+measure passes)."""

    PHASES = ("analyse", "plan", "rewrite", "measure", "ringing", "summary")

    def __init__(self):
        self.t = dict.fromkeys(self.PHASES, 0.0)
        self.peak_mb = {}          # the process's peak RSS (MB) at the end of each phase
        self.passes = 0
        self._t0 = self._last = time.process_time()

    def lap(self, phase):
        now = time.process_time()
        self.t[phase] += now - self._last
        self._last = now
        self.peak_mb[phase] = peak_rss_mb()

    def as_dict(self):
        d = dict(self.t)
        d["total"] = self._last - self._t0
        return d


def trim_heap():
    """Give the C heap's free pages back to the system (glibc malloc_trim): planning frees
    tens of MB of numpy arrays in the middle of the heap, which glibc keeps, and rewrite,
    measure and the summary would grow the peak on top of them (rectilinear plate: RSS
    before the summary 324 -> 289 MB).  Elsewhere (no glibc) a no-op."""
    try:
        import ctypes
        libc = ctypes.CDLL(None)
        trim = libc.malloc_trim
    except (OSError, AttributeError):
        return
    trim(0)


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


MAX_WARNINGS = 100


def _warnings_json(warnings):
    """The reader's warnings for the summary: the first MAX_WARNINGS as {line, text}, and the count."""
    return {"count": len(warnings),
            "first": [{"line": idx + 1, "text": text} for idx, text in warnings[:MAX_WARNINGS]]}
