"""Where each re-timed stroke's block landed in the written file: rows (first output line,
last output line, stroke index), in file order, as rewrite() makes them and measure, the
second pass and the summary read them.

Held as three array("q") (24 bytes a row): a list of tuples held ~130 bytes a row (the
tuple and two int objects past the small ints; ~6.7 MB for the rectilinear plate's 52 k
strokes, through the rewrite, the measure and the summary).  Reads as that list did: len,
[k] and iteration give (first, last, stroke) tuples, made when read."""
from __future__ import annotations

from array import array
from operator import itemgetter

import numpy as np

_FIRST, _LAST, _STROKE = itemgetter(0), itemgetter(1), itemgetter(2)


class OutRanges:
    __slots__ = ("first", "last", "stroke")

    def __init__(self, rows=()):
        self.first, self.last, self.stroke = array("q"), array("q"), array("q")
        self.take(list(rows))

    def append(self, row):
        a, z, i = row
        self.first.append(a)
        self.last.append(z)
        self.stroke.append(i)

    def take(self, rows: list):
        """Append the rows of the list rows (tuples, as the compiled rewrite appends them)
        and empty it: its tuples are let go as soon as they are copied."""
        if rows:
            self.first.extend(map(_FIRST, rows))
            self.last.extend(map(_LAST, rows))
            self.stroke.extend(map(_STROKE, rows))
            rows.clear()

    def __len__(self):
        return len(self.first)

    def __getitem__(self, k):
        if isinstance(k, slice):
            out = OutRanges()
            out.first, out.last, out.stroke = self.first[k], self.last[k], self.stroke[k]
            return out
        return self.first[k], self.last[k], self.stroke[k]

    def __iter__(self):
        return zip(self.first, self.last, self.stroke)

    def __eq__(self, other):
        if isinstance(other, (OutRanges, list, tuple)):
            return len(self) == len(other) and all(a == tuple(b) for a, b in zip(self, other))
        return NotImplemented

    __hash__ = None

    def __repr__(self):
        return f"OutRanges({list(self)!r})"


def columns(out_ranges):
    """(first, last, stroke) of out_ranges (an OutRanges, or a list of rows) as three int64
    arrays of their own."""
    if type(out_ranges) is OutRanges:
        return tuple(np.frombuffer(a, np.int64).copy() for a in (out_ranges.first, out_ranges.last, out_ranges.stroke))
    rows = np.array(list(out_ranges), np.int64).reshape(-1, 3)
    return rows[:, 0].copy(), rows[:, 1].copy(), rows[:, 2].copy()


class Digests:
    """stroke index -> the 16-byte digest (blake2b) of the block written for it, for the
    strokes 0 .. n - 1: what a second pass compares to find the blocks it changed.  Held in
    one bytearray, 17 bytes a stroke (a dict of bytes held ~120 bytes a block: ~4.4 MB on
    the rectilinear plate through the measure).  Reads as that dict did: d[i] (KeyError
    where no block was written), d.get(i), i in d, len(d)."""
    __slots__ = ("_d", "_has")

    def __init__(self, n):
        self._d = bytearray(16 * n)
        self._has = bytearray(n)

    def __setitem__(self, i, dg):
        if len(dg) != 16:
            raise ValueError("Digests: a digest is 16 bytes")
        if not 0 <= i < len(self._has):
            raise IndexError(f"Digests: stroke {i} out of range")
        self._d[16 * i:16 * i + 16] = dg
        self._has[i] = 1

    def __getitem__(self, i):
        if not self._has[i]:
            raise KeyError(i)
        return bytes(self._d[16 * i:16 * i + 16])

    def get(self, i, default=None):
        return self[i] if self._has[i] else default

    def __contains__(self, i):
        return 0 <= i < len(self._has) and bool(self._has[i])

    def __len__(self):
        return self._has.count(1)

    def take(self, d: dict):
        """Set the entries of the dict d (as the compiled rewrite fills one) and empty it:
        in rows (one join and two fancy assignments, not a call an entry)."""
        if not d:
            return
        blob = b"".join(d.values())
        if len(blob) != 16 * len(d):           # (a digest of another size: said by __setitem__)
            for i, dg in d.items():
                self[i] = dg
        else:
            idx = np.fromiter(d.keys(), np.int64, len(d))
            if idx.size and (idx.min() < 0 or idx.max() >= len(self._has)):
                raise IndexError("Digests: a stroke out of range")
            np.frombuffer(self._d, np.uint8).reshape(-1, 16)[idx] = np.frombuffer(blob, np.uint8).reshape(-1, 16)
            np.frombuffer(self._has, np.uint8)[idx] = 1
        d.clear()

    def differ(self, other: "Digests"):
        """A bool array, stroke by stroke: self.get(i) != other.get(i)."""
        h1 = np.frombuffer(self._has, np.uint8).astype(bool)
        h2 = np.frombuffer(other._has, np.uint8).astype(bool)
        d1 = np.frombuffer(self._d, np.uint8).reshape(-1, 16)
        d2 = np.frombuffer(other._d, np.uint8).reshape(-1, 16)
        return (h1 != h2) | (h1 & h2 & (d1 != d2).any(axis=1))
