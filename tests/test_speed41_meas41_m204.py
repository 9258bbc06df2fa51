"""The fused reader's shortcut for the rewrite's own M204 line (issue 8, session 41;
gcode_opt/_reader.c sess_m204_s): "M204 S<digits>[.<digits>]" and the line's LF, read in a
live session without read_words and sess_m204's general steps.  The measure pass (Sim.play_buf)
and the analyse loops (fused_line of the M204s between runs) must read every M204 as the
Python step reads it: the value's bits (float() of the text), print and travel set and
retract left, in every flavour; and every other shape (a sign, an exponent, 16 digits or
more, a blank or a comment after the value, a second word, two blanks, CR LF, a value out
of (0, MAX_ACCEL_A]) left to the general path, with the same result.

References: the Python step (MachineState._step_python) line by line for the measure loop
(test_speed36_reader_lines._python_play), test_speed_analyse2_runs' line-by-line analyse."""
from __future__ import annotations

import random

import pytest

from gcode_opt import state as st
from gcode_opt.firmware import simulate as fw

from test_speed28_measure_buf import _run
from test_speed36_reader_lines import _python_play
from test_speed_analyse2_runs import COMPILED, _same
from test_speed_measure_fused import PROFILES

pytestmark = pytest.mark.skipif(st._reader is None or fw._core is None or not hasattr(fw._core.Sim, "play_buf"),
                                reason="the compiled reader and firmware core are not built here")


def _value(rng):
    """An M204 value's text: mostly the rewrite's ("800", "3.4", "0.1"), and the edges of the
    shortcut's rule (digits either side of the point, 15 and 16 digits, leading zeros)."""
    r = rng.random()
    if r < 0.5:
        return f"{rng.uniform(0.05, 5000):.{rng.randint(0, 3)}f}".rstrip("0").rstrip(".") or "1"
    if r < 0.6:
        return rng.choice([".5", "5.", "0.1", "000123", "1500.50", "999999.9999", "1000000", "1000000.0",
                           "0.000000001", "7." + "1" * 13, "12345.678901234", "0." + "0" * 13 + "7",
                           "0" * 12 + "800", "0" * 17 + "800.5"])
    if r < 0.75:
        d = rng.randint(1, 6)                         # 15 or 16 digits in all, the point anywhere
        digits = "".join(rng.choice("0123456789") for _ in range(rng.choice([14, 15, 16])))
        return rng.choice("123456789") + digits[:d - 1] + "." + digits[d - 1:]
    if r < 0.8:
        return rng.choice(["+800", "0.1234567890123456789", "0.1" + "0" * 20])
    return str(rng.randint(1, 20000))


def _m204(rng):
    v = _value(rng)
    return rng.choices([f"M204 S{v}", f"M204 S{v} ", f"M204 S{v};c", f"M204 S{v} T{_value(rng)}",
                        f"M204  S{v}", f"M204 P{v} T{v}", f"M204 S{v}\t", f"M204 T{v} S{v}", f"M204 S{v} R5"],
                       weights=[12, 1, 1, 1, 1, 1, 1, 1, 1])[0]


def _file(tmp_path, seed, crlf=False):
    """Moves of every kind (print, travel, retract, E only) under M204s of every shape above."""
    rng = random.Random(4100 + seed)
    out = ["G21", "G90", "M83", ";TYPE:Perimeter", "G1 Z0.2 F600"]
    x = y = 100.0
    for i in range(1500):
        if rng.random() < 0.45:
            out.append(_m204(rng))
        x, y = x + rng.uniform(-3, 3), y + rng.uniform(-3, 3)
        kind = rng.random()
        if kind < 0.6:
            out.append(f"G1 X{x:.3f} Y{y:.3f} E{rng.uniform(0.01, 0.1):.5f} F{rng.randint(600, 6000)}")
        elif kind < 0.8:
            out.append(f"G1 X{x:.3f} Y{y:.3f} F9000")
        elif kind < 0.9:
            out.append(f"G1 E-{rng.uniform(0.2, 1):.2f} F2100")
        else:
            out.append(rng.choice([";TYPE:Internal infill", ";TYPE:Travel", "M107", "G4 P0", "G1 F1200"]))
    path = tmp_path / f"m204_{seed}.gcode"
    path.write_bytes(("\r\n" if crlf else "\n").join(out).encode() + b"\n")
    return str(path)


@pytest.mark.parametrize("prof", sorted(PROFILES))
@pytest.mark.parametrize("seed", range(3))
def test_measure_reads_m204s_as_python(tmp_path, prof, seed, monkeypatch):
    path = _file(tmp_path, seed)
    profile = PROFILES[prof]()
    ref = _python_play(path, profile, monkeypatch)
    for size in (64, 1 << 16):
        assert _run(path, profile, size, False, monkeypatch=monkeypatch) == ref, size


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_measure_reads_crlf_m204s_as_python(tmp_path, prof, monkeypatch):
    """CR LF lines (play_buf's lf false): the shortcut takes none of them"""
    path = _file(tmp_path, 7, crlf=True)
    profile = PROFILES[prof]()
    assert _run(path, profile, 1 << 16, False, monkeypatch=monkeypatch) == _python_play(path, profile, monkeypatch)


@pytest.mark.skipif(not COMPILED, reason="the compiled model and reader are not built")
@pytest.mark.parametrize("seed", range(2))
def test_analyse_reads_m204s_as_the_reference(tmp_path, seed):
    _same(_file(tmp_path, seed), ["prusa-mk3s", "voron24"][seed])


@pytest.mark.parametrize("raw", ["M204 S0\n", "M204 S0.0\n", "M204 S1000000.1\n", "M204 S2000000\n", "M204 S.\n",
                                 "M204 S\n", "M204 S-5\n", "M204 S8e2\n",
                                 "M204 S800.0.0\n", "M204 S0x10\n", "M204 S1" + "0" * 20 + "\n"])
@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_refused_values_as_python(tmp_path, raw, prof, monkeypatch):
    """A value Python refuses (out of (0, MAX_ACCEL_A], or no number) after moves in a live
    session: the measure loop raises the same error, or gives the same result."""
    path = tmp_path / "refused.gcode"
    path.write_text("M83\nM204 S800\nG1 X5 Y5 E1\nG1 X6 Y5 E1\n" + raw + "G1 X7 Y5 E1\nM204 S900\nG1 X8 Y5 E1\n")
    profile = PROFILES[prof]()
    outs = []
    for play in (lambda: _python_play(str(path), profile, monkeypatch),
                 lambda: _run(str(path), profile, 1 << 16, False, monkeypatch=monkeypatch)):
        try:
            outs.append(("ok", play()))
        except Exception as e:       # noqa: BLE001 -- the same exception, whatever it is
            outs.append((type(e).__name__, str(e)))
    assert outs[0] == outs[1]
