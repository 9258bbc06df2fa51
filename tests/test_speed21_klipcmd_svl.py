"""Sim.play reads plain SET_VELOCITY_LIMIT lines in C (firmware/_core.c svl_line) instead of
handing each to MachineState._step_python: a Klipper output carries one or two around every
re-timed stroke (62 k in the gyroid plate's voron24 output).  Against the line-by-line loop
with the pure-Python reader (and the pure-Python model): the same state (every modal
attribute, the Limits' values to the bit, the float types), the same rows, sums, SimResult
and ledger, the same errors, on real Klipper outputs (bundled *_klipper samples processed
under voron24 and auto) and on hand-written odd variants (lower case, spacing, missing
values, junk, comments, CR LF, huge numbers, nan, macros, keys twice)."""
from __future__ import annotations

import os
import random
import struct
import subprocess
import sys

import pytest

from gcode_opt import state as st
from gcode_opt.firmware import simulate as fw
from gcode_opt.profile import load_profile

from test_speed_measure_fused import _run, _lines
from test_speed_measure_loop import _ref_play, res_bits

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLES = os.path.join(ROOT, "sample_gcode")

pytestmark = pytest.mark.skipif(fw._core is None or st._reader is None or not fw.use_fused(True),
                                reason="the compiled firmware core or reader is not built here")

# read in C (svl_line) under klipper
PLAIN = [
    "SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=0.25\n",
    "SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=0\n",
    "SET_VELOCITY_LIMIT  ACCEL=2500   MINIMUM_CRUISE_RATIO=0.1  \n",
    "\tSET_VELOCITY_LIMIT\tACCEL=1800\t; a comment = here ; SET_VELOCITY_LIMIT ACCEL=9\n",
    "SET_VELOCITY_LIMIT ACCEL=1700 ; reset\r\n",
    "SET_VELOCITY_LIMIT VELOCITY=250 SQUARE_CORNER_VELOCITY=4.5 ACCEL_TO_DECEL=900\n",
    "SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=-0\n",
    "SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=.5\n",
    "SET_VELOCITY_LIMIT ACCEL=5. MINIMUM_CRUISE_RATIO=+0.5\n",
    "SET_VELOCITY_LIMIT ACCEL=1000000 VELOCITY=100000 SQUARE_CORNER_VELOCITY=0\n",
    "SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=0.9999999999999999\n",
    "SET_VELOCITY_LIMIT ACCEL=0000000000000000000000000000000000000000000000000000000000003000\n",
    "SET_VELOCITY_LIMIT ACCEL_TO_DECEL=-7\n",
    "SET_VELOCITY_LIMIT ACCEL=2345.6789012345678901234\n",
]
# read by Python (as before): state changes or nothing, no error
ODD = [
    "set_velocity_limit minimum_cruise_ratio=0.3\n",
    "Set_Velocity_Limit ACCEL=2100\n",
    "SET_VELOCITY_LIMIT ACCEL=\n",
    "SET_VELOCITY_LIMIT ACCEL\n",
    "SET_VELOCITY_LIMIT\n",
    "SET_VELOCITY_LIMIT ;ACCEL=5\n",
    "SET_VELOCITY_LIMIT ACCEL={printer.toolhead.max_accel}\n",
    "SET_VELOCITY_LIMIT ACCEL='2000' MINIMUM_CRUISE_RATIO=\"0.4\"\n",
    "SET_VELOCITY_LIMIT ACCEL=2000 ACCEL=2600\n",
    "SET_VELOCITY_LIMIT FOO=bar MINIMUM_CRUISE_RATIO=0.2\n",
    "SET_VELOCITY_LIMIT ACCEL=2000 X\n",
    "SET_VELOCITY_LIMIT ACCEL=2200*12\n",
    "N10 SET_VELOCITY_LIMIT ACCEL=2300\n",
    "SET_VELOCITY_LIMIT ACCEL = 2400\n",
    "SET_VELOCITY_LIMIT\x1cACCEL=2000\n",
    "SET_VELOCITY_LIMITACCEL=5\n",
    "SET_VELOCITY_LIMIT ACCEL_TO_DECEL=junk\n",
    "SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=0." + "0" * 100 + "1\n",
    "SET_VELOCITY_LIMIT minimum_CRUISE_ratio=0.45\n",
    "SET_VELOCITY_LIMIT ACCEL=1900 \u00e9\n",
    "  ; SET_VELOCITY_LIMIT ACCEL=5\n",
]
# Python raises (the C path must leave them to it)
BAD = [
    "SET_VELOCITY_LIMIT ACCEL=nan\n",
    "SET_VELOCITY_LIMIT ACCEL=0\n",
    "SET_VELOCITY_LIMIT ACCEL=-1000\n",
    "SET_VELOCITY_LIMIT ACCEL=1000000.0000001\n",
    "SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=1\n",
    "SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=0.99999999999999999999\n",
    "SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=-0.001\n",
    "SET_VELOCITY_LIMIT VELOCITY=0\n",
    "SET_VELOCITY_LIMIT VELOCITY=100000.5\n",
    "SET_VELOCITY_LIMIT SQUARE_CORNER_VELOCITY=-1\n",
    "SET_VELOCITY_LIMIT SQUARE_CORNER_VELOCITY=100001\n",
    "SET_VELOCITY_LIMIT ACCEL=1e3\n",
    "SET_VELOCITY_LIMIT ACCEL=junk\n",
    "SET_VELOCITY_LIMIT ACCEL=1.2.3\n",
    "SET_VELOCITY_LIMIT ACCEL=" + "9" * 400 + "\n",
    "SET_VELOCITY_LIMIT ACCEL=" + "9" * 60 + "\n",
    "SET_VELOCITY_LIMIT ACCEL=2000\rG1 X1\n",
    "SET_VELOCITY_LIMIT ACCEL=2000 MINIMUM_CRUISE_RATIO=inf\n",
    "SET_VELOCITY_LIMIT ACCEL=- MINIMUM_CRUISE_RATIO=0.5\n",
]


def state_bits(state):
    """Every modal attribute with its type; the Limits by its slots, to the bit."""
    out = []
    for name, v in zip(st.MachineState.MODAL, state.snapshot()):
        if type(v) is st.Limits:
            v = tuple((type(x).__name__, struct.pack("<d", x)) for x in v._values())
        elif type(v) is float:
            v = struct.pack("<d", v)
        out.append((name, type(v).__name__, v))
    return out


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    """Real Klipper outputs: bundled *_klipper samples processed by this tree."""
    d = tmp_path_factory.mktemp("klipcmd")
    got = {}
    for name, prof in (("prusa_klipper", "voron24"), ("prusa_klipper", "auto"),
                       ("prusa_klipper_no_comments", "voron24")):
        out = str(d / f"{name}_{prof}.gcode")
        env = dict(os.environ, PYTHONPATH=ROOT)
        subprocess.run([sys.executable, "-m", "gcode_opt", "process", os.path.join(SAMPLES, name + ".gcode"),
                        "-o", out, "--profile", prof, "-q"], check=True, env=env, cwd=ROOT)
        got[(name, prof)] = out
    return got


def _python_ref(path, profile, watch=None):
    old = st.use_reader("python")
    try:
        return _run(path, profile, 0, None, watch)
    finally:
        st.use_reader(old)


def _variants_file(tmp_path, src, extra, seed=1):
    """src's lines with the `extra` lines put after its SET_VELOCITY_LIMIT lines and at random places."""
    lines = _lines(src)
    rng = random.Random(seed)
    out = []
    for ln in lines:
        out.append(ln)
        if ln.startswith("SET_VELOCITY_LIMIT") and rng.random() < 0.3 or rng.random() < 0.01:
            out.append(rng.choice(extra))
    for i, ln in enumerate(extra):             # each one at least once
        out.insert(200 + 37 * i, ln)
    path = str(tmp_path / "variants.gcode")
    with open(path, "w", newline="", encoding="utf-8") as fh:
        fh.writelines(out)
    return path


def test_outputs_carry_the_lines(outputs):
    for path in outputs.values():
        assert sum(ln.startswith("SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=") for ln in _lines(path)) > 1000


@pytest.mark.parametrize("key", [("prusa_klipper", "voron24"), ("prusa_klipper", "auto"),
                                 ("prusa_klipper_no_comments", "voron24")])
def test_klipper_outputs_same_bits(outputs, key):
    """Whole passes over real outputs: rows, sums, SimResult, final state as the per-line
    loop with the Python reader leaves them, fused and not; ledger passes too."""
    path = outputs[key]
    profile = load_profile("voron24")
    ref = _python_ref(path, profile)
    for fused in (True, False):
        got = _run(path, profile, 4096, fused)
        assert got == ref, fused
    n = len(_lines(path))
    rng = random.Random(5)
    watch, line = [], 0
    while line < n:
        line += rng.choice((0, 1, 9, 80, 300))
        last = line + rng.choice((0, 3, 30, 200))
        watch.append((line, last))
        line = last + 1
    assert _run(path, profile, 777, True, watch) == _python_ref(path, profile, watch)


@pytest.mark.parametrize("prof", ["voron24", "prusa-mk3s"])
def test_odd_variants_same_state(outputs, tmp_path, prof):
    """Plain and odd SET_VELOCITY_LIMIT lines mixed into a real output: the same rows,
    sums, result and final state (every modal attribute to the bit, float types) as the
    Python reader line by line, and the same state after every line."""
    path = _variants_file(tmp_path, outputs[("prusa_klipper", "voron24")], PLAIN + ODD)
    profile = load_profile(prof)
    ref = _python_ref(path, profile)
    got = _run(path, profile, 4096, True)
    assert got == ref
    # the state after every line (chunks of one line: play() writes the state back)
    lines = _lines(path)
    states = []
    for reader in ("python", "c"):
        old = st.use_reader(reader)
        try:
            state = st.MachineState(profile, path)
            sim = fw.new_sim(profile, None, None)
            seen = []
            step = state.step
            for i, ln in enumerate(lines[:6000]):
                if reader == "c":
                    sim.play([ln], 0, i, step, -2, False, None)
                else:
                    _ref_play([(i, ln)], state, sim, None, None)
                seen.append(state_bits(state))
            sim.stop()
            states.append((seen, res_bits(sim.res)))
        finally:
            st.use_reader(old)
    assert states[0] == states[1]


def test_plain_lines_single_file_pure_python(tmp_path):
    """The pure-Python model and reader against the compiled ones (simulate_file)."""
    src = os.path.join(SAMPLES, "prusa_klipper.gcode")
    path = _variants_file(tmp_path, src, PLAIN, seed=3)
    profile = load_profile("voron24")
    got = res_bits(fw.simulate_file(path, profile))
    old_c, old_r = fw.use_core("python"), st.use_reader("python")
    try:
        ref = res_bits(fw.simulate_file(path, profile))
    finally:
        fw.use_core(old_c)
        st.use_reader(old_r)
    assert got == ref


@pytest.mark.parametrize("bad", BAD)
def test_bad_values_same_error(outputs, tmp_path, bad):
    """A line Python refuses: the same error and text, the state as the per-line loop
    leaves it (plain lines before it read in C)."""
    lines = _lines(outputs[("prusa_klipper", "voron24")])
    lines.insert(3000, bad)
    path = str(tmp_path / "bad.gcode")
    with open(path, "w", newline="", encoding="utf-8") as fh:
        fh.writelines(lines)
    profile = load_profile("voron24")
    got = []
    for fused in (None, True):
        old = st.use_reader("python" if fused is None else "c")
        try:
            state = st.MachineState(profile, path)
            sim = fw.new_sim(profile, None, None)
            with pytest.raises(st.GcodeError) as e:
                if fused is None:
                    _ref_play(enumerate(lines), state, sim, None, None)
                else:
                    fw._play_chunks([(0, lines)], state, sim, None, None)
        finally:
            st.use_reader(old)
        got.append((str(e.value), state_bits(state), res_bits(sim.res)))
    assert got[0] == got[1]
    assert got[0][0].startswith(f"{path}:3001: ")


def test_plain_lines_do_not_reach_python(outputs, monkeypatch):
    """The C path is really taken: in play(), no plain line reaches _step_python (the odd
    ones still do), and a MachineState subclass still gets every such line in Python."""
    path = outputs[("prusa_klipper", "voron24")]
    lines = _lines(path)
    seen = []
    orig = st.MachineState._step_python

    def counting(self, idx, raw):
        seen.append(raw)
        return orig(self, idx, raw)

    monkeypatch.setattr(st.MachineState, "_step_python", counting)
    profile = load_profile("voron24")
    n_svl = sum(ln.startswith("SET_VELOCITY_LIMIT") for ln in lines)
    state = st.MachineState(profile, path)
    fw._play_chunks([(0, lines)], state, fw.new_sim(profile, None, None), None, None)
    assert n_svl > 1000 and not any("SET_VELOCITY_LIMIT" in r for r in seen)
    seen.clear()
    state = st.MachineState(profile, path)
    fw._play_chunks([(0, ODD[:1] + lines)], state, fw.new_sim(profile, None, None), None, None)
    assert seen.count(ODD[0]) == 1

    class Sub(st.MachineState):
        pass

    seen.clear()
    fw._play_chunks([(0, lines)], Sub(profile, path), fw.new_sim(profile, None, None), None, None)
    assert sum("SET_VELOCITY_LIMIT" in r for r in seen) == n_svl
