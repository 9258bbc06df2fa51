"""--profile auto: reading the slicer's settings (file, Cura header and ;SETTING_3, SLIC3R_*)
and building the profile from them.  Small synthetic files; the expected values are the ones
written into them."""
import json
import os
import re
import subprocess
import sys

import pytest

from gcode_opt.detect import auto_profile, choose_base, conflicts, detect_profile
from gcode_opt.profile import load_profile
from gcode_opt.slicer_config import read_settings

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
SAMPLES = os.path.join(ROOT, "sample_gcode")
MOVES = "G90\nM83\nG1 X10 Y10 F3000\nG1 X20 Y10 E1 F1800\n"


def _file(tmp_path, text, name="f.gcode"):
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def _block(**kv):
    """A PrusaSlicer-style closing config block."""
    return "; prusaslicer_config = begin\n" + "".join(f"; {k} = {v}\n" for k, v in kv.items()) \
        + "; prusaslicer_config = end\n"


def test_normal_mode_value_is_taken_before_silent(tmp_path):
    f = _file(tmp_path, MOVES + _block(machine_max_acceleration_x="1000,960", machine_max_acceleration_y="800,700",
                                       machine_max_feedrate_x="200,100", machine_max_feedrate_y="200,100",
                                       gcode_flavor="marlin2"))
    a = auto_profile(f, environ={})
    assert a.profile.max_accel_a == 800.0            # the weaker axis, normal mode
    assert a.profile.max_velocity_v == 200.0
    assert a.taken["max_accel_a"][1] == "machine_max_acceleration_x/y"


@pytest.mark.parametrize("slicer_flavor,ours,junction", [
    ("marlin", "marlin-legacy", "jerk"), ("marlin2", "marlin2", "jd"), ("klipper", "klipper", "scv"),
    ("reprap", "rrf", "jerk"), ("reprapfirmware", "rrf", "jerk"),
])
def test_gcode_flavor_mapping(tmp_path, slicer_flavor, ours, junction):
    f = _file(tmp_path, MOVES + _block(gcode_flavor=slicer_flavor))
    a = auto_profile(f, environ={})
    assert a.profile.flavour == ours
    assert a.profile.junction == junction            # the generic profile of that firmware, or its own model
    assert a.taken["flavour"][0] == ours and slicer_flavor in a.taken["flavour"][1]


def test_unknown_flavour_keeps_the_base_and_says_so(tmp_path):
    f = _file(tmp_path, MOVES + _block(gcode_flavor="sailfish"))
    a = auto_profile(f, environ={})
    assert a.profile.flavour == "klipper" and "flavour" not in a.taken
    assert any("sailfish" in n for n in a.notes)


def test_stripped_file_with_slic3r_variables(tmp_path):
    """The issue's reproducer: comments stripped, SLIC3R_PRINTER_MODEL=MK3S set -> not generic-klipper."""
    f = _file(tmp_path, MOVES)
    env = {"SLIC3R_PRINTER_MODEL": "MK3S", "SLIC3R_GCODE_FLAVOR": "marlin",
           "SLIC3R_MACHINE_MAX_ACCELERATION_X": "900,960", "SLIC3R_MACHINE_MAX_ACCELERATION_Y": "900,960",
           "SLIC3R_PP_OUTPUT_NAME": "/tmp/x.gcode", "PATH": "/bin"}
    a = auto_profile(f, environ=env)
    assert a.base == "prusa-mk3s" and "SLIC3R_PRINTER_MODEL" in a.why_base
    assert a.profile.flavour == "marlin-legacy" and a.profile.max_accel_a == 900.0
    assert a.taken["max_accel_a"][1].startswith("SLIC3R_MACHINE_MAX_ACCELERATION_")
    assert "pp_output_name" not in read_settings(f, env).values      # the script's own variables, not settings


def test_file_wins_over_environment(tmp_path):
    f = _file(tmp_path, MOVES + _block(printer_model="MK4", machine_max_acceleration_x=4000,
                                       machine_max_acceleration_y=4000, gcode_flavor="marlin2"))
    a = auto_profile(f, environ={"SLIC3R_PRINTER_MODEL": "MK3S", "SLIC3R_MACHINE_MAX_ACCELERATION_X": "1000"})
    assert a.base == "prusa-mk4" and a.profile.max_accel_a == 4000.0


def test_limits_usage_ignore_takes_no_limits(tmp_path):
    f = _file(tmp_path, MOVES + _block(machine_limits_usage="ignore", machine_max_acceleration_x=50,
                                       machine_max_acceleration_y=50, gcode_flavor="klipper"))
    a = auto_profile(f, environ={})
    assert a.profile.max_accel_a == load_profile("generic-klipper").max_accel_a
    assert any("ignore" in n for n in a.notes)


def test_zero_means_not_set(tmp_path):
    f = _file(tmp_path, MOVES + _block(printer_model="MK4IS", machine_max_acceleration_travel=0,
                                       filament_max_volumetric_speed=0, gcode_flavor="marlin2"))
    a = auto_profile(f, environ={})
    mk4 = load_profile("prusa-mk4")
    assert a.profile.travel_accel_a == mk4.travel_accel_a
    assert a.profile.max_volumetric_flow == mk4.max_volumetric_flow


def test_firmware_retraction_only_when_used(tmp_path):
    on = _file(tmp_path, MOVES + _block(use_firmware_retraction=1, retract_length=1.5, retract_speed=30,
                                        gcode_flavor="klipper"), "on.gcode")
    off = _file(tmp_path, MOVES + _block(use_firmware_retraction=0, retract_length=1.5, retract_speed=30,
                                         gcode_flavor="klipper"), "off.gcode")
    a, b = auto_profile(on, environ={}), auto_profile(off, environ={})
    assert (a.profile.fw_retract_length_d, a.profile.fw_retract_speed_v) == (1.5, 30.0)
    base = load_profile("generic-klipper")
    assert (b.profile.fw_retract_length_d, b.profile.fw_retract_speed_v) == (base.fw_retract_length_d,
                                                                             base.fw_retract_speed_v)


def _cura_setting_lines(data):
    """;SETTING_3 lines as Cura's GCodeWriter._serialiseSettings writes them: the JSON with '\\',
    newline and CR escaped, cut into lines of 80 characters including the prefix."""
    prefix = ";SETTING_3 "
    s = json.dumps(data)
    s = re.sub(r"\\|\n|\r", lambda m: {"\\": "\\\\", "\n": "\\n", "\r": "\\r"}[m.group(0)], s)
    step = 80 - len(prefix)
    return "".join(prefix + s[i:i + step] + "\n" for i in range(0, len(s), step))


def test_cura_settings_block(tmp_path):
    glob = ("[general]\nversion = 4\nname = Fine #2\ndefinition = creality_ender3\n\n[metadata]\n"
            "type = quality_changes\nsetting_version = 19\n\n[values]\nmachine_max_acceleration_x = 700\n"
            "machine_max_acceleration_y = 650\nmachine_max_feedrate_x = 250\nmachine_max_feedrate_y = 250\n")
    ext = "[general]\nversion = 4\n\n[values]\nmaterial_diameter = 2.85\n"
    text = ";FLAVOR:Marlin\n;Generated with Cura_SteamEngine 5.2.1\n" + MOVES + ";End of Gcode\n" \
        + _cura_setting_lines({"global_quality": glob, "extruder_quality": [ext]})
    f = _file(tmp_path, text)
    st = read_settings(f, environ={})
    assert st.values["machine_max_acceleration_x"] == "700"
    assert st.where["machine_max_acceleration_x"] == "Cura ;SETTING_3"
    a = auto_profile(f, environ={})
    assert a.base == "ender3" and "creality_ender3" in a.why_base
    assert (a.profile.max_accel_a, a.profile.max_velocity_v, a.profile.filament_diameter_d) == (650.0, 250.0, 2.85)
    assert a.profile.flavour == "marlin2"             # Cura's "Marlin" does not say 1.x or 2.x: the base's kept


def test_cura_start_gcode_names_the_machine():
    """The issue: a Cura Ender 3 file got generic-marlin."""
    name, why = detect_profile(os.path.join(SAMPLES, "cura_box.gcode"))
    assert name == "ender3" and "Ender 3" in why


def test_cura_flavor_alone_gives_generic_marlin(tmp_path):
    f = _file(tmp_path, ";FLAVOR:Marlin\n;Generated with Cura_SteamEngine 4.13.0\n" + MOVES)
    assert detect_profile(f)[0] == "generic-marlin"


def test_prusa_model_names():
    from gcode_opt.slicer_config import SlicerSettings
    for model, want in (("MK3S", "prusa-mk3s"), ("MK3.5", "prusa-mk4"), ("MK4IS", "prusa-mk4"),
                        ("Bambu Lab X1 Carbon", "bambu-x1c"), ("Ender-3 V2", "ender3")):
        st = SlicerSettings(values={"printer_model": model}, where={"printer_model": "file"})
        assert choose_base(st)[0] == want, model


def test_named_profile_conflicts_one_line_each():
    f = os.path.join(SAMPLES, "prusa_mk3s_rectilinear.gcode")
    assert conflicts(load_profile("prusa-mk3s"), f, environ={}) == []
    lines = conflicts(load_profile("prusa-mk4"), f, environ={})
    acc = [x for x in lines if " max_accel_a " in x]
    assert len(acc) == 1 and "1000" in acc[0] and "4000" in acc[0]
    assert all(x.startswith("gcode-opt: warning: ") and "\n" not in x for x in lines)


def test_cli_prints_sources_and_quiet_suppresses(tmp_path):
    src = os.path.join(SAMPLES, "prusa_absolute_e.gcode")
    env = {k: v for k, v in os.environ.items() if not k.startswith("SLIC3R_")}
    run = lambda *extra: subprocess.run([sys.executable, "-m", "gcode_opt", "simulate", src, *extra],  # noqa: E731
                                        cwd=ROOT, capture_output=True, text=True, env=env)
    loud = run()
    assert loud.returncode == 0, loud.stderr
    assert loud.stderr.startswith("gcode-opt: profile prusa-mk3s + file (printer_model = MK3S")
    assert "max_accel_a 1000 (machine_max_acceleration_x/y)" in loud.stderr
    quiet = run("--json")                             # simulate's quiet switch
    assert "gcode-opt: profile" not in quiet.stderr
    named = run("--profile", "prusa-mk4", "--json")
    assert "warning: the file says max_accel_a 1000" in named.stderr


def test_orca_bambu_key_names(tmp_path):
    """OrcaSlicer/Bambu Studio name the feedrate limits machine_max_speed_* and the retraction
    retraction_length/_speed (as in a Bambu Studio X1C file's config block)."""
    f = _file(tmp_path, MOVES + "; CONFIG_BLOCK_START\n" + "".join(f"; {k} = {v}\n" for k, v in (
        ("gcode_flavor", "marlin"), ("machine_max_acceleration_x", "20000,20000"),
        ("machine_max_acceleration_y", "20000,20000"), ("machine_max_speed_x", "500,200"),
        ("machine_max_speed_y", "500,200"), ("machine_max_speed_z", "20,20"), ("machine_max_speed_e", "30,30"),
        ("printer_model", "Bambu Lab X1 Carbon"), ("use_firmware_retraction", "1"),
        ("retraction_length", "0.8"), ("retraction_speed", "30"))) + "; CONFIG_BLOCK_END\n")
    a = auto_profile(f, environ={})
    assert a.base == "bambu-x1c"
    p = a.profile
    assert (p.max_accel_a, p.max_velocity_v, p.max_z_velocity_v, p.max_e_velocity_v) == (20000.0, 500.0, 20.0, 30.0)
    assert (p.fw_retract_length_d, p.fw_retract_speed_v) == (0.8, 30.0)
    assert a.taken["max_velocity_v"][1] == "machine_max_speed_x/y"
    assert p.flavour == "marlin-legacy"               # 'marlin' in these slicers writes M204 S as PrusaSlicer's does
