"""Sim.play_buf's line split, 16 bytes at a time (issue 8, session 41; firmware/_core.c
src_next_buf): in a block with no CR it finds a line's '\\n' and whether its bytes are ASCII
in one pass over whole 16-byte pieces, the rest by memchr and the 8-byte loop as before.  The
lines must be read_lines' (a non-ASCII line decoded as UTF-8 with surrogateescape, an ASCII
one copied): lines of every length around the 16-byte pieces, a byte >= 0x80 anywhere in a
line, just before or just after its '\\n' (the next line's), in the piece that holds the '\\n'
or an earlier one, near the block's end and in long lines.

Reference: st.read_lines; the lines play_buf hands a Python step (which reads every line:
test_speed28_measure_buf._blocks_lines), and the measure loop against the Python step."""
from __future__ import annotations

import random

import pytest

from gcode_opt import state as st
from gcode_opt.firmware import simulate as fw

from test_speed28_measure_buf import _blocks_lines, _run
from test_speed36_reader_lines import _python_play
from test_speed_measure_fused import PROFILES

pytestmark = pytest.mark.skipif(fw._core is None or not hasattr(fw._core.Sim, "play_buf"),
                                reason="the compiled firmware core is not built here")


def _bytes(rng, n_lines):
    out = bytearray()
    for _ in range(n_lines):
        n = rng.choice([0, 1, 2, rng.randint(3, 14), 15, 16, 17, rng.randint(18, 47), 31, 32, 33, rng.randint(48, 200)])
        line = bytearray(rng.choice(b"G1 XYE.0123456789;") for _ in range(n))
        if n and rng.random() < 0.3:                   # a non-ASCII byte somewhere in the line
            line[rng.randrange(n)] = rng.choice([0x80, 0xc3, 0xe9, 0xff])
            if rng.random() < 0.5 and n > 1:            # (a whole UTF-8 character too)
                p = rng.randrange(n - 1)
                line[p:p + 2] = "é".encode()
        out += line + b"\n"
    return bytes(out)


@pytest.mark.parametrize("seed", range(4))
def test_lines_as_read_lines(tmp_path, seed, monkeypatch):
    rng = random.Random(4300 + seed)
    data = _bytes(rng, 1500) + rng.choice([b"", b"G1 X1", b"\xe9\xe9 no end", b"x" * 40])
    path = tmp_path / f"split{seed}.gcode"
    path.write_bytes(data)
    ref = list(st.read_lines(str(path)))
    for size in (17, 64, 1000, 1 << 16):
        monkeypatch.setattr(fw, "BLOCK_BYTES", size)
        assert _blocks_lines(str(path)) == ref, size


def test_measure_with_non_ascii_lines_as_python(tmp_path, monkeypatch):
    """Moves with non-ASCII comments (the line to the Python step) and ASCII ones (read in
    C) side by side, each kind just before the other's '\\n'."""
    rng = random.Random(4400)
    out = ["G21", "G90", "M83", "M204 S1000", ";TYPE:Perimeter"]
    x = 100.0
    for i in range(1500):
        x += rng.uniform(-2, 2)
        move = f"G1 X{x:.3f} Y{100 + i % 7} E0.05"
        out.append(move + rng.choice(["", "", " ;é", ";\u00ff", " ; ok", ";" + "é" * rng.randint(1, 9)]))
    path = tmp_path / "nonascii.gcode"
    path.write_text("\n".join(out) + "\n", encoding="utf-8")
    profile = PROFILES["prusa-mk3s"]()
    assert _run(str(path), profile, 1 << 16, False, monkeypatch=monkeypatch) == _python_play(str(path), profile,
                                                                                             monkeypatch)
