"""The compiled reader answers two more kinds of line itself (issue 8, session 32), the same
bits as the Python step:

- a classic command _step_python does not read (state.COMMANDS_READ: "M73 P5", "M107",
  "T0", "M862.3 P ..."): None, nothing changed (_reader.c noop_command); the analyse
  loops (Sim.gap_lines) and the measure loop read past it;
- a comment a feature or layer marker starts: the feature features.feature_from_comment
  gives, or layer + 1 (_reader.c marked_comment); state.feature_seen tells analyse a
  feature comment was read where its per-line check did not see it.

The reference is MachineState._step_python (what the compiled step handed these lines
to before) and test_speed_analyse2_runs' line-by-line analyse."""
from __future__ import annotations

import inspect
import random
import re

import pytest

from gcode_opt import features as feat
from gcode_opt import state as st
from gcode_opt.profile import load_profile
from gcode_opt.state import MachineState
from test_speed_analyse2_runs import COMPILED, _random_file, _same
from test_speed_measure_reader import Counter, compare

needs_reader = pytest.mark.skipif(st._reader is None, reason="the compiled reader is not built")


def test_commands_read_names_every_command_the_python_step_reads():
    """COMMANDS_READ must hold every command name _step_python and _other compare with: a
    command added there but not here would be skipped by the compiled reader."""
    src = inspect.getsource(MachineState._step_python) + inspect.getsource(MachineState._other)
    named = set(re.findall(r'"([A-Z][0-9]+(?:\.[0-9]+)?)"', src)) | st._WAITS
    assert named and named <= st.COMMANDS_READ, named - st.COMMANDS_READ
    assert {"G0", "G1", "G92", "M204", "M400", "G28"} <= st.COMMANDS_READ


_NOOP = ["M73 P5 R12", "M73 Q0 S359", "M107", "M106 S255", "T0", "T1", "G17", "M862.3 P \"MK3S\"", "M115 U3.13.0",
         "m73 p5", "M073 P1", "M0073", "G0.5 X1", "G1.5", "M117 hello world", "M104 S215", "M140 S60", "M84",
         "G10.5", "M2040", "M2 ", "G4.0 P1", "M73P5", "M107\t", "M900 K0.05", "M486 S1"]
_PYTHON = ["M3000000000", "M30000000000000000000000", "G00000", "T", "G92 E0", "G90", "G91", "M82", "M83", "G20",
           "G21", "M204 S800", "M201 X1000", "M203 X200", "M205 X8 Y8", "M221 S95", "M220 S90", "G10", "G11",
           "G4 P10", "G28", "M400", "M109 S200", "G01 X1", "G000001 X2 Y2", "g1 x1", "G1 X1 X2", "M0", "M1",
           "M600", "N10 M73 P5", "M73 P5*12", "n3 M107", " M73 P5", "\tM107", "G29", "G80", "M226", "G34",
           "M190 S60", "M204 P1000 T1500", "G4", "M82 ", "M204"]


def _command_lines(rng, n):
    lines = []
    for _ in range(n):
        body = rng.choice(_NOOP + _PYTHON)
        lines.append(body + rng.choice(["\n", "\n", "\r\n", " ; note\n", ";TYPE:Perimeter\n", "", "  \n"]))
        if rng.random() < 0.3:
            lines.append(rng.choice(["G1 X1 Y2 E0.1\n", "G1 X2 Y3\n", "G1 E-0.8\n", ";TYPE:Solid infill\n",
                                     ";LAYER_CHANGE\n", "; FEATURE: Outer wall\n", ";type:nonsense\n"]))
    return lines


@needs_reader
@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24", "ender3"])
@pytest.mark.parametrize("seed", range(2))
def test_command_lines_as_python(prof, seed, monkeypatch):
    """Every command line (classic, read or not, odd shapes, line numbers, checksums,
    lowercase, leading zeros, fractions): the same result, state and errors as the Python
    step; a command the Python step does not read never reaches it."""
    rng = random.Random(seed)
    cnt = Counter(monkeypatch)
    lines = _command_lines(rng, 2000)
    compare(lines, load_profile(prof), cnt.py)
    noop = {raw for raw in lines if any(raw.startswith(b) and raw[len(b):][:1] in ("\n", "\r", " ", ";", "")
                                        for b in _NOOP)}
    assert len(noop) > 20
    assert not noop & set(cnt.lines)
    assert any(raw.startswith("N10 M73") for raw in cnt.lines)     # (line numbers: Python's)


@needs_reader
def test_noop_commands_stay_in_c_exactly(monkeypatch):
    """Which lines noop_command takes: a mutant that took a command Python reads, or
    skipped none, fails here."""
    cnt = Counter(monkeypatch)
    state = MachineState(load_profile("prusa-mk3s"), "f.gcode")
    for raw in ["M73 P5\n", "M107\n", "T0\n", "M862.3 P \"MK3S\"\n", "G17\n", "M073\n", "G0.5\n"]:
        assert st._reader.step(state, 3, raw) is None
    assert cnt.lines == []
    for raw in ["G92 E0\n", "N1 M73\n", "M73*3\n", " M107\n", "G01 X1\n", "M30000000000000000000000\n"]:
        st._reader.step(state, 3, raw)
    assert len(cnt.lines) == 6


def _with_noise(rng, text):
    """_random_file's lines with commands the reader skips and marked comments put
    between them (in runs, which they close, and between runs, where gap_lines reads)."""
    out = []
    for line in text.split("\n"):
        out.append(line)
        r = rng.random()
        if r < 0.04:
            out.append(rng.choice(["M73 P5 R12", "M107", "M106 S200", "T0", "G17", "m73 p1", "M117 x"]))
        elif r < 0.07:
            out.append(rng.choice([";TYPE:Perimeter", ";TYPE:Internal infill", ";LAYER_CHANGE", "; FEATURE: Sparse infill",
                                   ";TYPE:Nonsense", "; feature  ", ";layer:3"]))
    return "\n".join(out)


@pytest.mark.skipif(not COMPILED, reason="the compiled model and reader are not built")
@pytest.mark.parametrize("seed", range(6))
def test_analyse_with_skipped_lines_is_the_reference(tmp_path, seed):
    rng = random.Random(3200 + seed)
    f = tmp_path / f"noise{seed}.gcode"
    f.write_text(_with_noise(rng, _random_file(rng, 5000)))
    prof = ["prusa-mk3s", "voron24", "ender3"][seed % 3]
    kw = [dict(), dict(features=feat.ALL)][seed // 3]
    _same(str(f), prof, **kw)


@pytest.mark.skipif(not COMPILED, reason="the compiled model and reader are not built")
@pytest.mark.parametrize("text", [
    # the only feature comment where gap_lines reads (after a move eligible() refuses)
    "M83\nG1 X1 Y1\nG1 X2 Y1 E-1\nM73 P1\n;TYPE:Perimeter\nM107\nG1 X3 Y1 E1\nG1 X4 Y1 E1\nG1 X5 Y1 E1\n",
    # no feature comment at all, skipped commands between runs
    "M83\nG1 X1 Y1 E1\nG1 X2 Y1 E1\nM73 P1\nG1 X3 Y1 E1\nT0\nG1 X2 Y1 E-1\nM107\n; feature  \nG1 X3 Y2 E1\n",
    # a marked comment that names no feature after its strip, a layer marker
    "M83\n;TYPE:Perimeter\nG1 X1 Y1 E1\nG1 X2 Y1 E1\n;LAYER_CHANGE\nG1 X3 Y1 E1\n;type:  \nG1 X4 Y1 E1\n",
])
@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_analyse_feature_seen_is_the_reference(tmp_path, text, prof):
    f = tmp_path / "seen.gcode"
    f.write_text(text)
    for kw in (dict(), dict(features=feat.ALL), dict(features=("perimeter",))):
        _same(str(f), prof, **kw)
