"""Session 44: run_block's start texts f"{x0:.8f}" read from fmt_f's integer (start8_units,
start8_decimals) instead of from the text (units_txt, start_decimals): the same units (or
the same decline: more than 15 digits, past 2^53) and the same decimals, for every dec
0..15, on doubles of every size and sign (-0.0, ties at the 8th decimal, the 15-digit and
2^53 bounds, random bit patterns), and the text f"{x:.8f}" itself."""
from __future__ import annotations

import random
import struct

import pytest

from gcode_opt import emit

CORE = emit.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "start8"),
                                reason=f"no compiled emit core with start8: {emit.CORE_WHY}")


def _doubles():
    rng = random.Random(448)
    xs = [0.0, -0.0, 1e-9, 5e-9, -5e-9, 4.9999999e-9, 1.5e-8, 2.5e-8, 0.5, -0.5, 1.0, 123.456, -123.456,
          9999999.99999999, 1e7, 1e8 - 1, 12345678.9, 999999.999999995, 1e15, 9e15, 2.0 ** 53, 1e17, 1e20,
          1e-300, 5e-324, -1e-300]
    for p in range(-9, 18):
        for _ in range(150):
            xs.append(rng.uniform(-1, 1) * 10 ** p)
            xs.append(round(rng.uniform(-1, 1) * 10 ** p, rng.randint(0, 9)))
    xs += [struct.unpack("<d", struct.pack("<Q", rng.getrandbits(64)))[0] for _ in range(2000)]
    return xs


def test_start_units_and_decimals_from_the_integer():
    seen = declined = 0
    for x in _doubles():
        for dec in range(16):
            got = CORE.start8(x, dec)
            if got is None:                    # fmt_f declines (not finite, past its range): the text path
                continue
            text, u_n, d_n, u_t, d_t = got
            assert text == f"{x:.8f}", x
            assert (u_n, d_n) == (u_t, d_t), (x, dec, got)
            seen += 1
            declined += u_n is None
    assert seen > 100_000 and 0 < declined < seen
