"""The compiled reader's two shortcuts for the measure loop (gcode_opt/_reader.c), against
the Python reader bit for bit:

- numbers [+-]digits[.digits] read by Clinger's fast path (an exact integer over an exact
  power of ten, one correctly rounded division) instead of PyOS_string_to_double: every
  value must be Python's float() of the token, the state after the line the same;
- comment-only and blank lines answered in C (None, nothing changed) unless the comment
  starts with a prefix features.py acts on (those go to MachineState._step_python).

The reference is the Python step (MachineState._step_python, what 9bb98a8's compiled
step handed these lines to, or float() itself for the numbers)."""
from __future__ import annotations

import random
import struct

import pytest

from gcode_opt import features as feat
from gcode_opt import state as st
from gcode_opt.profile import load_profile
from gcode_opt.state import Arc, Barrier, Limits, MachineState, Move

pytestmark = pytest.mark.skipif(st._reader is None, reason="the compiled reader is not built here "
                                f"({st.CORE_WHY}); the Python reader runs alone")


def norm(v):
    t = type(v)
    if t is float:
        return ("f", struct.pack("<d", v))
    if t in (bool, int, str) or v is None:
        return (t.__name__, v)
    if t in (Move, Arc, Limits, Barrier):
        return (t.__name__,) + tuple(norm(getattr(v, s)) for s in t.__slots__)
    if t in (tuple, list):
        return (t.__name__,) + tuple(norm(x) for x in v)
    raise AssertionError(f"unexpected type {t}")


def outcome(step, state, idx, raw):
    try:
        return norm(step(state, idx, raw)), None
    except Exception as e:           # noqa: BLE001 -- the same exception, whatever it is
        return None, (type(e).__name__, str(e))


class Counter:
    """The lines the compiled step hands to _step_python."""

    def __init__(self, monkeypatch):
        self.lines = []
        py = MachineState._step_python

        def counted(state, idx, raw):
            self.lines.append(raw)
            return py(state, idx, raw)
        monkeypatch.setattr(MachineState, "_step_python", counted)
        self.py = py


def compare(lines, prof, py_step):
    a, b = MachineState(prof, "f.gcode"), MachineState(prof, "f.gcode")
    for idx, raw in enumerate(lines):
        ra = outcome(py_step, a, idx, raw)
        rb = outcome(st._reader.step, b, idx, raw)
        assert ra == rb, f"line {idx + 1} {raw!r}"
        assert norm(a.snapshot()) == norm(b.snapshot()), f"line {idx + 1} {raw!r}: states differ"


# ---------------------------------------------------------------- numbers
def _number(rng):
    """A decimal token: up to 25 digits, the point anywhere (or none), leading zeros, a
    sign now and then; sizes around the fast path's limits (19 digits, 2^53, 22 places)."""
    k = rng.choice((1, 2, 3, 5, 8, 15, 16, 17, 18, 19, 20, 22, 25))
    digits = "".join(rng.choice("0123456789") for _ in range(k))
    if rng.random() < 0.2:
        digits = "0" * rng.randint(1, 6) + digits
    p = rng.randint(0, len(digits))
    s = digits[:p] + "." + digits[p:] if rng.random() < 0.85 else digits
    return rng.choice(("", "", "", "-", "+")) + s


EDGE = ["0", "-0", "+0", "0.", ".0", "-.0", "-0.000", "1.", ".5", "9007199254740992", "9007199254740993",
        "900719925474099.3", "9007199254740993.0", "0.9007199254740993", "1" * 19, "1" * 20,
        "0.0000000000000000000001", "0.00000000000000000000001", "1234567.0000000000000001",
        "99999.99999", "0.1", "0.3", "2.675", "1.0000000000000002", "1.00000000000000011",
        "123456789012345678", "1234567890123456789", "12345678901234567890", ".", "-", "+", "-.", "1.2.3",
        "1-2", "--1", "+-1", "00000000000000000000000001.5"]


@pytest.mark.parametrize("seed", range(6))
def test_numbers_are_float(seed, monkeypatch):
    """G1 and M204 lines with random and edge numbers: the same Move, state and errors as
    the Python step (whose numbers are float() of the token)."""
    rng = random.Random(seed)
    prof = load_profile("prusa-mk3s")
    cnt = Counter(monkeypatch)
    lines = ["G90\n", "M83\n"]
    toks = EDGE + [_number(rng) for _ in range(3000)]
    for tok in toks:
        lines.append(f"G1 X{tok} Y{_number(rng)} E{_number(rng)}\n")
        lines.append("G1 X1 Y2\n")
        if rng.random() < 0.1:
            lines.append(f"M204 S{tok} T{_number(rng)}\n")
    compare(lines, prof, cnt.py)


@pytest.mark.parametrize("seed", range(3))
def test_number_values_exactly(seed):
    """The value the compiled step puts into the Move is float(token), bit for bit (the
    tokens the fast path takes; X far from the previous X so the move is never empty)."""
    rng = random.Random(100 + seed)
    prof = load_profile("prusa-mk3s")
    state = MachineState(prof, "f.gcode")
    n = 0
    for tok in [_number(rng) for _ in range(4000)] + EDGE:
        try:
            x = float(tok)
        except ValueError:
            continue
        if not abs(x) <= st.MAX_POS_D:
            continue
        state.x = 123456.0 if x != 123456.0 else 0.0
        mv = st._reader.step(state, 0, f"G1 X{tok}\n")
        assert struct.pack("<d", mv.x1) == struct.pack("<d", x), tok
        n += 1
    assert n > 1000


# ---------------------------------------------------------------- comment and blank lines
def _marks():
    return list(feat._PREFIXES) + list(feat._LAYER_MARKERS)


def _comment(rng):
    body = rng.choice(["TYPE:Solid infill", "TYPE:External perimeter", "type:support material", "WIDTH:0.45",
                       "HEIGHT:0.2", "LAYER_CHANGE", "layer:12", "LAYER:3", " feature: gap fill",
                       " FEATURE skirt", "feature:bridge", " change_layer", " gcode-opt begin: x", "WIPE_START",
                       "", " ", "TYPE", " feature", "Feature:", "lay", "T", "layer_changes"])
    lead = rng.choice(["", "", " ", "\t", "  \t", "\x0b", "\x1c", "\x0c"])
    tail = rng.choice(["\n", "\n", "\r\n", " \n", "\t\n", "", "  \r\n"])
    if rng.random() < 0.2:
        body = body.upper()
    return lead + ";" + body + tail


@pytest.mark.parametrize("seed", range(4))
def test_comment_lines_as_python(seed, monkeypatch):
    """Comment-only and blank lines (every marker, case, leading whitespace str.split
    skips, CRLF, no ending): the same None, feature and layer as the Python step; since
    session 32 the lines a marker starts are read in C too (_reader.c marked_comment)."""
    rng = random.Random(seed)
    prof = load_profile("prusa-mk3s")
    cnt = Counter(monkeypatch)
    lines = []
    for _ in range(3000):
        r = rng.random()
        if r < 0.7:
            lines.append(_comment(rng))
        elif r < 0.85:
            lines.append(rng.choice(["\n", "\r\n", " \n", "\t\t\n", "\x1f\n", "\x0b\x0c\n"]))
        else:
            lines.append(rng.choice(["G1 X1 E0.1\n", "G1 X2 Y3\n", "M204 S800\n", "G92 E0\n"]))
    compare(lines, prof, cnt.py)
    marks = tuple(_marks())
    marked = [raw for raw in lines if ";" in raw and not raw[:raw.index(";")].split()
              and raw[raw.index(";"):].lower().startswith(marks)]
    assert cnt.lines == [raw for raw in lines if raw.startswith("G92")]
    assert len(marked) > 300


def test_plain_comments_stay_in_c(monkeypatch):
    """A comment no marker starts, a blank line, and (since session 32) a marked one never
    reach _step_python; the marked ones still set the feature and the layer."""
    prof = load_profile("prusa-mk3s")
    calls = []
    py = MachineState._step_python

    def counted(state, idx, raw):
        calls.append(raw)
        return py(state, idx, raw)
    monkeypatch.setattr(MachineState, "_step_python", counted)
    state = MachineState(prof, "f.gcode")
    for raw in ["; gcode-opt begin: x\n", ";WIPE_START\n", "\n", "  \n", ";WIDTH:0.45\r\n", ";"]:
        assert st._reader.step(state, 1, raw) is None
    assert calls == []
    assert st._reader.step(state, 1, ";TYPE:Solid infill\n") is None
    assert st._reader.step(state, 2, ";LAYER_CHANGE\n") is None
    assert calls == []
    assert state.feature == feat.SOLID_INFILL and state.layer == 1 and state.feature_seen is True
