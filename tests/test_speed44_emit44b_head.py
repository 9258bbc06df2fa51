"""A block's head text (issue 8, session 44): scaled_int takes |x| 10^k in 64-bit words
where m 5^k fits them (fmt_f(x, 4)'s always do), fmt_f copies its digits without memcpy
calls, and head_text_of takes the numbers' lengths from their formatting instead of
strlen; block_into looks for a line break in a head's first line only in its kind where
head_text_of wrote the line (head_line_breaks).  fmt_f against PyOS_double_to_string (the core's format_check) on doubles about
the 64-bit bound, the shift's ends and halfway cases; head_text (head_of hook) against
pipeline's f-string (_HEAD_TEXT) with texts of every short length, and its first line's
breaks found from the kind as from the line's text."""
from __future__ import annotations

import math
import random
import struct

import pytest

from gcode_opt import emit, pipeline as pl

CORE = emit.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "head_of"),
                                reason="the compiled rewrite core is not built here")


def _doubles(rng, n):
    out = []
    for _ in range(n):
        kind = rng.random()
        if kind < 0.3:                            # any exponent near the 64-bit bound's
            x = rng.uniform(1, 2) * 2.0 ** rng.randrange(-70, 70)
        elif kind < 0.6:                          # halfway cases of k decimals: (j + 1/2) / 10^k
            k = rng.randrange(0, 9)
            x = (rng.randrange(0, 10 ** 7) + 0.5) / 10 ** k
        elif kind < 0.8:                          # a random bit pattern (finite)
            x = struct.unpack("<d", struct.pack("<Q", rng.getrandbits(64)))[0]
            if not math.isfinite(x):
                x = 1.5
        else:                                     # ties in binary: j / 2^s
            x = rng.randrange(1, 2 ** 20) / 2.0 ** rng.randrange(1, 40)
        out.append(-x if rng.random() < 0.4 else x)
    return out


def test_fmt_f_is_python():
    rng = random.Random(4401)
    xs = _doubles(rng, 40_000)
    raw = struct.pack(f"<{len(xs)}d", *xs)
    taken_all = 0
    for prec in list(range(0, 21)):
        taken, bad = CORE.format_check(raw, "f", prec)
        assert bad == -1, (prec, xs[bad], CORE.format_text(xs[bad], "f", prec), format(xs[bad], f".{prec}f"))
        taken_all += taken
    taken, bad = CORE.format_check(raw, "g", 4)
    assert bad == -1, (xs[bad], CORE.format_text(xs[bad], "g", 4))
    assert taken_all > 300_000 and taken > 10_000


def test_head_text_is_the_f_string():
    rng = random.Random(4402)
    made = broken = 0
    odd = [math.nan, math.inf, -math.inf, -0.0, 0.0, 5e-324, 0.00005, 0.00015, 99999.99995, 1e22, 1.0 / 3.0]
    for _ in range(20_000):
        chars = "linearc_" if rng.random() < 0.7 else "line\r\n\x0b\x0c\x1c\x1d\x1e\x1f\t"
        kind = "".join(rng.choice(chars) for _ in range(rng.randrange(0, 40)))
        svl = "".join(rng.choice("SET_VELOCITY_LIMIT =0.5\n") for _ in range(rng.randrange(0, 60)))
        nums = [rng.choice(odd) if rng.random() < 0.15 else rng.uniform(0, 1) * 10 ** rng.randrange(-6, 7)
                for _ in range(3)]
        n_segs, n_lines = rng.randrange(-5, 10 ** rng.randrange(1, 12)), rng.randrange(0, 10 ** rng.randrange(1, 12))
        got = CORE.head_of((kind, n_segs, *nums, svl), n_lines)
        if got is None:
            continue
        made += 1
        head, by_kind, by_text = got
        assert head == pl._HEAD_TEXT(emit.BEGIN, n_lines, kind, n_segs, *nums, svl), (kind, n_segs, nums, svl)
        assert by_kind == by_text == CORE.head_breaks(head.partition("\n")[0].encode()), (kind, nums)
        broken += by_text
    assert made > 15_000 and 1_000 < broken < made // 2
