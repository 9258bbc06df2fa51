"""`--profile auto`: the machine's limits from what the slicer wrote, the rest from the closest
bundled profile.

The slicer knows the printer's limits (slicer_config.read_settings: the closing config block,
Cura's header and settings, SLIC3R_* variables).  Those it does not know -- moving mass,
segment rate, planner buffer, cornering parameter, arc chord -- come from a bundled profile,
chosen by printer model, else by flavour.  Every value says where it came from."""
from __future__ import annotations

import re

from .profile import SCHEMA, Profile, load_profile, profile_from_dict
from .records import field_names, record
from .slicer_config import SlicerSettings, read_settings

# model substrings (lower case) -> bundled profile; longer, more specific names first
_MODELS = (("mk3.5", "prusa-mk4"), ("mk3.9", "prusa-mk4"), ("mk3s", "prusa-mk3s"), ("mk3", "prusa-mk3s"),
           ("mk4", "prusa-mk4"), ("x1 carbon", "bambu-x1c"), ("x1c", "bambu-x1c"), ("voron", "voron24"),
           ("ender-3", "ender3"), ("ender3", "ender3"), ("ender 3", "ender3"))
_GENERIC = {"klipper": "generic-klipper", "marlin2": "generic-marlin", "marlin-legacy": "generic-marlin",
            "rrf": "generic-marlin"}

# PrusaSlicer/Orca gcode_flavor -> our flavour, and why
_SLIC3R_FLAVOURS = {
    "marlin": ("marlin-legacy", "PrusaSlicer's marlin = legacy Marlin, M204 S/T"),
    "marlin2": ("marlin2", "Marlin 2: M204 P/R/T"),
    "klipper": ("klipper", "Klipper"),
    "reprap": ("rrf", "RepRapFirmware"),
    "reprapfirmware": ("rrf", "RepRapFirmware"),
}
# the cornering model a firmware uses when the bundled profile's is of another firmware
_JUNCTION = {"klipper": "scv", "marlin-legacy": "jerk", "marlin2": "jd", "rrf": "jerk"}


def _model_profile(text):
    t = text.lower()
    for key, name in _MODELS:
        if key in t:
            return name
    return None


def _flavour(st: SlicerSettings):
    """(our flavour or None, why).  printer_notes naming Klipper win over a marlin gcode_flavor:
    PrusaSlicer < 2.6 had no klipper flavour, so Klipper users pick marlin2 and say so in the notes."""
    notes = st.get("printer_notes") or ""
    if re.search(r"klipper", notes, re.I):
        return "klipper", "printer_notes mention Klipper" + ("" if st.where.get("printer_notes") == "file"
                                                             else f" ({st.where['printer_notes']})")
    fl = (st.get("gcode_flavor") or "").strip().lower()
    if fl:
        if fl in _SLIC3R_FLAVOURS:
            ours, why = _SLIC3R_FLAVOURS[fl]
            return ours, f"gcode_flavor = {fl}: {why}"
        return None, f"gcode_flavor = {fl} is not a firmware gcode-opt models"
    cura = (st.get("cura_flavor") or "").strip()
    if cura:
        c = cura.lower()
        if c.startswith("reprap"):
            return "rrf", f";FLAVOR:{cura} (Cura): RepRapFirmware"
        if c.startswith("marlin") or c in ("griffin", "ultigcode"):
            return "marlin", f";FLAVOR:{cura} (Cura): Marlin, 1.x or 2.x not said"
        return None, f";FLAVOR:{cura} (Cura) is not a firmware gcode-opt models"
    return None, "the file names no G-code flavour"


def choose_base(st: SlicerSettings) -> tuple[str, str]:
    """(bundled profile name, why): by printer model, else by flavour, else generic-klipper."""
    for key in ("printer_model", "printer_settings_id"):
        val = (st.get(key) or "").strip()
        if val:
            name = _model_profile(val)
            if name:
                return name, f"{key} = {val}" + ("" if st.where.get(key) == "file" else f" ({st.where[key]})")
    notes = st.get("printer_notes") or ""
    m = re.search(r"PRINTER_MODEL_(\w+)", notes)
    if m and _model_profile(m.group(1)):
        return _model_profile(m.group(1)), f"printer_notes: PRINTER_MODEL_{m.group(1)}"
    definition = st.get("definition") or ""          # Cura: [general] definition = creality_ender3
    if definition and _model_profile(definition):
        return _model_profile(definition), f"Cura definition {definition}"
    if st.slicer == "cura":                            # Cura's start G-code names the machine it was made for
        for line in st.head.splitlines():
            if line.lstrip().startswith(";") and _model_profile(line):
                return _model_profile(line), f"Cura start G-code '{line.strip()}'"
    ours, why = _flavour(st)
    if ours == "marlin":
        return "generic-marlin", why
    if ours:
        return _GENERIC[ours], why
    return "generic-klipper", "nothing in the file names the printer"


def detect_profile(path: str) -> tuple[str, str]:
    """(bundled profile name, why) for the file alone (no environment)."""
    return choose_base(read_settings(path, environ={}))


# ------------------------------------------------------------------ limits from the slicer
def _pair_min(st, kx, ky):
    """min of the X and Y values (a per-axis cap binds on the weaker axis), with its source."""
    vals = [(st.number(k), k) for k in (kx, ky) if st.number(k) is not None and st.number(k) > 0]
    if not vals:
        return None
    v = min(x for x, _ in vals)
    keys = [k for _, k in vals]
    src = keys[0] if len(keys) == 1 else f"{kx[:-2]}_x/y"
    return v, _label(st, keys[0], src)


def _one(st, *keys):
    for k in keys:
        v = st.number(k)
        if v is not None and v > 0:
            return v, _label(st, k, k)
    return None


def _label(st, key, text):
    w = st.where.get(key, "file")
    return text if w == "file" else w if w.startswith("SLIC3R_") else f"{text}, {w}"


def slicer_limits(st: SlicerSettings, flavour: str) -> dict:
    """profile key -> (value, source) for what the slicer states.  A value <= 0 means 'not set'
    in these slicers and is skipped; machine_limits_usage = ignore means the limits are not the
    machine's, so none are taken."""
    out = {}
    usage = (st.get("machine_limits_usage") or "").strip()
    if usage != "ignore":
        for key, got in (("max_accel_a", _pair_min(st, "machine_max_acceleration_x", "machine_max_acceleration_y")),
                         ("max_velocity_v", _pair_min(st, "machine_max_feedrate_x", "machine_max_feedrate_y")
                          or _pair_min(st, "machine_max_speed_x", "machine_max_speed_y")),   # Orca/Bambu name
                         ("jerk_xy_v", _pair_min(st, "machine_max_jerk_x", "machine_max_jerk_y")
                          or _one(st, "machine_max_jerk_xy")),
                         ("default_accel_a", _one(st, "machine_max_acceleration_extruding", "machine_acceleration")),
                         ("retract_accel_a", _one(st, "machine_max_acceleration_retracting")),
                         ("travel_accel_a", _one(st, "machine_max_acceleration_travel")),
                         ("max_z_velocity_v", _one(st, "machine_max_feedrate_z", "machine_max_speed_z")),
                         ("max_z_accel_a", _one(st, "machine_max_acceleration_z")),
                         ("max_e_velocity_v", _one(st, "machine_max_feedrate_e", "machine_max_speed_e"))):
            if got:
                out[key] = got
        if flavour == "marlin-legacy" and "default_accel_a" in out:
            # legacy Marlin has no travel acceleration: M204 S sets printing and travel alike
            v, src = out["default_accel_a"]
            out["travel_accel_a"] = (v, src + "; legacy Marlin travels at M204 S")
    for key, got in (("filament_diameter_d", _one(st, "filament_diameter", "material_diameter")),
                     ("max_volumetric_flow", _one(st, "filament_max_volumetric_speed"))):
        if got:
            out[key] = got
    fw = (st.get("use_firmware_retraction") or st.get("machine_firmware_retract") or "").strip().lower()
    if fw in ("1", "true"):
        for key, ks in (("fw_retract_length_d", ("retract_length", "retraction_length")),   # Prusa, Orca/Bambu
                        ("fw_retract_speed_v", ("retract_speed", "retraction_speed"))):
            got = _one(st, *ks)
            if got:
                out[key] = (got[0], got[1] + " with firmware retraction")
    return out


def _as_tables(values: dict) -> dict:
    data: dict = {}
    for k, v in values.items():
        table = SCHEMA[k][0]
        (data.setdefault(table, {}) if table else data)[k] = list(v) if isinstance(v, tuple) else v
    return data


@record
class AutoProfile:
    """The profile 'auto' chose for a file: the base profile and the values taken from the file."""
    profile: Profile
    base: str
    why_base: str
    taken: dict          # profile key -> (value, source)
    notes: list          # other remarks (flavour, limits usage)

    def describe(self) -> str:
        """One compact block for stderr: the choice on the first line, then each value and its source."""
        items = [f"{k} {_fmt(v)} ({src})" for k, (v, src) in self.taken.items()] or ["the file states no limits"]
        items.append(f"the rest (moving mass, segment rate, buffer, cornering) from {self.base}")
        body = [""]
        for it in items:                          # whole items per line: a value never parts from its source
            if body[-1] and len(body[-1]) + len(it) > 108:
                body.append("")
            body[-1] += ("; " if body[-1] else "") + it
        body = ["  " + b for b in body]
        return "\n".join([f"gcode-opt: profile {self.base} + file ({self.why_base}; choose another with "
                          "--profile):"] + body + [f"  {n}" for n in self.notes])


def _fmt(v):
    return f"{v:g}" if isinstance(v, float) else str(v)


def auto_profile(path: str, environ=None, metadata=None) -> AutoProfile:
    """environ: the SLIC3R_* variables (default os.environ); metadata: the file's settings read
    elsewhere (a .bgcode's slicer-metadata block), see slicer_config.read_settings."""
    st = read_settings(path, environ, metadata)
    base_name, why = choose_base(st)
    base = load_profile(base_name)
    ours, fwhy = _flavour(st)
    notes = []
    taken: dict = {}
    flavour = base.flavour
    if ours == "marlin":            # Cura's Marlin: keep a Marlin base's own generation
        if base.flavour not in ("marlin2", "marlin-legacy"):
            flavour = "marlin2"
            taken["flavour"] = ("marlin2", fwhy)
        else:
            notes.append(f"{fwhy}: {base.name}'s {base.flavour} kept")
    elif ours:
        flavour = ours
        taken["flavour"] = (ours, fwhy)
    else:
        notes.append(f"{fwhy}: {base.name}'s {base.flavour} kept")
    junction = base.junction
    if flavour != base.flavour:
        junction = _JUNCTION[flavour]
        taken["junction"] = (junction, f"{flavour}'s cornering model; {base.name} is {base.flavour}")
    usage = (st.get("machine_limits_usage") or "").strip()
    if usage == "ignore":
        notes.append("machine_limits_usage = ignore: the slicer's machine limits are not the printer's; none taken")
    elif usage == "time_estimate_only":
        notes.append("machine_limits_usage = time_estimate_only: the slicer does not send these limits to the "
                     "printer; check they match its firmware")
    taken.update(slicer_limits(st, flavour))
    if junction != "jerk":                   # classic jerk is not this firmware's cornering model
        taken.pop("jerk_xy_v", None)
    values = {n: getattr(base, n) for n in field_names(Profile)}
    values.update({k: v for k, (v, _src) in taken.items()})
    values["junction"] = junction
    name = f"{base.name}+file"
    values["name"] = name
    values["sources"] = tuple(f"{k} = {_fmt(v)} from {src}" for k, (v, src) in taken.items()) \
        + tuple(f"{base.name}: {s}" for s in base.sources)
    prof = profile_from_dict(_as_tables(values), name, where=f"--profile auto ({path})")
    return AutoProfile(prof, base.name, why, taken, notes)


# keys compared with a named profile; a difference is worth a warning
_COMPARED = ("flavour", "max_accel_a", "max_velocity_v", "jerk_xy_v", "default_accel_a", "retract_accel_a",
             "travel_accel_a", "max_z_velocity_v", "max_z_accel_a", "max_e_velocity_v", "filament_diameter_d",
             "max_volumetric_flow")


def conflicts(prof: Profile, path: str, environ=None, metadata=None) -> list[str]:
    """One line per limit where the file's slicer settings differ from a profile the user named."""
    st = read_settings(path, environ, metadata)
    ours, why = _flavour(st)
    stated = slicer_limits(st, ours if ours and ours != "marlin" else prof.flavour)
    if ours and ours != "marlin":
        stated = {"flavour": (ours, why), **stated}
    out = []
    for k in _COMPARED:
        if k not in stated or (k == "jerk_xy_v" and prof.junction != "jerk"):
            continue
        v, src = stated[k]
        mine = getattr(prof, k)
        same = v == mine if isinstance(v, str) else abs(v - mine) <= 1e-9 * max(1.0, abs(mine))
        if not same:
            out.append(f"gcode-opt: warning: the file says {k} {_fmt(v)} ({src}); profile {prof.name} has "
                       f"{_fmt(mine)}; using the profile's")
    return out
