"""Machine state: what a firmware remembers from line to line.

`MachineState.step(idx, raw)` reads one line and returns what it does to the machine:
a `Move` (the toolhead or the extruder moves), a `Barrier` (the planner must come to a
stop: homing, dwell, waits), or None (the line only changes modal state or is unknown).
Positions are logical coordinates in mm (after G20 and G92), speeds mm/s, accelerations
mm/s^2.  The flavour decides how M204 and G90/M83 are read, as the firmware would.
"""
from __future__ import annotations

import math

from . import features as feat
from .profile import Profile
from .words import command_of, keyvals_of, params_of, strip_checksum

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

    def replace(self, **kw) -> "Limits":
        new = Limits(*(getattr(self, s) for s in Limits.__slots__))
        for k, v in kw.items():
            setattr(new, k, v)
        return new


class Move:
    """One motion line as the firmware sees it."""
    __slots__ = ("idx", "kind", "x0", "y0", "z0", "x1", "y1", "z1", "e", "v", "accel",
                 "feature", "layer", "lim", "arc", "has_f", "e_rel", "xyz_rel", "checksum", "inch")

    def __init__(self, idx, kind, x0, y0, z0, x1, y1, z1, e, v, accel, feature, layer, lim,
                 arc=None, has_f=False, e_rel=True, xyz_rel=False, checksum=False, inch=False):
        self.idx, self.kind = idx, kind
        self.x0, self.y0, self.z0, self.x1, self.y1, self.z1 = x0, y0, z0, x1, y1, z1
        self.e, self.v, self.accel = e, v, accel
        self.feature, self.layer, self.lim, self.arc = feature, layer, lim, arc
        self.has_f, self.e_rel, self.xyz_rel, self.checksum = has_f, e_rel, xyz_rel, checksum
        self.inch = inch                  # written in inches (G20): we leave such lines alone

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
    """G2/G3 geometry: centre, radius, start angle, signed sweep (rad, + = CCW)."""
    __slots__ = ("cx", "cy", "r", "theta0", "sweep", "length_d", "cw")

    def __init__(self, cx, cy, r, theta0, sweep, dz):
        self.cx, self.cy, self.r, self.theta0, self.sweep = cx, cy, r, theta0, sweep
        self.cw = sweep < 0
        self.length_d = math.hypot(r * abs(sweep), dz)


class Barrier:
    """The planner must be empty here (homing, dwell, heat-and-wait...); dwell_t seconds."""
    __slots__ = ("idx", "dwell_t", "reason")

    def __init__(self, idx, dwell_t, reason):
        self.idx, self.dwell_t, self.reason = idx, dwell_t, reason


class GcodeError(ValueError):
    """A line we cannot read safely; names file and line."""

    def __init__(self, path, idx, raw, why):
        super().__init__(f"{path}:{idx + 1}: {why}: {raw.rstrip()!r}")


_G1_WORDS = frozenset("XYZEF")
_WAITS = {"M109", "M190", "M400", "M0", "M1", "M600", "M191", "M116", "G29", "G80", "G34", "M226"}


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
    else:
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
    return Arc(cx, cy, r, t0, sweep, dz)


class MachineState:
    """Modal state of the firmware, updated line by line."""

    def __init__(self, profile: Profile, path: str = "<input>"):
        self.profile, self.path = profile, path
        self.flavour = profile.flavour
        self.x = self.y = self.z = 0.0
        self.e = 0.0                      # logical E (absolute reading)
        self.abs_xyz = True               # G90
        self.e_rel_flag = False           # M83
        self.inch = False                 # G20
        self.v = 25.0                     # modal feed, mm/s (Marlin's power-on 1500 mm/min)
        self.feature = feat.OTHER
        self.layer = 0
        self.retracted = False
        self.accel_print = profile.default_accel_a    # M204 P (Klipper: the single accel)
        self.accel_travel = profile.travel_accel_a    # M204 T (Marlin 2 / RRF)
        self.accel_retract = profile.retract_accel_a  # M204 R
        self.lim = Limits(profile.max_velocity_v, profile.max_accel_a, profile.max_accel_a,
                          profile.square_corner_velocity_v, profile.minimum_cruise_ratio_r,
                          profile.junction_deviation_d, profile.jerk_xy_v, profile.jerk_xy_v)

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
    def step(self, idx: int, raw: str):
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
        # fast path: the slicer's own "G1 X.. Y.. E.. F.." (~95 % of a file)
        if (t0 == "G1" or t0 == "G0") and "*" not in code:
            try:
                p = {t[0]: float(t[1:]) for t in toks[1:]}
            except ValueError:
                p = None
            if p is None or not p.keys() <= _G1_WORDS:
                p = params_of(code)
            return self._linear(idx, raw, p, False)
        code, checksum = strip_checksum(code)
        cmd = command_of(code)
        if cmd in ("G1", "G0"):
            return self._linear(idx, raw, params_of(code), checksum)
        if cmd in ("G2", "G3"):
            return self._arc(idx, raw, code, cmd == "G2", checksum)
        return self._other(idx, raw, cmd, code)

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
        return x, y, z, de

    def _feed(self, p):
        if "F" in p:
            f = self._mm(p["F"]) / 60.0
            if f > 0.0:
                self.v = f
            return True
        return False

    def _linear(self, idx, raw, p, checksum):
        has_f = self._feed(p)
        x, y, z, de = self._target(p)
        x0, y0, z0 = self.x, self.y, self.z
        self.x, self.y, self.z = x, y, z
        self.e += de
        if x == x0 and y == y0 and z == z0:
            if de == 0.0:
                return None
            kind = EONLY
            accel = self.accel_for(False, False)
        else:
            kind = LINE
            accel = self.accel_for(de > 0.0, True)
        ftr = self.feature if (de > 0.0 or kind == EONLY) else feat.TRAVEL
        return Move(idx, kind, x0, y0, z0, x, y, z, de, self.v, accel, ftr, self.layer,
                    self.lim, None, has_f, self.e_relative, not self.abs_xyz, checksum, self.inch)

    def _arc(self, idx, raw, code, cw, checksum):
        p = params_of(code)
        has_f = self._feed(p)
        x, y, z, de = self._target(p)
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
        self.x, self.y, self.z = x, y, z
        self.e += de
        ftr = self.feature if de > 0.0 else feat.TRAVEL
        return Move(idx, ARC, x0, y0, z0, x, y, z, de, self.v, self.accel_for(de > 0.0, True),
                    ftr, self.layer, self.lim, arc, has_f, self.e_relative, not self.abs_xyz, checksum,
                    self.inch)

    def _other(self, idx, raw, cmd, code):
        prof = self.profile
        if cmd == "G92":
            p = params_of(code)
            if not p:                      # bare G92: all axes to zero
                self.x = self.y = self.z = self.e = 0.0
            if "X" in p: self.x = self._mm(p["X"])
            if "Y" in p: self.y = self._mm(p["Y"])
            if "Z" in p: self.z = self._mm(p["Z"])
            if "E" in p: self.e = self._mm(p["E"])
        elif cmd == "G90":
            self.abs_xyz = True
            if self.flavour == "marlin2":  # Marlin 2: G90 also makes E absolute
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
            self._m204(params_of(code))
        elif cmd == "M201":
            p = params_of(code)
            kw = {}
            if "X" in p: kw["ax_max"] = p["X"]
            if "Y" in p: kw["ay_max"] = p["Y"]
            if kw: self.lim = self.lim.replace(**kw)
        elif cmd == "M203":
            p = params_of(code)
            vals = [p[a] for a in ("X", "Y") if a in p]
            if vals:
                v = min(vals) / (60.0 if self.flavour == "rrf" else 1.0)   # RRF: mm/min
                self.lim = self.lim.replace(v_max=v)
        elif cmd == "M205":
            p = params_of(code)
            kw = {}
            if "X" in p: kw["jerk_x"] = p["X"]
            if "Y" in p: kw["jerk_y"] = p["Y"]
            if "J" in p: kw["jd"] = p["J"]
            if kw: self.lim = self.lim.replace(**kw)
        elif cmd == "SET_VELOCITY_LIMIT":
            kv = keyvals_of(code)
            kw = {}
            try:
                if "VELOCITY" in kv: kw["v_max"] = float(kv["VELOCITY"])
                if "SQUARE_CORNER_VELOCITY" in kv: kw["scv"] = float(kv["SQUARE_CORNER_VELOCITY"])
                if "MINIMUM_CRUISE_RATIO" in kv: kw["mcr"] = float(kv["MINIMUM_CRUISE_RATIO"])
                if "ACCEL" in kv: self.accel_print = self.accel_travel = float(kv["ACCEL"])
            except ValueError:
                pass                       # a macro variable such as ACCEL={x}: leave as is
            if kw: self.lim = self.lim.replace(**kw)
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
            return Barrier(idx, t, "G4 dwell")
        elif cmd == "G28":
            return Barrier(idx, 0.0, "G28 home")
        elif cmd in _WAITS:
            return Barrier(idx, 0.0, cmd)
        return None

    def _m204(self, p):
        fl = self.flavour
        if fl == "klipper":
            if "S" in p:
                self.accel_print = p["S"]
            elif "P" in p and "T" in p:
                self.accel_print = min(p["P"], p["T"])
            self.accel_travel = self.accel_print
        elif fl == "marlin-legacy":        # Prusa-Firmware MK3: S = all moves, T = retract
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


def read_lines(path: str):
    """Yield (idx, raw_line_with_ending).  Streams; keeps CRLF/LF as written."""
    with open(path, "r", encoding="utf-8", errors="surrogateescape", newline="") as fh:
        for idx, raw in enumerate(fh):
            yield idx, raw


def events(path: str, profile: Profile):
    """Yield (idx, raw, event) for every line of the file: event is Move, Barrier or None."""
    st = MachineState(profile, path)
    step = st.step
    for idx, raw in read_lines(path):
        yield idx, raw, step(idx, raw)
