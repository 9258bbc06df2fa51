"""One absurdly long line in a real file must be processed or refused cleanly, in time.

A fuzzed line of 574 k digits hung the reader (session 50); a sweep of the package's
patterns found four more readers that were quadratic on long runs (test_patterns_linear.py).
Here each kind of long line (200 k characters of digits, spaces, words, comment, KEY=VALUE,
a configuration value ...) goes into the middle (or the configuration tail) of a real
PrusaSlicer file and through the whole command, with the fuzz oracle's checks (check_case:
exit code, message naming file and line, input untouched, output verified).  Each took
0.1-0.8 s (compiled) and 0.2-2.4 s (pure Python) at 500 k characters when written; a hang
is reported after test_fuzz.HANG_T (60 s)."""
import os

import pytest

from test_fuzz import OK, REFUSED, check_case

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
N = 200_000
SHAPES = {
    "digits": b"G1 X" + b"1" * N + b" Y10 E0.1",
    "digits_then_bad_arc": b"G1 X" + b"1" * N + b"G3 Xinf Y100.000 R1 E0.4",
    "spaces": b"G1 X10" + b" " * N + b"Y10 E0.1",
    "comment": b"G1 X10 Y10 E0.1 ;" + b"a" * N,
    "words": b"G1" + b" X1" * (N // 3),
    "words_no_space": b"G1" + b"X1" * (N // 2),
    "keyval": b"SET_VELOCITY_LIMIT " + b"a" * N,
    "keyval_value": b"SET_VELOCITY_LIMIT ACCEL=" + b"1" * N,
    "m204": b"M204 S" + b"1" * N,
    "feature": b";TYPE:" + b"x" * N,
    "dots": b"G1 X" + b"." * N,
    "fraction": b"G1 X1." + b"0" * N + b"1 Y2 E.1",
    "tabs": b"G1\t" + b"\t" * N + b"X1",
    "carriage_returns": b"G1 X1 Y1 E0.1" + b"\r" * N,
    "non_ascii_comment": "G1 X1 ;".encode() + "é".encode() * (N // 2),
    "layer_z": b";LAYER_CHANGE\n;Z:" + b"9" * N,
    "arc_offset": b"G2 X10 Y10 I" + b"5" * N + b" J0 E0.1",
    "config_value": b"; fill_density = 1" + b" " * N + b"%",
    "line_number": b"N" + b"1" * N + b" G1 X1",
    "checksum": b"G1 X1*" + b"9" * N,
}


@pytest.fixture(scope="module")
def sample_lines():
    with open(os.path.join(ROOT, "sample_gcode", "prusa_gyroid.gcode"), "rb") as fh:
        return fh.read().split(b"\n")


@pytest.mark.parametrize("name", sorted(SHAPES))
def test_long_line_is_processed_or_refused(name, sample_lines):
    lines = list(sample_lines)
    # the configuration block is read from the file's tail; every other line in mid-print
    lines.insert(len(lines) - 5 if name == "config_value" else len(lines) // 2, SHAPES[name])
    cat, detail = check_case(b"\n".join(lines), "prusa-mk3s", False)
    assert cat in (OK, REFUSED), f"{name}: {cat}: {detail}"
