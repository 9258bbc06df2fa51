"""The compiled column pass (gcode_opt/_emit.c fast_check, behind validate._fast_ok and
stroke_block) finds each line's end as it reads the line (issue 8, session 36): no memchr
a line, the numbers read up to the line's newline without a bound test a digit
(dec_value_nl), the last number of a line required to end at its newline, the command
buffer's limit checked on the line's length found so.  Lines that end early or late, a
number cut or followed by more, a line one byte over or at the limit, at the block's
last line: the core passes exactly the good ones, and never one the Python pass fails.
Also plain_line's unbounded number reads (the tests' line_read hook) against float()."""
from __future__ import annotations

import pytest

from gcode_opt import emit, validate

_CORE = emit.CORE_MOD
pytestmark = pytest.mark.skipif(_CORE is None or validate._FAST_BODY is None,
                                reason="the compiled rewrite core is not built here")

HEAD = "; gcode-opt begin: replaces 2 lines, kind=line"
END = "; gcode-opt end\n"
GOOD = ["M204 S1500", "G1 X10.5 Y20.25 E0.0123 F600", "M204 S800.5", "G1 X11 Y20.25 E0.01 F1200.7",
        "G1 F3000", "SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=0.5", "G1 X12.125 Y20.25 F1200.7"]
# a good line turned into one the pass must not take (its end early or late, a number cut)
BAD = {"G1 X10.5 Y20.25 E0.0123 F600": ["G1 X10.5 Y20.25 E0.0123 F600x", "G1 X10.5 Y20.25 E0.0123 F",
                                        "G1 X10.5 Y20.25 E0.0123 F600 ", "G1 X10.5 Y20.25 E0.0123 F6.0.0",
                                        "G1 X10.5 Y20.25 E0.0123", "G1 X10.5 Y20.25 E F600",
                                        "G1 X10.5 Y F600", "G1 X Y20.25 F600", "G1 X10.5 Y20.25 E0.0123 F600;",
                                        "G1 X10.5Y20.25 F600", "G1 X10.5 Y20.25  F600", "G1 X-10.5- Y1 F600",
                                        # two good lines in one: the first must end at the newline
                                        "G1 X10.5 Y20.25 E0.0123 F600 G1 F3000", "G1 X1 Y2 F600;M204 S1500"],
       "M204 S1500": ["M204 S", "M204 S1500 ", "M204 S1500x", "M204 S15.0.0", "M204 T1500", "M204 S-",
                      "M204 S1500 M204 S1500", "M204 S1500;G1 F3000"],
       "G1 F3000": ["G1 F", "G1 F3000 ", "G1 F3000..", "G1 F30a", "G1 F3000 G1 F3000"],
       "SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=0.5": ["SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=",
                                                       "SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=0.5 ",
                                                       "SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=0.5 G1 F3000"]}


def _text(lines):
    return HEAD + "\n" + "\n".join(lines) + "\n" + END


def _core(text, limit=0, klipper=True):
    """fast_body's verdict on the block's body (True, or None: declined)"""
    i = text.find("\n")
    return _CORE.fast_body(text, i, len(text) - len(END) + 1 - 1, "S", klipper, limit, 3000.0, None, None, 0.0,
                           0, 0.0, 0.0)


def _python(text):
    """the Python column pass's verdict (the core off)"""
    real = validate._FAST_BODY
    validate._FAST_BODY = None
    try:
        return validate._fast_ok(text, "klipper", 3000.0, None, True, "line", None, 0.0)
    finally:
        validate._FAST_BODY = real


def test_good_block_passes_both():
    text = _text(GOOD)
    assert _core(text) is True and _python(text) is True


@pytest.mark.parametrize("at", [0, 1, -1])           # first, middle, last line of the body
def test_a_line_ended_early_or_late_is_declined(at):
    for good, bads in BAD.items():
        for bad in bads:
            lines = list(GOOD)
            lines.remove(good)
            lines.insert(at if at >= 0 else len(lines), bad)
            text = _text(lines)
            assert _core(text) is None, bad
            assert _python(text) is False, bad


def test_the_limit_is_the_longest_line():
    longest = max(len(ln) for ln in GOOD)
    for at in (0, len(GOOD) - 1):                    # the longest line first and last
        lines = sorted(GOOD, key=len, reverse=at == 0)
        text = _text(lines)
        assert _core(text, limit=longest) is True
        assert _core(text, limit=longest - 1) is None
        assert _core(text, limit=longest + 1) is True


def test_klipper_only_line_declined_elsewhere():
    assert _core(_text(GOOD), klipper=False) is None
    assert _core(_text([ln for ln in GOOD if not ln.startswith("SET_")]), klipper=False) is True


@pytest.mark.parametrize("line", ["G1 X10.5 Y20.25 E0.0123", "G1 X1 Y2", "G1 X-0.125 Y.5 E-.25 ;c",
                                  "G1 X123456789.12345678 Y1", "G1 X1. Y2.\r", "G1 X1 Y2 E3 Q", "G1 X1 Y2-",
                                  "G1 X1.2.3 Y2", "G1 X1 Y2 E"])
def test_line_read_numbers_are_float(line):
    got = _CORE.line_read(line)
    if got is None:
        return
    x, y, e = got[7], got[8], got[9]
    assert (x, y) == (float(got[0]), float(got[1]))
    assert e == (None if got[2] is None else float(got[2]))
    assert got[0] in line and got[1] in line


def test_py_round_is_pythons_round():
    """emit_cols' py_round (a point's units: the addition of 2^52 rounds, halves to even)
    against Python's round() on halves, near-halves, the 2^52 edge, large, tiny and signed
    values, and the declines (not finite, past 4e18)."""
    import math
    import random
    import struct
    rng = random.Random(36)
    xs = [0.0, -0.0, 0.5, -0.5, 1.5, 2.5, -2.5, 1e-300, -1e-300, 2.0 ** 52, 2.0 ** 52 + 1, 2.0 ** 52 - 0.5,
          2.0 ** 53 + 2, -(2.0 ** 52) + 0.5, 3.9e18, 4.0e18, -4.0e18, 1e19, math.inf, -math.inf, math.nan]
    for _ in range(20000):
        k = rng.randrange(-200000, 200000)
        xs += [k + 0.5, math.nextafter(k + 0.5, math.inf), math.nextafter(k + 0.5, -math.inf),
               rng.uniform(-1e6, 1e6) * rng.choice([1, 1e-6, 1e6, 1e9]), k * 0.001 * 1000.0]
    got = _CORE.rounds(struct.pack(f"{len(xs)}d", *xs))
    want = [round(x) if math.isfinite(x) and abs(x) < 4.0e18 else None for x in xs]
    assert got == want


def test_units_text_about_the_32_bit_step():
    """units_at's digits: 64-bit steps down to 32 bits, then 32-bit ones; its 16-byte
    copies of the whole and the fraction (17 digits and more: the exact copy) -- texts
    as emit._fmt_units writes them, about 2^32 and 10^16 and for every dec."""
    from gcode_opt import emit as em
    us = [u for c in (2 ** 32, 10 ** 16, 10 ** 17, 2 ** 63 - 1) for u in range(c - 300, min(c + 300, 2 ** 63))]
    for u in us:
        for dec in (0, 1, 3, 5, 16, 17, 30):
            for v in (u, -u):
                assert _CORE.units_text(v, dec) == em._fmt_units(v, dec), (v, dec)


@pytest.mark.parametrize("line,plain", [("G1 X1 Y2\r", True), ("G1 X1 Y2 E3 ; c\r", True), ("G1 X1 Y2 ;a\rb", False),
                                        ("G1 X1\r Y2", False), ("G1 X1 Y2\r\r", False), ("G1 X1 Y2 E3\r;c", False),
                                        ("G1 X1 Y2 ; \x0b ok", True)])
def test_plain_line_takes_a_cr_only_last(line, plain):
    """block_into no longer looks for a "\\r" (nor a byte not ASCII) in a line before
    plain_line reads it: plain_line reads the line to its end and refuses one but the last."""
    assert (_CORE.line_read(line) is not None) == plain


def test_strokes_with_comments_not_ascii_or_cr_as_pure_python(tmp_path):
    """A stroke's lines with a comment not ASCII (UTF-8 or not), CRLF line ends (a lone CR
    the reader refuses: test_plain_line_takes_a_cr_only_last):
    the compiled rewrite (block_into declines those strokes through plain_line now) writes
    the bytes the pure-Python one writes."""
    import os
    import subprocess
    import sys
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    src = open(os.path.join(root, "sample_gcode", "prusa_gyroid.gcode"), "rb").read().split(b"\n")
    k = 0
    for i, ln in enumerate(src):
        if ln.startswith(b"G1 X") and b";" not in ln:
            k += 1
            tail = [b"", b" ; caf\xc3\xa9", b"\r", b" ; \xff"][k % 4]
            src[i] = ln + tail
    f = tmp_path / "odd.gcode"
    f.write_bytes(b"\n".join(src))
    outs = []
    for pure in ("", "1"):
        env = dict(os.environ, GCODE_OPT_PURE_PYTHON=pure)
        if not pure:
            env.pop("GCODE_OPT_PURE_PYTHON")
        o = tmp_path / f"out{pure}.gcode"
        subprocess.run([sys.executable, "-m", "gcode_opt", "process", str(f), "-o", str(o), "-q"], env=env, cwd=root,
                       check=True, capture_output=True)
        outs.append(o.read_bytes())
    assert outs[0] == outs[1] and b"gcode-opt begin" in outs[0]
