"""Slower corners by junction command (corners.junction_commands): the parameter written
before the move after a corner gives the chosen corner speed in the firmware's own junction
law (firmware/junction.py, ports of Klipper's toolhead.py and Marlin 1.1's classic jerk,
written independently of the closed forms in corners.py), the validator accepts the
commands only where the firmware reads them, and a written file restores the value in
force right after the slowed move."""
from __future__ import annotations

import math
import os
import types

import pytest

from gcode_opt import features as feat
from gcode_opt.corners import CMD_MARGIN_R, junction_commands
from gcode_opt.firmware.junction import (klipper_corner_v2, klipper_junction_deviation,
                                         marlin_jerk_junction_v)
from gcode_opt.pipeline import Options, process
from gcode_opt.profile import load_profile
from gcode_opt.validate import BlockInvalid, validate_block

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RECT = os.path.join(ROOT, "sample_gcode", "prusa_mk3s_rectilinear.gcode")
KLIPPER = os.path.join(ROOT, "sample_gcode", "prusa_klipper.gcode")
TURNS_DEG = (45.0, 60.0, 90.0, 120.0, 135.0, 150.0, 170.0)


def _stroke(turn_deg, v0, lim, u_deg=10.0):
    a = math.radians(u_deg)
    p = a - math.radians(turn_deg)
    return types.SimpleNamespace(corner_cmd0=True, v0=v0, prev_u=(math.cos(p), math.sin(p)),
                                 ux=math.cos(a), uy=math.sin(a), kind="line", lim=lim)


def _value(cmd, word):
    return float(next(w for w in cmd.split() if w.startswith(word))[len(word):])


@pytest.mark.parametrize("turn_deg", TURNS_DEG)
def test_jerk_command_gives_the_corner_speed(turn_deg):
    lim = types.SimpleNamespace(jerk_x=8.0, jerk_y=8.0, scv=5.0)
    v_c = 2.5
    st = _stroke(turn_deg, v_c, lim)
    before, after = junction_commands(st, "marlin-legacy", "jerk")
    j = _value(before, "X")
    assert j == _value(before, "Y") and 0 < j < 8.0
    assert after == "M205 X8 Y8"
    nominal = 40.0                      # both moves fast: the jerk limit decides the junction
    safe = min(j / max(abs(st.ux), 1e-9), j / max(abs(st.uy), 1e-9), nominal)
    p_safe = min(8.0 / max(abs(st.prev_u[0]), 1e-9), 8.0 / max(abs(st.prev_u[1]), 1e-9), nominal)
    v = marlin_jerk_junction_v(st.prev_u[0], st.prev_u[1], 0.0, nominal, p_safe, st.ux, st.uy, 0.0,
                               nominal, safe, j, j, 0.4)
    assert v == pytest.approx(CMD_MARGIN_R * v_c, rel=2e-3)     # the written value is rounded to 1e-3


@pytest.mark.parametrize("turn_deg", TURNS_DEG)
def test_klipper_command_gives_the_corner_speed(turn_deg):
    lim = types.SimpleNamespace(jerk_x=8.0, jerk_y=8.0, scv=5.0)
    st = _stroke(turn_deg, 1.0, lim)
    accel, p_accel = 1800.0, 3000.0     # the junction deviation follows each move's own accel

    def corner_v(scv):
        return math.sqrt(klipper_corner_v2(st.prev_u[0], st.prev_u[1], 0.0, klipper_junction_deviation(5.0, p_accel),
                                           p_accel, 1e9, st.ux, st.uy, 0.0, klipper_junction_deviation(scv, accel),
                                           accel, 1e9))
    v_c = st.v0 = 0.5 * corner_v(5.0)   # half the firmware's own corner speed
    before, after = junction_commands(st, "klipper", "scv")
    scv_c = _value(before, "SQUARE_CORNER_VELOCITY=")
    assert 0 < scv_c < 5.0 and after == "SET_VELOCITY_LIMIT SQUARE_CORNER_VELOCITY=5"
    assert corner_v(scv_c) == pytest.approx(CMD_MARGIN_R * v_c, rel=2e-3)


def test_no_command_above_the_value_in_force_or_on_other_firmware():
    lim = types.SimpleNamespace(jerk_x=8.0, jerk_y=8.0, scv=5.0)
    assert junction_commands(_stroke(90.0, 20.0, lim), "marlin-legacy", "jerk") is None   # would raise jerk
    assert junction_commands(_stroke(90.0, 2.0, lim), "marlin2", "jd") is None            # M205 J: no
    assert junction_commands(_stroke(90.0, 2.0, lim), "rrf", "jerk") is None
    st = _stroke(90.0, 2.0, lim)
    st.corner_cmd0 = False
    assert junction_commands(st, "marlin-legacy", "jerk") is None


def _block(cmd, flavour):
    m204 = "M204 P500" if flavour == "marlin2" else "M204 S500"
    return ("; gcode-opt begin: replaces 1 lines, kind=line, 2 segments\n"
            f"{m204}\n{cmd}\nG1 X1 Y0 E0.05 F600\nG1 X2 Y0 E0.05 F1200\n; gcode-opt end")


def test_validator_takes_m205_where_the_firmware_reads_it():
    validate_block(_block("M205 X0.98 Y0.98", "marlin-legacy"), "marlin-legacy", 1000.0)
    validate_block(_block("M205 X2.5 Y2.5", "marlin2"), "marlin2", 1000.0)
    for cmd, flavour in (("M205 X0.98 Y0.98", "klipper"), ("M205 X0 Y0", "marlin-legacy"),
                         ("M205 X1", "marlin-legacy"), ("M205 J0.01", "marlin2"),
                         ("M205 X1 Y1 E2", "marlin-legacy"), ("M205 X1e1 Y1", "marlin-legacy")):
        with pytest.raises(BlockInvalid):
            validate_block(_block(cmd, flavour), flavour, 1000.0)


@pytest.mark.parametrize("src,profile,cmd,restore", [
    (RECT, "prusa-mk3s", "M205 X", "M205 X8 Y8"),
    (KLIPPER, "voron24", "SET_VELOCITY_LIMIT SQUARE_CORNER_VELOCITY=", "SET_VELOCITY_LIMIT SQUARE_CORNER_VELOCITY=5"),
])
def test_written_commands_are_restored_after_one_move(tmp_path, src, profile, cmd, restore):
    out = tmp_path / "o.gcode"
    opts = Options(max_slowdown_r=0.05, features=feat.parse_feature_list("all"))
    opts.corner_budget_r = 1.0
    process(src, str(out), load_profile(profile), opts)
    lines = out.read_text().splitlines()
    inside, n = False, 0
    for k, line in enumerate(lines):
        if line.startswith("; gcode-opt begin"):
            inside = True
        elif line.startswith("; gcode-opt end"):
            inside = False
        elif inside and line.startswith(cmd) and line != restore:
            assert lines[k + 1].startswith("G1 ") and lines[k + 2] == restore, lines[k:k + 3]
            n += 1
    assert n > 100
