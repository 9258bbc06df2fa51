"""Firmware model: play a G-code file as a constant-acceleration lookahead firmware would.

``simulate_file(path, profile)`` reads the file (as ``state.events`` does) and returns a
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

Two cores play the model: ``_Sim`` below, and its compiled twin ``_gcode_opt_fwcore.Sim``
(firmware/_core.c, built at install when a C compiler is there: setup.py), which gives
the same bits (tests/test_fwcore_bits.py) in a twentieth of the time.  ``CORE`` says which one plays
("c" or "python"); GCODE_OPT_PURE_PYTHON=1 in the environment forces the Python one.

With the compiled core, simulate_file, simulate_ledger and replay_runs read the file in
chunks (read_chunks) and its Sim.play runs the per-line loop in C (_play_chunks: Python
only where the ledger records a stop or a watched range's start).  Where the model's
callbacks are the core's own (StrokeSums, the ringing's RowSink) and the compiled reader
is built, play() reads the common lines through the reader's fused loop (_reader.c
fused_line: the move as doubles, the reader's x y z e v held in C meanwhile); the same
bits as the per-line loop _play (tests/test_speed_measure_loop.py, _fused.py).
"""
from __future__ import annotations

import math
from array import array
from functools import partial
from types import MethodType

from .. import state as st
from .junction import (KLIPPER_INSTANT_CORNER_V, SQRT2_M1, klipper_corner_v2, klipper_extruder_v2,
                       marlin_jd_v2, marlin_jerk_junction_v)
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
        self._lim = None          # the Limits caps and jerk were last taken from
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
        self.max_stop_lines = MAX_STOP_LINES

    def empty(self) -> bool:
        """Nothing planned is waiting: what comes next cannot change what came before."""
        pl = self.planner
        waiting = pl.queue if isinstance(pl, KlipperPlanner) else pl.buf
        return not waiting and self.rec is None and self.prev is None

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

    def _set_lim(self, lim):
        # the per-axis accel caps and jerks the junction laws read: one tuple per Limits
        # object (copy-on-write, so identity is enough), not one per block
        self._lim = lim
        self.caps = (lim.ax_max, lim.ay_max, self.prof.max_z_accel_a)
        self.jerk = (lim.jerk_x, lim.jerk_y, self.jerk_z)

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
        # axis_limited and marlin_safe_speed written out: this runs once per block
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
        aux, auy = abs(ux), abs(uy)
        auz = abs(uz)
        if self.klipper_fw:
            # Klipper: M204 / SET_VELOCITY_LIMIT set the toolhead's max_accel itself, uncapped
            # (no per-axis XY limit; M201 is an unknown command); only Z scales it down
            a = a0
            if uz:
                az = prof.max_z_accel_a / auz
                if az < a:
                    a = az
        else:
            if lim is not self._lim:              # caps and jerk change with the Limits only
                self._set_lim(lim)
            cx, cy, cz = self.caps
            a = a0                                # axis_limited(a0, u, caps)
            if aux > 0.0 and a * aux > cx:
                a = cx / aux
            if auy > 0.0 and a * auy > cy:
                a = cy / auy
            if auz > 0.0 and a * auz > cz:
                a = cz / auz
        v_max = lim.v_max
        if self.klipper_limits:                   # Klipper: one toolhead speed, Z scaled
            v = mv.v if mv.v < v_max else v_max
            if uz:
                vz = prof.max_z_velocity_v / auz
                if vz < v:
                    v = vz
        else:                                     # Marlin: per-axis M203 caps
            v = mv.v
            if aux > 0.0 and v * aux > v_max:
                v = v_max / aux
            if auy > 0.0 and v * auy > v_max:
                v = v_max / auy
            if auz > 0.0:
                cz = prof.max_z_velocity_v
                if v * auz > cz:
                    v = cz / auz
        model = self.model
        if model == "scv":
            jd = lim.scv * lim.scv * SQRT2_M1 / a0
            mcr_a = a0 * (1.0 - lim.mcr)
        else:
            jd = lim.jd
            mcr_a = a
        # E per path mm as the extruder sees it: M221's flow factor scales E (Klipper's
        # extruder junction limit reads it)
        er = de * inv * mv.flow_r if de else 0.0
        b = Block(mv.idx, mv.kind, first, d, ux, uy, uz, er, a, jd, v, mcr_a)
        if model == "jerk":
            if lim is not self._lim:
                self._set_lim(lim)
            jx, jy, jz = self.jerk
            safe = v                              # marlin_safe_speed(u, v, jerk)
            limited = False
            comp = aux * v
            if comp > jx:
                limited = True
                safe = jx
            comp = auy * v
            if comp > jy:
                if limited:
                    mjerk = jy * v
                    if comp * safe > mjerk:
                        safe = mjerk / comp
                else:
                    limited = True
                    safe = jy
            comp = auz * v
            if comp > jz:
                if limited:
                    mjerk = jz * v
                    if comp * safe > mjerk:
                        safe = mjerk / comp
                else:
                    safe = jz
            b.safe_v = safe
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
        at = b.accel_t
        ct = b.cruise_t
        dt = b.decel_t
        t = at + ct + dt
        sv = b.start_v
        cv = b.cruise_v
        ev = b.end_v
        ta = at + dt
        a2 = a * a * ta
        cv2 = cv * cv
        v2 = (at * (sv * sv + sv * cv + cv2) + dt * (ev * ev + ev * cv + cv2)) / 3.0 + ct * cv * cv
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
                if len(res.stop_lines) < self.max_stop_lines:
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


# ---------------------------------------------------------------- which core plays
def _load_core():
    """The compiled core (module _gcode_opt_fwcore, built from firmware/_core.c), set up
    with this module's classes; None if it is not built, if it was built from another
    _core.c than the one beside this file (a stale build), or if GCODE_OPT_PURE_PYTHON
    asks for the Python model.  CORE_WHY says why not."""
    global CORE_WHY, _CLineRecord, _CSimResult
    from . import load_core
    core, CORE_WHY = load_core()
    if core is None:
        return None

    class _CLineRecord(core.LineRecord):
        __slots__ = ()
        as_dict = LineRecord.as_dict
        __repr__ = LineRecord.__repr__

    class _CSimResult(core.SimResult):
        __slots__ = ()
        as_dict = SimResult.as_dict
        __repr__ = SimResult.__repr__

    core.setup(st.Move, st.Arc, st.Limits, st.Barrier, _CLineRecord, _CSimResult,
               {"LINE": st.LINE, "ARC": st.ARC, "EONLY": st.EONLY,
                # Sim.play reads plain SET_VELOCITY_LIMIT lines as MachineState does
                "STATE": st.MachineState, "MAX_VELOCITY_V": st.MAX_VELOCITY_V,
                "MAX_ACCEL_A": st.MAX_ACCEL_A})
    if hasattr(core, "use_reader"):
        # Sim.play reads the common lines through the compiled reader's fused loop
        core.use_reader(getattr(st._reader, "_C_API", None))
    CORE_WHY = ""
    return core


def use_fused(on: bool) -> bool:
    """Let Sim.play read the common lines through the compiled reader's fused loop (the
    default where both are built), or make it call the reader's step line by line (tests
    compare the two); returns whether the fused loop is now in use."""
    cap = getattr(st._reader, "_C_API", None) if on else None
    return bool(_core.use_reader(cap)) if _core is not None and hasattr(_core, "use_reader") else False


CORE_WHY = ""
_core = _load_core()
CORE = "c" if _core is not None else "python"     # which core plays (--profile-time, summary)


def use_core(name: str) -> str:
    """Make `name` ("c" or "python") the core later passes play; returns the previous one
    (tests run the model on both)."""
    global CORE
    if name not in ("c", "python") or (name == "c" and _core is None):
        raise ValueError(f"no {name!r} firmware-model core here")
    old, CORE = CORE, name
    return old


def new_sim(profile, on_line, on_block=None):
    """A model pass (move, barrier, stop, empty, res, max_stop_lines) on the core in use."""
    if CORE == "c":
        # the constants as they are now, as _Sim reads them (tests change some)
        from . import planner
        return _core.Sim(profile, on_line, on_block,
                         (CORNER_COS, FULL_STOP_V, SQRT2_M1, planner.MINIMUM_PLANNER_SPEED,
                          KLIPPER_INSTANT_CORNER_V, ARC_MIN_TURN, KLIPPER_CHUNK, MAX_STOP_LINES))
    return _Sim(profile, on_line, on_block)


def simulate_events(event_iter, profile, on_line=None, on_block=None) -> SimResult:
    """Play (idx, raw, event) triples (as ``state.events`` yields them).

    ``on_block(b)``, if given, sees every planned block in execution order, after its
    line's figures were accumulated: a ``planner.Block`` with ``idx`` (0-based source
    line), ``kind``, ``first`` (first block of its line), ``d`` (mm), unit vector
    ``ux, uy, uz``, ``start_v, cruise_v, end_v`` (mm/s), ``accel`` (mm/s^2) and the
    trapezoid's ``accel_t, cruise_t, decel_t`` (s).  Read it, don't keep it changing."""
    sim = new_sim(profile, on_line, on_block)
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


def simulate_file(path, profile, on_line=None, on_block=None, on_barrier=None, progress=None,
                  on_count=None) -> SimResult:
    """simulate_events over the file's lines (state.events), read in chunks and played by the
    compiled loop (Sim.play) where the compiled core plays.  on_barrier(dwell_t), if given,
    is called once the model took a Barrier (as ringing.wrap_events does); progress(n), if
    given, is told the characters read (per chunk, or per line in pure Python).
    on_count(n), if given, is told the file's lines as summary.count_lines counts them,
    where the pass knows that number (_counted_by)."""
    state = st.MachineState(profile, path)
    sim = new_sim(profile, on_line, on_block)
    if hasattr(sim, "play"):
        blocks = Blocks(path, progress)
        _play_chunks(blocks, state, sim, None, None, on_barrier)
        _counted_by(blocks, on_count)
    else:
        _play(_counted(st.read_lines(path), progress), state, sim, None, None, on_barrier)
    sim.stop()
    return sim.res


# ---------------------------------------------------------------- the file in chunks
CHUNK_HINT = 1 << 16      # characters a chunk of lines is read in (~2 k lines): the compiled
                          # loop leaves C once a chunk, memory stays flat


def read_chunks(path, progress=None):
    """The file's lines as read_lines reads them (the same splitting, endings kept), in
    lists: (idx of the first, [raw, ...]).  progress(n) is told each chunk's characters."""
    with st.open_text(path) as fh:
        idx0 = 0
        while True:
            lines = fh.readlines(CHUNK_HINT)
            if not lines:
                return
            if progress is not None:
                progress(sum(map(len, lines)))
            yield idx0, lines
            idx0 += len(lines)


BLOCK_BYTES = 1 << 16     # bytes a block of Blocks is read in (~2.5 k lines of a re-timed file)


class Blocks:
    """The file for Sim.play_buf: iterated, read_chunks' (idx0, [raw, ...]) chunks (the loops
    that read lists of str: the reference); blocks() yields (buf, cr): bytes-like blocks of
    whole lines in file order (a block ends after a line's ending, the last at the file's
    end), cr False where the block holds no "\r".  play_buf splits and decodes them as
    read_lines does, without a list of str a chunk (the rectilinear plate's measure, 926 k
    lines: 9 % fewer instructions than readlines' chunks).  progress(n) is told each
    block's bytes."""

    def __init__(self, path, progress=None):
        self.path, self.progress = path, progress
        self.cr = False           # a block yielded held a "\r"
        self.n_lines = None       # _play_blocks: the lines it played, once it played them all

    def __iter__(self):
        return read_chunks(self.path, self.progress)

    def count(self):
        """The file's lines as summary.count_lines counts them, if known: the lines played
        where no "\r" ended one (else None)."""
        return None if self.cr else self.n_lines

    def blocks(self):
        progress = self.progress
        self.cr = False
        with open(self.path, "rb") as fh:
            seek = fh.seekable()
            rest = b""
            while True:
                data = fh.read(BLOCK_BYTES)
                if not data:
                    if rest:
                        cr = b"\r" in rest
                        self.cr |= cr
                        yield rest, cr
                    return
                n_read = len(data)
                if rest:
                    data = rest + data
                # cut after the last line ending; a "\r" at the very end may be the start of a
                # "\r\n" (one ending): its line waits for the next block.  A block without
                # "\r" (every block of a file of LF endings) is read once for it, not twice
                # (the cut's rfind and cr's find each read all of it: ~2.4 M instructions a
                # pass of the rectilinear plate)
                has_cr = b"\r" in data
                stop = len(data) - 1 if data[-1] == 13 else len(data)
                k = data.rfind(b"\n", 0, stop) + 1
                if has_cr:
                    k = max(k, data.rfind(b"\r", 0, stop) + 1)
                if k == 0:
                    if progress is not None:
                        progress(n_read)
                    rest = data
                    continue
                # the cut line is read again with the next block (a seek back) rather than
                # joined to it (rest + data copied the whole block: ~12 M bytes a pass of
                # the gyroid plate); it lies in the bytes just read
                tail = len(data) - k if seek else 0
                if tail:
                    fh.seek(-tail, 1)
                    rest = b""
                else:
                    rest = data[k:]
                if progress is not None:
                    progress(n_read - tail)     # (each byte told once)
                cr = has_cr and data.find(b"\r", 0, k) >= 0
                self.cr |= cr
                yield memoryview(data)[:k], cr


def _chunked(lines, n=2048):
    """(idx, raw) lines of consecutive idx as (idx of the first, [raw, ...]) chunks of n."""
    buf, idx0 = [], 0
    for idx, raw in lines:
        if not buf:
            idx0 = idx
        buf.append(raw)
        if len(buf) == n:
            yield idx0, buf
            buf = []
    if buf:
        yield idx0, buf


def _counted(lines, progress):
    """(idx, raw) lines, progress(len(raw)) told before each is yielded."""
    if progress is None:
        yield from lines
        return
    for item in lines:
        progress(len(item[1]))
        yield item


# ---------------------------------------------------------------- replaying a part of a file
# The model stands empty after every stop (an E-only move, a barrier, the end of the file):
# what follows depends on nothing before it but the reader's modal state.  A file that
# differs from one already played only inside some line ranges is therefore played again
# only from the stop before each changed range to the stop after it, the reader restored
# from a snapshot taken there, and the result spliced into the first pass's figures.

_SUMS = ("time_t", "int_a2", "int_a2_t", "int_v2", "n_moves", "n_blocks", "full_stops",
         "short_segments", "barrier_dwell_t", "corners", "corner_dv2")
_N_SUMS = len(_SUMS)
_INT_SUMS = frozenset(("n_moves", "n_blocks", "full_stops", "short_segments", "corners"))


class Ledger:
    """What a full pass recorded around its watched line ranges: for each range, the stop
    before it (``lo``) and the stop after it (``hi``), as indices into ``line`` (the stop's
    line; -1 before the file) with the reader's snapshot there, the running sums of the
    SimResult there, and the peak speed and acceleration of the stretch ending there.
    ``stop_lines`` holds every full stop's line (1-based), not only the first 100.
    ``ok`` is False when a watched range held a stop (its replay could not start empty)."""

    def __init__(self):
        from array import array
        self.line = array("q")
        self.state = []
        self.sums = array("d")
        self.peak_v = array("d")
        self.peak_a = array("d")
        self.lo = array("q")
        self.hi = array("q")
        self.stop_lines = []
        self.n_lines = 0
        self.ok = True
        self.res = None

    def _commit(self, line, state, sums, peak_v, peak_a):
        """sums: _sums_row's bytes (the writer's), or _sums' tuple."""
        self.line.append(line)
        self.state.append(state)
        if type(sums) is bytes:
            self.sums.frombytes(sums)
        else:
            self.sums.extend(sums)
        self.peak_v.append(peak_v)
        self.peak_a.append(peak_a)
        return len(self.line) - 1

    def sums_at(self, j):
        return self.sums[j * _N_SUMS:(j + 1) * _N_SUMS]


def _sums(res):
    return (res.time_t, res.int_a2, res.int_a2_t, res.int_v2, res.n_moves, res.n_blocks, res.full_stops,
            res.short_segments, res.barrier_dwell_t, res.corners, res.corner_dv2)


def _sums_row(res):
    """_sums(res) as a Ledger holds it: the bytes of its array("d") (counts as floats), added
    by one copy (frombytes: an extend from the tuple cost ~6 k instructions a commit)."""
    return array("d", _sums(res)).tobytes()


def _take_stop(res):
    """(peak_v, peak_a, _sums_row(res)), res's peaks then set to 0.0: the compiled
    SimResult's take_stop() for the Python model's SimResult."""
    peak_v, peak_a = res.peak_v, res.peak_a
    res.peak_v = res.peak_a = 0.0
    return peak_v, peak_a, _sums_row(res)


def _play(lines, state, sim, watch, led, on_barrier=None):
    """Step (idx, raw) lines through the reader `state` and the model `sim`.  With `led`,
    record the stops around the sorted, disjoint line ranges `watch` [(first, last), ...].
    on_barrier(dwell_t), if given, is called once the model took a Barrier (its blocks
    flushed), as ringing.wrap_events does: a ringing Collector can ride on the pass."""
    Move, Barrier, EONLY = st.Move, st.Barrier, st.EONLY
    step, move, barrier = state.step, sim.move, sim.barrier
    if on_barrier is not None:
        def barrier(ev, _take=sim.barrier):
            _take(ev)
            on_barrier(ev.dwell_t)
    res = sim.res
    if led is None:
        for idx, raw in lines:
            ev = step(idx, raw)
            if ev is not None:
                cls = type(ev)
                if cls is Move:
                    move(ev)
                elif cls is Barrier:
                    barrier(ev)
        return
    w = _LedgerWriter(led, watch, state, res)
    next_first = w.next_first
    idx = -1
    for idx, raw in lines:
        if idx == next_first:
            next_first = w.range_starts()
        ev = step(idx, raw)
        if ev is None:
            continue
        cls = type(ev)
        if cls is Move:
            move(ev)
            if ev.kind != EONLY:
                continue
        elif cls is Barrier:
            barrier(ev)
        else:
            continue
        w.stopped(idx)             # the model stands empty after this line
    w.finish(idx + 1, sim)


class LineRanges:
    """Sorted, disjoint line ranges [(first, last), ...] (a Ledger's watched ranges) held as
    two array("q"): a list of tuples held ~125 bytes a range (~6.5 MB for the rectilinear
    plate's 52 k strokes while its output is measured), these 16.  Reads as that list
    (len, [i], iteration: (first, last) tuples made when read)."""
    __slots__ = ("first", "last")

    def __init__(self, first, last):
        if len(first) != len(last):
            raise ValueError("LineRanges: as many first lines as last lines")
        self.first, self.last = array("q", first), array("q", last)

    @classmethod
    def of_rows(cls, first, last):
        """From two int64 numpy arrays (their bytes copied, no int objects made)."""
        a, z = array("q"), array("q")
        a.frombytes(first.astype("=i8", copy=False).tobytes())
        z.frombytes(last.astype("=i8", copy=False).tobytes())
        return cls(a, z)

    def __len__(self):
        return len(self.first)

    def __getitem__(self, i):
        return self.first[i], self.last[i]

    def __iter__(self):
        return zip(self.first, self.last)


def _ranges(watch):
    """watch's first and last lines as two array("q") (the same arrays for LineRanges)."""
    if type(watch) is LineRanges:
        return watch.first, watch.last
    return array("q", [r[0] for r in watch]), array("q", [r[1] for r in watch])


def _repeat(j, k):
    """array("q") of k times j: extended into another array("q") as one copy (a list's ints
    go in one by one, each parsed: ~0.2 M of them a plate's measure)."""
    return array("q", (j,)) * k


class _LedgerWriter:
    """What _play and _play_chunks record into a Ledger around the watched ranges: told
    where a watched range starts and where the model stands empty, it commits the stop
    before each range and the stop after it, with the peaks of the stretch between."""

    def __init__(self, led, watch, state, res):
        self.led, self.snap, self.res = led, state.snapshot, res
        # the peaks and sums at a stop in one call (the compiled SimResult's)
        self.take = getattr(res, "take_stop", None) or partial(_take_stop, res)
        self.w_first, self.w_last = _ranges(watch)     # each watched range's first and last line
        self.n_w = len(self.w_first)
        self.wi = 0
        self.next_first = self.w_first[0] if self.n_w else -2   # first line of the next watched range
        self.pending = []          # watched ranges started, waiting for the stop after them
        self.carry_v = self.carry_a = 0.0   # peaks since the last committed stop, up to the last stop
        self.last = (-1, self.snap(), _sums_row(res))
        self.last_j = -1           # index of `last` in the ledger, -1 = not committed
        self.quiet = None          # on_quiet's QuietStops (the quiet stops kept in C), if any

    def range_starts(self):
        """The next line to play is the first of watched range wi: returns the first line
        of the range after it (-2: none)."""
        led = self.led
        if self.last_j < 0:
            last = self.last
            self.last_j = led._commit(last[0], last[1], last[2], self.carry_v, self.carry_a)
            self.carry_v = self.carry_a = 0.0
        led.lo.append(self.last_j)
        self.pending.append(self.wi)
        self.wi += 1
        self.next_first = self.w_first[self.wi] if self.wi < self.n_w else -2
        return self.next_first

    def ranges_start(self, k):
        """range_starts k times over (the lines between them played, the model not empty
        in between): the same ledger entries."""
        led = self.led
        if self.last_j < 0:
            last = self.last
            self.last_j = led._commit(last[0], last[1], last[2], self.carry_v, self.carry_a)
            self.carry_v = self.carry_a = 0.0
        led.lo.extend(_repeat(self.last_j, k))
        self.pending.extend(range(self.wi, self.wi + k))
        self.wi += k
        self.next_first = self.w_first[self.wi] if self.wi < self.n_w else -2

    def stopped(self, idx):
        """The model stands empty after line idx."""
        peak_v, peak_a, sums = self.take()
        if peak_v > self.carry_v:
            self.carry_v = peak_v
        if peak_a > self.carry_a:
            self.carry_a = peak_a
        self.last = (idx, self.snap(), sums)
        self.last_j = -1
        pending = self.pending
        if pending:
            led = self.led
            if self.w_last[pending[-1]] >= idx:          # a stop inside a watched range
                led.ok = False
            self.last_j = led._commit(idx, self.last[1], self.last[2], self.carry_v, self.carry_a)
            self.carry_v = self.carry_a = 0.0
            led.hi.extend(_repeat(self.last_j, len(pending)))
            self.pending = []

    def on_quiet(self, state):
        """stopped, for play_buf's stops with no watched range pending: the compiled core's
        quiet_record, bound to a QuietStops that keeps them without a Python object each
        (absorb() folds them in), where the take is the compiled SimResult's own and the
        snapshot the reader's; else stopped itself (the reference)."""
        res = self.res
        if (USE_QUIET_CORE and hasattr(_core, "quiet_record") and isinstance(res, _core.SimResult)
                and getattr(type(res), "take_stop", None) is _core.SimResult.take_stop
                and type(state).snapshot is st.MachineState.snapshot):
            self.quiet = _core.quiet_new(res, st._modal_of, state)
            return MethodType(_core.quiet_record, self.quiet)
        return self.stopped

    def ledger_core(self, state):
        """A LedgerCore that records every stop and range start of play_buf's pass in C (the
        same entries as range_starts and stopped, no return to Python for them), where the
        conditions of on_quiet's QuietStops hold; else None.  The writer's state is the
        core's until take_core."""
        res = self.res
        if (USE_LEDGER_CORE and USE_QUIET_CORE and hasattr(_core, "ledger_new") and isinstance(res, _core.SimResult)
                and getattr(type(res), "take_stop", None) is _core.SimResult.take_stop
                and type(state).snapshot is st.MachineState.snapshot and not self.pending
                and self.last_j < 0 and not len(self.led.line) and type(self.last[2]) is bytes):
            return _core.ledger_new(res, st._modal_of, state, self.w_last, self.led, self.last[1], self.last[2])
        return None

    def take_core(self, core, wi):
        """The writer's state back from the LedgerCore `core` (its entries appended to the
        ledger), wi: the next watched range."""
        _core.ledger_flush(core)
        idx, snap, sums, self.last_j, self.carry_v, self.carry_a, n_pend, ok = _core.ledger_done(core)
        self.last = (idx, snap, sums)
        self.pending = list(range(wi - n_pend, wi))
        self.wi = wi
        self.next_first = self.w_first[wi] if wi < self.n_w else -2
        if not ok:
            self.led.ok = False

    def absorb(self):
        """The quiet stops on_quiet's QuietStops kept since the last absorb, folded in as
        stopped would have recorded them (none pending: nothing committed)."""
        got = _core.quiet_take(self.quiet)
        if got is not None:
            idx, snap, sums, peak_v, peak_a = got
            if peak_v > self.carry_v:
                self.carry_v = peak_v
            if peak_a > self.carry_a:
                self.carry_a = peak_a
            self.last = (idx, snap, sums)
            self.last_j = -1

    def finish(self, n_lines, sim):
        """The file ended after n_lines lines: the model stopped, the last stop committed."""
        led, res = self.led, self.res
        led.n_lines = n_lines
        sim.stop()
        carry_v, carry_a = max(self.carry_v, res.peak_v), max(self.carry_a, res.peak_a)
        end_j = led._commit(led.n_lines - 1, self.snap(), _sums_row(res), carry_v, carry_a)
        led.hi.extend(_repeat(end_j, len(self.pending)))
        if self.wi < self.n_w:    # ranges past the end of the file: nothing to replay from
            led.ok = False
        res.peak_v = max(led.peak_v) if len(led.peak_v) else 0.0
        res.peak_a = max(led.peak_a) if len(led.peak_a) else 0.0


USE_PLAY_FIRSTS = True    # tests turn it off: a play() call per watched range (the reference)


def _play_chunks(chunks, state, sim, watch, led, on_barrier=None):
    """_play on (idx0, [raw, ...]) chunks (read_chunks) with a compiled Sim: its play() runs
    the loop, leaving C only where _play's ledger does something (a watched range's first
    line, a line after which the model stands empty); the same steps in the same order."""
    if type(chunks) is Blocks and USE_PLAY_BUF and hasattr(sim, "play_buf"):
        _play_blocks(chunks, state, sim, watch, led, on_barrier)
        return
    play, step = sim.play, state.step
    if led is None:
        for idx0, lines in chunks:
            play(lines, 0, idx0, step, -2, False, on_barrier)
        return
    w = _LedgerWriter(led, watch, state, sim.res)
    n_lines = 0
    if getattr(_core, "PLAY_FIRSTS", 0) and USE_PLAY_FIRSTS:
        # the watched ranges' first lines passed over in C: play() leaves only where the
        # model stands empty (or at the chunk's end) and says how many ranges started
        firsts = w.w_first
        wi = 0
        for idx0, lines in chunks:
            n = len(lines)
            n_lines = idx0 + n
            i = 0
            while i < n:
                i, stopped, wj = play(lines, i, idx0, step, wi, True, on_barrier, firsts)
                if wj != wi:
                    w.ranges_start(wj - wi)
                    wi = wj
                if stopped:
                    w.stopped(idx0 + i - 1)
        w.finish(n_lines, sim)
        return
    next_first = w.next_first
    for idx0, lines in chunks:
        n = len(lines)
        n_lines = idx0 + n
        i = 0
        while i < n:
            i, stopped = play(lines, i, idx0, step, next_first, True, on_barrier)
            if stopped:
                w.stopped(idx0 + i - 1)    # the model stands empty after line idx0 + i - 1
            elif i < n:                    # line idx0 + i (not read yet) starts a watched range
                next_first = w.range_starts()
    w.finish(n_lines, sim)


USE_PLAY_BUF = True       # tests turn it off: Blocks played as read_chunks' lists (the reference)
USE_QUIET_STOPS = True    # tests turn it off: play_buf returns at every stop (the reference)
USE_QUIET_CORE = True     # tests turn it off: _LedgerWriter.stopped records the quiet stops (the reference)
USE_LEDGER_CORE = True    # tests turn it off: the ledger written by _LedgerWriter between play_buf's returns (the reference)


def _play_blocks(blocks, state, sim, watch, led, on_barrier=None):
    """_play_chunks on Blocks' blocks of bytes (Sim.play_buf): the same lines, the same
    steps in the same order, the same ledger."""
    play, step = sim.play_buf, state.step
    idx = 0
    if led is None:
        for buf, cr in blocks.blocks():
            n = len(buf)
            pos = 0
            while pos < n:
                pos, idx, _ = play(buf, pos, idx, cr, step, -2, False, on_barrier)
        blocks.n_lines = idx
        return
    w = _LedgerWriter(led, watch, state, sim.res)
    if getattr(_core, "PLAY_FIRSTS", 0) and USE_PLAY_FIRSTS:
        firsts = w.w_first
        wi = 0
        core = w.ledger_core(state) if USE_QUIET_STOPS else None
        if core is not None:
            # every stop and range start recorded in C: play_buf returns at a block's end only
            for buf, cr in blocks.blocks():
                n = len(buf)
                pos = 0
                while pos < n:
                    pos, idx, _, wi = play(buf, pos, idx, cr, step, wi, True, on_barrier, firsts, core)
            w.take_core(core, wi)
            blocks.n_lines = idx
            w.finish(idx, sim)
            return
        # a stop with no watched range pending is recorded by w.stopped called from the loop
        # (no return to here: ~3.8 k of them on the rectilinear plate's measure)
        quiet = w.on_quiet(state) if USE_QUIET_STOPS else None
        absorb = w.absorb if quiet is not None and w.quiet is not None else None
        for buf, cr in blocks.blocks():
            n = len(buf)
            pos = 0
            while pos < n:
                pos, idx, stopped, wj = play(buf, pos, idx, cr, step, wi, True, on_barrier, firsts,
                                             None if w.pending else quiet)
                if absorb is not None:
                    absorb()               # (the quiet stops of that call, before anything reads them)
                if wj != wi:
                    w.ranges_start(wj - wi)
                    wi = wj
                if stopped:
                    w.stopped(idx - 1)
        blocks.n_lines = idx
        w.finish(idx, sim)
        return
    next_first = w.next_first
    for buf, cr in blocks.blocks():
        n = len(buf)
        pos = 0
        while pos < n:
            pos, idx, stopped = play(buf, pos, idx, cr, step, next_first, True, on_barrier)
            if stopped:
                w.stopped(idx - 1)         # the model stands empty after line idx - 1
            elif pos < n:                  # line idx (not read yet) starts a watched range
                next_first = w.range_starts()
    blocks.n_lines = idx
    w.finish(idx, sim)


def _counted_by(blocks, on_count):
    """on_count(the lines Blocks played) where they are count_lines' lines: played as
    blocks of bytes (play_buf), none ended by a "\r"."""
    if on_count is not None and blocks.count() is not None:
        on_count(blocks.count())


def simulate_ledger(path, profile, watch, on_line=None, on_block=None, lines=None, on_barrier=None,
                    progress=None, on_count=None):
    """simulate_file that also returns a Ledger of the stops around the sorted, disjoint
    line ranges `watch` [(first, last), ...] (0-based, inclusive), for replay_runs.
    `lines`: the file's (idx, raw) lines if the caller reads them (read_lines(path));
    else the file is read here, in chunks played by the compiled loop where the compiled
    core plays (progress(n), if given, is told the characters read);
    on_barrier(dwell_t): called after each Barrier (see _play); on_count as simulate_file's."""
    state = st.MachineState(profile, path)
    state.warnings = []
    sim = new_sim(profile, on_line, on_block)
    sim.max_stop_lines = math.inf
    led = Ledger()
    if lines is None and hasattr(sim, "play"):
        blocks = Blocks(path, progress)
        _play_chunks(blocks, state, sim, watch, led, on_barrier)
        _counted_by(blocks, on_count)
    else:
        lines = _counted(st.read_lines(path), progress) if lines is None else lines
        _play(lines, state, sim, watch, led, on_barrier)
    res = sim.res
    led.stop_lines = res.stop_lines
    res.stop_lines = led.stop_lines[:MAX_STOP_LINES]
    led.res = res
    return res, led


class ReplayMismatch(Exception):
    """A replayed stretch did not end as the full pass did (not empty, or another reader
    state): the splice would not be the full pass's result."""


E_TOL_D = 1e-9     # mm of filament: a logical E summed in another order (a re-timed block
                   # cuts a stroke's E into other pieces) differs by rounding only; the
                   # file writes E to 1e-5 mm, so 1e-9 mm is no difference a line can make
_E = st.MachineState.MODAL.index("e")


def _same_state(a, b):
    """Two reader snapshots that make every later line read the same: equal, but the
    logical E to E_TOL_D."""
    return a[:_E] == b[:_E] and a[_E + 1:] == b[_E + 1:] and abs(a[_E] - b[_E]) <= E_TOL_D


def replay_runs(path, profile, led, runs, on_line=None, on_block=None):
    """The firmware model on `path`, a file that equals the one `led` was recorded on
    except inside `runs` [(lo, hi, first, last), ...]: ledger stop indices lo < hi, and the
    new file's lines first..last that replace the old lines line[lo]+1..line[hi] (sorted,
    disjoint).  Plays those lines only, each stretch from the reader snapshot at lo, and
    checks that it ends empty; where the reader's state there is not the recorded one (an F
    the old lines did not leave, say; the logical E is compared to E_TOL_D, as the file's
    own E words are read with the same rounding), the stretch goes on to the next recorded stop,
    and so on, until both agree (or the file ends).  Then splices: the sums of the full
    pass minus the old stretches plus the new ones (equal to a full pass to rounding,
    ~1e-15 relative), the peaks of the stretches kept and played, every full stop's line
    renumbered.  Returns (SimResult, [(lo, hi), ...] the stretches played).
    Raises ReplayMismatch if the files do not line up as `runs` says."""
    if not led.ok:
        raise ReplayMismatch("the ledger has a stop inside a watched range")
    out = SimResult()
    tot = list(_sums(led.res))
    peak_v, peak_a = [], []
    stop_lines = []
    played = []
    kept_from = 0             # first ledger stretch (by its end index) not yet accounted for
    old_stop = led.stop_lines
    si = 0                    # next old stop line to consider
    shift = 0                 # new line - old line, outside the runs
    n_sums = _N_SUMS
    end = len(led.line) - 1   # the end of the file
    queue = list(runs)
    queue.reverse()
    with open(path, "r", encoding="utf-8", errors="surrogateescape", newline="") as fh:
        lines = enumerate(fh)
        pos = -1              # last line read

        def upto(last):
            nonlocal pos
            if pos >= last:
                return
            for idx, raw in lines:
                pos = idx
                yield idx, raw
                if idx >= last:
                    return

        while queue:
            lo, hi, first, last = queue.pop()
            # stretches kept before this run: their peaks, their full stops (renumbered)
            for j in range(kept_from, lo + 1):
                peak_v.append(led.peak_v[j])
                peak_a.append(led.peak_a[j])
            lo_line = led.line[lo]
            while si < len(old_stop) and old_stop[si] - 1 <= lo_line:
                stop_lines.append(old_stop[si] + shift)
                si += 1
            if first - 1 != lo_line + shift or pos > first - 1:
                raise ReplayMismatch(f"run at old line {lo_line + 1} does not start where the new file has it")
            for _ in upto(first - 1):
                pass
            if pos != first - 1:
                raise ReplayMismatch(f"the new file ends before line {first + 1}")
            state = st.MachineState(profile, path)
            state.warnings = []
            state.restore(led.state[lo])
            sim = new_sim(profile, on_line, on_block)
            sim.max_stop_lines = math.inf
            while True:
                if hasattr(sim, "play"):
                    _play_chunks(_chunked(upto(last)), state, sim, None, None)
                else:
                    _play(upto(last), state, sim, None, None)
                if hi == end:
                    sim.stop()
                if pos != last or not sim.empty():
                    raise ReplayMismatch(f"replay of lines {first + 1}-{last + 1} did not end empty")
                if hi == end or _same_state(state.snapshot(), led.state[hi]):
                    break
                # not where the full pass was: go on to the next recorded stop
                after = last - led.line[hi]          # new line - old line after this run
                hi += 1
                last = led.line[hi] + after
                if queue and hi > queue[-1][0]:      # into the next run: take it in
                    _, hi2, _, last2 = queue.pop()
                    if hi2 >= hi:
                        hi, last = hi2, last2
                    else:
                        last = led.line[hi] + (last2 - led.line[hi2])
            r = sim.res
            old_lo, old_hi = led.sums_at(lo), led.sums_at(hi)
            new = _sums(r)
            for k in range(n_sums):
                tot[k] += new[k] - (old_hi[k] - old_lo[k])
            peak_v.append(r.peak_v)
            peak_a.append(r.peak_a)
            hi_line = led.line[hi]
            while si < len(old_stop) and old_stop[si] - 1 <= hi_line:
                si += 1
            stop_lines.extend(r.stop_lines)
            shift = last - hi_line
            kept_from = hi + 1
            played.append((lo, hi))
    for j in range(kept_from, len(led.line)):
        peak_v.append(led.peak_v[j])
        peak_a.append(led.peak_a[j])
    stop_lines.extend(s + shift for s in old_stop[si:])
    for name, value in zip(_SUMS, tot):
        setattr(out, name, int(round(value)) if name in _INT_SUMS else value)
    out.peak_v = max(peak_v) if peak_v else 0.0
    out.peak_a = max(peak_a) if peak_a else 0.0
    out.stop_lines = stop_lines[:MAX_STOP_LINES]
    return out, played
