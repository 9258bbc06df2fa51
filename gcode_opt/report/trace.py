"""Play one file through the firmware model and keep what the report draws.

``trace_file(path, profile)`` returns a ``Trace``: the ``SimResult``, one ``LineRecord``
per moving line, the ``Move`` of every moving line, and every planned block as columns
of numpy arrays (start/end point, speeds, acceleration and the three trapezoid phase
times), so a stroke's as-executed speed profile can be rebuilt phase by phase.
"""
from __future__ import annotations

from array import array

import numpy as np

from .. import state as st
from ..firmware.simulate import simulate_events

BLOCK_FIELDS = ("idx", "x0", "y0", "x1", "y1", "d", "start_v", "cruise_v", "end_v", "accel",
                "accel_t", "cruise_t", "decel_t", "v2_int", "nominal_v")


class Trace:
    """Figures of one file as the firmware model executes it."""

    def __init__(self, res, lines, moves, blocks, n_lines):
        self.res = res              # SimResult
        self.lines = lines          # idx -> LineRecord
        self.moves = moves          # idx -> state.Move
        self.blocks = blocks        # field -> np.ndarray (BLOCK_FIELDS), in execution order
        self.n_lines = n_lines      # lines in the file

    def block_range(self, first_idx, last_idx):
        """Slice of the block arrays for source lines first_idx..last_idx (0-based)."""
        idx = self.blocks["idx"]
        lo = int(np.searchsorted(idx, first_idx, side="left"))
        hi = int(np.searchsorted(idx, last_idx, side="right"))
        return slice(lo, hi)

    def line_sum(self, first_idx, last_idx, attr):
        return float(sum(getattr(self.lines[i], attr) for i in range(first_idx, last_idx + 1)
                         if i in self.lines))

    def line_max(self, first_idx, last_idx, attr):
        vals = [getattr(self.lines[i], attr) for i in range(first_idx, last_idx + 1) if i in self.lines]
        return float(max(vals)) if vals else 0.0


def trace_file(path, profile, ringing=False) -> Trace:
    """ringing: also keep the rows of the commanded motion ringing.py solves (Trace.ring_rows,
    from the same firmware-model pass)."""
    from .. import ringing as rg
    ring = rg.Rows() if ringing else None
    ring_line = ring_block = None
    if ring is not None:
        ring_line, ring_block, ring_dwell = rg.hooks(ring)
    lines = {}
    moves = {}
    cols = {k: array("d") for k in BLOCK_FIELDS}
    cursor = [0.0, 0.0]
    count = [0]

    def feed():
        for idx, raw, ev in st.events(path, profile):
            count[0] = idx + 1
            if ev is not None and type(ev) is st.Move:
                moves[idx] = ev
            yield idx, raw, ev

    def on_line(rec):
        lines[rec.idx] = rec
        if ring_line is not None:
            ring_line(rec)

    def on_block(b):
        if b.first:
            m = moves[b.idx]
            cursor[0], cursor[1] = m.x0, m.y0
        x0, y0 = cursor
        x1, y1 = x0 + b.d * b.ux, y0 + b.d * b.uy
        cursor[0], cursor[1] = x1, y1
        sv, cv, ev = b.start_v, b.cruise_v, b.end_v
        v2 = (b.accel_t * (sv * sv + sv * cv + cv * cv) + b.decel_t * (ev * ev + ev * cv + cv * cv)) / 3.0 \
            + b.cruise_t * cv * cv
        for k, v in zip(BLOCK_FIELDS, (b.idx, x0, y0, x1, y1, b.d, sv, cv, ev, b.accel,
                                       b.accel_t, b.cruise_t, b.decel_t, v2, b.nominal_v)):
            cols[k].append(v)
        if ring_block is not None:
            ring_block(b)

    events = feed() if ring is None else rg.wrap_events(feed(), ring_dwell)
    res = simulate_events(events, profile, on_line=on_line, on_block=on_block)
    blocks = {k: np.frombuffer(v, dtype=float).copy() if len(v) else np.zeros(0) for k, v in cols.items()}
    blocks["idx"] = blocks["idx"].astype(int)
    tr = Trace(res, lines, moves, blocks, count[0])
    tr.ring_rows = ring.items if ring is not None else None
    return tr


def count_lines(path) -> int:
    with open(path, "rb") as fh:
        return sum(1 for _ in fh)


def profile_points(blocks, sl, t0=0.0):
    """As-executed speed and tangential acceleration of blocks[sl] against time.

    Returns (t_v, v, t_a, a): piecewise-linear speed knots (mm/s) and a step function of
    acceleration (mm/s^2, two points per phase so it plots as steps), t from t0 (s)."""
    tv, vv, ta, aa = [], [], [], []
    t = t0
    for k in range(sl.start, sl.stop):
        sv, cv, ev = blocks["start_v"][k], blocks["cruise_v"][k], blocks["end_v"][k]
        acc = blocks["accel"][k]
        at, ct, dt = blocks["accel_t"][k], blocks["cruise_t"][k], blocks["decel_t"][k]
        for dur, v_end, a in ((at, cv, acc), (ct, cv, 0.0), (dt, ev, -acc)):
            if dur <= 0.0:
                continue
            if not tv:
                tv.append(t)
                vv.append(sv)
            ta += [t, t + dur]
            aa += [a, a]
            t += dur
            tv.append(t)
            vv.append(v_end)
    return np.array(tv), np.array(vv), np.array(ta), np.array(aa)
