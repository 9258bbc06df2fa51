"""The model's per-line calls inlined (session 39): src_next_buf into play_loop (the line's
bounds and its ASCII test: 8 bytes at a time, the last 8 again), play_fused into play_loop,
run_lines and gap_lines, linear_calc and fill_fused into the fused readers.  The same
lines, moves and figures as the 9bb98a8 per-line loop (test_speed_measure_loop._ref_play):
a byte that is not ASCII at every place of lines 2 to 24 bytes long (each side of the
8-byte steps), in the code (the Python step reads it) and in a comment, among G1 (XY, Z or E alone)
and M204 lines, played through play_buf at block sizes that cut the lines anywhere."""
from __future__ import annotations

import pytest

from gcode_opt import state as st
from gcode_opt.firmware import simulate as fw
from gcode_opt.profile import load_profile

from test_speed28_measure_buf import _run

pytestmark = pytest.mark.skipif(fw._core is None or not hasattr(fw._core.Sim, "play_buf"),
                                reason="the compiled firmware core is not built here")


def _lines():
    out = [b"G90\n", b"M83\n", b"M204 S1000\n"]
    x = 0
    for n in range(1, 25):
        for at in range(n):        # (first too: "é1" is an unknown command since words' ASCII fix)
            x += 1
            base = (b"G1 X%d Y%d E.01 ;" % (x % 97, x % 89) + b"c" * 30)[:n]
            if len(base) < n:
                base += b"c" * (n - len(base))
            line = base[:at] + b"\xc3\xa9"[: 1 if at % 3 else 2] + base[at + 1:]
            out.append(line + b"\n")
            out.append(b"G1 X%d Y%d E.02\n" % (x % 83, x % 79))
            if x % 5 == 0:
                out.append(b"M204 S%d\n" % (500 + x % 700))
            if x % 7 == 0:                   # a Z move alone, and an E move alone
                out.append(b"G1 Z%d.2\nG1 E-.8\nG1 E.8\n" % (x % 9))
    return b"".join(out)


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_non_ascii_anywhere_as_per_line_loop(tmp_path, prof, monkeypatch):
    path = str(tmp_path / "na.gcode")
    with open(path, "wb") as fh:
        fh.write(_lines())
    profile = load_profile(prof)

    def outcome(ref, size):
        try:
            return _run(path, profile, size, ref, None, monkeypatch)
        except st.GcodeError as e:       # (a line the reader refuses: the same error)
            return str(e)

    ref = outcome(True, 0)
    for size in (7, 50, 1 << 16):
        assert outcome(False, size) == ref, size
