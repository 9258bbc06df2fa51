"""The line plans a windowed run makes, kept in an unnamed file for the rewrite (issue 8,
benchmarks/lines56.md).

A windowed run lets each line's segment plan go once its figures are on the plan
(schedule._line_figures); the rewrite needs the plans of the re-timed lines again
(schedule._PlansAgain).  Remaking them was ~0.08 s of the rectilinear plate's windowed
rewrite; here each plan the runs make is written once, as it is made, a record of doubles a
plan, under its key (line class, T, beta): a line's plan is its key's (segments.plan_once).
The rewrite reads back the records of a window's rows by their keys, one plan object a
record shared by its rows; a row whose key has no record is the caller's to make.

Held in memory: an index of the records by a hash of their keys, 18 bytes a record
(rectilinear plate: ~6 k records for ~52 k strokes; a row index was 6 bytes a stroke, the
end of the run's peak); the records themselves are the file's."""
from __future__ import annotations

from operator import attrgetter

import numpy as np

from .segments import RowPlan, SegmentPlan
from . import objfields
from .spill_file import SpillFile, block_plans, plan_arrays, plan_heads

# a record: its key (line class (its int64's bits), T, beta), time_t, int_a2, its type
# (_TYPES' index), 1.0 where its fault verdict was "" when written (else 0.0: None, made again
# when asked), its shape (_SHAPES' index), then the knots s (n + 1), speeds v (n + 1),
# accelerations (n) and feeds (n) of its n segments
HEAD = 8
_TYPES = (RowPlan, SegmentPlan)
_SHAPES = ("law", "trapezoid")
MAX_N = np.iinfo(np.uint16).max         # segments a record's plan has at most (LineSpill.nseg)
MAX_END = 1 << 40                       # doubles the records take at most
GAP = 2048                              # doubles between two records read in one pread at most
_F64 = np.dtype(float)


def record_len(n):
    """The doubles of the record of a plan of n segments."""
    return HEAD + 4 * n + 2


class LineSpill(SpillFile):
    """Records of line plans in an unnamed file (the module's doc): put writes plans under
    their keys, take reads rows' plans back by theirs."""

    def __init__(self, fh):
        super().__init__(fh)
        self.h = np.zeros(0, np.uint64)             # the records' key hashes (_key_hash), sorted
        self.at = np.zeros(0, np.int64)             # each one's record: its first double's index
        self.nseg = np.zeros(0, np.uint16)          # its plan's segments
        self.last = None                            # the call before's (records, their keys, plans)

    @classmethod
    def make(cls, folder=None):
        """A spill in folder (None: the temporary folder), or None where no file can be made
        there."""
        fh = SpillFile.open(folder)
        return None if fh is None else cls(fh)

    def put(self, plans, cls, T, beta):
        """The plans (a list; None: no plan) made for the keys (cls, T, beta) (int64 and
        float arrays, one a plan) written and indexed, but those the records do not hold
        (None, another type or shape, a junction command, odd arrays).  A failed write ends
        the spill (no record read again).  RowPlans of one block written by the block (most
        plans: _row_blocks), the others one by one."""
        m = len(plans)
        if self.fh is None or not m:
            return
        cls = np.asarray(cls, np.int64)
        T, beta = np.asarray(T, float), np.asarray(beta, float)
        parts, qs, lens = [], [], []
        blocks, rest = _row_blocks(plans)
        for block, ii, rr in blocks:
            parts.append(_block_records(block, rr, [plans[q] for q in ii.tolist()], cls[ii], T[ii], beta[ii]).ravel())
            qs.append(ii)
            lens.append(np.full(ii.size, block[2].shape[1], np.int64))
        if rest:
            got = _rest_records(plans, rest, cls, T, beta)
            if got is not None:
                parts += got[0]
                qs.append(got[1])
                lens.append(got[2])
        if not qs:
            return
        buf = np.concatenate(parts)
        qs, n = np.concatenate(qs), np.concatenate(lens)
        size = record_len(n)
        end = self.append(buf, MAX_END)
        if end is None:
            return
        h = np.concatenate([self.h, _key_hash(cls[qs], T[qs], beta[qs])])
        o = np.argsort(h, kind="stable")
        self.h = h[o]
        self.at = np.concatenate([self.at, end + np.cumsum(size) - size])[o]
        self.nseg = np.concatenate([self.nseg, n.astype(np.uint16)])[o]

    def take(self, rows, cls, T, beta):
        """(the rows of rows (sorted) whose key (cls, T, beta: arrays, one a row) has a
        record, their plans (a list: one object a record, shared by its rows); the other
        rows).  The records of the call before are not read again: their plans are taken (a
        line class's rows recur window after window: rectilinear plate, ~23.5 k records a
        command read without it, ~6.9 k with it).  Row by row only 1-D arrays are read
        (each record's key a column of int64 bits, not a (records, 3) array gathered a row
        at a time: ~170 instructions a row), and each record's place found through a table
        by index position (_places), not sorted and searched."""
        cls = np.asarray(cls, np.int64)
        T, beta = np.asarray(T, float), np.asarray(beta, float)
        if self.fh is None or not self.h.size or not rows.size:
            self.last = None
            return rows[:0], [], rows
        h = _key_hash(cls, T, beta)
        k = np.searchsorted(self.h, h)
        np.minimum(k, self.h.size - 1, out=k)
        has = self.h[k] == h
        if not has.any():
            self.last = None
            return rows[:0], [], rows
        every = bool(has.all())                     # (the windows' case: every row's key recorded)
        kh = k if every else k[has]
        u_k, which = _places(kh, self.h.size, self.at)
        u = self.at[u_k]                            # each record once, in the file's order
        n_u = self.nseg[u_k]
        plans, key = [None] * u.size, [np.empty(u.size, np.int64) for _ in range(3)]
        new = np.ones(u.size, bool)
        if self.last is not None:
            lu, lkey, lplans = self.last
            j = np.minimum(np.searchsorted(lu, u), lu.size - 1)
            old = np.flatnonzero(lu[j] == u)
            new[old] = False
            jo = j[old]
            for c in range(3):
                key[c][old] = lkey[c][jo]
            _put_at(plans, old, lplans, jo)
        self.last = None                            # (its plans not held past this call's)
        need = np.flatnonzero(new)
        if need.size:
            try:
                buf, start = self._read(u[need], record_len(n_u[need]))
            except OSError:         # (the records lost: every row the caller's)
                self.close()
                return rows[:0], [], rows
            bits = buf.view(np.int64)
            for c in range(3):
                key[c][need] = bits[start + c]
            _put_at(plans, need, _plans(buf, start, _blocks(buf, start, n_u[need])))
        self.last = (u, key, plans)
        # a record is the row's where its key is the row's, bit for bit (not a hash's twin)
        if every:                                   # (no row left out: no mask taken of each array)
            same = ((key[0][which] == cls) & (key[1][which] == T.view(np.int64)) & (key[2][which] == beta.view(np.int64)))
            if same.all():
                return rows, objfields.items(plans, which), rows[:0]
        else:
            same = ((key[0][which] == cls[has]) & (key[1][which] == T[has].view(np.int64))
                    & (key[2][which] == beta[has].view(np.int64)))
        has[has] = same
        return rows[has], objfields.items(plans, which[same]), rows[~has]

    def _read(self, at, lens):
        """The records at at (sorted, distinct; doubles from the file's start, lens long):
        (one array of their doubles, each one's first index there); records less than GAP
        doubles apart read in one pread (with what lies between)."""
        z = at + lens
        return self.read_runs(at, z, np.flatnonzero(at[1:] > z[:-1] + GAP) + 1, "line plans'")


def _places(k, n, at):
    """(the distinct positions of k (ints in 0 .. n - 1) in the order of their at, each
    k's place in that list): distinct(at[k]) and its searchsorted, by a mark and a place
    a position in tables of n (the index's records: tens of kB), not a sort and a binary
    search of every row (the rows of a window are ~4x its records)."""
    mark = np.zeros(n, bool)
    mark[k] = True
    u_k = np.flatnonzero(mark)
    u_k = u_k[np.argsort(at[u_k], kind="stable")]
    place = np.empty(n, np.intp)
    place[u_k] = np.arange(u_k.size)
    return u_k, place[k]


# _key_hash's odd constants (as distinct.py's: multiples of the golden ratio's) and splitmix64's finish
_MULT = tuple(np.uint64((k * 0x9E3779B97F4A7C15) % (1 << 64) | 1) for k in (1, 2, 3))
_MIX = tuple((np.uint64(k), np.uint64(c)) for k, c in ((30, 0xBF58476D1CE4E5B9), (27, 0x94D049BB133111EB), (31, 1)))


def _key_hash(cls, T, beta):
    """A uint64 hash of each key (cls, T, beta) by its bits: equal keys, equal hashes (two
    keys may share one: take compares the records' keys)."""
    h = (np.ascontiguousarray(cls, np.int64).view(np.uint64) * _MULT[0]
         + np.ascontiguousarray(T, float).view(np.uint64) * _MULT[1]
         + np.ascontiguousarray(beta, float).view(np.uint64) * _MULT[2])
    for k, c in _MIX:
        h ^= h >> k
        h *= c
    return h


def _record(p, cls, T, beta):
    """[head, s, v, accel, feed] of plan p's record under key (cls, T, beta), or None where p is not one
    the records hold: a RowPlan or SegmentPlan of a shape of _SHAPES, no junction command,
    four 1-D float64 arrays of n + 1, n + 1, n, n numbers (n <= MAX_N)."""
    arrs = plan_arrays(p, _SHAPES, MAX_N)
    if arrs is None:
        return None
    head = np.array([0.0, T, beta, p.time_t, p.int_a2, _TYPES.index(type(p)), 1.0 if p.fault == "" else 0.0,
                     _SHAPES.index(p.shape)])
    head[:1].view(np.int64)[0] = cls
    return [head] + arrs


def _rest_records(plans, rest, cls, T, beta):
    """The records of the plans at the places rest (_record's each, those it holds): ([the
    parts to join, a record's head then its four arrays], their places (int64), their
    segment counts (int64)), or None where none is held.  Every head made in one array
    (plan_heads' compiled reads, the types' and shapes' codes), not an array a plan."""
    got = [(q, a) for q in rest for a in (plan_arrays(plans[q], _SHAPES, MAX_N),) if a is not None]
    if not got:
        return None
    qs = np.array([q for q, _ in got], np.int64)
    ps = list(map(plans.__getitem__, qs.tolist()))
    H = np.empty((qs.size, HEAD))
    H.view(np.int64)[:, 0] = cls[qs]
    H[:, 1], H[:, 2] = T[qs], beta[qs]
    plan_heads(ps, H[:, 3:7])           # (figures, a type code, verdicts: the type's made here)
    H[:, 5] = [_TYPES.index(type(p)) for p in ps]
    H[:, 7] = [_SHAPES.index(p.shape) for p in ps]
    parts = []
    for h, (_, arrs) in zip(H, got):
        parts.append(h)
        parts += arrs
    return parts, qs, np.array([a[2].size for _, a in got], np.int64)


def _row_blocks(plans):
    """plans' RowPlans with no junction command, of a shape of _SHAPES, rows of 2-D float64
    blocks S, V, A, F of n + 1, n + 1, n, n columns (n <= MAX_N), by their blocks:
    ([((S, V, A, F), their places in plans, their rows)], the other places (not None))."""
    got = _row_blocks_compiled(plans) if len(plans) >= COMPILED_PLANS else None
    if got is not None:
        return got
    # (a group found by its V's id, its other blocks compared by identity: not four ids and
    # a tuple a plan; a plan of the same V but other blocks keyed by all four, as before)
    by, rest = {}, []
    for q, p in enumerate(plans):
        if p is None:
            continue
        if type(p) is RowPlan and type(p._row) is int and p.first_cmds is None:
            V = p._v
            got = by.get(id(V))
            if got is None:
                if type(V) is not np.ndarray:
                    rest.append(q)
                    continue
                got = by[id(V)] = ((p._s, V, p._accel, p._feed), [], [])
            elif not (got[0][0] is p._s and got[0][2] is p._accel and got[0][3] is p._feed):
                key = (id(p._s), id(V), id(p._accel), id(p._feed))
                got = by.get(key)
                if got is None:
                    got = by[key] = ((p._s, V, p._accel, p._feed), [], [])
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


# plans a put groups by objfields' compiled passes (_row_blocks_compiled) from this many: a
# few passes a put, where the Python loop was ~3.6 k instructions a plan (rectilinear plate:
# ~6 k line plans in 25 blocks over its three runs' puts)
COMPILED_PLANS = 64


def _row_blocks_compiled(plans):
    """_row_blocks' answer (the same blocks, places, rows and other places, in the same
    order) read by objfields' compiled passes: the plans' classes, their RowPlans' rows,
    commands, shapes and four blocks' identities, each block's RowPlans then found by
    their four blocks' places; None where a pass declines (the core not built, a RowPlan's
    row not an int, a junction command, a V not an array): the caller's loop then."""
    kinds = objfields.codes(plans, "__class__", {RowPlan: 0, type(None): 1}, add=True)
    if kinds is None:
        return None
    rp = np.flatnonzero(kinds == 0)
    sub = objfields.take(plans, rp)
    if sub is None or not sub:
        return None
    rows = objfields.codes(sub, "_row", None)
    cmds = objfields.codes(sub, "first_cmds", {None: 0})
    shapes = objfields.codes(sub, "shape", dict(_SHAPE_CODES), add=True)
    if rows is None or cmds is None or shapes is None:
        return None
    keys = []
    heads = []
    for name in ("_s", "_v", "_accel", "_feed"):
        got = objfields.ids(sub, name)
        if got is None:
            return None
        heads.append(got[0])
        keys.append(got[1].astype(np.int64))
    if not all(type(V) is np.ndarray for V in heads[1]):
        return None
    # one int a plan for its four blocks' places (mixed radix of their distinct counts)
    ws = [len(h) for h in heads]
    if ws[0] * ws[1] * ws[2] * ws[3] >= 1 << 62:
        return None
    key = ((keys[0] * ws[1] + keys[1]) * ws[2] + keys[2]) * ws[3] + keys[3]
    _, first, inv = np.unique(key, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")            # the groups as first met
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    g = rank[inv.reshape(-1)]
    by = np.argsort(g, kind="stable")                   # the plans group by group, each in order
    ends = np.cumsum(np.bincount(g, minlength=order.size)).tolist()
    fine_shape = shapes < len(_SHAPES)
    out, rest = [], np.flatnonzero(kinds >= 2).tolist()
    for a, z, f in zip([0] + ends[:-1], ends, first[order].tolist()):
        mem = by[a:z]
        block = tuple(h[k[f]] for h, k in zip(heads, keys))
        S, V, A, F = block
        n = A.shape[1] if type(A) is np.ndarray and A.ndim == 2 else -1
        ii = rp[mem].astype(np.int64)
        if (n >= 0 and n <= MAX_N and all(type(x) is np.ndarray and x.ndim == 2 and x.dtype == _F64 for x in block)
                and S.shape[1] == V.shape[1] == n + 1 and F.shape[1] == n and fine_shape[mem].all()):
            out.append((block, ii, rows[mem].astype(np.intp)))
        else:
            rest += ii.tolist()
    return out, rest


_SHAPE_CODES = tuple(zip(_SHAPES, range(len(_SHAPES))))


def _block_records(block, rows, plans, cls, T, beta):
    """The records (m, record_len(n)) of the RowPlans plans, rows `rows` of block (S, V, A, F),
    under the keys (cls, T, beta)."""
    S, V, A, F = block
    m, n = len(plans), A.shape[1]
    R = np.empty((m, record_len(n)))
    k = HEAD
    R.view(np.int64)[:, 0] = cls
    R[:, 1], R[:, 2] = T, beta
    plan_heads(plans, R[:, 3:7])        # (figures, _TYPES' RowPlan, verdicts; the shapes below)
    shape = objfields.codes(plans, "shape", dict(zip(_SHAPES, range(len(_SHAPES)))))
    R[:, 7] = np.fromiter(map(_SHAPES.index, map(_SHAPE, plans)), float, m) if shape is None else shape
    R[:, k:k + n + 1] = S[rows]
    R[:, k + n + 1:k + 2 * n + 2] = V[rows]
    R[:, k + 2 * n + 2:k + 3 * n + 2] = A[rows]
    R[:, k + 3 * n + 2:] = F[rows]
    return R


_SHAPE = attrgetter("shape")


def _blocks(buf, start, ns):
    """The records (first doubles start in buf, of plans of ns segments) as blocks of one
    segment count: [(their indices, the block (m, record_len(n)) gathered from buf, n)]."""
    o = np.argsort(ns, kind="stable")
    no = ns[o]
    cut = np.flatnonzero(no[1:] != no[:-1]) + 1
    out = []
    for a, z in zip([0] + cut.tolist(), cut.tolist() + [o.size]):
        g, n = o[a:z], int(no[a])
        out.append((g, _rows_at(buf, start[g], record_len(n)), n))
    return out


def _rows_at(buf, start, width):
    """buf[start[:, None] + np.arange(width)] (buf 1-D, each start + width <= its size):
    where buf is a contiguous float64 array, the rows start of a view of buf whose row i
    is buf[i:i + width], taken a row at a time (a copy each), not a double at a time
    through a 2-D index (~20 instructions a double: ~4 M of the rectilinear plate's
    windowed rewrite)."""
    if type(buf) is np.ndarray and buf.dtype == _F64 and buf.ndim == 1 and buf.flags.c_contiguous and buf.size >= width:
        return np.ndarray((buf.size - width + 1, width), _F64, buf, 0, (_F64.itemsize, _F64.itemsize))[start]
    return buf[start[:, None] + np.arange(width)]


def _plans(buf, start, blocks):
    """The plans of the records of buf at start, as blocks (_blocks; the layout above), in
    start's order."""
    return block_plans(buf, start, blocks, HEAD, (3, 4, 5, 6, 7), _SHAPES)


def _put_at(dst, rows, src, at=None):
    """dst[i] = src[at[k]] (at None: src[k]) for k, i in enumerate(rows) (int arrays): in
    one compiled pass where built (objfields.put_at)."""
    rows = rows.astype(np.intp, copy=False)
    at = None if at is None else at.astype(np.intp, copy=False)
    if not objfields.put_at(dst, rows, src, at):
        for i, j in zip(rows.tolist(), range(rows.size) if at is None else at.tolist()):
            dst[i] = src[j]


