"""Issue 11, done means: `--profile auto` on each sample names its machine and takes its limits
from the file where the file has them; the figures equal those of a hand-written profile with
the same limits.

The numbers below are read by hand from each sample's closing config block (PrusaSlicer 2.5:
`; machine_max_acceleration_x = 1000,960` ...: normal mode, the first value); the rest of each
hand-written profile is the bundled profile's TOML, read here with tomllib."""
import json
import os
import re
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
    "prusa_gyroid_fullspeed.gcode": ("prusa-mk3s", MK3S_FILE),
    "prusa_benchy_like.gcode": ("prusa-mk3s", MK3S_FILE),
    "prusa_gyroid_fullspeed_klipper.gcode": ("generic-klipper", KLIPPER_FILE),
    "prusa_klipper_no_comments.gcode": ("generic-klipper", KLIPPER_FILE),
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
    for t in ("firmware", "limits", "machine", "resonance"):
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


# ---------------------------------------------------------------- PrusaSlicer's calling convention
PP_DIR = "Dünn Ordner's prints"          # a space, a non-ASCII letter and a quote in the path


def _posix_command(script, gcode):
    """The command line PrusaSlicer runs on Linux/macOS (PostProcessor.cpp run_script): the
    post_process line as the user wrote it, then the G-code path in single quotes, each ' as '\\''
    -- handed to `$SHELL -c`."""
    return script + " '" + gcode.replace("'", "'\\''") + "'"


def test_run_as_prusaslicer_gui_does(tmp_path):
    """The GUI copies the G-code to NAME.gcode.pp, sets every setting as SLIC3R_<KEY> plus
    SLIC3R_PP_HOST / SLIC3R_PP_OUTPUT_NAME, and runs the script with the copy's path last.
    Here the copy's settings comments are stripped (the ;TYPE: feature comments stay), so the
    profile can only come from the variables."""
    folder = tmp_path / PP_DIR
    bindir = folder / "bin dir"
    bindir.mkdir(parents=True)
    exe = bindir / "gcode-opt"
    exe.write_text(f"#!/bin/sh\nexec {sys.executable} -m gcode_opt \"$@\"\n")
    exe.chmod(0o755)
    final = folder / "Würfel 20 mm.gcode"
    pp = folder / "Würfel 20 mm.gcode.pp"
    text = open(os.path.join(SAMPLES, "prusa_absolute_e.gcode"), encoding="utf-8").read()
    pp.write_text("".join(ln for ln in text.splitlines(True) if not re.match(r"; [a-z_0-9]+ = ", ln)),
                  encoding="utf-8")
    before = pp.read_bytes()
    env = {k: v for k, v in os.environ.items() if not k.startswith("SLIC3R_")}
    env.update({"SLIC3R_PRINTER_MODEL": "MK3S", "SLIC3R_GCODE_FLAVOR": "marlin",
                "SLIC3R_MACHINE_MAX_ACCELERATION_X": "1000,960", "SLIC3R_MACHINE_MAX_ACCELERATION_Y": "1000,960",
                "SLIC3R_MACHINE_MAX_FEEDRATE_X": "200,100", "SLIC3R_MACHINE_MAX_FEEDRATE_Y": "200,100",
                "SLIC3R_PP_HOST": "File", "SLIC3R_PP_OUTPUT_NAME": str(final), "PYTHONPATH": ROOT})
    script = "'" + str(exe).replace("'", "'\\''") + "' process --profile auto"   # the user quotes the program
    proc = subprocess.run(["/bin/sh", "-c", _posix_command(script, str(pp))], env=env, cwd=str(tmp_path),
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.startswith("gcode-opt: profile prusa-mk3s + file (printer_model = MK3S (SLIC3R_PRINTER_MODEL)")
    assert "max_accel_a 1000 (SLIC3R_MACHINE_MAX_ACCELERATION_" in proc.stderr
    after = pp.read_bytes()
    assert after != before and b"; gcode-opt begin:" in after       # changed in place, under the .pp name
    assert sorted(p.name for p in folder.iterdir()) == ["Würfel 20 mm.gcode.pp", "bin dir"]   # no stray files


@pytest.mark.slow
def test_real_prusaslicer_runs_gcode_opt(tmp_path):
    """PrusaSlicer itself (the CLI: same run_script and variables, no .pp copy) slices a cube
    into a folder with spaces and non-ASCII letters and runs gcode-opt as its post-processor."""
    import shutil
    ps = shutil.which("prusa-slicer")
    if not ps:
        pytest.skip("prusa-slicer not installed")
    folder = tmp_path / PP_DIR
    bindir = folder / "bin dir"
    bindir.mkdir(parents=True)
    exe = bindir / "gcode-opt"
    exe.write_text(f"#!/bin/sh\nenv | grep '^SLIC3R_PP_OUTPUT_NAME=' > \"$(dirname \"$0\")/env.txt\"\n"
                   f"exec {sys.executable} -m gcode_opt \"$@\"\n")
    exe.chmod(0o755)
    stl = tmp_path / "cube.stl"
    quads = [((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)), ((0, 0, 1), (0, 1, 1), (1, 1, 1), (1, 0, 1)),
             ((0, 0, 0), (0, 0, 1), (1, 0, 1), (1, 0, 0)), ((1, 0, 0), (1, 0, 1), (1, 1, 1), (1, 1, 0)),
             ((1, 1, 0), (1, 1, 1), (0, 1, 1), (0, 1, 0)), ((0, 1, 0), (0, 1, 1), (0, 0, 1), (0, 0, 0))]
    facets = []
    for q in quads:
        for tri in ((q[0], q[1], q[2]), (q[0], q[2], q[3])):
            facets.append(" facet normal 0 0 0\n  outer loop\n" + "".join(
                f"   vertex {x * 20} {y * 20} {z * 4}\n" for x, y, z in tri) + "  endloop\n endfacet\n")
    stl.write_text("solid c\n" + "".join(facets) + "endsolid c\n")
    ini = tmp_path / "pp.ini"
    ini.write_text("post_process = '" + str(exe).replace("'", "'\\''") + "' process --profile auto\n",
                   encoding="utf-8")
    out = folder / "Würfel 20 mm.gcode"
    env = {k: v for k, v in os.environ.items() if not k.startswith("SLIC3R_")}
    env["PYTHONPATH"] = ROOT
    proc = subprocess.run([ps, "--load", os.path.join(SAMPLES, "prusa_mk3s.ini"), "--load", str(ini),
                           "--export-gcode", "--output", str(out), str(stl)], env=env, capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    body = out.read_text(encoding="utf-8")
    assert "; gcode-opt begin:" in body and "; printer_model = MK3S" in body
    assert (bindir / "env.txt").read_text(encoding="utf-8").strip() == f"SLIC3R_PP_OUTPUT_NAME={out}"
