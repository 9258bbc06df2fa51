"""The reader's target check at the range's edges (issue 8, session 62; gcode_opt/_reader.c
linear_calc): |X|, |Y|, |Z| <= MAX_POS_D and |E| <= MAX_E_D are tested as |v| <= bound (one
branch a line), where they were -b <= v <= b pairs.  A move at the bound, just past it, at
-0.0, past it on one axis only, or with E at or past its bound must still be read as the
Python step reads it (accepted, or sent to Python, whose _check_target raises or passes),
by the compiled step (linear) and by the measure loop's fused reads (Sim.play_buf).

References: the Python step (MachineState._step_python) line by line
(test_reader_core_bits.compare_lines), and the Python step's play (_python_play)."""
from __future__ import annotations

import random

import pytest

from gcode_opt import state as st
from gcode_opt.firmware import simulate as fw

from test_reader_core_bits import PROFILES, Counter, compare_lines
from test_speed28_measure_buf import _run
from test_speed36_reader_lines import _python_play

pytestmark = pytest.mark.skipif(st._reader is None, reason="the compiled reader is not built here")


def _edge(rng, bound, past=True):
    """a value at, inside or (past) just past bound, either sign, in the text forms a slicer
    writes"""
    b = int(bound)
    inside = [f"{b}", f"-{b}", f"{b}.0", f"-{b}.000", f"{b - 1}.999", "0", "-0", "-0.0", "12.5"]
    return rng.choice(inside + ([f"{b}.001", f"-{b}.001", f"{b + 1}", f"{b}.0000001"] if past else []))


def _edge_lines(rng, n, past=True):
    lines = []
    for _ in range(n):
        words = []
        for c in rng.sample("XYZE", rng.randint(1, 4)):
            if rng.random() < 0.5:
                words.append(f"{c}{_edge(rng, st.MAX_E_D if c == 'E' else st.MAX_POS_D, past)}")
            else:
                words.append(f"{c}{rng.uniform(-200, 200):.3f}")
        if rng.random() < 0.3:
            words.append(f"F{rng.choice([600, 1800, 7200])}")
        lines.append(rng.choice(["G1 ", "G0 "]) + " ".join(words) + "\n")
        if rng.random() < 0.2:   # back inside, so the next lines move from a usual place
            lines.append("G1 X10 Y10 Z0.2\n")
    return lines


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
@pytest.mark.parametrize("seed", range(2))
@pytest.mark.parametrize("modes", [("G90", "M83"), ("G90", "M82"), ("G91", "M83")])
def test_step_reads_range_edges_as_python(prof, seed, modes, monkeypatch):
    cnt = Counter(monkeypatch)
    rng = random.Random(6200 + seed)
    lines = [f"{modes[0]}\n", f"{modes[1]}\n", "M204 S1000\n"] + _edge_lines(rng, 800)
    diff = compare_lines(lines, PROFILES[prof](), cnt.py)
    assert diff is None, diff
    if modes[0] == "G91":
        return          # (relative targets: the sums, not the values, meet the bounds)
    # the compiled step reads every move inside the bounds itself (a value at a bound too):
    # Python reads the moves past them only
    past = sum(any(abs(float(w[1:])) > (st.MAX_E_D if w[0] == "E" else st.MAX_POS_D) for w in ln.split()[1:])
               for ln in lines[3:])
    # (the three mode lines may go to Python too, as the profile has it)
    assert past > 0 and past <= cnt.n <= past + 3, (cnt.n, past)


@pytest.mark.skipif(fw._core is None or not hasattr(fw._core.Sim, "play_buf"),
                    reason="the compiled firmware core is not built here")
@pytest.mark.parametrize("seed", range(2))
def test_measure_reads_range_edges_as_python(tmp_path, seed, monkeypatch):
    rng = random.Random(6210 + seed)
    path = tmp_path / f"edges{seed}.gcode"
    # (a line past a bound stops the Python play: _check_target raises; the step test has them)
    path.write_text("G90\nM83\nM204 S1000\n" + "".join(_edge_lines(rng, 600, past=False)))
    profile = PROFILES["prusa-mk3s"]()
    ref = _python_play(str(path), profile, monkeypatch)
    for size in (64, 1 << 16):
        assert _run(str(path), profile, size, False, monkeypatch=monkeypatch) == ref, size
