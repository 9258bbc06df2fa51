"""Firmware model: play a G-code file as a constant-acceleration lookahead firmware would.

``simulate_file(path, profile)`` reads the file with ``state.events`` and returns a
``SimResult``: print time, the integral of |a|^2 over time (tangential accelerations of
the trapezoids plus the direction changes at junctions), the integral of |v|^2, peaks,
full stops, and one ``LineRecord`` per moving source line through ``on_line``.

Which firmware: ``profile.block_buffer == 0`` is Klipper's full lookahead (with
minimum_cruise_ratio when the junction model is "scv"); ``block_buffer = B > 0`` is a
Marlin-style planner that knows B-1 blocks (the ring buffer holds B-1) when a block
starts.  ``profile.junction`` picks the junction law: "scv" (Klipper), "jd" (Marlin 2
junction deviation), "jerk" (Marlin 1.1 / Prusa classic jerk).

Direction changes: a junction turning by theta at speed v changes the velocity vector by
dv = 2 v sin(theta/2).  Where the path is a curve cut into segments (theta <= 30 deg: arc
chords, gyroid polylines) we count it as a normal acceleration spread over
t_j = (t_prev + t_next) / 2, i.e. dv^2 / t_j, half to each adjacent move (both halves to
the line itself when the junction is inside an arc); for chords of a circle this is
exactly the centripetal integral (v^2/R)^2 t.  A sharper turn is a corner: the firmware
takes it as a velocity jump, whose "int a^2" depends only on how the model smears it, so
corners are reported apart, as their count and sum of dv^2 (mm^2/s^2).

Klipper (flavour "klipper", block_buffer 0) is played as klippy's toolhead does it: M204 /
SET_VELOCITY_LIMIT ACCEL set the accel uncapped (no per-axis XY limit), Z scales accel and
speed, chords as gcode_arcs cuts them (see arc_chords).  tests/test_klipper_oracle.py checks
it against the real Klipper planner: the same trapezoids to 1e-9.  ``int_a2_t`` is that
planner's sum of a^2 (accel_t + decel_t) over the XYZ moves (the oracle's int_a2_xyz; its
int_a2_xy weights each move by its XY share).
"""
from __future__ import annotations

import math

from .. import state as st
from .junction import (KLIPPER_INSTANT_CORNER_V, SQRT2_M1, axis_limited, klipper_corner_v2,
                       klipper_extruder_v2, marlin_jd_v2, marlin_jerk_junction_v,
                       marlin_safe_speed)
from .planner import Block, KlipperPlanner, MarlinPlanner

CORNER_COS = math.cos(math.radians(30.0))   # turns sharper than 30 deg are corners
FULL_STOP_V = 0.5          # mm/s: a junction slower than this is a halt for the machine's frame
                           # (Marlin's own floor is 0.05 mm/s); counted as a full stop
MAX_STOP_LINES = 100
KLIPPER_CHUNK = 512       # lazy-flush the Klipper queue every this many new moves


ARC_MIN_TURN = 1e-3       # rad: the model never cuts an arc into chords turning less than this


def arc_chords(length_d: float, sweep: float, segment_d: float) -> int:
    """How many chords the model plays a G2/G3 as.

    Klipper's gcode_arcs and Marlin's plan_arc cut floor(length / segment) chords (at
    least 1), however many that is: a 1e5 mm radius would give 6e5 chords a turn.  Past
    r = segment / ARC_MIN_TURN (1 m for 1 mm chords) each chord turns by < 1 mrad, where no
    junction law binds (Klipper's scv corner speed ~ 1.8 scv / turn = 9000 mm/s, Marlin's
    jd and jerk likewise), and the centripetal limit sqrt(r a) does not depend on the
    chord count; so the model cuts those by angle instead: at most ceil(|sweep| / 1 mrad),
    6284 chords a turn, whatever the radius or the segment length."""
    turn = abs(sweep) if abs(sweep) <= 2.0 * math.pi else 2.0 * math.pi   # NaN too
    n_max = math.ceil(turn / ARC_MIN_TURN)
    n = length_d / segment_d if segment_d > 0.0 else 1.0
    if not n <= n_max:                        # also NaN
        n = n_max
    return max(1, int(n))


class LineRecord:
    """What one moving source line did (arc chords aggregated into their line)."""
    __slots__ = ("idx", "start_v", "end_v", "peak_v", "time_t", "int_a2", "int_a2_j",
                 "int_v2", "peak_a", "kind")

    def __init__(self, idx, kind):
        self.idx, self.kind = idx, kind
        self.start_v = self.end_v = self.peak_v = 0.0
        self.time_t = self.int_a2 = self.int_a2_j = self.int_v2 = self.peak_a = 0.0

    def as_dict(self) -> dict:
        return {s: getattr(self, s) for s in LineRecord.__slots__}

    def __repr__(self):
        return (f"LineRecord(line {self.idx + 1}, v {self.start_v:.2f}->{self.peak_v:.2f}->"
                f"{self.end_v:.2f}, t={self.time_t:.5f}, a2={self.int_a2:.1f}+{self.int_a2_j:.1f})")


class SimResult:
    __slots__ = ("time_t", "int_a2", "int_a2_t", "int_v2", "peak_v", "peak_a", "n_moves",
                 "n_blocks", "full_stops", "stop_lines", "short_segments", "barrier_dwell_t",
                 "corners", "corner_dv2")

    def __init__(self):
        self.corners = 0
        self.corner_dv2 = 0.0
        self.time_t = self.int_a2 = self.int_a2_t = self.int_v2 = 0.0
        self.peak_v = self.peak_a = 0.0
        self.n_moves = self.n_blocks = self.full_stops = self.short_segments = 0
        self.stop_lines = []
        self.barrier_dwell_t = 0.0

    def as_dict(self) -> dict:
        d = {s: getattr(self, s) for s in SimResult.__slots__}
        d["stop_lines"] = list(self.stop_lines)
        return d

    def __repr__(self):
        return "SimResult(" + ", ".join(f"{k}={v!r}" for k, v in self.as_dict().items()) + ")"


class _Sim:
    """Builds blocks from moves, runs the planner, integrates what it plans."""

    def __init__(self, profile, on_line, on_block=None):
        self.prof = profile
        self.on_line = on_line
        self.on_block = on_block
        self.res = SimResult()
        self.klipper_limits = profile.block_buffer <= 0
        self.klipper_fw = profile.flavour == "klipper"
        self.model = profile.junction
        self.jerk_z = getattr(profile, "jerk_z_v", 0.4)
        self.icv = getattr(profile, "instantaneous_corner_velocity_v", KLIPPER_INSTANT_CORNER_V)
        self.caps = (profile.max_accel_a, profile.max_accel_a, profile.max_z_accel_a)
        self.jerk = (profile.jerk_xy_v, profile.jerk_xy_v, self.jerk_z)
        self.min_seg_t = profile.min_segment_time_t
        out = self._emit
        if profile.block_buffer > 0:
            # a ring buffer of B slots holds B-1 blocks, the executing one included
            self.planner = MarlinPlanner(self._junction_fn(), out, profile.block_buffer - 1,
                                         self._start_v2 if self.model == "jerk" else None)
        else:
            self.planner = KlipperPlanner(self._junction_fn(), out, KLIPPER_CHUNK)
        self.stop_thr = max(self.planner.stop_v, FULL_STOP_V)
        # accumulator state
        self.prev = None          # last planned kinematic block (None after a stop)
        self.prev_t = 0.0
        self.rec = None           # open LineRecord

    # ---- junction laws --------------------------------------------------------------
    def _junction_fn(self):
        model = self.model
        if model == "scv":
            icv = self.icv

            def junction(p, b):
                v2 = klipper_corner_v2(p.ux, p.uy, p.uz, p.jd, p.accel, p.delta_v2,
                                       b.ux, b.uy, b.uz, b.jd, b.accel, b.delta_v2)
                if b.er != p.er:
                    e2 = klipper_extruder_v2(p.er, b.er, icv)
                    if e2 < v2:
                        v2 = e2
                return v2
        elif model == "jd":
            sim = self

            def junction(p, b):
                cx, cy, cz = sim.caps
                return marlin_jd_v2(p.ux, p.uy, p.uz, b.ux, b.uy, b.uz, b.d, b.accel, b.jd,
                                    cx, cy, cz)
        else:
            sim = self

            def junction(p, b):
                jx, jy, jz = sim.jerk
                v = marlin_jerk_junction_v(p.ux, p.uy, p.uz, p.nominal_v, p.safe_v,
                                           b.ux, b.uy, b.uz, b.nominal_v, b.safe_v, jx, jy, jz)
                return v * v
        return junction

    def _start_v2(self, b):
        return b.safe_v * b.safe_v

    # ---- moves -> blocks ------------------------------------------------------------
    def move(self, mv):
        kind = mv.kind
        self.res.n_moves += 1
        if kind == st.EONLY:
            self._eonly(mv)
            return
        if kind == st.LINE:
            self._block(mv, True, mv.x1 - mv.x0, mv.y1 - mv.y0, mv.z1 - mv.z0, mv.e)
            return
        arc = mv.arc
        n = arc_chords(arc.length_d, arc.sweep, self.prof.arc_segment_d)
        cx, cy, r, t0, sw = arc.cx, arc.cy, arc.r, arc.theta0, arc.sweep
        dz = (mv.z1 - mv.z0) / n
        de = mv.e / n
        px, py = mv.x0, mv.y0
        cos, sin = math.cos, math.sin
        for i in range(1, n + 1):
            if i == n:
                x, y = mv.x1, mv.y1
            else:
                th = t0 + sw * i / n
                x, y = cx + r * cos(th), cy + r * sin(th)
            self._block(mv, i == 1, x - px, y - py, dz, de)
            px, py = x, y

    def _block(self, mv, first, dx, dy, dz, de):
        d = math.sqrt(dx * dx + dy * dy + dz * dz)
        if d < 1e-9:
            if de and first:
                self._eonly(mv)
            return
        inv = 1.0 / d
        ux, uy, uz = dx * inv, dy * inv, dz * inv
        lim = mv.lim
        prof = self.prof
        a0 = mv.accel
        if not a0 > 0.0:                          # M204 S0 or garbage: the profile's default
            a0 = prof.default_accel_a
        if self.klipper_fw:
            # Klipper: M204 / SET_VELOCITY_LIMIT set the toolhead's max_accel itself, uncapped
            # (no per-axis XY limit; M201 is an unknown command); only Z scales it down
            a = a0
            if uz:
                az = prof.max_z_accel_a / abs(uz)
                if az < a:
                    a = az
        else:
            self.caps = caps = (lim.ax_max, lim.ay_max, prof.max_z_accel_a)
            a = axis_limited(a0, ux, uy, uz, caps[0], caps[1], caps[2])
        if self.klipper_limits:                   # Klipper: one toolhead speed, Z scaled
            v = mv.v if mv.v < lim.v_max else lim.v_max
            if uz:
                vz = prof.max_z_velocity_v / abs(uz)
                if vz < v:
                    v = vz
        else:                                     # Marlin: per-axis M203 caps
            v = axis_limited(mv.v, ux, uy, uz, lim.v_max, lim.v_max, prof.max_z_velocity_v)
        if self.model == "scv":
            jd = lim.scv * lim.scv * SQRT2_M1 / a0
            mcr_a = a0 * (1.0 - lim.mcr)
        else:
            jd = lim.jd
            mcr_a = a
        # E per path mm as the extruder sees it: M221's flow factor scales E (Klipper's
        # extruder junction limit reads it)
        er = de * inv * mv.flow_r if de else 0.0
        b = Block(mv.idx, mv.kind, first, d, ux, uy, uz, er, a, jd, v, mcr_a)
        if self.model == "jerk":
            self.jerk = (lim.jerk_x, lim.jerk_y, self.jerk_z)
            b.safe_v = marlin_safe_speed(ux, uy, uz, v, lim.jerk_x, lim.jerk_y, self.jerk_z)
        if self.min_seg_t > 0.0 and d < self.min_seg_t * v:
            self.res.short_segments += 1
        self.planner.add(b)

    def _eonly(self, mv):
        """Rest-to-rest trapezoid of the extruder alone; the toolhead stands still."""
        self.stop()
        d = abs(mv.e)
        v = min(mv.v, self.prof.max_e_velocity_v)
        a = mv.accel
        if d <= 0.0 or v <= 0.0 or a <= 0.0:
            t = 0.0
        elif v * v <= a * d:
            t = d / v + v / a
        else:
            t = 2.0 * math.sqrt(d / a)
        self.res.time_t += t
        rec = LineRecord(mv.idx, st.EONLY)
        rec.time_t = t
        if self.on_line is not None:
            self.on_line(rec)

    def barrier(self, ev):
        self.stop()
        self.res.time_t += ev.dwell_t
        self.res.barrier_dwell_t += ev.dwell_t

    def stop(self):
        self.planner.stop()
        self._close()
        self.prev = None

    # ---- planned blocks -> integrals ------------------------------------------------
    def _emit(self, b):
        res = self.res
        a = b.accel
        at, ct, dt = b.accel_t, b.cruise_t, b.decel_t
        t = at + ct + dt
        sv, cv, ev = b.start_v, b.cruise_v, b.end_v
        ta = at + dt
        a2 = a * a * ta
        v2 = (at * (sv * sv + sv * cv + cv * cv) + dt * (ev * ev + ev * cv + cv * cv)) / 3.0 \
            + ct * cv * cv
        pa = a if ta > 0.0 else 0.0
        res.n_blocks += 1
        res.time_t += t
        res.int_a2_t += a2
        res.int_a2 += a2
        res.int_v2 += v2
        if cv > res.peak_v:
            res.peak_v = cv
        p = self.prev
        rec = self.rec
        jterm = na = 0.0
        if p is not None and not b.after_stop:
            if sv < self.stop_thr:
                res.full_stops += 1
                if len(res.stop_lines) < MAX_STOP_LINES:
                    res.stop_lines.append(b.idx + 1)
            cos_turn = p.ux * b.ux + p.uy * b.uy + p.uz * b.uz
            dv2 = 2.0 * sv * sv * (1.0 - cos_turn)
            if cos_turn < CORNER_COS:
                res.corners += 1
                res.corner_dv2 += dv2
            elif dv2 > 0.0:
                tj = 0.5 * (self.prev_t + t)
                jterm = dv2 / tj
                na = math.sqrt(dv2) / tj
                res.int_a2 += jterm
                if na > res.peak_a:
                    res.peak_a = na
        if pa > res.peak_a:
            res.peak_a = pa
        if rec is not None and b.idx == rec.idx:
            rec.int_a2 += jterm
            if na > rec.peak_a:
                rec.peak_a = na
        else:
            if rec is not None:
                rec.int_a2_j += 0.5 * jterm
                if na > rec.peak_a:
                    rec.peak_a = na
                self.rec = None
                if self.on_line is not None:
                    self.on_line(rec)
            rec = self.rec = LineRecord(b.idx, b.kind)
            rec.start_v = sv
            rec.int_a2_j = 0.5 * jterm
            rec.peak_a = na
        rec.end_v = ev
        if cv > rec.peak_v:
            rec.peak_v = cv
        if pa > rec.peak_a:
            rec.peak_a = pa
        rec.time_t += t
        rec.int_a2 += a2
        rec.int_v2 += v2
        self.prev = b
        self.prev_t = t
        if self.on_block is not None:
            self.on_block(b)

    def _close(self):
        rec = self.rec
        if rec is not None:
            self.rec = None
            if self.on_line is not None:
                self.on_line(rec)


def simulate_events(event_iter, profile, on_line=None, on_block=None) -> SimResult:
    """Play (idx, raw, event) triples (as ``state.events`` yields them).

    ``on_block(b)``, if given, sees every planned block in execution order, after its
    line's figures were accumulated: a ``planner.Block`` with ``idx`` (0-based source
    line), ``kind``, ``first`` (first block of its line), ``d`` (mm), unit vector
    ``ux, uy, uz``, ``start_v, cruise_v, end_v`` (mm/s), ``accel`` (mm/s^2) and the
    trapezoid's ``accel_t, cruise_t, decel_t`` (s).  Read it, don't keep it changing."""
    sim = _Sim(profile, on_line, on_block)
    move = sim.move
    barrier = sim.barrier
    Move, Barrier = st.Move, st.Barrier
    for _idx, _raw, ev in event_iter:
        if ev is None:
            continue
        cls = type(ev)
        if cls is Move:
            move(ev)
        elif cls is Barrier:
            barrier(ev)
    sim.stop()
    return sim.res


def simulate_file(path, profile, on_line=None, on_block=None) -> SimResult:
    return simulate_events(st.events(path, profile), profile, on_line, on_block)
