"""The fused readers' shortcut for a command line (issue 8, session 36; gcode_opt/_reader.c):
a line of the fused loops with no CR (lf) that a command starts -- its first character
neither a blank nor a ';' -- is read without line_shape's look for its ';' (command_line):
read_words reads the code up to a ';' itself, and code_len finds the ';' only for a line
that goes on to noop_command.  The measure pass (Sim.play_buf: fused_line_ascii) and the
analyse loops (run_lines, gap_lines: fused_peek_ascii) must read such lines as the Python
step does: code and comment, a ';' right after the command or a word, a blank or a tab
before the comment, lowercase and short lines, commands the reader skips or hands on.

References: the Python step (MachineState._step_python) line by line for the measure loop
(test_speed_measure_loop._ref_play), test_speed_analyse2_runs' line-by-line analyse."""
from __future__ import annotations

import random

import pytest

from gcode_opt import state as st
from gcode_opt.firmware import simulate as fw

from test_speed28_measure_buf import _run
from test_speed_analyse2_runs import COMPILED, _random_file, _same
from test_speed_measure_fused import PROFILES

pytestmark = pytest.mark.skipif(st._reader is None or fw._core is None or not hasattr(fw._core.Sim, "play_buf"),
                                reason="the compiled reader and firmware core are not built here")

# commands with their comments in the shapes command_line takes (and a few it leaves to
# line_shape: a blank or a ';' first), the code's words read or not (a word given twice,
# which the Python step raises for: test_hand_lines_as_python)
_CODES = ["G1 X{x} Y{y} E0.05", "G1 X{x} Y{y}", "G1 E-0.8", "G1 F2400", "G0 X{x} Y{y} F9000", "M204 S{a}",
          "M204 P{a} T{a}", "M107", "M73 P5 R12", "G92 E0", "M83", "G4 P0", "T0", "M106 S255", "g1 x{x} y{y}",
          "G1 X{x} Y{y} Q1", "M204", "G1", "M2", "G1X{x}", "M204S{a}", "G1 X{x}*5"]
_TAILS = ["", " ; note", ";c", "\t; tab first", " ;", ";;", "  ;TYPE:Perimeter", "; G1 X5 Y5", " \t "]


def _line(rng, x, y):
    code = rng.choice(_CODES).format(x=f"{x:.3f}", y=f"{y:.3f}", a=rng.choice([800, 1500.5, 2500]))
    line = code + rng.choice(_TAILS)
    if rng.random() < 0.05:
        line = rng.choice([" ", "\t", ";"]) + line        # (line_shape's lines)
    return line


def _file(tmp_path, seed):
    """A random file of moves (test_speed_analyse2_runs._random_file) with command lines
    of every shape above between them, LF only (lf: the shortcut runs)."""
    rng = random.Random(3600 + seed)
    out = []
    x = y = 100.0
    for line in _random_file(rng, 3000).split("\n"):
        out.append(line)
        if rng.random() < 0.3:
            x, y = x + rng.uniform(-1, 1), y + rng.uniform(-1, 1)
            out.append(_line(rng, x, y))
    f = tmp_path / f"shapes{seed}.gcode"
    f.write_text("\n".join(out) + "\n")
    return str(f)


def _python_play(path, profile, monkeypatch):
    """_run's reference loop, every line read by the Python step"""
    with monkeypatch.context() as m:
        m.setattr(st.MachineState, "step", st.MachineState._step_python)
        return _run(path, profile, 0, True)


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
@pytest.mark.parametrize("seed", range(3))
def test_measure_play_reads_command_lines_as_python(tmp_path, prof, seed, monkeypatch):
    path = _file(tmp_path, seed)
    profile = PROFILES[prof]()
    ref = _python_play(path, profile, monkeypatch)
    for size in (64, 1 << 16):
        assert _run(path, profile, size, False, monkeypatch=monkeypatch) == ref, size


def test_measure_play_reads_the_shapes_in_c(tmp_path, monkeypatch):
    """The lines the shortcut takes stay in C: a G1 or M204 with a comment, a command the
    reader skips; a mutant that sent them to Python would still pass the test above."""
    text = "M83\n" + "".join(f"G1 X{i} Y1 E0.1 ; c{i}\nM204 S{800 + i};x\nM107\t;fan\n" for i in range(1, 40))
    path = tmp_path / "c.gcode"
    path.write_text(text)
    seen = []
    py = st.MachineState._step_python

    def counted(state, idx, raw):
        seen.append(raw)
        return py(state, idx, raw)
    monkeypatch.setattr(st.MachineState, "_step_python", counted)
    _run(str(path), PROFILES["prusa-mk3s"](), 1 << 16, False, monkeypatch=monkeypatch)
    assert seen == ["M83\n"]


@pytest.mark.skipif(not COMPILED, reason="the compiled model and reader are not built")
@pytest.mark.parametrize("seed", range(3))
def test_analyse_reads_command_lines_as_the_reference(tmp_path, seed):
    _same(_file(tmp_path, seed), ["prusa-mk3s", "voron24", "ender3"][seed])


@pytest.mark.parametrize("raw", ["G1 X1 X2 ; c\n", "G1 X1 X2;\n", "M204 S-5 ;c\n", "G1 X1e400;\n", "M204 S0\t;\n"])
def test_hand_lines_as_python(tmp_path, raw, monkeypatch):
    """A line the Python step raises for, after a comment-less and a commented move: the
    measure loop raises the same error (the fused reader hands the line on untouched)."""
    path = tmp_path / "raise.gcode"
    path.write_text("M83\nG1 X5 Y5 E1\nG1 X6 Y5 E1 ;c\n" + raw + "G1 X7 Y5 E1\n")
    profile = PROFILES["prusa-mk3s"]()
    errs = []
    for play in (lambda: _python_play(str(path), profile, monkeypatch),
                 lambda: _run(str(path), profile, 1 << 16, False, monkeypatch=monkeypatch)):
        try:
            play()
            errs.append(None)
        except Exception as e:       # noqa: BLE001 -- the same exception, whatever it is
            errs.append((type(e).__name__, str(e)))
    assert errs[0] is not None and errs[0] == errs[1]
