"""The output validator (validate.py): hand-made good blocks pass, and every rule rejects
a block that breaks it.  Blocks are written by hand, not by the emitter."""
import pytest

from gcode_opt.validate import BlockInvalid, Geometry, validate_block

HDR = "; gcode-opt begin: replaces 2 lines, kind=line, 3 segments, T=0.1s (was 0.1s), beta=infs^2"
END = "; gcode-opt end"
LINE = Geometry([(10.0, 10.0), (20.0, 10.0), (30.0, 10.0)])
# quarter circle, centre (10, 0), r 10, from (0, 0) counter-clockwise... start angle pi
ARC = Geometry([(0.0, 0.0), (10.0, -10.0)], arc=(10.0, 0.0, 10.0, 3.141592653589793, 1.5707963267948966))

GOOD = {
    "klipper": [HDR, "SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=0", "M204 S1500.5",
                "G1 X15 Y10 E.18 F3000.1", "M204 S800", "G1 X20 Y10 E0.187 F2400 ; a comment",
                "G1 X30.000 Y10.000 E0.374 F1800", "M204 S3000", "SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=0.5",
                "G1 F4800", END],
    "marlin2": [HDR, "M204 P1500", "G1 X15 Y10 E0.18 F3000.1", "G1 X30 Y10 E-0.5 F1800", "M204 P3000",
                "G1 F4800", END],
    "rrf": [HDR, "M204 P1500", "G1 X15 Y10 E0.18 F3000.1", "G1 X30 Y10 E0.5 F1800", "M204 P3000", "G1 F4800", END],
    "marlin-legacy": [HDR, "M204 S1500", "G1 X15 Y10 E0.18 F3000.1", "G1 X30 Y10 E0.5 F1800", "M204 S3000",
                      "G1 F4800", END],
}


def _check(lines, flavour="klipper", geo=LINE, accel_max=3000.0, **kw):
    validate_block("\n".join(lines) + "\n", flavour, accel_max, geo, **kw)


@pytest.mark.parametrize("flavour", sorted(GOOD))
def test_good_blocks_pass(flavour):
    _check(GOOD[flavour], flavour, kind="line")


def test_good_arc_block_passes():
    hdr = HDR.replace("kind=line", "kind=arc")
    _check([hdr, "M204 S1000", "G2 X2.929 Y-7.071 I10 J0 E0.3 F3000", "G2 X10 Y-10 I7.071 J7.071 E0.3 F3000",
            "M204 S3000", "G1 F4800", END], geo=ARC, kind="arc")


def test_travel_block_in_marlin2_uses_T():
    _check([HDR, "M204 T5000", "G1 X15 Y10 F9000", "G1 X30 Y10 F9000", "M204 T5000", "G1 F9000", END],
           "marlin2", accel_max=5000.0, extruding=False)


def _mutate(i, line, flavour="klipper"):
    lines = list(GOOD[flavour])
    lines[i] = line
    return lines


BAD = [
    # (flavour, lines, reason fragment)
    ("klipper", _mutate(2, "M204 S0"), "M204 value out of range"),
    ("klipper", _mutate(2, "M204 S-100"), "M204 value out of range"),
    ("klipper", _mutate(2, "M204 S3000.2"), "M204 value out of range"),        # above max + rounding
    ("klipper", _mutate(2, "M204 Snan"), "not a plain decimal"),
    ("klipper", _mutate(2, "M204 P1500"), "not the klipper form"),
    ("marlin2", _mutate(1, "M204 S1500", "marlin2"), "not the marlin2 form"),
    ("marlin-legacy", _mutate(1, "M204 P1500", "marlin-legacy"), "not the marlin-legacy form"),
    ("klipper", _mutate(2, "M204 S100 T100"), "M204 takes one value"),
    ("klipper", _mutate(3, "G1 X15 Y10 E0.18 F0"), "F not above 0"),
    ("klipper", _mutate(3, "G1 X15 Y10 E0.18 F-60"), "F not above 0"),
    ("klipper", _mutate(3, "G1 X15 Y1e1 E0.18 F3000"), "not a plain decimal"),          # exponent
    ("klipper", _mutate(3, "G1 X15 Y10 Einf F3000"), "not a plain decimal"),
    ("klipper", _mutate(3, "G1 X15 Y10 E0.18 Fnan"), "not a plain decimal"),
    ("klipper", _mutate(3, "G1 X+15 Y10 E0.18 F3000"), "not a plain decimal"),
    ("klipper", _mutate(3, "G1 X15.123456789 Y10 E0.18 F3000"), "too many decimals"),
    ("klipper", _mutate(3, "G1 X15 Y10 Z0.3 E0.18 F3000"), "word Z not allowed"),
    ("klipper", _mutate(3, "G1 X15 Y10 I1 E0.18 F3000"), "word I not allowed"),
    ("klipper", _mutate(3, "G1 X15 Y10 E0.1 E0.18 F3000"), "repeated"),
    ("klipper", _mutate(3, "G1 X15 E0.18 F3000"), "without both X and Y"),
    ("klipper", _mutate(3, "G1 E0.18 F3000"), "extrusion without a move"),
    ("klipper", _mutate(3, "G1 X15 Y10.01 E0.18 F3000"), "off the original path"),
    ("klipper", _mutate(3, "G1 X35 Y10 E0.18 F3000"), "off the original path"),        # beyond the end
    ("klipper", _mutate(3, "G0 X15 Y10 F3000"), "command G0 not allowed"),
    ("klipper", _mutate(3, "M220 S100"), "command M220 not allowed"),
    ("klipper", _mutate(3, "g1 X15 Y10 E0.18 F3000"), "lower-case"),
    ("klipper", _mutate(3, "; just a comment"), "comment line"),
    ("klipper", _mutate(1, "SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=1"), "MINIMUM_CRUISE_RATIO out of range"),
    ("klipper", _mutate(1, "SET_VELOCITY_LIMIT MAX_ACCEL=100"), "key unknown"),
    ("klipper", _mutate(1, "SET_VELOCITY_LIMIT ACCEL=0"), "accel out of range"),
    ("klipper", _mutate(1, "SET_VELOCITY_LIMIT SQUARE_CORNER_VELOCITY=-1"), "not above 0"),
    ("klipper", _mutate(1, "SET_VELOCITY_LIMIT"), "without a key"),
    ("marlin2", _mutate(1, "SET_VELOCITY_LIMIT ACCEL=1000", "marlin2"), "Klipper's"),
    ("klipper", _mutate(0, "; gcode-opt begin: 3 segments"), "not fenced"),
    ("klipper", GOOD["klipper"][:-1], "not fenced"),
    ("marlin2", _mutate(2, "G1 X" + "0" * 30 + "15 Y" + "0" * 30 + "10 E0.18 F" + "0" * 20 + "3000", "marlin2"),
     "command buffer"),
]


@pytest.mark.parametrize("flavour,lines,why", BAD, ids=[b[2] + f"-{i}" for i, b in enumerate(BAD)])
def test_each_rule_rejects(flavour, lines, why):
    with pytest.raises(BlockInvalid) as e:
        _check(lines, flavour)
    assert why in str(e.value)
    assert str(e.value).startswith("validator: ")


def test_kind_must_be_named():
    with pytest.raises(BlockInvalid, match="kind"):
        _check(GOOD["klipper"], kind="curve")


@pytest.mark.parametrize("line,why", [
    ("G2 X2.929 Y-7.071 E0.3 F3000", "arc without I/J"),
    ("G2 I10 J0 E0.3 F3000", "arc without its end point"),
    ("G2 X3.5 Y-7.071 I10 J0 E0.3 F3000", "off the original path"),          # not on the circle
    ("G2 X10 Y10 I10 J0 E0.3 F3000", "off the original path"),               # on the circle, outside the sweep
])
def test_arc_rules(line, why):
    hdr = HDR.replace("kind=line", "kind=arc")
    with pytest.raises(BlockInvalid, match=why):
        _check([hdr, "M204 S1000", line, "G2 X10 Y-10 I7.071 J7.071 E0.3 F3000", "M204 S3000", "G1 F4800", END],
               geo=ARC)


def test_point_tolerance_follows_the_digits_written():
    """tests/cases/four_decimal_coordinates.gcode: a 4-decimal start and a 3-decimal end;
    a new point rounded to 3 decimals was 0.0012 mm off the segment (verify caught it)."""
    geo = Geometry([(98.1079, 100.4936), (99.965, 98.108)])
    hdr = HDR
    a, b = (98.1079, 100.4936), (99.965, 98.108)
    t = 0.03
    x, y = a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])
    good = f"G1 X{x:.4f} Y{y:.4f} E0.01 F600"
    _check([hdr, "M204 S500", good, "G1 X99.965 Y98.108 E0.01 F600", "M204 S1000", "G1 F3000", END], geo=geo)
    with pytest.raises(BlockInvalid, match="off the original path"):
        _check([hdr, "M204 S500", "G1 X98.166 Y100.417 E0.01 F600", "G1 X99.965 Y98.108 E0.01 F600",
                "M204 S1000", "G1 F3000", END], geo=geo)


def test_filament_must_match_the_original():
    # relative E: the block's E words sum to the original's (0.18 + 0.187 + 0.374 = 0.741)
    _check(GOOD["klipper"], e_check=(True, 0.741))
    with pytest.raises(BlockInvalid, match="filament"):
        _check(GOOD["klipper"], e_check=(True, 0.742))
    # absolute E: the last E word is the original's last
    lines = [HDR, "M204 S1000", "G1 X15 Y10 E10.5 F3000", "G1 X30 Y10 E11.25 F3000", "M204 S3000", "G1 F4800", END]
    _check(lines, e_check=(False, 11.25))
    with pytest.raises(BlockInvalid, match="filament"):
        _check(lines, e_check=(False, 11.5))
    with pytest.raises(BlockInvalid, match="filament"):          # no E at all where the original extruded
        _check([HDR, "M204 S1000", "G1 X30 Y10 F3000", "M204 S3000", "G1 F4800", END], e_check=(True, 0.5))
