"""The analyse pass's common lines in C (issue 8): pipeline.analyse reading a run's
continuing lines (the model's Sim.run_lines) and the lines between runs (Sim.gap_lines)
through the compiled reader's fused session, with strokes.group_lines' fast and gap hooks,
must give what the code it replaced gave, bit for bit: every stroke slot, the model's
sums, the feature tally, the reader's warnings, the ringing figures.  The reference below
is that code as it was (commit ddecd40: pipeline.analyse and strokes.group_lines),
renamed, not imported; it reads line by line through step() and sim.move()."""
from __future__ import annotations

import math
import os
import random
from collections import deque

import pytest

from gcode_opt import features as feat
from gcode_opt import pipeline as pl
from gcode_opt import state as reader
from gcode_opt import vertex_filter
from gcode_opt.firmware import simulate as fwsim
from gcode_opt.profile import load_profile
from gcode_opt.state import ARC, LINE, Barrier, MachineState, Move
from gcode_opt.strokes import (COLLINEAR_SIN, NOT_OPEN, Stroke, _direction, _kind_state, _straight_parts, _unit,
                               eligible, eligible_arc)
from test_speed_analyse import _bits, _sim_bits, _stroke_bits

SAMPLES = "sample_gcode/"
_CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus/")
COMPILED = fwsim.CORE == "c" and reader._C_STEP is not None and hasattr(fwsim._core, "RecordLog")


# ---------------------------------------------------------------- the reference (ddecd40, verbatim)
def _ref_group_lines(event_iter, selected, on_stroke, min_length_d: float = 0.0, max_turn_deg: float = 0.0,
                split_vertex=None, start_state=None, opened=None):
    """group_strokes without the tagged items: yields the (idx, raw, event) triples on
    unchanged and hands each stroke to on_stroke(stroke) as it closes (before the triple of
    the line that closed it; the last ones after the last triple).  opened, a one-item
    list if given, holds the first line of the run or arc stroke still open (NOT_OPEN if
    none): a line before it is either in a stroke already handed over or in none.

    The common line, a G1 continuing the open run, is tested first and least: the run's
    feed, acceleration, feature, Z and E mode are its first move's (equality carries along
    the run), the last move's direction and the run's length are kept as it grows."""
    selected = frozenset(selected)
    curves = max_turn_deg > 0.0
    min_cos = math.cos(math.radians(max_turn_deg)) if curves else 2.0
    hypot = math.hypot
    run = []               # moves of the open run
    run_len = 0.0          # their XY lengths summed, in order (as Stroke sums them: no stroke of the run is longer)
    run_ends = []          # run_len after each move
    run_xy = []            # the run's start and every move's end, x y x y ... (Stroke._curve's)
    r_epm = 0.0            # the first move's E per mm or a larger one's (Stroke._curve's)
    ld = 0.0               # XY length of the run's last move
    turned = False         # a vertex of the run is not collinear (a curve if curves are on)
    run_prev_u = None      # direction of the move before the run
    arc = None             # an arc stroke waiting to close (at the next line)
    last_u = None          # direction of the last move; None after a stop
    waiting = None         # closed stroke still waiting for the next move's direction
    run_start = None       # start_state() where the open run began
    r_v = r_accel = r_feature = r_z = r_erel = r_travel = None   # the open run's (first move's)
    r_last = -2            # idx of the run's last move
    pm, lux, luy = None, 0.0, 0.0   # the run's last move and its direction
    # split_vertex.short_bounds(lim, accel, min_cos) (vertex_filter.splitter): the segment
    # lengths at which split_vertex is proven False, kept for one (limits, acceleration)
    f_bounds = getattr(split_vertex, "short_bounds", None)
    f_lim, f_accel, f_lo, f_hi = None, None, 1.0, 0.0     # (a run of another acceleration clears f_lim)
    coll = COLLINEAR_SIN
    if opened is None:
        opened = [NOT_OPEN]
    else:
        opened[0] = NOT_OPEN

    def close(next_u_known, next_u):
        """Hand over the strokes of the open run / arc; the last one's next_u as given (or
        waiting); returns the last one handed over (None if none)."""
        nonlocal run, arc
        out = []
        if arc is not None:
            out = [arc]
            arc = None
        elif run and min_length_d > 0.0 and run_len < min_length_d:
            run = []          # every stroke of it would be dropped: build none (most runs of gyroid)
        elif run:
            if curves and turned and len(run) >= 3:
                parts = [(0, Stroke(run[0])._curve(run, run_xy, run_ends, r_epm))]
            elif len(run) == 1:
                parts = [(0, Stroke(run[0]))]
            else:
                parts = _straight_parts(run)
            e_k, k_done = (run_start[0] if run_start else 0.0), 0
            if len(parts) == 1:           # the loop below for one stroke (most runs)
                st = parts[0][1]
                st._pux, st._puy = (None, None) if run_prev_u is None else run_prev_u    # prev_u
                if run_start is not None:
                    st.start_state = _kind_state(st, e_k, run_start)
                out.append(st)
            else:
                for j, (k0, st) in enumerate(parts):
                    st.prev_u = run_prev_u if k0 == 0 else _unit(run[k0 - 1])
                    if j + 1 < len(parts):
                        st.next_u = _unit(run[parts[j + 1][0]])
                    if run_start is not None:
                        for m in run[k_done:k0]:      # the reader's own sum, in its order
                            e_k += m.e
                        k_done = k0
                        st.start_state = _kind_state(st, e_k, run_start)
                    out.append(st)
            run = []
        opened[0] = NOT_OPEN
        out = [st for st in out if st.length_d >= min_length_d]
        if out and next_u_known:
            out[-1].next_u = next_u
        for st in out:
            on_stroke(st)
        return out[-1] if out else None

    for idx, raw, ev in event_iter:
        cls = type(ev)
        if run and cls is Move:
            # a G1 continuing the run (the next line; the feed, acceleration, feature, Z
            # and E mode of the move before) and eligible() itself, less what
            # equality with the run's first move already proves (feature selected, feed
            # >= MIN_FEED_V, z0 == z1)
            if (ev.idx == r_last + 1 and ev.v == r_v and ev.accel == r_accel and ev.feature == r_feature
                    and ev.z0 == r_z and ev.z1 == r_z and ev.e_rel == r_erel and ev.kind == LINE
                    and not ev.checksum and not ev.xyz_rel and not ev.inch and ev.speed_r == 1.0
                    and (ev.x1 != ev.x0 or ev.y1 != ev.y0) and (ev.e > 0.0 or (ev.e == 0.0 and r_travel))):
                x1, y1 = ev.x1, ev.y1
                dx, dy = x1 - ev.x0, y1 - ev.y0
                d = hypot(dx, dy)
                ux, uy = dx / d, dy / d         # _unit(ev); (lux, luy) is _unit(pm)
                dot = lux * ux + luy * uy
                cross = lux * uy - luy * ux
                if -coll <= cross <= coll and dot > 0.0:      # collinear: |cross| <= COLLINEAR_SIN
                    take = True
                elif dot >= min_cos:
                    if split_vertex is None:
                        take = turned = True
                    else:
                        if ev.lim is not f_lim:        # (rarely) other limits or acceleration
                            f_lim, f_accel = ev.lim, r_accel
                            f_lo, f_hi = f_bounds(f_lim, f_accel, min_cos) if f_bounds else (1.0, 0.0)
                        # lengths in the filter's bounds prove split False (vertex_filter.py)
                        take = ((f_lo <= d <= f_hi and f_lo <= ld <= f_hi)
                                or not split_vertex(pm, ev, ld, d, (lux, luy), (ux, uy)))
                        if take:
                            turned = True
                else:
                    take = False
                if take:
                    run.append(ev)
                    run_len += d
                    run_ends.append(run_len)
                    run_xy += (x1, y1)
                    q = ev.e / d
                    if q > r_epm:
                        r_epm = q
                    r_last += 1                     # ev.idx
                    pm, lux, luy, ld = ev, ux, uy, d
                    yield idx, raw, ev
                    continue
                ok = True
            else:
                ok = eligible(ev, selected)
            is_move = True
            last_u = (lux, luy)
        else:
            if run:
                last_u = (lux, luy)
            is_move = cls is Move or (ev is not None and cls is not Barrier and hasattr(ev, "kind"))
            if waiting is not None and ev is not None:
                waiting.next_u = _direction(ev, False) if is_move else None
                waiting = None
            ok = is_move and eligible(ev, selected)
        if run or arc is not None:
            last = close(is_move, _direction(ev, False) if is_move else None)
            if last is not None and ev is None:
                waiting = last
        if ok:
            run = [ev]
            x0, y0, x1, y1 = ev.x0, ev.y0, ev.x1, ev.y1
            dx, dy = x1 - x0, y1 - y0
            d = hypot(dx, dy)
            run_len = ld = d
            run_ends = [d]
            run_xy = [x0, y0, x1, y1]
            r_epm = ev.e / d
            turned = False
            run_prev_u = last_u
            run_start = start_state() if start_state is not None else None
            r_v, r_accel, r_feature, r_z, r_erel = ev.v, ev.accel, ev.feature, ev.z1, ev.e_rel
            if r_accel != f_accel:
                f_lim = None
            r_travel = ev.feature == "travel"
            r_last = ev.idx
            opened[0] = idx
            pm, lux, luy = ev, dx / d, dy / d     # _direction(ev, True) of an eligible line
            last_u = (lux, luy)
        else:
            if is_move and ev.kind == ARC and eligible_arc(ev, raw, selected):
                arc = Stroke.of_arc(ev)          # closes at the next line
                arc.prev_u = last_u
                if start_state is not None:
                    ss = start_state()
                    arc.start_state = _kind_state(arc, ss[0], ss)
                opened[0] = idx
            if is_move:
                if ev.kind == ARC:
                    last_u = _direction(ev, True)
                else:                      # _direction(ev, True) of a line
                    dx, dy = ev.x1 - ev.x0, ev.y1 - ev.y0
                    d = hypot(dx, dy)
                    last_u = (dx / d, dy / d) if d > 0 else None
            elif ev is not None:           # a Barrier: the planner stops
                last_u = None
        yield idx, raw, ev
    close(False, None)


def _ref_analyse(path, profile: Profile, opts: Options):
    """Strokes of the original file with the firmware model's figures for each.

    The model plays each line as it is read, before the strokes see it.  Its records (one
    a moving line, in file order) go to strokes by index ranges: strokes close in file
    order, so a record goes to the oldest closed stroke still due, or waits (early) while
    its line is in the run still open, or belongs to no stroke.  With the compiled model
    the records go into its RecordLog instead (no Python call a record), which sums them
    per stroke and per feature after the pass, in the same order (_apply_log)."""
    log = pl._record_log()
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
    ring = None
    opts.ringing_before = None
    if getattr(opts, "ringing", True):
        # the original's ringing rides on this pass (streamed: bounded memory)
        from gcode_opt import ringing as rg
        ring = rg.Collector(profile)
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

    def read():
        """The file's (idx, raw, event), each played by the model as it is read (what
        simulate_events and, with ringing, ringing.wrap_events do)."""
        step = state.step
        move, barrier = sim.move, sim.barrier
        last_f = None
        with reader.open_text(path) as fh:
            lines = enumerate(fh)           # read_lines without its generator layer
            if opts.progress is not None:
                lines = fwsim._counted(lines, opts.progress.advance)
            for idx, raw in lines:
                e_before[0] = state.e
                if not seen[0] and raw.lstrip()[:1] == ";" and feat.feature_from_comment(raw) is not None:
                    seen[0] = True
                ev = step(idx, raw)
                cls = type(ev)
                if cls is Move:
                    if ev.feature != last_f:
                        last_f = ev.feature
                        if not feat_at:
                            tally[0] = idx
                        feat_at.append((idx, last_f))
                    move(ev)
                elif cls is Barrier:
                    barrier(ev)
                    if ring is not None:
                        ring_dwell(ev.dwell_t)
                yield idx, raw, ev

    for _ in _ref_group_lines(read(), opts.features, on_stroke, opts.min_length_d, opts.max_turn_deg, split,
                         start_state, opened):
        pass
    sim.stop()
    if log is not None:
        pl._apply_log(log, strokes, feat_at, by_feature)
    if ring is not None:
        opts.ringing_before = ring.figures()
    opts.feature_info = feat.selection_info(seen[0], opts.features)
    return strokes, sim.res


# ---------------------------------------------------------------- the checks
def _analyse_both(path, prof, ringing=True, **kw):
    profile = load_profile(prof)
    o1, o2 = pl.Options(**kw), pl.Options(**kw)
    o1.ringing = o2.ringing = ringing
    s1, sim1 = _ref_analyse(path, profile, o1)
    s2, sim2 = pl.analyse(path, profile, o2)
    return (s1, sim1, o1), (s2, sim2, o2)


def _same(path, prof, ringing=True, **kw):
    (s1, sim1, o1), (s2, sim2, o2) = _analyse_both(path, prof, ringing, **kw)
    assert len(s1) == len(s2)
    for a, b in zip(s1, s2):
        assert _stroke_bits(a) == _stroke_bits(b), (a.first_idx, a.last_idx)
        assert a.lim is b.lim or a.lim == b.lim
    assert _sim_bits(sim1) == _sim_bits(sim2)
    assert _bits(list(o1.by_feature.items())) == _bits(list(o2.by_feature.items()))   # and their order
    assert o1.reader_warnings == o2.reader_warnings
    assert o1.feature_info == o2.feature_info
    assert _bits(o1.ringing_before) == _bits(o2.ringing_before)
    return s2


class _Taken:
    """Counts the lines the C loops read (wraps pipeline.group_lines' fast and gap)."""

    def __init__(self, monkeypatch):
        self.run = self.gap = 0
        real = pl.group_lines

        def group_lines(*a):
            a = list(a)
            for k, name in ((-2, "run"), (-1, "gap")):
                f = a[k]
                if f is not None:
                    def counted(*x, _f=f, _name=name):
                        got = _f(*x)
                        if got:
                            setattr(self, _name, getattr(self, _name) + got[0])
                        return got
                    a[k] = counted
            return real(*a)
        monkeypatch.setattr(pl, "group_lines", group_lines)


_FILES = [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"),
          ("prusa_klipper.gcode", "voron24"), ("cura_box.gcode", "ender3"),
          ("prusa_gyroid_arcs.gcode", "voron24"), ("prusa_concentric_arcs.gcode", "prusa-mk3s"),
          ("prusa_gyroid_fullspeed_klipper.gcode", "voron24"), ("prusa_benchy_like.gcode", "prusa-mk3s"),
          ("prusa_gyroid.gcode", "ender3"), ("prusa_gyroid.gcode", "generic-klipper"),
          ("edge/tiny_move.gcode", "prusa-mk3s"), ("edge/arcs.gcode", "voron24"),
          ("edge/firmware_retraction.gcode", "prusa-mk3s"), ("edge/no_feature_comments.gcode", "prusa-mk3s"),
          ("edge/long_end_segment_curve.gcode", "prusa-mk3s"), ("edge/relative_g91.gcode", "prusa-mk3s"),
          ("edge/tool_changes.gcode", "prusa-mk3s"), ("edge/g92_resets.gcode", "prusa-mk3s")]


@pytest.mark.parametrize("name,prof", _FILES)
def test_analyse_is_the_reference(name, prof):
    _same(SAMPLES + name, prof)


@pytest.mark.parametrize("kw", [dict(max_turn_deg=0.0), dict(min_length_d=0.0), dict(min_length_d=5.0),
                                dict(features=feat.ALL), dict(max_turn_deg=10.0, min_length_d=2.0),
                                dict(ringing=False)])
@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24"),
                                       ("prusa_gyroid_arcs.gcode", "ender3")])
def test_analyse_is_the_reference_other_options(name, prof, kw):
    _same(SAMPLES + name, prof, **kw)


@pytest.mark.skipif(not COMPILED, reason="the compiled model and reader are not built")
def test_the_c_loops_read_most_lines(monkeypatch):
    """The test above compares the C loops, not Python with Python: on the gyroid sample
    they read most lines (runs' and between runs'), and the strokes are still the same."""
    taken = _Taken(monkeypatch)
    path = SAMPLES + "prusa_gyroid.gcode"
    _same(path, "prusa-mk3s")
    with open(path) as fh:
        n = sum(1 for _ in fh)
    assert taken.run > n // 10 and taken.gap > n // 4 and taken.run + taken.gap > n // 2, (taken.run, taken.gap, n)


@pytest.mark.parametrize("core,rd", [("python", "python"), ("c", "python"), ("python", "c")])
def test_analyse_is_the_reference_other_cores(core, rd):
    """The Python model or the Python reader (no C loop: the Python reader's step is not
    the one the fused session reads for)."""
    old, old_core = reader.use_reader(rd), fwsim.use_core(core)
    try:
        _same(SAMPLES + "prusa_gyroid.gcode", "prusa-mk3s")
        _same(SAMPLES + "prusa_klipper.gcode", "voron24", features=feat.ALL)
    finally:
        reader.use_reader(old)
        fwsim.use_core(old_core)


def test_analyse_with_a_progress_bar_is_the_reference():
    """opts.progress counts the characters read (a chunk at a time now)."""
    path = SAMPLES + "prusa_gyroid.gcode"
    profile = load_profile("prusa-mk3s")
    o1, o2 = pl.Options(), pl.Options(progress=pl.Progress(1, enabled=False))
    s1, _ = _ref_analyse(path, profile, o1)
    s2, _ = pl.analyse(path, profile, o2)
    assert [_stroke_bits(s) for s in s1] == [_stroke_bits(s) for s in s2]
    assert o2.progress.done == os.path.getsize(path)


@pytest.mark.parametrize("name,prof", [("plate_gyroid", "prusa-mk3s"), ("plate_rectilinear", "voron24")])
def test_analyse_is_the_reference_plates(name, prof):
    """The issue's plates (sample_gcode/make_corpus.sh; a few s each)."""
    path = _CORPUS + name + ".gcode"
    if not os.path.exists(path):
        pytest.skip("corpus not built")
    _same(path, prof)


@pytest.mark.slow
@pytest.mark.parametrize("name,prof", [("plate_gyroid", "voron24"), ("plate_rectilinear", "prusa-mk3s"),
                                       ("bridges_klipper", "voron24"), ("gyroid_fwretract", "ender3"),
                                       ("no_type_comments", "prusa-mk3s"), ("bridges", "generic-marlin")])
def test_analyse_is_the_reference_corpus(name, prof):
    path = _CORPUS + name + ".gcode"
    if not os.path.exists(path):
        pytest.skip("corpus not built")
    _same(path, prof)


# ---------------------------------------------------------------- random and degenerate files
def _random_file(rng, n):
    """G-code meant to hit every way a line leaves (or stays in) the C loops: runs that
    go straight, turn a little, turn past the curve limit, reverse; moves of zero, tiny
    (< the vertex filter's bounds) and long length; F words equal or not to the run's;
    M204 / M220 / M221 / M83 / M82 / G91 / G90 / G92 / G20 / G21 / G4 / M400 between;
    features selected or not, marked and unmarked comments, blank lines, E-only and
    Z-only moves, retractions, travel, arcs, checksummed and odd-shaped lines."""
    out = ["M201 X1000 Y1000", "M204 P1000 T1500", "G21", "G90", "M83", ";TYPE:Internal infill"]
    x, y, z = 100.0, 100.0, 0.2
    ang = 0.0
    feed = 3000
    feats = [";TYPE:Internal infill", ";TYPE:Solid infill", ";TYPE:Perimeter", ";TYPE:External perimeter",
             ";TYPE:Travel", "; FEATURE: Inner wall", ";TYPE:Bridge infill", ";LAYER_CHANGE"]
    rel = False
    for _ in range(n):
        r = rng.random()
        if r < 0.55:                       # a G1 of the common shape, mostly continuing
            t = rng.random()
            if t < 0.45:
                pass                       # straight on
            elif t < 0.75:
                ang += rng.uniform(-0.2, 0.2)
            elif t < 0.8:
                ang += rng.choice([1e-4, -1e-4, 1e-3, -1e-3, 2e-3])
            elif t < 0.88:
                ang += rng.uniform(-1.2, 1.2)
            elif t < 0.9:
                ang += math.pi
            else:
                ang += rng.uniform(-0.6, 0.6)
            d = rng.choice([rng.uniform(0.05, 1.5), rng.uniform(0.05, 1.5), rng.uniform(1.5, 8.0), 1e-7, 0.0,
                            rng.uniform(1e-4, 1e-2)])
            x1 = round(x + d * math.cos(ang), rng.choice([3, 3, 5, 9]))
            y1 = round(y + d * math.sin(ang), rng.choice([3, 3, 5, 9]))
            words = []
            if rel:
                words += [f"X{x1 - x:.4f}", f"Y{y1 - y:.4f}"]
            else:
                if x1 != x or rng.random() < 0.8:
                    words.append(f"X{x1}")
                if y1 != y or rng.random() < 0.8:
                    words.append(f"Y{y1}")
            e = rng.choice([f"E{d * 0.04:.5f}", f"E{d * 0.04:.5f}", f"E{d * 0.05:.5f}", "", "E0", "E-0.8",
                            f"E{d * 0.04:.5f}"])
            if e:
                words.append(e)
            if rng.random() < 0.08:
                feed = rng.choice([feed, feed, 1200, 3000, 7200, 30])
                words.append(f"F{feed}")
            if rng.random() < 0.03:
                words.insert(0, f"Z{z}")
            rng.shuffle(words) if rng.random() < 0.05 else None
            out.append(rng.choice(["G1 ", "G1 ", "G1 ", "G0 ", "G1  "]) + " ".join(words)
                       + rng.choice(["", "", "", " ; c", "  "]))
            if not rel:
                x, y = x1, y1
            else:
                x, y = x + float(f"{x1 - x:.4f}"), y + float(f"{y1 - y:.4f}")
        elif r < 0.62:
            out.append(rng.choice(feats))
        elif r < 0.66:
            out.append(rng.choice(["; a comment", "", "   ", ";", "; feature x", "\t; tab"]))
        elif r < 0.69:
            out.append(rng.choice(["G1 E-0.8 F2100", "G1 E0.8", "G1 F1200", "G1 F3000", "G1 Z" + str(round(z, 2)),
                                   "G1 X{:.3f} Y{:.3f}".format(x, y)]))
            if out[-1].startswith("G1 Z"):
                z = round(z + rng.choice([0.0, 0.2]), 2)
                out[-1] = f"G1 Z{z}"
        elif r < 0.72:
            out.append(rng.choice(["M204 P800 T1200", "M204 S1500", "M204 P1000 T1500", "M204 P1000.0 T1500.0",
                                   "M220 S90", "M220 S100", "M221 S95", "M205 X8 Y8", "M203 X200 Y200",
                                   "M400", "G4 P10", "M83", "M82", "G92 E0"]))
            if out[-1] == "M82":
                out.append("G92 E0")
        elif r < 0.73:
            rel = not rel
            out.append("G91" if rel else "G90")
        elif r < 0.74:
            out.append(f"G2 X{x + 1:.3f} Y{y:.3f} I0.5 J0 E0.05")
            x += 1
        elif r < 0.75:
            out.append(f"N{rng.randint(1, 99)} G1 X{x:.3f} Y{y + 0.5:.3f} E0.02*{rng.randint(1, 99)}")
            y += 0.5
        elif r < 0.76:
            out.append(rng.choice([f"g1 x{x:.3f} y{y:.3f}", f"G1 X{x:.3f} Y{y:.3f} E0.02 S0", f"G01 X{x:.3f}",
                                   f"G1X{x:.3f}"]))
        else:                              # a travel, then back to the run
            x1, y1 = round(x + rng.uniform(-5, 5), 3), round(y + rng.uniform(-5, 5), 3)
            out.append(f"G1 X{x1} Y{y1} F{rng.choice([7200, 9000])}")
            if rel:
                out[-1] = f"G1 X{x1 - x:.3f} Y{y1 - y:.3f} F7200"
                x, y = x + float(f"{x1 - x:.3f}"), y + float(f"{y1 - y:.3f}")
            else:
                x, y = x1, y1
            out.append(f"G1 F{feed}")
        x = min(max(x, -500.0), 500.0)
        y = min(max(y, -500.0), 500.0)
    return "\n".join(out) + "\n"


@pytest.mark.parametrize("seed", range(12))
def test_analyse_is_the_reference_random(tmp_path, seed):
    rng = random.Random(seed)
    f = tmp_path / f"random{seed}.gcode"
    f.write_text(_random_file(rng, 6000))        # > one chunk: runs cross chunks
    prof = ["prusa-mk3s", "voron24", "ender3", "generic-klipper"][seed % 4]
    kw = [dict(), dict(features=feat.ALL), dict(max_turn_deg=0.0), dict(min_length_d=0.0)][seed // 4 % 4]
    _same(str(f), prof, **kw)


@pytest.mark.parametrize("text", [
    "",
    "\n\n\n",
    "G1 X1 Y1\n",
    "M83\n;TYPE:Internal infill\nG1 X1 Y1 E1\nG1 X2 Y1 E1\nG1 X3 Y1 E1\n",
    "M83\n;TYPE:Internal infill\nG1 X1 Y1 E1\nG1 X2 Y1 E1\r\nG1 X3 Y1 E1\n",      # a CR: Python's
    "M83\n;TYPE:Internal infill\nG1 X1 Y1 E1\nG1 X2 Y1 E1\nG1 X3 Y1 E1",          # no newline at the end
    "M83\n;TYPE:Internal infill\nG1 X1 Y1 E1 F600\nG1 X2 Y1 E1 F600.0\nG1 X3 Y1 E1 F601\nG1 X4 Y1 E1\n",
    "M83\n;TYPE:Internal infill\nG1 X1 Y1 E1\nG1 X1 Y1 E1\nG1 X1 Y1 E0\nG1 X2 Y1 E1\nG1 X3 Y1 Z1 E1\n",
    "M83\n;TYPE:Internal infill\nG1 X1 Y1 E1\nG1 X2 Y1 E-1\nG1 X3 Y1 E0\nG1 X4 Y1\n",
    "M83\n;TYPE:Travel\nG1 X1 Y1\nG1 X2 Y1\nG1 X3 Y1 E0\nG1 X4 Y1 E0.1\n",
    "M83\n;TYPE:Internal infill\nG1 X1 Y1 E1\nG1 X2 Y1.0000001 E1\nG1 X3 Y1.0000003 E1\nG1 X4 Y1 E1\n",
    "M83\n;TYPE:Internal infill\nG1 X1 Y1 E1\nG1 X1.0000001 Y1 E1\nG1 X1.0000002 Y1.0000001 E1\nG1 X5 Y3 E1\n",
    "M83\n;TYPE:Internal infill\nG1 X1 Y1 E1\nM220 S50\nG1 X2 Y1 E1\nG1 X3 Y1 E1\nM220 S100\nG1 X4 Y1 E1\n",
    "M83\n;TYPE:Internal infill\nG1 X1 Y1 E1\nG20\nG1 X2 Y1 E1\nG1 X3 Y1 E1\nG21\nG1 X4 Y1 E1\n",
    "M83\n;TYPE:Internal infill\nG1 X1 Y1 E1\nG91\nG1 X2 Y1 E1\nG1 X3 Y1 E1\nG90\nG1 X4 Y1 E1\n",
    "M82\n;TYPE:Internal infill\nG1 X1 Y1 E1\nG1 X2 Y1 E2\nG1 X3 Y1 E3\nG92 E0\nG1 X4 Y1 E1\n",
    "M83\n;TYPE:Perimeter\nG1 X1 Y1 E1\nG1 X2 Y1 E1\n;TYPE:Internal infill\nG1 X3 Y1 E1\nG1 X4 Y1 E1\n",
    "M83\n;TYPE:Perimeter\nG1 X1 Y1 E1\nG1 X2 Y1 E1\nG1 X2 Y1 E-1\nG1 X3 Y1\nG1 X3 Y1 E1\nG1 X4 Y1 E1\n",
    "M83\n;TYPE:Perimeter\nG1 X1 Y1 E1\nG1 Z0.4\nG1 X2 Y1 E1\nG1 X2 Y1\nG4 P100\nG1 X3 Y1 E1\n",
    "M83\n;TYPE:Internal infill\nG1 X1 Y1 E1\nG1 X1e3 Y1 E1\nG1 X2 Y1 E1 F1e9\nG1 X3 Y1 E1\n",
    "M83\n;TYPE:Internal infill\nG1 X1 Y1 E1\nG1 X2 Y2 E1\nG1 X3 Y3.1 E1\nG1 X4 Y4.3 E1\nM204 S500\n"
    "G1 X5 Y5.6 E1\nG1 X6 Y7 E1\nG1 X7 Y8.5 E1\n",
    "M83\n;TYPE:Internal infill\nG1 X1 Y1 E1\nG1 X5 Y5 E1\nG1 X9 Y9.8 E1\nG1 X13 Y14.9 E1\nG1 X17 Y20.5 E1\n",
    "\ufeffM83\n;TYPE:Internal infill\nG1 X1 Y1 E1\nG1 X2 Y1 E1\nG1 X3 Y1 E1\n",
    "M83\n;TYPE:Internal infill\nG1 X1 Y1 E1\nG1 X2 Y1 E1\n\u00e9\nG1 X3 Y1 E1\nG1 X4 Y1 E1\n",
])
@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_analyse_is_the_reference_degenerate(tmp_path, text, prof):
    f = tmp_path / "degenerate.gcode"
    f.write_text(text, encoding="utf-8")
    for kw in (dict(), dict(features=feat.ALL), dict(min_length_d=0.0, max_turn_deg=45.0)):
        try:
            _same(str(f), prof, **kw)
        except reader.GcodeError:
            with pytest.raises(reader.GcodeError):
                _analyse_both(str(f), prof, **kw)
