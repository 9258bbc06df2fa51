"""The windowed run's curve geometry made once (issue 8, benchmarks/geom57.md).

A window loaded from the StrokeStore comes back without its curves' geometry (the store
keeps no cache: stroke_store), so the windowed run made the same geometry again at every
pass: plan_inputs' chains.classify, the candidates' window loads (stored_strokes'
on_load), the budget runs and the rewrite (schedule._rebuild_geometry): ~4 times the
list path's build_geoms on the gyroid plate.  GeomKeep writes the geometry plan_inputs
leaves on each curve and chain (curves._Blk rows as the list path keeps them through its
passes: the lengths, caps, cap, end turns, κ_eff, κ at the vertices where made, the
chains' caps) to an unnamed file as it is made, and gives it back to the strokes later
loads make: the same doubles, in blocks of one vertex count (the blocks' make is not
seen: build_geoms' bits are row by row, benchmarks/geoms55.md).

A record a window of rows (several where plan_inputs' calls cut a window), all doubles: a
header (parts, rows, the chains' caps' doubles, then each part's segment count n, rows m
and flags; a part: the rows of one block in the window), N_COLS columns of one double a
row, each part's 2-D arrays (lengths, caps where kept), the chains' caps end to end; then
κ at the vertices apart, read only where asked (the candidates: its one reader).  A
geometry GeomKeep does not take (CurveGeom's own, a block holding caps at the whole jerk,
chain caps of another length) is not written: the caller makes it as before
(build_geoms)."""
from __future__ import annotations

import os
from bisect import bisect_left, bisect_right
from itertools import chain, compress, repeat
from operator import attrgetter, is_not

import numpy as np

from . import objfields
from .curves import _BLOCKS, _CURVE_CORE, _NO_ENDS, _Blk, put_rows
from .spill_file import SpillFile

# a part's flags: which arrays its record holds
F_CAPS, F_KE, F_KV, F_CAP_MIN = 1, 2, 4, 8
# a row's bits (the record's last column): κ_eff not made, a chain's caps kept, κ at the vertices not made
R_KE_MISS, R_CHAIN, R_KV_MISS = 1, 2, 4
# the record's columns, one double a row: window row, cap, the two end turns (NaN: None),
# the limits' index (GeomKeep.lims), accel, κ_eff, the row's bits
C_ROW, C_CAP, C_END0, C_END1, C_LIM, C_ACCEL, C_KE, C_BITS = range(8)
N_COLS = 8
_MAX_END = 1 << 60          # doubles a file may hold (no index type to outgrow)
_BYTES_OR_NONE = {bytes, type(None)}
_CURV, _K, _CHAIN_CAPS = attrgetter("curv"), attrgetter("_k"), attrgetter("chain_caps")
_PTS = attrgetter("pts")
_PWRITEV = getattr(os, "pwritev", None)     # (not on every system: there a record is joined first)
_IOV_MAX = 512              # buffers a pwritev writes at most (under IOV_MAX, 1024)


def _bytes_of(x):
    return x if type(x) is bytes else np.ascontiguousarray(x, float).tobytes()


class GeomKeep(SpillFile):
    """The curve geometry of a StrokeStore's rows by window of `window` rows (the module's
    doc).  recs: {window: [(first double, main doubles, κ doubles)]}; lims: the limits
    objects met (the blocks' lim reads them by index)."""

    def __init__(self, window, profile, folder=None):
        super().__init__(SpillFile.open(folder))
        self.window, self.profile = int(window), profile
        self.recs = {}
        self.lims, self._lim_at = [], {}
        self.given = 0              # geometries given back (a measure)

    # ------------------------------------------------------------------ writing
    def put(self, lo, sts, codes):
        """Keep the geometry of the curves and chains (codes: plan_kind codes) of sts, the
        strokes of rows lo.. (as plan_inputs left it)."""
        from .schedule import C_CHAIN, C_CURVE
        if self.fh is None:
            return
        rows = np.flatnonzero((codes == C_CURVE) | (codes == C_CHAIN))
        if not rows.size:
            return
        gs = list(map(_CURV, objfields.items(sts, rows)))
        try:
            # the blocks in the order first met, each row's place among them; each row's row in its block
            bs, which = objfields.by_identity(gs, "_b")
            ks = objfields.codes(gs, "_k", None)
            if ks is None:
                ks = np.fromiter(map(_K, gs), np.int64, len(gs))
        except AttributeError:          # (a geometry of another make, or none: each made again)
            return
        cc = list(map(_CHAIN_CAPS, gs))
        # the rows of each block (in row order), the blocks in the order of their first rows
        order = np.argsort(which, kind="stable")
        cut = (np.flatnonzero(np.diff(which[order])) + 1).tolist()
        runs = [(a, z) for a, z in zip([0] + cut, cut + [len(order)]) if _keepable(bs[int(which[order[a]])])]
        if not runs:
            return
        # the kept blocks' rows, block after block
        at = np.concatenate([order[a:z] for a, z in runs]) if len(runs) > 1 else order[runs[0][0]:runs[0][1]]
        blocks = [bs[int(which[order[a]])] for a, _ in runs]
        lens = [z - a for a, z in runs]
        kq = ks[at]
        got = objfields.take(cc, at)
        cc = list(map(cc.__getitem__, at.tolist())) if got is None else got
        cols = self._columns(blocks, lens, kq, cc)
        rs = rows[at] + lo
        W = self.window
        js = rs // W
        cols[C_ROW] = rs - js * W
        jcut = (np.flatnonzero(np.diff(js)) + 1).tolist()          # (where a window ends)
        parts = {}                      # window -> [parts: (head, columns, 2-D arrays, chain caps, κ arrays)]
        fit, whole, caps, at_byte = _chain_fits(blocks, lens, kq, cc, cols[C_BITS])
        r0 = 0
        for b, m, ok, all_rows in zip(blocks, lens, fit, whole):
            r1 = r0 + m
            if ok:
                (n, flags), arrs, kap = self._block(b, None if all_rows else kq[r0:r1])
                cuts = jcut[bisect_right(jcut, r0):bisect_left(jcut, r1)]
                for c, e in zip([r0] + cuts, cuts + [r1]):
                    parts.setdefault(int(js[c]), []).append(
                        ((n, e - c, flags), cols[:, c:e], [x[c - r0:e - r0] for x in arrs],
                         caps[at_byte[c]:at_byte[e]], [x[c - r0:e - r0] for x in kap]))
            r0 = r1
        for j, ps in parts.items():
            self._write(j, ps)

    def _columns(self, blocks, lens, ks, cc):
        """The record's columns (N_COLS, rows; the row column left for the caller) of the
        blocks' rows ks (lens of them a block, block after block), their chain caps cc
        (each bytes or None: made so here, in place): each column gathered from the
        blocks' arrays joined, in a few numpy calls a put, not ~20 a block (~620 blocks
        on the gyroid plate).  The limits objects of each block indexed in the order met."""
        R = len(ks)
        at = np.repeat(np.cumsum([0] + [b.d.shape[0] for b in blocks[:-1]]), lens) + ks     # (in the joined arrays)
        lim_at, table = [], []
        for b in blocks:
            lim_at.append(len(table))
            table += [self._lim_index(x) for x in b._lim[1]]
        nan = np.full(max(b.d.shape[0] for b in blocks), np.nan)
        no = np.zeros(nan.size, bool)
        cols = np.empty((N_COLS, R))
        cols[C_CAP] = np.concatenate([b.cap for b in blocks])[at]
        cols[C_ACCEL] = np.concatenate([b._lim[3] for b in blocks])[at]
        which = np.concatenate([b._lim[2] for b in blocks])[at] + np.repeat(lim_at, lens)
        cols[C_LIM] = np.array(table, float)[which]
        if all(b._end2 is not None for b in blocks):       # (build_geoms' columns of them: one gather)
            cols[C_END0:C_END1 + 1] = np.concatenate([b._end2 for b in blocks], axis=1)[:, at]
        else:
            cols[C_END0:C_END1 + 1] = _end_cols(list(map(list(chain.from_iterable(b.cos_end for b in blocks)).__getitem__,
                                                         at.tolist())))
        cols[C_KE] = np.concatenate([nan[:b.d.shape[0]] if b._ke is None else b._ke for b in blocks])[at]
        bits = np.zeros(R, np.int64)
        for name, r in (("_ke", R_KE_MISS), ("_kv", R_KV_MISS)):
            miss = [None if getattr(b, name) is None else getattr(b, name + "_miss") for b in blocks]
            if any(x is not None for x in miss):
                bits[np.concatenate([no[:b.d.shape[0]] if x is None else x for b, x in zip(blocks, miss)])[at]] |= r
        # the caps' classes by the compiled codes' table (its keys: the classes met), not a
        # set made of every row's class besides (~2.6 M instructions, windowed gyroid)
        classes = {type(None): 0}
        got = objfields.codes(cc, "__class__", classes, add=True)
        if not (classes.keys() if got is not None else set(map(type, cc))) <= _BYTES_OR_NONE:   # (vertex_caps' arrays)
            cc[:] = [c if c is None or type(c) is bytes else np.asarray(c, float).tobytes() for c in cc]
        bits[np.fromiter(map(is_not, cc, repeat(None)), bool, R) if got is None else got != 0] |= R_CHAIN
        cols[C_BITS] = bits
        return cols

    @staticmethod
    def _block(b, ks):
        """((n, flags), 2-D arrays, κ arrays) of the block b's rows ks (None: all its rows, in
        order: the block's own arrays, not a copy of them)."""
        n = b.d.shape[1]
        flags = F_CAP_MIN if b.cap_min else 0
        arrs = [b.d if ks is None else b.d[ks]]
        if b._caps is not None:
            flags |= F_CAPS
            arrs.append(b._caps if ks is None else b._caps[ks])
        if b._ke is not None:
            flags |= F_KE
        kap = []
        if b._kv is not None:
            flags |= F_KV
            kap.append(b._kv if ks is None else b._kv[ks])
        return (n, flags), arrs, kap

    def _lim_index(self, lim):
        k = self._lim_at.get(id(lim))
        if k is None:
            k = self._lim_at[id(lim)] = len(self.lims)
            self.lims.append(lim)
        return k

    def _write(self, j, parts):
        """Window j's record of parts (_part's): the header (parts, rows, chain caps' doubles,
        each part's n, m, flags), the columns (N_COLS, rows), each part's 2-D arrays, the
        chains' caps, then κ at the vertices.  The pieces written as they are, one gathered
        write (_append_pieces), not joined into one buffer first (a copy of every double
        of the record, ~200 kB a record on the gyroid plate)."""
        head = [len(parts), sum(p[0][1] for p in parts), sum(len(p[3]) for p in parts) // 8]
        head += [x for p in parts for x in p[0]]
        main = [np.asarray(head, float), np.concatenate([p[1] for p in parts], axis=1).ravel()]
        main += [a.ravel() for p in parts for a in p[2]]
        kap = [a.ravel() for p in parts for a in p[4]]
        n_main = sum(a.size for a in main) + head[2]
        n_kap = sum(a.size for a in kap)
        at = self._append_pieces(main + [p[3] for p in parts] + kap, n_main + n_kap)
        if at is None:
            self.recs = {}          # (the file let go: every geometry made again)
            return
        self.recs.setdefault(j, []).append((at, n_main, n_kap))

    def _append_pieces(self, pieces, n):
        """The pieces (float64 arrays and bytes of doubles, n doubles in all) written one
        after the other at the file's end, by gathered writes (os.pwritev; else joined and
        SpillFile.append): the double they start at, or None as append answers it."""
        if _PWRITEV is None:
            return self.append(np.frombuffer(b"".join(map(_bytes_of, pieces)), float), _MAX_END)
        end = self.end
        if end + n > _MAX_END:
            self.close()
            return None
        bufs = [x if type(x) is bytes else np.ascontiguousarray(x, float).data.cast("B") for x in pieces]
        pos, fd = end * 8, self.fh.fileno()
        try:
            for a in range(0, len(bufs), _IOV_MAX):
                part = bufs[a:a + _IOV_MAX]
                want = sum(map(len, part))
                got = _PWRITEV(fd, part, pos)
                if got != want:         # (a short write: the rest of this part as one buffer)
                    rest = memoryview(b"".join(map(bytes, part)))[got:]
                    while len(rest):
                        k = os.pwrite(fd, rest, pos + got)
                        rest, got = rest[k:], got + k
                pos += want
        except OSError:
            self.close()
            return None
        self.end += n
        return end

    # ------------------------------------------------------------------ reading back
    def give(self, rows, sts, kappa=False):
        """Put the kept geometry on the strokes sts of rows (store rows, in order) that have
        none: each window's record read once, a block a part (of the rows asked).  kappa:
        κ at the vertices too (else made when read, as after curves.drop_kappa)."""
        if not self.recs or not len(rows):
            return
        W = self.window
        rows = np.asarray(rows, np.int64)
        js = rows // W
        cut = (np.flatnonzero(np.diff(js)) + 1).tolist()
        for a, z in zip([0] + cut, cut + [len(rows)]):
            j = int(js[a])
            recs = self.recs.get(j)
            if not recs:
                continue
            pos = np.full(W, -1, np.int64)          # (each window row's stroke in sts; read only)
            pos[rows[a:z] - j * W] = np.arange(a, z)
            for rec in recs:
                self._give_rec(rec, pos, sts, kappa)

    def _pread(self, at, n):
        """n doubles from double at, in an array of their own (writable: a block's κ rows not
        made are made into it, _Blk.make_kappa)."""
        out = np.empty(n)
        if os.preadv(self.fh.fileno(), [out], at * 8) != 8 * n:
            raise OSError("geometry spill cut short")
        return out

    def _give_rec(self, rec, pos, sts, kappa):
        """The parts of record rec (first double, main doubles, κ doubles) put on the
        strokes sts[pos[row]] (pos: -1 where a window row is not asked) that have none:
        _give_whole where every row is asked (the candidates' loads), else _give_parts."""
        at, n_main, n_kap = rec
        main = self._pread(at, n_main)
        P, R = int(main[0]), int(main[1])
        head = main[3:3 + 3 * P].astype(np.int64).reshape(P, 3).tolist()
        x = 3 + 3 * P
        cols = main[x:x + N_COLS * R].reshape(N_COLS, R)
        at_r = pos[cols[C_ROW].astype(np.int64)]           # each row's stroke in sts (-1: not asked)
        asked = at_r >= 0
        if not asked.any():
            return
        kap = self._pread(at + n_main, n_kap) if kappa and n_kap else None
        if asked.all():
            self._give_whole(main, kap, head, cols, at_r, sts)
        else:
            self._give_parts(main, kap, head, cols, at_r, asked, sts)

    def _give_whole(self, main, kap, head, cols, at_r, sts):
        """_give_rec of a record whose every row is asked: each part's block takes views of
        the record (its lengths, caps, κ_eff, cap, limits, accelerations), with fewer
        numpy calls a part; the parts' rows without κ found for every part at once (where
        a row of the record has any)."""
        R = cols.shape[1]
        bits = cols[C_BITS].astype(np.int64)
        any_ke = any_kv = None
        if (bits & (R_KE_MISS | R_KV_MISS)).any():
            r_at = np.cumsum([m for _, m, _ in head]) - [m for _, m, _ in head]
            ke_miss, kv_miss = (bits & R_KE_MISS) != 0, (bits & R_KV_MISS) != 0
            any_ke = np.logical_or.reduceat(ke_miss, r_at).tolist()
            any_kv = np.logical_or.reduceat(kv_miss, r_at).tolist()
        which = cols[C_LIM].astype(np.int32)
        ends = _ends(cols[C_END0], cols[C_END1], True)
        chain = _rows_chain_caps(main[main.size - int(main[2]):], head, bits)
        lim = (self.profile, self.lims)
        bsts_all = objfields.items(sts, at_r)
        x = 3 + 3 * len(head) + N_COLS * R
        r0 = y = 0
        for p, (n, m, fl) in enumerate(head):
            r1, xa, ya = r0 + m, x, y
            x += m * n + (m * (n - 1) if fl & F_CAPS else 0)
            y += m * (n + 1) if fl & F_KV else 0
            d = main[xa:xa + m * n].reshape(m, n)
            caps = main[xa + m * n:xa + m * (2 * n - 1)].reshape(m, n - 1) if fl & F_CAPS else None
            kv = kap[ya:ya + m * (n + 1)].reshape(m, n + 1) if fl & F_KV and kap is not None else None
            ke = cols[C_KE, r0:r1] if fl & F_KE else None
            bsts = bsts_all[r0:r1]
            blk = _Blk(d, None, kv, ke, caps, None, cols[C_CAP, r0:r1], ends[r0:r1], bool(fl & F_CAP_MIN),
                       pts=list(map(_PTS, bsts)), lim=lim + (which[r0:r1], cols[C_ACCEL, r0:r1]))
            # (its own masks: make_kappa clears their rows as it makes them)
            if ke is not None and any_ke is not None and any_ke[p]:
                blk._ke_miss = ke_miss[r0:r1].copy()
            if kv is not None and any_kv is not None and any_kv[p]:
                blk._kv_miss = kv_miss[r0:r1].copy()
            _BLOCKS.add(blk)
            self.given += _give_rows(blk, bsts, chain[r0:r1])
            r0 = r1

    def _give_parts(self, main, kap, head, cols, at_r, asked, sts):
        """_give_rec of a record whose rows are asked in part (the runs' curves, then
        chains): each part's rows asked copied into a block of their own (a part asked
        whole: views of the record, as _give_whole).  The asked rows' columns (cap, κ_eff,
        limits, accelerations, κ masks, end turns, strokes) are gathered once for the
        record and each part's block takes its run of them, not ~15 numpy calls a part
        (a windowed gyroid run: ~2.9 k parts, ~70 % of them not asked at all)."""
        n_main, P, R = main.size, len(head), cols.shape[1]
        x = 3 + 3 * P + N_COLS * R
        rs = np.flatnonzero(asked)                   # the record's rows asked, in order
        # each part's first place in rs (part p: rs[at[p]:at[p + 1]])
        at = np.searchsorted(rs, np.cumsum([0] + [m for _, m, _ in head])).tolist()
        got = cols[:, rs]                           # (their columns, one gather)
        bits_all = cols[C_BITS].astype(np.int64)
        bits = bits_all[rs]
        ke_any = kv_any = None                      # (the parts with rows whose κ is not made)
        if (bits & (R_KE_MISS | R_KV_MISS)).any():
            ke_miss, kv_miss = (bits & R_KE_MISS) != 0, (bits & R_KV_MISS) != 0
            ke_any, kv_any = _runs_any(ke_miss, at), _runs_any(kv_miss, at)
        which = got[C_LIM].astype(np.int32)
        cap, accel, ke_col = got[C_CAP], got[C_ACCEL], got[C_KE]
        ends = _ends(got[C_END0], got[C_END1], True)
        chain = _rows_chain_caps(main[n_main - int(main[2]):], head, bits_all, rs)
        bsts_all = objfields.items(sts, at_r[rs])
        lim = (self.profile, self.lims)
        r0 = y = 0
        for p, (n, m, flags) in enumerate(head):
            r1, xa, ya = r0 + m, x, y
            x += m * n + (m * (n - 1) if flags & F_CAPS else 0)
            y += m * (n + 1) if flags & F_KV else 0
            a, z = at[p], at[p + 1]
            k = z - a
            if not k:
                r0 = r1
                continue
            d = main[xa:xa + m * n].reshape(m, n)
            caps = main[xa + m * n:xa + m * (2 * n - 1)].reshape(m, n - 1) if flags & F_CAPS else None
            kv = kap[ya:ya + m * (n + 1)].reshape(m, n + 1) if flags & F_KV and kap is not None else None
            if k < m:
                sel = rs[a:z] - r0
                d = d[sel]
                caps = None if caps is None else caps[sel]
                kv = None if kv is None else kv[sel]
            ke = ke_col[a:z] if flags & F_KE else None
            bsts = bsts_all[a:z]
            blk = _Blk(d, None, kv, ke, caps, None, cap[a:z], ends[a:z], bool(flags & F_CAP_MIN),
                       pts=list(map(_PTS, bsts)), lim=lim + (which[a:z], accel[a:z]))
            if ke is not None and ke_any is not None and ke_any[p]:
                blk._ke_miss = ke_miss[a:z]
            if kv is not None and kv_any is not None and kv_any[p]:
                blk._kv_miss = kv_miss[a:z]
            _BLOCKS.add(blk)
            self.given += _give_rows(blk, bsts, chain[a:z])
            r0 = r1


def _rows_chain_caps(flat, head, bits, rs=None):
    """Each of the rows rs' (sorted; None: every row) chain caps, in their order: the bytes
    of its n - 1 doubles (as chains' _classify_block keeps them), or None, from the chain
    caps flat (rows in order; bits: every row's).  One slice of the caps' bytes a row
    that has them (_byte_runs)."""
    has = (bits & R_CHAIN) != 0
    w = np.repeat([8 * (n - 1) for n, _, _ in head], [m for _, m, _ in head])
    z = np.cumsum(np.where(has, w, 0))
    if rs is not None:
        has, w, z = has[rs], w[rs], z[rs]
    if not has.any():
        return [None] * has.size
    return _byte_runs(flat, z - w, z, has)


def _byte_runs(flat, a, z, has):
    """[flat's bytes[a[i]:z[i]] if has[i] else None for each i] (a, z int64 arrays, has a
    bool array): one compiled pass where built (~38 k chains a windowed gyroid run)."""
    if _BYTE_RUNS is not None:
        return _BYTE_RUNS(flat, a, z, has, has.size)
    buf = flat.tobytes()
    return [buf[i:j] if h else None for h, i, j in zip(has.tolist(), a.tolist(), z.tolist())]


_BYTE_RUNS = getattr(_CURVE_CORE, "byte_runs", None)


def _runs_any(mask, at):
    """Whether any of mask[at[p]:at[p + 1]] is set, a bool a run p (an empty run: False)."""
    c = np.concatenate(([0], np.cumsum(mask)))[at]
    return (c[1:] > c[:-1]).tolist()


def _give_rows(blk, sts, chain):
    """Row k of blk (curves.row_geom, its chain caps the k-th of chain) put on sts[k] where
    it has no geometry; how many were given (curves.put_rows: one compiled pass)."""
    return put_rows(blk, sts, chain)


def _chain_fits(blocks, lens, ks, cc, bits):
    """For put's blocks (lens of its rows a block, their rows ks in their blocks, block
    after block; cc their chain caps, bytes or None; bits the C_BITS column): (whether each
    block is kept: no chain of it, or the chains' caps that are not empty all n - 1
    doubles and at least one such (a bool list); whether its rows are all its rows in
    order (a bool list); the chains' caps joined, row after row; each row's first byte
    there (R + 1 ints)).  A few numpy calls a put, not a Python pass over the rows a
    block (~620 blocks on the windowed gyroid plate)."""
    R = len(ks)
    has = (bits.astype(np.int64) & R_CHAIN) != 0
    clen = np.zeros(R, np.int64)
    if has.any():
        clen[has] = np.fromiter(map(len, compress(cc, has.tolist())), np.int64)
    first = np.cumsum([0] + lens[:-1])
    n = np.array([b.d.shape[1] for b in blocks], np.int64)
    full = clen > 0
    wrong = full & (clen != 8 * (np.repeat(n, lens) - 1))
    any_of = np.logical_or.reduceat
    fit = ~any_of(has, first) | (any_of(full, first) & ~any_of(wrong, first))
    rows = np.array([b.d.shape[0] for b in blocks], np.int64)
    whole = np.logical_and.reduceat(ks == np.arange(R) - np.repeat(first, lens), first) & (rows == lens)
    at_byte = np.zeros(R + 1, np.int64)
    np.cumsum(clen, out=at_byte[1:])
    return fit.tolist(), whole.tolist(), b"".join(filter(None, cc)), at_byte.tolist()


def _keepable(b):
    """Whether block b is build_geoms' (a 2-D float block of rows, its limits, no caps at
    the whole jerk, cap an array, κ arrays or none): CurveGeom's own (a list of one cap)
    and anything else are made again by the caller."""
    return (type(b) is _Blk and b._u is None and b._lim is not None and b.caps_jerk1 is None
            and type(b.d) is np.ndarray and b.d.ndim == 2 and b.d.dtype == np.float64 and b.d.shape[1] >= 1
            and type(b.cap) is np.ndarray and len(b.cos_end) == b.d.shape[0]
            and all(x is None or type(x) is np.ndarray for x in (b._caps, b._ke, b._kv)))


def _end_cols(ends):
    """The end turns' cosines of CurveGeom.cos_end's ends as (2, m) doubles, NaN where None
    (most are curves._NO_ENDS: only the others converted)."""
    out = np.full((len(ends), 2), np.nan)
    turn = [e is not _NO_ENDS for e in ends]
    if any(turn):
        out[np.flatnonzero(turn)] = np.array(list(compress(ends, turn)), float).reshape(-1, 2)
    return out.T


def _ends(c0, c1, asked):
    """CurveGeom.cos_end of each asked row whose end turns' cosines are c0 and c1 (NaN
    where None): curves._NO_ENDS where neither end turns (and where not asked), else a
    tuple of the doubles (numpy float64, as curves._ends_of gives them)."""
    m0, m1 = ~np.isnan(c0), ~np.isnan(c1)
    turn = (m0 | m1) & asked
    out = [_NO_ENDS] * c0.size
    for k, a, b in zip(np.flatnonzero(turn).tolist(), m0[turn].tolist(), m1[turn].tolist()):
        out[k] = (c0[k] if a else None, c1[k] if b else None)
    return out
