"""The line plans a windowed run makes, kept in an unnamed file for the rewrite (issue 8,
benchmarks/lines56.md).

A windowed run lets each line's segment plan go once its figures are on the plan
(schedule._window_figures, _line_figures); the rewrite needs the plans of the re-timed
lines again (schedule._PlansAgain).  Remaking them was ~0.08 s of the rectilinear plate's
windowed rewrite; here each plan the runs make is written once, as it is made, a record of
doubles a plan, and a row points at the record of the plan its (line class, T, beta) gave
(many rows share one: a line's plan is its key's, segments.plan_once).  The rewrite reads
back the records of a window's rows, one plan object a record shared by its rows, where the
record's (T, beta) is the row's bit for bit; the other rows are the caller's to make.

Held in memory: 6 bytes a row (where its record starts, its segment count); the records
themselves are the file's."""
from __future__ import annotations

import os
from itertools import compress, repeat
from functools import partial
from operator import attrgetter, eq

import numpy as np

from .distinct import distinct
from .segments import RowPlan, SegmentPlan

# a record: T, beta, time_t, int_a2, its type (_TYPES' index), 1.0 where its fault verdict
# was "" when written (else 0.0: None, made again when asked), its shape (_SHAPES' index),
# then the knots s (n + 1), speeds v (n + 1), accelerations (n) and feeds (n) of its n segments
HEAD = 7
_TYPES = (RowPlan, SegmentPlan)
_SHAPES = ("law", "trapezoid")
MAX_N = np.iinfo(np.uint16).max         # segments a record's plan has at most (LineSpill.nseg)
MAX_END = np.iinfo(np.int32).max        # doubles the records take at most (LineSpill.at)
GAP = 2048                              # doubles between two records read in one pread at most
_F64 = np.dtype(float)


def record_len(n):
    """The doubles of the record of a plan of n segments."""
    return HEAD + 4 * n + 2


class LineSpill:
    """Records of line plans in an unnamed file (the module's doc).  put writes plans and
    gives where each went; point makes rows point at records; take reads rows' plans back."""

    def __init__(self, n_rows, fh):
        self.fh = fh
        self.at = np.full(n_rows, -1, np.int32)     # a row's record: its first double's index (-1: none)
        self.nseg = np.zeros(n_rows, np.uint16)     # its plan's segments
        self.end = 0                                # the doubles written
        self.last = None                            # the call before's (records, their (T, beta), plans)

    @classmethod
    def make(cls, n_rows, folder=None):
        """A spill over n_rows rows in folder (None: the temporary folder), or None where no
        file can be made there."""
        from .outfile import unnamed_file
        try:
            return cls(n_rows, unnamed_file(folder))
        except OSError:
            return None

    def put(self, plans, T, beta):
        """The plans (a list; None: no plan) made at (T, beta) (float arrays, one a plan)
        written: (where each record starts (int32, -1 where not written: None, another type
        or shape, a junction command, odd arrays, a failed write), its segments (uint16)).
        RowPlans of one block written by the block (most plans: _row_blocks), the others
        one by one."""
        m = len(plans)
        at, ns = np.full(m, -1, np.int32), np.zeros(m, np.uint16)
        if self.fh is None or not m:
            return at, ns
        T, beta = np.asarray(T, float), np.asarray(beta, float)
        parts, qs, lens = [], [], []
        blocks, rest = _row_blocks(plans)
        for block, ii, rr in blocks:
            parts.append(_block_records(block, rr, [plans[q] for q in ii.tolist()], T[ii], beta[ii]).ravel())
            qs.append(ii)
            lens.append(np.full(ii.size, block[2].shape[1], np.int64))
        for q in rest:
            got = _record(plans[q], T[q], beta[q])
            if got is not None:
                parts += got
                qs.append(np.array([q], np.int64))
                lens.append(np.array([got[1].size - 1], np.int64))     # (the knots: n + 1)
        if not qs:
            return at, ns
        buf = np.concatenate(parts)
        qs, n = np.concatenate(qs), np.concatenate(lens)
        size = record_len(n)
        if self.end + buf.size > MAX_END:           # (indices past int32: nothing more written)
            self.close()
            return at, ns
        try:
            self.fh.seek(self.end * 8)
            mv, done = buf.data.cast("B"), 0
            while done < len(mv):
                done += self.fh.write(mv[done:])
        except OSError:
            self.close()
            return at, ns
        at[qs] = self.end + np.cumsum(size) - size
        ns[qs] = n
        self.end += buf.size
        return at, ns

    def point(self, rows, at, nseg):
        """Rows (an int array) point at the records at (put's: -1 none) of nseg segments."""
        self.at[rows], self.nseg[rows] = at, nseg

    def take(self, rows, T, beta):
        """(the rows of rows (sorted) whose record was made at their (T, beta) (arrays, one a
        row), their plans (a list: one object a record, shared by its rows); the other rows).
        The records of the call before are not read again: their plans are taken (a line
        class's rows recur window after window: rectilinear plate, ~10 k records a command
        read without it, ~7 k with it)."""
        at = self.at[rows] if self.fh is not None else np.full(rows.size, -1, np.int32)
        has = at >= 0
        if not has.any():
            self.last = None
            return rows[:0], [], rows
        hat = at[has].astype(np.int64)
        u = distinct(hat)                           # each record once, in the file's order
        which = np.searchsorted(u, hat)
        n_u = np.zeros(u.size, np.int64)
        n_u[which] = self.nseg[rows[has]]
        plans, tb = [None] * u.size, np.empty((u.size, 2))
        new = np.ones(u.size, bool)
        if self.last is not None:
            lu, ltb, lplans = self.last
            k = np.minimum(np.searchsorted(lu, u), lu.size - 1)
            old = np.flatnonzero(lu[k] == u)
            new[old] = False
            tb[old] = ltb[k[old]]
            for q, p in zip(old.tolist(), map(lplans.__getitem__, k[old].tolist())):
                plans[q] = p
        self.last = None                            # (its plans not held past this call's)
        need = np.flatnonzero(new)
        if need.size:
            try:
                buf, start = self._read(u[need], record_len(n_u[need]))
            except OSError:         # (the records lost: every row the caller's)
                self.close()
                return rows[:0], [], rows
            for g, G, n in _blocks(buf, start, n_u[need]):
                g = need[g]
                tb[g] = G[:, :2]
                for q, p in zip(g.tolist(), _plans(G, n)):
                    plans[q] = p
        self.last = (u, tb, plans)
        # a record is the row's where it was made for the row's (T, beta), bit for bit
        tb_v = tb.view(np.int64)
        same = ((tb_v[which, 0] == np.asarray(T, float)[has].view(np.int64))
                & (tb_v[which, 1] == np.asarray(beta, float)[has].view(np.int64)))
        has[has] = same
        return rows[has], list(map(plans.__getitem__, which[same].tolist())), rows[~has]

    def _read(self, at, lens):
        """The records at at (sorted, distinct; doubles from the file's start, lens long):
        (one array of their doubles, each one's first index there); records less than GAP
        doubles apart read in one pread (with what lies between)."""
        z = at + lens
        cut = np.flatnonzero(at[1:] > z[:-1] + GAP) + 1
        chunks, start, base = [], np.empty(at.size, np.int64), 0
        for f, e in zip([0] + cut.tolist(), cut.tolist() + [at.size]):
            lo, hi = int(at[f]), int(z[e - 1])
            chunks.append(np.frombuffer(os.pread(self.fh.fileno(), (hi - lo) * 8, lo * 8), float))
            if chunks[-1].size != hi - lo:
                raise OSError("line plans' spill cut short")
            start[f:e] = base + at[f:e] - lo
            base += hi - lo
        return (chunks[0] if len(chunks) == 1 else np.concatenate(chunks)), start

    def close(self):
        """The file let go (no record read again)."""
        if self.fh is not None:
            self.fh.close()
            self.fh = None

    __del__ = close             # (with the plan's remake: not left to the collector's warning)


def _record(p, T, beta):
    """[head, s, v, accel, feed] of plan p's record at (T, beta), or None where p is not one
    the records hold: a RowPlan or SegmentPlan of a shape of _SHAPES, no junction command,
    four 1-D float64 arrays of n + 1, n + 1, n, n numbers (n <= MAX_N)."""
    kind = type(p)
    if kind is not RowPlan and kind is not SegmentPlan or p.first_cmds is not None or p.shape not in _SHAPES:
        return None
    arrs = [p.s, p.v, p.accel, p.feed]
    if not all(type(a) is np.ndarray and a.ndim == 1 and a.dtype == _F64 for a in arrs):
        return None
    n = arrs[2].size
    if not (arrs[0].size == arrs[1].size == n + 1 and arrs[3].size == n and n <= MAX_N):
        return None
    head = np.array([T, beta, p.time_t, p.int_a2, _TYPES.index(kind), 1.0 if p.fault == "" else 0.0,
                     _SHAPES.index(p.shape)])
    return [head] + arrs


def _row_blocks(plans):
    """plans' RowPlans with no junction command, of a shape of _SHAPES, rows of 2-D float64
    blocks S, V, A, F of n + 1, n + 1, n, n columns (n <= MAX_N), by their blocks:
    ([((S, V, A, F), their places in plans, their rows)], the other places (not None))."""
    by, rest = {}, []
    for q, p in enumerate(plans):
        if p is None:
            continue
        if type(p) is RowPlan and type(p._row) is int and p.first_cmds is None and type(p._v) is np.ndarray:
            key = (id(p._s), id(p._v), id(p._accel), id(p._feed))
            got = by.get(key)
            if got is None:
                got = by[key] = ((p._s, p._v, p._accel, p._feed), [], [])
            got[1].append(q)
            got[2].append(p._row)
        else:
            rest.append(q)
    out = []
    for block, ii, rr in by.values():
        S, V, A, F = block
        n = A.shape[1] if type(A) is np.ndarray and A.ndim == 2 else -1
        if (n >= 0 and n <= MAX_N and all(type(x) is np.ndarray and x.ndim == 2 and x.dtype == _F64 for x in block)
                and S.shape[1] == V.shape[1] == n + 1 and F.shape[1] == n
                and all(plans[q].shape in _SHAPES for q in ii)):
            out.append((block, np.array(ii, np.int64), np.array(rr, np.intp)))
        else:
            rest += ii
    return out, rest


def _block_records(block, rows, plans, T, beta):
    """The records (m, record_len(n)) of the RowPlans plans, rows `rows` of block (S, V, A, F)."""
    S, V, A, F = block
    m, n = len(plans), A.shape[1]
    R = np.empty((m, record_len(n)))
    k = HEAD
    R[:, 0], R[:, 1] = T, beta
    R[:, 2] = np.fromiter(map(_TIME_T, plans), float, m)
    R[:, 3] = np.fromiter(map(_INT_A2, plans), float, m)
    R[:, 4] = 0.0                       # (_TYPES' RowPlan)
    R[:, 5] = np.fromiter(map(_FINE, map(_FAULT, plans)), float, m)
    R[:, 6] = np.fromiter(map(_SHAPES.index, map(_SHAPE, plans)), float, m)
    R[:, k:k + n + 1] = S[rows]
    R[:, k + n + 1:k + 2 * n + 2] = V[rows]
    R[:, k + 2 * n + 2:k + 3 * n + 2] = A[rows]
    R[:, k + 3 * n + 2:] = F[rows]
    return R


_TIME_T, _INT_A2 = attrgetter("time_t"), attrgetter("int_a2")
_FAULT, _SHAPE = attrgetter("fault"), attrgetter("shape")
_FINE = partial(eq, "")                 # (a verdict "": 1.0; None or a reason: 0.0)


def _blocks(buf, start, ns):
    """The records (first doubles start in buf, of plans of ns segments) as blocks of one
    segment count: [(their indices, the block (m, record_len(n)) gathered from buf, n)]."""
    o = np.argsort(ns, kind="stable")
    no = ns[o]
    cut = np.flatnonzero(no[1:] != no[:-1]) + 1
    out = []
    for a, z in zip([0] + cut.tolist(), cut.tolist() + [o.size]):
        g, n = o[a:z], int(no[a])
        out.append((g, buf[start[g][:, None] + np.arange(record_len(n))], n))
    return out


def _plans(G, n):
    """The plans of n segments of the records G (rows): RowPlans as rows of G's blocks,
    SegmentPlans of their own copies, each with its verdict "" where its record had it."""
    k = HEAD
    S, V = G[:, k:k + n + 1], G[:, k + n + 1:k + 2 * n + 2]
    A, F = G[:, k + 2 * n + 2:k + 3 * n + 2], G[:, k + 3 * n + 2:]
    t, a2, kind, shape = G[:, 2].tolist(), G[:, 3].tolist(), G[:, 4], G[:, 6]
    m = G.shape[0]
    if not kind.any() and not shape.any():      # (the usual case: every one a RowPlan of the law)
        plans = list(map(RowPlan, repeat(S, m), repeat(V, m), repeat(A, m), repeat(F, m), range(m), t, a2))
    else:
        sh = [_SHAPES[int(c)] for c in shape.tolist()]
        plans = [RowPlan(S, V, A, F, i, t[i], a2[i], sh[i]) if kind[i] == 0.0
                 else SegmentPlan(S[i].copy(), V[i].copy(), A[i].copy(), F[i].copy(), t[i], a2[i], sh[i])
                 for i in range(m)]
    for p in compress(plans, G[:, 5].tolist()):
        p.fault = ""
    return plans
