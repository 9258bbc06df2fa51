"""Ringing of a G-code file: the firmware model's commanded motion through the resonance
model (firmware/resonance.py).

``trace(path, profile)`` plays the file with the firmware model and returns the commanded
XY motion as pieces of constant acceleration (three per planned block: accelerate, cruise,
decelerate; one per rest: E-only moves and dwells), with the velocity jump at each piece's
start.  ``figures(path, profile)`` gives, per axis, RMS and peak ringing (micrometres) and
their parts excited by the ramps (acceleration steps), the corners (junctions turning more
than 30 degrees, the firmware model's corner threshold, and the jumps into and out of rest)
and the gentle turns (junctions of curves cut into segments); with an input shaper in the
profile, the ringing of the shaped motion and the shaper's path smoothing.

``figures`` streams: a ``Collector`` rides on one firmware-model pass (``play``, or
``hooks`` + ``wrap_events`` beside a pass's own callbacks) and solves the pieces 16 k blocks
at a time, carrying each oscillator's state across chunks, so memory does not grow with
the file; ``trace`` keeps the whole motion (plots, tests); the report draws its stretch
from kept rows (``RowTable``: 12 numbers a block) solving only windows of them.

What is modelled: X and Y of the toolhead as the firmware commands them (Z and E are not);
each axis a linear damped oscillator with the profile's [resonance] frequency and damping;
the machine at rest before the file starts and after it ends (the last ring-down counts).
"""
from __future__ import annotations

import math
import operator
from array import array
from itertools import chain

import numpy as np

from .distinct import distinct
from . import state as st
from .firmware.resonance import (Oscillator, Response, RingMemo, RingRoom, Room, _smoothing_chunk,
                                 release_solve_room, shaped_events, shaper_pulses, smoothing)
from .firmware import simulate as fwsim
from .firmware.simulate import CORNER_COS, simulate_file

UM = 1000.0               # mm -> micrometres
NONE, CORNER, TURN = 0, 1, 2
PARTS = ("ramp", "corner", "turn")


class Trace:
    """Commanded XY motion, one row per piece (numpy arrays of equal length n):
    t0 (s) start, dur (s), acc (n x 2, mm/s^2), vel (n x 2, mm/s, at the start, after the
    jump), dv (n x 2, the velocity jump at the start), da (n x 2, the acceleration step at
    the start), pos (n x 2, mm, relative to the first move's start), s (mm of path at the
    start), speed (mm/s at the start), tan_a (mm/s^2 along the path), cls (NONE / CORNER /
    TURN: what kind of velocity jump starts the piece), idx (0-based source line, -1 for
    rests).  The first and the last three pieces are the machine idle (1 s) before and after
    the file; time 0 is the file's start."""

    def __init__(self, rows):
        self.__dict__.update(rows)

    @property
    def total_t(self) -> float:
        return float(self.dur[3:-3].sum())

    def __len__(self):
        return len(self.t0)


ROW = 12                  # numbers per block or rest in the firmware model's stream
IDLE = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, -1, 0.0)   # 1 s at rest


def _block_row(b):
    return (b.ux, b.uy, b.start_v, b.cruise_v, b.end_v, b.accel, b.accel_t, b.cruise_t,
            b.decel_t, 1.0 if b.after_stop else 0.0, b.idx, 1.0)


# a block's row but its last number (1.0): the same values _block_row reads, in its order
_BLOCK_FIELDS = operator.attrgetter("ux", "uy", "start_v", "cruise_v", "end_v", "accel", "accel_t",
                                    "cruise_t", "decel_t", "after_stop", "idx")


def _rest_row(dt_t):
    return (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, dt_t, 0.0, 1.0, -1, 0.0)


def hooks(sink):
    """(on_line, on_block, on_barrier_dwell) that feed `sink` (a Collector, or anything with
    on_block(b) and rest(dt_t)) from a firmware-model pass: E-only moves and dwells are
    rests.  on_barrier_dwell(dwell_t) must be called once the simulator took the Barrier
    (wrap_events does it).

    A Collector with a RowSink gets the sink's own hooks: the compiled model writes the
    rests into the sink itself (where these hooks would), and then its line() and dwell()
    do nothing; played by the Python model, they write them."""
    rows = getattr(sink, "sink", None)
    if rows is not None:
        return rows.line, rows, rows.dwell
    eonly = st.EONLY

    def on_line(rec):
        if rec.kind == eonly:
            sink.rest(rec.time_t)
    return on_line, sink.on_block, sink.rest


def wrap_events(event_iter, on_barrier_dwell):
    """The (idx, raw, event) stream, calling on_barrier_dwell(dwell_t) after each Barrier:
    the generator resumes only after the simulator took it, so its blocks are flushed.
    When on_barrier_dwell is a RowSink's dwell and the compiled model writes that sink's
    rests (known once the pass began: the model exists before the first event is taken),
    the events pass through untouched."""
    rows = getattr(on_barrier_dwell, "__self__", None)
    if rows is not None and getattr(rows, "sim_rests", False):
        yield from event_iter
        return
    Barrier = st.Barrier
    for item in event_iter:
        yield item
        ev = item[2]
        if type(ev) is Barrier:
            on_barrier_dwell(ev.dwell_t)


def play(path, profile, sink, on_line=None):
    """One firmware-model pass over the file feeding `sink`; returns the SimResult.
    on_line, if given, sees every LineRecord too.  Read in chunks (simulate_file); where
    the compiled model writes a RowSink's rests itself (its line() then does nothing) and
    no on_line is asked for, the model gets no Python callback per record, so its play()
    reads the common lines through the reader's fused loop."""
    ring_line, on_block, on_dwell = hooks(sink)
    if on_line is not None:
        def both(rec, _a=on_line, _b=ring_line):
            _a(rec)
            _b(rec)
    elif on_block is not None and type(on_block) is _row_sink_type() and fwsim.CORE == "c":
        both = None
    else:
        both = ring_line
    return simulate_file(path, profile, both, on_block, on_barrier=on_dwell)


class Rows:
    """Whole-trace sink: every row kept (12 floats a block; trace_from_items(rows.items)
    makes the pieces), for plots and tests."""

    def __init__(self):
        self.items = array("d")

    @classmethod
    def padded(cls):
        """Rows whose items begin with the idle row: add the closing one with close_padded(),
        then RowTable(items, model, padded=True) reads them in place."""
        r = cls()
        r.items.extend(IDLE)
        return r

    def close_padded(self):
        self.items.extend(IDLE)

    def on_block(self, b):
        self.items.extend(_block_row(b))

    def rest(self, dt_t):
        if dt_t > 0.0:
            self.items.extend(_rest_row(dt_t))


def trace(path, profile) -> Trace:
    """Play the file (firmware/simulate.py) and collect its whole commanded motion (memory
    grows with the file: ~0.4 kB per block; figures() streams instead)."""
    rows = Rows()
    res = play(path, profile, rows)
    tr = trace_from_items(rows.items)
    tr.sim = res                             # the firmware model's SimResult of the same pass
    return tr


class _Carry:
    """Where the pieces built so far end: what the next rows' pieces continue from (the
    machine at rest at the origin, 1 s before the file, to start)."""

    def __init__(self):
        self.t, self.s = -1.0, 0.0
        self.pos, self.vel_end, self.acc = np.zeros(2), np.zeros(2), np.zeros(2)
        self.ux = self.uy = self.isb = 0.0


def trace_from_items(items) -> Trace:
    """Build the pieces from (ux, uy, start_v, cruise_v, end_v, accel, accel_t, cruise_t,
    decel_t, after_stop, idx, is_block) rows (rests: is_block 0, cruise_t = duration)."""
    m = np.asarray(items, float).reshape(-1, ROW)
    idle = np.array([IDLE])
    return _pieces(np.vstack([idle, m, idle]), _Carry())   # at rest before and after (1 s each, not counted)


def _pieces(m, c: _Carry, full: bool = True) -> Trace:
    """The pieces of rows m (k x 12) following on from c; c moves to their end.  Without
    `full`, no pos, s, idx (None; c's pos and s left behind): the ringing needs only t0,
    dv, da, cls (and vel, acc)."""
    ux, uy, sv, cv, ev, a, at, ct, dt, after, idx, isb = m.T
    dur = np.stack([at, ct, dt], 1).ravel()
    speed = np.stack([sv, cv, cv], 1).ravel()
    tan_a = np.stack([a, 0.0 * a, -a], 1).ravel()
    u = np.repeat(np.stack([ux, uy], 1), 3, axis=0)
    vel = speed[:, None] * u
    acc = tan_a[:, None] * u
    end_speed = speed + tan_a * dur
    vel_end = end_speed[:, None] * u
    cs = np.cumsum(dur)
    t0 = c.t + np.concatenate([[0.0], cs[:-1]])              # the file starts at t = 0
    if full:
        ds = speed * dur + 0.5 * tan_a * dur * dur
        cs_s = np.cumsum(ds)
        s = c.s + np.concatenate([[0.0], cs_s[:-1]])
        cs_p = np.cumsum(ds[:, None] * u, axis=0)
        pos = c.pos + np.vstack([[0.0, 0.0], cs_p[:-1]])
    n = len(dur)
    # velocity jumps: only where a block or a rest begins (inside a block the speed is
    # continuous; take it exactly so rounding does not ring)
    starts = np.zeros(n, bool)
    starts[::3] = True
    prev_end = np.vstack([c.vel_end, vel_end[:-1]])
    dv = np.where(starts[:, None], vel - prev_end, 0.0)
    da = acc - np.vstack([c.acc, acc[:-1]])
    # a junction is a gentle turn when consecutive blocks are both moving and turn < 30 deg
    cls = np.zeros(n, np.int8)
    pux, puy, pisb = np.concatenate([[c.ux], ux[:-1]]), np.concatenate([[c.uy], uy[:-1]]), \
        np.concatenate([[c.isb], isb[:-1]])
    cos_turn = ux * pux + uy * puy
    moving_pair = (isb > 0) & (pisb > 0) & (after == 0)
    gentle = moving_pair & (cos_turn >= CORNER_COS)
    cls[::3] = np.where(gentle, TURN, CORNER)
    # an axis-parallel pair (e.g. pure Z) has cos 0 with no XY turn: its XY jump is 0 anyway
    c.t = c.t + float(cs[-1])
    c.vel_end, c.acc = vel_end[-1].copy(), acc[-1].copy()
    c.ux, c.uy, c.isb = float(ux[-1]), float(uy[-1]), float(isb[-1])
    if not full:
        return Trace(dict(t0=t0, dur=dur, acc=acc, vel=vel, dv=dv, da=da, pos=None, s=None,
                          speed=speed, tan_a=tan_a, cls=cls, idx=None))
    c.s = c.s + float(cs_s[-1])
    c.pos = c.pos + cs_p[-1]
    return Trace(dict(t0=t0, dur=dur, acc=acc, vel=vel, dv=dv, da=da, pos=pos, s=s,
                      speed=speed, tan_a=tan_a, cls=cls, idx=np.repeat(idx, 3).astype(np.int64)))


def model_of(profile):
    """The resonance and shaper in force, as the profile states them."""
    fx = getattr(profile, "freq_x_hz", 50.0)
    fy = getattr(profile, "freq_y_hz", 50.0)
    sfx = getattr(profile, "shaper_freq_x_hz", 0.0) or fx
    sfy = getattr(profile, "shaper_freq_y_hz", 0.0) or fy
    return dict(freq_x_hz=fx, freq_y_hz=fy, damping_r=getattr(profile, "damping_r", 0.1),
                shaper=getattr(profile, "shaper", "none"), shaper_freq_x_hz=sfx,
                shaper_freq_y_hz=sfy, shaper_damping_r=getattr(profile, "shaper_damping_r", 0.1))


def _jumps(tr: Trace, model: dict, name: str, ax: int, part: str):
    """(dr, drp): the ringing's jumps at the pieces' starts for one axis and part."""
    w = 2.0 * math.pi * model[f"freq_{name}_hz"]
    if part == "ramp":
        return tr.da[:, ax] / (w * w), None
    if part == "all":
        return tr.da[:, ax] / (w * w), -tr.dv[:, ax]
    cls = CORNER if part == "corner" else TURN
    return None, np.where(tr.cls == cls, -tr.dv[:, ax], 0.0)


def response(tr: Trace, model: dict, name: str, part: str = "all", shaper: str | None = None):
    """The Response of axis name ('x'/'y') to the jumps of `part` ('all', 'ramp', 'corner',
    'turn'), through the shaper (the model's unless given).  Events whose jumps are both
    zero are left out (the free decay runs on across them)."""
    shaper = model["shaper"] if shaper is None else shaper
    ax = "xy".index(name)
    osc = Oscillator(model[f"freq_{name}_hz"], model["damping_r"])
    dr, drp = _jumps(tr, model, name, ax, part)
    keep = np.zeros(len(tr), bool)
    for j in (dr, drp):
        if j is not None:
            keep |= j != 0.0
    t = tr.t0[keep]
    zero = np.zeros(len(t))
    dr = zero if dr is None else dr[keep]
    drp = zero if drp is None else drp[keep]
    a_p, t_p = shaper_pulses(shaper, model[f"shaper_freq_{name}_hz"], model["shaper_damping_r"])
    t_ev, (dr_s, drp_s) = shaped_events(t, (dr, drp), a_p, t_p)
    return Response(osc, t_ev, dr_s, drp_s)


def responses(tr: Trace, model: dict, shaper: str | None = None):
    """{axis: {part: Response}} for parts 'all', 'ramp', 'corner', 'turn' (all in memory at
    once: for plots and tests; figures_of_trace solves one at a time)."""
    return {name: {part: response(tr, model, name, part, shaper) for part in ("all",) + PARTS}
            for name in "xy"}


def _axis_figures(tr: Trace, model: dict, name: str, shaper: str, total_t: float) -> dict:
    got = {}
    for part in ("all",) + PARTS:
        r = response(tr, model, name, part, shaper)
        got[part] = (r.int_r2(), r.peak())
        del r
    return _axis_dict(got, total_t)


def _axis_dict(got: dict, total_t: float) -> dict:
    """{part: (int r^2 dt, peak |r|)} -> rms / peak (micrometres) per part (those in got)."""
    d = {}
    for part in ("all",) + PARTS:
        if part not in got:           # a Collector without the parts (parts=False)
            continue
        i_r2, peak = got[part]
        key = "" if part == "all" else "_" + part
        d["rms" + key + "_um"] = math.sqrt(max(i_r2, 0.0) / total_t) * UM if total_t > 0 else 0.0
        d["peak" + key + "_um"] = peak * UM
    return d


def _assemble(model: dict, shaper: str, total_t: float, axes: dict, smooth=None) -> dict:
    out = {"model": dict(model, shaper=shaper), "time_s": total_t}
    out.update(axes)
    # the XY error vector: RMS adds in squares; its peak is at least the larger axis'
    xy = {}
    for key in ("rms_um", "rms_ramp_um", "rms_corner_um", "rms_turn_um"):
        if key in out["x"]:
            xy[key] = math.hypot(out["x"][key], out["y"][key])
    xy["peak_um"] = max(out["x"]["peak_um"], out["y"]["peak_um"])
    out["xy"] = xy
    if smooth is not None:
        rms_d, max_d = smooth
        out["smoothing"] = {"rms_um": rms_d * UM, "max_um": max_d * UM}
    return out


def _pulses(model: dict, shaper: str):
    return [shaper_pulses(shaper, model[f"shaper_freq_{a}_hz"], model["shaper_damping_r"]) for a in "xy"]


def figures_of_trace(tr: Trace, model: dict, shaper: str | None = None) -> dict:
    shaper = model["shaper"] if shaper is None else shaper
    total_t = tr.total_t
    axes = {name: _axis_figures(tr, model, name, shaper, total_t) for name in "xy"}
    smooth = smoothing(tr.t0, tr.pos, tr.vel, tr.acc, _pulses(model, shaper)) if shaper != "none" else None
    return _assemble(model, shaper, total_t, axes, smooth)


# ---------------------------------------------------------------- streaming, bounded memory
# blocks turned into pieces and solved at once.  4096, not 16384: each chunk's rows, pieces
# and solve temporaries were ~13 MB more at once (peak RSS: the analyse pass 102 -> 89 MB,
# the rectilinear plate's measure pass 171 -> 160 MB, a 8 k-line file's ringing pass 62 ->
# 55 MB), for the same CPU.  The figures are the same up to rounding: the sums and the
# oscillators' carry are cut at other rows (at most ~1e-10 relative on the bundled samples
# and corpus; tests/test_ringing_stream.py: any chunk size against the whole trace)
CHUNK_BLOCKS = 4096
PEND_BLOCKS = 1024        # planned blocks a Collector keeps before it writes their rows
STREAM_SMOOTH = 1 << 16   # merged pieces of the shaper smoothing evaluated at once


class _Stream:
    """The ringing of one axis and part, solved chunk by chunk: events (shaped) wait until
    no later chunk can bring an earlier one; the amplitude after the last solved event and
    its time carry the oscillator across chunks (its piece's length is known only when the
    next event is)."""

    def __init__(self, osc: Oscillator, pulses, memo=None, lead=False):
        self.osc, (self.a_p, self.t_p) = osc, pulses
        self.t = np.zeros(0)
        self.dr, self.drp = np.zeros(0), np.zeros(0)
        self.t_last, self.c_last = None, 0j
        self.t1 = None                  # add_joined's t1 for _solve (during its call only)
        self.int_r2, self.peak = 0.0, 0.0
        # the exponentials shared with the streams of the same oscillator (resonance.RingMemo;
        # lead: this stream's go into it, for the others)
        self.memo, self.lead = memo, lead
        # no shaper (one pulse, weight 1.0 at time 0.0): shaped_events is t + 0.0 and the
        # jumps times 1.0, i.e. the jumps themselves
        self.plain = len(self.a_p) == 1 and float(self.a_p[0]) == 1.0 and float(self.t_p[0]) == 0.0

    def add(self, t, dr, drp, horizon_t):
        """Unshaped events (time, dr, drp); solve every event earlier than horizon_t."""
        if self.plain:
            t_s, dr_s, drp_s = t + 0.0, dr, drp
        else:
            t_s, (dr_s, drp_s) = shaped_events(t, (dr, drp), self.a_p, self.t_p)
        if len(self.t):
            t_all = np.concatenate([self.t, t_s])
            dr_all = np.concatenate([self.dr, dr_s])
            drp_all = np.concatenate([self.drp, drp_s])
        else:                   # nothing waits: the new events as they are (the same numbers)
            t_all, dr_all, drp_all = t_s, dr_s, drp_s
        if not (t_all[:-1] <= t_all[1:]).all():     # in order already (no shaper): the sort keeps it
            order = np.argsort(t_all, kind="stable")
            t_all, dr_all, drp_all = t_all[order], dr_all[order], drp_all[order]
        k = int(np.searchsorted(t_all, horizon_t, side="left"))
        self._solve(t_all[:k], dr_all[:k], drp_all[:k])
        # what waits is copied: a few events, not a view holding the chunk's arrays
        self.t, self.dr, self.drp = t_all[k:].copy(), dr_all[k:].copy(), drp_all[k:].copy()

    def front(self) -> int:
        """The numbers add_joined's arrays hold before the new events: the carried time
        (if any) and the events that wait."""
        return (self.t_last is not None) + len(self.t)

    def add_joined(self, t1, dr1, drp1, horizon_t):
        """add() of the new events at t1[front():] (dr1, drp1: the waiting events' then the
        new ones'), where the caller wrote the carried time and the waiting events in
        front of them (_events' lead): the same steps without concatenating (~8 instructions
        a number each; the concatenations add and _solve make)."""
        has_last, nw = self.t_last is not None, len(self.t)
        if self.plain:
            # (the steps below and _solve's in one call of the core, where it takes them)
            got = self.osc.join(t1, dr1, drp1, has_last, nw, horizon_t, self.c_last if has_last else None,
                                self.peak)
            if got is not None:
                k, solved = got
                if k:
                    self._solved(solved, t1[has_last + k - 1])
                self.t, self.dr, self.drp = t1[has_last + k:].copy(), dr1[k:].copy(), drp1[k:].copy()
                return
        new_t = t1[has_last + nw:]
        new_t += 0.0                    # (add's t + 0.0, in place: no shaper here)
        t_all = t1[has_last:]
        if not self.plain or not (t_all[:-1] <= t_all[1:]).all():
            self.add(new_t, dr1[nw:], drp1[nw:], horizon_t)     # (the new events, as add takes them)
            return
        k = int(np.searchsorted(t_all, horizon_t, side="left"))
        self.t1 = t1[:has_last + k]     # (_solve's t after the carried time, made)
        try:
            self._solve(t_all[:k], dr1[:k], drp1[:k])
        finally:
            self.t1 = None
        self.t, self.dr, self.drp = t_all[k:].copy(), dr1[k:].copy(), drp1[k:].copy()

    def _solve(self, t, dr, drp):
        if len(t) == 0:
            return
        osc = self.osc
        # in one call of the core where it gives these steps' bits (Oscillator.solve); t1:
        # t after the carried time, unless add_joined has it
        t1 = self.t1
        if t1 is None:
            t1 = t if self.t_last is None else np.concatenate([[self.t_last], t])
        got = osc.solve(t1, dr, drp, None if self.t_last is None else self.c_last, self.peak)
        if got is not None:
            self._solved(got, t1[-1])
            return
        dc = osc.jump_amplitude(dr, drp)
        if self.t_last is not None:        # the carried amplitude starts the cumulative sum
            t = np.concatenate([[self.t_last], t])
            dc = np.concatenate([[self.c_last], dc])
        memo, lead = self.memo, self.lead
        c = osc.amplitudes(t, dc, memo, lead)
        if len(c) > 1:
            dur = np.diff(t)
            if np.isfinite(dur).all():
                self.int_r2 += osc.integral_r2_fin_sum(c[:-1], dur, memo, lead, t[:-1])
            else:
                self.int_r2 += float(osc.integral_r2(c[:-1], dur).sum())
            self.peak = max(self.peak, osc.max_abs_r(c[:-1], dur))
        self.t_last, self.c_last = float(t[-1]), complex(c[-1])

    def _solved(self, got, t_last):
        """The core's (sum, peak, last amplitude) of events up to t_last taken in."""
        i_r2, peak, c_last = got
        if peak is not None:
            self.int_r2 += i_r2
            self.peak = max(self.peak, peak)
        self.t_last, self.c_last = float(t_last), c_last

    def finish(self):
        self._solve(self.t, self.dr, self.drp)
        self.t = np.zeros(0)
        if self.t_last is not None:        # the last rings down at rest
            c, inf = np.array([self.c_last]), np.array([np.inf])
            self.int_r2 += float(self.osc.integral_r2(c, inf)[0])
            self.peak = max(self.peak, float(self.osc.peak_abs_r(c, inf)[0]))
            self.t_last = None
        return self.int_r2, self.peak


class _SmoothStream:
    """resonance.smoothing over a window of pieces: the merged pieces between breakpoints
    (piece starts, shifted by every pulse time) are integrated once every breakpoint up to
    them is known, i.e. below the pieces' end plus the earliest (negative) pulse time; the
    window keeps the pieces later merged pieces still look up (back to the latest pulse
    time)."""

    def __init__(self, pulses):
        self.pulses = pulses
        ts = np.concatenate([t_p for _a, t_p in pulses] + [np.zeros(1)])
        self.t_min, self.t_max = float(ts.min()), float(ts.max())
        self.win = None
        self.lo = self.t_first = None
        self.integral, self.max_d = 0.0, 0.0

    def add(self, tr: Trace, t_end: float, final: bool):
        new = (tr.t0, tr.pos, tr.vel, tr.acc)
        if self.win is None:
            self.win = new
            self.lo = self.t_first = float(tr.t0[0])
        else:
            self.win = tuple(np.concatenate([w, x]) for w, x in zip(self.win, new))
        t0, x0, v0, a0 = self.win
        brk = distinct(np.concatenate([t0 + ti for _a, t_p in self.pulses for ti in t_p]
                                       + [t0, [self.lo]]))
        if final:
            self.t_last = float(t0[-1])
            brk = brk[(brk >= self.lo) & (brk <= self.t_last)]
        else:
            brk = brk[(brk >= self.lo) & (brk < t_end + self.t_min)]
        for c0 in range(0, max(len(brk) - 1, 0), STREAM_SMOOTH):
            i, m = _smoothing_chunk(t0, x0, v0, a0, self.pulses, brk[c0:c0 + STREAM_SMOOTH + 1], 4)
            self.integral += i
            self.max_d = max(self.max_d, m)
        if len(brk):
            self.lo = float(brk[-1])
        k = max(int(np.searchsorted(t0, self.lo - self.t_max, side="right")) - 2, 0)
        self.win = tuple(w[k:] for w in self.win)

    def result(self):
        total_t = self.t_last - self.t_first
        return (math.sqrt(max(self.integral, 0.0) / total_t) if total_t > 0 else 0.0), self.max_d


class Collector:
    """Ringing figures of a firmware-model pass in bounded memory.

    Feed it the pass's planned blocks (on_block) and its rests (rest: E-only moves and
    dwells), in execution order -- hooks() / wrap_events() / play() do that -- then call
    figures(): the same dict as figures_of_trace on the whole trace.  Every chunk_blocks
    rows are turned into pieces and solved; what crosses to the next chunk is the pieces'
    end state, each axis' and part's oscillator amplitude, the shaped events not yet due
    and the shaper smoothing's window: memory does not grow with the file.

    Where the compiled firmware core is built, on_block is its RowSink: the core's model
    writes each block's row into it without a Block object (the Python model calls it
    with the block); the chunks are cut at the same rows as the Python rows cut them."""

    def __init__(self, profile=None, shaper: str | None = None, chunk_blocks: int = CHUNK_BLOCKS,
                 model: dict | None = None, parts: bool = True):
        self.model = model_of(profile) if model is None else model
        # parts=False: the whole ringing only, not its ramp / corner / turn parts (6 of the 8
        # streams: ~half a ringing pass's solve) -- for a run that shows no parts (the
        # command line without --json, --report or --corners auto); "all"'s figures are
        # the same bits either way (the parts read "all"'s exponentials, never the reverse)
        self.parts = ("all",) + (PARTS if parts else ())
        self.shaper = self.model["shaper"] if shaper is None else shaper
        self.limit = ROW * max(int(chunk_blocks), 1)
        pulses = _pulses(self.model, self.shaper)
        self.streams = {}
        memos = {}                         # one RingMemo per part and oscillator
        # the ramp, corner and turn memos are written one part after the other, each cleared
        # before the next part runs (_flush): one room for them all (RingRoom); "all"'s is
        # read while they write, and keeps its own
        parts_room = RingRoom()
        for ax, name in enumerate("xy"):
            osc = Oscillator(self.model[f"freq_{name}_hz"], self.model["damping_r"])
            for part in self.parts:
                # X's stream keeps its exponentials for Y's of the same part where the steps
                # are numpy's (the core's ring_solve declined, or is off): the two axes share
                # most events, and their restarts start at the same events.  (The core's
                # solve shares its pieces' numbers in its own table.)
                memo = memos.get((osc.s, osc.wd, part))
                if memo is None:
                    memo = memos[osc.s, osc.wd, part] = RingMemo(None if part == "all" else parts_room)
                self.streams[name, part] = _Stream(osc, pulses[ax], memo, ax == 0)
        self.horizon = {name: float(pulses[ax][1].min()) for ax, name in enumerate("xy")}
        self.smooth = _SmoothStream(pulses) if self.shaper != "none" else None
        self.carry = _Carry()
        # _events' output, kept from chunk to chunk (the streams are done with a chunk's
        # events when _flush returns: what waits is copied)
        self.events_room = Room()
        self.rows = array("d", IDLE)       # at rest 1 s before the file (not counted)
        self.pend = []                     # blocks not yet in rows (on_block)
        self.room = 0                      # blocks on_block takes before _drain
        # the compiled firmware core writes the rows itself into a RowSink (no Block object
        # per block): the rows wait there, in the same order, and reach rows in _drain
        self.sink = None
        sink_type = _row_sink_type()
        if sink_type is not None:
            self.sink = sink_type(self.limit // ROW, self._full)
            self.sink.put(self.rows)
            self.rows = array("d")
            # (rest: dwell, which leaves the rests to a compiled model that writes them)
            self.on_block, self.rest = self.sink, self.sink.dwell
        self.skip_first = True
        self.time_t = 0.0
        self.chunks = 0                    # chunks solved (tests force many)
        self.result = None

    def on_block(self, b):
        # (with a RowSink the instance's on_block is the sink itself; this is for a call
        # through the class)
        if self.sink is not None:
            self.sink(b)
            return
        # the block is kept as it is (the planner is done with it) and turned into its row
        # with the others in _drain: one C-level pass instead of a tuple built per block
        pend = self.pend
        pend.append(b)
        if len(pend) >= self.room:
            self._drain()
            if len(self.rows) >= self.limit:
                self._flush(False)

    def _full(self):
        # the sink holds a chunk's rows (it calls this once it does)
        self._flush(False)

    def _drain(self):
        """The pending blocks' rows (_block_row of each) appended to rows, in order."""
        if self.sink is not None:
            self.rows.frombytes(self.sink.take())
            return
        pend = self.pend
        n = len(pend)
        if n:
            m = np.empty((n, ROW))
            m[:, :ROW - 1] = np.fromiter(chain.from_iterable(map(_BLOCK_FIELDS, pend)), float,
                                         n * (ROW - 1)).reshape(n, ROW - 1)
            m[:, ROW - 1] = 1.0
            self.rows.frombytes(m.tobytes())
            pend.clear()
        # blocks until the rows are full, at most PEND_BLOCKS (bounded memory)
        self.room = min((self.limit - len(self.rows)) // ROW, PEND_BLOCKS)

    def rest(self, dt_t):
        if self.sink is not None:
            self.sink.dwell(dt_t)
            return
        if dt_t > 0.0:
            self._drain()
            self.rows.extend(_rest_row(dt_t))
            if len(self.rows) >= self.limit:
                self._flush(False)
            else:
                self.room = min((self.limit - len(self.rows)) // ROW, PEND_BLOCKS)

    def add_rows(self, items):
        """Rows already collected (Rows.items, an array('d')), in order."""
        self._drain()
        for i in range(0, len(items), self.limit):
            self.rows.extend(items[i:i + self.limit])
            if len(self.rows) >= self.limit:
                self._flush(False)
        self._drain()
        if self.sink is not None:          # what is left waits in the sink, as rows would
            self.sink.put(self.rows)
            self.rows = array("d")

    def _flush(self, final: bool):
        if self.sink is not None and not len(self.rows):
            # the sink's rows as they are (its bytes, read only: not copied twice more)
            m = np.frombuffer(self.sink.take(), float).reshape(-1, ROW)
        else:
            self._drain()
            m = np.frombuffer(self.rows, float).reshape(-1, ROW).copy()
        self.rows = array("d")
        if self.sink is not None and final:
            self.sink = None                # nothing more comes (and no cycle is left)
        self.room = min(self.limit // ROW, PEND_BLOCKS)
        if not len(m):
            return
        self.time_t += _rows_time(m, 1 if self.skip_first else 0, len(m) - 1 if final else len(m))
        self.skip_first = False
        self.chunks += 1
        # the events after each stream's carried time and waiting events (add_joined)
        got = _events(m, self.carry, self.model, len(self.parts) > 1, self.events_room, self.streams) \
            if self.smooth is None else None
        joined = got is not None
        if got is None:             # (without a shaper the core's events are all a chunk needs)
            tr = _pieces(m, self.carry, self.smooth is not None)
            got = {}
            for ax, name in enumerate("xy"):
                # the jumps of _jumps, each made once for the parts that share it: ramp and
                # all take da / w^2, all, corner and turn -dv (where it is not 0, the same
                # values as np.where(cls == ..., -dv, 0))
                dr, drp = _jumps(tr, self.model, name, ax, "all")
                ramp, jump = dr != 0.0, drp != 0.0
                keeps = {"all": ramp | jump, "ramp": ramp, "corner": jump & (tr.cls == CORNER),
                         "turn": jump & (tr.cls == TURN)}
                for part in ("all",) + PARTS:
                    keep = keeps[part]
                    zero = np.zeros(int(keep.sum()))
                    got[name, part] = (tr.t0[keep], dr[keep] if part in ("all", "ramp") else zero,
                                       drp[keep] if part != "ramp" else zero)
                del dr, drp, ramp, jump, keeps
        # (the carry is at the chunk's end now)
        horizon = {name: np.inf if final else self.carry.t + self.horizon[name] for name in "xy"}
        # part by part, X then Y (the streams are independent: any order gives the same
        # sums): Y takes X's exponentials of the part (RingMemo), which then go; "all"'s
        # go last (X's other parts take them too)
        for part in self.parts:
            for name in "xy":
                if joined:
                    self.streams[name, part].add_joined(*got.pop((name, part)), horizon[name])
                else:
                    self.streams[name, part].add(*got.pop((name, part)), horizon[name])
            if part != "all":
                for name in "xy":
                    self.streams[name, part].memo.clear()
        for name in "xy":
            self.streams[name, "all"].memo.clear()
        if self.smooth is not None:
            self.smooth.add(tr, self.carry.t, final)

    def figures(self) -> dict:
        """The figures (the pass must be over: the machine is put at rest after it)."""
        if self.result is None:
            self._drain()
            self.rows.extend(IDLE)         # at rest 1 s after the file: the last ring-down
            self._flush(True)
            axes = {name: _axis_dict({part: self.streams[name, part].finish()
                                      for part in self.parts}, self.time_t)
                    for name in "xy"}
            smooth = self.smooth.result() if self.smooth is not None else None
            self.result = _assemble(self.model, self.shaper, self.time_t, axes, smooth)
            self.streams = self.smooth = self.events_room = None
            release_solve_room()           # (the next pass takes it again)
        return self.result


USE_EVENTS = True         # tests turn it off: the events by _pieces and numpy (the reference)


def _events_core():
    core = fwsim._core
    return core if USE_EVENTS and core is not None and hasattr(core, "ring_events") else None


def _events(m, c: _Carry, model: dict, parts: bool = True, room: Room | None = None, lead=None):
    """{(axis, part): (t, dr, drp)}: the events Collector._flush hands each stream, from the
    rows m (k x 12) following on from c (c moves to their end, as _pieces moves it), by the
    compiled core's ring_events (the same numbers as _pieces without positions, _jumps and
    the parts' masks: the same operations in the same order); None without the core.
    Without `parts`, "all"'s only (the core writes no other part's).  room: where they are
    written (views of its array; the Collector's, kept from chunk to chunk: ~1.2 MB a
    chunk of 4096 rows, whose fresh pages fault when written: ~1.3 k fewer faults a
    plate_rectilinear run), else new arrays.

    lead ({(axis, part): _Stream}: the Collector's streams, or None): each stream's events
    are (t1, dr, drp) for its add_joined: the stream's carried time (if any) and waiting
    events written in front of the new ones (the core leaves room for them)."""
    core = _events_core()
    if core is None:
        return None
    n = len(m)
    f = max(st.front() for st in lead.values()) if lead else 0    # room before each output
    nt, nr, np_ = 16 * n + 8 * f, 12 * n + 4 * f, 10 * n + 6 * f
    out = room.grab(nt + nr + np_) if room is not None else np.empty(nt + nr + np_)
    t_out, dr_out, drp_out = out[:nt], out[nt:nt + nr], out[nt + nr:nt + nr + np_]
    w = [2.0 * math.pi * model[f"freq_{name}_hz"] for name in "xy"]     # _jumps' w, and its w * w
    counts, t, vx, vy, ax_, ay_, ux, uy, isb = core.ring_events(
        np.ascontiguousarray(m), c.t, float(c.vel_end[0]), float(c.vel_end[1]), float(c.acc[0]), float(c.acc[1]),
        c.ux, c.uy, c.isb, w[0] * w[0], w[1] * w[1], CORNER_COS, t_out, dr_out, drp_out, not parts, f)
    c.t = t
    c.vel_end, c.acc = np.array([vx, vy]), np.array([ax_, ay_])
    c.ux, c.uy, c.isb = ux, uy, isb
    got = {}
    for a, name in enumerate("xy"):
        t0, r0, p0 = (8 * n + 4 * f) * a + f, (6 * n + 2 * f) * a + f, (5 * n + 3 * f) * a + f
        # where each part's times, dr and drp start in the outputs (None: zeros)
        at = {"all": (t0, r0, p0), "ramp": (t0 + 3 * n + f, r0 + 3 * n + f, None),
              "corner": (t0 + 6 * n + 2 * f, None, p0 + 3 * n + f),
              "turn": (t0 + 7 * n + 3 * f, None, p0 + 4 * n + 2 * f)}
        for part, k in zip(("all",) + PARTS if parts else ("all",), counts[4 * a:4 * a + 4]):
            ti, ri, pi = at[part]
            st = lead.get((name, part)) if lead else None
            nw, front = (len(st.t), st.front()) if st is not None else (0, 0)
            if st is not None:          # (its waiting dr or drp where the part has none: zeros)
                t_out[ti - nw:ti] = st.t
                if ri is not None:
                    dr_out[ri - nw:ri] = st.dr
                if pi is not None:
                    drp_out[pi - nw:pi] = st.drp
                if st.t_last is not None:
                    t_out[ti - front] = st.t_last
            got[name, part] = (t_out[ti - front:ti + k],
                               dr_out[ri - nw:ri + k] if ri is not None else np.zeros(nw + k),
                               drp_out[pi - nw:pi + k] if pi is not None else np.zeros(nw + k))
    return got


USE_ROWS_TIME = True      # tests turn it off: numpy's sum (the reference)
_ROWS_TIME_OK = None      # the core's ring_rows_time gave numpy's bits on the probe (once a process)


def _rows_time_core():
    """The compiled core where its ring_rows_time gives numpy's bits (checked once on a
    probe: varied numbers over a buffer of numpy's and a few more, and none), else None."""
    global _ROWS_TIME_OK
    core = fwsim._core
    if not USE_ROWS_TIME or core is None or not hasattr(core, "ring_rows_time"):
        return None
    if _ROWS_TIME_OK is None:
        from .probe_rng import ProbeRng
        rng = ProbeRng(9038)
        m = np.zeros((2734, ROW))
        m[:, 6:9] = (rng.uniform(0.0, 1.0, 3 * len(m))
                     * rng.choice(np.array([1e-9, 1e-6, 1e-3, 1.0, 1e3]), 3 * len(m))).reshape(-1, 3)
        _ROWS_TIME_OK = all(
            np.float64(core.ring_rows_time(m, a, b)).tobytes() == np.float64(m[a:b, 6:9].sum()).tobytes()
            for a, b in ((1, len(m) - 1), (2, 2)))
    return core if _ROWS_TIME_OK else None


def _rows_time(m, r0: int, r1: int) -> float:
    """float(m[r0:r1, 6:9].sum()) (m: rows, C-contiguous): the time of the rows' pieces, by
    the core where it gives numpy's bits (numpy's strided sum copies the rows one at a
    time into its buffer: ~60 instructions a row; here ~25)."""
    core = _rows_time_core()
    if core is not None and m.flags.c_contiguous and m.dtype == np.float64:
        return core.ring_rows_time(m, r0, r1)
    return float(m[r0:r1, 6:9].sum())


def _row_sink_type():
    """The compiled firmware core's RowSink, or None (pure Python, or a core without it)."""
    core = fwsim._core
    return getattr(core, "RowSink", None) if core is not None and USE_SINK else None


USE_SINK = True           # tests turn it off: the Python rows (pend, _drain) for reference


def figures(path, profile, shaper: str | None = None, parts: bool = True) -> dict:
    """Ringing figures of one file (for the summary JSON, `simulate` and the report):
    {"model": {...}, "time_s", "x": {...}, "y": {...}, "xy": {...}[, "smoothing": {...}]}
    with rms_um / peak_um and (parts) their _ramp / _corner / _turn parts per axis.  `shaper`
    overrides the profile's ("none" for the unshaped machine)."""
    col = Collector(profile, shaper, parts=parts)
    play(path, profile, col)
    return col.figures()


def _change(b, a):
    return {"before": b, "after": a, "change": (a / b - 1.0) if b else None}


def compare(before: dict, after: dict) -> dict:
    """Before / after / change of the XY ringing (RMS, peak, the parts, the shaper's
    smoothing) and, under "x" / "y", of each axis: the summary's and the report's
    headline."""
    out = {}
    # (the parts' keys only where both sides have them: a Collector(parts=False) has none)
    for key in ("rms_um", "peak_um", "rms_ramp_um", "rms_corner_um", "rms_turn_um"):
        if key in before["xy"] and key in after["xy"]:
            out[key] = _change(before["xy"][key], after["xy"][key])
    for ax in "xy":
        out[ax] = {key: _change(before[ax][key], after[ax][key]) for key in AXIS_KEYS
                   if key in before[ax] and key in after[ax]}
    if "smoothing" in before and "smoothing" in after:
        out["smoothing_rms_um"] = {"before": before["smoothing"]["rms_um"],
                                   "after": after["smoothing"]["rms_um"]}
        out["smoothing_max_um"] = {"before": before["smoothing"]["max_um"],
                                   "after": after["smoothing"]["max_um"]}
    return out


AXIS_KEYS = tuple(f"{m}{p}_um" for m in ("rms", "peak") for p in ("", "_ramp", "_corner", "_turn"))


def summary_of(before: dict, after: dict) -> dict:
    """The summary JSON's "ringing" from the two files' figures (same model and shaper)."""
    if before["model"] != after["model"]:
        raise ValueError("ringing before and after were figured with different models")
    return {"model": before["model"], "before": before, "after": after,
            "change": compare(before, after)}


def summary(original, processed, profile) -> dict:
    """The summary JSON's "ringing": both files' figures (the profile's shaper in force)
    and their comparison.  Two more firmware-model passes (one per file)."""
    return summary_of(figures(original, profile), figures(processed, profile))


def headline_text(r: dict) -> str:
    """One line for the CLI summary from summary_of's dict."""
    c, m = r["change"], r["model"]

    def pct(x):
        return "n/a" if x is None else f"{x * 100:+.0f} %"
    shaper = "no input shaper" if m["shaper"] == "none" else \
        f"{m['shaper'].upper()} shaper at {m['shaper_freq_x_hz']:g} / {m['shaper_freq_y_hz']:g} Hz"
    text = (f"RMS {c['rms_um']['before']:.2f} -> {c['rms_um']['after']:.2f} um ({pct(c['rms_um']['change'])}), "
            f"peak {c['peak_um']['before']:.1f} -> {c['peak_um']['after']:.1f} um ({pct(c['peak_um']['change'])}); "
            f"X {c['x']['rms_um']['before']:.2f} -> {c['x']['rms_um']['after']:.2f}, "
            f"Y {c['y']['rms_um']['before']:.2f} -> {c['y']['rms_um']['after']:.2f} um RMS "
            f"(resonance {m['freq_x_hz']:g} / {m['freq_y_hz']:g} Hz, damping {m['damping_r']:g}, {shaper})")
    if "smoothing_rms_um" in c:
        sm = c["smoothing_rms_um"]
        text += f"; shaper smoothing {sm['before']:.1f} -> {sm['after']:.1f} um RMS"
    return text


def text_rows(fig: dict) -> list:
    """(label, text) rows for `gcode-opt simulate`'s table."""
    m, xy = fig["model"], fig["xy"]
    rows = [("ringing RMS / peak",
             f"{xy['rms_um']:.2f} / {xy['peak_um']:.1f} um XY (X {fig['x']['rms_um']:.2f}, "
             f"Y {fig['y']['rms_um']:.2f}) at {m['freq_x_hz']:g} / {m['freq_y_hz']:g} Hz, "
             f"damping {m['damping_r']:g}, shaper {m['shaper']}"),
            ("ringing excited by", f"ramps {xy['rms_ramp_um']:.2f}, corners {xy['rms_corner_um']:.2f}, "
                                   f"gentle turns {xy['rms_turn_um']:.2f} um RMS")]
    if "smoothing" in fig:
        rows.append(("shaper smoothing", f"{fig['smoothing']['rms_um']:.1f} um RMS, "
                                         f"{fig['smoothing']['max_um']:.0f} um max"))
    return rows


def with_shaper(profile, shaper: str):
    """The profile with another input shaper (tuned where the profile says)."""
    import dataclasses          # (here: a run that keeps its shaper never imports it)
    return dataclasses.replace(profile, shaper=shaper)


# ---------------------------------------------------------------- a stretch for plots
def time_at_s(tr: Trace, s_d):
    """Times at which the commanded motion reaches path distance s_d (first reach)."""
    s_d = np.asarray(s_d, float)
    k = np.clip(np.searchsorted(tr.s, s_d, side="right") - 1, 0, len(tr) - 1)
    v, a, rem = tr.speed[k], tr.tan_a[k], s_d - tr.s[k]
    disc = np.maximum(v * v + 2.0 * a * rem, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = np.where(np.abs(a) > 1e-12, (np.sqrt(disc) - v) / np.where(a == 0, 1, a),
                       rem / np.where(v > 0, v, np.inf))
    return tr.t0[k] + np.clip(np.nan_to_num(tau), 0.0, tr.dur[k])


def s_at_t(tr: Trace, t):
    t = np.asarray(t, float)
    k = np.clip(np.searchsorted(tr.t0, t, side="right") - 1, 0, len(tr) - 1)
    tau = np.clip(t - tr.t0[k], 0.0, tr.dur[k])
    return tr.s[k] + tr.speed[k] * tau + 0.5 * tr.tan_a[k] * tau * tau


def busiest_stretch(tr: Trace, model: dict, length_d: float = 50.0) -> float:
    """Start (mm of path) of the stretch of length_d where this trace rings most (by the
    exact integral of |r|^2 over time, binned by path distance)."""
    e = np.zeros(len(tr))
    for name in "xy":
        r = response(tr, model, name)
        per = r.osc.integral_r2(r.c, r.dur)
        k = np.clip(np.searchsorted(tr.t0, r.t_ev, side="right") - 1, 0, len(tr) - 1)
        np.add.at(e, k, per)
    total_s = float(tr.s[-1])
    if total_s <= length_d:
        return 0.0
    bins = np.floor(tr.s / (0.5 * length_d)).astype(np.int64)
    per_bin = np.bincount(bins, weights=e)
    win = per_bin[:-1] + per_bin[1:] if len(per_bin) > 1 else per_bin
    bin_d = 0.5 * length_d
    return float(np.argmax(win) * bin_d)


def stretch(tr: Trace, model: dict, s0_d: float, length_d: float, n: int = 4000,
            shaper: str | None = None):
    """(s_d, rx_um, ry_um): the ringing sampled (exactly) at n instants evenly spaced in
    time over the part of the path [s0_d, s0_d + length_d]."""
    t_a, t_b = time_at_s(tr, [s0_d, s0_d + length_d])
    t = np.linspace(t_a, t_b, n)
    rx = response(tr, model, "x", shaper=shaper).at(t)
    ry = response(tr, model, "y", shaper=shaper).at(t)
    return s_at_t(tr, t), rx * UM, ry * UM


# ---------------------------------------------------------------- the stretch from kept rows
# The report keeps each file's rows (12 numbers a block) and solves only windows of them:
# the ringing before a window has decayed below exp(-HISTORY) of itself once HISTORY / s
# seconds (s = damping x 2 pi f) lie between, so a window starts that far back.
HISTORY = 36.0


def row_dur_ds(m):
    """Duration (s) and path length (mm) of each row of m (k x ROW)."""
    _ux, _uy, sv, cv, _ev, a, at, ct, dt = m[:, :9].T
    dur = at + ct + dt
    ds = sv * at + 0.5 * a * at * at + cv * ct + cv * dt - 0.5 * a * dt * dt
    return dur, ds


class RowTable:
    """Rows (as Rows.items, with the idle rows at both ends added; padded: items has them,
    e.g. Rows.padded()'s) and where each row starts
    in time and path distance: windows of pieces without building the whole trace."""

    def __init__(self, items, model: dict, shaper: str | None = None, padded: bool = False):
        m = np.asarray(items, float).reshape(-1, ROW)
        if padded:              # items hold the idle rows already: kept as they are, not copied
            self.m = m
        else:
            idle = np.array([IDLE])
            self.m = np.vstack([idle, m, idle])
        self._times(model, shaper)
        dur, ds = row_dur_ds(self.m)
        self.t = -1.0 + np.concatenate([[0.0], np.cumsum(dur)[:-1]])
        self.s = np.concatenate([[0.0], np.cumsum(ds)[:-1]])

    def _times(self, model: dict, shaper: str | None):
        self.model = model
        self.shaper = model["shaper"] if shaper is None else shaper
        ts = np.concatenate([t_p for _a, t_p in _pulses(model, self.shaper)])
        self.span_t = float(ts.max() - ts.min())
        s_min = min(2.0 * math.pi * model[f"freq_{a}_hz"] * model["damping_r"] for a in "xy")
        self.history_t = HISTORY / s_min + self.span_t

    @classmethod
    def part(cls, m, t, s, model: dict, shaper: str | None = None):
        """A RowTable of some consecutive rows m of a file's (with their t and s, as the whole
        file's RowTable has them): its windows are the whole table's where they lie in it."""
        rt = cls.__new__(cls)
        rt.m, rt.t, rt.s = m, t, s
        rt._times(model, shaper)
        return rt

    def __len__(self):
        return len(self.m)

    def carry_at(self, r: int) -> _Carry:
        """The pieces' state where row r starts (position left at 0: windows are for ringing)."""
        c = _Carry()
        c.t, c.s = float(self.t[r]), float(self.s[r])
        if r > 0:
            ux, uy, _sv, cv, _ev, a, _at, _ct, dt, _after, _idx, isb = self.m[r - 1]
            u = np.array([ux, uy])
            c.vel_end, c.acc = (cv - a * dt) * u, -a * u
            c.ux, c.uy, c.isb = float(ux), float(uy), float(isb)
        return c

    def window(self, t_a: float, t_b: float):
        """(Trace, t_own): the pieces of the rows from history_t before t_a to the shaper's
        span after t_b -- the ringing at times in [t_a, t_b] is that of the whole file."""
        r0 = max(int(np.searchsorted(self.t, t_a - self.history_t, side="right")) - 1, 0)
        r1 = min(int(np.searchsorted(self.t, t_b + self.span_t, side="right")) + 2, len(self.m))
        return _pieces(self.m[r0:r1], self.carry_at(r0))


STRETCH_ROWS = 16384      # busiest_stretch_rows' window (the report's, apart from the Collector's chunks)


def busiest_stretch_rows(rt: RowTable, length_d: float = 50.0, chunk_rows: int = STRETCH_ROWS) -> float:
    """busiest_stretch over a RowTable, window by window (bounded memory): each window's
    events earlier than its own rows' start are history, those after their end lookahead."""
    total_s = float(rt.s[-1])
    if total_s <= length_d:
        return 0.0
    bin_d = 0.5 * length_d
    per_bin = np.zeros(stretch_bins(total_s, length_d))
    n = len(rt)
    for r0 in range(0, n, chunk_rows):
        r1 = min(r0 + chunk_rows, n)
        for bins, per in stretch_energy(rt, r0, r1, r1 == n, bin_d):
            np.add.at(per_bin, bins, per)
    return busiest_bin(per_bin, length_d)


def stretch_bins(total_s: float, length_d: float) -> int:
    """busiest_stretch_rows' bins (of length_d / 2) over total_s mm of path."""
    return int(total_s // (0.5 * length_d)) + 2


def stretch_energy(rt: RowTable, r0: int, r1: int, last: bool, bin_d: float):
    """(bins, energies) per axis of the ringing events of rows r0..r1-1 of rt (last: the
    file's last rows), binned by path distance in bins of bin_d mm."""
    t_own_a = float(rt.t[r0])
    t_own_b = np.inf if last else float(rt.t[r1])
    tr = rt.window(t_own_a, float(rt.t[min(r1, len(rt) - 1)]))
    for name in "xy":
        r = response(tr, rt.model, name, shaper=rt.shaper)
        own = (r.t_ev >= t_own_a) & (r.t_ev < t_own_b)
        if not last:
            own &= np.isfinite(r.dur)
        per = r.osc.integral_r2(r.c[own], r.dur[own])
        k = np.clip(np.searchsorted(tr.t0, r.t_ev[own], side="right") - 1, 0, len(tr) - 1)
        yield np.floor(tr.s[k] / bin_d).astype(np.int64), per


def busiest_bin(per_bin, length_d: float) -> float:
    """Start (mm) of the two consecutive bins with most energy."""
    win = per_bin[:-1] + per_bin[1:] if len(per_bin) > 1 else per_bin
    bin_d = 0.5 * length_d
    return float(np.argmax(win) * bin_d)


def stretch_rows(rt: RowTable, s0_d: float, length_d: float, n: int = 4000):
    """stretch() over a RowTable: only the window around the stretch is solved."""
    r_a = max(int(np.searchsorted(rt.s, s0_d, side="right")) - 1, 0)
    r_b = min(int(np.searchsorted(rt.s, s0_d + length_d, side="right")), len(rt) - 1)
    tr = rt.window(float(rt.t[r_a]), float(rt.t[r_b]))
    return stretch(tr, rt.model, s0_d, length_d, n, rt.shaper)
