"""read_words' shortcut for a line of usual words (issue 8, session 41; gcode_opt/_reader.c
usual_words): an ended line (LF or CR last) whose words are each one blank, a letter not seen
yet, an optional '-' and digits[.digits] (1 to 15 digits), the code ending at the line's
ending, is read without read_words_in's general steps.  Every value must be float()'s of its
text, and every other shape -- 16 digits and more, '+', an exponent, a second point, a sign
inside, two blanks, a tab, a comment, a letter twice, no digit -- the general steps' (the
same value, or the same refusal: Python's error).

References: the Python step (MachineState._step_python) against the compiled step line by
line (test_reader_core_bits.compare_lines: Moves and states bit for bit), and the measure
loop (Sim.play_buf) against the Python step (test_speed36_reader_lines._python_play)."""
from __future__ import annotations

import random

import pytest

from gcode_opt import state as st
from gcode_opt.firmware import simulate as fw

from test_reader_core_bits import PROFILES, Counter, compare_lines
from test_speed28_measure_buf import _run
from test_speed36_reader_lines import _python_play

pytestmark = pytest.mark.skipif(st._reader is None, reason="the compiled reader is not built here")


def _number(rng):
    """A value's text: the usual ones, and the edges of the shortcut's rule (15 and 16
    digits, the top ones above 2^53, leading zeros, no digit before or after the point)."""
    r = rng.random()
    sign = "-" if rng.random() < 0.2 else ""
    if r < 0.4:
        return sign + f"{rng.uniform(0, 250):.{rng.randint(0, 5)}f}"
    if r < 0.5:
        t = f"{rng.uniform(0, 1):.{rng.randint(1, 5)}f}"
        return sign + (t[1:] if t.startswith("0.") else t)          # ".0429"
    if r < 0.75:
        n = rng.choice([14, 15, 15, 16, 16, 17])
        digits = rng.choice(["9", "8", "1"]) + "".join(rng.choice("0123456789") for _ in range(n - 1))
        p = rng.randint(0, n)
        return sign + digits[:p] + "." + digits[p:] if p < n else sign + digits
    if r < 0.85:
        return sign + rng.choice(["0", "0.", ".0", "5.", "000123.5", "0" * 20 + "1", "1" + "0" * 14,
                                  "9007199254740993", "900719925474099.3", "0.000000000000001"])
    return rng.choice(["+5", "1e3", "1.2.3", "1-2", ".", "-", "-.", "", "--1", "5+", "1E2", "0x1"])


def _line(rng):
    words = rng.sample("XYZEF", rng.randint(1, 5))
    body = "".join(f" {c}{_number(rng)}" for c in words)
    r = rng.random()
    if r < 0.08:
        body = body.replace(" ", "  ", 1)
    elif r < 0.12:
        body = body.replace(" ", "\t", 1)
    elif r < 0.16:
        body += rng.choice([" ", ";c", " ; c", "\t"])
    elif r < 0.2:
        body += f" {words[0]}1"                                     # a letter twice
    end = rng.choice(["\n"] * 8 + ["\r\n", "\r", ""])
    return rng.choice(["G1", "G1", "G0"]) + body + end


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
@pytest.mark.parametrize("seed", range(3))
def test_step_reads_words_as_python(prof, seed, monkeypatch):
    cnt = Counter(monkeypatch)
    rng = random.Random(4141 + seed)
    lines = [rng.choice(["G90\n", "G91\n", "M83\n", "M82\n", "G92 E0\n"]) if rng.random() < 0.05 else _line(rng)
             for _ in range(3000)]
    diff = compare_lines(lines, PROFILES[prof](), cnt.py)
    assert diff is None, diff


@pytest.mark.skipif(fw._core is None or not hasattr(fw._core.Sim, "play_buf"),
                    reason="the compiled firmware core is not built here")
@pytest.mark.parametrize("seed", range(2))
def test_measure_reads_words_as_python(tmp_path, seed, monkeypatch):
    """A file of moves in the usual shapes (LF lines: the measure loop's), values of every
    length: the measure loop's blocks, sums and state as the Python step's."""
    rng = random.Random(4200 + seed)
    out = ["G21", "G90", "M83", "M204 S1000", "G1 Z0.2 F600"]
    x = y = 100.0
    for _ in range(2000):
        x, y = x + rng.uniform(-2, 2), y + rng.uniform(-2, 2)
        xs, ys = (f"{v:.{rng.randint(0, 14)}f}" for v in (x, y))
        e = f"{rng.uniform(0.001, 0.1):.{rng.randint(1, 14)}f}"
        out.append(rng.choice([f"G1 X{xs} Y{ys} E{e[1:] if rng.random() < 0.5 else e}",
                               f"G1 X{xs} Y{ys} E{e} F{rng.randint(600, 6000)}", f"G1 X{xs} Y{ys} F9000",
                               f"G1 E-{e} F2100", f"G1 Y{ys} X{xs} E{e}", f"G1 X{xs}  Y{ys} E{e}",
                               f"G1 X{xs} Y{ys} E{e} ;c"]))
    path = tmp_path / f"words{seed}.gcode"
    path.write_text("\n".join(out) + "\n")
    profile = PROFILES["prusa-mk3s"]()
    assert _run(str(path), profile, 1 << 16, False, monkeypatch=monkeypatch) == _python_play(str(path), profile,
                                                                                             monkeypatch)
