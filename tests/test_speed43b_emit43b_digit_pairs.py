"""plain_line (_emit.c) reads a stroke line's numbers two digits at a time (digit_pairs: a
64 KiB table of byte pairs) where the byte after the line's '\\n' is readable, else a digit
at a time: line_read takes both readings and raises where they differ; here against
plain_moves' reading (num_run, plain_decimal, to_double) on lines whose numbers have runs
of every length (odd, even, past 15 and 19 digits), signs, points and the bytes either
side of the digits (':' and '/') after them."""
from __future__ import annotations

import random
import struct

import pytest

from gcode_opt import emit

CORE = emit.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "line_read"),
                                reason=f"no compiled emit core: {emit.CORE_WHY}")

TAILS = ["", " ", "  ", "\t", " ;c", ";x 1.5", "\r", " ;\r", ":", "/", ".", "-", "0", "a"]


def _digits(rng, n):
    return "".join(rng.choice("0123456789" if rng.random() < 0.7 else "09") for _ in range(n))


def _number(rng):
    sign = rng.choice(["", "", "-", "+", "--"])
    whole = _digits(rng, rng.choice([0, 1, 2, 3, rng.randrange(4, 23)]))
    if rng.random() < 0.8:
        return sign + whole + "." + _digits(rng, rng.choice([0, 1, 2, 3, 4, 5, rng.randrange(6, 23)]))
    return sign + whole


def _line(rng):
    words = f"G1 X{_number(rng)} Y{_number(rng)}"
    if rng.random() < 0.7:
        words += f" E{_number(rng)}"
    return words + rng.choice(TAILS)


def _bits(v):
    return struct.pack("<d", v)


def test_pair_reading():
    rng = random.Random(4343)
    taken = 0
    for _ in range(60_000):
        line = _line(rng)
        got = CORE.line_read(line)          # (raises where the two readings differ)
        want = CORE.plain_moves([line + "\n"], "0", "0")
        assert (got is None) == (want is None), line
        if got is None:
            continue
        taken += 1
        xs, ys, es, given, comments, (xv, yv, ev), _, _ = want
        xt, yt, et, ct, dx, dy, de, x, y, e = got
        assert (xt, yt, et or "0", ct, et is not None) == (xs[0], ys[0], es[0], comments[0], given[0]), line
        assert _bits(x) == _bits(xv[0]) and _bits(y) == _bits(yv[0]), line
        assert e is None or _bits(e) == _bits(ev[0]), line
        assert (dx, dy, de) == tuple(len(t.partition(".")[2]) for t in (xt, yt, et or "")), line
    assert taken > 5_000
