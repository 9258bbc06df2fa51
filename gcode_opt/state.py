"""Machine state: what a firmware remembers from line to line.

`MachineState.step(idx, raw)` reads one line and returns what it does to the machine:
a `Move` (the toolhead or the extruder moves), a `Barrier` (the planner must come to a
stop: homing, dwell, waits), or None (the line only changes modal state or is unknown).
Positions are logical coordinates in mm (after G20 and G92), speeds mm/s, accelerations
mm/s^2.  The flavour decides how M204, M201/M203/M205, SET_VELOCITY_LIMIT, F<=0 and
G90/M83 are read, as the firmware would (Klipper ignores M201/M203/M205).

A line the state must read (G0-G3, G92, M204, M201/M203/M205, G4, G10/G11,
SET_VELOCITY_LIMIT) is read by the strict tokenizer (words.py) and range-checked; what a
printer would reject or misread raises GcodeError naming the file and line.  Unknown
commands are never parsed.  `MachineState.warnings` collects (idx, text) for lines left
as written that a user should hear of (an arc whose end is off its circle, an M205 J
Marlin ignores).
"""
from __future__ import annotations

import math
import operator

from . import features as feat
from .profile import Profile
from .words import (WordError, shown, command_of, command_text, compiled_on_first_call, keyvals_of, params_of,
                    strict_number, strip_checksum)

# Move.kind
LINE = 0      # straight XY(Z) move, with or without E
ARC = 1       # G2/G3 in the XY plane (helical Z allowed)
EONLY = 2     # extruder only (retract / prime, G10/G11)


class Limits:
    """Planner limits in force (copy-on-write: a Move keeps the object it was made with)."""
    __slots__ = ("v_max", "ax_max", "ay_max", "scv", "mcr", "jd", "jerk_x", "jerk_y")

    def __init__(self, v_max, ax_max, ay_max, scv, mcr, jd, jerk_x, jerk_y):
        self.v_max, self.ax_max, self.ay_max = v_max, ax_max, ay_max
        self.scv, self.mcr, self.jd, self.jerk_x, self.jerk_y = scv, mcr, jd, jerk_x, jerk_y

    def _values(self):
        return tuple(getattr(self, s) for s in Limits.__slots__)

    def __eq__(self, other):          # by value: two readers that read the same lines agree
        return type(other) is Limits and self._values() == other._values()

    def __hash__(self):
        return hash(self._values())

    def replace(self, **kw) -> "Limits":
        new = Limits(*(getattr(self, s) for s in Limits.__slots__))
        for k, v in kw.items():
            setattr(new, k, v)
        return new


class Move:
    """One motion line as the firmware sees it."""
    __slots__ = ("idx", "kind", "x0", "y0", "z0", "x1", "y1", "z1", "e", "v", "accel",
                 "feature", "layer", "lim", "arc", "has_f", "e_rel", "xyz_rel", "checksum", "inch",
                 "flow_r", "speed_r")

    def __init__(self, idx, kind, x0, y0, z0, x1, y1, z1, e, v, accel, feature, layer, lim,
                 arc=None, has_f=False, e_rel=True, xyz_rel=False, checksum=False, inch=False,
                 flow_r=1.0, speed_r=1.0):
        self.idx, self.kind = idx, kind
        self.x0, self.y0, self.z0, self.x1, self.y1, self.z1 = x0, y0, z0, x1, y1, z1
        self.e, self.v, self.accel = e, v, accel
        self.feature, self.layer, self.lim, self.arc = feature, layer, lim, arc
        self.has_f, self.e_rel, self.xyz_rel, self.checksum = has_f, e_rel, xyz_rel, checksum
        self.inch = inch                  # written in inches (G20): we leave such lines alone
        self.flow_r = flow_r              # M221 flow factor: the extruder moves e * flow_r
        self.speed_r = speed_r            # M220 speed factor, already applied to v: F written in such
                                          # a stroke would be scaled again by the firmware

    @property
    def length_d(self) -> float:
        if self.kind == ARC:
            return self.arc.length_d
        return math.sqrt((self.x1 - self.x0) ** 2 + (self.y1 - self.y0) ** 2 + (self.z1 - self.z0) ** 2)

    def __repr__(self):
        return (f"Move(line {self.idx + 1}, kind={self.kind}, ({self.x0:.3f},{self.y0:.3f},{self.z0:.3f})->"
                f"({self.x1:.3f},{self.y1:.3f},{self.z1:.3f}), e={self.e:.5f}, v={self.v:.2f}, a={self.accel:.0f}, "
                f"{self.feature})")


class Arc:
    """G2/G3 geometry: centre, radius, start angle, signed sweep (rad, + = CCW).

    end_off_d: how far (mm) the end point is from the circle through the start; a
    firmware sweeps the start's circle and then goes straight to the end.  off_circle:
    beyond arc_end_tol_d(r), so the arc is not the circle a law would re-time (left alone)."""
    __slots__ = ("cx", "cy", "r", "theta0", "sweep", "length_d", "cw", "end_off_d", "off_circle")

    def __init__(self, cx, cy, r, theta0, sweep, dz, end_off_d=0.0):
        self.cx, self.cy, self.r, self.theta0, self.sweep = cx, cy, r, theta0, sweep
        self.cw = sweep < 0
        self.length_d = math.hypot(r * abs(sweep), dz)
        self.end_off_d = end_off_d
        self.off_circle = end_off_d > arc_end_tol_d(r)


def arc_end_tol_d(r_d: float) -> float:
    """Tolerance on |r_end - r_start| (mm): a slicer rounds end and centre to 0.001 mm,
    so 0.005 mm (or 0.1 % of a large radius) is rounding, anything more is a bad arc."""
    return max(0.005, 1e-3 * r_d)


class Barrier:
    """The planner must be empty here (homing, dwell, heat-and-wait...); dwell_t seconds."""
    __slots__ = ("idx", "dwell_t", "reason")

    def __init__(self, idx, dwell_t, reason):
        self.idx, self.dwell_t, self.reason = idx, dwell_t, reason


class GcodeError(ValueError):
    """A line we cannot read safely; names file and line."""

    def __init__(self, path, idx, raw, why):
        super().__init__(f"{path}:{idx + 1}: {why}: {shown(raw.rstrip())}")


# the slicer's own "G1 X.. Y.. E.. F..": this regex leaves float() only the characters
# "+-.0123456789", where float() accepts exactly the strict number grammar (and raises on
# "1.2.3", "1-2", "."), so the fast path reads what the strict tokenizer would
# (compiled at their first call: the compiled reader reads those lines in most runs)
_fast_m204 = compiled_on_first_call(globals(), "_fast_m204", r"M204(?:[ \t]+[SPTR][-+.0-9]+)*[ \t\r\n]*", "fullmatch")
_fast_match = compiled_on_first_call(globals(), "_fast_match", r"G[01](?:[ \t]+[XYZEF][-+.0-9]+)*[ \t\r\n]*",
                                     "fullmatch")

# Ranges beyond any printer: a value outside is a damaged file, refused with its line.
MAX_POS_D = 1e5        # |X|,|Y|,|Z|,|I|,|J|,|R| in mm (100 m)
MAX_E_D = 1e7          # |E| in mm: 10 km of filament (~30 kg of 1.75 mm), more than any
                       # print; at 5 decimals that is 1e12 units, exact in a float64
MAX_F = 1e7            # F in mm/min (167 m/s)
MAX_ACCEL_A = 1e6      # mm/s^2 (100 g; the fastest printers stay below 1e5)
MAX_VELOCITY_V = 1e5   # mm/s
MAX_DWELL_T = 1e6      # s (11 days)
_CLASSIC_LETTERS = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZ")
_MOTION_CMDS = frozenset(("G0", "G1", "G2", "G3"))
_WAITS = {"M109", "M190", "M400", "M0", "M1", "M600", "M191", "M116", "G29", "G80", "G34", "M226"}
# the classic commands (words.command_of's names) _step_python reads: any other returns
# None there and changes nothing, and the compiled reader answers it so itself (keep this
# in step with _step_python and _other: tests/test_speed32_reader_noop.py checks)
COMMANDS_READ = frozenset({"G0", "G1", "G2", "G3", "G92", "G90", "G91", "M82", "M83", "G20", "G21", "M204", "M201",
                           "M203", "M205", "M221", "M220", "G10", "G11", "G4", "G28"} | _WAITS)


def arc_from_words(x0, y0, x1, y1, p, cw, dz):
    """Arc from G2/G3 words (I/J offsets or R).  Returns None for a degenerate arc."""
    if "I" in p or "J" in p:
        cx, cy = x0 + p.get("I", 0.0), y0 + p.get("J", 0.0)
        r = math.hypot(x0 - cx, y0 - cy)
    elif "R" in p:
        r_signed = p["R"]
        r = abs(r_signed)
        dx, dy = x1 - x0, y1 - y0
        chord = math.hypot(dx, dy)
        if chord == 0.0 or r == 0.0:
            return None
        h2 = r * r - chord * chord / 4.0
        h = math.sqrt(max(h2, 0.0))
        mx, my = (x0 + x1) / 2.0, (y0 + y1) / 2.0
        # centre is left of the chord for CCW short arcs; R<0 asks for the long way round
        sgn = (1.0 if not cw else -1.0) * (1.0 if r_signed > 0 else -1.0)
        cx, cy = mx - sgn * h * dy / chord, my + sgn * h * dx / chord
        r = math.hypot(x0 - cx, y0 - cy)    # R below half the chord: firmwares centre the
    else:                                   # arc on the chord's midpoint
        return None
    if r == 0.0:
        return None
    t0 = math.atan2(y0 - cy, x0 - cx)
    t1 = math.atan2(y1 - cy, x1 - cx)
    sweep = t1 - t0
    if cw:
        if sweep >= -1e-12:
            sweep -= 2 * math.pi
    else:
        if sweep <= 1e-12:
            sweep += 2 * math.pi
    return Arc(cx, cy, r, t0, sweep, dz, abs(math.hypot(x1 - cx, y1 - cy) - r))


class MachineState:
    """Modal state of the firmware, updated line by line."""

    def __init__(self, profile: Profile, path: str = "<input>"):
        self.profile, self.path = profile, path
        self.flavour = profile.flavour
        self._one_accel = self.flavour in ("klipper", "marlin-legacy")   # one accel for every XY move
        self.x = self.y = self.z = 0.0
        self.e = 0.0                      # logical E (absolute reading)
        self.abs_xyz = True               # G90
        self.e_rel_flag = False           # M83
        self.inch = False                 # G20
        self.v = 25.0                     # modal feed, mm/s (Marlin's power-on 1500 mm/min)
        self.feature = feat.OTHER
        self.layer = 0
        self.warnings = []                # (idx, text): lines left alone that a user should know of
        self.flow_r = 1.0                 # M221 S/100 (Klipper's extrude_factor)
        self.speed_r = 1.0                # M220 S/100: every move's F is scaled by it (Klipper, Marlin, RRF)
        self.pa_t = 0.0                   # Klipper pressure advance (s), config default 0
        self.pa_smooth_t = 0.040          # Klipper pressure_advance_smooth_time default
        self.retracted = False
        self.feature_seen = False         # the compiled reader read a feature comment (pipeline.analyse)
        self.accel_print = profile.default_accel_a    # M204 P (Klipper: the single accel)
        self.accel_travel = profile.travel_accel_a    # M204 T (Marlin 2 / RRF)
        self.accel_retract = profile.retract_accel_a  # M204 R
        self.lim = Limits(profile.max_velocity_v, profile.max_accel_a, profile.max_accel_a,
                          profile.square_corner_velocity_v, profile.minimum_cruise_ratio_r,
                          profile.junction_deviation_d, profile.jerk_xy_v, profile.jerk_xy_v)

    # ---- a copy of what the lines changed (the firmware model replays from it) --------
    MODAL = ("x", "y", "z", "e", "abs_xyz", "e_rel_flag", "inch", "v", "feature", "layer", "flow_r",
             "speed_r", "pa_t", "pa_smooth_t", "retracted", "accel_print", "accel_travel",
             "accel_retract", "lim")

    def snapshot(self) -> tuple:
        """Every attribute a line can change, as a tuple (Limits is copy-on-write, so
        sharing it is safe).  restore(snapshot) puts the state back where it was."""
        return _modal_of(self)

    def restore(self, snap: tuple) -> None:
        for name, value in zip(MachineState.MODAL, snap):
            setattr(self, name, value)

    # ---- derived modal values -------------------------------------------------------
    @property
    def e_relative(self) -> bool:
        return self.e_rel_flag or not self.abs_xyz

    def accel_for(self, extruding: bool, kinematic: bool) -> float:
        """The acceleration the firmware uses for this kind of move."""
        if not kinematic:
            return self.accel_retract
        if self.flavour == "klipper" or self.flavour == "marlin-legacy":
            return self.accel_print                     # one accel for every XY move
        return self.accel_print if extruding else self.accel_travel

    # ---- one line -------------------------------------------------------------------
    def _step_python(self, idx: int, raw: str):
        """Read one line: Move, Barrier or None (step is this, or the compiled fast path
        that falls back to it; see use_reader)."""
        if idx == 0 and raw[:1] == "\ufeff":       # a UTF-8 BOM is encoding, not G-code
            raw = raw[1:]
        if "\r" in raw and (raw[-1:] == "\r" or "\r" in raw.rstrip("\r\n")):
            # a lone CR: read_lines ends a line there, as Marlin and Prusa-Firmware do (a
            # reader splitting at LF only leaves it inside); Klipper splits at LF only and
            # reads the two as one line.  The firmwares disagree, and a block written with
            # this line's ending would be one comment line to Klipper
            raise GcodeError(self.path, idx, raw, "a carriage return (CR) without a line feed ends or cuts "
                             "this line: Marlin and Prusa-Firmware read what follows it as a new line, Klipper "
                             "does not; the file's line endings are damaged (convert them, e.g. with "
                             "dos2unix or mac2unix)")
        i = raw.find(";")
        code = raw if i < 0 else raw[:i]
        toks = code.split()
        if not toks:
            if i >= 0:
                comment = raw[i:]
                f = feat.feature_from_comment(comment)
                if f is not None:
                    self.feature = f
                elif feat.is_layer_change(comment):
                    self.layer += 1
            return None
        t0 = toks[0]
        # fast path: the slicer's own "G1 X.. Y.. E.. F.." (~95 % of a file), proven strict
        if (t0 == "G1" or t0 == "G0") and _fast_match(code) is not None:
            p = {}                                 # a loop, not a dict comprehension: cheaper here
            try:
                for t in toks[1:]:
                    p[t[0]] = float(t[1:])
            except ValueError:
                p = None                           # "X1.2.3": the strict path says why
            if p is not None and len(p) == len(toks) - 1:     # else a word given twice
                return self._linear(idx, raw, p, False)
        elif t0 == "M204" and _fast_m204(code) is not None:    # every segment of a re-timed block
            p = {}
            try:
                for t in toks[1:]:
                    p[t[0]] = float(t[1:])
            except ValueError:
                p = None
            if p is not None and len(p) == len(toks) - 1:
                self._m204(idx, raw, p)
                return None
        try:
            code, checksum = strip_checksum(code)
            cmd = command_of(code)
            if self.flavour == "klipper" and cmd[:1] in _CLASSIC_LETTERS and command_text(code) != cmd:
                # Klipper does not normalise 'G01': an unknown command it skips.  A move in
                # that form whose words are unreadable (NaN, inf, garbage) is still a broken
                # file (other firmwares read it as G1): refused, as the same line as 'G1'.
                if cmd in _MOTION_CMDS:
                    params_of(code)
                return None
            if cmd in ("G1", "G0"):
                return self._linear(idx, raw, params_of(code), checksum)
            if cmd in ("G2", "G3"):
                return self._arc(idx, raw, code, cmd == "G2", checksum)
            return self._other(idx, raw, cmd, code)
        except WordError as e:
            raise GcodeError(self.path, idx, raw, str(e)) from None

    step = _step_python                    # use_reader below puts the compiled fast path here

    def _error(self, idx, raw, why):
        return GcodeError(self.path, idx, raw, why)

    def _mm(self, v: float) -> float:
        return v * 25.4 if self.inch else v

    def _target(self, p):
        if self.inch:
            p = {k: v * 25.4 for k, v in p.items()}
        if self.abs_xyz:
            x = p.get("X", self.x)
            y = p.get("Y", self.y)
            z = p.get("Z", self.z)
        else:
            x = self.x + p.get("X", 0.0)
            y = self.y + p.get("Y", 0.0)
            z = self.z + p.get("Z", 0.0)
        ev = p.get("E")
        if ev is None:
            de = 0.0
        else:
            de = ev if (self.e_rel_flag or not self.abs_xyz) else ev - self.e
        return x, y, z, de, ev

    def _check_target(self, idx, raw, x, y, z, ev):
        """Positions and E within what any printer can mean (after G20 and G91)."""
        b = MAX_POS_D
        if not (-b <= x <= b and -b <= y <= b and -b <= z <= b):
            raise self._error(idx, raw, f"position beyond {b:g} mm: X{x:g} Y{y:g} Z{z:g}")
        if ev is not None and not -MAX_E_D <= ev <= MAX_E_D:
            raise self._error(idx, raw, f"E beyond {MAX_E_D:g} mm")

    def _feed(self, idx, raw, p):
        if "F" in p:
            f_text = p["F"]
            if not f_text <= MAX_F:
                raise self._error(idx, raw, f"F beyond {MAX_F:g} mm/min")
            if f_text <= 0.0:
                if self.flavour in ("klipper", "rrf"):   # Klipper: "Invalid speed"
                    raise self._error(idx, raw, "F must be above 0 (the firmware rejects it or "
                                                "crawls at its minimum speed)")
                return True                    # Marlin, Prusa-Firmware: F<=0 keeps the last feed
            self.v = self._mm(f_text) / 60.0
            return True
        return False

    def _linear(self, idx, raw, p, checksum):
        # _target, accel_for and _feed's usual case inlined: this runs for ~95 % of a file's lines
        if "F" in p:
            f_text = p["F"]
            if 0.0 < f_text <= MAX_F and not self.inch:
                self.v = f_text / 60.0
                has_f = True
            else:
                has_f = self._feed(idx, raw, p)
        else:
            has_f = False
        if self.inch:
            p = {k: v * 25.4 for k, v in p.items()}
        x0, y0, z0 = self.x, self.y, self.z
        abs_xyz = self.abs_xyz
        if abs_xyz:
            x, y, z = p.get("X", x0), p.get("Y", y0), p.get("Z", z0)
        else:
            x, y, z = x0 + p.get("X", 0.0), y0 + p.get("Y", 0.0), z0 + p.get("Z", 0.0)
        e_rel = self.e_rel_flag or not abs_xyz
        ev = p.get("E")
        de = 0.0 if ev is None else (ev if e_rel else ev - self.e)
        b = MAX_POS_D
        if not (-b <= x <= b and -b <= y <= b and -b <= z <= b) or (ev is not None and not -MAX_E_D <= ev <= MAX_E_D):
            self._check_target(idx, raw, x, y, z, ev)
        self.x, self.y, self.z = x, y, z
        self.e += de
        if x == x0 and y == y0 and z == z0:
            if de == 0.0:
                return None
            return Move(idx, EONLY, x0, y0, z0, x, y, z, de, self.v * self.speed_r, self.accel_retract, self.feature,
                        self.layer, self.lim, None, has_f, e_rel, not abs_xyz, checksum, self.inch,
                        self.flow_r, self.speed_r)
        if de > 0.0:
            accel, ftr = self.accel_print, self.feature
        else:
            accel = self.accel_print if self._one_accel else self.accel_travel
            ftr = feat.TRAVEL
        return Move(idx, LINE, x0, y0, z0, x, y, z, de, self.v * self.speed_r, accel, ftr, self.layer,
                    self.lim, None, has_f, e_rel, not abs_xyz, checksum, self.inch, self.flow_r,
                    self.speed_r)

    def _arc(self, idx, raw, code, cw, checksum):
        p = params_of(code)
        for k in "IJR":
            if k in p and not abs(self._mm(p[k])) <= MAX_POS_D:
                raise self._error(idx, raw, f"{k} beyond {MAX_POS_D:g} mm")
        has_f = self._feed(idx, raw, p)
        x, y, z, de, ev = self._target(p)
        self._check_target(idx, raw, x, y, z, ev)
        x0, y0, z0 = self.x, self.y, self.z
        if "I" in p or "J" in p:
            p = dict(p)
            p["I"], p["J"] = self._mm(p.get("I", 0.0)), self._mm(p.get("J", 0.0))
        elif "R" in p:
            p = dict(p)
            p["R"] = self._mm(p["R"])
        arc = arc_from_words(x0, y0, x, y, p, cw, z - z0)
        if arc is None:
            raise GcodeError(self.path, idx, raw, "arc without I/J or R, or with zero radius")
        if arc.off_circle:
            self.warnings.append((idx, f"arc end {arc.end_off_d:.3f} mm off its circle (r {arc.r:.3f} mm): "
                                       "left as written, not re-timed"))
        self.x, self.y, self.z = x, y, z
        self.e += de
        ftr = self.feature if de > 0.0 else feat.TRAVEL
        return Move(idx, ARC, x0, y0, z0, x, y, z, de, self.v * self.speed_r, self.accel_for(de > 0.0, True),
                    ftr, self.layer, self.lim, arc, has_f, self.e_relative, not self.abs_xyz, checksum,
                    self.inch, self.flow_r, self.speed_r)

    def _other(self, idx, raw, cmd, code):
        prof = self.profile
        fl = self.flavour
        if cmd == "G92":
            p = params_of(code)
            if not p:                      # bare G92: all axes to zero
                self.x = self.y = self.z = self.e = 0.0
            x = self._mm(p["X"]) if "X" in p else self.x
            y = self._mm(p["Y"]) if "Y" in p else self.y
            z = self._mm(p["Z"]) if "Z" in p else self.z
            ev = self._mm(p["E"]) if "E" in p else None
            self._check_target(idx, raw, x, y, z, ev)
            self.x, self.y, self.z = x, y, z
            if ev is not None:
                self.e = ev
        elif cmd == "G90":
            self.abs_xyz = True
            if fl == "marlin2":            # Marlin 2: G90 also makes E absolute
                self.e_rel_flag = False
        elif cmd == "G91":
            self.abs_xyz = False
        elif cmd == "M82":
            self.e_rel_flag = False
        elif cmd == "M83":
            self.e_rel_flag = True
        elif cmd == "G20":
            self.inch = True
        elif cmd == "G21":
            self.inch = False
        elif cmd == "M204":
            self._m204(idx, raw, params_of(code))
        elif cmd in ("M201", "M203", "M205"):
            if fl != "klipper":            # Klipper: "Unknown command", nothing changes
                self._limits_m(idx, raw, cmd, params_of(code))
        elif cmd == "M221":
            self._m221(idx, raw, params_of(code))
        elif cmd == "M220":
            self._m220(idx, raw, params_of(code))
        elif cmd == "SET_PRESSURE_ADVANCE":
            if fl == "klipper" and self._set_pressure_advance(idx, raw, code):
                return Barrier(idx, 0.0, "SET_PRESSURE_ADVANCE flush")
        elif cmd == "SET_VELOCITY_LIMIT":
            if fl == "klipper":            # other firmwares do not know it
                self._set_velocity_limit(idx, raw, code)
        elif cmd == "G10" or cmd == "G11":
            p = params_of(code)
            if set(p) - {"S"}:             # G10 L2 P1 X0 (RRF offsets) is not a retraction
                return None
            retract = cmd == "G10"
            if retract == self.retracted:  # firmware ignores a second G10 in a row
                return None
            self.retracted = retract
            d = prof.fw_retract_length_d
            if d <= 0.0:
                return None
            return Move(idx, EONLY, self.x, self.y, self.z, self.x, self.y, self.z,
                        -d if retract else d, prof.fw_retract_speed_v, self.accel_retract,
                        self.feature, self.layer, self.lim, None, False, True, False, False)
        elif cmd == "G4":
            p = params_of(code)
            t = p.get("P", 0.0) / 1000.0 + p.get("S", 0.0)
            if min(p.get("P", 0.0), p.get("S", 0.0)) < 0.0 or not t <= MAX_DWELL_T:
                raise self._error(idx, raw, f"dwell must be between 0 and {MAX_DWELL_T:g} s")
            return Barrier(idx, t, "G4 dwell")
        elif cmd == "G28":
            return Barrier(idx, 0.0, "G28 home")
        elif cmd in _WAITS:
            return Barrier(idx, 0.0, cmd)
        return None

    def _positive(self, idx, raw, cmd, letter, value, top, unit):
        """A limit a firmware needs above 0 (Klipper rejects 0; Marlin, Prusa-Firmware and
        RepRapFirmware take it and then divide by it or never accelerate)."""
        if not 0.0 < value <= top:
            raise self._error(idx, raw, f"{cmd} {letter} must be above 0 and at most {top:g} {unit}")
        return value

    def _m204(self, idx, raw, p):
        fl = self.flavour
        if fl == "klipper":
            # toolhead.cmd_M204: S (> 0) wins; else P and T (each > 0 if given), both needed
            if "S" in p:
                self.accel_print = self._positive(idx, raw, "M204", "S", p["S"], MAX_ACCEL_A, "mm/s^2")
            else:
                for k in "PT":
                    if k in p:
                        self._positive(idx, raw, "M204", k, p[k], MAX_ACCEL_A, "mm/s^2")
                if "P" in p and "T" in p:
                    self.accel_print = min(p["P"], p["T"])
            self.accel_travel = self.accel_print
            return
        for k in "SPTR":
            if k in p and not 0.0 < p[k] <= MAX_ACCEL_A:    # _positive's test, its message on failure
                self._positive(idx, raw, "M204", k, p[k], MAX_ACCEL_A, "mm/s^2")
        if fl == "marlin-legacy":          # Prusa-Firmware MK3: S = all moves, T = retract
            if "S" in p:
                self.accel_print = self.accel_travel = p["S"]
                if "T" in p:
                    self.accel_retract = p["T"]
            else:
                if "P" in p: self.accel_print = self.accel_travel = p["P"]
                if "R" in p: self.accel_retract = p["R"]
        else:                              # Marlin 2 and RRF: P print, T travel, R retract
            if "S" in p:
                self.accel_print = self.accel_travel = p["S"]
            if "P" in p: self.accel_print = p["P"]
            if "T" in p: self.accel_travel = p["T"]
            if "R" in p: self.accel_retract = p["R"]

    def _limits_m(self, idx, raw, cmd, p):
        """M201 / M203 / M205 as Marlin 2, Prusa-Firmware and RepRapFirmware read them."""
        fl = self.flavour
        kw = {}
        if cmd == "M201":
            if "X" in p: kw["ax_max"] = self._positive(idx, raw, cmd, "X", p["X"], MAX_ACCEL_A, "mm/s^2")
            if "Y" in p: kw["ay_max"] = self._positive(idx, raw, cmd, "Y", p["Y"], MAX_ACCEL_A, "mm/s^2")
        elif cmd == "M203":
            per_s = 60.0 if fl == "rrf" else 1.0               # RRF: mm/min
            vals = [self._positive(idx, raw, cmd, a, p[a] / per_s, MAX_VELOCITY_V, "mm/s")
                    for a in ("X", "Y") if a in p]
            if vals:
                kw["v_max"] = min(vals)
        else:
            for a, key in (("X", "jerk_x"), ("Y", "jerk_y")):
                if a in p:
                    if not 0.0 <= p[a] <= MAX_VELOCITY_V:
                        raise self._error(idx, raw, f"M205 {a} (jerk) must be between 0 and "
                                                    f"{MAX_VELOCITY_V:g} mm/s")
                    kw[key] = p[a]
            if "J" in p and fl == "marlin2":
                if 0.01 <= p["J"] <= 0.3:  # Marlin 2 answers "?J out of range" and keeps its value
                    kw["jd"] = p["J"]
                else:
                    self.warnings.append((idx, "M205 J outside 0.01..0.3 mm: Marlin ignores it"))
        if kw:
            self.lim = self.lim.replace(**kw)

    def _m220(self, idx, raw, p):
        """Speed factor.  Klipper: S above 0 (100 without S); Marlin / Prusa / RRF report
        without S.  Both scale the F of every later move, the current one included."""
        if "S" not in p:
            if self.flavour == "klipper":
                self.speed_r = 1.0
            return
        s_pct = p["S"]
        if not 0.0 < s_pct <= 1e4:
            raise self._error(idx, raw, "M220 S (speed %) must be above 0 and at most 10000")
        self.speed_r = s_pct / 100.0

    def _m221(self, idx, raw, p):
        """Flow factor.  Klipper: S above 0, 100 without S; Marlin / Prusa / RRF take S0
        (no extrusion) and report without S."""
        if "S" not in p:
            if self.flavour == "klipper":
                self.flow_r = 1.0
            return
        s_pct = p["S"]
        low_ok = s_pct > 0.0 if self.flavour == "klipper" else s_pct >= 0.0
        if not (low_ok and s_pct <= 1e4):
            raise self._error(idx, raw, "M221 S (flow %) must be above 0 and at most 10000"
                              if self.flavour == "klipper" else "M221 S (flow %) must be between 0 and 10000")
        self.flow_r = s_pct / 100.0

    def _set_pressure_advance(self, idx, raw, code) -> bool:
        """Klipper's extruder._set_pressure_advance: ADVANCE >= 0, SMOOTH_TIME in [0, 0.2];
        True when the effective smooth time changes (Klipper then flushes: a full stop)."""
        kv = keyvals_of(code)
        vals = {}
        for key in ("ADVANCE", "SMOOTH_TIME"):
            text = kv.get(key)
            if text is None or "{" in text or "}" in text:
                continue
            try:
                vals[key] = strict_number(text)
            except WordError as e:
                raise self._error(idx, raw, f"{key}: {e}") from None
        pa = vals.get("ADVANCE", self.pa_t)
        smooth = vals.get("SMOOTH_TIME", self.pa_smooth_t)
        if not 0.0 <= pa <= 1e3:
            raise self._error(idx, raw, "ADVANCE must be at least 0")
        if not 0.0 <= smooth <= 0.2:
            raise self._error(idx, raw, "SMOOTH_TIME must be between 0 and 0.2 s")
        old = self.pa_smooth_t if self.pa_t else 0.0
        new = smooth if pa else 0.0
        self.pa_t, self.pa_smooth_t = pa, smooth
        return new != old

    def _set_velocity_limit(self, idx, raw, code):
        """Klipper's toolhead.cmd_SET_VELOCITY_LIMIT rules: VELOCITY and ACCEL above 0,
        SQUARE_CORNER_VELOCITY at least 0, MINIMUM_CRUISE_RATIO in [0, 1)."""
        kv = keyvals_of(code)
        vals = {}
        for key in ("VELOCITY", "ACCEL", "SQUARE_CORNER_VELOCITY", "MINIMUM_CRUISE_RATIO"):
            text = kv.get(key)
            if text is None or "{" in text or "}" in text:
                continue                   # a macro expression such as ACCEL={x}: not ours to read
            try:
                vals[key] = strict_number(text)
            except WordError as e:
                raise self._error(idx, raw, f"{key}: {e}") from None
        v = vals.get("VELOCITY")
        if v is not None and not 0.0 < v <= MAX_VELOCITY_V:
            raise self._error(idx, raw, f"VELOCITY must be above 0 and at most {MAX_VELOCITY_V:g} mm/s")
        a = vals.get("ACCEL")
        if a is not None and not 0.0 < a <= MAX_ACCEL_A:
            raise self._error(idx, raw, f"ACCEL must be above 0 and at most {MAX_ACCEL_A:g} mm/s^2")
        scv = vals.get("SQUARE_CORNER_VELOCITY")
        if scv is not None and not 0.0 <= scv <= MAX_VELOCITY_V:
            raise self._error(idx, raw, "SQUARE_CORNER_VELOCITY must be at least 0 "
                                        f"and at most {MAX_VELOCITY_V:g} mm/s")
        mcr = vals.get("MINIMUM_CRUISE_RATIO")
        if mcr is not None and not 0.0 <= mcr < 1.0:
            raise self._error(idx, raw, "MINIMUM_CRUISE_RATIO must be at least 0 and below 1")
        kw = {}
        if v is not None: kw["v_max"] = v
        if scv is not None: kw["scv"] = scv
        if mcr is not None: kw["mcr"] = mcr
        if a is not None: self.accel_print = self.accel_travel = a
        if kw: self.lim = self.lim.replace(**kw)


_get_modal = operator.attrgetter(*MachineState.MODAL)


# ---------------------------------------------------------------- which reader plays
def _load_reader():
    """The compiled fast path of step (module _gcode_opt_reader, built from _reader.c),
    set up with this module's classes; None if it is not built, if it was built from
    another _reader.c than the one beside this file (a stale build), or if
    GCODE_OPT_PURE_PYTHON asks for Python.  CORE_WHY says why not."""
    global CORE_WHY
    import os
    from .native import load
    core, CORE_WHY = load("_gcode_opt_reader", os.path.join(os.path.dirname(os.path.abspath(__file__)), "_reader.c"),
                          "reader")
    if core is None:
        return None
    core.setup(Move, MachineState, feat.TRAVEL, LINE, EONLY, MAX_POS_D, MAX_E_D, MAX_F, MAX_ACCEL_A, COMMANDS_READ)
    CORE_WHY = ""
    return core


CORE_WHY = ""
_reader = _load_reader()
_C_STEP = _reader.make_method() if _reader is not None else None


def _modal_getter():
    """snapshot's getter: the compiled reader's (each attribute read from a MachineState's
    dict: about half the attrgetter's instructions) where it is built and MachineState's
    class defines none of the names (else the dict would not be where they are read);
    else _get_modal.  The same tuple (tests/test_speed49_snap49_session.py)."""
    if _reader is None or not hasattr(_reader, "snapshot") or any(hasattr(MachineState, n) for n in MachineState.MODAL):
        return _get_modal
    _reader.set_modal(MachineState.MODAL, _get_modal)
    return _reader.snapshot


_modal_of = _modal_getter()
CORE = "python"


def use_reader(name: str) -> str:
    """Make `name` ("c": the compiled fast path for G0/G1 and M204 lines, everything else
    by _step_python; or "python") MachineState.step; returns the previous one.  Tests
    read on both; a state's bound step keeps the reader it was taken with."""
    global CORE
    if name not in ("c", "python") or (name == "c" and _C_STEP is None):
        raise ValueError(f"no {name!r} reader here")
    old, CORE = CORE, name
    MachineState.step = _C_STEP if name == "c" else MachineState._step_python
    return old


use_reader("c" if _C_STEP is not None else "python")


def open_text(path: str):
    """The file as read_lines reads it (iterate it for the lines with their endings)."""
    return open(path, "r", encoding="utf-8", errors="surrogateescape", newline="")


def read_lines(path: str):
    """Yield (idx, raw_line_with_ending).  Streams; keeps CRLF/LF as written."""
    with open_text(path) as fh:
        yield from enumerate(fh)


def line_chunks(path: str, progress=None, cr=None):
    """The file's lines as read_lines reads them, in chunks: (idx of the first, lines), the
    lines (raw, ...) as simulate.read_chunks gives them (there the chunks end elsewhere: callers take any
    chunking).  The compiled reader splits blocks of bytes (no TextIOWrapper), simulate.
    CHUNK_HINT bytes at a time (read_chunks' characters: one knob for both), each chunk a
    Lines (split_block): a sequence of those str, made only as they are read -- the
    compiled model's run_lines and gap_lines read most lines from its bytes (on the gyroid
    plate all but ~5 k of 461 k; a list of str a chunk cost ~0.1 G instructions there).
    Without it, read_chunks itself.
    progress(n) is told each chunk's characters.  cr, a one-item list if given, is set
    True unless the file holds no "\r" (then its lines, ended by "\n" alone, are the ones
    summary.count_lines counts; read_chunks' path does not look: True)."""
    from .firmware import simulate       # (it imports this module)
    split = getattr(_reader, "split_block", None)
    if split is None:
        if cr is not None:
            cr[0] = True
        yield from simulate.read_chunks(path, progress)
        return
    block = max(1, simulate.CHUNK_HINT)
    with open(path, "rb") as fh:
        seek = fh.seekable()
        idx0, rest = 0, b""
        while True:
            data = fh.read(block)
            final = not data
            if cr is not None and not cr[0] and b"\r" in data:
                cr[0] = True
            if rest:
                data = rest + data
            lines, used = split(data, final)
            if seek and used and used < len(data):
                # the cut line is read again with the next block (a seek back) rather than
                # joined to it: rest + data copied the whole block
                fh.seek(used - len(data), 1)
                rest = b""
            else:
                rest = data[used:]
            if lines:
                if progress is not None:      # (characters: the bytes where they are ASCII)
                    progress(used if data.isascii() else sum(map(len, lines)))
                yield idx0, lines
                idx0 += len(lines)
            if final:
                return


def events(path: str, profile: Profile, warnings: list | None = None):
    """Yield (idx, raw, event) for every line of the file: event is Move, Barrier or None.
    Give `warnings` (a list) to collect the reader's (idx, text) warnings into it."""
    st = MachineState(profile, path)
    if warnings is not None:
        st.warnings = warnings
    step = st.step
    for idx, raw in read_lines(path):
        yield idx, raw, step(idx, raw)
