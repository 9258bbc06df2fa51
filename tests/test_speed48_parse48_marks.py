"""The reader's comment marks by their bytes 1 and 2 first (issue 8, session 48;
gcode_opt/_reader.c marked, MARK_PAIR): a comment-only line is marked where, lowercased, it
starts with one of features._PREFIXES or _LAYER_MARKERS; a bitmap of the marks' bytes 1 and 2
(each | 0x20) refuses a line whose pair no mark has with one test, before the mark-by-mark
compare (the rewrite's own "; gcode-opt ..." comments, ~80 k lines of the rectilinear plate's
measure pass).  A mark shorter than 3 bytes turns the bitmap off (every line goes mark by mark).

Reference: the Python step (MachineState._step_python) against the compiled step line by line
(test_reader_core_bits.compare_lines), on comments that are marks in any case, near misses in
bytes 1 and 2 (a byte ^ 0x20: '_' and DEL, '[' and '{', which | 0x20 makes equal) and after
them, cut short (0 to all bytes), with the marks features.py has and with short marks added."""
from __future__ import annotations

import random

import pytest

from gcode_opt import features
from gcode_opt import state as st

from test_reader_core_bits import PROFILES, Counter, compare_lines

pytestmark = pytest.mark.skipif(st._reader is None, reason="the compiled reader is not built here")

OTHERS = ("; gcode-opt end", "; gcode-opt begin: replaces 1 lines", ";WIPE_START", ";WIDTH:0.45", ";", ";;",
          "; ", ";l", ";L", ";t", "; f", ";\x7f", ";_", ";{", ";[")


def _twin(c):
    """a byte | 0x20 leaves as it is: c ^ 0x20 where that is printable ASCII, else c"""
    d = chr(ord(c) ^ 0x20)
    return d if " " <= d <= "~" or d == "\x7f" else c


def _comment(rng, marks):
    t = rng.choice(marks + OTHERS)
    t = "".join(c.upper() if rng.random() < 0.4 else c for c in t)
    if rng.random() < 0.3 and len(t) > 1:              # a near miss, in bytes 1 and 2 mostly
        i = rng.choice([1, 2]) if len(t) > 2 and rng.random() < 0.7 else rng.randrange(1, len(t))
        t = t[:i] + rng.choice([_twin(t[i]), chr(ord(t[i]) ^ 1), "_", "\x7f"]) + t[i + 1:]
    if rng.random() < 0.2:
        t = t[:rng.randint(0, len(t))]
    return t + rng.choice(["", "", " x", "Perimeter", " 1", "  "]) + rng.choice(["\n", "\n", "\r\n", ""])


def _lines(rng, marks, n):
    lines = ["G90\n", "M83\n"]
    for _ in range(n):
        lines.append(_comment(rng, marks) if rng.random() < 0.8 else f"G1 X{rng.randint(1, 99)} E0.1\n")
    return lines


def _setup_reader():
    st._reader.setup(st.Move, st.MachineState, features.TRAVEL, st.LINE, st.EONLY, st.MAX_POS_D, st.MAX_E_D,
                     st.MAX_F, st.MAX_ACCEL_A, st.COMMANDS_READ)


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
@pytest.mark.parametrize("seed", range(3))
def test_marks_read_as_python(prof, seed, monkeypatch):
    cnt = Counter(monkeypatch)
    rng = random.Random(4840 + seed)
    marks = features._PREFIXES + features._LAYER_MARKERS
    diff = compare_lines(_lines(rng, marks, 4000), PROFILES[prof](), cnt.py)
    assert diff is None, diff


@pytest.mark.parametrize("short", [(";w",), (";",), (";t", "; f")])
def test_short_marks_read_as_python(short, monkeypatch):
    """marks of 1 or 2 bytes (the bitmap off), as a layer marker and as a feature prefix"""
    cnt = Counter(monkeypatch)
    rng = random.Random(4850 + len(short))
    try:
        with monkeypatch.context() as m:
            m.setattr(features, "_LAYER_MARKERS", features._LAYER_MARKERS + short[:1])
            m.setattr(features, "_PREFIXES", features._PREFIXES + short[1:])
            _setup_reader()
            marks = features._PREFIXES + features._LAYER_MARKERS
            diff = compare_lines(_lines(rng, marks, 3000), PROFILES["prusa-mk3s"](), cnt.py)
    finally:
        _setup_reader()
    assert diff is None, diff
