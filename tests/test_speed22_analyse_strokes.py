"""analyse's first pass faster and smaller (issue 8, s22): strokes.group_lines building a
run's one stroke directly (_run_stroke), start_state kept in three slots, ends_d of a
one-move stroke made when read, the closing line's direction shared with the next run, and
pipeline.analyse's start_state with accel_for inlined, must give what the code they replaced
gave, bit for bit: every public Stroke attribute, the model's sums, the feature tally.

The reference below is that code as it was at 479aedb (strokes.Stroke, _straight_parts,
group_lines; MachineState.accel_for), verbatim but renamed, not imported.  pipeline.analyse
runs once as it is and once with the reference group_lines and a MachineState whose
accel_for is the reference's (so analyse takes its start_state() through accel_for)."""
from __future__ import annotations

import math
import os
from array import array

import pytest

from gcode_opt import features as feat
from gcode_opt import pipeline as pl
from gcode_opt import state as reader
from gcode_opt.firmware import simulate as fwsim
from gcode_opt.profile import load_profile
from gcode_opt.state import ARC, LINE, Barrier, MachineState, Move
from gcode_opt.strokes import (COLLINEAR_SIN, K_ARC, K_CURVE, K_LINE, NOT_OPEN, Points, Stroke,
                               _direction, _kind_state, _read_move, _unit, eligible, eligible_arc)
from test_speed_analyse import _bits, _sim_bits

SAMPLES = "sample_gcode/"
_CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus/")


# ---------------------------------------------------------------- the reference (479aedb, verbatim)
class _RefStroke:
    """Geometry and original timing of one straight stroke (original file's figures).
    Every stroke lives for the whole run: slots, and ends_d an array of doubles."""
    __slots__ = ("first_idx", "last_idx", "x0", "y0", "z", "ux", "uy", "length_d", "ends_d",
                 "v_feed", "accel", "feature", "layer", "e_rel",
                 "v0", "v1", "time_t", "int_a2", "int_v2", "lim", "e_per_mm",
                 "_pux", "_puy", "_nux", "_nuy", "kind", "arc", "pts", "curv", "start_state", "chain_T",
                 "v0_fw", "v1_fw", "corner_cmd0", "corner_cmd1")

    def __init__(self, m):
        self.kind = K_LINE
        self.arc = None              # state.Arc of an arc stroke
        self.pts = None              # curve strokes: Points, (x, y) vertices, start included
        self.curv = None             # curve strokes: cached curves.CurveGeom
        self.chain_T = None          # chain strokes: chains.ChainMemo (its candidates, law durations)
        self.first_idx = self.last_idx = m.idx
        self.x0, self.y0, self.z = m.x0, m.y0, m.z0
        d = math.hypot(m.x1 - m.x0, m.y1 - m.y0)
        self.ux, self.uy = (m.x1 - m.x0) / d, (m.y1 - m.y0) / d
        self.length_d = d
        self.ends_d = array("d", (d,))   # distance from stroke start to each original vertex
        self.v_feed, self.accel = m.v, m.accel
        self.feature, self.layer, self.e_rel = m.feature, m.layer, m.e_rel
        self.lim = m.lim
        self.e_per_mm = m.e / d
        self.v0 = self.v1 = self.time_t = self.int_a2 = self.int_v2 = 0.0
        # prev_u = next_u = None: XY directions of the neighbouring moves (None: a stop)
        self._pux = self._puy = self._nux = self._nuy = None
        self.v0_fw = self.v1_fw = None       # the firmware's own end speeds when corners.py lowered v0/v1
        self.corner_cmd0 = self.corner_cmd1 = False   # that lowered end is set by a junction command
        self.start_state = None      # group_strokes(start_state=...): (E before, accel, cruise ratio)

    # the XY directions of the neighbouring moves, (x, y) or None: kept as four floats (a
    # tuple each took ~70 bytes more a stroke)
    @property
    def prev_u(self):
        x = self._pux
        return None if x is None else (x, self._puy)

    @prev_u.setter
    def prev_u(self, u):
        self._pux, self._puy = (None, None) if u is None else u

    @property
    def next_u(self):
        x = self._nux
        return None if x is None else (x, self._nuy)

    @next_u.setter
    def next_u(self, u):
        self._nux, self._nuy = (None, None) if u is None else u

    @property
    def n_moves(self) -> int:
        return self.last_idx - self.first_idx + 1

    @classmethod
    def of_arc(cls, m):
        """A G2/G3 move on its own: path length S = R |sweep| (no Z change)."""
        st = cls.__new__(cls)
        st.kind, st.arc, st.pts, st.curv, st.chain_T = K_ARC, m.arc, None, None, None
        st.first_idx = st.last_idx = m.idx
        st.x0, st.y0, st.z = m.x0, m.y0, m.z0
        a = m.arc
        sgn = 1.0 if a.sweep > 0 else -1.0
        st.ux, st.uy = -math.sin(a.theta0) * sgn, math.cos(a.theta0) * sgn   # start tangent
        st.length_d = a.length_d
        st.ends_d = array("d", (a.length_d,))
        st.v_feed, st.accel = m.v, m.accel
        st.feature, st.layer, st.e_rel = m.feature, m.layer, m.e_rel
        st.lim = m.lim
        st.e_per_mm = m.e / a.length_d
        st.v0 = st.v1 = st.time_t = st.int_a2 = st.int_v2 = 0.0
        st.prev_u = st.next_u = None
        st.v0_fw = st.v1_fw = None
        st.corner_cmd0 = st.corner_cmd1 = False
        st.start_state = None
        return st

    @classmethod
    def of_curve(cls, moves, ds=None):
        """A chain of adjacent G1 moves (one feature, feed, accel, Z) that turns at its
        vertices by at most the curve threshold: one smooth curve, kind K_CURVE.  ds: the
        moves' XY lengths, if known (math.hypot of each, as here)."""
        st = cls(moves[0])
        xy = [moves[0].x0, moves[0].y0]
        if ds is None:
            ds = [math.hypot(m.x1 - m.x0, m.y1 - m.y0) for m in moves]
        length_d, e_per_mm = 0.0, st.e_per_mm
        ends = []
        for m, d in zip(moves, ds):
            length_d += d
            ends.append(length_d)
            q = m.e / d
            if q > e_per_mm:          # max(e_per_mm, q)
                e_per_mm = q
            xy += (m.x1, m.y1)
        return st._curve(moves, xy, ends, e_per_mm)

    def _curve(self, moves, xy, ends, e_per_mm, last_idx=None):
        """This stroke of moves[0] made the curve of all moves: xy the start and every
        move's end, ends their lengths summed in order, e_per_mm the first move's E per mm
        or a larger one's (of_curve's loop; group_lines sums them as it reads the moves);
        last_idx the last move's line if given (else moves[-1].idx)."""
        self.kind = K_CURVE
        self.length_d, self.e_per_mm = ends[-1], e_per_mm
        self.pts, self.ends_d = Points(xy), array("d", ends)
        self.last_idx = moves[-1].idx if last_idx is None else last_idx
        return self

    def try_extend(self, m) -> bool:
        """Append move m if it continues this stroke in a straight line."""
        if self.kind != K_LINE:
            return False
        if (m.idx != self.last_idx + 1 or m.v != self.v_feed or m.accel != self.accel
                or m.feature != self.feature or m.z0 != self.z or m.z1 != self.z or m.e_rel != self.e_rel):
            return False
        dx, dy = m.x1 - m.x0, m.y1 - m.y0
        d = math.hypot(dx, dy)
        if d == 0.0:
            return False
        # same direction: cross product ~0 and dot product > 0
        if abs(dx * self.uy - dy * self.ux) > COLLINEAR_SIN * d or dx * self.ux + dy * self.uy <= 0.0:
            return False
        self.last_idx = m.idx
        self.length_d += d
        self.ends_d.append(self.length_d)
        self.e_per_mm = max(self.e_per_mm, m.e / d)
        return True



def _ref_straight_parts(run):
    """Straight strokes of one run of adjacent compatible moves that is not a curve (curves
    off, fewer than 3 moves, or no vertex turning by more than the collinear tolerance): a
    new stroke wherever the direction drifts (Stroke.try_extend); [(first move, stroke)]."""
    out = []
    cur = _RefStroke(run[0])
    k0 = 0
    for k in range(1, len(run)):
        if not cur.try_extend(run[k]):
            out.append((k0, cur))
            cur, k0 = _RefStroke(run[k]), k
    out.append((k0, cur))
    return out



def _ref_group_lines(event_iter, selected, on_stroke, min_length_d: float = 0.0, max_turn_deg: float = 0.0,
                split_vertex=None, start_state=None, opened=None, fast=None, gap=None):
    """group_strokes without the tagged items: yields the (idx, raw, event) triples on
    unchanged and hands each stroke to on_stroke(stroke) as it closes (before the triple of
    the line that closed it; the last ones after the last triple).  opened, a one-item
    list if given, holds the first line of the run or arc stroke still open (NOT_OPEN if
    none): a line before it is either in a stroke already handed over or in none.

    The common line, a G1 continuing the open run, is tested first and least: the run's
    feed, acceleration, feature, Z and E mode are its first move's (equality carries along
    the run), the last move's direction and the run's length are kept as it grows.

    fast, if given (pipeline.analyse: the compiled model's Sim.run_lines with the reader's
    chunk), is called whenever the open run has grown by a line: it reads the lines that
    follow as long as this code would take them into the run without asking Python (the
    test below, the vertex filter's bounds), appending their moves to the run as this code
    does (each such move kept in run as its E alone, a float: _read_move makes the Move
    where one is needed), and returns (lines taken, run_len, r_epm, ld, lux, luy,
    turned), 0 (none taken) or None (it cannot: not called again).  Those lines are not
    yielded.

    gap, if given (pipeline.analyse: the model's Sim.gap_lines), is called with last_u and
    whether a stroke waits for the next move's direction after a line that leaves no run
    or arc stroke open: it reads the lines that follow as long as this code would do
    nothing with them but set last_u (blank and unmarked comment lines, lines that make no
    move, moves eligible() refuses unless a stroke waits: see gap_lines for the rest) and
    returns (lines read, last_u after them), 0 (none read) or None (it cannot: not called
    again).  Those lines are not yielded either."""
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
    lazy = False           # fast read lines of the open run: their moves are floats in run
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
        opened[0] = NOT_OPEN
        if arc is not None:
            st, arc = arc, None
        elif not run:
            return None
        elif min_length_d > 0.0 and run_len < min_length_d:
            run = []          # every stroke of it would be dropped: build none (most runs of gyroid)
            return None
        else:
            if curves and turned and len(run) >= 3:
                st = _RefStroke(run[0])._curve(run, run_xy, run_ends, r_epm, r_last)
            elif len(run) == 1:
                st = _RefStroke(run[0])
            else:
                if lazy:
                    run = [_read_move(run, k, run_xy, r_z, r_v, r_accel, r_feature, r_erel)
                           if type(m) is float else m for k, m in enumerate(run)]
                parts = _ref_straight_parts(run)
                if len(parts) > 1:
                    return close_parts(parts, next_u_known, next_u)
                st = parts[0][1]
            # one stroke (most runs): what close_parts does for it
            st._pux, st._puy = (None, None) if run_prev_u is None else run_prev_u    # prev_u
            if run_start is not None:
                st.start_state = _kind_state(st, run_start[0], run_start)
            run = []
        if st.length_d < min_length_d:
            return None
        if next_u_known:
            st._nux, st._nuy = (None, None) if next_u is None else next_u        # next_u
        on_stroke(st)
        return st

    def close_parts(parts, next_u_known, next_u):
        """close() for a run of straight strokes [(first move, stroke)]."""
        nonlocal run
        out = []
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
                        if not (f_lo <= d <= f_hi and f_lo <= ld <= f_hi) and type(pm) is float:
                            pm = _read_move(run, len(run) - 1, run_xy, r_z, r_v, r_accel, r_feature, r_erel)
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
                    if fast is not None:            # the lines that follow, in C
                        got = fast(run, run_ends, run_xy, r_v, r_accel, r_feature, r_z, r_erel, r_travel, lux,
                                   luy, ld, run_len, r_epm, turned, min_cos, coll, split_vertex is not None,
                                   f_lim, f_lo, f_hi)
                        if got:
                            n, run_len, r_epm, ld, lux, luy, turned = got
                            r_last += n
                            pm, lazy = run[-1], True
                        elif got is None:
                            fast = None
                    yield idx, raw, ev
                    continue
                ok = True
                is_move = True
                last_u = (lux, luy)
                close(True, (ux, uy))               # (ux, uy): _direction(ev, False)
            else:
                ok = eligible(ev, selected)
                is_move = True
                last_u = (lux, luy)
                close(True, _direction(ev, False))
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
            lazy = False
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
            if fast is not None:                  # the lines that follow, in C
                got = fast(run, run_ends, run_xy, r_v, r_accel, r_feature, r_z, r_erel, r_travel, lux, luy, ld,
                           run_len, r_epm, turned, min_cos, coll, split_vertex is not None, f_lim, f_lo, f_hi)
                if got:
                    n, run_len, r_epm, ld, lux, luy, turned = got
                    r_last += n
                    pm, lazy = run[-1], True
                elif got is None:
                    fast = None
        else:
            if is_move and ev.kind == ARC and eligible_arc(ev, raw, selected):
                arc = _RefStroke.of_arc(ev)          # closes at the next line
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
        if gap is not None and not run and arc is None:
            got = gap(last_u, waiting is not None)      # the lines that follow, in C
            if got:
                last_u = got[1]
            elif got is None:
                gap = None
        yield idx, raw, ev
    close(False, None)


class _RefState(MachineState):
    def accel_for(self, extruding: bool, kinematic: bool) -> float:
        """The acceleration the firmware uses for this kind of move."""
        if not kinematic:
            return self.accel_retract
        if self.flavour == "klipper" or self.flavour == "marlin-legacy":
            return self.accel_print                     # one accel for every XY move
        return self.accel_print if extruding else self.accel_travel


# ---------------------------------------------------------------- the checks
# every attribute other modules read (the reference's slots, start_state and ends_d included,
# prev_u / next_u as their tuples), n_moves; curv and chain_T are plan's
_PUBLIC = ["first_idx", "last_idx", "x0", "y0", "z", "ux", "uy", "length_d", "ends_d", "v_feed", "accel", "feature",
           "layer", "e_rel", "v0", "v1", "time_t", "int_a2", "int_v2", "lim", "e_per_mm", "prev_u", "next_u", "kind",
           "arc", "pts", "start_state", "v0_fw", "v1_fw", "corner_cmd0", "corner_cmd1", "n_moves"]


def _public_bits(st):
    out = []
    for n in _PUBLIC:
        v = getattr(st, n)
        if n == "ends_d":
            assert isinstance(v, array) and v.typecode == "d"
        if n == "pts" and v is not None:
            assert type(v) is Points
            v = v.xy
        out.append(_bits(v))
    return tuple(out)


def _analyse_ref(path, profile, opts, monkeypatch):
    with monkeypatch.context() as mp:
        mp.setattr(pl, "group_lines", _ref_group_lines)
        mp.setattr(pl, "MachineState", _RefState)
        return pl.analyse(path, profile, opts)


def _same(path, prof, monkeypatch, **kw):
    profile = load_profile(prof)
    o1, o2 = pl.Options(**kw), pl.Options(**kw)
    s1, sim1 = _analyse_ref(path, profile, o1, monkeypatch)
    s2, sim2 = pl.analyse(path, profile, o2)
    assert all(type(s) is _RefStroke for s in s1) and all(type(s) is Stroke for s in s2)
    assert len(s1) == len(s2)
    for a, b in zip(s1, s2):
        assert _public_bits(a) == _public_bits(b), (a.first_idx, a.last_idx)
    assert _sim_bits(sim1) == _sim_bits(sim2)
    assert _bits(sorted(o1.by_feature.items())) == _bits(sorted(o2.by_feature.items()))
    assert o1.reader_warnings == o2.reader_warnings
    assert o1.feature_info == o2.feature_info
    assert _bits(o1.ringing_before) == _bits(o2.ringing_before)
    return s2


_FILES = [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"),
          ("prusa_klipper.gcode", "voron24"), ("prusa_klipper_no_comments.gcode", "voron24"),
          ("cura_box.gcode", "ender3"), ("prusa_gyroid_arcs.gcode", "voron24"),
          ("prusa_concentric_arcs.gcode", "prusa-mk3s"), ("prusa_benchy_like.gcode", "ender3"),
          ("edge/arcs.gcode", "voron24"), ("edge/arc_variants.gcode", "prusa-mk3s"),
          ("edge/no_feature_comments.gcode", "prusa-mk3s"), ("edge/cura_type.gcode", "prusa-mk3s"),
          ("edge/tiny_move.gcode", "prusa-mk3s"), ("edge/long_end_segment_curve.gcode", "prusa-mk3s"),
          ("edge/m204_variants.gcode", "prusa-mk3s"), ("edge/klipper_macros.gcode", "voron24")]


@pytest.mark.parametrize("name,prof", _FILES)
def test_strokes_are_the_reference(name, prof, monkeypatch):
    """Real files (arcs, Cura, no feature comments, M204 changes, Klipper): every public
    attribute of every stroke, bit for bit."""
    strokes = _same(SAMPLES + name, prof, monkeypatch)
    if name == "prusa_gyroid.gcode":
        kinds = {s.kind for s in strokes}
        assert {K_LINE, K_CURVE} <= kinds and len(strokes) > 100
        assert sum(s._ends is None for s in strokes) > 10      # one-move strokes keep no ends_d
    if name == "prusa_gyroid_arcs.gcode":
        assert any(s.kind == K_ARC for s in strokes)


@pytest.mark.parametrize("kw", [dict(max_turn_deg=0.0), dict(min_length_d=0.0), dict(min_length_d=5.0),
                                dict(features=feat.ALL)])
@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24"),
                                       ("cura_box.gcode", "bambu-x1c")])
def test_strokes_are_the_reference_other_options(name, prof, kw, monkeypatch):
    """Curves off (straight parts only), no minimum length, a long one, every feature
    (travel runs: start_state's travel acceleration, which bambu-x1c has apart)."""
    _same(SAMPLES + name, prof, monkeypatch, **kw)


def test_strokes_are_the_reference_pure_python(monkeypatch):
    """The Python reader and the Python firmware model (GCODE_OPT_PURE_PYTHON's path)."""
    old, old_core = reader.use_reader("python"), fwsim.use_core("python")
    try:
        _same(SAMPLES + "prusa_gyroid.gcode", "prusa-mk3s", monkeypatch)
        _same(SAMPLES + "prusa_klipper.gcode", "voron24", monkeypatch)
    finally:
        reader.use_reader(old)
        fwsim.use_core(old_core)


@pytest.mark.parametrize("name,prof", [("plate_gyroid", "prusa-mk3s"), ("no_type_comments", "prusa-mk3s"),
                                       ("bridges_klipper", "voron24")])
def test_strokes_are_the_reference_corpus(name, prof, monkeypatch):
    """The large real files the speed goal is measured on (~4 s for the gyroid plate)."""
    path = _CORPUS + name + ".gcode"
    if not os.path.exists(path):
        pytest.skip("corpus not built")
    _same(path, prof, monkeypatch)


def test_stroke_attributes_read_as_before():
    """Stroke(m), try_extend, of_arc and the start_state / ends_d properties read what the
    reference's slots held."""
    m = lambda i, x0, x1, y1=0.0: Move(i, LINE, x0, 0.0, 0.2, x1, y1, 0.2, 0.05, 50.0, 1000.0, "perimeter", 1,  # noqa
                                       None, None, None, False, False, False, False, 1.0, 1.0)
    for new, ref in ((Stroke(m(3, 0.0, 1.0)), _RefStroke(m(3, 0.0, 1.0))),):
        assert _public_bits(new) == _public_bits(ref)
        e = new.ends_d
        assert list(e) == [1.0] and new.ends_d is not e       # made when read
        for k, x in enumerate((2.5, 3.0 + 1e-9, 7.0)):
            assert new.try_extend(m(4 + k, new.length_d if k == 0 else x - 1, x, 1e-7 * k)) == \
                ref.try_extend(m(4 + k, ref.length_d if k == 0 else x - 1, x, 1e-7 * k))
            assert _public_bits(new) == _public_bits(ref)
        assert new.ends_d is new.ends_d and len(new.ends_d) == new.n_moves
        new.start_state = ref.start_state = (1.5, 2000.0, 0.5)
        assert new.start_state == (1.5, 2000.0, 0.5) and _public_bits(new) == _public_bits(ref)
        new.start_state = ref.start_state = None
        assert new.start_state is None
        new.ends_d = array("d", (4.0, 5.0))
        assert list(new.ends_d) == [4.0, 5.0]
