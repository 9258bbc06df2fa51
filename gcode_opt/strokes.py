"""Strokes: runs of consecutive collinear moves that one law of motion can re-time.

A stroke is a straight run of adjacent G0/G1 lines of one selected feature, at one
feedrate, one Z and one acceleration.  It ends at a corner, a feature or feed change,
a retraction, a Z change, or any other line (a comment included: every non-motion line
must stay exactly where it was, so a stroke never spans one).  The firmware model gives
the speeds the original file reaches at the stroke's two ends; the re-timed law starts
and ends at those same speeds, so the moves around the stroke are planned as before.
"""
from __future__ import annotations

import math
from array import array

from .state import ARC, LINE, MAX_POS_D, Barrier, Move
from .words import param_texts, split_comment, strip_checksum

MIN_FEED_V = 1.0          # mm/s: slower moves are left alone -- segment feeds are written to 0.1 mm/s
                          # and a firmware's minimum feed is of that order, so a law could not be played
COLLINEAR_SIN = 1e-3      # |sin| of the turn below which two moves are one line (0.06 deg)

# Stroke.kind (a chain is a curve whose vertices cap the speed below its feed: chains.py)
K_LINE, K_ARC, K_CURVE, K_CHAIN = "line", "arc", "curve", "chain"


class Points:
    """A curve stroke's vertices, (x, y) pairs packed in one array of doubles: 16 bytes a
    vertex where a list of tuples of floats took ~110 (every stroke is kept for the whole
    run; the gyroid plate has ~10 vertices a stroke).  Reads like the list of tuples it
    replaces: len, truth, p[k] and iteration give (x, y) tuples of floats; np.asarray
    gives the (n, 2) float array."""
    __slots__ = ("xy",)

    def __init__(self, xy=()):
        self.xy = array("d", xy)

    def append(self, p):
        self.xy.extend(p)

    def __len__(self):
        return len(self.xy) >> 1

    def __getitem__(self, k):
        if isinstance(k, slice):
            return [self[j] for j in range(*k.indices(len(self)))]
        n = len(self)
        if k < 0:
            k += n
        if not 0 <= k < n:
            raise IndexError("vertex index out of range")
        return self.xy[2 * k], self.xy[2 * k + 1]

    def __iter__(self):
        it = iter(self.xy)
        return zip(it, it)

    def __array__(self, dtype=None, copy=None):
        import numpy as np
        return np.array(self.xy, dtype=float if dtype is None else dtype).reshape(-1, 2)


# a Stroke's fields (its __slots__ in pure Python)
FIELDS = ("first_idx", "last_idx", "x0", "y0", "z", "ux", "uy", "length_d", "_ends",
          "v_feed", "accel", "feature", "layer", "e_rel",
          "v0", "v1", "time_t", "int_a2", "int_v2", "lim", "e_per_mm",
          "_pux", "_puy", "_nux", "_nuy", "kind", "arc", "pts", "curv", "_ss_e", "_ss_a", "_ss_c",
          "chain_T", "v0_fw", "v1_fw", "corner_cmd0", "corner_cmd1")


def _fw_core():
    """The compiled firmware core (firmware/_core.c) or None (pure Python, not built, stale:
    native.load).  Its StrokeBase holds the fields that are always a float (or a float or
    None) as doubles and first_idx / last_idx as ints -- a float object of its own each
    took 24 bytes beside its slot (gyroid plate: ~13 MB of 40 for its 35 k strokes).  They
    read back as the same floats and ints; a value of another type is kept as that object."""
    from .firmware import load_core
    core, _ = load_core()
    return core if hasattr(core, "StrokeBase") else None


_CORE = _fw_core()
_BASE = None if _CORE is None else _CORE.StrokeBase


class Stroke(object if _BASE is None else _BASE):
    """Geometry and original timing of one straight stroke (original file's figures).
    Every stroke lives for the whole run: slots (or the compiled StrokeBase's fields:
    FIELDS either way), and ends_d an array of doubles."""
    __slots__ = FIELDS if _BASE is None else ()

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
        self._ends = None            # ends_d of one move: (length_d,), made when read (see ends_d)
        self.v_feed, self.accel = m.v, m.accel
        self.feature, self.layer, self.e_rel = m.feature, m.layer, m.e_rel
        self.lim = m.lim
        self.e_per_mm = m.e / d
        self.v0 = self.v1 = self.time_t = self.int_a2 = self.int_v2 = 0.0
        # prev_u = next_u = None: XY directions of the neighbouring moves (None: a stop)
        self._pux = self._puy = self._nux = self._nuy = None
        self.v0_fw = self.v1_fw = None       # the firmware's own end speeds when corners.py lowered v0/v1
        self.corner_cmd0 = self.corner_cmd1 = False   # that lowered end is set by a junction command
        self._ss_e = self._ss_a = self._ss_c = None   # start_state (None: not recorded)

    # ends_d: distance from the stroke's start to each original vertex, an array of doubles.
    # A stroke of one move (or an arc) keeps none: its ends_d is array("d", (length_d,)),
    # made when read (most strokes are read a few times; ~90 bytes a stroke less)
    @property
    def ends_d(self):
        e = self._ends
        return array("d", (self.length_d,)) if e is None else e

    @ends_d.setter
    def ends_d(self, e):
        self._ends = e

    # start_state: group_strokes(start_state=...)'s (E before, accel, cruise ratio), or None;
    # kept as three slots (a tuple took 48 bytes more a stroke)
    @property
    def start_state(self):
        e = self._ss_e
        return None if e is None else (e, self._ss_a, self._ss_c)

    @start_state.setter
    def start_state(self, ss):
        self._ss_e, self._ss_a, self._ss_c = (None, None, None) if ss is None else ss

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
        st._ends = None                  # ends_d: (length_d,)
        st.v_feed, st.accel = m.v, m.accel
        st.feature, st.layer, st.e_rel = m.feature, m.layer, m.e_rel
        st.lim = m.lim
        st.e_per_mm = m.e / a.length_d
        st.v0 = st.v1 = st.time_t = st.int_a2 = st.int_v2 = 0.0
        st.prev_u = st.next_u = None
        st.v0_fw = st.v1_fw = None
        st.corner_cmd0 = st.corner_cmd1 = False
        st._ss_e = st._ss_a = st._ss_c = None
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
        self.pts, self._ends = Points(xy), array("d", ends)
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
        if self._ends is None:
            self._ends = array("d", (self.length_d,))
        self.length_d += d
        self._ends.append(self.length_d)
        self.e_per_mm = max(self.e_per_mm, m.e / d)
        return True


def eligible(m, selected: frozenset) -> bool:
    """A move we may re-time: a plain straight XY line, constant Z, absolute XYZ in mm (G21),
    no checksum (renumbering checksummed lines is the host's job), selected feature."""
    return (m.kind == LINE and m.feature in selected and not m.checksum and not m.xyz_rel and not m.inch
            and m.speed_r == 1.0 and m.v >= MIN_FEED_V
            and m.z0 == m.z1 and (m.x1 != m.x0 or m.y1 != m.y0)
            and (m.e > 0.0 or (m.e == 0.0 and m.feature == "travel")))


def eligible_arc(m, raw, selected: frozenset) -> bool:
    """A G2/G3 we may re-time: selected feature, I/J form (the centre is in the file's
    text, so sub-arcs can keep it exactly), absolute XY in mm, no checksum, no Z change,
    extruding, at least 1 mm long, its end on its circle (else a firmware ends it with a
    straight jump the law does not know of: state.Arc.off_circle), and its whole circle
    1 mm inside the reader's position range (its sub-arcs must read back)."""
    if not (m.kind == ARC and m.feature in selected and not m.checksum and not m.xyz_rel and not m.inch
            and m.speed_r == 1.0 and m.v >= MIN_FEED_V
            and m.z0 == m.z1 and m.e > 0.0 and m.arc.length_d >= 1.0 and not m.arc.off_circle):
        return False
    a = m.arc        # sub-arc ends are rounded points of the circle: keep them inside the range
    if abs(a.cx) + a.r > MAX_POS_D - 1.0 or abs(a.cy) + a.r > MAX_POS_D - 1.0:
        return False
    code, _ = strip_checksum(split_comment(raw)[0])
    p = param_texts(code)
    return ("I" in p or "J" in p) and "R" not in p and "Z" not in p


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


def _straight_parts(run):
    """Straight strokes of one run of adjacent compatible moves that is not a curve (curves
    off, fewer than 3 moves, or no vertex turning by more than the collinear tolerance): a
    new stroke wherever the direction drifts (Stroke.try_extend); [(first move, stroke)]."""
    out = []
    cur = Stroke(run[0])
    k0 = 0
    for k in range(1, len(run)):
        if not cur.try_extend(run[k]):
            out.append((k0, cur))
            cur, k0 = Stroke(run[k]), k
    out.append((k0, cur))
    return out


def _read_move(run, k, run_xy, z, v, accel, feature, e_rel):
    """The Move the reader made of run[k], a line of the run the model's Sim.run_lines read
    (group_lines' fast): run[k] is that move's E; its ends are run_xy's, its Z, feed,
    acceleration, feature and E mode the run's (equal to the bit: run_lines takes no other
    line), the rest the run's first move's (only G0/G1 lines are between: none changes
    them); has_f is not kept (None)."""
    m0, j = run[0], 2 * k
    return Move(m0.idx + k, LINE, run_xy[j], run_xy[j + 1], z, run_xy[j + 2], run_xy[j + 3], z, run[k], v, accel,
                feature, m0.layer, m0.lim, None, None, e_rel, False, False, False, m0.flow_r, m0.speed_r)


def _head_move(m, idx, x0, y0, z0, x1, y1, z1, e, v, has_f):
    """The Move step() made of the first line of a run that the model's Sim.run_lines opened
    (the line that closed the run before: group_lines' pre path, in C): its doubles as the
    reader read them, the rest the first move's of the run run_lines was handed, m (the
    run's feed, acceleration, feature, E mode and limits are equal to its; its layer, flow
    and speed factors only other lines change)."""
    return Move(idx, LINE, x0, y0, z0, x1, y1, z1, e, v, m.accel, m.feature, m.layer, m.lim, None, has_f, m.e_rel,
                False, False, False, m.flow_r, m.speed_r)


def _run_stroke(m, kind, ux, uy, length_d, e_per_mm, last_idx, pts, ends, prev_u, ss, travel):
    """The stroke group_lines' close() makes of a run that is one stroke, what Stroke(m) (and
    _curve(...) for a curve, pts its Points and ends its ends_d; else None, None: one move)
    and close's prev_u and start_state give, from what the run kept: (ux, uy) the first
    move's direction and e_per_mm / length_d as Stroke and _curve compute them (the same
    operations on the same floats, in group_lines); ss the run's start_state() or None,
    travel: the run's feature is travel (_kind_state)."""
    st = _new(Stroke)
    st.kind, st.arc, st.pts, st.curv, st.chain_T = kind, None, pts, None, None
    st.first_idx, st.last_idx = m.idx, last_idx
    st.x0, st.y0, st.z = m.x0, m.y0, m.z0
    st.ux, st.uy = ux, uy
    st.length_d, st._ends = length_d, ends
    st.v_feed, st.accel = m.v, m.accel
    st.feature, st.layer, st.e_rel = m.feature, m.layer, m.e_rel
    st.lim = m.lim
    st.e_per_mm = e_per_mm
    st.v0 = st.v1 = st.time_t = st.int_a2 = st.int_v2 = 0.0
    st._pux, st._puy = (None, None) if prev_u is None else prev_u
    st._nux = st._nuy = None
    st.v0_fw = st.v1_fw = None
    st.corner_cmd0 = st.corner_cmd1 = False
    if ss is None:
        st._ss_e = st._ss_a = st._ss_c = None
    else:
        st._ss_e, st._ss_a, st._ss_c = ss[0], (ss[2] if travel else ss[1]), ss[3]
    return st


_UNSET = object()


def _reduce(st):
    """copy / pickle of a Stroke over StrokeBase (which has no slots to copy by): the class
    and every field that is set, as the slotted class gives them ((None, {slot: value}))."""
    import copyreg
    fields = {n: v for n in FIELDS if (v := getattr(st, n, _UNSET)) is not _UNSET}
    return copyreg.__newobj__, (type(st),), (None, fields)


if _BASE is not None:
    # the field names where code looks them up (tests, benchmarks/mem_breakdown.py): read
    # only when a class is made, the empty tuple above made no slot
    Stroke.__slots__ = FIELDS
    Stroke.__reduce__ = _reduce



def line_spans(strokes):
    """(first_idx, last_idx) of every stroke of the list, two int64 arrays (the core reads
    StrokeBase's ints directly; else one attribute read each)."""
    import numpy as np
    n = len(strokes)
    lo, hi = np.empty(n, np.int64), np.empty(n, np.int64)
    if _CORE is not None and type(strokes) is list and _CORE.stroke_lines(strokes, lo, hi):
        return lo, hi
    from operator import attrgetter
    return (np.fromiter(map(attrgetter("first_idx"), strokes), np.int64, n),
            np.fromiter(map(attrgetter("last_idx"), strokes), np.int64, n))


def stroke_fields(strokes, names):
    """The fields `names` of every stroke of the list read by the compiled core, or None
    (no core, not all StrokeBase, a name it does not keep): (vals, kinds), float64 and int8
    arrays (len(strokes), len(names)): a float's value (kind 0), None (1, vals NaN), a
    bool (2, 1.0 / 0.0), another object (3) or an unset object field (4): read those
    yourself (segments.line_classes)."""
    if _CORE is None or type(strokes) is not list or not hasattr(_CORE, "stroke_fields"):
        return None
    import numpy as np
    vals, kinds = np.empty((len(strokes), len(names))), np.empty((len(strokes), len(names)), np.int8)
    return (vals, kinds) if _CORE.stroke_fields(strokes, tuple(names), vals, kinds) else None


def put_sums(strokes, got, v0, v1, time_t, int_a2, int_v2):
    """The model's sums given to the strokes of the list: v0 where got & 1, v1 where got & 2,
    time_t, int_a2, int_v2 to all (got an int64 array, the rest float64 arrays: the
    values their floats have)."""
    if _CORE is not None and type(strokes) is list and _CORE.stroke_put_sums(strokes, got, v0, v1, time_t, int_a2,
                                                                              int_v2):
        return
    for s, g, a, b, x, y, z in zip(strokes, got.tolist(), v0.tolist(), v1.tolist(), time_t.tolist(),
                                   int_a2.tolist(), int_v2.tolist()):
        if g == 3:              # (most strokes: both ends' records came)
            s.v0, s.v1, s.time_t, s.int_a2, s.int_v2 = a, b, x, y, z
            continue
        if g & 1:
            s.v0 = a
        if g & 2:
            s.v1 = b
        s.time_t, s.int_a2, s.int_v2 = x, y, z


_new = Stroke.__new__          # (object.__new__ for the pure-Python class; StrokeBase's otherwise)


def _kind_state(st, e0, ss):
    """(E before the stroke, the acceleration its kind of move uses, cruise ratio)."""
    return e0, (ss[2] if st.feature == "travel" else ss[1]), ss[3]


def group_strokes(event_iter, selected, min_length_d: float = 0.0, max_turn_deg: float = 0.0,
                  split_vertex=None, start_state=None):
    """Consume (idx, raw, event) triples; yield them on unchanged, and collect strokes.

    Yields ("line", idx, raw, event) for every line and ("stroke", stroke) when a stroke
    closes (after its last line has been yielded; several strokes may close at once, in
    file order).  Strokes shorter than min_length_d are dropped.  Keeping it a generator
    lets the firmware model run on the same stream.  A stroke's next_u is filled in when
    the next move arrives.  group_lines does the work (this wraps it).

    max_turn_deg > 0 turns curve strokes on: a run of adjacent compatible eligible G1 moves
    whose every vertex turns by <= max_turn_deg (and that split_vertex(prev_move, move, their
    lengths, their unit directions), if given, does not reject: a vertex whose firmware
    speed cap no acceleration lifts is below the feed) is one curve stroke when it really turns (a vertex turns by more than
    COLLINEAR_SIN); else straight strokes (_straight_parts).  A split_vertex carrying
    short_bounds(lim, accel, min_cos) (vertex_filter.splitter) is not called at a vertex whose
    two lengths lie in the bounds it returns: there it is proven False.

    start_state(), if given, is called when a run or an arc stroke starts (the reader has
    just read its first line) and must return (E before that line, acceleration of printing
    moves, of travel moves, cruise ratio) in force; each stroke gets
    ``start_state = (E before its first line, the acceleration of its kind, cruise ratio)``
    (a stroke inside a run: E summed along the run, as the reader sums it).
    """
    closed = []
    for idx, raw, ev in group_lines(event_iter, selected, closed.append, min_length_d, max_turn_deg,
                                    split_vertex, start_state):
        if closed:
            for st in closed:
                yield "stroke", st
            closed.clear()
        yield "line", idx, raw, ev
    for st in closed:
        yield "stroke", st


NOT_OPEN = 1 << 62        # group_lines' opened[0] when no run or arc is open


def group_lines(event_iter, selected, on_stroke, min_length_d: float = 0.0, max_turn_deg: float = 0.0,
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
    turned, runs opened), 0 (none taken) or None (it cannot: not called again).  Those
    lines are not yielded.  With the kit it is handed, it also takes the line that turns
    the run too sharply (the `pre` path below: the run closes, the next opens at that line)
    where close() would make at most one stroke without asking Python (none, one move, a
    curve), making that stroke as _run_stroke does and handing it to on_stroke; when it
    opened runs, rs holds r_last, r_ux, r_uy, run_prev_u, run_start and the first line of
    the last one, and run[0] its first Move (_head_move).

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
    r_ux = r_uy = 0.0      # the run's first move's direction
    pre = False            # the line read is a run's first, its x1, y1, d, ux, uy known (it closed a run)
    lazy = False           # fast read lines of the open run: their moves are floats in run
    pm, lux, luy = None, 0.0, 0.0   # the run's last move and its direction
    # split_vertex.short_bounds(lim, accel, min_cos) (vertex_filter.splitter): the segment
    # lengths at which split_vertex is proven False, kept for one (limits, acceleration)
    f_bounds = getattr(split_vertex, "short_bounds", None)
    f_lim, f_accel, f_lo, f_hi = None, None, 1.0, 0.0     # (a run of another acceleration clears f_lim)
    coll = COLLINEAR_SIN
    # what fast needs to close a run and open the next itself (Sim.run_lines' kit)
    kit = (Stroke, Points, array, K_LINE, K_CURVE, on_stroke, _head_move, float(min_length_d), curves)
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
                # Stroke(run[0])._curve(run, run_xy, run_ends, r_epm, r_last) and what follows
                st = _run_stroke(run[0], K_CURVE, r_ux, r_uy, run_ends[-1], r_epm, r_last, Points(run_xy),
                                 array("d", run_ends), run_prev_u, run_start, r_travel)
                run = []
            elif len(run) == 1:
                # Stroke(run[0]) and what follows: its length, E per mm are the run's
                st = _run_stroke(run[0], K_LINE, r_ux, r_uy, run_len, r_epm, r_last, None, None, run_prev_u,
                                 run_start, r_travel)
                run = []
            else:
                if lazy:
                    run = [_read_move(run, k, run_xy, r_z, r_v, r_accel, r_feature, r_erel)
                           if type(m) is float else m for k, m in enumerate(run)]
                parts = _straight_parts(run)
                if len(parts) > 1:
                    return close_parts(parts, next_u_known, next_u)
                st = parts[0][1]
                # one stroke: what close_parts does for it
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
                        rs = [r_last, r_ux, r_uy, run_prev_u, run_start, None]
                        got = fast(run, run_ends, run_xy, r_v, r_accel, r_feature, r_z, r_erel, r_travel, lux,
                                   luy, ld, run_len, r_epm, turned, min_cos, coll, split_vertex is not None,
                                   f_lim, f_lo, f_hi, kit, rs)
                        if got:
                            n, run_len, r_epm, ld, lux, luy, turned, reopened = got
                            if reopened:            # it closed the run and opened others: the last one's
                                r_last, r_ux, r_uy, run_prev_u, run_start, opened[0] = rs
                            else:
                                r_last += n
                            pm, lazy = run[-1], True
                        elif got is None:
                            fast = None
                    yield idx, raw, ev
                    continue
                ok = pre = True                     # (d, ux, uy: the new run's first move's, below)
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
            x0, y0 = ev.x0, ev.y0
            if pre:        # the line that closed the run: x1, y1, d, ux, uy are its (the same operations)
                pre = False
                lux, luy = ux, uy                   # (one pair of floats: this run's ux, uy, that stroke's next_u)
            else:
                x1, y1 = ev.x1, ev.y1
                dx, dy = x1 - x0, y1 - y0
                d = hypot(dx, dy)
                lux, luy = dx / d, dy / d
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
            pm = ev                               # (lux, luy): _direction(ev, True) of an eligible line
            r_ux, r_uy = lux, luy                 # Stroke(ev)'s ux, uy
            last_u = (lux, luy)
            if fast is not None:                  # the lines that follow, in C
                rs = [r_last, r_ux, r_uy, run_prev_u, run_start, None]
                got = fast(run, run_ends, run_xy, r_v, r_accel, r_feature, r_z, r_erel, r_travel, lux, luy, ld,
                           run_len, r_epm, turned, min_cos, coll, split_vertex is not None, f_lim, f_lo, f_hi,
                           kit, rs)
                if got:
                    n, run_len, r_epm, ld, lux, luy, turned, reopened = got
                    if reopened:                  # (as above)
                        r_last, r_ux, r_uy, run_prev_u, run_start, opened[0] = rs
                    else:
                        r_last += n
                    pm, lazy = run[-1], True
                elif got is None:
                    fast = None
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
        if gap is not None and not run and arc is None:
            got = gap(last_u, waiting is not None)      # the lines that follow, in C
            if got:
                last_u = got[1]
            elif got is None:
                gap = None
        yield idx, raw, ev
    close(False, None)
