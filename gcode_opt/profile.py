"""Printer profiles: the machine's limits, its firmware and its moving mass.

Profiles are TOML files in the repository's `profiles/` folder (installed as the
package `gcode_opt.profiles`).  `load_profile("prusa-mk3s")` finds a bundled one by
name; a path to a .toml file works too.  Every field has a unit in its name.

A profile file is checked against SCHEMA before use: each key lives in one table
([firmware], [limits], [machine], [resonance]; `name` and `sources` at the top), has a type and a
range, and a few keys are required.  An error names the file and the key:
`my.toml: max_accel_a = -1000: must be > 0 mm/s^2` (ProfileError, a ValueError).

Required, because a wrong guess changes what is written or what the firmware does:
  flavour, junction      -- decide which commands are written (M204 forms, SET_VELOCITY_LIMIT)
                            and how corners are modelled; a guessed flavour wrote Klipper
                            commands into Marlin files
  max_velocity_v, max_accel_a -- cap every speed and acceleration written
  the parameter of the chosen junction model (square_corner_velocity_v for scv,
  junction_deviation_d for jd, jerk_xy_v for jerk) -- sets the corner speeds the plan
                            relies on
Optional, with a stated default: default_accel_a = max_accel_a (Klipper starts at
max_accel; Marlin caps the accel in force by M201 anyway), travel_accel_a and
retract_accel_a = default_accel_a; the rest take the dataclass defaults below, which only
refine the model (masses, hotend flow, segment rate, arc chord, ...).

[resonance] (optional; only the ringing figures read it): the frame's resonance per axis
and the input shaper the firmware runs.  Defaults when absent: freq_x_hz = freq_y_hz = 50
(ESTIMATE: mid of the 30-100 Hz Klipper's docs, Measuring_Resonances.md, give for common
printers), damping_r = 0.1 (Klipper's DEFAULT_DAMPING_RATIO, "a good all-round value" per
its docs), shaper = "none", shaper_freq_x/y_hz = the resonance's (a shaper tuned at f),
shaper_damping_r = 0.1 (Klipper's [input_shaper] damping_ratio_x/y default)."""
from __future__ import annotations

import math
import os
import re

from .records import field, field_names, record

FLAVOURS = ("klipper", "marlin2", "marlin-legacy", "rrf")
SHAPERS = ("none", "zv", "mzv", "ei")
JUNCTION_MODELS = ("scv", "jd", "jerk")


class ProfileError(ValueError):
    """A profile that cannot be used; the message starts with the file (and key)."""


@record(frozen=True)
class Profile:
    """One printer: its limits, firmware and moving mass (fields below, units in their names)."""
    # (a docstring of its own: without one, @dataclass builds one from inspect.signature of
    # the 35 fields at every import, ~9 M instructions of each run's start)
    name: str
    flavour: str = "klipper"            # how the firmware reads M204/M203/G90... (see state.py)
    junction: str = "scv"               # scv: Klipper square_corner_velocity; jd: Marlin junction
                                        # deviation; jerk: Marlin classic jerk
    # speed and acceleration limits
    max_velocity_v: float = 300.0       # mm/s, XY (Klipper max_velocity / Marlin M203 X Y)
    max_accel_a: float = 3000.0         # mm/s^2, per-axis cap (Klipper max_accel / Marlin M201 X Y)
    default_accel_a: float = 3000.0     # mm/s^2, accel in force at start of file if it sets none
    travel_accel_a: float = 3000.0      # mm/s^2, Marlin/RRF travel accel at start
    retract_accel_a: float = 1500.0     # mm/s^2, E-only moves
    max_z_velocity_v: float = 15.0      # mm/s
    max_z_accel_a: float = 200.0        # mm/s^2
    max_e_velocity_v: float = 120.0     # mm/s, E-only moves
    square_corner_velocity_v: float = 5.0   # mm/s (Klipper)
    minimum_cruise_ratio_r: float = 0.5     # Klipper [printer] minimum_cruise_ratio
    junction_deviation_d: float = 0.013     # mm (Marlin JD)
    jerk_xy_v: float = 8.0              # mm/s (Marlin classic jerk, M205 X Y)
    # planner / MCU
    block_buffer: int = 0               # planner buffer in moves (0 = Klipper-style full lookahead)
    min_segment_time_t: float = 0.0     # s, Marlin DEFAULT_MINSEGMENTTIME
    max_segment_rate: float = 1000.0    # segments (moves) per second the firmware sustains
    arc_segment_d: float = 1.0          # mm, chord length used to cut G2/G3
    steps_per_mm_xy: float = 80.0       # X/Y motor steps per mm (Marlin M92; 1.8 deg, GT2 20T, 16 microsteps)
    min_move_steps: int = -1            # a move with fewer steps on every axis is dropped (joined with the
                                        # next move) by the firmware; -1 = the flavour's (min_move_d)
    # machine
    moving_mass_x_kg: float = 0.5       # mass the X motor accelerates
    moving_mass_y_kg: float = 0.5       # mass the Y motor accelerates (the bed on a bed-slinger)
    filament_diameter_d: float = 1.75
    max_volumetric_flow: float = 15.0   # mm^3/s, hotend melt limit
    fw_retract_length_d: float = 0.8    # mm, G10/G11 firmware retraction
    fw_retract_speed_v: float = 35.0    # mm/s
    # resonance (ringing figures only; see the module docstring for the defaults' sources)
    freq_x_hz: float = 50.0             # X resonance (Klipper's shaper calibration gives it)
    freq_y_hz: float = 50.0             # Y resonance
    damping_r: float = 0.1              # damping ratio zeta of both axes
    shaper: str = "none"                # input shaper in force: none / zv / mzv / ei
    shaper_freq_x_hz: float = 0.0       # shaper frequencies; 0 = tuned at freq_x_hz / freq_y_hz
    shaper_freq_y_hz: float = 0.0
    shaper_damping_r: float = 0.1       # the shaper's design damping (Klipper damping_ratio_x/y)
    sources: tuple[str, ...] = field(default_factory=tuple)   # where the numbers come from

    def moving_mass_kg(self, ux: float, uy: float) -> tuple[float, float]:
        """(m_eff, m2_eff) for motion along the unit direction (ux, uy): the kinetic term
        weighs sum m_i u_i^2, the inertia-force term sum m_i^2 u_i^2 (each axis pushes
        its own mass)."""
        mx, my = self.moving_mass_x_kg, self.moving_mass_y_kg
        return mx * ux * ux + my * uy * uy, mx * mx * ux * ux + my * my * uy * uy

    @property
    def min_move_d(self) -> float:
        """The shortest X or Y travel (mm) of a move the firmware executes as its own block;
        a shorter one it drops and joins with the next move, so a lead-in there would not
        slow its corner and a lead-out's distance would cut the next corner.  Marlin 2
        (planner.cpp: `step_event_count < MIN_STEPS_PER_SEGMENT` (6) returns) and
        Prusa-Firmware 3.x (`step_event_count <= dropsegments` (5)) drop moves under 6
        steps; Klipper and RepRapFirmware queue any move.  One step of margin: the step
        count is taken between rounded step positions."""
        steps = self.min_move_steps
        if steps < 0:
            steps = 6 if self.flavour in ("marlin2", "marlin-legacy") else 0
        return (steps + 1) / self.steps_per_mm_xy if steps > 0 else 0.0


# ---------------------------------------------------------------- schema
# key -> (table, kind, lo, lo_open, hi, hi_open, unit); table "" = top level.
# kind: "num" (finite int or float, not bool), "int" (whole number, not bool), "str", "strs",
# or a tuple of allowed strings.  lo/hi None = unbounded on that side.  The upper bounds are
# far above any printer; they stop a typo (an extra 000, m for mm) from reaching the planner
# as a number whose square overflows.
V_MAX, A_MAX = 1e4, 1e6                  # mm/s, mm/s^2


def _pos(hi):
    return (0.0, True, hi, False)        # (0, hi]


def _nonneg(hi):
    return (0.0, False, hi, False)       # [0, hi]


SCHEMA = {
    "name": ("", "str", None, False, None, False, ""),
    "sources": ("", "strs", None, False, None, False, ""),
    "flavour": ("firmware", FLAVOURS, None, False, None, False, ""),
    "junction": ("firmware", JUNCTION_MODELS, None, False, None, False, ""),
    "square_corner_velocity_v": ("firmware", "num", *_nonneg(V_MAX), "mm/s"),
    "minimum_cruise_ratio_r": ("firmware", "num", 0.0, False, 1.0, True, ""),
    "junction_deviation_d": ("firmware", "num", *_pos(10.0), "mm"),
    "jerk_xy_v": ("firmware", "num", *_nonneg(V_MAX), "mm/s"),
    "block_buffer": ("firmware", "int", 0, False, 100000, False, "moves"),
    "min_segment_time_t": ("firmware", "num", 0.0, False, 1.0, False, "s"),
    "max_segment_rate": ("firmware", "num", *_pos(1e6), "segments/s"),
    # a chord of 1e-9 mm cut one arc into ~1e10 pieces: the run never ended
    "arc_segment_d": ("firmware", "num", 0.01, False, 10.0, False, "mm"),
    "steps_per_mm_xy": ("firmware", "num", *_pos(1e5), "steps/mm"),
    "min_move_steps": ("firmware", "int", -1, False, 1000, False, "steps"),
    "fw_retract_length_d": ("firmware", "num", *_nonneg(100.0), "mm"),
    "fw_retract_speed_v": ("firmware", "num", *_pos(V_MAX), "mm/s"),
    "max_velocity_v": ("limits", "num", *_pos(V_MAX), "mm/s"),
    "max_accel_a": ("limits", "num", *_pos(A_MAX), "mm/s^2"),
    "default_accel_a": ("limits", "num", *_pos(A_MAX), "mm/s^2"),
    "travel_accel_a": ("limits", "num", *_pos(A_MAX), "mm/s^2"),
    "retract_accel_a": ("limits", "num", *_pos(A_MAX), "mm/s^2"),
    "max_z_velocity_v": ("limits", "num", *_pos(V_MAX), "mm/s"),
    "max_z_accel_a": ("limits", "num", *_pos(A_MAX), "mm/s^2"),
    "max_e_velocity_v": ("limits", "num", *_pos(V_MAX), "mm/s"),
    "moving_mass_x_kg": ("machine", "num", *_pos(1000.0), "kg"),
    "moving_mass_y_kg": ("machine", "num", *_pos(1000.0), "kg"),
    "filament_diameter_d": ("machine", "num", 0.1, False, 10.0, False, "mm"),
    "max_volumetric_flow": ("machine", "num", *_pos(1e4), "mm^3/s"),
    # 1 Hz .. 1 kHz brackets every printer frame; zeta < 1 keeps the oscillator underdamped
    # (the exact solution the ringing model uses), Klipper's EI shaper is defined to 0.4
    "freq_x_hz": ("resonance", "num", 1.0, False, 1000.0, False, "Hz"),
    "freq_y_hz": ("resonance", "num", 1.0, False, 1000.0, False, "Hz"),
    "damping_r": ("resonance", "num", 0.0, True, 1.0, True, ""),
    "shaper": ("resonance", SHAPERS, None, False, None, False, ""),
    "shaper_freq_x_hz": ("resonance", "num", 1.0, False, 1000.0, False, "Hz"),
    "shaper_freq_y_hz": ("resonance", "num", 1.0, False, 1000.0, False, "Hz"),
    "shaper_damping_r": ("resonance", "num", 0.0, True, 0.4, False, ""),
}
TABLES = ("firmware", "limits", "machine", "resonance")
REQUIRED = ("flavour", "junction", "max_velocity_v", "max_accel_a")
JUNCTION_KEY = {"scv": "square_corner_velocity_v", "jd": "junction_deviation_d", "jerk": "jerk_xy_v"}
assert set(SCHEMA) | {"name"} == set(field_names(Profile))


def _toml_text(v):
    """A value as it reads in TOML (the user's own spelling, near enough)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v + '"'
    if isinstance(v, float) and not math.isfinite(v):
        return "nan" if v != v else ("inf" if v > 0 else "-inf")
    if isinstance(v, dict):
        return "a table"
    if isinstance(v, list):
        return "[...]"
    return repr(v)


# keys whose whole interval is the message; the others name the side that was crossed
_INTERVAL = {"minimum_cruise_ratio_r", "arc_segment_d", "filament_diameter_d", "block_buffer",
             "min_segment_time_t", "freq_x_hz", "freq_y_hz", "damping_r", "shaper_freq_x_hz",
             "shaper_freq_y_hz", "shaper_damping_r"}


def _range_text(key, below, lo, lo_open, hi, hi_open, unit):
    u = f" {unit}" if unit else ""
    if key in _INTERVAL and hi is not None:
        return f"must be in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}{u}"
    if below:
        return f"must be {'>' if lo_open else '>='} {lo:g}{u}"
    return f"must be {'<' if hi_open else '<='} {hi:g}{u} (far above any printer: a typo?)"


def _check(key, v):
    """Error text for value v of key, or None."""
    _, kind, lo, lo_open, hi, hi_open, unit = SCHEMA[key]
    if isinstance(kind, tuple):
        if not isinstance(v, str) or v not in kind:
            return f"must be one of {', '.join(kind)}"
        return None
    if kind == "str":
        return None if isinstance(v, str) and v.strip() else "must be a non-empty string"
    if kind == "strs":
        ok = isinstance(v, list) and all(isinstance(s, str) for s in v)
        return None if ok else "must be a list of strings"
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        what = ("true/false" if isinstance(v, bool) else "a string" if isinstance(v, str)
                else "a table" if isinstance(v, dict) else "a list" if isinstance(v, list) else type(v).__name__)
        return f"must be a number{' in ' + unit if unit else ''}, not {what}"
    if kind == "int" and not isinstance(v, int):
        return "must be a whole number"
    if not math.isfinite(v):
        return "must be a finite number"
    bad_lo = lo is not None and (v <= lo if lo_open else v < lo)
    bad_hi = hi is not None and (v >= hi if hi_open else v > hi)
    return _range_text(key, bad_lo, lo, lo_open, hi, hi_open, unit) if bad_lo or bad_hi else None


def profile_from_dict(data: dict, name: str, where: str | None = None) -> Profile:
    """Validate a parsed profile TOML against SCHEMA and build the Profile.  `where`
    (the file, for messages) defaults to name + '.toml'."""
    where = where or f"{name}.toml"

    def err(msg):
        return ProfileError(f"{where}: {msg}")

    if not data:
        raise err("empty profile; it needs at least " + ", ".join(REQUIRED))
    flat: dict = {}
    for k, v in data.items():
        if k in TABLES:
            if not isinstance(v, dict):
                raise err(f"{k} must be a table ([{k}])")
            items = v.items()
            table = k
        elif isinstance(v, dict):
            raise err(f"unknown table [{k}]; tables are " + ", ".join(f"[{t}]" for t in TABLES))
        else:
            items, table = ((k, v),), ""
        for key, val in items:
            spec = SCHEMA.get(key)
            if spec is None:
                raise err(f"unknown key {key}" + (f" in [{table}]" if table else "")
                          + f"; known: {', '.join(sorted(SCHEMA))}")
            if spec[0] != table:
                home = f"under [{spec[0]}]" if spec[0] else "at the top of the file"
                raise err(f"{key} belongs {home}, not " + (f"under [{table}]" if table else "at the top"))
            msg = _check(key, val)
            if msg:
                raise err(f"{key} = {_toml_text(val)}: {msg}")
            flat[key] = val
    missing = [k for k in REQUIRED if k not in flat]
    if not missing and JUNCTION_KEY[flat["junction"]] not in flat:
        missing.append(JUNCTION_KEY[flat["junction"]])
    if missing:
        raise err("missing " + ", ".join(f"{k} (under [{SCHEMA[k][0]}])" for k in missing)
                  + "; no default is assumed for these")
    flat.setdefault("name", name)
    flat.setdefault("default_accel_a", flat["max_accel_a"])
    flat.setdefault("travel_accel_a", flat["default_accel_a"])
    flat.setdefault("retract_accel_a", flat["default_accel_a"])
    for ax in ("x", "y"):                    # a shaper tuned at the resonance unless told
        flat.setdefault(f"shaper_freq_{ax}_hz", flat.get(f"freq_{ax}_hz", getattr(Profile, f"freq_{ax}_hz")))
    for k in ("block_buffer",):
        if k in flat:
            flat[k] = int(flat[k])
    for k, (table, kind, *_rest) in SCHEMA.items():
        if kind == "num" and k in flat:
            flat[k] = float(flat[k])
    if "sources" in flat:
        flat["sources"] = tuple(flat["sources"])
    return Profile(**flat)


def _bundled_dir():
    """profiles/ of the repository, installed as package data `gcode_opt.profiles`: the
    package's folder as the import system finds it (importlib.resources.files gives the
    same folder for an installed or editable package, and costs ~1 MB resident to import),
    as a str (os.path: pathlib and the urllib.parse and ipaddress it imports cost ~4 ms of
    every run's start)."""
    from importlib.util import find_spec
    try:
        spec = find_spec("gcode_opt.profiles")
    except (ImportError, ValueError):
        spec = None
    for d in (spec.submodule_search_locations or ()) if spec is not None else ():
        if os.path.isdir(d):
            return d
    d = os.path.join(os.path.dirname(os.path.dirname(os.path.realpath(__file__))), "profiles")  # a source checkout
    return d if os.path.isdir(d) else None


def profile_names() -> list[str]:
    d = _bundled_dir()
    if d is None:
        return []
    return sorted(n[:-5] for n in os.listdir(d) if n.endswith(".toml"))


# the plain TOML the bundled profiles are written in (_plain_toml)
_BARE = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_-")   # a bare key's
_CTRL = frozenset(map(chr, [*range(0x20), 0x7f]))        # never in a string; in a comment, tab only
_NUMBER = r"[+-]?(?:0|[1-9][0-9]*)(?:\.[0-9]+)?(?:[eE][+-]?[0-9]+)?\Z"     # decimal, no underscores


def _plain_toml(text: str) -> dict | None:
    """tomllib.loads(text) for the plain TOML of the bundled profiles, read without tomllib
    (its import and parse cost ~10 M instructions more a run): comment lines, [table]
    headers, `key = value` with a bare key and a value that is a string without escapes, a
    decimal number or an array of such strings one to a line; a comment after any of
    them.  None for any other text (a repeated key or table, a dotted or quoted key, an
    escape, true, a date, an inline table or array, CR ...): tomllib reads it then."""
    if "\r" in text:
        return None
    root: dict = {}
    table = root
    lines = iter(text.split("\n"))
    for line in lines:
        s = line.lstrip(" \t")
        if not s or s[0] == "#":
            if not _plain_end(s):
                return None
        elif s[0] == "[":
            name, close, rest = s[1:].partition("]")
            name = name.strip(" \t")
            if not (close and name and _BARE.issuperset(name)) or name in root or not _plain_end(rest):
                return None
            table = root[name] = {}
        else:
            key, eq, v = s.partition("=")
            key, v = key.rstrip(" \t"), v.lstrip(" \t")
            if not (eq and key and _BARE.issuperset(key)) or key in table:
                return None
            if v[:1] == "[":
                value = _plain_strings(v[1:], lines)
            elif v[:1] == '"':
                value, rest = _plain_string(v)
                value = value if _plain_end(rest) else None
            else:
                num = v.partition("#")[0].rstrip(" \t")
                ok = re.match(_NUMBER, num) and _plain_end(v[len(num):])
                value = None if not ok else float(num) if any(c in num for c in ".eE") else int(num)
            if value is None:
                return None
            table[key] = value
    return root


def _plain_end(rest):
    """rest, what follows a value or header, is blanks and at most a comment."""
    rest = rest.lstrip(" \t")
    return not rest or rest[0] == "#" and _CTRL.isdisjoint(rest.replace("\t", ""))


def _plain_string(v):
    """(the string v starts with, the rest of v) for a string without escapes, else (None, '')."""
    end = v.find('"', 1)
    s = v[1:end]
    if v[:1] != '"' or end < 0 or "\\" in s or not _CTRL.isdisjoint(s):
        return None, ""
    return s, v[end + 1:]


def _plain_strings(rest, lines):
    """The array of strings, one to a line, that opens before rest: read from lines to its
    closing bracket; None if it is not that."""
    if not _plain_end(rest):
        return None
    items = []
    comma = True                             # (a comma between two strings, as TOML wants)
    for line in lines:
        s = line.lstrip(" \t")
        if s[:1] == "]":
            return items if _plain_end(s[1:]) else None
        value, rest = _plain_string(s) if comma else (None, "")
        if value is None:
            return None
        rest = rest.lstrip(" \t")
        comma = rest[:1] == ","
        if not _plain_end(rest[1:] if comma else rest):
            return None
        items.append(value)
    return None


def _parse(text: str, where: str) -> dict:
    try:  # Python 3.11+
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover - 3.10
        import tomli as tomllib
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        msg = str(e)
        line = ""
        m = re.search(r"\(at line (\d+), column \d+\)", msg)
        if m:
            line = ":" + m.group(1)
            msg = msg[:m.start()].strip()
        raise ProfileError(f"{where}{line}: not valid TOML: {msg}") from None


def load_profile(name_or_path: str) -> Profile:
    """A bundled profile by name ('prusa-mk3s') or a TOML file by path."""
    if name_or_path.endswith(".toml") or os.sep in name_or_path or (os.altsep and os.altsep in name_or_path):
        where = name_or_path
        if os.path.isdir(name_or_path):
            raise ProfileError(f"{where}: is a directory, not a profile file")
        try:
            with open(name_or_path, "rb") as fh:
                raw = fh.read()
        except FileNotFoundError:
            raise ProfileError(f"{where}: no such profile file; bundled profiles: "
                               f"{', '.join(profile_names()) or 'none'}") from None
        except OSError as e:
            raise ProfileError(f"{where}: cannot read: {e.strerror or e}") from None
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError:
            raise ProfileError(f"{where}: not a text (UTF-8) file") from None
        base = os.path.basename(name_or_path)
        return profile_from_dict(_parse(text, where), base[:-5] if base.endswith(".toml") else base, where)
    d = _bundled_dir()
    if d is not None:
        p = os.path.join(d, f"{name_or_path}.toml")
        if os.path.isfile(p):
            where = p
            with open(p, encoding="utf-8") as fh:
                text = fh.read()
            data = _plain_toml(text)
            return profile_from_dict(_parse(text, where) if data is None else data, name_or_path, where)
    raise ProfileError(f"no profile named {name_or_path!r}; bundled: {', '.join(profile_names()) or 'none'}"
                       " (or give a path to a .toml file)")
