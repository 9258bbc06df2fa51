"""Reader and machine state on hand-written edge cases (expected values worked out by hand)."""
import math
import os

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


@pytest.mark.parametrize("text", ["M83\nG1 X1 Y2 E.1 F600\rM204 S800\nG1 X3 Y4 E.1\n",
                                  "M83\n;WIPE_END\rG1 X1 Y2 E.1\nG1 X3 Y4 E.1\n"])
def test_lone_cr_is_refused_naming_the_line(text):
    """A CR without LF ends a line for Marlin and Prusa-Firmware (the reader splits there
    too) but not for Klipper, which reads the two as one line: the firmwares disagree on
    what the file does, and a block written with that line's ending would be a single
    comment line to Klipper (found by the fuzz campaign: written files that broke the
    invariants)."""
    msg = refuse(text, "marlin-legacy", match="carriage return")      # a reader that splits at LF
    assert ":2:" in msg
    import dataclasses
    import tempfile
    prof = dataclasses.replace(load_profile("generic-klipper"), flavour="marlin-legacy")
    with tempfile.NamedTemporaryFile("w", suffix=".gcode", newline="", delete=False) as fh:
        fh.write(text)
    try:                                      # the product's reader splits at the CR itself
        with pytest.raises(GcodeError, match="carriage return") as ei:
            list(events(fh.name, prof))
        assert ":2:" in str(ei.value)
    finally:
        os.unlink(fh.name)


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
    # prusa_klipper: its printer notes name Klipper (PrusaSlicer 2.5 has no Klipper flavour);
    # cura_box: CuraEngine's start G-code names the Ender-3 (see tests/test_detect.py)
    ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "generic-klipper"),
    ("cura_box.gcode", "ender3"), ("edge/klipper_macros.gcode", "generic-klipper"),
])
def test_profile_detection(name, expected):
    from gcode_opt.detect import detect_profile
    assert detect_profile("sample_gcode/" + name)[0] == expected


# ---- issue 7: strict reading, ranges, flavour-faithful limits, odd arcs, encodings ----------

from gcode_opt.state import GcodeError  # noqa: E402


def refuse(text, flavour="klipper", match=None):
    with pytest.raises(GcodeError, match=match) as ei:
        run(text, flavour)
    return str(ei.value)


def test_fast_path_and_strict_path_read_alike():
    spaced = "M83\nG1 X10 Y5 E0.5 F600\nG1 X-.5 Y+3. E.25\n"
    glued = "M83\nG1X10Y5E0.5F600\nG1X-.5Y+3.E.25\n"        # not the fast path
    a = [(m.x1, m.y1, m.e, m.v) for m in moves(run(spaced)[1])]
    b = [(m.x1, m.y1, m.e, m.v) for m in moves(run(glued)[1])]
    assert a == b == [(10.0, 5.0, 0.5, 10.0), (-0.5, 3.0, 0.25, 10.0)]


@pytest.mark.parametrize("text,match", [
    ("G1 X100000.001", "position beyond"),
    ("G1 Y-100001", "position beyond"),
    ("G1 X" + "9" * 400, "position beyond"),                # float() of it is inf
    ("G91\nG1 X60000\nG1 X60000", "position beyond"),       # relative moves add up
    ("G20\nG1 X4000", "position beyond"),                   # 4000 in = 101600 mm
    ("G92 X200000", "position beyond"),
    ("G1 X1 E10000001", "E beyond"),
    ("G2 X10 Y0 I200000 J0", "I beyond"),
    ("G1 X1 F10000001", "F beyond"),
    ("G4 P-5", "dwell"),
])
def test_ranges_refused(text, match):
    msg = refuse(text, match=match)
    assert msg.startswith(f"<input>:{text.count(chr(10)) + 1}: ")   # the last line is the bad one


def test_ranges_at_the_bound_accepted():
    _, evs = run("G1 X100000 Y-100000 Z0.2 F600\nG1 X1 E10000000\n")
    m = moves(evs)
    assert (m[0].x1, m[0].y1) == (1e5, -1e5) and m[1].e == 1e7


@pytest.mark.parametrize("flavour,refused", [("klipper", True), ("rrf", True),
                                             ("marlin2", False), ("marlin-legacy", False)])
def test_f_zero_or_negative(flavour, refused):
    text = "G1 X1 F600\nG1 X2 F0\nG1 X3 F-100\n"
    if refused:
        assert "F must be above 0" in refuse(text, flavour)
    else:                                  # Marlin, Prusa-Firmware: F<=0 keeps the last feed
        _, evs = run(text, flavour)
        assert [m.v for m in moves(evs)] == [10.0, 10.0, 10.0]


def test_klipper_ignores_m201_m203_m205_marlin_applies_them():
    text = "M201 X500 Y700\nM203 X100 Y120\nM205 X5 Y6 J0.05\nG1 X1 F600\n"
    st, _ = run(text, "klipper")
    base = MachineState(dataclasses_replace_flavour("klipper")).lim
    assert (st.lim.ax_max, st.lim.ay_max, st.lim.v_max, st.lim.jd, st.lim.jerk_x) == \
        (base.ax_max, base.ay_max, base.v_max, base.jd, base.jerk_x)
    st, _ = run(text, "marlin2")
    assert (st.lim.ax_max, st.lim.ay_max, st.lim.v_max, st.lim.jerk_x, st.lim.jerk_y, st.lim.jd) == \
        (500, 700, 100, 5, 6, 0.05)
    st, _ = run("M203 X6000 Y9000\n", "rrf")              # RepRapFirmware: mm/min
    assert st.lim.v_max == 100


def dataclasses_replace_flavour(flavour):
    import dataclasses
    return dataclasses.replace(load_profile("generic-klipper"), flavour=flavour, fw_retract_length_d=0.8)


def test_klipper_m204_rules():
    # toolhead.cmd_M204: S > 0 wins (P, T then unread); P alone is ignored; any read value <= 0 raises
    st, _ = run("M204 S1000\nM204 P2000\n", "klipper")
    assert st.accel_print == 1000
    st, _ = run("M204 S1500 P0\n", "klipper")
    assert st.accel_print == 1500
    assert "M204 S must be above 0" in refuse("M204 S0\n", "klipper")
    assert "M204 P must be above 0" in refuse("M204 P0 T1000\n", "klipper")
    assert "M204 T must be above 0" in refuse("M204 T-5\n", "klipper")
    refuse("M204 S-1000\n", "klipper")


@pytest.mark.parametrize("flavour", ["marlin2", "marlin-legacy", "rrf"])
@pytest.mark.parametrize("line", ["M204 S0", "M204 P0", "M204 T-1", "M204 R0", "M201 X0", "M201 Y-100",
                                  "M203 X0", "M205 X-1"])
def test_marlin_rrf_nonpositive_limits_refused(flavour, line):
    assert "must be" in refuse(line + "\n", flavour)


def test_marlin2_m205_j_out_of_range_ignored_with_warning():
    st, _ = run("M205 J0.5\n", "marlin2")
    assert st.lim.jd == load_profile("generic-klipper").junction_deviation_d
    assert st.warnings and st.warnings[0][0] == 0 and "J" in st.warnings[0][1]


@pytest.mark.parametrize("line,match", [
    ("SET_VELOCITY_LIMIT ACCEL=0", "ACCEL must be above 0"),
    ("SET_VELOCITY_LIMIT VELOCITY=-1", "VELOCITY must be above 0"),
    ("SET_VELOCITY_LIMIT SQUARE_CORNER_VELOCITY=-0.1", "SQUARE_CORNER_VELOCITY"),
    ("SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=1", "MINIMUM_CRUISE_RATIO"),
    ("SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=-0.5", "MINIMUM_CRUISE_RATIO"),
    ("SET_VELOCITY_LIMIT ACCEL=1e3", "ACCEL: unreadable number"),
    ("SET_VELOCITY_LIMIT ACCEL=inf", "ACCEL: unreadable number"),
])
def test_set_velocity_limit_refused(line, match):
    refuse(line + "\n", "klipper", match=match)


def test_set_velocity_limit_accepted_forms():
    st, _ = run("SET_VELOCITY_LIMIT SQUARE_CORNER_VELOCITY=0 MINIMUM_CRUISE_RATIO=0.99 ACCEL=2000\n"
                "SET_VELOCITY_LIMIT ACCEL={params.A} VELOCITY=300\n", "klipper")   # macro tolerated
    assert (st.lim.scv, st.lim.mcr, st.accel_print, st.lim.v_max) == (0, 0.99, 2000, 300)
    st, _ = run("SET_VELOCITY_LIMIT ACCEL=2000 VELOCITY=1\n", "marlin2")      # unknown to Marlin
    assert st.accel_print == load_profile("generic-klipper").default_accel_a and st.lim.v_max != 1


def test_motion_and_read_commands_refuse_garbage_unknown_commands_do_not():
    assert "exponent" in refuse("G92 E1e2\n")
    assert "byte 0xff that is not UTF-8" in refuse("G1 X1 Y2\udcff\n")  # a non-UTF-8 byte in code
    _, evs = run("M117 Y2e1 inf \udcff\nM862.3 P \"MK3S\"\nG1 X1 ; caf\udce9\n")
    assert evs[:2] == [None, None] and moves(evs)[0].x1 == 1


def test_bom_on_line_one_is_not_part_of_the_command():
    st, evs = run("\ufeffG1 X10 Y5 F600\nG1 X20\n")
    m = moves(evs)
    assert (m[0].x1, m[0].y1) == (10, 5) and m[1].x0 == 10


def test_arc_end_off_its_circle_is_warned_and_not_retimed():
    from gcode_opt.strokes import K_ARC, group_strokes
    # start (100,100), centre (110,100): r 10; end (110,110.5) is 0.5 mm outside
    text = "M83\n;TYPE:Internal infill\nG1 X100 Y100 F600\nG2 X110 Y110.5 I10 J0 E0.5\n" \
           "G1 X100 Y100\nG2 X110 Y110 I10 J0 E0.5\n"
    st, evs = run(text)
    arcs = [m for m in moves(evs) if m.kind == ARC]
    assert arcs[0].arc.off_circle and arcs[0].arc.end_off_d == pytest.approx(0.5)
    assert not arcs[1].arc.off_circle and arcs[1].arc.end_off_d == pytest.approx(0.0, abs=1e-12)
    assert st.warnings == [(3, st.warnings[0][1])] and "off its circle" in st.warnings[0][1]
    triples = [(i, raw + "\n", ev) for i, (raw, ev) in enumerate(zip(text.strip("\n").split("\n"), evs))]
    strokes = [x[1] for x in group_strokes(iter(triples), {feat.SPARSE_INFILL}) if x[0] == "stroke"]
    assert [(s.kind, s.first_idx) for s in strokes if s.kind == K_ARC] == [(K_ARC, 5)]


def test_arc_r_below_half_chord_is_a_half_circle_on_the_chord():
    # chord 20 mm, R 5: Marlin centres it on the chord's midpoint (h^2 < 0 -> h = 0)
    _, evs = run("G1 X0 Y0\nG2 X20 Y0 R5\n")
    a = moves(evs)[-1].arc
    assert (a.cx, a.cy, a.r) == (10, 0, 10) and abs(a.sweep) == pytest.approx(math.pi)


def test_arc_whose_circle_reaches_the_range_is_read_but_not_retimed():
    # reproducer: re-timed sub-arcs of this circle (|cx| + r = 1e5) were rounded to points
    # 1e-5 mm beyond the range, and the output's read-back refused them
    from gcode_opt.strokes import eligible_arc
    sel = {feat.SPARSE_INFILL}
    text = "M83\n;TYPE:Internal infill\nG1 X0 Y0 F6000\nG3 X50000 Y50000 I50000 J0 E1\n" \
           "G1 X0 Y0\nG3 X10 Y10 I10 J0 E1\n"
    _, evs = run(text)
    big, small = [m for m in moves(evs) if m.kind == ARC]
    assert big.arc.r == 50000 and not big.arc.off_circle
    assert not eligible_arc(big, "G3 X50000 Y50000 I50000 J0 E1\n", sel)
    assert eligible_arc(small, "G3 X10 Y10 I10 J0 E1\n", sel)


def test_klipper_does_not_normalise_g01_marlin_does():
    # Klipper looks its handler up by the text 'G01': unknown command, the move is skipped
    _, evs = run("G1 X1 Y1\nG01 X5 Y5\nG1 X9\n", "klipper")
    assert evs[1] is None and moves(evs)[-1].x0 == 1
    _, evs = run("G1 X1 Y1\nG01 X5 Y5\nG1 X9\n", "marlin2")
    assert moves(evs)[1].x1 == 5 and moves(evs)[-1].x0 == 5


def test_klipper_pressure_advance_flush_is_a_barrier():
    # extruder._set_pressure_advance flushes when the effective smooth time changes:
    # PA 0 -> 0.04 (smooth 0 -> 0.04 s), same PA again (no change), SMOOTH_TIME change, PA -> 0
    _, evs = run("SET_PRESSURE_ADVANCE ADVANCE=0.04\nSET_PRESSURE_ADVANCE ADVANCE=0.05\n"
                 "SET_PRESSURE_ADVANCE SMOOTH_TIME=0.02\nSET_PRESSURE_ADVANCE ADVANCE=0\n"
                 "SET_PRESSURE_ADVANCE ADVANCE={pa}\n", "klipper")
    assert [type(e).__name__ for e in evs] == ["Barrier", "NoneType", "Barrier", "Barrier", "NoneType"]
    _, evs = run("SET_PRESSURE_ADVANCE ADVANCE=0.04\n", "marlin2")       # unknown to Marlin
    assert evs == [None]
    refuse("SET_PRESSURE_ADVANCE SMOOTH_TIME=0.3\n", "klipper", match="SMOOTH_TIME")
    refuse("SET_PRESSURE_ADVANCE ADVANCE=-1\n", "klipper", match="ADVANCE")


def test_m221_flow_factor_on_moves():
    _, evs = run("M83\nG1 X1 E1\nM221 S50\nG1 X2 E1\nM221\nG1 X3 E1\n", "klipper")
    assert [m.flow_r for m in moves(evs)] == [1.0, 0.5, 1.0]          # Klipper: no S = 100 %
    assert [m.e for m in moves(evs)] == [1, 1, 1]                     # E stays as written
    _, evs = run("M83\nM221 S0\nG1 X1 E1\nM221\nG1 X2 E1\n", "marlin2")
    assert [m.flow_r for m in moves(evs)] == [0.0, 0.0]               # Marlin: S0 = no flow, bare M221 reports
    refuse("M221 S0\n", "klipper", match="M221")
    refuse("M221 S-5\n", "marlin2", match="M221")


def test_events_hands_out_the_warnings(tmp_path):
    f = tmp_path / "a.gcode"
    f.write_text("G1 X110 Y100\nG3 X100 Y110.2 I-10 J0 E0.5\n")
    got = []
    n = sum(1 for _ in events(str(f), load_profile("generic-klipper"), warnings=got))
    assert n == 2 and [w[0] for w in got] == [1] and "0.200 mm off its circle" in got[0][1]


def test_m220_scales_moves_and_keeps_them_out_of_retiming(tmp_path):
    # M220 scales every later move's F in the firmware; a re-timed segment's F would be scaled
    # again, so such strokes are not candidates (the firmware-model side is checked against
    # real Klipper in test_klipper_oracle.py::test_state_reads_as_klipper)
    from gcode_opt.state import MachineState
    from gcode_opt.strokes import eligible
    from gcode_opt.profile import load_profile
    st = MachineState(load_profile("voron24"), "t.gcode")
    moves = [st.step(i, line) for i, line in enumerate(
        ["G90", "M83", "G1 X0 Y0 F6000", "M220 S50", "G1 X50 Y0 E1", "M220 S100", "G1 X99 Y0 E1"])]
    half, full = moves[4], moves[6]
    assert half.v == pytest.approx(50.0) and full.v == pytest.approx(100.0)
    assert not eligible(half, frozenset({"other"} | {half.feature}))
    assert eligible(full, frozenset({full.feature}))
    with pytest.raises(Exception, match="M220"):
        st.step(7, "M220 S0")
