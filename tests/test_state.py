"""Reader and machine state on hand-written edge cases (expected values worked out by hand)."""
import math

import pytest

from gcode_opt import features as feat
from gcode_opt.profile import load_profile
from gcode_opt.state import ARC, EONLY, MachineState, Move, events

EDGE = "sample_gcode/edge/"


def run(text, flavour="klipper"):
    import dataclasses
    prof = dataclasses.replace(load_profile("generic-klipper"), flavour=flavour, fw_retract_length_d=0.8)
    st = MachineState(prof)
    evs = [st.step(i, raw + "\n") for i, raw in enumerate(text.strip("\n").split("\n"))]
    return st, evs


def moves(evs):
    return [e for e in evs if isinstance(e, Move)]


def test_absolute_relative_and_g92():
    st, evs = run("""
G90
M82
G1 X10 Y0 E1 F600
G92 E0
G1 X20 E0.5
G91
G1 X5 Y5 E0.25
G90
G92 X0 Y0
G1 X1
""")
    m = moves(evs)
    assert (m[0].x1, m[0].e, m[0].v) == (10, 1, 10.0)       # F600 mm/min = 10 mm/s
    assert m[1].e == pytest.approx(0.5)                      # after G92 E0, absolute E 0.5 is +0.5
    assert (m[2].x1, m[2].y1, m[2].e) == (25, 5, 0.25)       # G91: relative XYZ and E
    assert (m[3].x0, m[3].x1) == (0, 1)                      # G92 X0 redefines the origin
    assert m[0].feature == feat.OTHER and m[3].feature == feat.TRAVEL


def test_marlin2_g90_resets_relative_e_but_klipper_does_not():
    text = "M83\nG90\nG1 X1 E1\nG1 X2 E1\n"
    _, evs = run(text, "marlin2")
    assert [m.e for m in moves(evs)] == [1, 0]               # E absolute again: 1 -> 1 is no extrusion
    _, evs = run(text, "klipper")
    assert [m.e for m in moves(evs)] == [1, 1]


def test_inches():
    _, evs = run("G20\nG1 X1 Y1 F60\n")
    m = moves(evs)[0]
    assert (m.x1, m.y1) == pytest.approx((25.4, 25.4)) and m.v == pytest.approx(25.4)


@pytest.mark.parametrize("flavour,expect_print,expect_travel", [
    ("klipper", 1000.0, 1000.0),        # M204 P2000 T1000 -> min
    ("marlin2", 2000.0, 1000.0),
    ("rrf", 2000.0, 1000.0),
    ("marlin-legacy", 2000.0, 2000.0),  # Prusa-Firmware: P = all moves; T ignored without S
])
def test_m204_flavours(flavour, expect_print, expect_travel):
    st, _ = run("M204 P2000 T1000\n", flavour)
    assert st.accel_for(True, True) == expect_print
    assert st.accel_for(False, True) == expect_travel


def test_m204_s_and_klipper_set_velocity_limit():
    st, _ = run("M204 S1500 T900\n", "marlin-legacy")
    assert st.accel_print == 1500 and st.accel_retract == 900
    st, evs = run("SET_VELOCITY_LIMIT ACCEL=3000 MINIMUM_CRUISE_RATIO=0 VELOCITY=250\nG1 X10 E1\n")
    m = moves(evs)[0]
    assert m.accel == 3000 and m.lim.mcr == 0 and m.lim.v_max == 250


def test_arcs_ij_r_full_circle():
    _, evs = run("""
G1 X100 Y100
G2 X110 Y110 I10 J0 E0.5
G3 I10 J0 E1
G1 X140 Y120
G2 X160 Y120 R10
G3 X170 Y130 R-10
""")
    a = [e for e in evs if isinstance(e, Move) and e.kind == ARC]
    # quarter circle CW, centre (110,100), r 10: from angle pi to pi/2 clockwise = -pi/2
    assert (a[0].arc.cx, a[0].arc.cy, a[0].arc.r) == (110, 100, 10)
    assert a[0].arc.sweep == pytest.approx(-math.pi / 2)
    assert a[1].arc.sweep == pytest.approx(2 * math.pi)                     # full circle, end omitted
    assert a[1].length_d == pytest.approx(2 * math.pi * 10)
    assert abs(a[2].arc.sweep) == pytest.approx(math.pi) and a[2].arc.r == 10  # half circle by R
    assert abs(a[3].arc.sweep) == pytest.approx(1.5 * math.pi)                # R<0: the long way, 270 deg


def test_checksums_lowercase_nospace_and_crlf():
    _, evs = run("M83\nN10 G1 X1 Y2 *45\ng1 x3 y4 e.5\nG1X5Y6E.5\nG1 X7 Y8 E0.5 ;comment\r")
    m = moves(evs)
    assert [(e.x1, e.y1) for e in m] == [(1, 2), (3, 4), (5, 6), (7, 8)]
    assert m[0].checksum and not m[1].checksum
    assert [e.e for e in m[1:]] == [0.5, 0.5, 0.5]


def test_firmware_retraction_and_barriers():
    _, evs = run("G10\nG10\nG11\nG4 P500\nG28\nM400\nG10 L2 P1 X0\n")
    assert [type(e).__name__ for e in evs] == ["Move", "NoneType", "Move", "Barrier", "Barrier", "Barrier",
                                              "NoneType"]
    assert evs[0].kind == EONLY and evs[0].e < 0 and evs[2].e > 0
    assert evs[3].dwell_t == pytest.approx(0.5)


@pytest.mark.parametrize("comment,expected", [
    (";TYPE:Internal infill", feat.SPARSE_INFILL), (";TYPE:Solid infill", feat.SOLID_INFILL),
    ("; FEATURE: Sparse infill", feat.SPARSE_INFILL), (";TYPE:Sparse infill", feat.SPARSE_INFILL),
    (";TYPE:FILL", feat.SPARSE_INFILL), ("; feature infill", feat.SPARSE_INFILL),
    (";TYPE:External perimeter", feat.EXTERNAL_PERIMETER), (";TYPE:WALL-OUTER", feat.EXTERNAL_PERIMETER),
    ("; FEATURE: Outer wall", feat.EXTERNAL_PERIMETER), (";TYPE:SKIN", feat.SOLID_INFILL),
    (";TYPE:Something new", feat.OTHER), (";WIDTH:0.45", None),
])
def test_feature_comments(comment, expected):
    assert feat.feature_from_comment(comment) == expected


def test_every_edge_file_reads(tmp_path):
    import glob
    files = sorted(glob.glob(EDGE + "*.gcode"))
    assert len(files) >= 10
    for f in files:
        n = sum(1 for _ in events(f, load_profile("generic-klipper")))
        with open(f, newline="") as fh:
            assert n == len(fh.readlines())


def test_edge_feature_files_give_sparse_infill():
    for name in ("orca_feature", "bambu_type", "simplify3d_feature", "cura_type"):
        ftrs = {e.feature for _, _, e in events(EDGE + name + ".gcode", load_profile("generic-klipper"))
                if isinstance(e, Move) and e.e > 0}
        assert feat.SPARSE_INFILL in ftrs, name


@pytest.mark.parametrize("name,expected", [
    ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "generic-marlin"),
    ("cura_box.gcode", "generic-marlin"), ("edge/klipper_macros.gcode", "generic-klipper"),
])
def test_profile_detection(name, expected):
    from gcode_opt.detect import detect_profile
    assert detect_profile("sample_gcode/" + name)[0] == expected
