"""The reader's M204 lines in the fused loop (gcode_opt/_reader.c sess_m204): in a live
session an M204 sets the session's accel slots, written to the state only when the session
writes x y z e v back.  Against the Python reader (MachineState._step_python, through a
MachineState subclass, which the compiled reader hands every line to): the same lines in
the same chunks through Sim.play, and after every chunk the two states' modal attributes
the same bits, the three accel objects of the same types and sharing objects as Python
shares them (print and travel one float after "M204 S.."), the same exception text where
Python raises, and the same SimResult at the end (the accelerations the model took).
Lines: written outputs of gcode-opt (an M204 on every re-timed segment) and hand-made
M204 lines (every flavour; S P T R combinations; zero, negative, huge, boundary values;
Klipper without S) between travel, printing and E-only moves.  A counter checks that the
fused loop reads the M204 lines itself."""
from __future__ import annotations

import dataclasses
import random
import struct
from pathlib import Path

import pytest

from gcode_opt import state as st
from gcode_opt.firmware import simulate as fw
from gcode_opt.profile import load_profile

pytestmark = pytest.mark.skipif(fw._core is None or st._reader is None or not fw.use_fused(True),
                                reason="the compiled firmware core or reader is not built here")


def rrf():
    return dataclasses.replace(load_profile("generic-marlin"), flavour="rrf")


PROFILES = {"prusa-mk3s": lambda: load_profile("prusa-mk3s"), "voron24": lambda: load_profile("voron24"),
            "generic-marlin": lambda: load_profile("generic-marlin"), "rrf": rrf}
ACCELS = ("accel_print", "accel_travel", "accel_retract")
SAMPLE = Path(__file__).resolve().parent.parent / "sample_gcode" / "prusa_gyroid_arcs.gcode"


class PyState(st.MachineState):
    """The Python reader: the compiled step hands a subclass's every line to _step_python,
    and Sim.play opens no fused session for it."""


def bits(v):
    if isinstance(v, float):
        return ("f", struct.pack("<d", v))
    if isinstance(v, (list, tuple)):
        return (type(v).__name__,) + tuple(bits(x) for x in v)
    if isinstance(v, st.Limits):
        return ("Limits",) + tuple(bits(getattr(v, k)) for k in st.Limits.__slots__)
    assert v is None or type(v) in (bool, int, str), type(v)
    return (type(v).__name__, v)


def view(state):
    """The state as bits, the accel objects' types and which of them are one object."""
    acc = [getattr(state, k) for k in ACCELS]
    shared = tuple(acc[i] is acc[j] for i in range(3) for j in range(i + 1, 3))
    return bits(list(state.snapshot())), tuple(type(a).__name__ for a in acc), shared


def walk(lines, prof, seed, max_chunk=8, raised=None):
    """Both readers over the lines in the same random chunks (1..max_chunk lines): the first
    difference (text) or None.  `raised` (a list), if given, gets the error both raised."""
    rng = random.Random(seed)
    profile = PROFILES[prof]()
    ref, new = PyState(profile, "f.gcode"), st.MachineState(profile, "f.gcode")
    sims = [fw.new_sim(profile, None, None) for _ in range(2)]
    i = 0
    while i < len(lines):
        n = rng.randint(1, max_chunk)
        chunk = lines[i:i + n]
        got = []
        for state, sim in ((ref, sims[0]), (new, sims[1])):
            try:
                sim.play(chunk, 0, i, state.step, -2, False, None)
                err = None
            except st.GcodeError as e:
                err = str(e)
            got.append((err, view(state)))
        if got[0] != got[1]:
            return f"lines {i + 1}..{i + len(chunk)} {chunk!r}: python {got[0]} != fused {got[1]}"
        if got[0][0] is not None:    # both raised the same: the pass ends there
            if raised is not None:
                raised.append(got[0][0])
            return None
        i += n
    for sim in sims:
        sim.stop()
    a, b = (bits(list(fw.SimResult.as_dict(s.res).values())) for s in sims)
    return None if a == b else f"SimResult python {sims[0].res} != fused {sims[1].res}"


class M204Counter:
    """Counts the M204 lines handed to Python (MachineState._m204) by any reader."""

    def __init__(self, monkeypatch):
        self.n = 0
        py = st.MachineState._m204

        def counted(state, idx, raw, p):
            self.n += 1
            return py(state, idx, raw, p)
        monkeypatch.setattr(st.MachineState, "_m204", counted)


# ---------------------------------------------------------------- written files
@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """gcode-opt outputs of a sample under a legacy-Marlin and a Klipper profile."""
    from gcode_opt.pipeline import Options, process
    out = {}
    for prof in ("prusa-mk3s", "voron24"):
        path = tmp_path_factory.mktemp("w") / f"{prof}.gcode"
        process(str(SAMPLE), str(path), load_profile(prof), Options())
        out[prof] = path.read_text().splitlines(keepends=True)
    return out


@pytest.mark.parametrize("prof", sorted(PROFILES))
def test_written_file_same_state(written, prof, monkeypatch):
    """A re-timed file (M204 S.. before most segments), read under every flavour."""
    lines = written["voron24" if prof == "voron24" else "prusa-mk3s"]
    n_m204 = sum(1 for raw in lines if raw.startswith("M204 "))
    assert n_m204 > 500
    cnt = M204Counter(monkeypatch)
    assert walk(lines, prof, 1) is None
    # the fused loop read them (the Python reader's _m204 ran for every one: once for the
    # reference; a fused loop that handed them to Python would count them twice)
    assert cnt.n < 1.2 * n_m204, (cnt.n, n_m204)


def test_written_file_long_chunks(written):
    """Long chunks: sessions that stay live over many M204s."""
    assert walk(written["prusa-mk3s"], "prusa-mk3s", 2, max_chunk=4000) is None


# ---------------------------------------------------------------- hand-made lines
VALUES = ["1000", "1500.5", "800", "0", "-5", "0.0001", "20000", "1e3", "99999999", "000700", "+900", ".5",
          "1.2.3"]


def m204_line(rng):
    letters = [k for k in "SPTR" if rng.random() < 0.45]
    rng.shuffle(letters)
    if rng.random() < 0.03:
        letters.append(rng.choice("SPTR"))            # a word twice: Python says why
    words = []
    for k in letters:
        v = rng.choice(VALUES) if rng.random() < 0.04 else f"{rng.uniform(100, 5000):.{rng.randint(0, 3)}f}"
        words.append(f"{k}{v}")
    tail = rng.choice(["", "", " ; c", "  ", "\t"])
    return "M204" + "".join(" " + w for w in words) + tail + "\n"


def move_line(rng):
    x, y = rng.uniform(0, 200), rng.uniform(0, 200)
    r = rng.random()
    if r < 0.3:
        return f"G1 X{x:.3f} Y{y:.3f} F{rng.choice((3000, 9000))}\n"          # travel
    if r < 0.75:
        return f"G1 X{x:.3f} Y{y:.3f} E{rng.uniform(0.01, 1):.5f}\n"            # printing
    if r < 0.9:
        return f"G1 E{rng.choice(('-0.8', '0.8'))} F2100\n"                     # E only
    return rng.choice([";TYPE:Perimeter\n", "M106 S100\n", "G92 E0\n", "; note\n", "\n"])


def hand_lines(seed, n=80):
    rng = random.Random(seed)
    lines = ["G90\n", "M83\n", "G1 Z0.2 F600\n"]
    for _ in range(n):
        lines.append(m204_line(rng) if rng.random() < 0.4 else move_line(rng))
    return lines


@pytest.mark.parametrize("prof", sorted(PROFILES))
def test_hand_made_m204_same_state(prof):
    raised = []
    for seed in range(150):
        diff = walk(hand_lines(seed), prof, seed, raised=raised)
        assert diff is None, f"seed {seed}: {diff}"
    assert any("M204" in e for e in raised)      # the refused values were met, not only good ones
    assert len(raised) < 140                     # and most passes ran on past many M204s


@pytest.mark.parametrize("prof", sorted(PROFILES))
@pytest.mark.parametrize("seq", [
    ["M204 S900\n", "M204 P700\n", "M204 T1300\n"],
    ["M204 P700 T1300\n", "M204 S900\n"],
    ["M204 P700\n", "M204 T1300\n", "M204 R500\n"],
    ["M204 T1300\n"],                          # Klipper: P or T alone is no change (travel = print)
    ["M204 P0\n"], ["M204 S0\n"], ["M204 R0\n"], ["M204 T-1\n"],
    ["M204 S1000 T500\n", "M204 P600 R400\n"],
    ["M204 S99999999\n"], ["M204\n"], ["M204 S800 P0\n"],
])
def test_m204_sequences_in_a_live_session(prof, seq):
    """M204s after a move in one chunk (a live session), followed by moves of every kind."""
    lines = (["G90\n", "M83\n", "G1 X10 Y10 F3000\n", "G1 X20 Y10 E0.5\n"] + seq
             + ["G1 X30 Y10 E0.5\n", "G1 X30 Y30\n", "G1 E-0.5\n", "G1 E0.5\n", "G1 X40 Y30 E0.2\n"])
    assert walk(lines, prof, 0, max_chunk=len(lines)) is None
    assert walk(lines, prof, 1, max_chunk=3) is None


# ---------------------------------------------------------------- numbers as the words are scanned
def test_numbers_in_the_fused_loop():
    """read_words reads a value as it scans it (fast_decimal's rule, else to_double): G1 and
    M204 words with the edge tokens of the number tests and random ones (those Python
    takes), through the fused loop, against the Python reader (float() of the token)."""
    from test_speed_measure_reader import EDGE, _number

    def takes(tok, lo, hi):
        try:
            return lo <= float(tok) <= hi
        except ValueError:
            return False

    rng = random.Random(7)
    toks = [t for t in EDGE + [_number(rng) for _ in range(4000)] if takes(t, -1000.0, 1000.0)]
    accs = [t for t in toks if takes(t, 1.0, 10000.0)]
    assert len(toks) > 1500 and len(accs) > 200
    lines = ["G90\n", "M83\n", "G1 X1 Y1 F3000\n"]
    for tok in toks:
        lines.append(f"G1 X{tok} Y{rng.choice(toks)} E{rng.choice(toks)}\n")
        lines.append("G1 X1 Y2\n")
        if rng.random() < 0.3:
            lines.append(f"M204 S{rng.choice(accs)} T{rng.choice(accs)}\n")
    raised = []
    assert walk(lines, "generic-marlin", 7, raised=raised) is None
    assert raised == []
