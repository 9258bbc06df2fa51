"""The reader's test of a comment line's marks by their first four bytes (issue 8, session 43;
gcode_opt/_reader.c marked): a comment-only line is marked where, lowercased, it starts with
one of features._PREFIXES or _LAYER_MARKERS; the line's first four bytes, each | 0x20, are
compared with each mark's as one word first, and only a mark whose word agrees is compared
byte by byte.  The rewrite's own comments ("; gcode-opt begin: ...", ~80 k lines in the
rectilinear plate's measure pass) are refused by the words alone.

References: the Python step (MachineState._step_python) against the compiled step line by
line (test_reader_core_bits.compare_lines), and the measure loop (Sim.play_buf) against the
Python step (test_speed36_reader_lines._python_play): marks in every case, near misses
(one byte off in the first four and after them, '_' and DEL, which | 0x20 makes equal),
lines of 0 to 5 bytes, a mark's text after blanks or code."""
from __future__ import annotations

import random

import pytest

from gcode_opt import features
from gcode_opt import state as st
from gcode_opt.firmware import simulate as fw

from test_reader_core_bits import PROFILES, Counter, compare_lines
from test_speed28_measure_buf import _run
from test_speed36_reader_lines import _python_play

pytestmark = pytest.mark.skipif(st._reader is None, reason="the compiled reader is not built here")

MARKS = features._PREFIXES + features._LAYER_MARKERS
NAMES = ["perimeter", "External perimeter", "Internal infill", "wipe", "", " skirt ", "x"]


def _recase(rng, t):
    return "".join(c.upper() if rng.random() < 0.4 else c for c in t)


def _near(rng, t):
    """t with one byte changed: within its first four bytes or after them"""
    i = rng.randrange(min(len(t), 4)) if rng.random() < 0.6 else rng.randrange(len(t))
    c = rng.choice(["\x7f", "_", "?", "@", "[", "`", "{", " ", chr(ord(t[i]) ^ 0x20), chr(ord(t[i]) ^ 1)])
    return t[:i] + c + t[i + 1:]


def _comment(rng):
    r = rng.random()
    mark = rng.choice(MARKS)
    if r < 0.3:
        return _recase(rng, mark) + rng.choice(NAMES)
    if r < 0.5:
        return _near(rng, mark) + rng.choice(NAMES)
    if r < 0.6:
        return _recase(rng, mark[:rng.randint(0, len(mark))])
    if r < 0.7:
        return ";" + "".join(rng.choice(";_ \x7fTtLlAa:") for _ in range(rng.randint(0, 4)))
    if r < 0.8:
        return rng.choice([" ", "\t", "  "]) + _recase(rng, mark) + rng.choice(NAMES)
    if r < 0.9:
        return rng.choice(["; gcode-opt begin: replaces 1 lines, kind=line", "; gcode-opt end", ";WIPE_START",
                           ";WIDTH:0.45", "; stop printing object", "M107 " + mark])
    return "G1 X1 " + mark + "x"


def _text(rng, n):
    out = ["G90", "M83", "G1 Z0.2 F600"]
    for i in range(n):
        out.append(_comment(rng) if rng.random() < 0.6 else f"G1 X{i % 97 + 1}.5 Y{i % 89 + 2} E0.05")
    return out


@pytest.mark.parametrize("seed", range(3))
def test_step_reads_marks_as_python(seed, monkeypatch):
    cnt = Counter(monkeypatch)
    rng = random.Random(4330 + seed)
    lines = [ln + rng.choice(["\n", "\n", "\r\n", ""]) for ln in _text(rng, 3000)]
    diff = compare_lines(lines, PROFILES["prusa-mk3s"](), cnt.py)
    assert diff is None, diff


@pytest.mark.skipif(fw._core is None or not hasattr(fw._core.Sim, "play_buf"),
                    reason="the compiled firmware core is not built here")
@pytest.mark.parametrize("seed", range(2))
def test_measure_reads_marks_as_python(tmp_path, seed, monkeypatch):
    rng = random.Random(4340 + seed)
    path = tmp_path / f"marks{seed}.gcode"
    path.write_text("\n".join(_text(rng, 2000)) + "\n")
    profile = PROFILES["prusa-mk3s"]()
    assert _run(str(path), profile, 1 << 16, False, monkeypatch=monkeypatch) == _python_play(str(path), profile,
                                                                                             monkeypatch)
