"""Two of _emit.c's checks made cheaper (issue 8, session 40), against exact references:

  * fc_point's distance test decides on the squared distance where it is clear by far and
    calls hypot only near the limit: fast_body on one-line bodies whose point lies within
    1e-11 .. 1e-6 (relative) of its tolerance, inside and outside, against the exact
    verdict (the same float operations to the offsets, then Fraction squares);
  * has_break (block_into's test of the head line for str.splitlines' breaks below 0x20),
    8 bytes a step: head_breaks on random byte strings against the byte-by-byte test."""
from __future__ import annotations

import random
from fractions import Fraction

import pytest

from gcode_opt import emit

CORE = emit.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "head_breaks"),
                                reason=f"no compiled emit core with head_breaks: {emit.CORE_WHY}")

MARGIN_R = 1e-12


def _offsets(x, y, ax, ay, bx, by):
    """fc_point's ex, ey: the same float operations in the same order"""
    ddx, ddy = bx - ax, by - ay
    dd = ddx * ddx + ddy * ddy
    u = ((x - ax) * ddx + (y - ay) * ddy) / dd
    tt = min(max(u, 0.0), 1.0)
    return x - ax - tt * ddx, y - ay - tt * ddy


def _cases(seed=40, n=400):
    rng = random.Random(seed)
    for _ in range(n):
        ax, ay = rng.randint(-500, 500) / 10, rng.randint(-500, 500) / 10
        bx, by = ax + rng.randint(-300, 300) / 10, ay + rng.randint(-300, 300) / 10
        if (ax, ay) == (bx, by):
            continue
        t = rng.random()
        # a point of one decimal near the segment (tolerance 0.75 * 10**-1 from its decimals)
        x = round(ax + t * (bx - ax) + rng.uniform(-0.06, 0.06), 1)
        y = round(ay + t * (by - ay) + rng.uniform(-0.06, 0.06), 1)
        if (x, y) == (bx, by):                     # (the next vertex itself: no distance test)
            continue
        ex, ey = _offsets(x, y, ax, ay, bx, by)
        d2 = Fraction(ex) ** 2 + Fraction(ey) ** 2
        d = float(d2) ** 0.5
        if not 1e-4 < d < 0.07:
            continue
        for r in (1e-6, 1e-8, 1e-9, 3e-10, 1e-10, 1e-11):
            for side in (1, -1):
                tol_d = d * (1 + side * r) / (1 - MARGIN_R) - 1e-7     # the tolerance near d
                tol = min(0.75 * 10.0 ** -1, tol_d) + 1e-7
                lim = tol * (1.0 - MARGIN_R)
                yield ax, ay, bx, by, x, y, tol_d, d2 <= Fraction(lim) ** 2


def test_distance_near_its_tolerance_as_exact():
    n = n_in = 0
    for ax, ay, bx, by, x, y, tol_d, inside in _cases():
        text = f"\nG1 X{x:.1f} Y{y:.1f} F1200\n"
        got = CORE.fast_body(text, 0, len(text), "S", False, 0, 3000.0, [ax, bx], [ay, by], tol_d, 0, 0.0, 0.0)
        assert (got is True) == inside, (ax, ay, bx, by, x, y, tol_d)
        n += 1
        n_in += inside
    assert n > 1000 and 0.4 < n_in / n < 0.6


BREAKS = b"\r\x0b\x0c\x1c\x1d\x1e"


def test_head_breaks_as_bytewise():
    rng = random.Random(8)
    alphabet = bytes(range(0x20, 0x7f)) * 4 + bytes(range(0x00, 0x20)) + b"\x80\xff\xa0"
    for n in list(range(0, 40)) + [97, 128, 200]:
        for _ in range(60):
            b = bytearray(rng.choice(alphabet) for _ in range(n))
            if rng.random() < 0.5:                 # mostly plain text, a break put in at places
                b = bytearray(c if c >= 0x20 else 0x41 for c in b)
                if n and rng.random() < 0.7:
                    b[rng.randrange(n)] = rng.choice(BREAKS + b"\t\n\x01\x1f")
            b = bytes(b)
            assert CORE.head_breaks(b) == any(c in BREAKS for c in b), b
