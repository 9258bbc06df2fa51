"""The analyse pass's per-line work (issue 8): strokes.group_lines and pipeline.analyse's
hand-over of the firmware model's records by index ranges must give what the code they
replace gave, bit for bit.  The reference below is that code as it was (commit c8abe7b:
strokes.group_strokes and _partition, pipeline.analyse with its per-line dicts and sets),
renamed, not imported."""
from __future__ import annotations

import math
import os
import struct

import pytest

from gcode_opt import curves
from gcode_opt import features as feat
from gcode_opt import pipeline as pl
from gcode_opt import state as reader
from gcode_opt.firmware import simulate as fwsim
from gcode_opt.firmware.simulate import SimResult, simulate_events
from gcode_opt.profile import load_profile
from gcode_opt.state import ARC, MachineState, Move, events, read_lines
from gcode_opt.strokes import COLLINEAR_SIN, Stroke, eligible, eligible_arc, group_strokes

SAMPLES = "sample_gcode/"


# ---------------------------------------------------------------- the reference (c8abe7b, verbatim)
def _direction(ev, at_end):
    """Unit XY direction of a move where it leaves (at_end) or enters; None if it is not
    an XY move (E-only, Z-only) or not a move at all: the planner stops there."""
    if ev is None or not hasattr(ev, "kind"):
        return None
    if ev.kind == ARC:
        a = ev.arc
        th = a.theta0 + (a.sweep if at_end else 0.0)
        sgn = 1.0 if a.sweep > 0 else -1.0
        return (-math.sin(th) * sgn, math.cos(th) * sgn)
    dx, dy = ev.x1 - ev.x0, ev.y1 - ev.y0
    d = math.hypot(dx, dy)
    return (dx / d, dy / d) if d > 0 else None


def _unit(m):
    dx, dy = m.x1 - m.x0, m.y1 - m.y0
    d = math.hypot(dx, dy)
    return dx / d, dy / d


def _continues(pm, m) -> bool:
    """m may follow pm in one stroke: the next line, same feed, acceleration, feature, Z, E mode."""
    return (m.idx == pm.idx + 1 and m.v == pm.v and m.accel == pm.accel and m.feature == pm.feature
            and m.z0 == pm.z1 and m.z1 == pm.z1 and m.e_rel == pm.e_rel)


def _collinear(pu, u) -> bool:
    return abs(pu[0] * u[1] - pu[1] * u[0]) <= COLLINEAR_SIN and pu[0] * u[0] + pu[1] * u[1] > 0.0


def _run_length(run) -> float:
    """Path length of a run, summed as Stroke sums it (so no stroke of the run is longer)."""
    total = 0.0
    hypot = math.hypot
    for m in run:
        total += hypot(m.x1 - m.x0, m.y1 - m.y0)
    return total


def _kind_state(st, e0, ss):
    """(E before the stroke, the acceleration its kind of move uses, cruise ratio)."""
    return e0, (ss[2] if st.feature == "travel" else ss[1]), ss[3]


def _ref_partition(run, curves: bool):
    """Strokes of one run of adjacent compatible moves: one curve stroke if curves are on,
    the run has >= 3 moves and at least one vertex turns by more than the collinear
    tolerance; else straight strokes (a new one wherever the direction changes)."""
    if curves and len(run) >= 3:
        dirs = [_unit(m) for m in run]
        if any(not _collinear(a, b) for a, b in zip(dirs[:-1], dirs[1:])):
            return [(0, Stroke.of_curve(run))]
    out = []
    cur = Stroke(run[0])
    k0 = 0
    for k in range(1, len(run)):
        if not cur.try_extend(run[k]):
            out.append((k0, cur))
            cur, k0 = Stroke(run[k]), k
    out.append((k0, cur))
    return out



def _ref_group_strokes(event_iter, selected, min_length_d: float = 0.0, max_turn_deg: float = 0.0,
                  split_vertex=None, start_state=None):
    """Consume (idx, raw, event) triples; yield them on unchanged, and collect strokes.

    Yields ("line", idx, raw, event) for every line and ("stroke", stroke) when a stroke
    closes (after its last line has been yielded; several strokes may close at once, in
    file order).  Strokes shorter than min_length_d are dropped.  Keeping it a generator
    lets the firmware model run on the same stream.  A stroke's next_u is filled in when
    the next move arrives.

    max_turn_deg > 0 turns curve strokes on: a run of adjacent compatible eligible G1 moves
    whose every vertex turns by <= max_turn_deg (and that split_vertex(prev_move, move), if
    given, does not reject: a vertex whose firmware speed cap no acceleration lifts is
    below the feed) is one curve stroke when it really turns (strokes._partition).

    start_state(), if given, is called when a run or an arc stroke starts (the reader has
    just read its first line) and must return (E before that line, acceleration of printing
    moves, of travel moves, cruise ratio) in force; each stroke gets
    ``start_state = (E before its first line, the acceleration of its kind, cruise ratio)``
    (a stroke inside a run: E summed along the run, as the reader sums it).
    """
    selected = frozenset(selected)
    curves = max_turn_deg > 0.0
    min_cos = math.cos(math.radians(max_turn_deg)) if curves else 2.0
    run = []               # moves of the open run
    run_prev_u = None      # direction of the move before the run
    arc = None             # an arc stroke waiting to close (at the next line)
    last_u = None          # direction of the last move; None after a stop
    waiting = None         # closed stroke still waiting for the next move's direction
    run_start = None       # start_state() where the open run began

    def close(next_u_known, next_u):
        """Strokes of the open run / arc; the last one's next_u as given (or waiting)."""
        nonlocal run, arc
        out = []
        if arc is not None:
            out = [arc]
            arc = None
        elif run and min_length_d > 0.0 and _run_length(run) < min_length_d:
            run = []          # every stroke of it would be dropped: build none (most runs of gyroid)
        elif run:
            parts = _ref_partition(run, curves)
            e_k, k_done = (run_start[0] if run_start else 0.0), 0
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
        out = [st for st in out if st.length_d >= min_length_d]
        if out and next_u_known:
            out[-1].next_u = next_u
        return out

    for idx, raw, ev in event_iter:
        is_move = ev is not None and hasattr(ev, "kind")
        if waiting is not None and ev is not None:
            waiting.next_u = _direction(ev, False) if is_move else None
            waiting = None
        ok = is_move and eligible(ev, selected)
        if run and ok and _continues(run[-1], ev):
            pu, u = _unit(run[-1]), _unit(ev)
            if _collinear(pu, u) or (pu[0] * u[0] + pu[1] * u[1] >= min_cos
                                     and (split_vertex is None or not split_vertex(run[-1], ev))):
                run.append(ev)
                last_u = u
                yield "line", idx, raw, ev
                continue
        if run or arc is not None:
            done = close(is_move, _direction(ev, False) if is_move else None)
            if done and ev is None:
                waiting = done[-1]
            for st in done:
                yield "stroke", st
        if ok:
            run = [ev]
            run_prev_u = last_u
            run_start = start_state() if start_state is not None else None
        elif is_move and ev.kind == ARC and eligible_arc(ev, raw, selected):
            arc = Stroke.of_arc(ev)          # closes at the next line
            arc.prev_u = last_u
            if start_state is not None:
                ss = start_state()
                arc.start_state = _kind_state(arc, ss[0], ss)
        if is_move:
            last_u = _direction(ev, True)
        elif ev is not None:           # a Barrier: the planner stops
            last_u = None
        yield "line", idx, raw, ev
    for st in close(False, None):
        yield "stroke", st


def _ref_analyse(path, profile, opts):
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
    state = MachineState(profile, path)
    state.warnings = opts.reader_warnings = []     # arcs off their circle, ignored M205 J, ...
    e_before = [0.0]       # logical E before the line the stream is at (the generators are lazy)

    seen = [False]         # a slicer feature comment (";TYPE:", "; FEATURE:", ...) was read
    by_feature = opts.by_feature = {}   # the original's moves, time and int a^2 by feature (summary)
    feat_of = {}           # line idx -> feature of a move whose record has not come yet

    def read():
        step = state.step
        for idx, raw in read_lines(path):
            e_before[0] = state.e
            if not seen[0] and raw.lstrip()[:1] == ";" and feat.feature_from_comment(raw) is not None:
                seen[0] = True
            ev = step(idx, raw)
            if type(ev) is Move:
                feat_of[idx] = ev.feature
            yield idx, raw, ev

    def start_state():
        """What rewrite needs where a run of moves starts (it copies the file without
        re-reading it): E before the line, and the accelerations and cruise ratio in force
        (a G0-G3 line leaves those as they were, so the state after it is the one before)."""
        return e_before[0], state.accel_for(True, True), state.accel_for(False, True), state.lim.mcr

    def feed():
        for item in _ref_group_strokes(read(), opts.features,
                                  opts.min_length_d, opts.max_turn_deg, split, start_state):
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
        f = feat_of.pop(r.idx, None)
        if f is not None:
            tot = by_feature.get(f)
            if tot is None:
                tot = by_feature[f] = [0, 0.0, 0.0]
            tot[0] += 1
            tot[1] += r.time_t
            tot[2] += r.int_a2 + r.int_a2_j
        st = owner.pop(r.idx, None)
        if st is not None:
            apply(st, r)
        elif r.idx in pending_idx:
            early[r.idx] = r

    opts.ringing_before = None
    if getattr(opts, "ringing", True):
        # the original's ringing rides on this pass (streamed: bounded memory)
        from gcode_opt import ringing as rg
        ring = rg.Collector(profile)
        ring_line, ring_block, ring_dwell = rg.hooks(ring)

        def on_line_both(r):
            on_line(r)
            ring_line(r)
        sim = simulate_events(rg.wrap_events(feed(), ring_dwell), profile, on_line=on_line_both,
                              on_block=ring_block)
        opts.ringing_before = ring.figures()
    else:
        sim = simulate_events(feed(), profile, on_line=on_line)
    opts.feature_info = feat.selection_info(seen[0], opts.features)
    return strokes, sim



# ---------------------------------------------------------------- the checks
_SLOTS = [n for n in Stroke.__slots__ if n not in ("curv", "chain_T")]


def _bits(x):
    """A value with its floats as their bit patterns (so -0.0 != 0.0 and NaN == NaN)."""
    if isinstance(x, float):
        return struct.pack("<d", x)
    if isinstance(x, (tuple, list)):
        return tuple(_bits(v) for v in x)
    if hasattr(x, "__array__") and not isinstance(x, (str, bytes)):
        return tuple(_bits(float(v)) for v in x.__array__().ravel())
    if type(x).__name__ == "array":
        return tuple(_bits(v) for v in x)
    if isinstance(x, dict):
        return tuple(sorted((k, _bits(v)) for k, v in x.items()))
    if hasattr(x, "__slots__") and not isinstance(x, (str, bytes)):
        return (type(x).__name__,) + tuple(_bits(getattr(x, n, None)) for n in type(x).__slots__)
    return x


def _stroke_bits(st):
    return tuple(_bits(getattr(st, n)) for n in _SLOTS)


def _sim_bits(sim):
    return tuple(_bits(getattr(sim, n)) for n in SimResult.__slots__)   # the C core's type has none of its own


def _run_both(path, prof, **kw):
    profile = load_profile(prof)
    o1, o2 = pl.Options(**kw), pl.Options(**kw)
    s1, sim1 = _ref_analyse(path, profile, o1)
    s2, sim2 = pl.analyse(path, profile, o2)
    return (s1, sim1, o1), (s2, sim2, o2)


def _same(path, prof, **kw):
    (s1, sim1, o1), (s2, sim2, o2) = _run_both(path, prof, **kw)
    assert len(s1) == len(s2)
    for a, b in zip(s1, s2):
        assert _stroke_bits(a) == _stroke_bits(b), (a.first_idx, a.last_idx)
    assert _sim_bits(sim1) == _sim_bits(sim2)
    assert _bits(sorted(o1.by_feature.items())) == _bits(sorted(o2.by_feature.items()))
    assert o1.reader_warnings == o2.reader_warnings
    assert o1.feature_info == o2.feature_info
    assert _bits(o1.ringing_before) == _bits(o2.ringing_before)
    return s2


_FILES = [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"),
          ("prusa_klipper.gcode", "voron24"), ("cura_box.gcode", "ender3"),
          ("prusa_gyroid_arcs.gcode", "voron24"), ("prusa_concentric_arcs.gcode", "prusa-mk3s"),
          ("prusa_gyroid_fullspeed_klipper.gcode", "voron24"), ("prusa_benchy_like.gcode", "prusa-mk3s"),
          ("edge/tiny_move.gcode", "prusa-mk3s"), ("edge/arcs.gcode", "voron24"),
          ("edge/firmware_retraction.gcode", "prusa-mk3s"), ("edge/no_feature_comments.gcode", "prusa-mk3s"),
          ("edge/long_end_segment_curve.gcode", "prusa-mk3s"), ("edge/relative_g91.gcode", "prusa-mk3s"),
          ("edge/tool_changes.gcode", "prusa-mk3s"), ("edge/g92_resets.gcode", "prusa-mk3s")]


@pytest.mark.parametrize("name,prof", _FILES)
def test_analyse_is_the_reference(name, prof):
    """Default options: every stroke slot, the model's whole-file sums, the feature tally,
    the reader's warnings and the ringing figures, bit for bit."""
    strokes = _same(SAMPLES + name, prof)
    if name == "prusa_gyroid.gcode":
        assert len(strokes) > 100


@pytest.mark.parametrize("kw", [dict(max_turn_deg=0.0), dict(min_length_d=0.0), dict(min_length_d=5.0),
                                dict(features=feat.ALL)])
@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24"),
                                       ("prusa_gyroid_arcs.gcode", "voron24")])
def test_analyse_is_the_reference_other_options(name, prof, kw):
    """Curves off, no minimum length, a long one, more features (travel included)."""
    _same(SAMPLES + name, prof, **kw)


def test_analyse_is_the_reference_pure_python():
    """The Python reader and the Python firmware model (GCODE_OPT_PURE_PYTHON's path)."""
    old, old_core = reader.use_reader("python"), fwsim.use_core("python")
    try:
        _same(SAMPLES + "prusa_gyroid.gcode", "prusa-mk3s")
        _same(SAMPLES + "prusa_klipper.gcode", "voron24")
    finally:
        reader.use_reader(old)
        fwsim.use_core(old_core)


_CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus/")


@pytest.mark.slow
@pytest.mark.parametrize("name,prof", [("plate_rectilinear", "prusa-mk3s"), ("cura_gyroid", "ender3"),
                                       ("bridges_klipper", "voron24"), ("gyroid_fwretract", "prusa-mk3s")])
def test_analyse_is_the_reference_corpus(name, prof):
    """Real large files (sample_gcode/make_corpus.sh; ~10 s each)."""
    path = _CORPUS + name + ".gcode"
    if not os.path.exists(path):
        pytest.skip("corpus not built")
    _same(path, prof)


def test_analyse_without_ringing_is_the_reference():
    _same(SAMPLES + "prusa_gyroid.gcode", "prusa-mk3s")
    profile = load_profile("prusa-mk3s")
    o1, o2 = pl.Options(), pl.Options()
    o1.ringing = o2.ringing = False
    s1, sim1 = _ref_analyse(SAMPLES + "prusa_gyroid.gcode", profile, o1)
    s2, sim2 = pl.analyse(SAMPLES + "prusa_gyroid.gcode", profile, o2)
    assert [_stroke_bits(s) for s in s1] == [_stroke_bits(s) for s in s2]
    assert _bits(sorted(o1.by_feature.items())) == _bits(sorted(o2.by_feature.items()))


@pytest.mark.parametrize("min_d,turn", [(0.0, 0.0), (0.2, 30.0), (0.0, 30.0), (2.0, 10.0)])
def test_group_strokes_is_the_reference(min_d, turn):
    """The tagged stream itself (order of lines and strokes), with and without a splitter."""
    for name, prof in [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_gyroid_arcs.gcode", "voron24")]:
        profile = load_profile(prof)
        split = curves.vertex_splitter(profile) if turn else None

        def tagged(fn):
            out = []
            for item in fn(events(SAMPLES + name, profile), feat.DEFAULT_SELECTED, min_d, turn, split):
                if item[0] == "line":
                    out.append(("line", item[1]))
                else:
                    out.append(("stroke", _stroke_bits(item[1])))
            return out
        assert tagged(_ref_group_strokes) == tagged(group_strokes)


_RECORDLESS = """M201 X1000 Y1000
M204 P1000 T1500
G21
G90
M83
;TYPE:Internal infill
G1 X10 Y10 F6000
G1 X20 Y10 E0.5
G1 X30 Y10 E0.5
G1 X40 Y10 F9000
G1 X40.0000000001 Y10
G1 X50 Y20
G1 X60 Y30
G1 X60 Y30.0000000001
G1 X60.0000000001 Y30.0000000002
;a comment
G1 X70 Y30
G1 X80 Y30
G1 X80.0000000001 Y30
G4 P100
G1 X90 Y40 E1.0
"""


@pytest.mark.parametrize("features", [feat.DEFAULT_SELECTED, feat.ALL])
def test_analyse_is_the_reference_where_lines_have_no_record(tmp_path, features):
    """Travel strokes (features incl. travel) whose last lines move < 1e-9 mm: the model
    takes them without a record, so the stroke waits for a record that never comes."""
    f = tmp_path / "recordless.gcode"
    f.write_text(_RECORDLESS)
    strokes = _same(str(f), "prusa-mk3s", features=features)
    if features == feat.ALL:
        assert any(s.feature == "travel" and s.n_moves >= 2 for s in strokes)


def test_analyse_with_a_progress_bar_is_the_reference():
    """opts.progress counts the bytes read (a bar that is not drawn)."""
    path = SAMPLES + "prusa_gyroid.gcode"
    profile = load_profile("prusa-mk3s")
    o1, o2 = pl.Options(), pl.Options(progress=pl.Progress(1, enabled=False))
    s1, _ = _ref_analyse(path, profile, o1)
    s2, _ = pl.analyse(path, profile, o2)
    assert [_stroke_bits(s) for s in s1] == [_stroke_bits(s) for s in s2]
    assert o2.progress.done == os.path.getsize(path)
