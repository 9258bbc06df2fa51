"""Round 34 (analyse): the compiled reader's word scan without bounds, and native's header scan.

_reader.c's read_words scans a line whose code ends in its line ending ('\\n' or '\\r': the
common line, no comment) with loops that test no bound (that last character stops each);
any other line with the bounded loops.  Both must read every line as the Python reader
does: the line shapes at and around the code's end (a value, a sign, a point, a letter,
blanks just before the ending; each ending, or none; a comment after) against
MachineState._step_python, as tests/test_reader_core_bits.py compares them.

native._include_names must find the names _LOCAL_INCLUDE.findall finds (the pattern tried
only where a line's first character other than a blank is a "#")."""
from __future__ import annotations

import itertools
from pathlib import Path

import pytest

from gcode_opt import native
from gcode_opt import state as st
from gcode_opt.profile import load_profile
from tests.test_reader_core_bits import Counter, compare_lines

PKG = Path(native.__file__).resolve().parent

# the code's last word, as it may end: every shape the scan's loops stop on
LAST_WORDS = ["X1", "X12.5", "X-.5", "X+7", "X5.", "X.", "X-", "X", "X1.2.3", "X1-2", "X1+", "X-0", "X.0001",
              "X123456789012345678901", "X1e3", "E.31702", "E-.04", "F4800", "Z0.2"]
ENDINGS = ["\n", "\r\n", "\r", "", " \n", "\t\n", " ; c\n", ";c\n", "\n\r", " \r\n", "\r\r\n"]


def lines_ending_in_every_shape():
    out = []
    for word, end in itertools.product(LAST_WORDS, ENDINGS):
        out += [f"G1 {word}{end}", f"G1 X3 Y4 {word}{end}", f"G0 Y2{word[1:]}{end}", f"M204 S{word[1:]}{end}"]
    out += ["G1\n", "G1 \n", "G1 X1 Y\n", "G1 X1 E\n", "G1  X1\tY2 \t\n", "G1 X1Y2\n", "G1 X1 X2\n", "M204\n",
            "M204 S\n", "G1\r\n", "G1 X1 E\r"]
    return out


@pytest.mark.skipif(st._reader is None, reason=f"the compiled reader is not built here ({st.CORE_WHY})")
@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_line_ends_read_as_python_reads_them(prof, monkeypatch):
    cnt = Counter(monkeypatch)
    lines = lines_ending_in_every_shape()
    diff = compare_lines(lines, load_profile(prof), cnt.py)
    assert diff is None, diff
    # the compiled path read the well-formed lines itself (~330 of them; most ending in "\n": the
    # unbounded scan), the rest went to Python
    assert len(lines) - cnt.n >= 300, (cnt.n, len(lines))
    for prefix in (["G91\n"], ["M83\n"], ["G92 X-0.0 E5\n"]):
        diff = compare_lines(prefix + lines, load_profile(prof), cnt.py)
        assert diff is None, diff


INCLUDE_TEXTS = [b"", b'#include "a.h"', b'  #  include "a.h"\n#include "b.h"\n', b'// #include "a\n#include "b.h"\n',
                 b'#include "a\n#include "b.h"\n', b'x #include "q.h"\n\t#include "r.h"',
                 b'#include <x.h>\n #include "y.h" // c\n', b'#include "a.h"#include "b.h"\n#include "c.h"',
                 b'\r\n#include "a.h"\r\n#include "b.h"', b'##include "a.h"\n# include  "b"\n', b'#\n#\n#include "z"\n']


@pytest.mark.parametrize("text", INCLUDE_TEXTS + [p.read_bytes() for p in sorted(PKG.rglob("*.[ch]"))])
def test_include_names_are_findalls(text):
    assert native._include_names(text) == native._LOCAL_INCLUDE.findall(text)
