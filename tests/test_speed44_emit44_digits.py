"""Session 44: the rewrite core's number texts below 10^8 (_emit.c small_units_at: the eight
digits made in one 64-bit word, the whole's leading and the fraction's trailing zeros cut
by ctz / clz) against the Python texts they stand for, emit._fmt_units (the text) and the
decimals it carries (units_at_nf's nf, which the check at emission reads), and
emit._tenths_up (the feeds' and accelerations' tenths).  Every width 1..9 digits, each
digit position zero or not, every dec 0..15 (7 is the fast path's last, 8 on the old
loop), signs, and the 10^8 boundary."""
from __future__ import annotations

import random

import pytest

from gcode_opt import emit

CORE = emit.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "units_nf"),
                                reason=f"no compiled emit core with units_nf: {emit.CORE_WHY}")


def _ref(u, dec):
    text = emit._fmt_units(u, dec)
    return text, len(text.partition(".")[2])


def _values():
    rng = random.Random(44)
    us = [0, 1, 9, 10, 99, 100, 10 ** 7, 10 ** 8 - 1, 10 ** 8, 10 ** 8 + 1, 2 ** 32 - 1, 2 ** 32, 2 ** 53]
    for p in range(9):                    # each position alone, and all nines below it
        us += [10 ** p, 10 ** p - 1, 10 ** p + 1, 7 * 10 ** p, 10 ** p + 10 ** max(p - 3, 0)]
    for _ in range(40_000):               # digits of every width, zeros at random places
        n = rng.randint(1, 9)
        us.append(int("".join(rng.choice("0000123456789") for _ in range(n))))
    us += [rng.randint(0, 10 ** 8 - 1) for _ in range(20_000)]
    return us + [-u for u in us]


def test_units_nf_is_fmt_units_and_its_decimals():
    for u in _values():
        for dec in range(16):
            assert CORE.units_nf(u, dec) == _ref(u, dec), (u, dec)
    # through put_units too (units_text: the same function behind it)
    for u in (0, -5, 12345678, -99999999, 100000000, 1050):
        for dec in (0, 1, 3, 5, 7, 8):
            assert CORE.units_text(u, dec) == emit._fmt_units(u, dec)


def test_tenths_below_and_past_the_fast_path():
    rng = random.Random(4401)
    ks = list(range(-3, 20_000)) + [10 ** 8 - 1, 10 ** 8, 10 ** 8 + 1, 10 ** 7 * 3 + 10, (1 << 50) - 1]
    ks += [rng.randint(2, 10 ** 8 + 1000) for _ in range(40_000)]
    ks += [int(str(rng.randint(1, 9999)) + "0" * rng.randint(0, 4)) for _ in range(5_000)]
    for k in ks:
        assert CORE.tenths_text(k) == emit._tenths_up(k), k
