"""Issue 11, done means: `--profile auto` on each sample names its machine and takes its limits
from the file where the file has them; the figures equal those of a hand-written profile with
the same limits.

The numbers below are read by hand from each sample's closing config block (PrusaSlicer 2.5:
`; machine_max_acceleration_x = 1000,960` ...: normal mode, the first value); the rest of each
hand-written profile is the bundled profile's TOML, read here with tomllib."""
import json
import os
import subprocess
import sys

import pytest

try:
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - 3.10
    import tomli as tomllib

from gcode_opt.detect import auto_profile

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
SAMPLES = os.path.join(ROOT, "sample_gcode")

# by hand from the files' config blocks
MK3S_FILE = {"flavour": "marlin-legacy", "junction": "jerk", "max_accel_a": 1000.0, "max_velocity_v": 200.0,
             "jerk_xy_v": 8.0, "default_accel_a": 1250.0, "retract_accel_a": 1250.0,
             "travel_accel_a": 1250.0,      # legacy Marlin: travel at M204 S (= extruding), not the file's 1500
             "max_z_velocity_v": 12.0, "max_z_accel_a": 200.0, "max_e_velocity_v": 120.0,
             "filament_diameter_d": 1.75, "max_volumetric_flow": 15.0}
KLIPPER_FILE = {"flavour": "klipper", "junction": "scv", "max_accel_a": 9000.0, "max_velocity_v": 500.0,
                "default_accel_a": 9000.0, "retract_accel_a": 9000.0, "travel_accel_a": 9000.0,
                "max_z_velocity_v": 10.0, "max_z_accel_a": 100.0, "max_e_velocity_v": 60.0,
                "filament_diameter_d": 1.75, "max_volumetric_flow": 15.0}
EXPECT = {
    "prusa_mk3s_rectilinear.gcode": ("prusa-mk3s", MK3S_FILE),
    "prusa_gyroid.gcode": ("prusa-mk3s", MK3S_FILE),
    "prusa_absolute_e.gcode": ("prusa-mk3s", MK3S_FILE),
    "prusa_concentric.gcode": ("prusa-mk3s", MK3S_FILE),
    "prusa_concentric_arcs.gcode": ("prusa-mk3s", MK3S_FILE),
    "prusa_gyroid_arcs.gcode": ("prusa-mk3s", MK3S_FILE),
    "prusa_klipper.gcode": ("generic-klipper", KLIPPER_FILE),     # printer_notes: "Klipper-based printer"
    "cura_box.gcode": ("ender3", {}),                              # CuraEngine CLI writes no limits
}


def test_every_sample_is_covered():
    assert sorted(EXPECT) == sorted(f for f in os.listdir(SAMPLES) if f.endswith(".gcode"))


@pytest.mark.parametrize("name", sorted(EXPECT))
def test_auto_names_the_machine_and_takes_the_files_limits(name):
    base, limits = EXPECT[name]
    a = auto_profile(os.path.join(SAMPLES, name), environ={})
    assert a.base == base
    for k, v in limits.items():
        assert getattr(a.profile, k) == v, k
        if k != "junction":
            assert k in a.taken, k                  # and says it came from the file
    bundled = _bundled(base)
    for k, v in bundled.items():                    # what the file does not say comes from the base
        if k not in limits and k not in ("name", "sources"):
            assert getattr(a.profile, k) == v, k


def _bundled(name):
    with open(os.path.join(ROOT, "profiles", name + ".toml"), "rb") as fh:
        data = tomllib.load(fh)
    flat = {k: v for k, v in data.items() if not isinstance(v, dict)}
    for t in ("firmware", "limits", "machine"):
        flat.update(data.get(t, {}))
    return flat


def _toml(path, base, limits):
    """A hand-written profile: the bundled base with the file's limits."""
    flat = _bundled(base)
    flat.update(limits)
    with open(os.path.join(ROOT, "profiles", base + ".toml"), "rb") as fh:
        tables = {t: list(v) for t, v in tomllib.load(fh).items() if isinstance(v, dict)}
    out = [f'name = "{base}-by-hand"']
    for t, keys in tables.items():
        out.append(f"[{t}]")
        for k in keys:
            v = flat[k]
            out.append(f'{k} = "{v}"' if isinstance(v, str) else f"{k} = {v!r}")
    path.write_text("\n".join(out) + "\n")
    return str(path)


def _summary(tmp_path, src, profile, tag):
    js = tmp_path / f"{tag}.json"
    env = {k: v for k, v in os.environ.items() if not k.startswith("SLIC3R_")}
    subprocess.run([sys.executable, "-m", "gcode_opt", "process", src, "-o", str(tmp_path / f"{tag}.gcode"),
                    "--profile", profile, "--json", str(js), "-q"], cwd=ROOT, check=True, env=env)
    d = json.loads(js.read_text())
    for k in ("input", "output", "profile", "elapsed_s", "timing_s"):
        d.pop(k, None)
    return d, (tmp_path / f"{tag}.gcode").read_bytes()


def _same_figures(tmp_path, name):
    base, limits = EXPECT[name]
    src = os.path.join(SAMPLES, name)
    auto, out_auto = _summary(tmp_path, src, "auto", "auto")
    hand, out_hand = _summary(tmp_path, src, _toml(tmp_path / "hand.toml", base, limits), "hand")
    assert auto == hand
    assert out_auto == out_hand
    assert auto["strokes"]["retimed"] > 0


def test_auto_equals_hand_written_profile_mk3s(tmp_path):
    """~3 s: two runs on the smallest PrusaSlicer sample."""
    _same_figures(tmp_path, "prusa_absolute_e.gcode")


@pytest.mark.slow
@pytest.mark.parametrize("name", ["prusa_klipper.gcode", "cura_box.gcode"])
def test_auto_equals_hand_written_profile(tmp_path, name):
    _same_figures(tmp_path, name)
