"""The compiled fast path of the reader (gcode_opt/_reader.c) against the Python step, bit for bit.

Two MachineStates read the same lines, one by MachineState._step_python (the Python reader),
one by the compiled step (_gcode_opt_reader.step: its fast path for G0/G1 and M204 lines,
everything else handed to _step_python).  After every line the results must be the same:
a Move with every field the same bits and type (floats as floats, bools as bools), None
where Python gives None, the same exception type and text where Python raises, and the
two states' modal attributes (snapshot) and warnings the same bits.  Files: every bundled
sample and edge file, the corpus plates (slow), written outputs (M204 on every segment),
under every flavour (an RRF profile made from generic-marlin); fuzzed lines: mutations of
real G1 and M204 lines.  A counter checks that the compiled path really reads the lines
it should (a build that falls back on everything would otherwise pass).  Skipped, with
the reason, where the extension is not built."""
from __future__ import annotations

import dataclasses
import random
import struct
import subprocess
import sys
from pathlib import Path

import pytest

from gcode_opt import state as st
from gcode_opt.profile import load_profile
from gcode_opt.state import Arc, Barrier, Limits, MachineState, Move

ROOT = Path(__file__).resolve().parent.parent
SAMPLES = ROOT / "sample_gcode"
CORPUS = Path.home() / ".cache" / "gcode-opt-corpus"

pytestmark = pytest.mark.skipif(st._reader is None, reason="the compiled reader is not built here "
                                f"({st.CORE_WHY}); the Python reader runs alone")


def rrf():
    return dataclasses.replace(load_profile("generic-marlin"), flavour="rrf")


PROFILES = {"prusa-mk3s": lambda: load_profile("prusa-mk3s"), "voron24": lambda: load_profile("voron24"),
            "generic-marlin": lambda: load_profile("generic-marlin"), "rrf": rrf}


def norm(v):
    """A value as comparable bits: type and exact content (floats by their 8 bytes)."""
    t = type(v)
    if t is float:
        return ("f", struct.pack("<d", v))
    if t in (bool, int, str) or v is None:
        return (t.__name__, v)
    if t in (Move, Arc, Limits, Barrier):
        return (t.__name__,) + tuple(norm(getattr(v, s)) for s in t.__slots__)
    if t is tuple:
        return ("tuple",) + tuple(norm(x) for x in v)
    if t is list:
        return ("list",) + tuple(norm(x) for x in v)
    raise AssertionError(f"unexpected type {t}")


def outcome(step, state, idx, raw):
    try:
        return norm(step(state, idx, raw)), None
    except Exception as e:           # noqa: BLE001 -- the same exception, whatever it is
        return None, (type(e).__name__, str(e))


class Counter:
    """Counts the lines the compiled step hands to _step_python."""

    def __init__(self, monkeypatch):
        self.n = 0
        py = MachineState._step_python

        def counted(state, idx, raw):
            self.n += 1
            return py(state, idx, raw)
        monkeypatch.setattr(MachineState, "_step_python", counted)
        self.py = py


def compare_lines(lines, prof, py_step, path="f.gcode"):
    """Read lines with both readers; the first difference (text) or None; also the number of lines."""
    a, b = MachineState(prof, path), MachineState(prof, path)
    c_step = st._reader.step
    for idx, raw in enumerate(lines):
        ra = outcome(py_step, a, idx, raw)
        rb = outcome(c_step, b, idx, raw)
        if ra != rb:
            return f"line {idx + 1} {raw!r}: python {ra} != compiled {rb}"
        if norm(a.snapshot()) != norm(b.snapshot()) or norm(a.warnings) != norm(b.warnings):
            return f"line {idx + 1} {raw!r}: states differ {a.snapshot()} != {b.snapshot()}"
    return None


def read(path):
    return [raw for _, raw in st.read_lines(str(path))]


def check_file(path, prof_name, monkeypatch, min_fast_r=None):
    cnt = Counter(monkeypatch)
    lines = read(path)
    diff = compare_lines(lines, PROFILES[prof_name](), cnt.py, str(path))
    assert diff is None, f"{path.name} ({prof_name}): {diff}"
    if min_fast_r is not None:    # the compiled path read the G1/M204 lines itself
        assert len(lines) - cnt.n >= min_fast_r * len(lines), (cnt.n, len(lines))


SLOW = [pytest.mark.slow]
SMALL = ["prusa_gyroid_arcs.gcode", "prusa_klipper.gcode", "cura_box.gcode"]
BIG = sorted(p.name for p in SAMPLES.glob("*.gcode") if p.name not in SMALL)


@pytest.mark.parametrize("prof", sorted(PROFILES))
@pytest.mark.parametrize("name", SMALL + [pytest.param(n, marks=SLOW) for n in BIG])
def test_samples_same_bits(name, prof, monkeypatch):
    check_file(SAMPLES / name, prof, monkeypatch, min_fast_r=0.5)


@pytest.mark.parametrize("prof", sorted(PROFILES))
def test_edge_files_same_bits(prof, monkeypatch):
    for path in sorted((SAMPLES / "edge").glob("*.gcode")):
        check_file(path, prof, monkeypatch)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["plate_gyroid", "plate_rectilinear", "gyroid_fwretract", "bridges",
                                  "bridges_klipper", "no_type_comments", "cura_gyroid", "cura_bridges"])
def test_corpus_same_bits(name, monkeypatch):
    path = CORPUS / f"{name}.gcode"
    if not path.exists():
        pytest.skip(f"{path} not made (sample_gcode/make_corpus.sh)")
    check_file(path, "voron24" if "klipper" in name else "prusa-mk3s", monkeypatch, min_fast_r=0.5)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["plate_gyroid", "plate_rectilinear"])
def test_written_plates_same_bits(name, tmp_path, monkeypatch):
    """A corpus plate as gcode-opt writes it (~900 k lines, an M204 and a G1 a segment),
    written here (it once read a copy left in /tmp by an earlier run: skipped elsewhere)."""
    from gcode_opt.pipeline import Options, process
    src = CORPUS / f"{name}.gcode"
    if not src.exists():
        pytest.skip(f"{src} not made (sample_gcode/make_corpus.sh)")
    path = tmp_path / f"{name}.gcode"
    opts = Options()
    opts.ringing = False
    process(str(src), str(path), load_profile("prusa-mk3s"), opts)
    check_file(path, "prusa-mk3s", monkeypatch, min_fast_r=0.8)


@pytest.mark.parametrize("prof", ["prusa-mk3s", pytest.param("voron24", marks=SLOW)])
def test_written_output_same_bits(prof, tmp_path, monkeypatch):
    """A re-timed file: an M204 (or SET_VELOCITY_LIMIT) and a G1 per segment."""
    from gcode_opt.pipeline import Options, process
    out = tmp_path / "out.gcode"
    process(str(SAMPLES / "prusa_gyroid_arcs.gcode"), str(out), load_profile(prof), Options())
    text = out.read_text()
    assert "; gcode-opt begin" in text
    if prof == "prusa-mk3s":
        assert "\nM204 S" in text
    check_file(out, prof, monkeypatch, min_fast_r=0.5)


# ---------------------------------------------------------------- fuzzed lines
MODAL = ["G90\n", "G91\n", "M82\n", "M83\n", "G20\n", "G21\n", "M220 S50\n", "M220 S100\n", "M221 S90\n",
         "G92 E0\n", "G92 X1 Y2\n", "M204 S500\n", "M204 P900 T1500 R700\n", "M201 X800 Y900\n",
         "SET_VELOCITY_LIMIT ACCEL=3000\n", ";TYPE:Solid infill\n", ";LAYER_CHANGE\n", "G10\n", "G11\n"]


def mutate(rng, line):
    s = line.rstrip("\n")
    for _ in range(rng.randint(1, 3)):
        k = rng.randrange(17)
        pos = rng.randint(0, len(s))
        if k == 0:
            s = s[:pos] + rng.choice("+-") + s[pos:]
        elif k == 1:
            s = s[:pos] + "." + s[pos:]
        elif k == 2:
            s = s[:pos] + rng.choice(["e5", "E", "e-3", "1e400"]) + s[pos:]
        elif k == 3:
            s = s + " " + rng.choice("XYZEFSPTR") + rng.choice(["1", "-2.5", "0", "3000"])
        elif k == 4:
            s = s + " " + rng.choice("XYZE") + "9" * rng.choice([5, 17, 40, 5, 17, 40, 330])
        elif k == 5:
            s = s[:pos] + "\t" + s[pos:]
        elif k == 6:
            s = s[:pos] + rng.choice(["\r", "\r\n", "\x0b", "\x0c", "\x1c", "\xa0", "\ufeff", "\u00e9"]) + s[pos:]
        elif k == 7:
            s = s.replace(" ", "  ", 1)
        elif k == 8:
            s = s[:pos] + s[pos + 1:]
        elif k == 9:
            s = s + rng.choice([" ; comment", ";", " ;TYPE:Perimeter", "*57"])
        elif k == 10:
            s = rng.choice(["G0", "G1", "G01", "g1", " G1", "G10", "M204", "M2040", "G2", "M204S"]) \
                + s[s.find(" "):] if " " in s else s
        elif k == 11:
            s = s + rng.choice([" F0", " F-100", " F1e8", " F99999999", " F.5", " F60000000"])
        elif k == 12:
            s = s + rng.choice([" X100001", " Y-100000", " Z1e6", " E1e7", " E-10000001", " X.", " Y-"])
        elif k == 13:
            s = s + " " + rng.choice("XYZ") + "0"
        elif k == 14:
            s = s + " " + rng.choice("ABIJKN") + "1"
        elif k == 15:
            s = s + rng.choice(["   ", "\t", " \t "])
        else:
            s = s + rng.choice(["S0", " S0", " S-5", " S1000001", " P0", " T-1", " R0.5"])
    return s + rng.choice(["\n", "\n", "\r\n", "", "\r\r\n", "\n\r"])


def real_lines(n):
    g1, m204 = [], []
    for raw in read(SAMPLES / "prusa_gyroid.gcode") + read(SAMPLES / "prusa_klipper.gcode"):
        if raw.startswith(("G1 ", "G0 ")):
            g1.append(raw)
        elif raw.startswith("M204"):
            m204.append(raw)
    rng = random.Random(7)
    return rng.sample(g1, min(n, len(g1))), m204


@pytest.mark.parametrize("prof", sorted(PROFILES))
def test_fuzzed_lines_same_result(prof, monkeypatch):
    cnt = Counter(monkeypatch)
    g1, m204 = real_lines(1500)
    m204 = m204 + ["M204 S1000\n", "M204 P1200 T2000\n", "M204 R800\n", "M204 T900\n", "M204\n",
                   "M204 S1000 T700\n", "M204 T2000 P1200 R500\n", "M204 S700 R900\n", "M204 P900\n"]
    rng = random.Random(sorted(PROFILES).index(prof))
    lines = []
    for k in range(4000):
        r = rng.random()
        if r < 0.08:
            lines.append(rng.choice(MODAL))
        elif r < 0.25:
            lines.append(rng.choice(m204) if rng.random() < 0.5 else mutate(rng, rng.choice(m204)))
        elif r < 0.55:
            lines.append(rng.choice(g1))
        else:
            lines.append(mutate(rng, rng.choice(g1)))
    diff = compare_lines(lines, PROFILES[prof](), cnt.py)
    assert diff is None, diff
    assert cnt.n < 0.95 * len(lines)     # (G20 and G91 prefixes send many to Python)


@pytest.mark.parametrize("raw", [
    "G1 X10 Y20 E0.5 F1800\n", "G1 X10 X11\n", "G1 X1.2.3\n", "G1 X1-2\n", "G1 X.\n", "G1 X\n",
    "G1 X1e3\n", "G1 X+5 Y-.5\n", "G0 X1 ; travel\n", "G1 F0\n", "G1 F-1\n", "G1 F10000001\n",
    "G1 F1e\n", "G1 X100001\n", "G1 E10000001\n", "G1 E-10000000\n", "G1 X" + "9" * 400 + "\n",
    "G1 X-" + "9" * 400 + "\n", "G1\n", "G0\n", "G1", "G1 X1\r", "G1 X1\r\n", "G1 X1\r\r\n",
    "G1 X1\rY2\n", "G1 X1\n\r", "\ufeffG1 X1\n", "G1 X1 ;\u00e9\n", "G1\tX1\t\tY2 \t\n", "G1 X1Y2\n",
    "G1 X1*12\n", "N10 G1 X1*12\n", "G01 X1\n", "G1 x1\n", "G1 X0 Y0 Z0 E0\n", "G1 E-0.8 F2100\n",
    "G1 E0.8\n", "G1 X-0 Y-0\n", "G1 Z0.2 F720\n", "M204 S800\n", "M204 S0\n", "M204 S-1\n",
    "M204 P800 T1200 R500\n", "M204 S800 T1500\n", "M204 S900 R700\n", "M204 P800 T1200\n",
    "M204 P1200 T800\n", "M204 P800 T800\n", "M204 S800 P700 T600 R500\n", "M204 R900 T700 P500\n", "M204 S800 S900\n", "M204 T1000\n", "M204 S1000001\n", "M204 S1e3\n",
    "M204\n", "M204 S800 ; accel\n", "M204 S800\r\n", "M204\tP1500\n", "M204 X5\n", "M2040 S5\n",
])
@pytest.mark.parametrize("prof", sorted(PROFILES))
@pytest.mark.parametrize("strict", [False, True])
def test_hand_lines(raw, prof, strict, monkeypatch):
    """One line after a modal prefix (absolute, relative, relative E, scaled speed, inch);
    strict: against Python's strict tokenizer path (its fast regexes switched off)."""
    cnt = Counter(monkeypatch)
    if strict:
        monkeypatch.setattr(st, "_fast_match", lambda code: None)
        monkeypatch.setattr(st, "_fast_m204", lambda code: None)
    for prefix in ([], ["G91\n"], ["M83\n"], ["M220 S37\n", "G1 X3 F1234\n"], ["G20\n"], ["G92 X-0.0 E5\n"],
                   ["M204 P700 T900 R600\n"]):
        diff = compare_lines(prefix + [raw], PROFILES[prof](), cnt.py)
        assert diff is None, diff


def test_fast_path_moves_share_state_objects():
    """The Move holds the state's Limits object, feature string and (for an axis not
    given) the position object, as Python's does."""
    s = MachineState(load_profile("prusa-mk3s"))
    s.step(0, ";TYPE:Solid infill\n")
    s.step(1, "G1 X5 Y5 Z0.2\n")
    y_obj = s.y
    m = st._reader.step(s, 2, "G1 X6 E0.1\n")
    assert m.lim is s.lim and m.feature is s.feature and m.y1 is y_obj and m.y0 is y_obj
    assert type(m.e) is float and m.has_f is False and m.checksum is False


def test_pure_python_env():
    """GCODE_OPT_PURE_PYTHON=1 reads with Python; use_reader switches MachineState.step."""
    out = subprocess.run([sys.executable, "-c", "from gcode_opt import state as s; "
                          "print(s.CORE, s.MachineState.step is s.MachineState._step_python, s.CORE_WHY)"],
                         capture_output=True, text=True, env={"GCODE_OPT_PURE_PYTHON": "1", "PATH": ""},
                         cwd=str(ROOT), check=True)
    assert out.stdout.startswith("python True GCODE_OPT_PURE_PYTHON")
    old = st.use_reader("python")
    try:
        assert MachineState.step is MachineState._step_python
        st.use_reader("c")
        assert MachineState.step is not MachineState._step_python and st.CORE == "c"
    finally:
        st.use_reader(old)


def test_a_reader_built_from_another_source_is_not_used(monkeypatch):
    """A stale build (the C file changed since): the Python reader plays, and says why."""
    monkeypatch.setattr(st._reader, "SOURCE_SHA256", "0" * 64)
    monkeypatch.setattr(st, "CORE_WHY", "")
    assert st._load_reader() is None
    assert "another _reader.c" in st.CORE_WHY


def test_compiled_reader_plays_by_default():
    import os
    env = {k: v for k, v in os.environ.items() if k != "GCODE_OPT_PURE_PYTHON"}
    out = subprocess.run([sys.executable, "-c", "from gcode_opt import state as s; print(s.CORE)"],
                         capture_output=True, text=True, env=env, cwd=str(ROOT), check=True)
    assert out.stdout.strip() == "c"
