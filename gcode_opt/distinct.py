"""np.unique(a)'s plain form without its first-call cost: numpy 2's np.unique asks
numpy.ma whether the array is masked, which imports numpy.ma (~8 ms a run) for every
command.  distinct(a) is the same array, bit for bit: the sorted, flattened values with
each run of equal ones kept once (its first, as np.unique keeps it: the same sort), NaNs
as one (np.unique's equal_nan), of a's dtype.

column_classes(cols): a class per row of int64 columns, rows of one class equal in every
column (by a hash of the rows, not np.unique's sort of their bytes as records);
column_classes_first(cols) also each class's first row.

unique_first_inverse(h): np.unique(h, return_index=True, return_inverse=True)'s (first,
inverse) of a 1-D int64 / uint64 array, by one packed sort (np.unique where that cannot
give them).

value_codes(values): a code per value of a list of hashable values, equal values one code."""
from __future__ import annotations

import numpy as np

from . import objfields


def distinct(a) -> np.ndarray:
    s = np.asanyarray(a).flatten()
    s.sort()
    if s.size <= 1:
        return s
    keep = np.empty(s.size, bool)
    keep[0] = True
    np.not_equal(s[1:], s[:-1], out=keep[1:])
    if s.dtype.kind in "fc" and np.isnan(s[-1]):       # NaNs sort last: keep the first one only
        first = np.searchsorted(s, s[-1], side="left") if s.dtype.kind == "f" else int(np.flatnonzero(np.isnan(s))[0])
        keep[first + 1:] = False
        keep[first] = True
    return s[keep]


def column_classes(cols):
    """A class per row of the int64 columns cols (each (m,), any strides): rows of one
    class equal in every column.  Rows are hashed to one int64 (a wrapping sum of products
    by odd constants), sorted by it, and each row then compared with the first of its
    hash: one that differs (a collision) is a class of its own.  Column by column: no
    temporary wider than a column."""
    return column_classes_first(cols)[0]


def column_classes_first(cols):
    """(column_classes(cols), each class's first row): classes 0 .. k - 1, every one
    used."""
    m = cols[0].shape[0]
    h = _row_hashes(cols)
    first, inv = unique_first_inverse(h)
    del h
    out = inv.astype(np.int64)
    rep = first[inv]                        # each row's first of its hash
    odd = np.zeros(m, bool)
    for c in cols:
        odd |= c != c[rep]
    odd = np.flatnonzero(odd)
    out[odd] = first.size + np.arange(odd.size)
    return out, np.concatenate([first, odd])


def _row_hashes(cols):
    """column_classes' hash of each row of the int64 columns cols (uint64)."""
    w = len(cols)
    mult = (np.arange(1, w + 1, dtype=np.uint64) * np.uint64(0x9E3779B97F4A7C15)) | np.uint64(1)
    h = None                  # (the first column's mix is the row's: 0 ^ y is y, no zeroed array)
    for j, c in enumerate(cols):
        x = c.view(np.uint64) * mult[j]
        if h is None:
            h = x ^ (x >> np.uint64(29))
        else:
            h ^= x ^ (x >> np.uint64(29))
        h *= np.uint64(0xBF58476D1CE4E5B9)
    return h


_LOW32 = np.uint64(0xFFFFFFFF)
_SIGN64 = np.uint64(1 << 63)


def unique_first_inverse(h):
    """(first, inv) of np.unique(h, return_index=True, return_inverse=True), inv flat, the
    same arrays for a 1-D int64 or uint64 h.  np.unique finds them by a stable argsort
    (timsort, ~14 M instructions for 48 k keys); here by one sort of the keys' top 32 bits
    with each one's index in the bottom 32 (~2x fewer): where the keys come out in order
    that is the stable argsort's order (equal keys share their top bits, so go by index),
    and where two keys of one top half come out of order, np.unique itself."""
    m = h.size
    if h.ndim != 1 or h.dtype not in (np.uint64, np.int64) or not 2 <= m < 2 ** 32:
        _, first, inv = np.unique(h, return_index=True, return_inverse=True)
        return first, inv.ravel()
    u = h.view(np.uint64) if h.dtype == np.uint64 else h.view(np.uint64) ^ _SIGN64    # (int64's order)
    key = (u & ~_LOW32) | np.arange(m, dtype=np.uint64)
    key.sort()
    perm = (key & _LOW32).astype(np.intp)
    del key
    srt = u[perm]
    new = np.empty(m, bool)                 # where a run of equal keys starts
    new[0] = True
    np.greater(srt[1:], srt[:-1], out=new[1:])
    if not np.greater_equal(srt[1:], srt[:-1]).all():
        _, first, inv = np.unique(h, return_index=True, return_inverse=True)
        return first, inv.ravel()
    inv = np.empty(m, np.intp)
    inv[perm] = np.cumsum(new) - 1
    return perm[new], inv


def classes_in_row_order(cols):
    """(first, inv) of column_classes_first(cols), the classes numbered in the order of
    their first rows: first ascending, row q in class inv[q] (intp), equal in every column
    to row first[inv[q]]."""
    cls, first = column_classes_first(cols)
    by_first = np.argsort(first)
    place = np.empty(first.size, np.intp)   # class -> its place among the firsts
    place[by_first] = np.arange(first.size)
    return first[by_first], place[cls]



def value_codes(values):
    """({value: its code}, in the order of first appearance, and the code of each of the
    list `values` (hashable; an intp array)): `codes == code_of[v]` is the mask where the
    values equal v, for values that are equal exactly when their hashes and == agree
    (str, int, None), made by one pass of dict look-ups in C rather than a compare of
    every value of an object array per distinct value (~100 instructions a value)."""
    code_of = {}
    code = objfields.codes(values, None, code_of, add=True)     # (one compiled pass: the same dict)
    if code is not None:
        return code_of, code
    code_of = {v: c for c, v in enumerate(dict.fromkeys(values))}
    return code_of, np.fromiter(map(code_of.__getitem__, values), np.intp, len(values))
