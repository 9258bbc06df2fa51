"""stroke_block's units of a move's texts (issue 8, session 44): emit_cols takes a
number's units with the block's decimals from the digits' integer plain_line read
(units_read, block_into keeps them) instead of reading the text again (units_txt).  The core's
line_units hook gives both for a plain line: they must agree, declines included, on
numbers of every length, sign and point, for decimals at, above and below the texts'."""
from __future__ import annotations

import random

import pytest

from gcode_opt import emit

CORE = emit.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "line_units"),
                                reason="the compiled rewrite core is not built here")


def _number(rng):
    whole = "".join(rng.choice("0123456789") for _ in range(rng.choice([0, 1, 1, 2, 3, 5, 9, 14, 16, 20])))
    frac = "".join(rng.choice("0123456789") for _ in range(rng.choice([0, 1, 2, 3, 5, 6, 8, 12, 15, 17])))
    point = rng.random() < 0.85 or not whole
    text = whole + ("." + frac if point else "")
    if not whole and not frac:
        text = rng.choice(["0", "5.", ".5"])
    return ("-" if rng.random() < 0.3 else "") + text


def test_units_from_integers_are_units_txt():
    rng = random.Random(4444)
    compared = declined = 0
    for _ in range(60_000):
        line = f"G1 X{_number(rng)} Y{_number(rng)}"
        if rng.random() < 0.7:
            line += f" E{_number(rng)}"
        got = CORE.line_units(line, rng.randrange(0, 17), rng.randrange(0, 17))
        assert got is not None, line
        for pair in got:
            if pair is None:
                continue
            assert pair[0] == pair[1], (line, got)
            compared += 1
            declined += pair[0] is None
    assert compared > 100_000 and 1_000 < declined < compared // 2


def test_units_edges():
    for text in ["0", "-0", "5.", "-5.", ".5", "-.5", "123456789012345", "1234567890.12345", "9007199254.740992",
                 "9007199254.740993", "90071992547409.93", "1" * 16, "0." + "0" * 14 + "1", "12.5"]:
        for dec in range(0, 17):
            got = CORE.line_units(f"G1 X{text} Y{text} E{text}", dec, dec)
            assert got[0][0] == got[0][1] and got[2][0] == got[2][1], (text, dec, got)
