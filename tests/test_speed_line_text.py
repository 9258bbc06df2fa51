"""Per-line speed-ups of the text paths (issue 8) read and write what the long paths do:
emit._units (one int() of the digits) against exact decimal arithmetic, emit._num1
against _num(x, 1), the emitter's inlined accel/feed words against accel_command and
_feed_text, the validator's fast path for plain lines against the same lines read the
long way (a comment after them), and param_texts's inlined number check."""
import math
import random
from decimal import Decimal

import pytest

from gcode_opt.emit import StrokeText, _feed_text, _num, _num1, _units, accel_command, emit_stroke
from gcode_opt.validate import BlockInvalid, Geometry, validate_block
from gcode_opt.words import WordError, param_texts


def _units_ref(text, dec):
    """Exact: the decimal value times 10^dec, digits past dec cut (toward zero)."""
    v = Decimal(text if text not in ("", "+", "-") else "0").scaleb(dec)
    return int(v)          # int() of a Decimal truncates toward zero


def test_units_exact_on_number_texts():
    rng = random.Random(8)
    for _ in range(20000):
        whole = "".join(rng.choice("0123456789") for _ in range(rng.randint(0, 5)))
        frac = "".join(rng.choice("0123456789") for _ in range(rng.randint(0, 9)))
        text = rng.choice(["", "-", "+"]) + whole + ("." + frac if frac or rng.random() < 0.2 else "")
        if not (whole or frac):
            continue
        dec = rng.randint(0, 8)
        assert _units(text, dec) == _units_ref(text, dec), (text, dec)


@pytest.mark.parametrize("text,dec,want", [("-.5", 3, -500), ("+1.25", 1, 12), ("-0.0009", 3, 0),
                                           ("007.010", 2, 701), ("5.", 2, 500), ("-12", 0, -12)])
def test_units_cases(text, dec, want):
    assert _units(text, dec) == want


def test_num1_is_num_with_one_decimal():
    rng = random.Random(3)
    for _ in range(20000):
        x = max(math.ceil(rng.choice([rng.uniform(0.0, 30.0), rng.uniform(0.0, 2e5)]) * 10.0 - 1e-9) / 10.0, 0.1)
        assert _num1(x) == _num(x, 1)
    assert _num1(0.1) == "0.1" and _num1(100.0) == "100" and _num1(1500.5) == "1500.5"


def _stroke(flavour, accels, feeds, extruding=True):
    st = StrokeText(["G1 X10 Y0 E0.5\n", "G1 X20 Y0 E0.5\n"], "0", "0", 0)
    return emit_stroke(st, [10.0, 20.0], [0.0, 5.0, 10.0, 15.0, 20.0], [0.0, 10.0, 20.0, 10.0, 0.0],
                       accels, feeds, x0_text="0", y0_text="0", e_rel=True, flavour=flavour,
                       accel_restore=1000.0, mcr_restore=0.0, feed_restore_v=30.0, extruding=extruding)


@pytest.mark.parametrize("flavour", ["klipper", "marlin-legacy", "marlin2", "rrf"])
@pytest.mark.parametrize("extruding", [True, False])
def test_emitted_accel_and_feed_words(flavour, extruding):
    accels, feeds = [1234.51, 1234.51, 0.01, 987.0], [10.0, 20.004, 33.3333, 0.0001]
    lines = _stroke(flavour, accels, feeds, extruding).splitlines()
    cmds = [ln for ln in lines if ln.startswith("M204")][:-1]        # the last one is the restore
    want = []
    for a in accels:
        c = accel_command(flavour, a, extruding)
        if not want or want[-1] != c:
            want.append(c)
    assert cmds == want
    assert [ln.split(" F")[1] for ln in lines if ln.startswith("G1 X")] == [_feed_text(f) for f in feeds]


@pytest.mark.parametrize("accels,feeds", [([1.0, float("nan"), 1.0, 1.0], [10.0] * 4),
                                          ([1.0, 0.0, 1.0, 1.0], [10.0] * 4),
                                          ([1.0] * 4, [10.0, -1.0, 10.0, 10.0]),
                                          ([1.0] * 4, [10.0, float("inf"), 10.0, 10.0])])
def test_emitter_still_refuses_bad_values(accels, feeds):
    with pytest.raises(ValueError, match="not a positive number"):
        _stroke("marlin2", accels, feeds)


HDR = "; gcode-opt begin: replaces 2 lines, kind=line, 3 segments, T=0.1s (was 0.1s), beta=infs^2"
GEO = [(10.0, 10.0), (20.0, 10.0), (30.0, 10.0)]


def _verdict(lines, flavour="marlin2", **kw):
    try:
        validate_block("\n".join([HDR] + lines + ["; gcode-opt end"]) + "\n", flavour, 3000.0,
                       Geometry(GEO), **kw)
        return None
    except BlockInvalid as e:
        return str(e)


BODIES = [
    ["M204 P1500", "G1 X15 Y10 E0.18 F3000.1", "G1 X30 Y10 E0.5 F1800", "M204 P3000", "G1 F4800"],
    ["M204 P1500", "G1 X15 Y10.01 E0.18 F3000.1", "G1 X30 Y10 E0.5 F1800"],          # off the path
    ["M204 P1500", "G1 X15 Y10 E0.18 F0", "G1 X30 Y10 E0.5 F1800"],                 # F not above 0
    ["M204 P3500", "G1 X15 Y10 E0.18 F3000.1"],                                     # accel too high
    ["M204 S1500", "G1 X15 Y10 E0.18 F3000.1"],                                     # not marlin2's word
    ["M204 P1500", "G1 X15 Y10 E0.18 F3000.1", "G1 X15.0001 Y10 E0.18 F3000.1"],    # short move
    ["M204 P1500", "G1 X15." + "0" * 8 + " Y10." + "0" * 8 + " E0.18 F3000.1",
     "G1 X30 Y10 E0.5 F1800"],
    ["M204 P1500", "G1 X15.000000000 Y10 E0.18 F3000.1"],                           # 9 decimals
    ["M204 P1500", "G1 X15 Y10 E0.18 F3000.1", "G1 X30 Y10 E0.6 F1800"],            # filament off
]


@pytest.mark.parametrize("body", BODIES)
def test_validator_plain_lines_read_as_commented_ones(body):
    """A plain line takes the fast path; the same line with a comment after it takes the
    general one: the verdicts agree (the comment changes nothing a firmware reads)."""
    kw = dict(e_check=(True, 0.68), min_move_d=0.01)
    plain = _verdict(body, **kw)
    commented = _verdict([ln + " ; c" for ln in body], **kw)
    assert plain == commented


def test_validator_verdicts_are_not_all_alike():
    kw = dict(e_check=(True, 0.68), min_move_d=0.01)
    verdicts = [_verdict(b, **kw) for b in BODIES]
    assert verdicts[0] is None and verdicts[6] is None
    assert len({v for v in verdicts if v}) >= 6


def test_validator_plain_line_past_the_command_buffer():
    """Marlin's 96-byte command buffer holds for the fast path's lines too."""
    pad = "G1 X15 Y10 E" + "0" * 90 + ".18 F3000.1"
    assert len(pad) > 96
    assert "command buffer" in _verdict(["M204 P1500", pad])
    assert "command buffer" in _verdict(["M204 P1500", pad + " ; c"])
    assert _verdict(["M204 S1500", pad], "klipper") is None           # Klipper has no such buffer


@pytest.mark.parametrize("code,ok", [("G1 X1.5 Y-2 E.25", {"X": "1.5", "Y": "-2", "E": ".25"}),
                                     ("G1 X1.2.3 Y2", "unreadable"), ("G1 X1 X2", "given twice"),
                                     ("G1 X1_0 Y2", "unreadable"), ("G1 x1 y2", {"X": "1", "Y": "2"})])
def test_param_texts(code, ok):
    if isinstance(ok, dict):
        assert param_texts(code) == ok
    else:
        with pytest.raises(WordError, match=ok):
            param_texts(code)


def test_stroke_text_drops_line_numbers_and_checksums():
    """StrokeText skips strip_checksum only where it has nothing to drop."""
    raws = ["N10 G1 X1 Y2 E.5*45\n", "  G1 X2 Y3 E0.5 ; c\n", "G1 X3*12\n", "G1 Y4 E1\r\n", "n7 G1 X5\n"]
    st = StrokeText(raws, "0", "0", 0)
    assert st.x_texts == ["1", "2", "3", "3", "5"]
    assert st.y_texts == ["2", "3", "3", "4", "4"]
    assert st.e_texts == [".5", "0.5", "0", "1", "0"]
    assert st.e_given == [True, True, False, True, False]
    assert st.comments == ["", "; c", "", "", ""]
