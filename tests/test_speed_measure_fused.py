"""Sim.play's fused loop: where the model's callbacks are the core's own (StrokeSums,
RowSink) and the state's step is the compiled reader's, the common lines are read by the
reader's fused_line (a Move as doubles, the state's x y z e v held in C and written back
before any other line and at the end of each play call).  Against the per-line loop of
9bb98a8 (test_speed_measure_loop._ref_play): every block's ringing row (a RowSink that
keeps all of them), the per-stroke sums, the SimResult, the Ledger and its reader
snapshots, and the reader's state after the pass (also after a line that raises), on
samples and edge files under every flavour, with chunks from one line up."""
from __future__ import annotations

import dataclasses
import math
import os
import random

import numpy as np
import pytest

from gcode_opt import state as st
from gcode_opt.firmware import simulate as fw
from gcode_opt.profile import load_profile

from test_speed_measure_loop import _ref_play, bits, led_bits, res_bits

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLES = os.path.join(ROOT, "sample_gcode")

pytestmark = pytest.mark.skipif(fw._core is None or st._reader is None or not fw.use_fused(True),
                                reason="the compiled firmware core or reader is not built here")


def rrf():
    return dataclasses.replace(load_profile("generic-marlin"), flavour="rrf")


PROFILES = {"prusa-mk3s": lambda: load_profile("prusa-mk3s"), "voron24": lambda: load_profile("voron24"),
            "generic-marlin": lambda: load_profile("generic-marlin"), "rrf": rrf}

FILES = sorted("edge/" + f[:-6] for f in os.listdir(os.path.join(SAMPLES, "edge")) if f.endswith(".gcode")) + [
    "prusa_gyroid", "prusa_klipper", "prusa_absolute_e", "prusa_gyroid_arcs", "cura_box"]


class _Taps:
    """The core's own callbacks: a RowSink whose rows are all kept, StrokeSums over ranges."""

    def __init__(self, n_lines, seed):
        rng = random.Random(seed)
        self.rows = []
        self.sink = fw._core.RowSink(4096, lambda: self.rows.append(self.sink.take()))
        ranges, line = [], 0
        while line < n_lines:
            line += rng.choice((0, 1, 3, 20))
            hi = line + rng.choice((0, 2, 10, 60))
            ranges.append((line, hi))
            line = hi + 1
        self.ranges = ranges
        n = len(ranges)
        self.t, self.a2, self.v2 = np.zeros(n), np.zeros(n), np.zeros(n)
        self.sums = fw._core.StrokeSums(np.array([r[0] for r in ranges], np.int64),
                                        np.array([r[1] for r in ranges], np.int64), self.t, self.a2, self.v2)

    def result(self):
        self.sums.flush()
        return b"".join(self.rows) + self.sink.take(), bits([self.t, self.a2, self.v2])


def _lines(path):
    with open(path, encoding="utf-8", errors="surrogateescape", newline="") as fh:
        return fh.readlines()


def _run(path, profile, hint, fused, watch=None):
    """(rows, sums, SimResult bits, ledger bits or None, final state bits) of one pass."""
    lines = _lines(path)
    taps = _Taps(len(lines), 3)
    state = st.MachineState(profile, path)
    state.warnings = []
    sim = fw.new_sim(profile, taps.sums, taps.sink)
    led = None
    if watch is not None:
        sim.max_stop_lines = math.inf
        led = fw.Ledger()
    if fused is None:            # the 9bb98a8 per-line loop
        _ref_play(enumerate(lines), state, sim, watch, led)
    else:
        fw.use_fused(fused)
        try:
            chunks = [(i, lines[i:i + hint]) for i in range(0, len(lines), hint)]
            fw._play_chunks(chunks, state, sim, watch, led)
        finally:
            fw.use_fused(True)
    if watch is None:
        sim.stop()
    else:
        led.stop_lines = sim.res.stop_lines
        led.res = sim.res
    rows, sums = taps.result()
    return rows, sums, res_bits(sim.res), led and led_bits(led), bits([state.snapshot(), state.warnings])


@pytest.mark.parametrize("prof", sorted(PROFILES))
@pytest.mark.parametrize("name", FILES)
def test_fused_same_bits(name, prof):
    """Whole passes: the fused loop, the line-by-line play() and the 9bb98a8 loop agree on
    every block's row, the sums, the SimResult and the state left at the end."""
    path = os.path.join(SAMPLES, name + ".gcode")
    profile = PROFILES[prof]()
    try:
        ref = _run(path, profile, 0, None)
    except st.GcodeError as e:               # a file this flavour refuses: the same error
        for fused in (True, False):
            with pytest.raises(st.GcodeError) as got:
                _run(path, profile, 4096, fused)
            assert str(got.value) == str(e)
        return
    for fused in (True, False):
        got = _run(path, profile, 4096, fused)
        assert got == ref, (name, prof, fused)


@pytest.mark.parametrize("hint", [1, 7, 500])
@pytest.mark.parametrize("name,prof", [("prusa_gyroid", "prusa-mk3s"), ("prusa_klipper", "voron24"),
                                       ("edge/m204_variants", "rrf"), ("edge/relative_g91", "generic-marlin")])
def test_fused_ledger_same_bits(name, prof, hint):
    """The ledger pass: stops, watched-range starts and chunk edges anywhere, every reader
    snapshot the ledger keeps written back from the fused loop."""
    path = os.path.join(SAMPLES, name + ".gcode")
    profile = PROFILES[prof]()
    n = len(_lines(path))
    rng = random.Random(hint)
    watch, line = [], 0
    while line < n:
        line += rng.choice((0, 1, 2, 9, 80, 300))
        last = line + rng.choice((0, 1, 3, 30, 200))
        watch.append((line, last))
        line = last + 1
    ref = _run(path, profile, 0, None, watch)
    assert _run(path, profile, hint, True, watch) == ref


@pytest.mark.parametrize("bad", ["G1 X200000\n", "G1 X1.2.3\n", "M204 S-1\n", "G1 X1 Y1\rG1 X2\n"])
def test_fused_error_leaves_the_state(tmp_path, bad):
    """A line that raises after fused lines: the same error, and the state written back as
    the per-line loop leaves it (the lines before the bad one read)."""
    lines = _lines(os.path.join(SAMPLES, "prusa_gyroid.gcode"))
    lines.insert(3000, bad)
    path = str(tmp_path / "bad.gcode")
    with open(path, "w", newline="") as fh:
        fh.writelines(lines)
    profile = load_profile("prusa-mk3s")
    got = []
    for fused in (None, True):
        state = st.MachineState(profile, path)
        sim = fw.new_sim(profile, None, None)
        with pytest.raises(st.GcodeError) as e:
            if fused is None:
                _ref_play(enumerate(lines), state, sim, None, None)
            else:
                fw._play_chunks([(0, lines)], state, sim, None, None)
        got.append((str(e.value), bits(state.snapshot()), res_bits(sim.res)))
    assert got[0] == got[1]
    assert got[0][0].startswith(f"{path}:3001: ")


def test_fused_needs_the_cores_own_callbacks():
    """A Python on_line (it could read the state) makes play() call the reader's step line
    by line: the state is the dict's at every record."""
    path = os.path.join(SAMPLES, "prusa_gyroid.gcode")
    profile = load_profile("prusa-mk3s")
    lines = _lines(path)
    state = st.MachineState(profile, path)
    seen = []
    sim = fw.new_sim(profile, lambda r: seen.append((r.idx, state.x, state.y)), None)
    fw._play_chunks([(0, lines)], state, sim, None, None)
    sim.stop()
    ref_state = st.MachineState(profile, path)
    ref_seen = []
    ref_sim = fw.new_sim(profile, lambda r: ref_seen.append((r.idx, ref_state.x, ref_state.y)), None)
    _ref_play(enumerate(lines), ref_state, ref_sim, None, None)
    ref_sim.stop()
    assert len(seen) > 1000 and seen == ref_seen


def test_fused_is_used():
    """The fused loop really reads the common lines: a RowSink's flush (Python, allowed in
    the fused loop: the ringing never reads the reader's state) sees the state's x lag
    behind the rows while the fused loop holds it, never with the line-by-line play()
    (a build that declined every line would pass the bit tests)."""
    path = os.path.join(SAMPLES, "prusa_gyroid.gcode")
    profile = load_profile("prusa-mk3s")
    lines = _lines(path)
    lag = {}
    for fused in (True, False):
        state = st.MachineState(profile, path)
        seen = []

        def flush():
            rows = np.frombuffer(sink.take(), float).reshape(-1, 12)
            seen.append(rows[-1, 10])          # the last row's line
            seen.append(state.x)

        sink = fw._core.RowSink(64, flush)
        sim = fw.new_sim(profile, None, sink)
        fw.use_fused(fused)
        try:
            fw._play_chunks([(0, lines)], state, sim, None, None)
        finally:
            fw.use_fused(True)
        xs = seen[1::2]
        lag[fused] = sum(1 for a, b in zip(xs, xs[1:]) if a == b)
    assert lag[True] > 10 * (lag[False] + 1)


def test_fused_with_a_state_subclass():
    """A MachineState subclass (the compiled step hands its every line to Python): play()
    reads it line by line, the same bits."""
    class Sub(st.MachineState):
        pass

    path = os.path.join(SAMPLES, "prusa_klipper.gcode")
    profile = load_profile("voron24")
    lines = _lines(path)
    got = []
    for cls in (st.MachineState, Sub):
        state = cls(profile, path)
        sim = fw.new_sim(profile, None, None)
        fw._play_chunks([(0, lines)], state, sim, None, None)
        sim.stop()
        got.append((res_bits(sim.res), bits(state.snapshot())))
    assert got[0] == got[1]


@pytest.mark.parametrize("prof", sorted(PROFILES))
def test_fused_accel_per_kind_of_move(tmp_path, prof):
    """Travel, printing and E-only moves with three different accelerations in force (the
    profile's, then M204's): the fused loop gives each move the one the reader gives it
    (Klipper and legacy Marlin: one accel for every XY move; Marlin 2 / RRF: P and T)."""
    profile = dataclasses.replace(PROFILES[prof](), default_accel_a=1100.0, travel_accel_a=2300.0,
                                  retract_accel_a=700.0)
    rng = random.Random(5)
    lines = ["G90\n", "M83\n", "G1 Z0.2 F600\n"]
    for i in range(400):
        x, y = rng.uniform(0, 200), rng.uniform(0, 200)
        r = rng.random()
        if r < 0.3:
            lines.append(f"G1 X{x:.3f} Y{y:.3f} F{rng.choice((3000, 9000))}\n")      # travel
        elif r < 0.7:
            lines.append(f"G1 X{x:.3f} Y{y:.3f} E{rng.uniform(0.01, 1):.5f}\n")        # printing
        elif r < 0.8:
            lines.append(f"G1 E{rng.choice(('-0.8', '0.8'))} F2100\n")                 # E only
        elif r < 0.85 and i > 200:
            lines.append(rng.choice(["M204 P800 T1500\n", "M204 S900\n", "M204 T1700\n", "M204 R600\n"]))
        else:
            lines.append(f"G1 X{x:.3f} Y{y:.3f} E-0.1\n")                               # retracting move
    path = str(tmp_path / "accels.gcode")
    with open(path, "w") as fh:
        fh.writelines(lines)
    ref = _run(path, profile, 0, None)
    assert _run(path, profile, 64, True) == ref
