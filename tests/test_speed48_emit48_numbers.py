"""Session 48: emit_cols' number texts and counts, against Python's own.

- units_at_nf (now inlined in emit_cols, its small path always; big_units_at past 10^8 or
  7 decimals): the text of u = round(x 10^dec) for floats x of every magnitude (carries
  such as 9.9995, negatives, -0.0, tiny and huge values) and every dec 0..15, against
  emit._fmt_units and against Python's float formatting f"{u / 10**dec:.{dec}f}" (trailing
  zeros cut), and its decimals.
- ceil_tenths (the feed's and accel's ceil(x) as the truncation plus one where x is past
  it): against math.ceil about integers, halves, each side of 0 and -1, and the 2^50 bound.
- piece_lines (the pieces' "\\n" counts from block_into's pass over them): against
  str.count("\\n"), and None wherever the old by-text conditions held."""
from __future__ import annotations

import math
import random

import pytest

from gcode_opt import emit

CORE = emit.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "pieces_nl"),
                                reason=f"no compiled emit core with pieces_nl: {emit.CORE_WHY}")

TENTHS_MAX = 1 << 50


def _floats(rng):
    xs = [0.0, -0.0, 9.9995, -9.9995, 0.0005, 99.995, 999.9995, 0.04999, 1e-9, -1e-9, 123.456, 1e7, 9.99999999]
    for p in range(-12, 16):          # every magnitude, each side of its power of ten
        t = 10.0 ** p
        xs += [t, -t, math.nextafter(t, 0.0), math.nextafter(t, math.inf), 9.5 * t, 0.5 * t]
    for _ in range(4000):
        xs.append(rng.uniform(-1000.0, 1000.0))
        xs.append(rng.choice([-1, 1]) * 10.0 ** rng.uniform(-10, 15))
        xs.append(round(rng.uniform(0, 400), rng.randrange(0, 8)) + rng.choice([0.0, 5e-4, 5e-6, -5e-5]))
    return xs


def _python_text(u, dec):
    """Python's float formatting of u / 10^dec to dec decimals, trailing zeros cut (exact
    for |u| < 2^52: the double is within half a unit of the dec-th decimal of u)."""
    text = f"{u / 10 ** dec:.{dec}f}"
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    return text


def test_units_text_is_python_formatting():
    rng = random.Random(48)
    n_small = n_big = 0
    for x in _floats(rng):
        for dec in range(16):
            u = round(x * 10 ** dec)
            if abs(u) >= 2 ** 52:
                continue
            text, nf = CORE.units_nf(u, dec)
            want = emit._fmt_units(u, dec)
            assert text == want == _python_text(u, dec), (x, dec, u)
            assert nf == len(want.partition(".")[2]), (x, dec, u)
            if abs(u) < 10 ** 8 and dec <= 7:
                n_small += 1
            else:
                n_big += 1
    assert n_small > 50_000 and n_big > 50_000, (n_small, n_big)


def _ceil_ref(x):
    if not math.isfinite(x):
        return None
    c = math.ceil(x)
    return c if c < TENTHS_MAX else None


def test_ceil_tenths_is_math_ceil():
    rng = random.Random(4801)
    xs = [0.0, -0.0, 0.5, -0.5, 1.0, -1.0, -1.5, -2.0, -1e-9, -1e-6, 1e-300, -1e-300, 5e-324,
          math.nan, math.inf, 1e300, 2.0 ** 63, 2.0 ** 64,
          TENTHS_MAX - 1.0, TENTHS_MAX - 1.5, TENTHS_MAX - 0.5, float(TENTHS_MAX), TENTHS_MAX + 1.0]
    for t in (TENTHS_MAX - 1.0, float(TENTHS_MAX), -1.0, 0.0, 1.0, 2.0, 1e6):
        xs += [math.nextafter(t, -math.inf), math.nextafter(t, math.inf)]
    for k in range(-3, 3000):       # integers and their neighbours: the "+1 where past t" edge
        xs += [float(k), math.nextafter(float(k), math.inf), math.nextafter(float(k), -math.inf), k + 0.5]
    for _ in range(20_000):         # the values emit_cols takes: accel * 10 - 1e-9, feed * 600 - 1e-6
        a = rng.choice([rng.uniform(0.0, 20_000.0), round(rng.uniform(0, 5000), 1), 10.0 ** rng.uniform(-12, 16)])
        f = rng.choice([rng.uniform(0.0, 500.0), round(rng.uniform(0, 300), 2) / 60.0, 10.0 ** rng.uniform(-12, 13)])
        xs += [a * 10.0 - 1e-9, f * 600.0 - 1e-6]
    xs += [-rng.uniform(0, 1e12) for _ in range(2000)]      # (below -1: ceil itself)
    for x in xs:
        assert CORE.tenths_ceil(x) == _ceil_ref(x), x


def _pieces_ref(head, closing, before, after, nl, word, letter):
    if nl != "\n" or len(word) != 6 or not word.startswith("M204 ") or word[5] != letter:
        return None
    rest = head.partition("\n")[2]
    for piece in (rest, closing, before or "", after or ""):
        if piece and (not piece.endswith("\n") or any(ln.startswith("G1 X") for ln in piece.split("\n"))):
            return None
    return (head.count("\n"), closing.count("\n"), (before or "").count("\n"), (after or "").count("\n"), 1, 0)


def test_piece_lines_are_the_pieces_line_ends():
    rng = random.Random(4802)
    lines = ["G1 F1200\n", "M204 S800\n", "; gcode-opt end\n", "M107\n", "\n", "G1 X1 Y2\n", "G1 X\n",
             "G1 Z0.2\n", "; G1 X in a comment\n", "M204 P500 T500\n", "G1 F300", "M106 S255\r\n"]
    n_counted = n_none = 0
    for _ in range(20_000):
        def piece(lo):
            return "".join(rng.choice(lines) for _ in range(rng.randint(lo, 4)))
        head = "; gcode-opt begin: replaces 3 lines, kind=line\n" + (piece(0) if rng.random() < 0.3 else "")
        closing = piece(0)
        before = piece(0) if rng.random() < 0.5 else None
        after = piece(0) if rng.random() < 0.5 else None
        nl = rng.choice(["\n"] * 8 + ["\r\n"])
        word = rng.choice(["M204 S"] * 6 + ["M204 P", "M204 T", "M201 S", "M204 "])
        letter = rng.choice("SSSSP")
        want = _pieces_ref(head, closing, before, after, nl, word, letter)
        got = CORE.pieces_nl(head, closing, before, after, nl, word, letter)
        assert got == want, (head, closing, before, after, nl, word, letter)
        n_counted += want is not None
        n_none += want is None
    assert n_counted > 2000 and n_none > 2000, (n_counted, n_none)
