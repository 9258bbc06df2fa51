"""The reader's line split, 16 bytes at a time (issue 8, session 43; gcode_opt/_reader.c
split_scan): in a block with no CR the '\\n's are found by one compare a 16-byte piece and each
line's end read from the mask's bits, the rest of the block (fewer than 16 bytes past the last
piece, and the line without its ending) by the memchr steps as before.  The lines and the
bytes used must be the rule's: a line ends after "\\n", "\\r\\n" or a lone "\\r"; a line without
its ending (or a "\\r" last, maybe the start of "\\r\\n") waits unless the block is final.

Reference: that rule in Python over the bytes (_rule_split), for split_lines and split_block
(Lines), on blocks of lines of every length around the 16-byte pieces (empty lines, lines of
1 to 70 bytes, runs of '\\n'), bytes >= 0x80, with and without a CR, final or not."""
from __future__ import annotations

import random

import pytest

from gcode_opt import state as st

pytestmark = pytest.mark.skipif(st._reader is None or not hasattr(st._reader, "split_block"),
                                reason="the compiled reader is not built here")


def _rule_split(buf, final):
    """(the lines' bytes, the bytes they take) by the rule"""
    out, i, n = [], 0, len(buf)
    while i < n:
        j = i
        while j < n and buf[j] not in b"\r\n":
            j += 1
        if j == n:
            if not final:
                break
            e = n
        elif buf[j] == 13:
            if j + 1 == n and not final:
                break
            e = j + 2 if j + 1 < n and buf[j + 1] == 10 else j + 1
        else:
            e = j + 1
        out.append(buf[i:e])
        i = e
    return out, i


def _block(rng, cr):
    out = bytearray()
    for _ in range(rng.randint(0, 60)):
        n = rng.choice([0, 0, 1, 2, rng.randint(3, 20), rng.randint(14, 18), rng.randint(20, 70)])
        line = bytearray(rng.choice(b"G1 XYE0123456789.-;") for _ in range(n))
        if line and rng.random() < 0.05:
            line[rng.randrange(len(line))] = rng.choice([0x80, 0xc3, 0xff])
        out += line + (rng.choice([b"\r\n", b"\r", b"\n"]) if cr and rng.random() < 0.3 else b"\n")
    if rng.random() < 0.5:
        out += bytes(rng.choice(b"G1 X0123456789") for _ in range(rng.randint(0, 30)))   # a line without its ending
    return bytes(out)


def _as_bytes(lines):
    return [ln.encode("utf-8", "surrogateescape") for ln in lines]


@pytest.mark.parametrize("seed", range(4))
def test_split_is_the_rule(seed):
    rng = random.Random(4320 + seed)
    reader = st._reader
    for i in range(400):
        buf = _block(rng, cr=i % 4 == 3)
        for final in (False, True):
            want = _rule_split(buf, final)
            lines, used = reader.split_lines(buf, final)
            assert (_as_bytes(lines), used) == want, (buf, final)
            block, used = reader.split_block(buf, final)
            assert (_as_bytes(list(block)), used) == want, (buf, final)
