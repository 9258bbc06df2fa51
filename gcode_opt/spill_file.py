"""An unnamed file of doubles that a windowed run's plans are written to as they are made
and read back from by the rewrite (schedule._ChainSpill: the chains'; line_spill.LineSpill:
the lines'): appended to, read in runs of records, let go.  The records' layout and index are
each spill's own."""
from __future__ import annotations

import os
from functools import partial
from itertools import chain, compress, repeat
from operator import attrgetter, eq

import numpy as np

from . import objfields

_F64 = np.dtype(np.float64)
_PREADV = getattr(os, "preadv", None)       # (not on every system: there the runs are joined)


class SpillFile:
    """fh: the file (None once let go, or never made); end: the doubles written."""

    def __init__(self, fh):
        self.fh = fh
        self.end = 0

    @staticmethod
    def open(folder=None):
        """An unnamed file in folder (None: the temporary folder), or None where none can be
        made there."""
        from .outfile import unnamed_file
        try:
            return unnamed_file(folder)
        except OSError:
            return None

    def append(self, buf, max_end):
        """buf (float64) written at the file's end: the double it starts at; None where the
        file would pass max_end doubles (its index's type) or the write failed: the file is
        then let go (no record read again; the caller makes its plans again)."""
        end = self.end
        if end + buf.size > max_end:
            self.close()
            return None
        try:
            self.fh.seek(end * 8)
            mv, done = buf.data.cast("B"), 0
            while done < len(mv):
                done += self.fh.write(mv[done:])
        except OSError:
            self.close()
            return None
        self.end += buf.size
        return end

    def read_runs(self, a, z, cut, what):
        """The records at doubles a[i] .. z[i] - 1 (sorted, not overlapping) read one pread a
        run (a run starts at each position of cut, and at 0): (one array of their doubles,
        each record's first index there).  OSError if the file ends early.  Each run read
        straight into its place in the one array (preadv), not read apart and joined: the
        join copied every double read once more (~11 M instructions of memcpy in the
        gyroid plate's windowed rewrite, its chains' ~10 MB of records)."""
        if _PREADV is not None and a.size:
            return self._read_into(a, z, cut, what)
        chunks, start, base = [], np.empty(a.size, np.int64), 0
        for f, e in zip([0] + cut.tolist(), cut.tolist() + [a.size]):
            lo, hi = int(a[f]), int(z[e - 1])
            chunks.append(np.frombuffer(os.pread(self.fh.fileno(), (hi - lo) * 8, lo * 8), float))
            if chunks[-1].size != hi - lo:
                raise OSError(f"{what} spill cut short")
            start[f:e] = base + a[f:e] - lo
            base += hi - lo
        return (chunks[0] if len(chunks) == 1 else np.concatenate(chunks)), start

    def _read_into(self, a, z, cut, what):
        """read_runs' answer, each run read by preadv into its slice of one new array."""
        firsts = [0] + cut.tolist()
        lasts = cut.tolist() + [a.size]
        lo = a[firsts]
        hi = z[np.array(lasts, np.intp) - 1]
        base = np.cumsum(hi - lo) - (hi - lo)           # each run's first double in the array
        buf = np.empty(int((hi - lo).sum()), float)
        mv = memoryview(buf).cast("B")
        start = np.empty(a.size, np.int64)
        fd = self.fh.fileno()
        for f, e, l, h, b in zip(firsts, lasts, lo.tolist(), hi.tolist(), base.tolist()):
            n = (h - l) * 8
            if _PREADV(fd, [mv[b * 8:b * 8 + n]], l * 8) != n:
                raise OSError(f"{what} spill cut short")
            start[f:e] = b + a[f:e] - l
        return buf, start

    def close(self):
        """The file let go (no record read again)."""
        if self.fh is not None:
            self.fh.close()
            self.fh = None

    __del__ = close             # (with the plan's remake: not left to the collector's warning)


def plan_arrays(p, shapes, max_n):
    """[s, v, accel, feed] of segment plan p where a spill's record holds it: a RowPlan or
    SegmentPlan whose shape is one of shapes, with no junction command, and four 1-D float64
    arrays of n + 1, n + 1, n and n numbers (n <= max_n); else None."""
    from .segments import RowPlan, SegmentPlan
    kind = type(p)
    if kind is not RowPlan and kind is not SegmentPlan or p.first_cmds is not None or p.shape not in shapes:
        return None
    arrs = [p.s, p.v, p.accel, p.feed]
    if not all(type(a) is np.ndarray and a.ndim == 1 and a.dtype == _F64 for a in arrs):
        return None
    n = arrs[2].size
    if not (arrs[0].size == arrs[1].size == n + 1 and arrs[3].size == n and n <= max_n):
        return None
    return arrs


def record_plans(G, n, head, cols, shapes=("law",)):
    """The plans of n segments of the records G (rows: `head` doubles, then the knots s
    (n + 1), speeds v (n + 1), accelerations (n) and feeds (n)): RowPlans as rows of G's
    blocks, SegmentPlans of their own copies, each with its verdict "" where its record had
    it.  cols: the head's columns of time_t, int_a2, the type (0.0: a RowPlan), the verdict
    (1.0: "") and the shape (an index into shapes), or None where the records keep no shape
    (every one the law's)."""
    from .segments import RowPlan, SegmentPlan
    c_t, c_a2, c_kind, c_fine, c_shape = cols
    S, V = G[:, head:head + n + 1], G[:, head + n + 1:head + 2 * n + 2]
    A, F = G[:, head + 2 * n + 2:head + 3 * n + 2], G[:, head + 3 * n + 2:]
    t, a2, kind = G[:, c_t].tolist(), G[:, c_a2].tolist(), G[:, c_kind]
    shape = None if c_shape is None else G[:, c_shape]
    m = G.shape[0]
    if not kind.any() and (shape is None or not shape.any()):     # (the usual case: every one a RowPlan of the law)
        plans = list(map(RowPlan, repeat(S, m), repeat(V, m), repeat(A, m), repeat(F, m), range(m), t, a2))
    else:
        sh = [shapes[0]] * m if shape is None else [shapes[int(c)] for c in shape.tolist()]
        rowplan = (kind == 0.0).tolist()
        # a SegmentPlan's four arrays its own: rows of one copy of its block's rows (the
        # same numbers; each plan's rows apart from G and from the others'), made at once
        # and handed out as row views, not a numpy index and copy of each row (~17 k
        # instructions a plan: the rectilinear plate's ~360 SegmentPlans a windowed rewrite)
        own = np.flatnonzero(~(kind == 0.0))
        arrs = iter(zip(*(list(X[own]) for X in (S, V, A, F)))) if own.size else iter(())
        plans = [RowPlan(S, V, A, F, i, t[i], a2[i], sh[i]) if rowplan[i] else SegmentPlan(*next(arrs), t[i], a2[i], sh[i])
                 for i in range(m)]
    for p in compress(plans, G[:, c_fine].tolist()):
        p.fault = ""
    return plans


def row_plans(blocks, H):
    """The RowPlans of blocks [(S, V, A, F, k)]: k of each, the i-th of a block row i of its
    S, V, A, F, in order; plan q's time_t and int_a2 H[q, 0] and H[q, 1], its verdict ""
    where H[q, 2] is not 0.0 (H: a float64 array, a row a plan).  Made by the rewrite
    core's row_plans where built (no Python call a plan: ~1 us each through
    RowPlan.__init__, ~16 k chain plans in a windowed gyroid rewrite), else by a map."""
    from .emit import CORE_MOD
    from .segments import RowPlan
    make = getattr(CORE_MOD, "row_plans", None)
    if make is not None and type(H) is np.ndarray and H.dtype == _F64:
        got = make(RowPlan, blocks, np.ascontiguousarray(H), "law", "")
        if got is not None:
            return got
    plans = list(map(RowPlan, *[chain.from_iterable([repeat(b[j], b[4]) for b in blocks]) for j in range(4)],
                     chain.from_iterable(range(b[4]) for b in blocks), H[:, 0].tolist(), H[:, 1].tolist()))
    for p in compress(plans, H[:, 2].tolist()):
        p.fault = ""
    return plans


def block_plans(buf, start, blocks, head, cols, shapes=("law",)):
    """The plans of the records of buf at start (m of them), given as blocks [(their
    indices in 0 .. m - 1, their rows G, n)] (record_plans' layout and cols), as one list
    in start's order: record_plans of each block, but the heads of all read in one gather
    and, where every record is a RowPlan of the law (the usual case), the objects of all
    blocks made by one call (row_plans; a windowed gyroid rewrite reads ~1 k blocks of ~16
    chain plans: benchmarks/out57.md)."""
    from .objfields import put_at
    c_t, c_a2, c_kind, c_fine, c_shape = cols
    H = buf[start[:, None] + np.array([c_t, c_a2, c_fine, c_kind] + ([] if c_shape is None else [c_shape]))]
    out = [None] * start.size
    odd = H[:, 3:].any(axis=1)        # a SegmentPlan, or another shape: its block by record_plans, as before
    some_odd = odd.any()
    where, rows = [], []
    for g, G, n in blocks:
        if some_odd and odd[g].any():
            for q, p in zip(g.tolist(), record_plans(G, n, head, cols, shapes)):
                out[q] = p
            continue
        where.append(g)
        rows.append((G[:, head:head + n + 1], G[:, head + n + 1:head + 2 * n + 2], G[:, head + 2 * n + 2:head + 3 * n + 2],
                     G[:, head + 3 * n + 2:], G.shape[0]))
    if not where:
        return out
    at = np.concatenate(where).astype(np.intp, copy=False)
    plans = row_plans(rows, H[at])
    if not put_at(out, at, plans):
        for q, p in zip(at.tolist(), plans):
            out[q] = p
    return out


_TIME_T, _INT_A2, _FAULT = attrgetter("time_t"), attrgetter("int_a2"), attrgetter("fault")
_FINE = partial(eq, "")                 # (a verdict "": True; None or a reason: False)


def plan_heads(plans, out):
    """The four head columns both spills write of each plan (a list, a row of out each):
    its time_t and int_a2, 0.0 (the spills' type code of a RowPlan) and 1.0 where its fault
    verdict is "" (made: its checks passed), else 0.0; read by objfields' compiled passes
    where built, else one np.fromiter each (the same numbers)."""
    m = len(plans)
    fig = objfields.floats(plans, ("time_t", "int_a2"))
    if fig is None:
        out[:, 0] = np.fromiter(map(_TIME_T, plans), float, m)
        out[:, 1] = np.fromiter(map(_INT_A2, plans), float, m)
    else:
        out[:, 0:2] = fig
    out[:, 2] = 0.0
    fine = objfields.codes(plans, "fault", {"": 0}, add=True)     # (a verdict "": code 0)
    out[:, 3] = np.fromiter(map(_FINE, map(_FAULT, plans)), float, m) if fine is None else fine == 0
