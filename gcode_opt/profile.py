"""Printer profiles: the machine's limits, its firmware and its moving mass.

Profiles are TOML files in the repository's `profiles/` folder (installed as the
package `gcode_opt.profiles`).  `load_profile("prusa-mk3s")` finds a bundled one by
name; a path to a .toml file works too.  Every field has a unit in its name."""
from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, field
from importlib import resources

try:  # Python 3.11+
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - 3.10
    import tomli as tomllib

FLAVOURS = ("klipper", "marlin2", "marlin-legacy", "rrf")
JUNCTION_MODELS = ("scv", "jd", "jerk")


@dataclass(frozen=True)
class Profile:
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
    # machine
    moving_mass_x_kg: float = 0.5       # mass the X motor accelerates
    moving_mass_y_kg: float = 0.5       # mass the Y motor accelerates (the bed on a bed-slinger)
    filament_diameter_d: float = 1.75
    max_volumetric_flow: float = 15.0   # mm^3/s, hotend melt limit
    fw_retract_length_d: float = 0.8    # mm, G10/G11 firmware retraction
    fw_retract_speed_v: float = 35.0    # mm/s
    sources: tuple[str, ...] = field(default_factory=tuple)   # where the numbers come from

    def moving_mass_kg(self, ux: float, uy: float) -> tuple[float, float]:
        """(m_eff, m2_eff) for motion along the unit direction (ux, uy): the kinetic term
        weighs sum m_i u_i^2, the inertia-force term sum m_i^2 u_i^2 (each axis pushes
        its own mass)."""
        mx, my = self.moving_mass_x_kg, self.moving_mass_y_kg
        return mx * ux * ux + my * uy * uy, mx * mx * ux * ux + my * my * uy * uy


def _bundled_dir():
    """profiles/ of the repository, installed as package data `gcode_opt.profiles`."""
    try:
        d = resources.files("gcode_opt.profiles")
        if d.is_dir():
            return d
    except (ModuleNotFoundError, TypeError):
        pass
    from pathlib import Path                 # running from a source checkout
    d = Path(__file__).resolve().parent.parent / "profiles"
    return d if d.is_dir() else None


def profile_names() -> list[str]:
    d = _bundled_dir()
    if d is None:
        return []
    return sorted(p.name[:-5] for p in d.iterdir() if p.name.endswith(".toml"))


def profile_from_dict(data: dict, name: str) -> Profile:
    known = {f.name for f in dataclasses.fields(Profile)}
    flat: dict = {}
    for k, v in data.items():
        if isinstance(v, dict):          # [firmware], [limits], [machine] tables are flattened
            flat.update(v)
        else:
            flat[k] = v
    flat.setdefault("name", name)
    unknown = sorted(set(flat) - known)
    if unknown:
        raise ValueError(f"profile {name}: unknown key(s) {', '.join(unknown)}; "
                         f"known: {', '.join(sorted(known))}")
    if "sources" in flat:
        flat["sources"] = tuple(flat["sources"])
    prof = Profile(**flat)
    if prof.flavour not in FLAVOURS:
        raise ValueError(f"profile {name}: flavour {prof.flavour!r} not one of {FLAVOURS}")
    if prof.junction not in JUNCTION_MODELS:
        raise ValueError(f"profile {name}: junction {prof.junction!r} not one of {JUNCTION_MODELS}")
    return prof


def load_profile(name_or_path: str) -> Profile:
    """A bundled profile by name ('prusa-mk3s') or a TOML file by path."""
    if name_or_path.endswith(".toml") or os.sep in name_or_path:
        with open(name_or_path, "rb") as fh:
            data = tomllib.load(fh)
        return profile_from_dict(data, os.path.basename(name_or_path)[:-5])
    d = _bundled_dir()
    if d is not None:
        p = d / f"{name_or_path}.toml"
        if p.is_file():
            return profile_from_dict(tomllib.loads(p.read_text()), name_or_path)
    raise ValueError(f"no profile named {name_or_path!r}; bundled: {', '.join(profile_names()) or 'none'}"
                     " (or give a path to a .toml file)")
