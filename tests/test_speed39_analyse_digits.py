"""The compiled readers' digit loops (session 39): read_words (gcode_opt/_reader.c) and
dec_value_in (gcode_opt/_emit.c, both its copies: dec_value bounded by the text's length,
dec_value_nl up to the line's newline) test the point by the last byte's digit value and
count the digits after it from the point (no copy of the byte or of the index kept a
digit); read_words takes a value of 1 to 15 digits by Clinger's division without the
general test, and a word's letter by one table load.  The same values, lengths and
errors as before, bit for bit:

- read_words against the Python step (MachineState._step_python: float() of the token)
  on every length of integer and fraction part (0 to 20 and 0 to 25 digits, the 15-digit
  edge of the shortcut and the 19-digit and 2^53 edges of the general test), signs,
  points twice, in each word's place, lines ended by "\\n", "\\r\\n", a comment, blanks or
  nothing (the two copies of read_words_in);
- dec_value against plain_decimal and to_double (dec_read: the two-pass reading it
  replaced) on the same tokens followed by what may end them;
- dec_value_nl (line_read: plain_line's reading) against float() and the token's decimals."""
from __future__ import annotations

import struct

import pytest

from gcode_opt import emit
from gcode_opt import state as st
from gcode_opt.profile import load_profile
from gcode_opt.state import MachineState

from test_speed_measure_reader import Counter, compare

_CORE = emit.CORE_MOD


def _digits(k, seed):
    """k digits, not all zeros (a pattern of its own per seed)."""
    return "".join("7305928146"[(i * 3 + seed) % 10] for i in range(k))


def _tokens():
    out = []
    for a in list(range(0, 21)):
        for b in [-1] + list(range(0, 26)):               # -1: no point
            body = _digits(a, a + b) + ("" if b < 0 else "." + _digits(b, 2 * a + b + 1))
            out.append(body)
    out += ["-" + t for t in out[::7]] + ["+" + t for t in out[::11]]
    out += ["9007199254740992", "9007199254740993", "900719925474099.3", "999999999999999", "1000000000000000",
            "99999999999999.9", "9999999999999999", ".000000000000001", "1.2.3", "1..2", "-.", "1-2", "1+", "--1"]
    return out


TOKENS = _tokens()
ENDS = ["\n", "", "\r\n", " ;c\n", "  \n", ";\n"]


@pytest.mark.skipif(st._reader is None, reason="the compiled reader is not built here")
@pytest.mark.parametrize("end", ENDS)
def test_read_words_as_python(end, monkeypatch):
    """Each token as the first, a middle and the last word: the same Move, state and error
    as the Python step; most lines read in C."""
    cnt = Counter(monkeypatch)
    lines = ["G90\n", "M83\n"]
    for tok in TOKENS:
        lines += [f"G1 X{tok} Y2 E.5{end}", f"G1 X1 Y{tok} E.25{end}", f"G1 X3 Y4 E{tok}{end}", "G1 X0 Y0\n",
                  f"M204 S{tok}{end}"]
    compare(lines, load_profile("prusa-mk3s"), cnt.py)
    assert len(cnt.lines) < 0.7 * len(lines)


@pytest.mark.skipif(st._reader is None, reason="the compiled reader is not built here")
def test_read_words_values_are_float():
    state = MachineState(load_profile("prusa-mk3s"), "f.gcode")
    n = 0
    for tok in TOKENS:
        try:
            x = float(tok)
        except ValueError:
            continue
        if not abs(x) <= st.MAX_POS_D:
            continue
        for raw in (f"G1 X{tok}\n", f"G1 X{tok}", f"G1 X{tok} Y1\n", f"G1 X{tok};\n"):
            state.x = 123456.0 if x != 123456.0 else 0.0
            mv = st._reader.step(state, 0, raw)
            assert struct.pack("<d", mv.x1) == struct.pack("<d", x), raw
            n += 1
    assert n > 400


def _bits(r):
    return r if r[2] is None else (r[0], r[1], struct.pack("<d", r[2]))


@pytest.mark.skipif(_CORE is None or not hasattr(_CORE, "dec_read"), reason="the compiled rewrite core is not built here")
@pytest.mark.parametrize("tail", ["", " ", "\n", "x", ".", "-", "5"])
def test_dec_value_as_plain_decimal(tail):
    """dec_value's length, decimals and value are the two-pass reading's (plain_decimal,
    then to_double), bit for bit."""
    for tok in TOKENS:
        text = tok + tail
        new, old = _CORE.dec_read(text)
        assert _bits(new) == _bits(old), text


def _decimals(tok):
    return len(tok.split(".")[1]) if "." in tok else 0


@pytest.mark.skipif(_CORE is None or not hasattr(_CORE, "line_read"), reason="the compiled rewrite core is not built here")
def test_dec_value_nl_is_float():
    """plain_line's numbers (dec_value_nl, up to the line's end): float() of the token and
    its decimals, for the tokens a plain line takes."""
    n = 0
    for tok in TOKENS:
        if tok.startswith("+") or tok.count(".") > 1 or "-" in tok[1:] or "+" in tok or tok in ("", ".", "-", "-."):
            continue
        got = _CORE.line_read(f"G1 X{tok} Y1.5 E{tok}")
        if got is None:
            continue
        x_t, y_t, e_t, _c, dx, dy, de, x, y, e = got
        assert (x_t, e_t) == (tok, tok)
        assert struct.pack("<d", x) == struct.pack("<d", float(tok)) == struct.pack("<d", e), tok
        assert (dx, de) == (_decimals(tok), _decimals(tok)), tok
        n += 1
    assert n > 300
