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

from .state import ARC, LINE
from .words import param_texts, split_comment, strip_checksum

COLLINEAR_SIN = 1e-3      # |sin| of the turn below which two moves are one line (0.06 deg)

# Stroke.kind
K_LINE, K_ARC, K_CURVE = "line", "arc", "curve"


class Stroke:
    """Geometry and original timing of one straight stroke (original file's figures)."""
    __slots__ = ("first_idx", "last_idx", "x0", "y0", "z", "ux", "uy", "length_d", "ends_d",
                 "e_per_move", "v_feed", "accel", "feature", "layer", "e_rel",
                 "v0", "v1", "time_t", "int_a2", "int_v2", "lim", "e_per_mm",
                 "prev_u", "next_u", "kind", "arc", "pts")

    def __init__(self, m):
        self.kind = K_LINE
        self.arc = None              # state.Arc of an arc stroke
        self.pts = None              # curve strokes: list of (x, y) vertices, start included
        self.first_idx = self.last_idx = m.idx
        self.x0, self.y0, self.z = m.x0, m.y0, m.z0
        d = math.hypot(m.x1 - m.x0, m.y1 - m.y0)
        self.ux, self.uy = (m.x1 - m.x0) / d, (m.y1 - m.y0) / d
        self.length_d = d
        self.ends_d = [d]            # distance from stroke start to each original vertex
        self.e_per_move = [m.e]
        self.v_feed, self.accel = m.v, m.accel
        self.feature, self.layer, self.e_rel = m.feature, m.layer, m.e_rel
        self.lim = m.lim
        self.e_per_mm = m.e / d
        self.v0 = self.v1 = self.time_t = self.int_a2 = self.int_v2 = 0.0
        self.prev_u = self.next_u = None     # XY directions of the neighbouring moves (None: a stop)

    @property
    def n_moves(self) -> int:
        return self.last_idx - self.first_idx + 1

    @classmethod
    def of_arc(cls, m):
        """A G2/G3 move on its own: path length S = R |sweep| (no Z change)."""
        st = cls.__new__(cls)
        st.kind, st.arc, st.pts = K_ARC, m.arc, None
        st.first_idx = st.last_idx = m.idx
        st.x0, st.y0, st.z = m.x0, m.y0, m.z0
        a = m.arc
        sgn = 1.0 if a.sweep > 0 else -1.0
        st.ux, st.uy = -math.sin(a.theta0) * sgn, math.cos(a.theta0) * sgn   # start tangent
        st.length_d = a.length_d
        st.ends_d = [a.length_d]
        st.e_per_move = [m.e]
        st.v_feed, st.accel = m.v, m.accel
        st.feature, st.layer, st.e_rel = m.feature, m.layer, m.e_rel
        st.lim = m.lim
        st.e_per_mm = m.e / a.length_d
        st.v0 = st.v1 = st.time_t = st.int_a2 = st.int_v2 = 0.0
        st.prev_u = st.next_u = None
        return st

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
        self.e_per_move.append(m.e)
        self.e_per_mm = max(self.e_per_mm, m.e / d)
        return True


def eligible(m, selected: frozenset) -> bool:
    """A move we may re-time: a plain straight XY line, constant Z, absolute XYZ in mm (G21),
    no checksum (renumbering checksummed lines is the host's job), selected feature."""
    return (m.kind == LINE and m.feature in selected and not m.checksum and not m.xyz_rel and not m.inch
            and m.z0 == m.z1 and (m.x1 != m.x0 or m.y1 != m.y0)
            and (m.e > 0.0 or (m.e == 0.0 and m.feature == "travel")))


def eligible_arc(m, raw, selected: frozenset) -> bool:
    """A G2/G3 we may re-time: selected feature, I/J form (the centre is in the file's
    text, so sub-arcs can keep it exactly), absolute XY in mm, no checksum, no Z change,
    extruding, at least 1 mm long."""
    if not (m.kind == ARC and m.feature in selected and not m.checksum and not m.xyz_rel and not m.inch
            and m.z0 == m.z1 and m.e > 0.0 and m.arc.length_d >= 1.0):
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


def group_strokes(event_iter, selected, min_length_d: float = 0.0):
    """Consume (idx, raw, event) triples; yield them on unchanged, and collect strokes.

    Yields ("line", idx, raw, event) for every line and ("stroke", stroke) when a stroke
    closes (after its last line has been yielded).  Strokes shorter than min_length_d are
    dropped.  Keeping it a generator lets the firmware model run on the same stream.
    A stroke's next_u is filled in when the next move arrives.
    """
    selected = frozenset(selected)
    cur = None
    last_u = None          # direction of the last move; None after a stop
    waiting = None         # closed stroke still waiting for the next move's direction
    for idx, raw, ev in event_iter:
        is_move = ev is not None and hasattr(ev, "kind")
        if waiting is not None and ev is not None:
            waiting.next_u = _direction(ev, False) if is_move else None
            waiting = None
        if cur is not None:
            if is_move and eligible(ev, selected) and cur.try_extend(ev):
                last_u = (cur.ux, cur.uy)
                yield "line", idx, raw, ev
                continue
            if cur.length_d >= min_length_d:
                if is_move:
                    cur.next_u = _direction(ev, False)
                elif ev is None:
                    waiting = cur
                yield "stroke", cur
            cur = None
        if is_move and eligible(ev, selected):
            cur = Stroke(ev)
            cur.prev_u = last_u
        elif is_move and ev.kind == ARC and eligible_arc(ev, raw, selected):
            cur = Stroke.of_arc(ev)          # closes at the next line: try_extend refuses
            cur.prev_u = last_u
        if is_move:
            last_u = _direction(ev, True)
        elif ev is not None:           # a Barrier: the planner stops
            last_u = None
        yield "line", idx, raw, ev
    if cur is not None and cur.length_d >= min_length_d:
        yield "stroke", cur
