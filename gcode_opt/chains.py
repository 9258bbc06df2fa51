"""Chain strokes: a curve whose vertices cap the speed below the slicer's feed.

Gyroid, honeycomb, concentric infill and curved walls at the slicer's full speed are
runs of short G1 segments (~0.7 mm, turning ~10-25 deg) where the firmware's junction law
caps the speed at the vertices (classic jerk, Klipper's square-corner velocity) well
below F: the firmware brakes to the cap at every vertex and accelerates after it at the
full acceleration -- a sawtooth, the worst motion in the file.  A curve stroke
(curves.py) with a vertex whose cap x CAP_MARGIN is below its feed is a chain (classify;
the planner's kind K_CHAIN, plan_kind); it is re-timed as a whole.  To the rest of the
program it stays a curve (kind=curve in its block and in the summary): the same run of
G1 lines, one per original line, only the law differs.

Law (laws/chain.py): min ∫(ṡ² + β s̈²)dt with ṡ <= cap_i at every vertex, between the
original end speeds, in a duration T from the candidates; β = (T / GAMMA_MIN)², the
inertia term dominates as for curves.  Between binding vertices the firmware plays
straight segments, so the law is 1-D: only s̈ is in ∫|a|²dt there.

Emission: every original vertex is a knot, no new points.  Each segment goes from the
law's speed at one vertex to the next in the law's time: a pure ramp (F = the faster
end, a = the ramp's) where the law is monotone, else the bump the firmware plays with
those end speeds in that time with the least ∫a²dt: a trapezoid (up, cruise at F, down;
~16 % below the triangle for a small bump), or the triangle under classic jerk.  Accelerations are raised
to what the junctions need and the planner buffer asks (as curves.finish_curve does).

Prediction (predict_chain): what the firmware does with those segments -- its junction
speed at each vertex is the lowest of the junction law at the segments' own
accelerations and feeds, both feeds, and what the neighbouring ramps reach (a forward
and a backward pass, as its lookahead); each segment is then its trapezoid, plus the
normal term the firmware model counts at every vertex turning <= 30 deg.  The candidate
table holds these predicted figures, so the budget is spent on what the firmware does.
"""
from __future__ import annotations

import math
import sys
from array import array
from functools import partial
from itertools import compress, repeat
from operator import attrgetter, is_, is_not, itemgetter

import numpy as np

from .probe_rng import ProbeRng
from .distinct import unique_first_inverse
from . import curves
from . import objfields
from .firmware.junction import (SQRT2_M1, klipper_corner_v2, marlin_jd_v2, marlin_jd_v2_rows,
                                marlin_jerk_junction_v, marlin_safe_speed)
from .firmware.simulate import CORNER_COS, FULL_STOP_V
from .laws import chain as _chain_law
from .laws.chain import ChainProblem, _Flat, cold_binding, solve_chains, solve_flat
from .plan import SPEED_TOL_R, T_RATIOS, empty_table
from .segments import CRUISE_A, RowPlan, SegmentPlan, SegmentRules, hold_cruise_accels_rows, tent_feeds_rows
from .strokes import K_CHAIN, K_CURVE, Stroke

CHAIN_T_RATIOS = (1.0, 1.02, 1.05, 1.10, 1.25)   # the budget picks 1.0-1.07 at 3 %: 10 durations gained 0.02 pp
CHAIN_COLS = np.array([int(np.argmin(np.abs(T_RATIOS - r))) for r in CHAIN_T_RATIOS])
GAMMA_MIN = 0.1            # beta = (T / GAMMA_MIN)^2: the law is the min-∫a² one up to a 1 % speed term
MIN_FEED_V = 0.1           # mm/s: F of a segment between two (near) stops
CHAIN_CAP_MARGIN = 0.98    # on the firmware's vertex caps (rounding of the written F and accelerations)


# ------------------------------------------------------------------ which curves are chains
def vertex_caps(st, profile):
    """Firmware speed cap at every interior vertex (mm/s) x CHAIN_CAP_MARGIN: what the law
    must stay under.  The firmware goes to its own cap at a vertex whatever the law says
    (nothing else holds it lower there), so these are the original's own vertex limits:
    at the acceleration in force (segments are raised to what their junctions need), and
    for classic jerk the whole jerk (a chain's feeds are level: tent_feeds), not the
    share curves.py keeps for a change of F."""
    g = curves.geom(st, profile)
    if g.chain_caps is None:
        if profile.junction == "jerk":
            caps = g.caps_jerk1
            if caps is None:
                caps = curves.vertex_caps(profile, st.lim, st.accel, g.u, g.d, jerk_r=1.0)
        else:
            caps = g.caps
        g.chain_caps = CHAIN_CAP_MARGIN * caps
        g.caps_jerk1 = None         # read only to make chain_caps
    return _caps_array(g.chain_caps)


def _caps_array(c):
    """A chain's caps as its geometry keeps them (chain_caps: an array, or the bytes of its
    doubles where _classify_block made them) as an array of doubles (bytes: a read-only
    view of them)."""
    return np.frombuffer(c, float) if type(c) is bytes else c


def classify(strokes, rows, profile, end_cols=False, memo=None):
    """Curve strokes of `rows` with a vertex whose cap (x curves.CAP_MARGIN, as curves.py
    caps a curve's peak) is below the feed become chains.  end_cols: build_geoms'.  memo:
    the one ChainMemo every chain is marked with (plan_inputs' spilled: the strokes are
    stored and let go next, their memos stored as a mark alone), None: a new one each."""
    sts = [strokes[i] for i in rows if strokes[i].kind == K_CURVE]
    # κ made for the rows that will not be chains (a chain never reads it), by the test below
    # (the weights: plan_inputs' adjust_plan_inputs reads them next); the geometries put on
    # the strokes here where every stroke is a row of a block (put False): a chain's with
    # its caps, in one pass
    want = _NotChains()
    made = curves.build_geoms(sts, profile, jerk1=True, kappa=want, end_cols=end_cols,
                              weights=True, put=False) or []       # (None: a build_geoms of tests)
    every = sum(len(m[1]) for m in made) == len(sts)
    jerk = profile.junction == "jerk"
    for b, bsts in made:                 # the blocks build_geoms made: their rows in order
        # (_classify_block's chains are the rows cap < feed, the rows _NotChains did not
        # want κ made for: every row left a curve has it, none is left to make)
        if _classify_block(b, bsts, jerk, fresh=True, memo=memo, unput=every, hit=want.hit(bsts, b.cap)):
            continue
        if every:
            curves.put_rows(b, bsts, None, False)
        for st in bsts:
            _classify_one(st, profile, jerk)
        if (b._kv is None or b._kv_miss is not None) and _kappa_left(b, bsts):     # (a curve's κ not made yet: made now)
            b.make_kappa([k for k, st in enumerate(bsts) if st.chain_T is None])
    if not every:
        _classify_rest(sts, made, profile, jerk)
    if jerk:
        if every:                        # (their blocks: build_geoms' made)
            curves.drop_blocks_jerk1([m[0] for m in made])
        else:
            curves.drop_jerk1(sts)


_CHAIN_T = attrgetter("chain_T")


def _kappa_left(b, sts):
    """Whether b.make_kappa of the rows of sts (the block b's rows in order) that are no
    chain has a row to make: such a row, and κ not made for the block or for that row
    (classify asks it of the blocks _classify_block does not take: of those it takes, the
    rows left curves are the rows _NotChains wanted κ made for).
    Mostly not: build_geoms made κ for the rows _NotChains foresaw, the rows
    _classify_block did not make chains, or left it unmade where every row is a chain
    (make_kappa of no row then made the block's κ arrays, every row not made: the same
    to every reader as none, which makes the rows it reads; ~560 of the ~620 blocks of
    the windowed gyroid plate, ~12 numpy calls each, and arrays of nothing held)."""
    rows = np.fromiter(map(is_, map(_CHAIN_T, sts), repeat(None)), bool, len(sts))
    if not rows.any():
        return False
    if b._kv is None or b._ke is None:
        return True
    kv, ke = b._kv_miss, b._ke_miss
    if kv is None and ke is None:
        return False
    miss = kv if ke is None else ke if kv is None else kv | ke
    return bool(miss[rows].any())


class _NotChains:
    """build_geoms' want of classify: the rows of a block (strokes sts, cap their cap) whose
    κ is made at once, those _classify_block does not make chains (cap < feed); a row it
    does not foresee makes its κ when read.  The test of each block is kept for
    _classify_block, which asks it of the same list and cap after build_geoms (hit): each
    feed read once (~620 blocks on the windowed gyroid plate)."""
    __slots__ = ("_got",)

    def __init__(self):
        self._got = {}          # id(sts) -> (sts, cap, cap < feed): the lists held, their ids unique

    def __call__(self, sts, cap):
        feed = objfields.float_col(sts, "v_feed")
        feed = curves.floats_of(map(_V_FEED, sts), len(sts)) if feed is None else feed
        hit = cap < feed
        self._got[id(sts)] = (sts, cap, hit)
        return ~hit

    def hit(self, sts, cap):
        """cap < feed of the strokes sts as the call found it, if it was asked of this very
        list and cap (else None); let go."""
        got = self._got.pop(id(sts), None)
        return got[2] if got is not None and got[0] is sts and got[1] is cap else None


def _classify_rest(sts, made, profile, jerk):
    """classify's test of the strokes sts that are no row of a block build_geoms made
    (a geometry made before, or CurveGeom's own), by the block their geometry is a row of."""
    done = {id(st) for m in made for st in m[1]}
    by_blk = {}                          # the strokes of each geometry block, in order
    for st in sts:
        if id(st) not in done:
            b = getattr(curves.geom(st, profile), "_b", None)
            by_blk.setdefault(id(b), (b, []))[1].append(st)
    for b, bsts in by_blk.values():
        if type(b) is not curves._Blk or not _classify_block(b, bsts, jerk):
            for st in bsts:
                _classify_one(st, profile, jerk)


def _classify_one(st, profile, jerk):
    """classify's test and marking of one curve stroke."""
    g = curves.geom(st, profile)
    caps = g.caps
    # (np.min's reduction, called without its Python wrappers: ~1 us a curve)
    if caps.size and curves.CAP_MARGIN * float(np.minimum.reduce(caps)) < st.v_feed:
        st.chain_T = ChainMemo()     # the mark of a chain (plan_kind)
        if jerk and g.caps_jerk1 is not None:
            vertex_caps(st, profile)     # its caps now (planning reads them): the
                                         # caps at the whole jerk are read no more


def _classify_block(b, sts, jerk, fresh=False, memo=None, unput=False, hit=None):
    """_classify_one of the strokes sts, rows of the geometry block b (curves._Blk), as
    row operations on the block: its cap (CAP_MARGIN x each row's least cap, as
    np.minimum takes it: the test's own number where every cap is > 0, b.cap_min) against
    the feeds, and under classic jerk the chains' caps CHAIN_CAP_MARGIN x caps_jerk1 for
    the chains' rows at once (vertex_caps' product, elementwise: the same bits; each
    chain keeps a copy of its row).  False (nothing done) where the block is not such.
    fresh: sts are the block's rows in order, as build_geoms made them just now; unput:
    and their geometries not put on them yet (build_geoms' put False: put here, the
    chains' with their caps, curves.put_rows).  memo: classify's.  hit: cap < feed of the
    rows (fresh), if the caller has it (_NotChains.hit)."""
    if not (b.cap_min and isinstance(b.cap, np.ndarray) and b.caps.ndim == 2 and b.caps.shape[1] > 0):
        return False
    if not fresh and jerk and any(st.curv._j1 is not curves._FROM_BLOCK for st in sts):
        return False             # (a geometry's own caps at the whole jerk: one by one)
    if fresh:
        ks, cap = None, b.cap
    else:
        ks = np.array([st.curv._k for st in sts], np.int64)
        cap = b.cap[ks]
    if hit is None or not fresh:
        feed = objfields.float_col(sts, "v_feed")          # (one compiled pass)
        feed = curves.floats_of(map(_V_FEED, sts), len(sts)) if feed is None else feed
        hit = cap < feed
    hit_a = np.flatnonzero(hit)
    hit = hit_a.tolist()
    caps1 = chain = None
    if hit and jerk and b.caps_jerk1 is not None:         # (np.take's row gather: the same rows)
        caps1 = CHAIN_CAP_MARGIN * b.caps_jerk1.take(hit_a if ks is None else ks[hit_a], axis=0)
        buf, w = caps1.tobytes(), 8 * caps1.shape[1]      # (C order: row i is buf[w i:w (i + 1)])
        if fresh:
            chain = _chain_bytes(hit_a, buf, w, len(sts))
    if unput or chain is not None:      # (fresh: the rows' own geometries, made again with the chains' caps)
        curves.put_rows(b, sts, chain, False)
    if chain is not None:               # (their caps at the whole jerk: see _chain_bytes)
        caps1 = None
    for i, q in enumerate(hit):
        st = sts[q]
        st.chain_T = ChainMemo() if memo is None else memo         # the mark of a chain (plan_kind)
        if caps1 is None:
            continue
        g = st.curv
        if g.chain_caps is None:        # vertex_caps: its caps now, the
            # whole jerk's read no more; a copy of its own, not a view: _drop frees each
            # chain's as its plan is made (a view would hold the block's whole array while
            # any chain of it, not re-timed, keeps its caps); the bytes of its doubles, not
            # an array (~0.25 kB a chain, half of it the array's object: ~16 k chains held
            # from the plan's inputs to their plans on the gyroid plate)
            g.chain_caps = buf[w * i:w * (i + 1)]
            if type(g) is _CURVE_GEOM:
                g._j1 = None             # (the caps_jerk1 setter's store, without its call: ~16 k chains)
            else:
                g.caps_jerk1 = None
    return True


_CURVE_GEOM = curves.CurveGeom
_BYTE_RUNS = getattr(curves._CURVE_CORE, "byte_runs", None)


def _chain_bytes(hit_a, buf, w, m):
    """The chain caps of a fresh block's m rows, a list: the bytes of row i of buf (w bytes a
    row) for the i-th of the rows hit_a, None for the others (the compiled core's byte_runs,
    one pass: the slices the loop of _classify_block takes a chain, ~16 k on the gyroid
    plate), or None without the core.  The rows' geometries are then made again with them
    (curves.put_rows): a chain's keeps _j1 as _FROM_BLOCK, not None, as geom_keep gives a
    chain's back; classify lets go of the block's caps at the whole jerk next
    (drop_blocks_jerk1), so its caps_jerk1 is None either way."""
    if _BYTE_RUNS is None:
        return None
    has = np.zeros(m, bool)
    has[hit_a] = True
    at = np.zeros(m, np.int64)
    at[hit_a] = np.arange(0, w * hit_a.size, w, dtype=np.int64)
    return _BYTE_RUNS(buf, at, at + w, has, m)


_V_FEED = attrgetter("v_feed")


def plan_kind(st):
    """The kind the planner treats a stroke as: a chain is a curve stroke to the rest of
    the program (same vertices, same emission, `kind=curve` in its block and summary)
    with its own law and candidates here."""
    return K_CHAIN if st.chain_T is not None and st.kind == K_CURVE else st.kind


def adjust_plan_inputs(pin, strokes, rows, profile):
    """Masses and acceleration cap as a curve's; the speed cap stays the stroke's own
    (F x overshoot): the vertex caps are the law's constraints, not a cap on its peak."""
    curves.adjust_plan_inputs(pin, strokes, rows, profile, cap_peak=False)


# ------------------------------------------------------------------ laws
def _problems(strokes, T, beta, profile):
    out = []
    for st, t, b in zip(strokes, T, beta):
        g = curves.geom(st, profile)
        out.append(ChainProblem(g.s_v[1:-1], vertex_caps(st, profile), st.length_d, t, b, st.v0, st.v1))
    return out


TRIM_DROPPED = 2000          # chains whose rows plan_chain_segments dropped that are worth a malloc_trim
FINISH_ROWS = 2048          # candidate rows finished together (bounded memory, see _finish_table)
SOLVE_CHUNK = 2048           # chains solved in one batch (bounded memory on files of 10^4 chains)
SOLVE_SEGS = 2048 * 20       # segments of the chains solved in one batch (~2048 chains of the gyroid plate)
REPLAY_SEGS = 8192           # segments of the chains whose kept laws' knots are made again in one call
# the row numbers of a finishing batch as one set of int objects: a RowPlan's row and a memo's
# place in its rows array (ChainMemo.at) read from here share them, where each was an int of
# its own (~32 bytes: ~16 k chains' plans and memos held through the plan on the gyroid plate)
_ROW_INTS = tuple(range(FINISH_ROWS + 8))


def _row_int(i):
    """The int i, the shared object of _ROW_INTS where it has one."""
    return _ROW_INTS[i] if i < len(_ROW_INTS) else i


def _row_ints(n):
    """0 .. n - 1 as _ROW_INTS' shared objects where it has them all."""
    return _ROW_INTS if n <= len(_ROW_INTS) else range(n)


class _KeptPlans:
    """The segment plans the candidate table made of a chain's candidate laws (finish_chains'
    arrays, one row per candidate) under the rules `key`: plan_chain_segments takes the
    chosen candidate's row as it is (finish_chain would make the same plan again).  Kept on
    the stroke (ChainMemo.put), so that the chosen candidate is emitted without solving or
    finishing its law again.  Its rows are lo..lo+k of arrays shared by the chains finished
    together (`base`: vk, acc, feed, t_pred, a2_pred), not views of its own: ~10^4 chains
    on a plate, five views and a knot array each cost more than their numbers."""
    __slots__ = ("key", "ends_d", "base", "lo", "k")

    def __init__(self, key, ends_d, base, lo=0, k=None):
        self.key, self.ends_d, self.base, self.lo = key, ends_d, base, lo
        self.k = base[0].shape[0] - lo if k is None else k

    def _rows(self, j):
        return self.base[j][self.lo:self.lo + self.k]

    sk = property(lambda self: np.concatenate([[0.0], np.asarray(self.ends_d, float)]))
    vk = property(lambda self: self._rows(0))
    acc = property(lambda self: self._rows(1))
    feed = property(lambda self: self._rows(2))
    t_pred = property(lambda self: self._rows(3))
    a2_pred = property(lambda self: self._rows(4))

    def plan(self, r):
        vk, acc, feed, t_pred, a2_pred = self.base
        q = self.lo + r
        return SegmentPlan(self.sk, vk[q], acc[q], feed[q], float(t_pred[q]), float(a2_pred[q]))


class _KeptLaws:
    """What the candidate table keeps of a chain's candidate laws instead of their
    _KeptPlans: each row's law as its binding mask (n - 1 bools) and its pieces' durations
    (one per piece: its binding vertices + 1), its law duration T and weight beta, and its
    predicted figures (time, ∫|a|²), rows lo..lo+k of the arrays of the chains finished
    together (base = (bound (rows, n - 1; as bits, _PackedMask), piece durations (flat,
    shared by the chunk's rows: _LawCols), each row's first piece there and their number
    (rows, 2), T, beta (_Cells), t_pred, a2_pred, profile)).  The candidate table makes one
    for all the chains finished together (lo 0: a chain's row r is the batch's row r,
    _Finisher._finish), not one a chain (~16 k objects on the gyroid plate, ~1.2 MB held
    through the plan); st: the chain whose rows these are where they are one chain's, else
    None (row's st then).  The knot speeds vk and segment durations dt of the
    candidate chosen are made again from them (_rows_knots: _Flat.vertices_at, solve_flat's
    own operations after its Newton on the durations: the same bits, ~1/3 of the knots'
    bytes), then its accelerations and feeds (_replay: the same arithmetic, row by row, as
    the table's): those of every candidate, which the table held until the rewrite, were
    2/3 of the chains' memory.  A base of four arrays (vk, dt, t_pred, a2_pred) holds the
    rows' knots themselves (tests; st and profile not read)."""
    __slots__ = ("key", "base", "lo", "k", "st")

    def __init__(self, key, base, lo, k, st=None):
        self.key, self.base, self.lo, self.k, self.st = key, base, lo, k, st

    def row(self, r, st=None):
        """(vk, dt, predicted time, predicted ∫|a|²) of row r (of the chain st; None: self.st)."""
        b = self.base
        if len(b) == 4:
            q = self.lo + r
            return b[0][q], b[1][q], float(b[2][q]), float(b[3][q])
        vk, dt, tp, a2 = _gather_rows([self], [r], [self.st if st is None else st], b[7])
        return vk[0], dt[0], tp[0], a2[0]

    def plan(self, r, st, rules, profile):
        """The SegmentPlan of row r (chain st), as _replay makes it."""
        return _replay([(st, self, r)], rules, profile)[0]


class LawSpill:
    """An unnamed temporary file the windowed candidates write their kept laws' arrays to
    (laws_spilled_to): each finishing batch's pieces' durations (its rows' in row order),
    pieces' places, binding bits and predicted ∫|a|² (~7 MB on the gyroid plate, held from
    the chain batches through the budget runs: the windowed command's peak), read back
    (_SpilledRows) only for the rows a run or the rewrite replays.  The same doubles and
    integers, written and read as their bytes.  The arrays written together (put_block:
    a batch's kept laws, which the replay reads together) are read back together, one
    read, and the last blocks read are kept (up to CACHE_BYTES)."""

    CACHE_BYTES = 1 << 18

    def __init__(self, folder=None):
        from .stroke_store import _TempFile
        self._io = _TempFile(folder)
        self.end = 0                 # bytes written
        self._cache, self._cached = {}, 0        # {block: its bytes (uint8)}, oldest first; their bytes

    def put(self, a):
        """a (an array) written at the file's end, as the _SpilledRows that reads it back."""
        return self.put_block([a])[0]

    def put_block(self, arrays):
        """The arrays written one after the other at the file's end, as _SpilledRows that
        read them back (the block's bytes read once for all of them)."""
        arrays = [np.ascontiguousarray(a) for a in arrays]
        blk = (self.end, sum(a.nbytes for a in arrays))
        out, at = [], 0
        for a in arrays:
            out.append(_SpilledRows(self, blk, at, a.shape, a.dtype))
            if a.nbytes:
                self._io.write(self.end + at, a.data.cast("B"))
            at += a.nbytes
        self.end += at
        return out

    def pieces(self, PT, spans):
        """(the rows' pieces' durations, their places there) of rows whose durations are
        PT[a:a + c], (a, c) = spans[i] (int32): each row's after the row before (the same
        doubles; rows sharing pieces, _Spread's, each get a copy), their new places (a'[i],
        c[i]) as int32."""
        cnt = spans[:, 1].astype(np.int64)
        off = _offsets(cnt)
        out = np.empty(spans.shape, np.int32)
        out[:, 0] = off[:-1]
        out[:, 1] = spans[:, 1]
        # (take: numpy's plain gather loop, a third of the fancy index's steps an item; the same doubles)
        return PT.take(_ranges(spans[:, 0].astype(np.int64), cnt)), out

    def block(self, blk, keep=True):
        """The bytes of the block blk ((byte pos, length)) as a uint8 array, read or cached
        (keep: kept in the cache once read)."""
        got = self._cache.get(blk)
        if got is None:
            got = np.empty(blk[1], np.uint8)
            if blk[1]:
                self._io.read_into(memoryview(got), blk[0])
            if keep and blk[1] <= self.CACHE_BYTES:
                cache = self._cache
                while cache and self._cached + blk[1] > self.CACHE_BYTES:
                    self._cached -= cache.pop(next(iter(cache))).size
                cache[blk] = got
                self._cached += blk[1]
        return got


class _SpilledRows:
    """An array LawSpill wrote to its file, indexed as the array would be: its block's bytes
    read back (or cached), viewed as the array, then indexed by numpy; nothing held but its
    place: its block blk (shared by the arrays written together), its byte offset there,
    its n rows, and its kind (a row's shape, dtype, bytes), one object for every array of
    that kind (~7 k of them on the gyroid plate: a shape tuple each was ~0.35 MB)."""
    __slots__ = ("spill", "blk", "off", "n", "kind")

    def __init__(self, spill, blk, off, shape, dtype):
        rest, dtype = tuple(shape[1:]), np.dtype(dtype)
        self.spill, self.blk, self.off, self.n = spill, blk, _row_int(off), _row_int(shape[0])
        key = (rest, dtype.str)
        kind = _SPILLED_KINDS.get(key)
        if kind is None:                # (a row's shape, dtype, bytes)
            kind = _SPILLED_KINDS[key] = (rest, dtype, dtype.itemsize * math.prod(rest))
        self.kind = kind

    shape = property(lambda self: (self.n,) + self.kind[0])
    dtype = property(lambda self: self.kind[1])
    ndim = property(lambda self: 1 + len(self.kind[0]))
    size = property(lambda self: self.n * math.prod(self.kind[0]))

    def __len__(self):
        return self.n

    def whole(self):
        """The array itself, read back (not kept in the spill's cache: read once)."""
        return self._view(self.spill.block(self.blk, False)).copy()

    def _view(self, data):
        rest, dtype, w = self.kind
        return data[self.off:self.off + self.n * w].view(dtype).reshape((self.n,) + rest)

    def __getitem__(self, ix):
        data = self.spill.block(self.blk)
        got = self._view(data)[ix]
        # (a view of the block, a slice's or a row's: a copy, as the cache's bytes are not the caller's)
        return got.copy() if isinstance(got, np.ndarray) and np.may_share_memory(got, data) else got


_SPILLED_KINDS = {}      # (a row's shape, dtype.str) -> the (shape, dtype, bytes) _SpilledRows of that kind share

# the LawSpill the candidate tables' kept laws go to (laws_spilled_to), or None: kept in memory
_SPILL = [None]


class laws_spilled_to:
    """`with laws_spilled_to(spill):` the candidate tables made inside keep their laws in
    spill (a LawSpill; None: in memory, the default)."""

    def __init__(self, spill):
        self.spill = spill

    def __enter__(self):
        self.old, _SPILL[0] = _SPILL[0], self.spill

    def __exit__(self, *exc):
        _SPILL[0] = self.old


class _PackedMask:
    """A (rows, n) array of bools held as bits (np.packbits along each row: 1/8 of the
    bytes; the kept laws' binding masks, ~1.4 MB as bools on the gyroid plate, held
    through the plan); indexing its rows gives them back as bools, the same values."""
    __slots__ = ("bits", "shape")

    def __init__(self, mask):
        self.bits = np.packbits(mask, axis=1)
        self.shape = mask.shape

    def __getitem__(self, rows):
        return np.unpackbits(self.bits[rows], axis=-1, count=self.shape[1]).view(bool)


class _RaggedMask:
    """The binding masks of a kept laws' base whose rows are runs of several segment counts
    (_Finisher._merged_base: a windowed call's groups in one base) held as one run of bits:
    run g is rows at[g]..at[g + 1] of w[g] bools each, every row's bools after the row
    before's (np.packbits of them all: bits, or its _SpilledRows).  Indexing rows of one
    width gives them as _PackedMask's (rows, width) bools; rows_flat any rows' bools laid
    end to end: the same values."""
    __slots__ = ("bits", "at", "w")

    def __init__(self, flat, at, w):
        self.bits = np.packbits(flat)
        self.at, self.w = at, w                 # (int64: G + 1 and G, ~30 runs)

    def widths(self, qq):
        """The widths (bools a row) of the rows qq (int64)."""
        return self.w.take(np.searchsorted(self.at, qq, side="right") - 1)

    def rows_flat(self, qq, bits=None):
        """(the bools of the rows qq (int64) one row after the other, each row's width);
        bits: the mask's bits already read (None: read here)."""
        g = np.searchsorted(self.at, qq, side="right") - 1
        w = self.w.take(g)
        first = _offsets(np.diff(self.at) * self.w)        # each run's first bit
        if bits is None:
            bits = self.bits[:] if type(self.bits) is _SpilledRows else self.bits
        flat = np.unpackbits(bits, count=int(first[-1])).view(bool)
        return flat[_ranges(first.take(g) + (qq - self.at.take(g)) * w, w)], w

    def __getitem__(self, rows):
        qq = np.asarray(rows, np.int64).reshape(-1)
        flat, w = self.rows_flat(qq)
        if w.size and np.any(w != w[0]):
            raise IndexError("rows of several widths")
        return flat.reshape(qq.size, int(w[0]) if w.size else 0)


class _Cells:
    """Cells of a table held as their places in it: cell q is table[row[q], col[q]] (the
    kept laws' T and beta, cells of _figures' (chains, columns) tables, which their
    _Source holds anyway: 4 bytes a row, not a copy of 8 bytes a row for each); indexing
    gives the cells' own doubles, as a fancy index of a copy would.  fn: the cells are
    fn(table's cells) (elementwise: a candidate table's beta from its T, _BetaOfT), or None."""
    __slots__ = ("table", "at", "fn")
    ndim = 1

    def __init__(self, table, row, col, fn=None):
        self.table, self.fn = table, fn
        self.at = (np.asarray(row, np.int64) * table.shape[1] + col).astype(np.int32)   # (C order)

    @property
    def shape(self):
        return self.at.shape

    def of(self, fn):
        """These cells' fn(cells), sharing their table and places (not a copy of the places)."""
        out = _Cells.__new__(_Cells)
        out.table, out.at, out.fn = self.table, self.at, fn
        return out

    def __getitem__(self, q):
        at = self.at[q]
        if self.fn is None:
            return np.take(self.table, at)
        # (fn on an array, as on the table: a numpy scalar's ** 2 is not the array's square)
        got = self.fn(np.take(self.table, at.reshape(-1)))
        return got.reshape(at.shape) if at.ndim else got[0]


def _chain_beta(T):
    """The weights beta of the law durations T (an array, not a numpy scalar: its ** 2 is
    not the array's square, bit for bit): (T / GAMMA_MIN)², elementwise."""
    return (T / GAMMA_MIN) ** 2


class _OuterT:
    """A table of law durations that is an outer product, T[i, c] = base[i] f[c] (the
    candidates' durations: each stroke's original duration times the columns' ratios),
    read as that table would be -- rows, row slices and gathers, np.take of its flat
    places (_Cells), np.array of it -- each entry the one product the table had, the same
    double; not held as a table: the table a chain's memo source and its kept laws held
    (~0.65 MB on the gyroid plate's ~16 k chains, through the plan; base: 1/5 of it)."""
    __slots__ = ("base", "f")
    ndim = 2

    def __init__(self, base, f):
        self.base, self.f = np.asarray(base, float), np.asarray(f, float)

    @property
    def shape(self):
        return self.base.size, self.f.size

    def __getitem__(self, ix):
        if type(ix) is tuple:                 # (cells: read in the table, made whole; not the package's)
            return np.asarray(self)[ix]
        b = self.base[ix]
        return b * self.f if np.ndim(b) == 0 else b[:, None] * self.f[None, :]

    def take(self, idx, axis=None, out=None, mode="raise"):
        """Rows (axis 0: the table of those rows), or flat places (axis None, as np.take:
        row idx // k, column idx % k of k columns, negative places from the end)."""
        if out is not None or mode != "raise" or axis not in (None, 0):
            return np.take(np.asarray(self), idx, axis=axis, out=out, mode=mode)
        if axis == 0:
            return _OuterT(self.base.take(idx), self.f)
        idx = np.asarray(idx)
        k = self.f.size
        return self.base.take(idx // k) * self.f.take(idx % k)

    def __array__(self, dtype=None, copy=None):
        T = self.base[:, None] * self.f[None, :]
        return T if dtype is None else T.astype(dtype, copy=False)


class _BetaOfT:
    """The candidates' weight table of the law durations table T, _chain_beta(T), read as
    that table would be (its rows, row slices and gathers: each entry its own T's
    function, the same doubles) and not held: the table a chain's memo source and its kept
    laws held beside T (~0.65 MB on the gyroid plate's ~16 k chains, through the plan)."""
    __slots__ = ("T",)
    ndim = 2

    def __init__(self, T):
        self.T = T

    @property
    def shape(self):
        return self.T.shape

    def __getitem__(self, ix):
        t = np.asarray(self.T[ix])
        return _chain_beta(t) if t.ndim else _chain_beta(t.reshape(1))[0]


class _Source:
    """What _figures solved a chain's candidates from, to solve one again (_knots_again):
    the (n, k) tables of law durations T and weights beta (row src_i of a chain), the
    columns' order (mid first, cold; each other from its neighbour prev[c], warm) and the
    rules key of its finishing.  One per _figures call, shared by its chains."""
    __slots__ = ("T", "beta", "order", "prev", "key", "again")

    def __init__(self, T, beta, order, prev, key):
        self.T, self.beta, self.order, self.prev, self.key = T, beta, order, prev, key
        self.again = _Again(self)


class _Again(_KeptLaws):
    """A candidate row whose knots were dropped (ChainMemo.drop_rows): plan_chain_segments
    makes its knots again (_knots_again: the chain solved again along the same columns,
    from the same starts; solve_flat's numbers are each chain's own, whatever chains are
    solved with it), its predicted figures (the table's finishing) and then its plan
    (_replay), as for a kept row.  i: the chain's row in src's tables (None: the memo's
    src_i)."""
    __slots__ = ("src", "i")

    def __init__(self, src, i=None):
        self.key, self.src, self.i = src.key, src, i
        self.base, self.lo, self.k = None, 0, 0

    def plan(self, r, st, rules, profile):
        """The SegmentPlan of the candidate at row r of its kept rows (ChainMemo.plan_of's
        row) of chain st, as plan_chain_segments makes it."""
        for t, T, beta, row, kept in st.chain_T.rows():
            if kept is self and row == r:
                return _again_plans([(st, self, T, beta)], rules, profile)[0]
        raise KeyError(r)


class _Chosen(_Again):
    """The rows of chains of one source src whose plans a plan_chain_segments(remember=False)
    made (_replay) and whose rows it then dropped, with the law of the row each one chose
    kept (_keep_chosen): a later ask of that same (T, beta) (the rewrite's remake of a
    windowed run's plans, schedule._PlansAgain) replays it (_replay by _chosen_laws_of: the
    knots made again from the law, then the finishing; the same bits) instead of solving
    the chain again (_again_plans); another candidate is made again as an _Again's.
    Flat arrays, not an object a chain (~130 bytes a chain on the gyroid plate, its pieces'
    durations most of it: benchmarks/replay54.md):
    ids, the chains' memos' ids, ascending (a chain's place: its memo holds this object,
    so its id is its own); bits, the binding masks packed (np.packbits) at bit offsets
    voff; tj, the pieces' durations at offsets poff; figs, (T, beta, predicted time,
    predicted ∫|a|²) a row."""
    __slots__ = ("ids", "bits", "voff", "tj", "poff", "figs")

    def __init__(self, src, ids, bound, voff, tj, poff, figs):
        """The laws of chains (memo ids ids, any order): row i's binding mask
        bound[voff[i]:voff[i + 1]], its pieces' durations tj[poff[i]:poff[i + 1]], figs[i]."""
        _Again.__init__(self, src)
        o = np.argsort(ids, kind="stable")
        nv, cnt = np.diff(voff)[o], np.diff(poff)[o]
        self.ids, self.figs = ids[o], figs[o]
        self.bits = np.packbits(bound[_ranges(voff[:-1][o], nv)])
        self.tj = tj[_ranges(poff[:-1][o], cnt)]
        self.voff, self.poff = _offsets(nv, np.int32), _offsets(cnt, np.int32)

    def places(self, memos, T, beta):
        """Each memo's place here where its chosen law is the candidate (T[i], beta[i]) (arrays
        of doubles), else -1."""
        ids = np.fromiter(map(id, memos), np.int64, len(memos))
        j = np.minimum(np.searchsorted(self.ids, ids), self.ids.size - 1)
        hit = (self.ids[j] == ids) & (self.figs[j, 0] == T) & (self.figs[j, 1] == beta)
        return np.where(hit, j, -1)


def _keep_chosen(items):
    """The _Chosen laws of items [(stroke, kept, row)] whose rows _replay(drop=True) is about
    to drop (ChainMemo.drop_rows: kept a _KeptLaws of its memo's source), one a source:
    [(_Chosen, its chains' memos)]; _hand_chosen gives them to the memos once dropped."""
    by_src = {}
    for st, kept, r in items:
        memo = st.chain_T
        src = memo.src
        if type(kept) is _KeptLaws and len(kept.base) == 8 and src is not None and kept.key == src.key:
            by_src.setdefault(id(src), (src, []))[1].append((id(memo), memo, kept, r))
    out = []
    for src, its in by_src.values():
        nv, voff, bound, tj, TL, beta, tp, a2, poff = _rows_laws(
            list(map(_IT2, its)), np.fromiter((it[3] for it in its), np.int64, len(its)))
        figs = np.stack([TL, beta, tp, a2], axis=1)
        ids = np.fromiter(map(_IT0, its), np.int64, len(its))
        out.append((_Chosen(src, ids, bound, voff, tj, poff, figs), list(map(_IT1, its))))
    return out


def _hand_chosen(chosen):
    """Each memo of _keep_chosen's answer whose rows were dropped (kept its source's _Again)
    keeps its _Chosen instead."""
    for ch, memos in chosen:
        again = ch.src.again
        for memo in memos:
            if memo.kept is again:
                memo.kept = ch


def _chosen_solved(again, strokes, laws):
    """The chains of again [(k, its _Again)] whose laws _again_plans solved (laws[i]:
    (binding mask, pieces' durations, T, beta, predicted time, predicted ∫|a|²) of
    again[i]) keep them (a _Chosen a source), where their rows are their memo's source's
    (its _Again, or a _Chosen of it)."""
    by_src = {}
    for (k, ag), law in zip(again, laws):
        memo = strokes[k].chain_T
        src = memo.src
        if memo.kept is ag and src is not None and ag.src is src and (ag is src.again or type(ag) is _Chosen):
            by_src.setdefault(id(src), (src, []))[1].append((memo, law))
    for src, its in by_src.values():
        memos = list(map(_IT0, its))
        bnd, tj = [law[0] for _, law in its], [law[1] for _, law in its]
        ch = _Chosen(src, np.fromiter(map(id, memos), np.int64, len(memos)),
                     np.concatenate(bnd), _offsets(np.array([b.size for b in bnd], np.int64)),
                     np.concatenate(tj), _offsets(np.array([t.size for t in tj], np.int64)),
                     np.array([law[2:] for _, law in its], float).reshape(-1, 4))
        for memo in memos:
            memo.kept = ch


def _offsets(counts, dtype=np.int64):
    """[0, counts' running sums] (counts an int array)."""
    out = np.zeros(counts.size + 1, dtype)
    np.cumsum(counts, out=out[1:])
    return out


def _chosen_asks(again, strokes, T, beta):
    """plan_chain_segments' again [(k, _Again)] split: (the chains asking for their chosen
    law [(stroke, _Chosen, its place)] and their k, the others as again)."""
    by_ch, rest = {}, []
    for k, ag in again:
        if type(ag) is _Chosen:
            by_ch.setdefault(id(ag), (ag, []))[1].append(k)
        else:
            rest.append((k, ag))
    if not by_ch:
        return [], [], again
    hits, ks = [], []
    T, beta = np.frombuffer(T, float), np.frombuffer(beta, float)
    for ch, kk in by_ch.values():
        sts = list(map(strokes.__getitem__, kk))
        at = np.array(kk, np.int64)
        for st, k, j in zip(sts, kk, ch.places(list(map(_CHAIN_T, sts)), T[at], beta[at]).tolist()):
            if j < 0:
                rest.append((k, ch))
            else:
                hits.append((st, ch, j))
                ks.append(k)
    rest.sort(key=_IT0)             # (again's order: the chains ascending)
    return hits, ks, rest


def _ranges(starts, counts):
    """The indices starts[i] .. starts[i] + counts[i] of each i, one after the other."""
    at = np.cumsum(counts) - counts
    return np.repeat(starts - at, counts) + np.arange(int(counts.sum()))


def _chosen_laws_of(Qs, items, profile, gs=None):
    """_laws_of's answer for items [(stroke, _Chosen, its place there)]: their chosen laws."""
    order = [q for Q in Qs for q in Q]
    m = len(order)
    sts = [items[q][0] for q in order]
    nv, cnt, figs = np.empty(m, np.int64), np.empty(m, np.int64), np.empty((m, 4))
    by_ch = {}
    for i, q in enumerate(order):
        _, ch, j = items[q]
        _, ii, jj = by_ch.setdefault(id(ch), (ch, [], []))
        ii.append(i)
        jj.append(j)
    groups = [(ch, np.array(ii, np.int64), np.array(jj, np.int64)) for ch, ii, jj in by_ch.values()]
    for ch, ii, jj in groups:
        nv[ii] = ch.voff[jj + 1] - ch.voff[jj]
        cnt[ii] = ch.poff[jj + 1] - ch.poff[jj]
        figs[ii] = ch.figs[jj]
    voff, poff = _offsets(nv), _offsets(cnt)
    bound, tj = np.empty(int(voff[-1]), bool), np.empty(int(poff[-1]))
    for ch, ii, jj in groups:
        bits = np.unpackbits(ch.bits, count=int(ch.voff[-1])).view(bool)
        bound[_ranges(voff[ii], nv[ii])] = bits[_ranges(ch.voff[jj].astype(np.int64), nv[ii])]
        tj[_ranges(poff[ii], cnt[ii])] = ch.tj[_ranges(ch.poff[jj].astype(np.int64), cnt[ii])]
    TL, beta, tp, a2 = (np.ascontiguousarray(figs[:, c]) for c in range(4))
    gso = [curves.geom(st, profile) for st in sts] if gs is None else [gs[q] for q in order]
    return sts, nv, voff, bound, tj, TL, beta, tp, a2, _laws_caps(sts, gso, profile), gso


_knots_s = curves.knots_s


def _ends_rows(sts, n):
    """The chains' ends_d arrays, where each is an array of n doubles: a RowPlan of each
    takes its knots from it (0, then its ends_d: segments.RowPlan), not from a block of
    them made for the plans (the same doubles, ~2.5 MB held through the budget runs on
    the gyroid plate's ~16 k chains); None where one is not (a SegmentPlan of _knots_s
    each, one by one)."""
    ends = list(map(_ENDS_D, sts))
    # (the checks as C-level maps over the list, types first: a generator's test a chain was
    # ~2 k instructions, ~17 k chains a gyroid plate's replays, either path)
    if ends and not (set(map(type, ends)) == _ARRAY_ONLY and set(map(_TYPECODE, ends)) == _D_ONLY
                     and set(map(len, ends)) == {n}):
        return None
    return ends


_ENDS_D, _TYPECODE = attrgetter("ends_d"), attrgetter("typecode")
_ARRAY_ONLY, _D_ONLY = {array}, {"d"}


def _settle_ends_plans(plans, ends, V, A, F):
    """schedule.settle_faults' verdict ("" where every check passes) kept on each of the
    RowPlans plans (rows 0.. of the blocks V, A, F; knots 0 then ends[i]: _ends_rows),
    made now by its _settle_rows on their knots as one block, which is not kept (the
    plans' knots are made of their ends when read; settle_faults made the same verdicts
    on the block the plans held).  Plans with a non-finite figure are left as
    settle_faults leaves them (seg_fault finds why)."""
    from .schedule import _settle_rows
    S = np.empty(V.shape)
    S[:, 0] = 0.0
    S[:, 1:] = np.frombuffer(b"".join(ends), float).reshape(len(ends), V.shape[1] - 1)
    fin = _figures_finite(plans)
    _settle_rows(S, V, A, F, plans if fin.all() else list(compress(plans, fin.tolist())))


_TIME_T, _INT_A2 = attrgetter("time_t"), attrgetter("int_a2")
# knot speeds of the batches _EndsSettle checks together (~0.4 MB of flat copies at most):
# a windowed run's call plans ~600 chains in ~40 batches of one segment count each
SETTLE_KNOTS = 1 << 14


def _figures_finite(plans):
    """Which plans' time_t and int_a2 are both finite (a bool array): one compiled pass
    where built (objfields.floats), else a pass a figure."""
    fig = objfields.floats(plans, ("time_t", "int_a2"))
    if fig is None:
        return (np.isfinite(np.fromiter(map(_TIME_T, plans), float, len(plans)))
                & np.isfinite(np.fromiter(map(_INT_A2, plans), float, len(plans))))
    return np.isfinite(fig).all(axis=1)


class _EndsSettle:
    """_settle_ends_plans of many batches (add: the same arguments) made together: their
    rows laid end to end in flat arrays, each check elementwise (finite, > 0, >= 0, the
    knots 0, ends increasing) and one reduction a row (np.logical_or.reduceat), the same
    verdicts as a batch's _settle_rows; not ~50 numpy calls a batch (a windowed gyroid run
    settled ~1 k batches of ~15 chains).  Batches are checked once SETTLE_KNOTS knot
    speeds wait, and at flush(); a batch of another shape, or of SETTLE_KNOTS knot speeds
    or more (the list path's, up to FINISH_ROWS chains: as fast by its own block's checks,
    without the flat copies), goes to _settle_ends_plans."""
    __slots__ = ("todo", "knots")

    def __init__(self):
        self.todo, self.knots = [], 0

    def add(self, plans, ends, V, A, F, rows_made=False):
        """rows_made: plans are the caller's RowPlan(ends[i], V, A, F, i, ...) as made (not
        checked a plan: _replay's, a C-level map of them)."""
        nd, m = np.ndarray, len(plans)
        if not (type(V) is nd and type(A) is nd and type(F) is nd and V.ndim == A.ndim == F.ndim == 2
                and V.dtype == A.dtype == F.dtype == _F8 and V.shape[0] == len(ends) == m
                and V.shape[1] >= 2 and A.shape == F.shape == (m, V.shape[1] - 1) and V.size < SETTLE_KNOTS
                and (rows_made or all(type(p) is RowPlan and p._row == i for i, p in enumerate(plans)))):
            _settle_ends_plans(plans, ends, V, A, F)
            return
        self.todo.append((plans, ends, V, A, F))
        self.knots += V.size
        if self.knots >= SETTLE_KNOTS:
            self.flush()

    def flush(self):
        todo, self.todo, self.knots = self.todo, [], 0
        if not todo:
            return
        plans = [p for t in todo for p in t[0]]
        K = np.concatenate([np.full(t[2].shape[0], t[2].shape[1], np.int64) for t in todo])
        E = np.frombuffer(b"".join([e for t in todo for e in t[1]]), float)
        at_v, at_e = _offsets(K)[:-1], _offsets(K - 1)[:-1]
        before = np.empty_like(E)           # each end's knot before it: 0.0 for a row's first
        before[1:] = E[:-1]
        before[at_e] = 0.0
        with np.errstate(invalid="ignore"):
            bad = np.logical_or.reduceat(~(np.isfinite(E) & (E > before)), at_e)
            V = np.concatenate([t[2].reshape(-1) for t in todo])
            bad |= np.logical_or.reduceat(~(np.isfinite(V) & (V >= 0.0)), at_v)
            for c in (3, 4):                # (accelerations, then feeds: > 0)
                X = np.concatenate([t[c].reshape(-1) for t in todo])
                bad |= np.logical_or.reduceat(~(np.isfinite(X) & (X > 0.0)), at_e)
        bad |= ~_figures_finite(plans)
        for p in compress(plans, (~bad).tolist()):
            p.fault = ""


def _replay(items, rules, profile, drop=False, laws_of=None, blocks=None):
    """SegmentPlans of candidate rows kept as _KeptLaws, items [(stroke, kept, row)]:
    finished again (_finish_stacked_dt by groups of the same number of segments, as the
    table did, or _finish_rows_dt chain by chain); row by row the table's numbers.  drop:
    each chain's memo drops its rows' knots (ChainMemo.drop_rows) once its chosen row is
    copied out (by groups: all rows gathered, then every chain's dropped, then the plans
    made; chain by chain: as each plan is made); the plans hold their own knot speeds
    then, not views of the candidates' arrays, and items' kept entries are cleared (None):
    the caller's list holds no candidate row once its plan is made.  laws_of: what gives
    the rows' laws (_laws_of's answer; None: _laws_of, from kept rows; _chosen_laws_of, from
    the chains' chosen laws, items [(stroke, _Chosen, its place there)]).  blocks: a list
    each batch of RowPlans made of blocks is appended to, (their places in items, V, A, F,
    their knots' ends), or None."""
    out = [None] * len(items)
    by_law = laws_of is not None
    laws_of = laws_of or _laws_of
    grouped = rules.junction in GROUP_JUNCTIONS and profile.junction == rules.junction
    gs = _geoms(list(map(_IT0, items)), profile)
    sk = lambda st: _knots_s(st.ends_d)       # noqa: E731
    if not grouped:
        rows = [None] * len(items)
        if items and (by_law or _all_laws(items)):
            # the knots of every row's law made again together (not a vertices_at call a chain)
            by_n = {}
            for q, n in enumerate(curves.seg_counts(gs)):
                by_n.setdefault(n, []).append(q)
            Qs = [qs[a:a + FINISH_ROWS] for qs in by_n.values() for a in range(0, len(qs), FINISH_ROWS)]
            for Q, (vk, dt, tp, a2) in zip(Qs, _gather_batches(Qs, items, profile, gs, laws_of)):
                for i, q in enumerate(Q):
                    rows[q] = (vk[i], dt[i], tp[i], a2[i])
        for q, (st, kept, r) in enumerate(items):
            vk, dt, t, a2 = kept.row(r, st) if rows[q] is None else rows[q]
            rows[q] = None
            acc, feed, _, _, _ = _finish_rows_dt(st, vk[None, :], dt[None, :], rules, profile, predict=False)
            out[q] = SegmentPlan(sk(st), vk, acc[0], feed[0], t, a2)
            if drop:
                _drop(st)
                items[q] = (st, None, r)
        return out
    by_n = {}
    for q, n in enumerate(curves.seg_counts(gs)):
        by_n.setdefault(n, []).append(q)
    # the chosen rows gathered first (copies: the plans' knot speeds are rows of these),
    # then, with drop, every chain's candidate knots freed before any plan is made: the
    # plans' arrays (acc, feed, knots, ~16 k SegmentPlans) were made while all the
    # candidates' knots were still held (the gyroid plate's planning peak, ~+15 MB)
    # (s30: the rows are kept as their laws: the chosen rows' laws are copied out, then the
    # rows dropped, then the knots made again group by group as the plans are made)
    Qs = [qs[a:a + FINISH_ROWS] for qs in by_n.values() for a in range(0, len(qs), FINISH_ROWS)]
    if by_law or _all_laws(items):
        groups = _gather_laws(Qs, items, profile, gs, laws_of)     # (every row by its law)
        batches = []
    else:
        groups = []
        batches = [(Q, _gather_rows([items[q][1] for q in Q], [items[q][2] for q in Q],
                                    [items[q][0] for q in Q], profile)) for Q in Qs]
    if drop:
        # (_drop, inline: ~16 k chains; with the chain core in one C pass: with sort_asks,
        # -37 M instructions on the gyroid plate) nor held here: the memo's rows were the last to hold them
        core = _chain_law.CORE_MOD
        (_drop_items if core is None else core.drop_items)(items, gs, _KeptLaws)
    groups.reverse()
    batches = [(Q, knots, None) for Q, knots in batches[::-1]]      # popped from the end: in the order gathered
    settle = _EndsSettle()
    while batches or groups:
        if not batches:
            grp, laws = groups.pop()
            batches = _finished_knots(grp, _laws_knots(grp, laws, profile), items, gs, rules, profile)[::-1]
            del laws
        Q, (vk, dt, tp, a2), fin = batches.pop()
        sts = list(map(_IT0, map(items.__getitem__, Q)))
        acc, feed, _, _, _ = fin or _finish_stacked_dt(sts, [gs[q] for q in Q], np.arange(len(Q)), vk, dt, rules,
                                                       profile, predict=False)
        ends = _ends_rows(sts, vk.shape[1] - 1)
        if ends is None:
            for i, q in zip(_row_ints(len(Q)), Q):
                out[q] = SegmentPlan(sk(sts[i]), vk[i], acc[i], feed[i], tp[i], a2[i])
        else:
            # (rows of the blocks: a RowPlan each, made by a C-level map, not a loop body a chain)
            plans = list(map(RowPlan, ends, repeat(vk), repeat(acc), repeat(feed), _row_ints(len(Q)), tp, a2))
            for q, plan in zip(Q, plans):
                out[q] = plan
            settle.add(plans, ends, vk, acc, feed, rows_made=True)
            if blocks is not None:
                blocks.append((Q, vk, acc, feed, ends))
            del plans
        del dt
    settle.flush()
    return out


def _all_laws(items):
    """Is every item's (stroke, _KeptLaws, row) kept base one of laws (8 entries)?  By
    C-level maps over the items (~16 k chains a gyroid plate's replays), not a generator's
    step an item; the generator where one has no base (it stops at the first not of 8)."""
    try:
        return set(map(len, map(_BASE, map(_IT1, items)))) <= {8}
    except (AttributeError, TypeError):
        return all(len(kept.base) == 8 for _, kept, _ in items)


def _geoms(sts, profile):
    """[curves.geom(st, profile) for st in sts]: the strokes' curv read by a C-level map where
    every one has it (the runs' chains: their geometry given or made first), not a Python
    call a chain (~17 k a gyroid plate's replays, either path)."""
    gs = list(map(_CURV, sts))
    if None in gs:
        return [curves.geom(st, profile) for st in sts]
    return gs


_CURV = attrgetter("curv")


def _finished_knots(Qs, knots, items, gs, rules, profile):
    """_replay's batches Qs with their knots (_laws_knots' answer) and their finishing's
    (acc, feed, ...) made in one _finish_ragged call for them all (predict off: the
    figures are the laws'), or None each (finished batch by batch: _finish_stacked_dt)
    where it declines; the same bits (the row code is chain_finish's).  Not the rows'
    own batches (_gather_rows): those are finished one by one as before."""
    # (each batch's strokes and geometries by C-level maps; its rows 0.. a view of one arange)
    own = np.arange(max(map(len, Qs), default=0))
    fins = _finish_ragged([(list(map(_IT0, map(items.__getitem__, Q))), list(map(gs.__getitem__, Q)), own[:len(Q)],
                            vk, dt) for Q, (vk, dt, _, _) in zip(Qs, knots)], rules, profile, predict=False)
    return list(zip(Qs, knots, fins or [None] * len(Qs)))


def _drop_items(items, gs, laws_type):
    """Each chain's rows dropped (ChainMemo.drop_rows) and its geometry's caps (gs, items'
    order), and items' kept entries cleared (None); the chain core's drop_items (ChainMemo's
    type laws_type: _KeptLaws)."""
    for q, st in enumerate(map(_IT0, items)):
        # (no loop variable left holding the last one's kept laws: the pieces of its whole
        # chunk, _LawCols, while the plans are made)
        st.chain_T.drop_rows()
        gs[q].chain_caps = None
        items[q] = (st, None, items[q][2])


def _gather_rows(kept, rs, sts, profile):
    """The rows rs[i] of kept[i] (_KeptLaws of the chains sts, all with the same number of
    segments) stacked: (vk, dt, predicted times, predicted ∫|a|²), the times as Python
    floats; each base's rows gathered by one fancy index (the chains finished together
    share one), then the knots made again from the laws (_rows_knots; a base of the
    knots themselves, _KeptLaws': gathered)."""
    by = {}
    for i, (kp, r) in enumerate(zip(kept, rs)):
        e = by.get(id(kp.base))
        if e is None:
            e = by[id(kp.base)] = (kp.base, [], [])
        e[1].append(i)
        e[2].append(kp.lo + r)
    m = len(kept)
    n = curves.geom(sts[0], profile).d.size
    vk, dt = np.empty((m, n + 1)), np.empty((m, n))
    bnd = np.empty((m, n - 1), bool)
    TL, beta, tp, a2 = np.empty(m), np.empty(m), np.empty(m), np.empty(m)
    law = []                        # the rows given by their laws
    tj = []
    for b, ii, qq in by.values():
        if len(b) == 4:             # the knots themselves
            vk[ii], dt[ii], tp[ii], a2[ii] = b[0][qq], b[1][qq], b[2][qq], b[3][qq]
            continue
        bnd[ii], TL[ii], beta[ii], tp[ii], a2[ii] = b[0][qq], b[3][qq], b[4][qq], b[5][qq], b[6][qq]
        sp = b[2][np.array(qq)]
        p0, cnt = sp[:, 0].astype(np.int64), sp[:, 1].astype(np.int64)
        at = np.cumsum(cnt) - cnt          # each row's first piece in this base's gather
        tj.append(b[1][np.repeat(p0 - at, cnt) + np.arange(int(cnt.sum()))])
        law += ii
    if law == list(range(m)):       # (the usual case: every row by its law, in order)
        vk, dt = _rows_knots(sts, bnd, np.concatenate(tj), TL, beta, profile)
    elif law:
        li = np.array(law)
        vk[li], dt[li] = _rows_knots([sts[i] for i in law], bnd[li], np.concatenate(tj), TL[li], beta[li], profile)
    return vk, dt, tp.tolist(), a2.tolist()


def _gather_batches(Qs, items, profile, gs=None, laws_of=None):
    """_gather_rows of each batch Q of Qs (items' indices; items [(stroke, _KeptLaws, row)],
    every row kept by its law, a batch's chains of one number of segments; gs: the
    strokes' geometries, items' order, or None; laws_of: as _gather_laws')."""
    return [x for grp, laws in _gather_laws(Qs, items, profile, gs, laws_of) for x in _laws_knots(grp, laws, profile)]


def _gather_laws(Qs, items, profile, gs=None, laws_of=None):
    """The laws of the rows of the batches Qs (as _gather_batches), copied out of their
    kept bases, consecutive batches together up to REPLAY_SEGS segments: [(those batches,
    their laws)] for _laws_knots, which needs no kept row (the chains' rows can be dropped
    first: only the chosen rows' laws, ~1/5 of the kept bytes, are held while the plans are
    made; each call's temporaries stay in the caches).  laws_of: _laws_of (None) or another
    giving its answer from other items (_chosen_laws_of)."""
    laws_of = laws_of or _laws_of
    out, grp, segs = [], [], 0
    for Q in Qs:
        w = len(Q) * curves.geom(items[Q[0]][0], profile).d.size
        if grp and segs + w > REPLAY_SEGS:
            out.append((grp, laws_of(grp, items, profile, gs)))
            grp, segs = [], 0
        grp.append(Q)
        segs += w
    if grp:
        out.append((grp, laws_of(grp, items, profile, gs)))
    return out


def _laws_knots(Qs, laws, profile):
    """(vk, dt, predicted times, predicted ∫|a|²) of each batch Q of Qs from their rows'
    laws (_laws_of): made again in one _Flat.vertices_at call (its numpy calls paid once,
    not per batch: ~80 batches of ~60 segment counts on the gyroid plate), then cut by
    batch.  The vertices' arc lengths from each batch's stacked lengths (curves.stack_d,
    _inner_s_stacked), not a d view a chain; those lengths not kept (the finishing stacks
    its own with the directions: the replay's first plans are made with no more held)."""
    sts, nv, voff, bound, tj, TL, beta, tp, a2, cv, gs = laws
    # (_flat_chains' arrays, the caps as _laws_of took them before the rows and caps were
    # dropped: not made again)
    m = len(sts)
    Ds, a = [], 0
    for Q in Qs:
        Ds.append(curves.stack_d(gs[a:a + len(Q)]))
        a += len(Q)
    sv = _inner_s_stacked(gs, Ds)
    del Ds
    L, v0, v1 = _lengths_ends(sts)
    fl = _Flat.of_arrays(sv, cv, nv, L, np.zeros(m), np.ones(m), v0, v1).with_T(TL, beta)
    vv, vt = fl.vertices_at(bound, tj) if voff[-1] else (np.empty(0), np.empty(0))
    out = []
    a = 0
    for Q in Qs:
        z = a + len(Q)
        n = int(nv[a]) + 1
        vk = np.empty((z - a, n + 1))
        tk = np.empty((z - a, n + 1))
        vk[:, 0], vk[:, -1] = fl.v0[a:z], fl.v1[a:z]
        tk[:, 0] = 0.0
        tk[:, -1] = TL[a:z]
        if n > 1:
            vk[:, 1:-1] = vv[voff[a]:voff[z]].reshape(z - a, n - 1)
            tk[:, 1:-1] = vt[voff[a]:voff[z]].reshape(z - a, n - 1)
        out.append((vk, _row_steps(tk), tp[a:z].tolist(), a2[a:z].tolist()))
        a = z
    return out


def _lengths_ends(sts):
    """(length_d, v0, v1) of the chains sts (a list) as three float64 arrays: by objfields'
    one compiled pass, else one np.fromiter each (the same doubles)."""
    got = objfields.floats(sts, ("length_d", "v0", "v1"))
    if got is not None:
        return tuple(np.ascontiguousarray(got[:, j]) for j in range(3))
    return tuple(np.fromiter(map(f, sts), float, len(sts)) for f in (_LENGTH_D, _V0, _V1))


_LENGTH_D, _V0, _V1 = attrgetter("length_d"), attrgetter("v0"), attrgetter("v1")
_BASE, _LO, _CHAIN_CAPS = attrgetter("base"), attrgetter("lo"), attrgetter("chain_caps")
_CHAIN_T = attrgetter("chain_T")
_DTYPE, _NDIM, _F8 = attrgetter("dtype"), attrgetter("ndim"), np.dtype(float)
_IS_NOT_NONE = partial(is_not, None)
_IT0, _IT1, _IT2 = itemgetter(0), itemgetter(1), itemgetter(2)


def _inner_s_stacked(gs, Ds):
    """_inner_s(gs) from the geometries' lengths stacked (Ds: curves.stack_d of
    consecutive runs of gs, each (m, n)): the rows laid end to end are the chains' d in
    their order (the same doubles), so the same sums (_inner_s_core) without a d view a
    chain; _inner_s itself where the core is missing or a chain has no segment."""
    core = _chain_law.CORE_MOD
    if core is None or not Ds or any(D.dtype != np.float64 or D.ndim != 2 or D.shape[1] < 1 for D in Ds):
        return _inner_s(gs)
    d = Ds[0].ravel() if len(Ds) == 1 else np.concatenate([D.ravel() for D in Ds])
    # (each row's segment count, its stack's width: one repeat, not an np.full a stack)
    n = np.repeat(np.array([D.shape[1] for D in Ds], np.int64), [D.shape[0] for D in Ds])
    return _inner_s_core(core, d, n)


def _laws_of(Qs, items, profile, gs=None):
    """The laws of the rows of the batches Qs, in their order: (strokes, vertices a row,
    their offsets, binding masks (flat), pieces' durations (flat), T, beta, predicted
    times, predicted ∫|a|², the chains' vertex caps (flat), their geometries).  gs: the
    items' geometries (items' order), or None (made here)."""
    order = [q for Q in Qs for q in Q]
    its = list(map(items.__getitem__, order))
    sts = list(map(_IT0, its))
    kept = list(map(_IT1, its))
    rows = np.fromiter(map(_IT2, its), np.int64, len(its))
    del its
    nv, voff, bound, tj, TL, beta, tp, a2, _ = _rows_laws(kept, rows)
    gso = _geoms(sts, profile) if gs is None else list(map(gs.__getitem__, order))
    return sts, nv, voff, bound, tj, TL, beta, tp, a2, _laws_caps(sts, gso, profile), gso


def _laws_caps(sts, gso, profile):
    """The chains' vertex caps (_flat_chains' cv) joined, taken now: _drop drops them with
    the rows (each geometry's chain_caps where every one has them, the usual case: what
    vertex_caps returns then, without a call a chain)."""
    caps = list(map(_CHAIN_CAPS, gso))
    if not all(map(_IS_NOT_NONE, caps)):
        caps = _kept_caps(sts, gso, profile)
    return _join_caps(caps)


def _rows_laws(kept, rows):
    """The laws of the rows rows[i] of kept[i] (_KeptLaws of bases of 8), in that order:
    (vertices a row, their offsets, binding masks (flat), pieces' durations (flat), T,
    beta, predicted times, predicted ∫|a|², the pieces' offsets)."""
    m = len(kept)
    # the rows grouped by their kept base (the chains finished together share one): its
    # rows' places lo + row, by numpy over the items (not a dict entry and two appends a
    # chain); a group's items in their order, as a dict of lists gathered them
    lo, got = objfields.codes(kept, "lo", None), objfields.ids(kept, "base")    # (one compiled pass each)
    qq_all = (np.fromiter(map(_LO, kept), np.int64, m) if lo is None else lo) + rows
    del lo
    if got is not None:
        # the groups in the order unique_first_inverse gives them (their bases' ids
        # ascending): each distinct base's rank among the few ids, a row's its base's
        ubase, which = got
        by_id = np.argsort(np.fromiter(map(id, ubase), np.uint64, len(ubase)), kind="stable")
        rank = np.empty(len(ubase), np.intp)
        rank[by_id] = np.arange(len(ubase))
        inv = rank[which]
        heads = list(map(ubase.__getitem__, by_id.tolist()))
        del ubase, which
    else:
        bases = list(map(_BASE, kept))
        first, inv = unique_first_inverse(np.fromiter(map(id, bases), np.uint64, m))
        heads = list(map(bases.__getitem__, first.tolist()))
        del bases
    by_pos = np.argsort(inv, kind="stable")
    ends = np.cumsum(np.bincount(inv, None, len(heads))).tolist()
    groups = [(b, by_pos[a:z]) for b, a, z in zip(heads, [0] + ends[:-1], ends)]
    del heads
    nv = np.empty(m, np.int64)                  # vertices a row
    for b, ii in groups:
        nv[ii] = b[0].widths(qq_all[ii]) if type(b[0]) is _RaggedMask else b[0].shape[1]
    voff = _offsets(nv)
    TL, beta, tp, a2 = np.empty(m), np.empty(m), np.empty(m), np.empty(m)
    bound = np.empty(int(voff[-1]), bool)
    cnt = np.empty(m, np.int64)
    parts = []
    for b, ii in groups:
        qq = qq_all[ii]
        TL[ii], beta[ii], tp[ii], a2[ii], mask, sp, piece_t = _base_rows(b, qq)
        if type(mask) is tuple:             # (a merged base's rows: their bools end to end, widths)
            bound[_ranges(voff[ii], mask[1])] = mask[0]
        elif b[0].shape[1]:
            bound[(voff[ii][:, None] + np.arange(b[0].shape[1])).ravel()] = mask.ravel()
        p0 = sp[:, 0].astype(np.int64)
        cnt[ii] = sp[:, 1]
        parts.append((ii, p0, piece_t))
    poff = _offsets(cnt)
    tj = np.empty(int(poff[-1]))
    for ii, p0, piece_t in parts:       # each row's pieces to its place in the order
        c = cnt[ii]
        tj[_ranges(poff[ii], c)] = piece_t[_ranges(p0, c)]
    return nv, voff, bound, tj, TL, beta, tp, a2, poff


def _base_rows(b, qq):
    """The rows qq of a kept laws' base b (of 8): (T, beta, predicted times, ∫|a|², binding
    masks (bools; a merged base's, _RaggedMask: (their bools end to end, widths)), pieces'
    places, the pieces' durations (indexable)).  A windowed run's
    base (_Finisher._kept_base with a spill, its T, beta and times _figs_base's) read in two
    steps: the three figures' columns by one lookup of their memo rows (_FigsCol), the
    four spilled arrays of its block as views of the block read once (_SpilledRows, a
    PackedMask's bits) -- the same numbers as each one indexed (~900 bases in a windowed
    gyroid run's replays, ~10 reads each)."""
    T, B, P, spilled = b[3], b[4], b[5], (b[1], b[2], b[6], getattr(b[0], "bits", None))
    ragged = type(b[0]) is _RaggedMask
    if not (type(T) is type(B) is type(P) is _FigsCol and T.rows is B.rows is P.rows
            and (T.col, B.col, P.col) == (1, 2, 0) and type(b[0]) in (_PackedMask, _RaggedMask)
            and all(type(x) is _SpilledRows for x in spilled)
            and len({(x.spill, x.blk) for x in spilled}) == 1):
        mask = b[0].rows_flat(np.asarray(qq, np.int64)) if ragged else b[0][qq]
        return b[3][qq], b[4][qq], b[5][qq], b[6][qq], mask, b[2][qq], b[1]
    at = T.rows.pos()[qq]
    if np.any(at < 0):
        raise IndexError("kept row not in the memos' rows")
    at = 4 * np.asarray(at, np.int64)
    figs = np.frombuffer(T.rows.figs, float)
    data = spilled[0].spill.block(spilled[0].blk)
    tj, sp, a2, bits = (x._view(data) for x in spilled)
    qq = np.asarray(qq, np.intp)
    # (fancy indexes: copies, not views of the cached block)
    mask = (b[0].rows_flat(qq.astype(np.int64), bits) if ragged
            else np.unpackbits(bits[qq], axis=-1, count=b[0].shape[1]).view(bool))
    return figs[at + 1], figs[at + 2], figs[at], a2[qq], mask, sp[qq], tj


def _join_caps(caps):
    """_join_d of chains' caps as their geometries keep them (arrays, or the bytes of their
    doubles: joined as they are)."""
    kinds = set(map(type, caps))
    if kinds == {bytes}:
        return np.frombuffer(b"".join(caps), float)
    return _join_d([_caps_array(c) for c in caps] if bytes in kinds else caps)


def _caps_sizes(caps):
    """The number of caps of each chain's caps as kept (_caps_array's sizes)."""
    if set(map(type, caps)) == {bytes}:         # (the usual: a C-level map of their lengths)
        return np.fromiter(map(len, caps), np.int64, len(caps)) >> 3
    return np.array([len(c) >> 3 if type(c) is bytes else c.size for c in caps], int)


def _join_d(arrs):
    """np.concatenate(arrs) of 1-d arrays: where all are contiguous doubles (numpy's own
    float64 descriptor, checked by identity: a dtype's hash is ~2 k instructions), their
    bytes joined in one call, the same doubles (read-only: the laws only read their caps);
    numpy's concatenate pays ~1.5 k instructions an array (~16 k chains' caps a plate's
    replay)."""
    if arrs and all(map(is_, map(_DTYPE, arrs), repeat(_F8))) and set(map(_NDIM, arrs)) == {1}:
        try:
            return np.frombuffer(b"".join(arrs), float)
        except (BufferError, ValueError, TypeError):       # (one not contiguous: no buffer for join)
            pass
    return np.concatenate(arrs)


def _rows_knots(sts, bnd, tj, TL, beta, profile):
    """The knot speeds vk (m, n + 1) and segment durations dt (m, n) of the laws of the m
    chains sts of n segments each given by their binding masks bnd (m, n - 1), their
    pieces' durations tj (flat, chain after chain), law durations TL and weights beta: the
    laws' vertices made again (_Flat.vertices_at: solve_flat's operations, the same bits)
    and laid out as _table_rows lays out the table's."""
    m, n = bnd.shape[0], bnd.shape[1] + 1
    fl = _flat_chains(sts, profile).with_T(TL, beta)
    vk = np.empty((m, n + 1))
    tk = np.empty((m, n + 1))
    vk[:, 0], vk[:, -1] = fl.v0, fl.v1
    tk[:, 0] = 0.0
    tk[:, -1] = TL
    if n > 1:
        vv, vt = fl.vertices_at(bnd.reshape(-1), tj)
        vk[:, 1:-1] = vv.reshape(m, n - 1)
        tk[:, 1:-1] = vt.reshape(m, n - 1)
    return vk, _row_steps(tk)


def _drop(st):
    """What a chain keeps for its candidates once a plan of one is made: its rows' knots
    (ChainMemo.drop_rows) and its law's vertex caps (vertex_caps makes them again, the
    same numbers: tests/test_speed22_chainmem_drop.py), ~0.8 kB a chain (s30: the rows'
    laws, ~1/3 of the knots they replaced)."""
    st.chain_T.drop_rows()
    g = st.curv
    if g is not None:
        g.chain_caps = None


def _knots_again(items, profile, laws=False):
    """The knots (vk (n + 1), dt (n)) of candidate rows whose knots were dropped, items
    [(stroke, _Source, its row i there, law T, beta)]: each chain solved again as _figures
    solved it (the same tables, the columns in the same order from the same starts, up to
    the one asked for) and its row taken out as _table_rows takes it.  laws: with its law
    (binding mask (n - 1), pieces' durations: _Chosen keeps it), (vk, dt, mask, pieces)."""
    out = [None] * len(items)
    for qs in _by_columns(items):
        src = items[qs[0]][1]           # (the group's columns' order: every source's of it)
        Tt, bt = _sources_rows(items, qs)
        # each one's first column of its (T, beta) (the same comparisons, all rows at once)
        hit = ((Tt == np.array([items[q][3] for q in qs], float)[:, None])
               & (bt == np.array([items[q][4] for q in qs], float)[:, None]))
        if not hit.any(axis=1).all():
            raise ValueError("chain candidate not in its table")
        cols = np.argmax(hit, axis=1).tolist()
        for a in range(0, len(qs), SOLVE_CHUNK):
            sl = slice(a, min(a + SOLVE_CHUNK, len(qs)))
            sts = [items[q][0] for q in qs[sl]]
            want = cols[sl]
            need = set()
            for c in want:                # the columns each one is solved along
                while c not in need:
                    need.add(c)
                    c = src.prev.get(c, c)
            base = _flat_chains(sts, profile)
            # chains whose every solve input is an earlier one's bit for bit (_same_chains,
            # as _solve_cols: ~16 % of the gyroid plate's) are not solved: each takes its
            # first's laws (solve_flat's numbers are each chain's own)
            Ts, bs, sb, pos = Tt[sl], bt[sl], base, np.arange(len(sts))
            same = _same_chains(base, Ts, bs)
            if same is not None:
                keep, pos = same
                sb, Ts, bs = base.take(keep), Ts[keep], bs[keep]
            m, nv = sb.S.size, sb.sv.size
            res = {}
            for c in src.order:
                if c not in need:
                    continue
                fl = sb.with_T(Ts[:, c], bs[:, c])
                if c in src.prev:
                    p = src.prev[c]
                    s0 = res[p]
                    vt = s0.vert_t * (Ts[:, c] / Ts[:, p])[fl.ch]
                    res[c] = solve_flat(fl, s0.bound.copy(), vt, np.ones(m, bool), pieces=False)
                else:
                    res[c] = solve_flat(fl, cold_binding(fl), np.zeros(nv), np.zeros(m, bool), pieces=False)
            # each chain's row laid out as _table_rows lays it out, the chains of one segment
            # count and column at once (the same copies and differences, row by row); each
            # one's (vk, dt) the rows of those arrays
            by = {}
            for jj, (c, n) in enumerate(zip(want, curves.seg_counts([curves.geom(st, profile) for st in sts]))):
                by.setdefault((n, c), []).append(jj)
            for (n, c), J in by.items():
                J = np.array(J, np.int64)
                vk = np.empty((J.size, n + 1))
                tk = np.empty((J.size, n + 1))
                vk[:, 0], vk[:, -1] = base.v0[J], base.v1[J]
                tk[:, 0] = 0.0
                tk[:, -1] = Tt[a + J, c]
                if n > 1:
                    ix = sb.voff[pos[J]][:, None] + np.arange(n - 1)
                    vk[:, 1:-1] = res[c].vert_v[ix]
                    tk[:, 1:-1] = res[c].vert_t[ix]
                dt = _row_steps(tk)
                bnd = res[c].bound[ix] if n > 1 else np.empty((J.size, 0), bool)
                P, po = res[c].piece_T, res[c].piece_off
                for i, (jj, p) in enumerate(zip(J.tolist(), pos[J].tolist())):
                    out[qs[a + jj]] = ((vk[i:i + 1], dt[i:i + 1], bnd[i], P[po[p]:po[p + 1]]) if laws
                                       else (vk[i:i + 1], dt[i:i + 1]))
            del res
    return out


def _by_columns(items):
    """The places of items [(stroke, _Source, its row there, ...)] grouped by their sources'
    columns (their number, order and warm starts), items' order in each: the chains of
    several sources solved together (a windowed run's later run re-plans a few chains of
    each of many windows' sources; solve_flat's numbers are each chain's own)."""
    by, keys = {}, {}
    for q, src in enumerate(map(_IT1, items)):
        key = keys.get(id(src))
        if key is None:
            key = keys[id(src)] = (src.T.shape[1], tuple(src.order), tuple(sorted(src.prev.items())))
        by.setdefault(key, []).append(q)
    return list(by.values())


def _sources_rows(items, qs):
    """(T, beta): the rows of items[q] (q in qs) in their sources' tables, qs' order."""
    by = {}
    for j, q in enumerate(qs):
        src = items[q][1]
        got = by.get(id(src))
        if got is None:
            got = by[id(src)] = (src, [], [])
        got[1].append(j)
        got[2].append(items[q][2])
    if len(by) == 1:
        src, _, idx = next(iter(by.values()))
        idx = np.array(idx, int)
        return src.T[idx], src.beta[idx]
    k = items[qs[0]][1].T.shape[1]
    Tt, bt = np.empty((len(qs), k)), np.empty((len(qs), k))
    for src, jj, idx in by.values():
        idx = np.array(idx, int)
        Tt[jj], bt[jj] = src.T[idx], src.beta[idx]
    return Tt, bt


def _again_plans(items, rules, profile, laws=None):
    """SegmentPlans of candidates whose knots were dropped, items [(stroke, _Again, law
    T, beta)]: the knots made again (_knots_again), then finished as the candidate
    table's finishing did (_Finisher: by groups of a segment count under GROUP_JUNCTIONS,
    else chain by chain; each row's numbers its own): its predicted figures and, from the
    same call, the accelerations and feeds _replay would make of that row again (the
    finishing's acc and feed do not depend on predict: one finishing, not two).  laws: a
    list, or None: each item's law put there (mask, pieces, T, beta, predicted time and
    ∫|a|²: _chosen_solved)."""
    got = _knots_again([(st, ag.src, st.chain_T.src_i if ag.i is None else ag.i, T, b)
                        for st, ag, T, b in items], profile, laws is not None)
    grouped = rules.junction in GROUP_JUNCTIONS and profile.junction == rules.junction
    out = [None] * len(items)
    figs = [None] * len(items)
    if grouped:
        settle = _EndsSettle()
        by_n = {}
        for q, (vk, *_) in enumerate(got):
            by_n.setdefault(vk.shape[1], []).append(q)
        for qs in by_n.values():
            for a in range(0, len(qs), FINISH_ROWS):
                Q = qs[a:a + FINISH_ROWS]
                sts = [items[q][0] for q in Q]
                vk = np.concatenate([got[q][0] for q in Q])
                dt = np.concatenate([got[q][1] for q in Q])
                acc, feed, t, a2, _ = _finish_stacked_dt(sts, [curves.geom(st, profile) for st in sts],
                                                         np.arange(len(Q)), vk, dt, rules, profile)
                ends = _ends_rows(sts, vk.shape[1] - 1)
                for i, q in zip(_row_ints(len(Q)), Q):
                    figs[q] = (float(t[i]), float(a2[i]))
                    out[q] = (SegmentPlan(_knots_s(sts[i].ends_d), vk[i], acc[i], feed[i], float(t[i]), float(a2[i]))
                              if ends is None else RowPlan(ends[i], vk, acc, feed, i, float(t[i]), float(a2[i])))
                if ends is not None:
                    settle.add([out[q] for q in Q], ends, vk, acc, feed)
        settle.flush()
    else:
        for q, (st, _, _, _) in enumerate(items):
            vk, dt = got[q][:2]
            acc, feed, t, a2, _ = _finish_rows_dt(st, vk, dt, rules, profile)
            figs[q] = (float(t[0]), float(a2[0]))
            out[q] = SegmentPlan(_knots_s(st.ends_d), vk[0], acc[0], feed[0], float(t[0]), float(a2[0]))
    if laws is not None:
        laws.extend((g[2], g[3], T, b) + f for g, (_, _, T, b), f in zip(got, items, figs))
    return out


class ChainMemo:
    """A chain stroke's memory (st.chain_T; not None marks a chain: plan_kind).  What a
    dict {predicted duration: law duration, ("law", T, beta): (_KeptPlans, row), "seg": ...}
    held: its candidates as rows (t_pred, law T, beta, row) of an array of doubles, newest
    first so that .index finds the latest write as the dict would; the last plan made and
    what it was made for.  The candidate table's rows of all the chains finished together
    are one array (put_shared: this chain's are rows at..at+n of it) and a chain's rows
    share one kept plan (kept: that object; a list, one per row, once put mixes them):
    ~0.25 kB a chain (a dict held ~1.8 kB)."""
    __slots__ = ("figs", "kept", "at", "n", "seg_T", "seg_beta", "seg_key", "seg", "src", "src_i", "seg_tin")

    def __init__(self):
        self.figs = self.kept = None
        self.at = self.n = 0
        self.seg_tin = None     # the duration seg was asked for (law_T's input); None once its rows change
        self.src = None         # the _Source of its rows (_figures), its row src_i there: drop_rows
        self.src_i = -1
        self.seg_T = self.seg_beta = self.seg_key = None
        self.seg = None         # the SegmentPlan of the last plan_chain_segments (for seg_T, seg_beta, seg_key)

    def _kept(self, q):
        return self.kept[q] if isinstance(self.kept, list) else self.kept

    def _own(self):
        """This chain's rows as its own array and kept list (before a put mixes in others)."""
        if self.figs is None:
            return array("d"), []
        figs = self.figs[4 * self.at:4 * (self.at + self.n)]
        return figs, [self._kept(q) for q in range(self.n)]

    def _set(self, figs, kept, at, n):
        self.figs, self.kept, self.at, self.n = figs, kept, at, n
        self.seg_tin = None     # law_of's answers may change: law_T is asked again

    def put(self, time_t, T, beta, kept, r):
        figs, ks = self._own()
        figs[0:0] = array("d", (time_t, T, beta, r))
        ks.insert(0, kept)
        self._set(figs, ks, 0, len(ks))

    def put_rows(self, buf, k, kept):
        """put(*row, kept) for k rows given as the bytes buf of a (k, 4) array of doubles,
        newest first (the order puts leave them in)."""
        new = array("d")
        new.frombytes(buf)
        self.put_shared(new, 0, k, kept)

    def put_shared(self, figs, at, k, kept):
        """put_rows of the k rows at..at+k of figs (an array of doubles, 4 a row, shared
        with other chains), all of kept."""
        if self.figs is None:
            self._set(figs, kept, at, k)
            return
        old, ks = self._own()
        new = figs[4 * at:4 * (at + k)]
        new.extend(old)
        self._set(new, [kept] * k + ks, 0, k + len(ks))

    def _find(self, x, col):
        """Index of the newest row whose column col equals x, from each match of x in figs."""
        figs, a = self.figs, 4 * self.at
        j, stop = a, a + 4 * self.n
        while True:
            try:
                j = figs.index(x, j, stop)
            except ValueError:
                return None
            if (j - a) % 4 == col:
                return (j - a) // 4
            j += 1

    def drop_rows(self):
        """Forget the laws of this chain's candidate rows (its _KeptLaws, rows of arrays
        shared with the chains finished together: ~0.6 kB a chain) once a plan was made
        of one: a later plan of another candidate makes its row again (_Again: the
        table's computation, solved for the chains asking, the same bits).  Only rows of
        one _figures call (kept one _KeptLaws of the call that set src) are dropped."""
        if type(self.kept) is _KeptLaws and self.src is not None and self.kept.key == self.src.key:
            self.kept = self.src.again

    def rows(self):
        """[(t_pred, law T, beta, row, kept)], newest first."""
        f, a = self.figs, 4 * self.at
        return [(f[a + 4 * q], f[a + 4 * q + 1], f[a + 4 * q + 2], f[a + 4 * q + 3], self._kept(q))
                for q in range(self.n)]

    def law_of(self, time_t):
        """The law duration that gave predicted duration time_t, or time_t."""
        q = None if self.figs is None else self._find(time_t, 0)
        return time_t if q is None else self.figs[4 * (self.at + q) + 1]

    def plan_of(self, T, beta):
        """(_KeptPlans, row) of the candidate (T, beta), or None."""
        if self.figs is None:
            return None
        figs, a = self.figs, 4 * self.at
        for q in range(self.n):
            if figs[a + 4 * q + 1] == T and figs[a + 4 * q + 2] == beta:
                return self._kept(q), int(figs[a + 4 * q + 3])
        return None

    def ask(self, t, beta, key):
        """plan_chain_segments' look-up of this chain asked for predicted duration t (a
        float) and weight beta under the rules key: (law T, its last plan) where that plan
        was made for (law T, beta, key), else (law T, None, plan_of(law T, beta) or None).
        law T: the last plan's where t is what it was asked for (its rows as they were),
        else law_of(t)."""
        seg = self.seg
        lt = self.seg_T if seg is not None and self.seg_tin == t else self.law_of(t)
        if seg is not None and self.seg_T == lt and self.seg_beta == beta and self.seg_key == key:
            return lt, seg, None
        return lt, None, self.plan_of(lt, beta)


ASK_ROWS_MIN = 64          # chains of one shared rows array worth answering by numpy (ask_all)


def ask_all(memos, t_in, b_in, key, T):
    """ChainMemo.ask of every memo, memos[k].ask(t_in[k], b_in[k], key) (t_in, b_in: arrays
    of doubles): the law durations written into T (an array of doubles), the rest returned
    as three lists, (last plans, kept plans, rows): a memo's last plan or None, and of its
    candidate (kept, row) or None, None.  The memos with no last plan whose rows are rows
    of one array shared by the chains finished together (put_shared: ~140 chains an array
    on the gyroid plate) are answered by numpy on that array, a group at once (ask's
    look-ups were ~1/3 of the first plan_chain_segments: ~16 k chains, ~5 rows each, a
    float object made of each double read); the others by ask.  (Three lists, not a tuple
    a chain: ~1 MB of tuples at once on that plate.)  With the chain core, every memo in
    one C pass (ask_memos: ask's answers; -136 M instructions on that plate)."""
    m = len(memos)
    segs, kept, rows = [None] * m, [None] * m, [None] * m
    core = _chain_law.CORE_MOD
    if core is not None:
        core.ask_memos(memos if type(memos) is list else list(memos), t_in, b_in, key, T, array, segs, kept, rows)
        return segs, kept, rows
    figs_l = list(map(_FIGS, memos))
    # the memos' places by their rows array, those with no last plan and rows only
    free = np.fromiter(map(_IS_NONE, map(_SEG, memos)), bool, m) & np.fromiter(map(_IS_NOT_NONE, figs_l), bool, m)
    ids = np.fromiter(map(id, figs_l), np.uint64, m)
    ks_free = np.flatnonzero(free)
    by_pos, ends = [], []
    if ks_free.size:
        first, inv = unique_first_inverse(ids[ks_free])
        by_pos = ks_free[np.argsort(inv, kind="stable")]        # grouped, in order within a group
        ends = np.cumsum(np.bincount(inv, None, first.size)).tolist()
    asked = np.ones(m, bool)             # answered by ask
    a = 0
    for z in ends:
        ks = by_pos[a:z]
        figs = figs_l[int(ks[0])]
        if ks.size >= ASK_ROWS_MIN and len(figs) % 4 == 0:
            _ask_rows(figs, ks, memos, t_in, b_in, T, kept, rows)
            asked[ks] = False
        a = z
    for k in np.flatnonzero(asked).tolist():
        T[k], segs[k], hit = memos[k].ask(t_in[k], b_in[k], key)
        if hit is not None:
            kept[k], rows[k] = hit
    return segs, kept, rows


def _ask_rows(figs, ks, memos, t_in, b_in, T, kept_out, rows_out):
    """ChainMemo.ask of the memos ks (an int array of places in memos, t_in, b_in and the
    outputs), with no last plan, whose rows are rows at..at+n of figs (4 doubles a row):
    law_of's newest row whose predicted time is t (figs.index's equality: NaN matches
    nothing, -0.0 matches 0.0), its law T or t, into T; plan_of's newest row of that (T,
    beta): its kept plans and row into kept_out and rows_out."""
    F = np.frombuffer(figs, float).reshape(-1, 4)
    ms = list(map(memos.__getitem__, ks.tolist()))
    m = len(ms)
    at = np.fromiter(map(_AT, ms), np.intp, m)
    n = np.fromiter(map(_N, ms), np.intp, m)
    w = int(n.max())
    t = np.frombuffer(t_in, float)[ks]
    b = np.frombuffer(b_in, float)[ks]
    lt = t.copy()
    hit = np.zeros(m, bool)
    q = np.zeros(m, np.intp)
    if w:
        j = np.arange(w)
        live = j < n[:, None]
        rows = np.where(live, at[:, None] + j, 0)         # (a dead place reads row 0: masked)
        same_t = live & (F[rows, 0] == t[:, None])
        found = same_t.any(axis=1)
        lt[found] = F[at[found] + same_t[found].argmax(axis=1), 1]
        same = live & (F[rows, 1] == lt[:, None]) & (F[rows, 2] == b[:, None])
        hit = same.any(axis=1)
        q = same.argmax(axis=1)
    r = F[at[hit] + q[hit], 3].tolist()  # (each hit's row in its kept plans, as a double)
    del F                                # (the rows array's buffer let go)
    np.frombuffer(T, float)[ks] = lt
    h = np.flatnonzero(hit).tolist()
    for k, memo, qi, ri in zip(ks[hit].tolist(), map(ms.__getitem__, h), q[hit].tolist(), r):
        kept = memo.kept
        kept_out[k] = kept[qi] if isinstance(kept, list) else kept
        rows_out[k] = int(ri)


_AT, _N, _FIGS, _SEG = attrgetter("at"), attrgetter("n"), attrgetter("figs"), attrgetter("seg")
_IS_NONE = partial(is_, None)


class MemosAside:
    """The chains' memos of a side table (a list, one slot a row: StoredStrokes keeps them)
    written to an unnamed temporary file in folder and let go until restore() puts them
    back, for the windowed rewrite and measure, which read none (the gyroid plate's 16.4 k
    memos, 2.0 MB, and their 110 rows arrays, 2.6 MB, held through them: benchmarks/mem59.md).
    Whoever reads a memo calls restore() first (StoredStrokes hands the memos out).

    - The rows arrays (ChainMemo.figs: arrays of doubles, each shared by a finishing batch's
      chains and its kept laws, _FigsRows): each written and its buffer let go in place
      (emptied: the same object, which the kept laws sharing it still hold), read back
      into it.  An array whose buffer is exported (a view of it alive) is kept as it is.
    - The memos themselves, where every one is the side table's alone (no other reference:
      a copy put back would part from it) and holds no last plan (seg ... seg_tin None: the
      windowed runs keep none): each one's objects (figs, kept, src: places in a list of
      the distinct ones, held here) and ints (at, n, src_i) written as columns, its slot
      emptied; restore() makes each memo again with those (the same objects, equal ints).
    All is written before anything is let go: a write error loses nothing."""
    __slots__ = ("_io", "_rows", "_side", "_memos")

    def __init__(self, side, folder=None):
        from .stroke_store import _TempFile
        rows = _memo_rows(side)
        memos = objfields.take(side, rows)
        if memos is None:
            memos = list(map(side.__getitem__, rows.tolist()))
        firsts, which = objfields.by_identity(memos, "figs")      # (the distinct rows arrays, in a compiled pass)
        figs = [f for f in firsts if f is not None and len(f)]
        self._io, arrays, end = _TempFile(folder), [], 0
        self._side, self._memos = side, None
        try:
            for f in figs:
                with memoryview(f) as mv:
                    self._io.write(end, mv.cast("B"))
                arrays.append((f, end, len(f) * f.itemsize))
                end += arrays[-1][2]
            cols = _MemoColumns.of(memos, rows, (firsts, which), self._io, end) if _memos_alone(memos) else None
        except OSError:
            self._io.close()
            raise
        self._rows = []
        for row in arrays:
            try:
                del row[0][:]
            except BufferError:         # (exported: kept as it is, nothing to read back)
                continue
            self._rows.append(row)
        if cols is not None:
            del memos
            self._memos = cols.let_go(side, rows)

    def restore(self):
        """Every rows array read back into its object and every memo put back in its slot
        (once: then the file is closed)."""
        if self._io is None:
            return
        for f, at, nbytes in self._rows:
            got = bytearray(nbytes)
            self._io.read_into(memoryview(got), at)
            f.frombytes(got)
        if self._memos is not None:
            self._memos.put_back(self._side, self._io)
        self._rows, self._memos, self._side = [], None, None
        self._io.close()
        self._io = None


def _memo_rows(side):
    """The rows of side (a list) that hold an object (not None), an intp array: their
    classes read in one compiled pass where built (objfields.codes)."""
    got = objfields.codes(side, "__class__", {type(None): 0}, add=True)
    if got is None:
        got = np.fromiter(map(_IS_NOT_NONE, side), bool, len(side))
    return np.flatnonzero(got)


def _memos_alone(memos):
    """Whether every one of memos (a list, the objects of a side table's slots) is a
    ChainMemo referenced by its slot and memos alone and holds no last plan (MemosAside
    lets them go and makes them again).  (One loop, each test cut short: ten map passes
    over the gyroid plate's 16 k memos cost ~45 M instructions more.)"""
    probe = [ChainMemo()]
    refs = _refs_in_loop(probe[:])      # (a memo in a slot, probe's, and in the list looped over)
    for m in memos:
        if (type(m) is not ChainMemo or sys.getrefcount(m) != refs or m.seg is not None or m.seg_T is not None
                or m.seg_beta is not None or m.seg_key is not None or m.seg_tin is not None
                or type(m.at) is not int or type(m.n) is not int or type(m.src_i) is not int):
            return False
    return True


def _refs_in_loop(memos):
    """The first of memos' references as _memos_alone's loop sees one of its memos."""
    for m in memos:
        return sys.getrefcount(m)


class _MemoColumns:
    """MemosAside's memos as columns in its file: their rows in the side table and, a memo
    a column, its figs', kept's and src's places in objs (the distinct objects, None
    among them where a memo holds None) and its at, n and src_i (int64, written at byte
    `pos` of the file)."""
    __slots__ = ("objs", "pos", "n")

    NAMES = ("figs", "kept", "src")

    @classmethod
    def of(cls, memos, rows, figs, io, pos):
        """figs: objfields.by_identity(memos, "figs"), made already."""
        self = cls()
        cols = np.empty((7, len(memos)), np.int64)
        cols[0] = rows
        self.objs = []
        for c, name in enumerate(cls.NAMES, 1):
            firsts, which = figs if name == "figs" else objfields.by_identity(memos, name)
            cols[c] = which
            cols[c] += len(self.objs)
            self.objs += firsts
        for c, name in enumerate(("at", "n", "src_i"), 4):
            cols[c] = np.fromiter(map(attrgetter(name), memos), np.int64, len(memos))
        io.write(pos, cols.data.cast("B"))
        self.pos, self.n = pos, len(memos)
        return self

    def let_go(self, side, rows):
        """The memos' slots emptied (read back from the file by put_back)."""
        if not objfields.fill_at(side, rows, None):
            for r in rows.tolist():
                side[r] = None
        return self

    def put_back(self, side, io):
        cols = np.empty((7, self.n), np.int64)
        io.read_into(memoryview(cols).cast("B"), self.pos)
        objs = self.objs
        for r, fk, kk, sk, at, n, si in zip(*(c.tolist() for c in cols)):
            m = side[r] = ChainMemo()
            m.figs, m.kept, m.src = objs[fk], objs[kk], objs[sk]
            m.at, m.n, m.src_i = _row_int(at), _row_int(n), _row_int(si)


def _rules_key(rules, profile):
    """What a chain's SegmentPlan depends on besides its law (plan_chain_segments' cache key)."""
    return (rules.junction, rules.n_max, rules.seg_t, rules.min_seg_d, id(profile))


def solve(strokes, T, beta, profile):
    """Laws of chains at law durations T (solved together, SOLVE_CHUNK at a time)."""
    out = []
    for a in range(0, len(strokes), SOLVE_CHUNK):
        sl = slice(a, a + SOLVE_CHUNK)
        out += solve_chains(_problems(strokes[sl], T[sl], beta[sl], profile))
    return out


# ------------------------------------------------------------------ segments
def _a_top(st):
    return min(st.accel, st.lim.ax_max, st.lim.ay_max)


TRAP_GRID = np.linspace(0.0, 1.0, 33)[1:]    # cruise speeds tried between d/t and the triangle's peak


def shape_segments(d, t, va, vb, a_top=np.inf, trapezoid=True):
    """Per segment (length d, duration t, end speeds va -> vb; a_top one value or one per
    segment): the firmware acceleration and feed that play it in that time.  A pure ramp where that takes at least t (F = the
    faster end).  Else a bump: the trapezoid up to F, cruise, down, whose ∫a²dt =
    a (2F - va - vb) is least among those taking t with a <= a_top, where
    a(F) = ((F - va)² + (F - vb)²) / (2 (F t - d)), d/t < F <= P; P is the triangle's peak
    (no cruise): the shape when no trapezoid fits a_top, and under classic jerk
    (trapezoid False), which counts a change of F between two moves as a jerk: there the
    feeds follow a tent from the slicer's F (tent_feeds) and a lifted F turns a trapezoid
    into a steeper triangle, while a triangle's F may be any value above its peak."""
    t_ramp = 2.0 * d / np.maximum(va + vb, 1e-12)
    ramp_a = np.abs(vb * vb - va * va) / (2.0 * d)
    bump = t < t_ramp * (1.0 - 1e-9)
    tt = np.where(bump, t, 1.0)
    disc = np.maximum(16.0 * d * d - 8.0 * tt * (2.0 * d * (va + vb) - tt * (va * va + vb * vb)), 0.0)
    peak = (4.0 * d + np.sqrt(disc)) / (4.0 * tt)
    peak = np.maximum(peak, np.maximum(va, vb))
    tri_a = (2.0 * peak * peak - va * va - vb * vb) / (2.0 * d)
    acc = np.where(bump, tri_a, ramp_a)
    feed = np.where(bump, peak, np.maximum(va, vb))
    if trapezoid and bump.any():
        bumps = np.flatnonzero(bump)
        for c in range(0, bumps.size, SHAPE_BUMPS):
            _shape_bumps(bumps[c:c + SHAPE_BUMPS], d, tt, va, vb, a_top, peak, tri_a, acc, feed)
    return acc, np.maximum(feed, MIN_FEED_V)


SHAPE_BUMPS = 4096      # bumps whose trapezoids shape_segments tries at once ((bumps, 32) arrays: ~1 MB each)


def _shape_bumps(b, d, tt, va, vb, a_top, peak, tri_a, acc, feed):
    """shape_segments' trapezoids tried on the bumps b (each bump's numbers its own: the
    same whatever bumps are tried with it), written in acc and feed."""
    lo = np.maximum(d[b] / tt[b], np.maximum(va[b], vb[b]))
    F = lo[:, None] + (peak[b] - lo)[:, None] * TRAP_GRID[None, :]
    x, y = va[b][:, None], vb[b][:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        a = ((F - x) ** 2 + (F - y) ** 2) / (2.0 * (F * tt[b][:, None] - d[b][:, None]))
        at = a_top if np.ndim(a_top) == 0 else np.asarray(a_top, float)[b][:, None]   # per segment
    cost = np.where((a > 0) & (a <= at), a * (2.0 * F - x - y), np.inf)
    j = np.argmin(cost, axis=1)
    r = np.arange(b.size)
    tri_cost = tri_a[b] * (2.0 * peak[b] - va[b] - vb[b])
    take = np.isfinite(cost[r, j]) & (cost[r, j] < tri_cost)
    acc[b] = np.where(take, a[r, j], tri_a[b])
    feed[b] = np.where(take, F[r, j], peak[b])


def finish_chain(st, law, rules, profile):
    """SegmentPlan of one chain from its law, and whether its own ramps fit the
    acceleration limit (before what the junctions need is added; a ramp that does not
    is played at the limit, slower than the law: the prediction says how much)."""
    return finish_chains(st, [law], rules, profile)[0]


def finish_chains(st, laws, rules, profile):
    """finish_chain for several laws of the same chain (its candidates), as rows of one
    (k, n) batch: the per-call overhead of numpy on ~20-segment chains is shared."""
    kept, fits = _finish_rows(st, laws, rules, profile)
    return [(kept.plan(r), bool(fits[r])) for r in range(len(laws))]


def _finish_rows(st, laws, rules, profile):
    """finish_chains as arrays: (_KeptPlans, fits per row)."""
    n = curves.geom(st, profile).d.size
    k = len(laws)
    vk = np.empty((k, n + 1))
    vk[:, 0], vk[:, -1] = st.v0, st.v1
    tk = np.empty((k, n + 1))
    tk[:, 0] = 0.0
    for r, law in enumerate(laws):
        vk[r, 1:-1] = law.vert_v
        tk[r, 1:-1] = law.vert_t
        tk[r, -1] = law.problem.T
    return _finish_rows_arrays(st, vk, tk, rules, profile)


def _finish_rows_arrays(st, vk, tk, rules, profile):
    """_finish_rows from the laws' speeds vk and times tk at the knots (k, n + 1)."""
    acc, feed, t_pred, a2_pred, fits = _finish_rows_dt(st, vk, _row_steps(tk), rules, profile)
    return _KeptPlans(_rules_key(rules, profile), st.ends_d, (vk, acc, feed, t_pred, a2_pred)), fits


def _finish_rows_dt(st, vk, tk, rules, profile, predict=True):
    """_finish_rows_arrays' numbers (acc, feed, t_pred, a2_pred, fits) from the knot speeds vk
    (k, n + 1) and the segments' durations tk (k, n)."""
    g = curves.geom(st, profile)
    d = g.d
    k, n = vk.shape[0], d.size
    a_top = _a_top(st)
    acc, feed = shape_segments(np.broadcast_to(d, (k, n)).ravel(), np.maximum(tk, 1e-12).ravel(),
                               vk[:, :-1].ravel(), vk[:, 1:].ravel(), a_top,
                               trapezoid=rules.junction != "jerk")
    acc, feed = acc.reshape(k, n), feed.reshape(k, n)
    fits = np.all(acc <= a_top * (1 + SPEED_TOL_R), axis=1)
    acc = np.minimum(acc, a_top)
    step_v = np.inf
    if rules.junction == "jerk":
        step_v = curves.JERK_F_STEP_R * min(st.lim.jerk_x, st.lim.jerk_y)
        # its floor is row by row arithmetic on the feeds as shaped: every row at once
        acc = _junction_accels(st, g, vk, acc, rules, profile, feed)
    else:       # each row's junction accelerations from its own feeds as shaped, all rows at once
        acc = _junction_accels(st, g, vk, acc, rules, profile, feed)
    acc = hold_cruise_accels_rows(acc, a_top)
    feed = _tent_rows(feed, st.v_feed, step_v)
    if not predict:
        return acc, feed, None, None, fits
    t_pred, a2_pred = predict_chains(st, g, acc, feed, profile)
    return acc, feed, t_pred, a2_pred, fits


def _tent_rows(need, v_feed, step_v, core=None):
    """segments.tent_feeds_rows(need, v_feed, step_v), by the chain core's tent_rows (the
    same differences, their maximum: the same bits) when every value is finite and > 0
    (classic jerk's chains: positive feeds and steps); else (an infinite step: the feeds
    as they are; a nan, a 0) by tent_feeds_rows.  core: the module (None = the chain core
    if it is there, False = never)."""
    core = _chain_law.CORE_MOD if core is None else core
    if core and need.ndim == 2 and need.size:
        k = need.shape[0]
        need_c = np.ascontiguousarray(need, float)
        vf = np.ascontiguousarray(np.broadcast_to(np.asarray(v_feed, float), (k,)))
        step = np.ascontiguousarray(np.broadcast_to(np.asarray(step_v, float), (k,)))
        out = np.empty(need_c.shape)
        if core.tent_rows(need_c, vf, step, out):
            return out
    return tent_feeds_rows(need, v_feed, step_v)


GROUP_JUNCTIONS = ("jerk", "scv", "jd")   # junction laws whose finishing runs over groups of chains
CORE_JUNCTIONS = {"jerk": 0, "scv": 1, "jd": 2}    # and the chain core's code of each (chain_finish)


def _window(g, profile):
    """The distance a finite-lookahead planner sees from each segment on (its block_buffer
    - 3 blocks), kept on the chain's geometry."""
    d, n = g.d, g.d.size
    nb = max(profile.block_buffer - 3, 1)
    ext = np.concatenate([d, np.full(nb, d[-1])])
    return np.convolve(ext, np.ones(nb), "valid")[:n]


def _windows(gs, profile):
    """_window of chains with the same number of segments, stacked (m, n): one np.convolve
    over their extended lengths laid end to end, each window read where its chain's own
    "valid" outputs fall (the same dot of the same nb terms in the same order)."""
    n, m = gs[0].d.size, len(gs)
    nb = max(profile.block_buffer - 3, 1)
    ext = np.empty((m, n + nb))
    ext[:, :n] = np.stack([g.d for g in gs])
    ext[:, n:] = ext[:, n - 1:n]
    conv = np.convolve(ext.ravel(), np.ones(nb), "valid")
    return conv[(np.arange(m) * (n + nb))[:, None] + np.arange(n)]


def finish_groups(items, rules, profile):
    """_finish_rows of many chains: [(stroke, laws)] -> [(_KeptPlans, fits)].  Under the
    junction laws whose vertex speeds are array arithmetic (GROUP_JUNCTIONS), chains with
    the same number of segments are finished together, their candidate rows stacked: the
    numpy calls are shared by ~10² chains instead of paid per chain.  Every row's numbers
    are its own (elementwise arithmetic, row sums over the same n): the same as chain by
    chain (tests/test_speed_plan_rows.py)."""
    out = [None] * len(items)
    if rules.junction not in GROUP_JUNCTIONS or profile.junction != rules.junction:
        for q, (st, laws) in enumerate(items):
            out[q] = _finish_rows(st, laws, rules, profile)
        return out
    by_n = {}
    for q, (st, laws) in enumerate(items):
        by_n.setdefault(curves.geom(st, profile).d.size, []).append(q)
    for qs in by_n.values():
        for q, res in zip(qs, _finish_group([items[q] for q in qs], rules, profile)):
            out[q] = res
    return out


def _finish_group(items, rules, profile):
    """_finish_rows of chains with the same number of segments, rows stacked."""
    sts = [st for st, _ in items]
    gs = [curves.geom(st, profile) for st in sts]
    ks = [len(laws) for _, laws in items]
    n = gs[0].d.size
    R = sum(ks)
    vk = np.empty((R, n + 1))
    tk = np.empty((R, n + 1))
    r = 0
    for st, laws in items:
        for law in laws:
            vk[r, 0], vk[r, -1] = st.v0, st.v1
            vk[r, 1:-1] = law.vert_v
            tk[r, 0] = 0.0
            tk[r, 1:-1] = law.vert_t
            tk[r, -1] = law.problem.T
            r += 1
    return _finish_stacked(sts, gs, ks, vk, tk, rules, profile)


def _finish_stacked(sts, gs, ks, vk, tk, rules, profile):
    """_finish_group from the rows' knot speeds vk and times tk (R, n + 1), ks[q] rows of
    chain sts[q] after each other."""
    own = np.repeat(np.arange(len(sts)), ks)               # the chain of each row
    acc, feed, t_pred, a2_pred, fits = _finish_stacked_dt(sts, gs, own, vk, _row_steps(tk), rules, profile)
    key = _rules_key(rules, profile)
    res = []
    base = (vk, acc, feed, t_pred, a2_pred)
    lo = 0
    for st, k in zip(sts, ks):
        res.append((_KeptPlans(key, st.ends_d, base, lo, k), fits[lo:lo + k]))
        lo += k
    return res


def _finish_stacked_dt(sts, gs, own, vk, tk, rules, profile, predict=True, du=None):
    """_finish_stacked's numbers (acc, feed, t_pred, a2_pred, fits) from the rows' knot
    speeds vk (R, n + 1) and segment durations tk (R, n); own: the chain of each row.
    du: curves.stack_du(gs) if the caller has it (None: made where needed)."""
    if rules.junction in GROUP_JUNCTIONS and profile.junction == rules.junction:
        got = _finish_core(sts, gs, own, vk, tk, rules, profile, predict, du=du)
        if got is not None:
            return got
    n = gs[0].d.size
    R = vk.shape[0]
    d = np.stack([g.d for g in gs])[own]
    a_top = np.array([_a_top(st) for st in sts], float)[own]
    acc, feed = shape_segments(d.ravel(), np.maximum(tk, 1e-12).ravel(), vk[:, :-1].ravel(), vk[:, 1:].ravel(),
                               np.repeat(a_top, n), trapezoid=rules.junction != "jerk")
    acc, feed = acc.reshape(R, n), feed.reshape(R, n)
    fits = np.all(acc <= (a_top * (1 + SPEED_TOL_R))[:, None], axis=1)
    acc = np.minimum(acc, a_top[:, None])
    step_v = np.inf
    if rules.junction == "jerk":
        step_v = (curves.JERK_F_STEP_R * np.array([min(st.lim.jerk_x, st.lim.jerk_y) for st in sts], float))[own]
        if profile.block_buffer > 0:       # _junction_accels under classic jerk: the lookahead floor
            window = _windows(gs, profile)[own]
            acc = np.maximum(acc, np.minimum(1.1 * feed ** 2 / (2.0 * window), a_top[:, None]))
    else:       # each row's junction accelerations from its own feeds as shaped, all rows at once
        acc = _junction_accels_stacked(sts, gs, own, d, vk, acc, a_top, rules, profile, feed)
    acc = hold_cruise_accels_rows(acc, a_top)
    feed = _tent_rows(feed, np.array([st.v_feed for st in sts], float)[own], step_v)
    if not predict:                  # (the caller has the figures: _replay)
        return acc, feed, None, None, fits
    t_pred, a2_pred = _predict_group(sts, gs, own, d, acc, feed, profile)
    return acc, feed, t_pred, a2_pred, fits


_CF_NO_W = np.empty(0)


def _cf_consts(profile):
    """The constants of the chain core's chain_finish (CK_* in _chaincore.c)."""
    return np.array([1 + SPEED_TOL_R, profile.default_accel_a, CRUISE_A, CORNER_COS, SQRT2_M1,
                     curves.ACCEL_MARGIN, FULL_STOP_V, MIN_FEED_V], float)


_CF_ROW = 15


def _cf_row(st, jd=False):
    """A chain's numbers for _finish_core's P: _a_top, v_feed, v0, v1, the limits' jerk_x,
    jerk_y, scv (jd: the limits' jd in its place, the chain core's CP_JD), ax_max, ay_max,
    prev_u and next_u (nan, nan where None) and whether each is there (1.0 / 0.0)."""
    lim, pu, nu = st.lim, st.prev_u, st.next_u
    hp, hn = pu is not None, nu is not None
    px, py = pu if hp else _NAN2
    nx, ny = nu if hn else _NAN2
    return (min(st.accel, lim.ax_max, lim.ay_max), st.v_feed, st.v0, st.v1, lim.jerk_x, lim.jerk_y,
            lim.jd if jd else lim.scv, lim.ax_max, lim.ay_max, px, py, nx, ny, 1.0 if hp else 0.0, 1.0 if hn else 0.0)


_NAN2 = (math.nan, math.nan)
# _finish_core's columns of P copied from _cf_rows' Q, by junction (jerk?): (P's, Q's)
_CF_P_COLS = {True: (np.array([0, 8, 9, 1, 3, 4]), np.array([0, 2, 3, 1, 4, 5])),
              False: (np.array([0, 8, 9, 5, 6, 7]), np.array([0, 2, 3, 6, 7, 8]))}


def _cf_rows(sts, core=None, jd=False):
    """_cf_row(st, jd) of every chain of sts as the rows of an (m, _CF_ROW) array: by the chain
    core's cf_rows (the same doubles read in C from each stroke's slots: ~16 k chains
    twice on the gyroid plate, a row of Python floats packed each), else (no core, or it
    declines: a stroke not a strokes.Stroke, a value not a float) packed as doubles as
    each row is made (not a list of m tuples of floats: ~1 MB at once on 2048 chains).
    core: the module (None = the chain core if it is there, False = never)."""
    core = _chain_law.CORE_MOD if core is None else core
    m = len(sts)
    fn = getattr(core, "cf_rows", None) if core else None
    if fn is not None and m:
        Q = np.empty((m, _CF_ROW))
        if fn(sts if type(sts) is list else list(sts), Stroke, Q, *((True,) if jd else ())):
            return Q
    buf = array("d")
    for st in sts:
        buf.extend(_cf_row(st, jd))
    return np.frombuffer(buf, float).reshape(m, _CF_ROW) if m else np.zeros((0, _CF_ROW))


def _junction_accels_stacked(sts, gs, own, d, vk, acc, a_top, rules, profile, feed):
    """_junction_accels (scv, jd) of stacked rows of chains with the same number of
    segments (own: the chain of each row; d (R, n), a_top (R,)), every row at once: each
    row's numbers are those of its chain's own call (curves.junctions_raised_rows, then the
    lookahead floor on _windows' sums, the same dot of the same terms); a row where the
    per-junction form would raise is made by its chain's call."""
    e = np.array([_junction_ends(st) for st in sts], float)[own]
    vj = np.array(vk, float)
    vj[:, 0] = np.where(e[:, 0] >= FULL_STOP_V, e[:, 0], 0.0)
    vj[:, -1] = np.where(e[:, 1] >= FULL_STOP_V, e[:, 1], 0.0)
    U = np.stack([g.u for g in gs])[own]
    out, odd = curves.junctions_raised_rows(e[:, 2], e[:, 3], e[:, 4] != 0.0, e[:, 5], e[:, 6], e[:, 7] != 0.0,
                                            U[..., 0], U[..., 1], d, vj, acc, rules.junction, e[:, 8:9],
                                            a_top[:, None])
    if profile.block_buffer > 0:
        window = _windows(gs, profile)[own]
        out = np.maximum(out, np.minimum(1.1 * feed ** 2 / (2.0 * window), a_top[:, None]))
    for r in np.flatnonzero(odd.any(axis=1)).tolist():
        c = own[r]
        out[r] = _junction_accels(sts[c], gs[c], vk[r], acc[r], rules, profile, feed[r])
    return out


def _junction_ends(st):
    """(v0, v1, prev_u x, y, has one, next_u x, y, has one, jd) of a chain."""
    pu, nu = st.prev_u, st.next_u
    p = (0.0, 0.0, 0.0) if pu is None else (pu[0], pu[1], 1.0)
    q = (0.0, 0.0, 0.0) if nu is None else (nu[0], nu[1], 1.0)
    return (st.v0, st.v1) + p + q + (st.lim.jd,)


def _finish_core(sts, gs, own, vk, tk, rules, profile, predict, core=None, du=None):
    """_finish_stacked_dt's numbers by the chain core's chain_finish (one C call for the
    batch: the same operations in numpy's order, the same bits: tests/test_speed21_chainfin_core.py),
    under a junction law of GROUP_JUNCTIONS that is the profile's; None (the numpy code
    then) when the core is missing or stale, or declines the inputs (a non-finite one, a
    classic-jerk tent input that is not finite and > 0).  core: the module (None = the
    chain core if it is there, False = never).  du: curves.stack_du(gs), or None (made here)."""
    core = _chain_law.CORE_MOD if core is None else core
    fn = getattr(core, "chain_finish", None) if core else None
    if fn is None or rules.junction not in CORE_JUNCTIONS or profile.junction != rules.junction:
        return None
    jerk = rules.junction == "jerk"
    n, m, R = gs[0].d.size, len(sts), vk.shape[0]
    # (np.array of the rows, not np.stack: the same copy, a third of the time on ~10^2 chains)
    D, U = curves.stack_du(gs) if du is None else du
    if vk.shape != (R, n + 1) or tk.shape != (R, n) or D.shape != (m, n) or U.shape != (m, n, 2):
        return None
    # the turns' cosines, g.cos_turn of every chain in one pass over the stack (the same
    # two-term sum of products a row, the same bits; ~34 k property calls on the gyroid plate)
    C = _turn_cosines(U, core) if n > 1 else np.empty((m, 0))
    W, ws = _CF_NO_W, 0
    if profile.block_buffer > 0:       # _windows' convolution, each chain's window at W[q ws:q ws + n]
        nb = max(profile.block_buffer - 3, 1)
        ext = np.empty((m, n + nb))
        ext[:, :n] = D
        ext[:, n:] = D[:, n - 1:n]
        W, ws = _window_sums(ext.ravel(), nb, core), n + nb
    # each chain's numbers in one pass over the chains, one row a chain (_cf_rows), then as
    # columns: the values the columns were given one list each before
    Q = _cf_rows(sts, core, rules.junction == "jd")
    pu, nu = Q[:, 9:11], Q[:, 11:13]
    P = np.zeros((m, 18))
    # _a_top, v0, v1 and the law's limits (jerk: v_feed, jerk_x, jerk_y; scv: scv, ax_max,
    # ay_max; jd: jd in scv's place, ax_max, ay_max): Q's columns copied in one gather (P's, Q's)
    to, fr = _CF_P_COLS[jerk]
    P[:, to] = Q[:, fr]
    # the end turns, curves.dot2(prev_u, u[0]) and dot2(u[-1], next_u) of predict_chains (its
    # two products and their sum; nan: no neighbour)
    P[:, 10] = pu[:, 0] * U[:, 0, 0] + pu[:, 1] * U[:, 0, 1]
    P[:, 11] = U[:, -1, 0] * nu[:, 0] + U[:, -1, 1] * nu[:, 1]
    if jerk:
        P[:, 2] = curves.JERK_F_STEP_R * np.minimum(P[:, 3], P[:, 4])     # step_v: the numpy code's
    else:
        P[:, 2] = math.inf
        hp = Q[:, 13] != 0.0
        hn = Q[:, 14] != 0.0
        P[hp, 12:14], P[hp, 14] = pu[hp], 1.0
        P[hn, 15:17], P[hn, 17] = nu[hn], 1.0
    acc, feed = np.empty((R, n)), np.empty((R, n))
    t, a2, fits = np.empty(R), np.empty(R), np.empty(R, bool)
    if not fn(CORE_JUNCTIONS[rules.junction], 1 if predict else 0, np.ascontiguousarray(own, np.int64),
              np.ascontiguousarray(vk, float), np.ascontiguousarray(tk, float), D, U, C, W, ws,
              P, TRAP_GRID, _cf_consts(profile), acc, feed, t, a2, fits):
        return None
    return (acc, feed, t, a2, fits) if predict else (acc, feed, None, None, fits)


RAGGED_CELLS = 1 << 16     # a ragged finishing call's segments at most (its copies of vk, dt, acc, feed: ~2 MB)


def _finish_ragged(batches, rules, profile, core=None, predict=True):
    """_finish_stacked_dt (predict) of several batches [(sts, gs, own, vk, tk)], each rows
    of chains of one segment count as _finish_stacked_dt takes them, in one call of the
    chain core's chain_finish_ragged: [(acc, feed, t, a2, fits)] a batch.  Each row is
    finished by chain_finish's own row code from the numbers _finish_core gives it (P from
    _cf_rows, the turn cosines and the windows' sums made chain by chain in C with the same
    operations): the same bits (tests/test_speed52_cpu52_ragged.py), without the ~15 numpy
    calls and the core's call of _finish_core a batch (the windowed candidates: ~30 batches a
    window).  None (the caller then finishes batch by batch) where _finish_core would not
    take them all: no core, another junction law, windows np.convolve would sum
    (_window_sums), a shape it declines, or the core declines an input.  core: the module
    (None = the chain core if it is there, False = never).  predict False: t and a2 None
    (acc and feed do not depend on it: _replay's)."""
    core = _chain_law.CORE_MOD if core is None else core
    fn = getattr(core, "chain_finish_ragged", None) if core else None
    if fn is None or rules.junction not in CORE_JUNCTIONS or profile.junction != rules.junction:
        return None
    nb = 0
    if profile.block_buffer > 0:
        nb = max(profile.block_buffer - 3, 1)
        if _window_sums_fn(core, nb) is None:
            return None
    sizes = []
    for sts, gs, own, vk, tk in batches:
        m, R, n = len(sts), vk.shape[0], vk.shape[1] - 1
        if n < 1 or tk.shape != (R, n) or len(gs) != m:
            return None
        sizes.append((m, R, n))
    ms, Rs, ns = np.array(sizes, np.int64).T
    coff = np.zeros(ms.sum() + 1, np.int64)
    np.cumsum(np.repeat(ns, ms), out=coff[1:])
    cells = int(Rs @ ns)
    R = int(Rs.sum())
    # the call's flat inputs made in place, batch after batch (each batch's lengths and
    # directions stacked into its stretch of D and U, its knots and steps copied into VK
    # and TK): the values the batches' own arrays ravelled and joined had, one copy each,
    # not a stack_du, four ravels and four joins (the knot steps a strided view: two
    # copies) a batch (~1.4 k batches on the windowed gyroid plate)
    D, U = np.empty(int(coff[-1])), np.empty(2 * int(coff[-1]))
    VK, TK, OWN = np.empty(cells + R), np.empty(cells), np.empty(R, np.int64)
    sts_all, c, a, r = [], 0, 0, 0
    for (sts, gs, own, vk, tk), (m, Rb, n) in zip(batches, sizes):
        if not curves.stack_du_into(gs, n, D[c:c + m * n].reshape(m, n), U[2 * c:2 * (c + m * n)].reshape(m, n, 2)):
            return None
        VK[a + r:a + r + Rb * (n + 1)].reshape(Rb, n + 1)[...] = vk
        TK[a:a + Rb * n].reshape(Rb, n)[...] = tk
        o = OWN[r:r + Rb]
        o[...] = own
        o += len(sts_all)
        sts_all += sts
        c += m * n
        a += Rb * n
        r += Rb
    acc, feed = np.empty(cells), np.empty(cells)
    t, a2, fits = np.empty(R), np.empty(R), np.empty(R, bool)
    if not fn(CORE_JUNCTIONS[rules.junction], 1 if predict else 0, nb, curves.JERK_F_STEP_R, OWN, coff, VK, TK, D, U,
              _cf_rows(sts_all, core, rules.junction == "jd"), TRAP_GRID, _cf_consts(profile), acc, feed, t, a2,
              fits):
        return None
    del VK, TK, D, U
    # (t, a2 and fits each batch's own arrays, as _finish_stacked_dt gives them: the memos keep
    # t and a2 a batch, and a view would keep the whole call's alive; acc and feed are views)
    out, a, r = [], 0, 0
    for (_, Rb, n) in sizes:
        out.append((acc[a:a + Rb * n].reshape(Rb, n), feed[a:a + Rb * n].reshape(Rb, n),
                    t[r:r + Rb].copy() if predict else None, a2[r:r + Rb].copy() if predict else None,
                    fits[r:r + Rb].copy()))
        a += Rb * n
        r += Rb
    return out


def _turn_cosines(U, core):
    """np.einsum("mij,mij->mi", U[:, :-1], U[:, 1:]): the turn cosines of chains of n > 1
    segments from their unit directions U (m, n, 2).  By the chain core's turn_cosines
    where U is C-contiguous doubles (einsum's additions in its order, from its zero: the
    same bits; einsum's set-up and generic loop a batch: ~30 M instructions net on the
    gyroid plate); else einsum.  core: the module (False / None: einsum)."""
    fn = getattr(core, "turn_cosines", None) if core else None
    if fn is not None and U.dtype == np.float64 and U.ndim == 3 and U.shape[2] == 2 and U.flags.c_contiguous:
        m, n = U.shape[0], U.shape[1]
        C = np.empty((m, n - 1))
        fn(U, m, n, C)
        return C
    return np.einsum("mij,mij->mi", U[:, :-1], U[:, 1:])


_WINDOW_SUMS_OK = {}     # nb -> does the core's window_sums give np.convolve's bits (_window_sums_ok)


def _window_sums(x, nb, core):
    """np.convolve(x, np.ones(nb), "valid") (x: doubles, C-contiguous): by the chain core's
    window_sums (each window's terms added left to right from 0.0: ~6 k instructions a
    chain less than numpy's dot call per window, ~17 k chains a plate's replay and as many
    in its candidates) where a probe found it gives np.convolve's bits for this nb on this
    machine (numpy's dot goes to OpenBLAS's ddot, whose vector kernel adds a long window
    in another order); else np.convolve.  core: the module (False / None: np.convolve)."""
    fn = _window_sums_fn(core, nb)
    if fn is not None and x.dtype == np.float64 and x.flags.c_contiguous and x.size >= nb:
        out = np.empty(x.size - nb + 1)
        fn(x, nb, out)
        return out
    return np.convolve(x, np.ones(nb), "valid")


def _window_sums_fn(core, nb):
    """The chain core's window_sums where it gives np.convolve's bits for this nb (a probe,
    once an nb: _window_sums_ok), else None.  core: the module (False / None: None)."""
    fn = getattr(core, "window_sums", None) if core else None
    if fn is None:
        return None
    ok = _WINDOW_SUMS_OK.get(nb)
    if ok is None:
        ok = _WINDOW_SUMS_OK[nb] = _window_sums_ok(fn, nb)
    return fn if ok else None


def _window_sums_ok(fn, nb):
    """Do window_sums and np.convolve(x, np.ones(nb), "valid") agree bit for bit on values
    whose sums depend on the order of their additions (magnitudes over 12 decades, signs
    mixed, plus segment-like lengths)?"""
    rng = ProbeRng(8)
    probes = [rng.uniform(0.01, 2.0, 4 * nb + 64),
              rng.lognormal(0.0, 6.0, 4 * nb + 64) * rng.choice([-1.0, 1.0], 4 * nb + 64),
              np.round(rng.uniform(0.1, 1.0, 4 * nb + 64), 3)]
    for x in probes:
        out = np.empty(x.size - nb + 1)
        fn(x, nb, out)
        if out.view(np.int64).tobytes() != np.convolve(x, np.ones(nb), "valid").view(np.int64).tobytes():
            return False
    return True


def _junction_accels(st, g, vk, acc, rules, profile, vmax):
    """curves.junction_accels; under classic jerk its per-vertex loop raises nothing (the
    jerk law does not scale with the acceleration), so only the finite-lookahead floor is
    applied, over arrays (tests/test_chain_strokes.py compares the two): acc and vmax may
    then be (k, n), k candidates of the chain at once."""
    if rules.junction != "jerk":
        return curves.junction_accels(st, g, vk, acc, rules, profile, vmax=vmax)
    acc = np.array(acc, float)
    if profile.block_buffer > 0:
        d, n = g.d, g.d.size
        a_top = min(st.accel, st.lim.ax_max, st.lim.ay_max)
        nb = max(profile.block_buffer - 3, 1)
        ext = np.concatenate([d, np.full(nb, d[-1])])
        window = np.convolve(ext, np.ones(nb), "valid")[:n]
        acc = np.maximum(acc, np.minimum(1.1 * vmax ** 2 / (2.0 * window), a_top))
    return acc


def _junction_v(profile, lim, pu, u, dp, dn, ap, an, fp, fn):
    """The firmware's junction speed limit between two moves with their own accelerations
    ap, an and feeds fp, fn (the laws of firmware/junction.py, as the firmware model)."""
    j = profile.junction
    if j == "scv":
        a0p, a_p = curves.accel_in_force(profile, lim, ap, pu)
        a0n, a_n = curves.accel_in_force(profile, lim, an, u)
        v2 = klipper_corner_v2(pu[0], pu[1], 0.0, lim.scv * lim.scv * SQRT2_M1 / a0p, a_p, 2.0 * dp * a_p,
                               u[0], u[1], 0.0, lim.scv * lim.scv * SQRT2_M1 / a0n, a_n, 2.0 * dn * a_n)
    elif j == "jd":
        _, a_n = curves.accel_in_force(profile, lim, an, u)
        v2 = marlin_jd_v2(pu[0], pu[1], 0.0, u[0], u[1], 0.0, dn, a_n, lim.jd, lim.ax_max, lim.ay_max, 1e9)
    else:
        jz = 1.0                           # z is 0 along a chain: any positive value
        sp = marlin_safe_speed(pu[0], pu[1], 0.0, fp, lim.jerk_x, lim.jerk_y, jz)
        sn = marlin_safe_speed(u[0], u[1], 0.0, fn, lim.jerk_x, lim.jerk_y, jz)
        v = marlin_jerk_junction_v(pu[0], pu[1], 0.0, fp, sp, u[0], u[1], 0.0, fn, sn,
                                   lim.jerk_x, lim.jerk_y, jz)
        return v
    return math.sqrt(v2) if math.isfinite(v2) else math.inf


def _safe_speed(ux, uy, nominal, jx, jy):
    """marlin_safe_speed over arrays (z = 0: its axis never limits); the jerks one value
    or one per row (broadcast)."""
    cx = np.abs(ux) * nominal
    lx = cx > jx
    safe = np.where(lx, jx, nominal)
    cy = np.abs(uy) * nominal
    ly = cy > jy
    with np.errstate(divide="ignore", invalid="ignore"):
        both = np.where(cy * safe > jy * nominal, jy * nominal / cy, safe)
    return np.where(ly, np.where(lx, both, jy), safe)


def _axis_jerk(v_exit, v_entry):
    up = np.where((v_entry > 0.0) | (v_exit < 0.0), v_exit - v_entry, np.maximum(v_exit, -v_entry))
    dn = np.where((v_entry < 0.0) | (v_exit > 0.0), v_entry - v_exit, np.maximum(-v_exit, v_entry))
    return np.where(v_exit > v_entry, up, dn)


def _jerk_junction_v(pu, u, p_nom, nom, jx, jy, p_safe=None, safe=None):
    """marlin_jerk_junction_v over arrays of junctions (z = 0), each axis's arithmetic in
    its order (tests/test_chain_strokes.py compares it with the scalar law); the moves'
    safe speeds (_safe_speed) may be given."""
    if p_safe is None:
        p_safe, safe = _safe_speed(pu[:, 0], pu[:, 1], p_nom, jx, jy), _safe_speed(u[:, 0], u[:, 1], nom, jx, jy)
    vmax = np.minimum(nom, p_nom)
    smaller = vmax / p_nom
    with np.errstate(divide="ignore", invalid="ignore"):
        jerk = _axis_jerk(pu[:, 0] * p_nom * smaller, u[:, 0] * nom)
        limited = jerk > jx
        vf = np.where(limited, jx / jerk, 1.0)
        v_exit, v_entry = pu[:, 1] * p_nom * smaller, u[:, 1] * nom
        v_exit, v_entry = np.where(limited, v_exit * vf, v_exit), np.where(limited, v_entry * vf, v_entry)
        jerk = _axis_jerk(v_exit, v_entry)
        ly = jerk > jy
        vf = np.where(ly, vf * (jy / jerk), vf)
    limited |= ly
    vmax = np.where(limited, vmax * vf, vmax)
    thr = vmax * 0.99
    return np.where((p_safe > thr) & (safe > thr), safe, vmax)


def _scv_junction_v(profile, u, d, acc, scv, ax_max, ay_max):
    """Klipper's junction speed (klipper_corner_v2 at the moves' accelerations in force,
    as _junction_v) at the interior vertices of moves along u (..., n, 2) of lengths d and
    accelerations acc (..., n): one chain's k candidates (u (n, 2), acc (k, n), scalar
    limits) or stacked rows of chains (u (R, n, 2), limits (R, 1)).  Elementwise: the
    same bits either way."""
    a0 = np.where(acc > 0, acc, profile.default_accel_a)     # curves.accel_in_force
    ux, uy = np.abs(u[..., 0]), np.abs(u[..., 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where((ux > 0) & (a0 * ux > ax_max), ax_max / ux, a0)
        a = np.where((uy > 0) & (a * uy > ay_max), ay_max / uy, a)
    jd = scv * scv * SQRT2_M1 / a0
    dv2 = 2.0 * d * a
    pu, un = u[..., :-1, :], u[..., 1:, :]
    cos_t = -(un[..., 0] * pu[..., 0] + un[..., 1] * pu[..., 1] + 0.0)
    s2, c2 = 0.5 * (1.0 - cos_t), 0.5 * (1.0 + cos_t)
    sin_d2 = np.sqrt(np.maximum(s2, 0.0))
    cos_d2 = np.sqrt(np.maximum(c2, 0.0))
    one_m = 1.0 - sin_d2
    ok = (one_m > 0.0) & (cos_d2 > 0.0)
    r_jd = sin_d2 / np.where(ok, one_m, 1.0)
    qt = 0.25 * sin_d2 / np.where(ok, cos_d2, 1.0)
    v2 = np.minimum(r_jd * jd[..., 1:] * a[..., 1:], r_jd * jd[..., :-1] * a[..., :-1])
    v2 = np.minimum(np.minimum(v2, dv2[..., 1:] * qt), dv2[..., :-1] * qt)
    return np.where(ok, np.sqrt(np.maximum(v2, 0.0)), np.inf)


def _lookahead_v2(v2, reach):
    """The firmware's lookahead on squared junction speeds v2 (..., n + 1) over moves that
    gain reach = 2 a d each (..., n), along the last axis: forward, what the ramps reach;
    backward, what they can brake from (the min-plus scans
    v2[k] = min(v2[k], v2[k-1] + reach[k-1]) as prefix minima)."""
    z = np.zeros(reach.shape[:-1] + (1,))
    c = np.concatenate([z, np.cumsum(reach, axis=-1)], axis=-1)
    v2 = np.minimum(v2, np.minimum.accumulate(v2 - c, axis=-1) + c)
    r = np.concatenate([z, np.cumsum(reach[..., ::-1], axis=-1)], axis=-1)[..., ::-1]   # reach to the end
    return np.minimum(v2, (np.minimum.accumulate((v2 - r)[..., ::-1], axis=-1) + r[..., ::-1])[..., ::-1])


def _predict_group(sts, gs, own, d, acc, feed, profile):
    """predict_chains for stacked rows of chains with the same number of segments (own:
    the chain of each row; d (R, n) their lengths); the same arithmetic row by row."""
    R, n = acc.shape
    u = np.stack([g.u for g in gs])[own]
    v = np.empty((R, n + 1))
    v[:, 0] = np.array([st.v0 for st in sts], float)[own]
    v[:, -1] = np.array([st.v1 for st in sts], float)[own]
    lim = lambda f: np.array([getattr(st.lim, f) for st in sts], float)[own][:, None]   # noqa: E731
    if profile.junction == "jerk":
        jx, jy = lim("jerk_x"), lim("jerk_y")
        fp, fn = feed[:, :-1].ravel(), feed[:, 1:].ravel()
        safe = _safe_speed(u[:, :, 0], u[:, :, 1], feed, jx, jy)   # once per move
        jxv, jyv = np.repeat(jx[:, 0], n - 1), np.repeat(jy[:, 0], n - 1)
        vj = _jerk_junction_v(u[:, :-1].reshape(-1, 2), u[:, 1:].reshape(-1, 2), fp, fn,
                              jxv, jyv, safe[:, :-1].ravel(), safe[:, 1:].ravel())
        v[:, 1:-1] = np.minimum(vj, np.minimum(fp, fn)).reshape(R, n - 1)
    elif profile.junction == "jd":
        vv = _jd_vertex_v(profile, u, d, acc, feed, lim("jd"), lim("ax_max"), lim("ay_max"))
        if vv is None:          # (a junction math.sqrt or the law would raise on: chain by chain)
            vv = np.empty((R, n - 1))
            for r in range(R):
                st, g = sts[own[r]], gs[own[r]]
                vv[r] = _vertex_v_loop(profile, st.lim, g.u, g.d, acc[r:r + 1], feed[r:r + 1])[0]
        v[:, 1:-1] = vv
    else:
        vj = _scv_junction_v(profile, u, d, acc, lim("scv"), lim("ax_max"), lim("ay_max"))
        v[:, 1:-1] = np.minimum(vj, np.minimum(feed[:, :-1], feed[:, 1:]))
    va, vb, t, a2 = _trapezoid_rows(v, acc, d, feed, np.stack([g.cos_turn for g in gs])[own])
    for end, (vv, tt) in enumerate(((va[:, 0], t[:, 0]), (vb[:, -1], t[:, -1]))):
        c = np.full(len(sts), np.nan)          # per chain, as predict_chains: None (nan) or the cosine
        for q, (st, g) in enumerate(zip(sts, gs)):
            w = st.prev_u if end == 0 else st.next_u
            if w is not None:
                c[q] = curves.dot2(w, g.u[0]) if end == 0 else curves.dot2(g.u[-1], w)
        c = c[own]
        on = c >= CORNER_COS                     # nan compares False
        a2 = np.where(on, a2 + 0.5 * 2.0 * vv * vv * (1.0 - c) / np.maximum(tt, 1e-12), a2)
    return np.sum(t, axis=1), a2


def _trapezoid_rows(v, acc, d, feed, cos_turn):
    """The firmware's trapezoids over rows of a chain's segments, from the junction speed
    caps v (k, n+1): lookahead, then per segment entry/exit speed, duration and the ∫|a|²dt
    of its ramps plus the normal term at each interior vertex turning enough to count
    (cos_turn (n-1,) or (k, n-1)).  Returns (va, vb, t, a2), a2 per row."""
    reach = 2.0 * acc * d
    v2 = _lookahead_v2(v * v, reach)
    va2, vb2 = v2[:, :-1], v2[:, 1:]
    peak2 = np.minimum(feed * feed, 0.5 * (reach + va2 + vb2))
    peak2 = np.maximum(peak2, np.maximum(va2, vb2))
    pk, va, vb = np.sqrt(peak2), np.sqrt(va2), np.sqrt(vb2)
    a = np.maximum(acc, 1e-12)
    up_d = (peak2 - va2) / (2.0 * a)
    dn_d = (peak2 - vb2) / (2.0 * a)
    cruise_d = np.maximum(d - up_d - dn_d, 0.0)
    t = (pk - va) / a + (pk - vb) / a + cruise_d / np.maximum(pk, 1e-9)
    a2 = np.sum(a * ((pk - va) + (pk - vb)), axis=1)
    vi = va[:, 1:]
    tj = 0.5 * (t[:, :-1] + t[:, 1:])
    dv2 = 2.0 * vi * vi * (1.0 - cos_turn)
    a2 = a2 + np.sum(np.where(cos_turn >= CORNER_COS, dv2 / np.maximum(tj, 1e-12), 0.0), axis=1)
    return va, vb, t, a2


def predict_chain(st, g, acc, feed, profile):
    """(time, ∫|a|²dt) of the firmware playing the chain's segments: junction speeds from
    its junction law, the feeds and its lookahead; trapezoids; normal vertex terms."""
    t, a2 = predict_chains(st, g, np.atleast_2d(acc), np.atleast_2d(feed), profile)
    return float(t[0]), float(a2[0])


def predict_chains(st, g, acc, feed, profile):
    """predict_chain for rows of (k, n) accelerations and feeds of the same chain."""
    d = g.d
    k, n = acc.shape
    lim = st.lim
    v = np.empty((k, n + 1))
    v[:, 0] = st.v0
    v[:, -1] = st.v1
    if profile.junction == "jerk":
        fp, fn = feed[:, :-1].ravel(), feed[:, 1:].ravel()
        safe = _safe_speed(g.u[:, 0], g.u[:, 1], feed, lim.jerk_x, lim.jerk_y)   # once per move
        vj = _jerk_junction_v(np.tile(g.u[:-1], (k, 1)), np.tile(g.u[1:], (k, 1)), fp, fn,
                              lim.jerk_x, lim.jerk_y, safe[:, :-1].ravel(), safe[:, 1:].ravel())
        v[:, 1:-1] = np.minimum(vj, np.minimum(fp, fn)).reshape(k, n - 1)
    elif profile.junction == "scv":
        vj = _scv_junction_v(profile, g.u, d, acc, lim.scv, lim.ax_max, lim.ay_max)
        v[:, 1:-1] = np.minimum(vj, np.minimum(feed[:, :-1], feed[:, 1:]))
    else:
        v[:, 1:-1] = _vertex_v_rows(profile, lim, g.u, d, acc, feed)
    va, vb, t, a2 = _trapezoid_rows(v, acc, d, feed, g.cos_turn)
    c0 = None if st.prev_u is None else curves.dot2(st.prev_u, g.u[0])
    c1 = None if st.next_u is None else curves.dot2(g.u[-1], st.next_u)
    for c, vv, tt in ((c0, va[:, 0], t[:, 0]), (c1, vb[:, -1], t[:, -1])):
        if c is not None and c >= CORNER_COS:
            a2 = a2 + 0.5 * 2.0 * vv * vv * (1.0 - c) / np.maximum(tt, 1e-12)
    return np.sum(t, axis=1), a2


def _vertex_v_rows(profile, lim, U, d, acc, feed):
    """The speed at each interior vertex of k rows of a chain's segments ((k, n)
    accelerations and feeds, directions U (n, 2)): _junction_v's law, then min with the two
    feeds; Marlin's junction deviation on arrays (_jd_vertex_v), another law or a junction
    the per-junction form would raise on vertex by vertex (_vertex_v_loop)."""
    got = None
    if profile.junction == "jd":
        got = _jd_vertex_v(profile, U, d, acc, feed, lim.jd, lim.ax_max, lim.ay_max)
    return _vertex_v_loop(profile, lim, U, d, acc, feed) if got is None else got


def _jd_vertex_v(profile, U, d, acc, feed, jd, ax_max, ay_max):
    """_vertex_v_loop's numbers under junction deviation on arrays: U (..., n, 2), d, acc
    and feed (..., n), jd and the caps one value or one a row ((R, 1)).  marlin_jd_v2_rows
    at the next move's acceleration in force (curves.accel_in_force_rows), sqrt where
    finite, then Python's min(v, fp, fn) as np.where on its comparisons: the same floats.
    None where the per-junction form would raise (math.sqrt of a negative, theta 0)."""
    ux, uy = U[..., 1:, 0], U[..., 1:, 1]
    a_n = curves.accel_in_force_rows(profile.default_accel_a, acc[..., 1:], ux, uy, ax_max, ay_max)
    v2, odd = marlin_jd_v2_rows(U[..., :-1, 0], U[..., :-1, 1], ux, uy, d[..., 1:], a_n, jd, ax_max, ay_max)
    if odd.any() or (v2 < 0.0).any():
        return None
    with np.errstate(invalid="ignore"):
        vj = np.where(np.isfinite(v2), np.sqrt(v2), math.inf)
    fp, fn = feed[..., :-1], feed[..., 1:]
    vj = np.where(fp < vj, fp, vj)
    return np.where(fn < vj, fn, vj)


def _vertex_v_loop(profile, lim, U, d, acc, feed):
    """_vertex_v_rows vertex by vertex (_junction_v)."""
    k, n = acc.shape
    v = np.empty((k, n - 1))
    u = [tuple(x) for x in U]
    for r in range(k):
        for j in range(1, n):
            vj = _junction_v(profile, lim, u[j - 1], u[j], d[j - 1], d[j],
                             acc[r, j - 1], acc[r, j], feed[r, j - 1], feed[r, j])
            v[r, j - 1] = min(vj, feed[r, j - 1], feed[r, j])
    return v


def law_T(st, T):
    """The law's duration behind a candidate's predicted duration T (the candidate tables
    hold what the firmware takes; plan.T is one of them)."""
    return float(T) if st.chain_T is None else st.chain_T.law_of(float(T))


def plan_chain_segments(strokes, T, beta, rules, profile, remember=True, keep_laws=True, blocks=None):
    """SegmentPlan per chain stroke (knots = the original vertices).  Each chain keeps its
    candidates' plans (st.chain_T.plan_of(T, beta), _KeptPlans): the chosen one is emitted
    without solving or finishing its law again; and its last plan (st.chain_T.seg): a re-plan of the
    budget that leaves its (T, beta) alone reuses it.  Once a chain's plan is made, the knots
    of its candidate rows and its vertex caps are dropped (_drop: ~12 MB on the gyroid plate);
    a re-plan that picks another of its candidates solves it again (_again_plans, the same
    bits: tests/test_speed22_chainmem_drop.py).  remember False: no chain keeps its plan
    (a windowed run lets its chains' plans go once judged, schedule._window_figures: a
    memo holding each one's last plan held them all); a later ask of its (T, beta) makes
    it again from its rows (_again_plans; tests/test_speed54_chainplans_lazy.py), or from
    the law it chose (_Chosen, kept for that ask) unless keep_laws is False (the plans are
    kept elsewhere: schedule._ChainSpill).  blocks: a list the replayed chains' RowPlans
    made of blocks are appended to, a batch each: (their places in the answer (int64), V,
    A, F: the blocks, their knots' ends), as the plans hold them (the chain spill writes
    them by block, not grouping the plans again); or None."""
    T_in = np.asarray(T, float)
    beta = np.asarray(beta, float)
    out = [None] * len(strokes)
    key = _rules_key(rules, profile)
    # per chain as arrays of doubles (the arrays' own doubles, 8 bytes each: lists of
    # floats held ~1 MB more at the plan's peak), read by the loops below as Python floats
    # without a numpy scalar per read: ~16 k chains on the gyroid plate
    t_in, b_in = array("d", T_in.tobytes()), array("d", beta.tobytes())
    T = array("d", t_in)                # the law durations (law_T)
    # each chain's law duration, and its last plan where that was made for this (T, beta)
    # (asked for what its last plan was made for, its rows as they were: law_T(t) is the
    # law duration that plan was made for; law_of reads only the rows); else the
    # candidate table's plan when this (T, beta) is one of the candidates (under the same
    # rules), else the law solved and finished (ChainMemo.ask: ask_all, by numpy on the shared rows)
    segs, kept_l, rows_l = ask_all(list(map(_CHAIN_T, strokes)), t_in, b_in, key, T)
    core = _chain_law.CORE_MOD
    if type(strokes) is not list:
        strokes = list(strokes)
    # (~16 k chains on the gyroid plate: with the chain core in one C pass; with drop_items, -37 M
    # instructions on that plate)
    todo, items, lazy, again, cold = (_sort_asks if core is None else core.sort_asks)(
        strokes, segs, kept_l, rows_l, key, _Again, _KeptLaws, out)
    segs = kept_l = rows_l = None     # (no kept plans held here: _replay drops them as it goes)
    if len(lazy) >= TRIM_DROPPED:
        # the heap's free pages given back before the plans are made: the budget's and the
        # curves' planning freed ~20 MB in the middle of it since the candidate table, and
        # the plans would grow the peak on top of them (gyroid plate: peak RSS -1..3 MB)
        from .pipeline import trim_heap
        trim_heap()
    # (the rows' kept objects handed over in items, not held here: _replay drops them as it goes)
    # remember False: each chain keeps the law it chose, replayed if asked again (_Chosen)
    keep_laws = keep_laws and not remember
    chosen = _keep_chosen(items) if keep_laws else None
    got = None if blocks is None else []
    for k, plan in zip(lazy, _replay(items, rules, profile, drop=True, blocks=got)):
        out[k] = plan
    del items
    if got:
        at = np.array(lazy, np.int64)
        blocks += [(at[Q], V, A, F, ends) for Q, V, A, F, ends in got]
    del got
    if chosen:
        _hand_chosen(chosen)
    del chosen
    if again:
        hits, ks, again = _chosen_asks(again, strokes, T, b_in)
        if hits:
            for k, plan in zip(ks, _replay(hits, rules, profile, laws_of=_chosen_laws_of)):
                out[k] = plan
        del hits
    if again:
        laws = [] if keep_laws else None
        plans = _again_plans([(strokes[k], ag, T[k], b_in[k]) for k, ag in again], rules, profile, laws)
        for (k, _), plan in zip(again, plans):
            out[k] = plan
        if laws:
            _chosen_solved(again, strokes, laws)
        del laws
    if cold:
        Ta = np.array(T, float)
        for k, law in zip(cold, solve([strokes[k] for k in cold], Ta[cold], beta[cold], profile)):
            out[k] = finish_chain(strokes[k], law, rules, profile)[0]
    dropped = set(lazy)                 # (_replay dropped theirs)
    if remember:
        (_remember_plans if core is None else core.remember_plans)(strokes, todo, out, T, b_in, t_in, key, dropped,
                                                                   _drop)
    else:
        for k in todo:
            if k not in dropped:
                _drop(strokes[k])
    if len(lazy) >= TRIM_DROPPED:   # their arrays were freed in the middle of the C heap: give them back
        from .pipeline import trim_heap
        trim_heap()
    return out


def _sort_asks(strokes, segs, kept_l, rows_l, key, again_type, laws_type, out):
    """plan_chain_segments' chains by ask_all's answers (segs, kept_l, rows_l): a chain's last
    plan into out; else it is to do (todo), and where it has a candidate row of the rules
    key: a dropped row (again_type) -> again [(k, kept)], a kept law (laws_type) -> items
    [(stroke, kept, row)] and lazy [k], another kept plan -> out[k] = kept.plan(row); no row ->
    cold.  (todo, items, lazy, again, cold); the chain core's sort_asks."""
    todo, items, lazy, again, cold = [], [], [], [], []
    for k, (seg, kept, r) in enumerate(zip(segs, kept_l, rows_l)):
        if seg is not None:
            out[k] = seg
            continue
        todo.append(k)
        if r is not None and kept.key == key:
            if isinstance(kept, again_type):
                again.append((k, kept))
            elif isinstance(kept, laws_type):
                items.append((strokes[k], kept, r))
                lazy.append(k)
            else:
                out[k] = kept.plan(r)
        else:
            cold.append(k)
    return todo, items, lazy, again, cold


def _remember_plans(strokes, todo, out, T, b_in, t_in, key, dropped, drop):
    """Each chain k of todo remembers its plan out[k] (its memo's seg) and what it was made
    for (law duration T[k], beta b_in[k], rules key, asked for t_in[k]), then drop(strokes[k])
    where k is not in dropped (_replay dropped those); the chain core's remember_plans."""
    for k in todo:
        st = strokes[k]
        memo = st.chain_T
        plan = out[k]
        memo.seg_T, memo.seg_beta, memo.seg_key, memo.seg = T[k], b_in[k], key, plan
        # (its plan's own time_t when equal, the usual case: no float kept per chain)
        tt, t = getattr(plan, "time_t", None), t_in[k]
        memo.seg_tin = tt if tt == t else t
        if k not in dropped:
            drop(st)            # its plan is made: the other candidates' knots are made again if asked


# ------------------------------------------------------------------ candidates
def _figures(strokes, rows, pin, T, beta, profile, rules):
    """Per (stroke, T) of the (n, k) tables T, beta (columns in increasing T): feasible?,
    predicted time and ∫|a|², the law's ∫ṡ².  Each stroke remembers which law T gave which
    predicted time (law_T) and the plans of its candidates (ChainMemo).  Column by column,
    each law warm-started from its neighbour's (the one nearest 1 x T_orig first, cold):
    the binding set moves little between close durations.  The laws stay flat arrays
    (laws/chain.FlatLaws), SOLVE_CHUNK chains at a time; their rows are finished by
    groups of the same number of segments gathered over the chunks (_Finisher).

    The chains are taken in the order of their number of segments (stable): the rows of
    one segment count then come from one or two chunks, and a count's last batch is
    finished as soon as the chunks have passed it (flush_below), not held (its knots)
    until the end beside every other count's (~7 MB on the gyroid plate).  Each chain's
    law is its own whatever chains are solved with it (solve_flat: the same bits, as
    _knots_again relies on), and each row's finishing its own."""
    n, k = T.shape
    if n == 0:
        return _figures_sorted(strokes, rows, pin, T, beta, profile, rules)
    # (each one's segment count as its geometry block's row length: no d view a chain)
    gs = _geoms(list(map(strokes.__getitem__, rows.tolist())), profile)
    nseg = np.array(curves.seg_counts(gs), np.int64)
    perm = np.argsort(nseg, kind="stable")
    if np.all(perm[1:] > perm[:-1]):
        return _figures_sorted(strokes, rows, pin, T, beta, profile, rules, nseg, gs)
    # (np.take's row gathers: numpy's fancy index copies a row at a time through its
    # general loop, several times slower for these short rows; the same values)
    Tp = T.take(perm, axis=0)
    bp = _BetaOfT(Tp) if type(beta) is _BetaOfT and beta.T is T else beta.take(perm, axis=0)
    got = _figures_sorted(strokes, rows[perm], pin, Tp, bp, profile, rules, nseg[perm],
                          [gs[i] for i in perm.tolist()])
    back = np.empty_like(perm)        # back in the rows' order: b[perm] = a, as b = a[back]
    back[perm] = np.arange(perm.size)
    return tuple(a.take(back, axis=0) for a in got)


def _figures_sorted(strokes, rows, pin, T, beta, profile, rules, nseg=None, gs=None):
    """_figures of chains in nondecreasing number of segments nseg (None: no early flush);
    gs: the rows' geometries (None: each chunk's made by _flat_chains)."""
    n, k = T.shape
    tab = _Table(n, k, T)
    mid = int(np.argmin(np.abs(T[0] / pin.T_orig[rows[0]] - 1.0))) if n else 0
    order = [mid] + list(range(mid + 1, k)) + list(range(mid - 1, -1, -1))
    prev = {c: (c - 1 if c > mid else c + 1) for c in order[1:]}
    fin = _Finisher(tab, rules, profile)
    fin.src = _Source(T, beta, order, prev, fin.key)
    fin.beta_fn = _chain_beta if type(beta) is _BetaOfT else None
    fin.T_outer = T if type(T) is _OuterT else None
    for sl in _chunks(nseg, n):      # the laws of one chunk of chains at a time
        a = sl.start
        sts = list(map(strokes.__getitem__, rows[sl].tolist()))
        base = _flat_chains(sts, profile, None if gs is None else gs[sl])
        Ts, bs = T[sl], beta[sl]
        res = _solve_cols(base, Ts, bs, order, prev)
        v_cap, t_min = pin.v_cap[rows[sl]], pin.t_seg_min[rows[sl]]
        use = np.stack([res[c].conv & (res[c].min_v >= -1e-9 * (1 + v_cap))
                        & (res[c].peak_v <= v_cap * (1 + SPEED_TOL_R)) & (Ts[:, c] >= t_min)
                        for c in range(k)], axis=1)
        laws = _LawCols(res, k, base.voff)
        for item in _table_rows(sts, base, res, use, Ts, profile, fin.grouped, laws):
            J, rj, rc, _, dt = item[:5]
            at = getattr(item, "at", None)
            j = getattr(item, "j", None)
            j = J[rj] if j is None else j
            bnd, spans = getattr(item, "bnd", None), getattr(item, "spans", None)
            kept = (bnd, laws.PT, spans) if bnd is not None and spans is not None else \
                laws.rows(j, rc, dt.shape[1], at, spans)
            fin.add(_Rows(a, sts, Ts, bs, *item, *kept, j=j))
        del res, laws, Ts, bs
        if nseg is not None:            # the counts no later chunk has: their last batches
            fin.flush_below(int(nseg[sl.stop - 1]))
            fin.detach()
    fin.flush()
    return tab.ok, tab.tp, tab.ia, tab.iv


def _solve_cols(base, T, beta, order, prev, spread=True):
    """The flat laws res[c] (solve_flat, FlatLaws or _Spread) of the chains base (a _Flat) at
    each column c of the (m, k) tables T, beta, in the columns' order: the first cold, each
    other warm-started from its neighbour prev[c].  Chains whose every solve input is the
    same bit for bit as an earlier chain's (_same_chains: ~27 % of the gyroid plate's) are
    not solved (spread: look for them): they get their first's laws (_Spread), the numbers
    its solve gave (solve_flat's numbers are each chain's own, whatever chains are solved
    with it)."""
    same = _same_chains(base, T, beta) if spread else None
    if same is not None:
        keep, pos = same
        got = _solve_cols(base.take(keep), T[keep], beta[keep], order, prev, False)
        vg = _spread_vertices(next(iter(got.values())), base, pos) if got else None
        return {c: _Spread(r, base, pos, vg) for c, r in got.items()}
    m, nv = base.S.size, base.sv.size
    res = {}
    for c in order:
        fl = base.with_T(T[:, c], beta[:, c])
        if c in prev:
            src = res[prev[c]]
            vt = src.vert_t * (T[:, c] / T[:, prev[c]])[fl.ch]
            res[c] = solve_flat(fl, src.bound.copy(), vt, np.ones(m, bool), pieces=False)
        else:
            res[c] = solve_flat(fl, cold_binding(fl), np.zeros(nv), np.zeros(m, bool), pieces=False)
    return res


def _bits(a):
    """The float64 array a's bits as int64 (equal bits: equal solve inputs; -0.0 and 0.0,
    nans of other payloads, differ)."""
    return np.ascontiguousarray(a, np.float64).view(np.int64)


def _same_rows(K):
    """Each row's first equal row of the int64 table K (R, c), bit for bit: rows grouped by
    a hash (a wrapping dot with fixed odd weights), then each compared with its group's
    first (a row that differs is its own).  None where every row is its own."""
    R, c = K.shape
    if R < 2:
        return None
    w = np.arange(1, c + 1, dtype=np.int64) * np.int64(-7046029254386353131) | np.int64(1)
    first, inv = unique_first_inverse(K @ w)
    if first.size == R:
        return None
    rep = first[inv]
    dup = np.flatnonzero(rep != np.arange(R))
    dup = dup[np.all(K[dup] == K[rep[dup]], axis=1)]
    if dup.size == 0:
        return None
    out = np.arange(R)
    out[dup] = rep[dup]
    return out


def _kept(rep):
    """(keep, pos) of the rows' firsts rep (_same_rows): the rows that are their own first
    (ascending), and each row's first's place in keep; None where every row is its own."""
    if rep is None:
        return None
    keep = np.flatnonzero(rep == np.arange(rep.size))
    if keep.size == rep.size:
        return None
    return keep, np.searchsorted(keep, rep)


def _same_chains(base, T, beta):
    """(keep, pos) where some chains of base (a _Flat; durations T and weights beta (m, k))
    have every solve input of an earlier one bit for bit (vertex positions and caps, length,
    end speeds, T and beta of each column): keep the chains to solve (ascending), pos[j]
    chain j's place in keep (its own or its first equal's).  None where every chain is its
    own.  Chains are first grouped by their scalars (_same_rows), then each one's vertices
    compared with its group's first; one that differs there is solved itself."""
    m = base.S.size
    K = np.concatenate([base.nv.astype(np.int64)[:, None], _bits(base.S)[:, None], _bits(base.v0)[:, None],
                        _bits(base.v1)[:, None], _bits(T).reshape(m, -1), _bits(beta).reshape(m, -1)], axis=1)
    rep = _same_rows(K)
    if rep is None:
        return None
    dup = np.flatnonzero(rep != np.arange(m))
    nv, voff = base.nv.astype(np.int64), base.voff.astype(np.int64)
    cnt = nv[dup]
    at = np.repeat(cnt - np.cumsum(cnt), cnt) + np.arange(int(cnt.sum()))    # place in its chain
    mine = np.repeat(voff[dup], cnt) + at
    theirs = np.repeat(voff[rep[dup]], cnt) + at
    sv, cv = _bits(base.sv), _bits(base.cv)
    differ = (sv[mine] != sv[theirs]) | (cv[mine] != cv[theirs])
    bad = np.bincount(np.repeat(np.arange(dup.size), cnt)[differ], None, dup.size) > 0
    rep[dup[bad]] = dup[bad]
    return _kept(rep)


def _spread_vertices(r, base, pos):
    """Each vertex of the chains of base its place among r's (the flat laws of base.take(keep)),
    chain j's those of r's chain pos[j] (one for every column solved for the same chains)."""
    rv = r.fl.voff.astype(np.int64)
    return np.repeat(rv[pos] - base.voff[:-1], base.nv) + np.arange(base.sv.size)


class _Spread:
    """The flat laws r (solved for base.take(keep)) of every chain of base, chain j's those
    of r's chain pos[j]: what _figures reads of a FlatLaws (per chain conv, iv, peak_v,
    min_v, each a copy of r's numbers; per vertex bound, vert_v, vert_t: r's at vg, the
    vertices' places there, _spread_vertices, gathered when read: _vertex_stack reads r's
    own); the pieces' durations piece_T are r's own, not copied (chain j's piece_n[j] of
    them from piece_at[j]: a chain and its first equal share theirs, _piece_spans)."""

    def __init__(self, r, base, pos, vg):
        for f in ("conv", "iv", "peak_v", "min_v"):
            setattr(self, f, getattr(r, f).take(pos))     # (take: numpy's plain gather loop, fewer steps than [pos])
        self.r, self.vg = r, vg
        po = r.piece_off
        self.piece_T, self.piece_at = r.piece_T, po.take(pos)
        self.piece_n = po.take(pos + 1) - self.piece_at

    bound = property(lambda self: self.r.bound[self.vg])
    vert_v = property(lambda self: self.r.vert_v[self.vg])
    vert_t = property(lambda self: self.r.vert_t[self.vg])


def _piece_spans(col):
    """(piece_T, each chain's first piece there, its number of pieces) of one column's flat
    laws col (a FlatLaws: its chains' pieces end to end; a _Spread: its chains' firsts')."""
    if isinstance(col, _Spread):
        return col.piece_T, col.piece_at, col.piece_n
    po = col.piece_off
    return col.piece_T, po[:-1], po[1:] - po[:-1]


def _chunks(nseg, n):
    """_figures' chunks of its n chains: SOLVE_CHUNK chains, or with their numbers of
    segments nseg (nondecreasing) at most SOLVE_SEGS segments (the chains in the order
    of their length: the long ones would be a chunk of ~10 x the usual vertices), at least
    one chain a chunk."""
    if nseg is None:
        return [slice(a, min(a + SOLVE_CHUNK, n)) for a in range(0, n, SOLVE_CHUNK)]
    out = []
    cum = np.cumsum(nseg)
    a = 0
    while a < n:
        base = cum[a - 1] if a else 0
        b = int(np.searchsorted(cum, base + SOLVE_SEGS, side="right"))
        b = min(max(b, a + 1), a + SOLVE_CHUNK, n)
        out.append(slice(a, b))
        a = b
    return out


class _Table:
    """The candidate table _figures fills: feasible?, predicted time and ∫|a|², ∫ṡ²."""

    def __init__(self, n, k, T):
        self.ok = np.zeros((n, k), bool)
        self.tp = np.array(T, float, order="C")     # (C order: put's flat places)
        self.ia = np.full((n, k), np.inf)
        self.iv = np.full((n, k), np.nan)

    def put(self, rows, cols, tp, ia, iv):
        """The feasible cells (rows[q], cols[q]) with their figures: each table's flat
        places rows * k + cols, made once (a 2-D fancy index makes them for each table)."""
        at = rows * self.ok.shape[1] + cols
        self.ok.ravel()[at] = True
        self.tp.ravel()[at] = tp
        self.ia.ravel()[at] = ia
        self.iv.ravel()[at] = iv


class _Rows:
    """Candidate rows of chains with the same number of segments n from one chunk (chains
    sts[J], its first row a in the table): row i is chain J[rj[i]]'s column rc[i], its
    knot speeds vk[i] and segment durations dt[i], its law's ∫ṡ² iv[i]; ks rows a chain;
    its law as _KeptLaws keeps it: binding mask bnd[i], pieces' durations tj[a:a + c],
    (a, c) = spans[i]; j: J[rj] (None: made here)."""
    __slots__ = ("a", "sts", "T", "beta", "J", "rj", "rc", "vk", "dt", "ks", "iv", "bnd", "tj", "spans", "n", "j")

    def __init__(self, a, sts, T, beta, J, rj, rc, vk, dt, ks, iv, bnd, tj, spans, j=None):
        self.a, self.sts, self.T, self.beta = a, sts, T, beta
        self.J, self.rj, self.rc, self.vk, self.dt, self.ks, self.iv = J, rj, rc, vk, dt, ks, iv
        self.j = J[rj] if j is None else j
        self.bnd, self.tj, self.spans = bnd, tj, spans
        self.n = dt.shape[1]


FINISH_CELLS = 1 << 20       # a finishing batch's rows x n x (n + 2) (tent_feeds_rows' envelopes): 8 MB


def _batch_rows(n):
    """The rows of a finishing batch of chains of n segments: FINISH_ROWS, fewer where the
    classic-jerk feed envelopes (rows, n, n + 2) would outgrow the caches."""
    return max(1, min(FINISH_ROWS, FINISH_CELLS // (n * (n + 2))))


def _batch_cells(rs):
    """The segments of a finishing batch rs (rows of one segment count)."""
    return sum(r.rj.size for r in rs) * rs[0].n


class _Finisher:
    """Finishes candidate rows (_Rows) into the table and the chains' memos.  Under the
    junction laws of GROUP_JUNCTIONS rows of the same segment count wait until a batch of
    FINISH_ROWS rows is full, over the chunks of chains (the finishing's numpy calls are
    paid per batch: ~10^2 rows instead of ~10^1); each row's numbers are its own (row by
    row arithmetic: tests/test_speed_plan_groups.py), so the batch does not change them.
    Else chain by chain, at once."""

    def __init__(self, tab, rules, profile):
        self.tab, self.rules, self.profile = tab, rules, profile
        self.key = _rules_key(rules, profile)
        self.grouped = rules.junction in GROUP_JUNCTIONS and profile.junction == rules.junction
        self.wait = {}                 # n -> [_Rows], their row count
        self.src = None                # the _Source of the rows (the chains' memos: drop_rows)
        self.beta_fn = None            # _chain_beta where the rows' beta is their T's (_BetaOfT)
        self.T_outer = None            # the whole table of T where it is an _OuterT (its cells: of it)
        self.spill = _SPILL[0]         # where the kept laws go (LawSpill), or None: kept in memory

    def add(self, r):
        if not self.grouped:
            self._keep(self._finish([r]))
            return
        rs, cnt = self.wait.get(r.n, ([], 0))
        if rs and cnt + r.rj.size > _batch_rows(r.n):
            self._keep(self._finish(rs))
            rs, cnt = [], 0
        rs.append(r)
        self.wait[r.n] = (rs, cnt + r.rj.size)

    def flush(self):
        self._finish_all([rs for rs, _ in self.wait.values()])
        self.wait = {}

    def flush_below(self, n):
        """Finish the waiting rows of chains of fewer than n segments."""
        self._finish_all([self.wait.pop(q)[0] for q in [q for q in self.wait if q < n]])

    def detach(self):
        """The waiting rows' knots and steps made their own arrays: _table_rows' items are
        views of the flat arrays of their run of groups (_knots_flat), which a count's rows
        waiting for the next chunk would otherwise hold whole through its solve."""
        for rs, _ in self.wait.values():
            for r in rs:
                if r.vk is not None and r.vk.base is not None:
                    r.vk, r.dt = r.vk.copy(), r.dt.copy()
                if r.bnd is not None and r.bnd.base is not None:
                    r.bnd = r.bnd.copy()

    def _finish_all(self, groups):
        """_finish of each batch rs of groups, in their order; under grouped finishing the
        numbers of consecutive batches made in one _finish_ragged call, up to RAGGED_CELLS
        segments a call (a window's ~30 segment counts: a call or two, not one a count).
        With a spill, the kept laws of all of them are kept together (_keep)."""
        done = []
        i = 0
        while i < len(groups):
            j, cells = i + 1, _batch_cells(groups[i])
            while self.grouped and j < len(groups) and cells + _batch_cells(groups[j]) <= RAGGED_CELLS:
                cells += _batch_cells(groups[j])
                j += 1
            got = None
            if j - i > 1:
                got = _finish_ragged([self._batch(rs) for rs in groups[i:j]], self.rules, self.profile)
            fins = (self._finish_many(groups[i:j], got) if got is not None
                    else [self._finish(groups[q]) for q in range(i, j)])
            for fin in fins:
                if self.spill is None:
                    self._keep(fin)
                elif fin:
                    done += fin
            i = j
        self._keep(done)

    def _batch(self, rs):
        """The batch rs as _finish_stacked_dt takes it: (sts, gs, own, vk, dt)."""
        # (the strokes and their geometries by C-level maps, not a Python step a chain: ~28 k
        # chains' rows finished on the windowed gyroid plate)
        sts = []
        for r in rs:
            sts += map(r.sts.__getitem__, r.J.tolist())
        gs = _geoms(sts, self.profile)
        if len(rs) == 1:             # (a window's batches: most are one group's rows)
            own = rs[0].rj
        else:
            off = np.cumsum([0] + [r.J.size for r in rs])
            own = np.concatenate([o + r.rj for o, r in zip(off, rs)])
        vk = rs[0].vk if len(rs) == 1 else np.concatenate([r.vk for r in rs])
        dt = rs[0].dt if len(rs) == 1 else np.concatenate([r.dt for r in rs])
        return sts, gs, own, vk, dt

    def _finish(self, rs):
        """Put the batch rs's rows in the table: [(r, its predicted times, ∫|a|², which of
        its rows are good)] for _keep (the puts and the answer: _finish_many's)."""
        profile, rules = self.profile, self.rules
        if self.grouped:
            sts, gs, own, vk, dt = self._batch(rs)
            _, _, t, a2, _ = _finish_stacked_dt(sts, gs, own, vk, dt, rules, profile)
            del vk, dt
        else:
            r = rs[0]
            _, _, t, a2, _ = _finish_rows_dt(r.sts[int(r.J[0])], r.vk, r.dt, rules, profile)
        return self._finish_many([rs], [(None, None, t, a2)])[0]

    def _finish_many(self, groups, got):
        """_finish of each batch rs of groups with its numbers got[q] (_finish_ragged's: t and
        ∫|a|² at [2] and [3]): the table's cells of all of them put at once (one good mask and one put, not ~10 numpy
        calls a batch: a windowed call's ~40 batches, one a segment count; each cell's values
        the same), each batch's answer as _finish gives it (its rows' good mask a view of
        the call's: read by _keep, not kept)."""
        rs_all = [r for rs in groups for r in rs]
        t = np.concatenate([g[2] for g in got])
        a2 = np.concatenate([g[3] for g in got])
        good = np.isfinite(a2) & np.isfinite(t) & (t > 0)
        rows = np.concatenate([r.a + r.j for r in rs_all])
        cols = np.concatenate([r.rc for r in rs_all])
        iv = np.concatenate([r.iv for r in rs_all])
        if good.all():               # (the usual case: the rows as they are, not gathered)
            self.tab.put(rows, cols, t, a2, iv)
        else:
            self.tab.put(rows[good], cols[good], t[good], a2[good], iv[good])
        fins, at = [], 0
        for rs, g in zip(groups, got):
            tb, a2b = g[2], g[3]
            lo, out = 0, []
            for r in rs:
                R = r.rj.size
                out.append((r, tb[lo:lo + R], a2b[lo:lo + R], good[at + lo:at + lo + R]))
                r.vk = r.dt = None
                lo += R
            at += lo
            fins.append(out)
        return fins

    def _keep(self, done):
        """The chains' memos and kept laws of the finished rows done (_finish's answer): a
        base a group of rows (r), or with a spill, bases of several groups' rows, up to
        FINISH_ROWS rows a base (_keep_run: a windowed call's ~33 groups, one a segment
        count on the gyroid plate, in a base or two).  None: nothing (kept already)."""
        if not done:
            return
        if self.spill is None:
            for r, tr, a2r, good in done:
                self._keep_run([(r, tr, a2r, good)])
            return
        run, R, nbytes = [], 0, 0
        for d in done:
            b = _kept_bytes(d[0])
            # (a memo's place in the rows: a shared int; the block a replay reads: cached)
            if run and (R + d[0].rj.size > FINISH_ROWS or nbytes + b > KEPT_BLOCK_BYTES):
                self._keep_run(run)
                run, R, nbytes = [], 0, 0
            run.append(d)
            R += d[0].rj.size
            nbytes += b
        if run:
            self._keep_run(run)

    def _keep_run(self, run):
        """One kept laws' base for the finished rows of run [(r, t, a2, good)] (_finish's), and
        the memos of their good rows: its rows r's after r's before it."""
        # (the rows' laws, not their knots: ~1/3 of the bytes, held until a plan is made;
        # one _KeptLaws for the rows of all these chains, each row its batch row)
        # (its rows' T, beta and predicted times: the memos' rows, _remember; memo52)
        kb = self._kept_base(run[0][0], run[0][2]) if len(run) == 1 else self._merged_base(run)
        kept = _KeptLaws(self.key, kb, 0, sum(d[0].rj.size for d in run))
        for d in run:
            d[0].bnd = None
        if len(run) == 1:
            r, tr, _, good = run[0]
            _remember(r.sts, r.j, r.rc, tr, good, r.T, r.beta, kept, self.src, r.a)
        else:
            _remember_runs([(r.sts, r.j, r.rc, tr, good, r.T, r.beta, r.a) for r, tr, _, good in run], kept,
                           self.src)

    def _kept_base(self, r, a2):
        """The kept laws' base of the rows r (_KeptLaws: binding bits, pieces' durations,
        their places, T, beta and predicted times read in the memos' rows (_remember), the
        predicted ∫|a|² a2, profile); with a spill, its arrays written there (the rows'
        pieces in row order: the chunk's pieces are not held by them)."""
        mask = _PackedMask(r.bnd)
        if self.spill is None:
            return (mask, r.tj, r.spans, None, None, None, a2, self.profile)
        tj, spans = self.spill.pieces(r.tj, r.spans)
        # (the 8-byte arrays first: each array aligned in its block's bytes)
        tj, a2, spans, mask.bits = self.spill.put_block([tj, a2, spans, mask.bits])
        return (mask, tj, spans, None, None, None, a2, self.profile)

    def _merged_base(self, run):
        """_kept_base of the rows of several groups run [(r, t, a2, good)] (a spill's): their
        masks' bits as one run (_RaggedMask), their pieces, places and ∫|a|² one after the
        other, one spill block (the pieces of the rows of one chunk gathered by one call)."""
        spill, tjs, sps, at, k = self.spill, [], [], 0, 0
        while k < len(run):
            e = k + 1
            while e < len(run) and run[e][0].tj is run[k][0].tj:
                e += 1
            sp = run[k][0].spans if e == k + 1 else np.concatenate([d[0].spans for d in run[k:e]])
            tj, sp = spill.pieces(run[k][0].tj, sp)
            sp[:, 0] += at
            at += tj.size
            tjs.append(tj)
            sps.append(sp)
            k = e
        mask = _RaggedMask(np.concatenate([d[0].bnd.ravel() for d in run]),
                           _offsets(np.array([d[0].rj.size for d in run], np.int64)),
                           np.array([d[0].bnd.shape[1] for d in run], np.int64))
        got = spill.put_block([np.concatenate(tjs), np.concatenate([d[2] for d in run]), np.concatenate(sps),
                               mask.bits])
        tj, a2, spans, mask.bits = got
        return (mask, tj, spans, None, None, None, a2, self.profile)


# a merged kept-laws base's spill block at most (_Finisher._keep), about: the replays read a
# base's block whole for its rows, kept in the spill's cache (LawSpill.CACHE_BYTES, which
# holds one such block).  Half the cache (round 44) made the gyroid plate's windowed
# candidates 72 merged bases, their replays 209 base reads; the whole cache 50 and 154:
# -37 M instructions, no peak rise (benchmarks/chains60.md)
KEPT_BLOCK_BYTES = 1 << 18


def _kept_bytes(r):
    """The bytes the kept laws of the rows r (_Rows) take in a spill block: each row's pieces'
    durations, its ∫|a|², its pieces' place and number, its binding bits."""
    R = r.rj.size
    return 8 * int(r.spans[:, 1].sum()) + 16 * R + (R * r.bnd.shape[1] + 7) // 8


def _flat_chains(sts, profile, gs=None):
    """The chains sts (geometries gs, or None: made here) as flat arrays (laws/chain._Flat;
    durations per column: with_T)."""
    if gs is None:
        gs = [curves.geom(st, profile) for st in sts]
    caps = _kept_caps(sts, gs, profile)
    cv = _join_caps(caps)
    m = len(sts)
    L, v0, v1 = _lengths_ends(sts)          # (one compiled pass: the same doubles)
    return _Flat.of_arrays(_inner_s_runs(gs), cv if cv.flags.writeable else cv.copy(), _caps_sizes(caps),
                           L, np.zeros(m), np.ones(m), v0, v1)


def _inner_s(gs):
    """The interior vertices' arc lengths of the geometries gs, chain after chain: each
    one's g.s_v[1:-1] (np.cumsum of its segment lengths d, its last sum left out).  With
    the chain core, the sums of all chains in one piece_cumsum call over their d laid end
    to end (the same additions in the same order, chain by chain, so the same bits: not a
    g.s_v array made and sliced per chain, ~3 us each on ~16 k chains)."""
    if not gs:
        return np.empty(0)
    core = _chain_law.CORE_MOD
    if core is not None:
        ds = [g.d for g in gs]
        d = np.concatenate(ds)
        n = np.fromiter(map(len, ds), np.int64, len(ds))
        # (a chain without segments has no last sum to leave out: per chain, as below)
        if d.dtype == np.float64 and n.all():
            return _inner_s_core(core, d, n)
    return np.concatenate([g.s_v[1:-1] for g in gs])


def _inner_s_runs(gs):
    """_inner_s(gs) with the lengths of each run of consecutive geometries of one segment
    count stacked (curves.stack_d: the same doubles) and summed by _inner_s_stacked, not a
    d view a chain (the candidates' chunks: chains in order of their segment counts, a few
    dozen runs for ~700 chains).  _inner_s where the core is missing or a run's count is 0."""
    if not gs or _chain_law.CORE_MOD is None:
        return _inner_s(gs)
    n = np.array(curves.seg_counts(gs), np.int64)
    if not n.all():
        return _inner_s(gs)
    ends = np.flatnonzero(n[1:] != n[:-1]).tolist()
    starts = [0] + [e + 1 for e in ends]
    return _inner_s_stacked(gs, [curves.stack_d(gs[a:z]) for a, z in zip(starts, starts[1:] + [len(gs)])])


def _inner_s_core(core, d, n):
    """_inner_s by the chain core: the segment lengths d of chains of n segments each."""
    off = np.zeros(n.size + 1, np.int64)
    np.cumsum(n, out=off[1:])
    s = np.empty(d.size)
    core.piece_cumsum(d, off, s)
    keep = np.ones(d.size, bool)
    keep[off[1:] - 1] = False             # each chain's last sum: its length, not a vertex
    return s[keep]


def _chain_caps(sts, gs, profile):
    """vertex_caps of the chains sts (geometries gs).  Under classic jerk, those whose caps
    went (_drop) and whose whole-jerk caps were read are made again in one batch, as
    build_geoms made them (curves._caps_flat_rows at the whole jerk: elementwise, the same
    bits as vertex_caps stroke by stroke), x CHAIN_CAP_MARGIN, without keeping them."""
    return [_caps_array(c) for c in _kept_caps(sts, gs, profile)]


def _kept_caps(sts, gs, profile):
    """_chain_caps as the geometries keep them (arrays, or the bytes of their doubles)."""
    # (every chain's caps kept already, the windowed candidates' usual case: each one's own,
    # as _kept_caps_made ends with, by a C-level map)
    caps = list(map(_CHAIN_CAPS, gs))
    if all(map(_IS_NOT_NONE, caps)):
        return caps
    return _kept_caps_made(sts, gs, profile)


def _kept_caps_made(sts, gs, profile):
    """_kept_caps, the caps not kept made (the blocks' rows, the whole-jerk batch, vertex_caps)."""
    out = [None] * len(sts)
    jerk = profile.junction == "jerk"
    # (the blocks' rows first: the chains whose caps went and whose whole-jerk caps were not
    # read are none of those, and are then looked for among the rest only, not by a row view
    # of its block's caps_jerk1 a chain, ~32 k on the windowed gyroid plate)
    _block_rows_caps(sts, gs, out, jerk)
    # (the chains still without caps found by C-level maps: none, mostly)
    miss = list(compress(range(len(out)), map(is_, out, repeat(None))))
    if not miss:
        return out
    if jerk:
        gone = [q for q in miss if gs[q].chain_caps is None and gs[q].caps_jerk1 is None]
        if len(gone) > 1:
            got = curves._caps_flat_rows([sts[q] for q in gone], profile, [gs[q].u for q in gone],
                                         [gs[q].d for q in gone], 1.0)
            if got is not None:
                flat, first = got
                for q, a in zip(gone, first):
                    out[q] = CHAIN_CAP_MARGIN * flat[a:a + gs[q].d.size - 1]
    for q in miss:
        if out[q] is None:
            c = gs[q].chain_caps
            out[q] = vertex_caps(sts[q], profile) if c is None else c
    return out


def _block_rows_caps(sts, gs, out, jerk):
    """vertex_caps of the chains sts (geometries gs) whose caps are not made yet and are
    rows of their geometry's block (classic jerk: the block's caps at the whole jerk, else
    its caps), into out[q] where out[q] is None: a block's rows in one product
    CHAIN_CAP_MARGIN x rows (vertex_caps' product a chain, elementwise: the same bits),
    not a call a chain (~50 k on the gyroid plate's windowed run, whose geometry is made
    again a window without the chains' caps).  Each chain keeps the bytes of its row, as
    _classify_block leaves them, and lets go of its caps at the whole jerk as vertex_caps
    does."""
    by_blk = {}                          # block -> ([q], [its row])
    geom, from_block = curves.CurveGeom, curves._FROM_BLOCK
    for q, st, g, c in zip(range(len(gs)), sts, gs, out):
        if (c is None and type(g) is geom and st.curv is g and g.chain_caps is None
                and (not jerk or g._j1 is from_block)):
            got = by_blk.get(g._b)
            if got is None:
                got = by_blk[g._b] = ([], [])
            got[0].append(q)
            got[1].append(g._k)
    for b, (qs, ks) in by_blk.items():
        src = b.caps_jerk1 if jerk else b.caps
        if type(src) is not np.ndarray or src.ndim != 2 or src.dtype != np.float64:
            continue                     # (vertex_caps a chain)
        rows = CHAIN_CAP_MARGIN * src.take(ks, axis=0)
        buf, w = rows.tobytes(), 8 * rows.shape[1]      # (C order: row i is buf[w i:w (i + 1)])
        for i, q in enumerate(qs):
            g = gs[q]
            g.chain_caps = out[q] = buf[w * i:w * (i + 1)]
            g._j1 = None                 # (caps_jerk1 = None: read only to make chain_caps)


class _TableItem(tuple):
    """One group of _table_rows' rows (J, rj, rc, vk, dt, ks, iv), with `at`: the flat index
    of its rows' vertices in the stacks (its width, vmap and vertex offsets), or None, `j`:
    J[rj], or None, `spans`: its rows' pieces' places (_LawCols.rows'), or None, and `bnd`:
    its rows' binding masks (_LawCols.rows'), or None (made by _LawCols.rows)."""
    at = j = spans = bnd = None


def _table_rows(sts, base, res, use, T, profile, grouped, laws=None):
    """The candidate table's rows of one chunk: chain j's usable columns c (use (m, k))
    from the flat laws res[c], as (J, rj, rc, vk, dt, ks, iv) per group of chains (_Rows):
    under grouped finishing the chains of one segment count, at most FINISH_ROWS rows a
    group, else one chain a group.  Each row keeps its knot speeds and segment durations
    (_KeptLaws: the accelerations and feeds are made again for the candidate chosen,
    _replay).  laws: the chunk's _LawCols, whose rows' pieces' places (spans) are then
    made here for every group at once (item.spans).

    What does not depend on a group's segment count (its rows, their chains, end speeds,
    durations, ∫ṡ², pieces' places) is gathered once for the groups end to end and sliced
    a group: a windowed call's chunk holds every segment count, ~40 groups of ~15 chains,
    each of which paid ~10 numpy calls for it (the same values, gathered at the same places)."""
    nseg = np.diff(base.voff) + 1      # (a chain's interior vertices: one less than its segments)
    has = use.any(axis=1)
    per = use.sum(axis=1)              # each chain's rows (np.bincount of its rj's: the same int64 counts)
    if grouped:            # chains of one segment count, at most FINISH_ROWS rows a group
        groups = _count_groups(nseg, has, per)
    else:
        groups = [np.array([j]) for j in np.flatnonzero(has).tolist()]
    if not groups:
        return
    v0, v1 = base.v0, base.v1
    # the columns' laws stacked (k, vertices) and (k, chains): each group's rows are then
    # one gather over (column, vertex), not one per column (~500 groups x 5 columns of
    # masks and fancy indexes on the gyroid plate); the same numbers copied
    k = use.shape[1]
    (VV, TT), vmap = _vertex_stack(res, k, ("vert_v", "vert_t"))
    IV = _stack_cols(res, k, "iv")
    voff = base.voff
    # the groups' rows end to end: chain by chain in the groups' order, columns ascending
    # (each group's use[J].nonzero() after the groups before it), and their gathers
    JA = groups[0] if len(groups) == 1 else np.concatenate(groups)
    rjA, rcA = use[JA].nonzero()
    jA = JA[rjA]
    perA = per.take(JA)
    V0, V1, TL, IVA = v0[jA], v1[jA], _at(T, jA, rcA), _at(IV, rcA, jA)
    SP = None if laws is None else laws.spans(jA, rcA)
    ca = np.cumsum([0] + [J.size for J in groups]).tolist()      # each group's first chain in JA
    ra = np.concatenate([[0], np.cumsum(perA)]).take(ca).tolist()  # and its first row
    if VV.flags.c_contiguous and TT.flags.c_contiguous and TT.shape == VV.shape:
        yield from _table_items(groups, ca, ra, nseg, rjA, rcA, jA, perA, V0, V1, TL, IVA, SP, VV, TT, vmap, voff,
                                laws)
        return
    for g, J in enumerate(groups):
        a, lo, hi = ca[g], ra[g], ra[g + 1]
        n = int(nseg[J[0]])
        rj = rjA[lo:hi] - a                        # rows: chain by chain, columns ascending
        rc, j = rcA[lo:hi], jA[lo:hi]
        R = j.size
        vk = np.empty((R, n + 1))
        tk = np.empty((R, n + 1))
        vk[:, 0], vk[:, -1] = V0[lo:hi], V1[lo:hi]
        tk[:, 0] = 0.0
        tk[:, -1] = TL[lo:hi]
        at = None            # (no flat places: the stacks are not one C-contiguous shape here)
        if n > 1:
            ix = _row_ranges(voff[j], n - 1)
            if vmap is not None:
                ix = vmap.take(ix)
            cc = rc[:, None]
            vk[:, 1:-1] = _at(VV, cc, ix)
            tk[:, 1:-1] = _at(TT, cc, ix)
        item = _TableItem((J, rj, rc, vk, _row_steps(tk), perA[a:a + J.size], IVA[lo:hi]))
        item.at, item.j = at, j
        if SP is not None:
            item.spans = SP[lo:hi]
        yield item


def _table_items(groups, ca, ra, nseg, rjA, rcA, jA, perA, V0, V1, TL, IVA, SP, VV, TT, vmap, voff, laws=None):
    """_table_rows' items of the groups whose rows (chain jA[i], column rcA[i], in the groups'
    order; group g's rows ra[g]:ra[g + 1], its chains ca[g]:ca[g + 1] of JA) read the
    C-contiguous stacks VV, TT of one shape: every row's knot speeds, segment durations and
    inner vertices' flat places made once for each run of consecutive groups of at most
    KNOTS_FLAT_CELLS cells (_knots_flat), each group's arrays views of them (a windowed call's chunk: ~40 groups of ~15 chains, each of which
    paid ~20 numpy calls for its own; the same values at the same places).  laws: the
    chunk's _LawCols; where its binding stack is gathered at the same places, each item's
    binding masks (item.bnd, _LawCols.rows' bnd) are views of one gather too."""
    nA = nseg.take(jA)
    vo = _offsets(nA + 1)
    BB = None
    if (laws is not None and laws.vmap is vmap and laws.voff is voff and laws.BB.flags.c_contiguous
            and laws.BB.shape == VV.shape):
        BB = laws.BB                # (_LawCols.rows' gather at the same places)
    rjA = rjA - np.repeat(np.array(ca[:-1], np.int64), np.diff(ra))     # each row's chain in its group
    vol, W = vo.tolist(), VV.shape[1]
    g = 0
    while g < len(groups):
        # the flat arrays made for a run of consecutive groups of at most KNOTS_FLAT_CELLS
        # cells (one group at least): a whole chunk's at once (the list path's chunks of
        # ~2 k chains) raised the gyroid plate's list peak ~5 MB
        e = g + 1
        while e < len(groups) and vol[ra[e + 1]] - vol[ra[g]] <= KNOTS_FLAT_CELLS:
            e += 1
        r0, r1 = ra[g], ra[e]
        c0 = vol[r0]
        VK, DT, IDX, BND = _knots_flat(nA[r0:r1], vo[r0:r1 + 1] - c0, V0[r0:r1], V1[r0:r1], TL[r0:r1], VV, TT, vmap,
                                       voff, jA[r0:r1], rcA[r0:r1], BB)
        for g in range(g, e):
            J = groups[g]
            a, lo, hi = ca[g], ra[g], ra[g + 1]
            n, R = int(nseg[J[0]]), hi - lo
            v0, v1 = vol[lo] - c0, vol[hi] - c0       # (rows lo..hi-1: n + 1 cells each)
            vk = VK[v0:v1].reshape(R, n + 1)
            dt = DT[v0:v1].reshape(R, n + 1)[:, :n]
            at = (IDX[v0:v1].reshape(R, n + 1)[:, 1:n], W, vmap, voff) if n > 1 else None
            item = _TableItem((J, rjA[lo:hi], rcA[lo:hi], vk, dt, perA[a:a + J.size], IVA[lo:hi]))
            item.at, item.j = at, jA[lo:hi]
            if SP is not None:
                item.spans = SP[lo:hi]
            if BND is not None:
                item.bnd = BND[v0:v1].reshape(R, n + 1)[:, 1:n]
            yield item
        g = e


KNOTS_FLAT_CELLS = 1 << 15     # _table_items' flat knots made at once (~0.8 MB of VK, DT, IDX, BND)


def _knots_flat(nA, vo, V0, V1, TL, VV, TT, vmap, voff, jA, rcA, BB=None):
    """(VK, DT, IDX, BND) of rows of nA[i] segments (chain jA[i], column rcA[i]), n + 1 cells a
    row end to end (row i's at vo[i]:vo[i + 1]): its knot speeds in VK (V0[i], the stack VV's
    at its chain's inner vertices in column rcA[i], V1[i]), its segment durations in DT's
    first n (the differences of its knot times: 0, TT's there, TL[i]; its last cell is not
    one), its inner vertices' flat places in the stacks in IDX's inner cells (rcA[i] x width
    + each one's place, through vmap where not None; its end cells' are any valid place),
    and in BND's the binding stack BB's there (None: BB None).  The numbers _table_rows'
    groups made each for its rows: the same gathers, the same subtractions of the same
    doubles.  By the chain core in one pass (knots_flat) when it is there, else numpy: one
    gather a stack for all the rows, the ends put after it (no scatter of every cell)."""
    cells, W = int(vo[-1]), VV.shape[1]
    core = _chain_law.CORE_MOD
    fn = getattr(core, "knots_flat", None) if core is not None else None
    ints = (nA, voff, jA, rcA) if vmap is None else (nA, voff, jA, rcA, vmap)
    if (fn is not None and all(x.dtype == np.int64 for x in ints)
            and all(x.dtype == np.float64 and x.flags.c_contiguous for x in (V0, V1, TL, VV, TT))
            and (BB is None or (BB.dtype == bool and BB.flags.c_contiguous))):
        c = np.ascontiguousarray            # (rcA: a view of nonzero's pairs)
        VK, DT, IDX = np.empty(cells), np.empty(cells), np.empty(cells, np.int64)
        BND = None if BB is None else np.empty(cells, bool)
        fn(c(nA), V0, V1, TL, VV, TT, None if BB is None else BB.view(np.uint8), None if vmap is None else c(vmap),
           c(voff), c(jA), c(rcA), VK, DT, IDX, None if BND is None else BND.view(np.uint8), W)
        return VK, DT, IDX, BND
    first, last = vo[:-1], vo[1:] - 1
    at = np.arange(cells, dtype=np.int64)
    if vmap is None:            # cell p of row i: place rcA[i] W + voff[jA[i]] + p - 1
        IDX = np.repeat(rcA * W + voff.take(jA) - 1 - first, nA + 1) + at
        IDX[first] = IDX[last] = 0
    else:
        v = np.repeat(voff.take(jA) - 1 - first, nA + 1) + at
        v[first] = v[last] = 0
        IDX = vmap.take(v) + np.repeat(rcA * W, nA + 1)
    VK = VV.ravel().take(IDX)
    VK[first], VK[last] = V0, V1
    TK = TT.ravel().take(IDX)
    TK[first], TK[last] = 0.0, TL
    DT = np.empty(cells)
    np.subtract(TK[1:], TK[:-1], out=DT[:-1])
    DT[-1] = 0.0                # (no row's step)
    return VK, DT, IDX, None if BB is None else BB.ravel().take(IDX)


def _count_groups(nseg, has, rows):
    """_table_rows' groups under grouped finishing: the chains `has` (mask) of each segment
    count nseg (ascending counts, each count's chains ascending), cut where the running sum
    of their rows (rows per chain) // FINISH_ROWS steps.  The same index arrays as a mask
    over the chunk, a cumsum and an np.split per count, made in one pass: the chains
    sorted by count (stable; already so in _figures_sorted's chunks), each count's running
    sums as the whole run's less the sum before its first chain (exact integers), the cuts
    where the count or the quotient changes, the groups slices of that order."""
    J = np.flatnonzero(has)
    if J.size == 0:
        return []
    q = nseg.take(J)
    if np.any(q[1:] < q[:-1]):
        o = np.argsort(q, kind="stable")
        J, q = J.take(o), q.take(o)
    cum = np.cumsum(rows.take(J))
    new = np.empty(J.size, bool)        # a count's first chain
    new[0] = True
    np.not_equal(q[1:], q[:-1], out=new[1:])
    first = np.flatnonzero(new)
    before = (cum - rows.take(J)).take(first)          # the rows before each count's first chain
    cut = (cum - np.repeat(before, np.diff(np.append(first, J.size)))) // FINISH_ROWS
    new[1:] |= cut[1:] != cut[:-1]
    at = np.flatnonzero(new).tolist() + [J.size]
    return [J[a:b] for a, b in zip(at[:-1], at[1:])]


class _LawCols:
    """The laws of one chunk's columns (solve_flat's FlatLaws res[c]) as _KeptLaws keeps a
    candidate row's law: its binding mask and its pieces' durations.  The durations of all
    the columns' pieces are one array PT, which the rows' kept laws share (each row: its
    first piece there and their number), not copied out row by row: a chain and its first
    equal (_Spread) share theirs (~18 % of the gyroid plate's pieces, held through the plan)."""

    def __init__(self, res, k, voff):
        self.voff = voff
        (self.BB,), self.vmap = _vertex_stack(res, k, ("bound",), bool)
        # the columns' pieces' durations end to end, chain c's of column q: PN[q, c] of them from P0[q, c]
        spans = [_piece_spans(res[c]) if c in res else None for c in range(k)]
        self.PT = np.concatenate([sp[0] for sp in spans if sp is not None])
        m = voff.size - 1
        self.P0, self.PN = np.zeros((k, m), np.int64), np.zeros((k, m), np.int64)
        at = 0
        for c, sp in enumerate(spans):
            if sp is not None:
                self.P0[c] = sp[1] + at
                self.PN[c] = sp[2]
                at += sp[0].size

    def spans(self, j, rc):
        """The rows' (chain j[i], column rc[i]) pieces' places (a, c): row i's pieces'
        durations PT[a:a + c] (int32: a chunk's pieces are ~10^5)."""
        return _at_both(self.P0, self.PN, rc, j).astype(np.int32)

    def rows(self, j, rc, n, at=None, spans=None):
        """(bnd (R, n - 1), PT, spans (R, 2)) of the rows (chain j[i], column rc[i]) of
        chains of n segments: row i's pieces' durations PT[a:a + c], (a, c) = spans[i]
        (self.spans: int32).  at: _table_rows' (flat index of these rows' vertices, the
        width, vmap and vertex offsets it was made for), or None; spans: the rows' spans if
        made (_table_rows' item.spans), or None (made here)."""
        R = j.size
        if (n > 1 and at is not None and at[2] is self.vmap and at[3] is self.voff and self.BB.flags.c_contiguous
                and self.BB.shape[1] == at[1]):
            bnd = self.BB.ravel().take(at[0])      # (_at's gather at the same places)
        elif n > 1:
            ix = _row_ranges(self.voff[j], n - 1)
            bnd = _at(self.BB, rc[:, None], ix if self.vmap is None else self.vmap[ix])
        else:
            bnd = np.empty((R, 0), bool)
        return bnd, self.PT, self.spans(j, rc) if spans is None else spans


ROW_RANGE_COLS = 8       # _row_ranges, _plus_rows: rows this short go column by column
# ... where there are at least this many rows: below, a column's numpy call (~4 k instructions
# of set-up each) costs more than the broadcast's buffered copies save (a windowed call's
# finishing groups: ~15 chains, ~75 rows, 743 groups on the gyroid plate; s62)
ROW_RANGE_ROWS = 256


def _row_ranges(start, w):
    """start[:, None] + np.arange(w) for int64 start (the same integers): column by column
    where the rows are short and many (numpy's broadcast of a short row pays a buffered copy
    a row: ~24 instructions an element at w = 5, ~10 by columns; _table_rows' rows are ~5-6
    long), else the broadcast (ROW_RANGE_ROWS)."""
    if w > ROW_RANGE_COLS or start.dtype != np.int64 or start.size < ROW_RANGE_ROWS:
        return start[:, None] + np.arange(w)
    out = np.empty((start.size, w), np.int64)
    for i in range(w):
        np.add(start, i, out=out[:, i])
    return out


def _row_steps(tk):
    """np.diff(tk, axis=1) (the same values) for a 2-D tk of times: where its rows are short
    and it is C-contiguous, one subtraction over tk's flat values (the row ends' steps
    across rows discarded) and a copy of the rest, not numpy's row-by-row buffered
    subtraction of two strided views (~85 instructions an element at 7 columns, ~25 so;
    long rows subtract well as they are)."""
    if tk.ndim != 2 or not 2 <= tk.shape[1] <= ROW_RANGE_COLS + 1 or tk.shape[0] < 2 \
            or tk.dtype != np.float64 or not tk.flags.c_contiguous:
        if tk.ndim == 2 and tk.dtype == np.float64:      # (np.diff's subtraction, without its set-up)
            return np.subtract(tk[:, 1:], tk[:, :-1])
        return np.diff(tk, axis=1)
    R, w = tk.shape
    f = tk.ravel()
    d = np.empty(R * w)
    np.subtract(f[1:], f[:-1], out=d[:-1])
    return d.reshape(R, w)[:, :-1].copy()


def _plus_rows(x, v):
    """x + v[:, None] for int64 x (R, w) and v (R,) (the same integers), x's memory reused;
    column by column where the rows are short and many (as _row_ranges)."""
    if x.shape[1] > ROW_RANGE_COLS or x.dtype != np.int64 or v.dtype != np.int64 or v.size < ROW_RANGE_ROWS:
        return x + v[:, None]
    for i in range(x.shape[1]):
        np.add(x[:, i], v, out=x[:, i])
    return x


def _at(A, rows, cols):
    """A[rows, cols] for a C-contiguous 2-D A and int arrays rows, cols of places inside it
    (broadcast together): a gather from A's flat values at rows * width + cols, the same
    values (~30 instructions an element with the index's sums, where numpy's 2-D fancy
    index took ~70: ~4 M entries of the gyroid plate's chain tables)."""
    if not A.flags.c_contiguous:
        return A[rows, cols]
    return A.ravel().take(rows * A.shape[1] + cols)     # (take: fewer steps an item than [])


def _at_both(A, B, rows, cols):
    """np.stack([_at(A, rows, cols), _at(B, rows, cols)], axis=1) (the same values): where A
    and B are C-contiguous 2-D arrays of one shape, their flat places made once."""
    if not (type(A) is np.ndarray and type(B) is np.ndarray and A.shape == B.shape and A.ndim == 2
            and A.flags.c_contiguous and B.flags.c_contiguous):
        return np.stack([_at(A, rows, cols), _at(B, rows, cols)], axis=1)
    at = rows * A.shape[1] + cols
    out = np.empty((at.size, 2), A.dtype if A.dtype == B.dtype else np.result_type(A, B))
    out[:, 0] = A.ravel().take(at)
    out[:, 1] = B.ravel().take(at)
    return out


def _vertex_stack(res, k, names, dtype=float):
    """([_stack_cols of each per-vertex array of names], vmap): where the columns are
    _Spreads of one solve (chains that repeat), the arrays of the laws they spread (fewer
    vertices) with vmap each vertex's place there (a gather less of every vertex a column,
    ~60 M instructions on the gyroid plate); else the columns' own and vmap None."""
    cols = [res[c] for c in range(k) if c in res]
    vg = getattr(cols[0], "vg", None) if cols else None
    if vg is not None and all(type(col) is _Spread and col.vg is vg for col in cols):
        own = {c: res[c].r for c in res}
        return [_stack_cols(own, k, name, dtype) for name in names], vg
    return [_stack_cols(res, k, name, dtype) for name in names], None


def _stack_cols(res, k, name, dtype=float):
    """The arrays res[c].<name> of the k columns as the rows of one (k, size) array (a
    column not solved: a row of nan (or False), never read: use has no row of it)."""
    got = [getattr(res[c], name, None) if c in res else None for c in range(k)]
    size = next(a.size for a in got if a is not None)
    out = np.empty((k, size), dtype)
    for c, a in enumerate(got):
        if a is None:
            out[c] = np.nan if dtype is float else 0
        else:
            out[c] = a
    return out


def _remember(sts, j, c, t, good, T, beta, kept, src=None, a=0):
    """Each chain's memo (ChainMemo.put_shared: one array for the batch) of its good rows:
    predicted time, law T, beta, and its row in kept (the batch's kept laws, shared by its
    chains: the batch row); rows of one chain are consecutive in j.  src: the _Source of
    the rows (chain sts[jj] is its row a + jj)."""
    _remember_runs([(sts, j, c, t, good, T, beta, a)], kept, src)


def _remember_runs(runs, kept, src=None):
    """_remember of the rows of several finishing groups kept in one base (kept; a windowed
    _Finisher's merged base, _Finisher._keep): run (sts, j, c, t, good, T, beta, a)
    (as _remember's arguments) holds kept's rows after those of the runs before it; one
    memo rows array for them all, each run's rows as _remember lays them out.  The runs'
    rows are laid out together (a windowed call's ~30 groups, one a segment count: the
    numpy calls paid once, not a group): each run's good rows, each chain's newest (last)
    first, in the runs' order -- the same rows a run at a time gave."""
    if len(runs) == 1:
        J, C, Tt, G = runs[0][1], runs[0][2], runs[0][3], runs[0][4]
        run_of = None
    else:
        J, C, Tt, G = (np.concatenate([r[x] for r in runs]) for x in (1, 2, 3, 4))
        run_of = np.repeat(np.arange(len(runs)), [r[1].size for r in runs])
    # the good rows (their index: the run's row plus the rows of the runs before it) by run,
    # chain, then newest first; (t, T, beta, row) made of those rows only (the same numbers
    # as a table of every row gathered at them; the row its index, exact as a float)
    g = G.nonzero()[0]                  # (np.flatnonzero's, without its Python wrappers)
    g = g[np.lexsort((-g, J[g]) if run_of is None else (-g, J[g], run_of[g]))]
    jq, cq = J[g], C[g]
    rows = np.empty((g.size, 4))        # (np.stack's columns, written in place)
    rows[:, 0] = Tt.take(g)
    _put_T_beta(rows, runs, jq, cq, None if run_of is None else run_of[g])
    rows[:, 3] = g
    figs = array("d")
    figs.frombytes(rows.tobytes())
    if type(kept) is _KeptLaws and len(kept.base) == 8 and kept.base[3] is None:
        kept.base = _figs_base(kept.base, figs, J.size)
    _put_memos(runs, J, run_of, g, figs, kept, src)


def _put_T_beta(rows, runs, jq, cq, rq):
    """rows[:, 1:3] = each good row's (T, beta) at its chain jq and column cq of its run's
    tables (rq: its run, None: one run), one gather where the runs share their tables (a
    chunk's groups)."""
    T, beta = runs[0][5], runs[0][6]
    if rq is None or all(r[5] is T and r[6] is beta for r in runs):
        rows[:, 1:3] = _at_both(T, beta, jq, cq)
        return
    cut = np.searchsorted(rq, np.arange(len(runs) + 1)).tolist()
    for r, lo, hi in zip(runs, cut[:-1], cut[1:]):
        rows[lo:hi, 1:3] = _at_both(r[5], r[6], jq[lo:hi], cq[lo:hi])


def _put_memos(runs, J, run_of, g, figs, kept, src):
    """Each chain of the runs (_remember_runs': J their rows' chains, run_of their runs or
    None, g the good rows in figs' order) keeps its rows of figs (_remember), in figs'
    order: a chain's rows are consecutive in its run's j."""
    first = _run_starts(J)
    if run_of is not None:
        first[1:] |= run_of[1:] != run_of[:-1]
    starts = first.nonzero()[0]
    chain = np.cumsum(first) - 1            # each row's chain (a run of equal j in a run)
    cnt = np.bincount(chain[g], None, starts.size).tolist()
    which = [0] * starts.size if run_of is None else run_of[starts].tolist()
    lo = 0
    shared, nshared = _ROW_INTS, len(_ROW_INTS)     # (_row_int inline: two calls a chain fewer)
    for k, jj, w in zip(cnt, J[starts].tolist(), which):
        if k:
            sts, a = runs[w][0], runs[w][7]
            memo = sts[jj].chain_T
            if memo.figs is None and memo.src is None:
                # a chain's first rows (the table's usual case): what _own_source and
                # put_shared set on a memo without rows nor source, set here
                if src is not None:
                    i = a + jj
                    memo.src, memo.src_i = src, shared[i] if i < nshared else i
                memo.figs, memo.kept, memo.at, memo.n = figs, kept, shared[lo] if lo < nshared else lo, k
                memo.seg_tin = None
            else:
                if src is not None:
                    _own_source(memo, src, a + jj)
                memo.put_shared(figs, _row_int(lo), k, kept)
            lo += k


class _FigsRows:
    """A finishing batch's memo rows array figs (4 doubles a row, _remember: predicted time,
    law T, beta, batch row) and its number of batch rows R.  pos(): each batch row's row in
    figs (-1: a row not kept), made from figs' 4th column (exact integers) when first read,
    by the first budget run's replay, and kept while its kept laws are (not held from the
    candidates to that run: 4 bytes a row)."""
    __slots__ = ("figs", "R", "_pos")

    def __init__(self, figs, R):
        self.figs, self.R, self._pos = figs, R, None

    def pos(self):
        if self._pos is None:
            q = np.frombuffer(self.figs, float)[3::4].astype(np.int64)     # (a copy: no view of figs kept)
            pos = np.full(self.R, -1, np.int32)
            pos[q] = np.arange(q.size, dtype=np.int32)
            self._pos = pos
        return self._pos


class _FigsCol:
    """Column col (0: predicted time, 1: law T, 2: beta) of a batch's kept laws' rows read
    in the memos' rows array (rows: _FigsRows): kept row q is figs' row pos()[q] (-1: a row
    not kept, never asked: plan_of finds only figs' rows).  Indexing gives the doubles
    themselves (a copy), as the arrays and _Cells it replaces held them: the same numbers
    were kept twice (the batch's predicted times, 8 bytes a row, and the T and beta cells'
    places, 4), now once (~1 MB on the gyroid plate's ~82 k rows, held from the
    candidates to the first budget run)."""
    __slots__ = ("rows", "col")
    ndim = 1

    def __init__(self, rows, col):
        self.rows, self.col = rows, col

    @property
    def shape(self):
        return (self.rows.R,)

    def __getitem__(self, q):
        at = self.rows.pos()[q]
        if np.any(at < 0):
            raise IndexError("kept row not in the memos' rows")
        # (a view of figs only for this read: an exported buffer would stop its resizing)
        return np.frombuffer(self.rows.figs, float)[4 * np.asarray(at, np.int64) + self.col]


def _figs_base(base, figs, R):
    """A kept laws' base (_Finisher._finish's, its T, beta and predicted times None) with
    those read in figs, the memo rows array of its R batch rows (_FigsCol)."""
    rows = _FigsRows(figs, R)
    return base[:3] + (_FigsCol(rows, 1), _FigsCol(rows, 2), _FigsCol(rows, 0)) + base[6:]


def _run_starts(j):
    """np.r_[True, j[1:] != j[:-1]] for a 1-D j (the same bools): where each run of equal
    values starts.  (np.r_ parses its index each call: ~15 us, once a finishing group.)"""
    out = np.empty(j.size, bool)
    if j.size:
        out[0] = True
        np.not_equal(j[1:], j[:-1], out=out[1:])
    return out


def _dropped_from(kept, src):
    """Is kept src's dropped rows (its _Again, or a _Chosen of src: its other rows are src's)?"""
    return kept is src.again or (type(kept) is _Chosen and kept.src is src)


def _own_source(memo, src, i):
    """Make src (row i) the source of memo's rows; rows of another source it dropped keep
    theirs (an _Again of their own row)."""
    old = memo.src
    if old is not None and old is not src:
        mine = _Again(old, memo.src_i)
        if _dropped_from(memo.kept, old):
            memo.kept = mine
        elif isinstance(memo.kept, list):
            memo.kept = [mine if _dropped_from(x, old) else x for x in memo.kept]
    memo.src, memo.src_i = src, _row_int(i)


def candidates_chain(pin, rows, strokes, profile, rules=None):
    """(T, beta, I, KE) for the chain strokes `rows`, shape (n, len(T_RATIOS)); inf where no
    candidate was computed or it breaks a limit.  I is the firmware's predicted ∫|a|²dt."""
    rules = rules or SegmentRules.for_profile(profile, 10)
    rows = np.asarray(rows, int)
    if rows.size == 0:
        return empty_table(pin, rows)[1:]
    # the columns' durations as empty_table's T has them (one product an entry: the same
    # bits); its four (n, len(T_RATIOS)) tables (~12 MB on the gyroid plate's ~16 k chains)
    # are made after _figures, not held beside its knots at the candidates' peak
    Tc = _OuterT(pin.T_orig[rows], T_RATIOS[CHAIN_COLS])
    ok, tp, ia, iv = _figures(strokes, rows, pin, Tc, _BetaOfT(Tc), profile, rules)
    if rows.size >= TRIM_DROPPED:     # _figures' freed temporaries (its solves' and finishing's)
        from .pipeline import trim_heap
        trim_heap()
    _, T, beta, I, KE = empty_table(pin, rows)
    T[:, CHAIN_COLS] = tp
    I[:, CHAIN_COLS] = np.where(ok, ia, np.inf)
    KE[:, CHAIN_COLS] = iv
    beta[:, CHAIN_COLS] = _chain_beta(np.asarray(Tc))
    return T, beta, I, KE


def fixed_alpha_chain(plan, pin, rows, strokes, profile, alpha, rules=None):
    """--alpha A on chains: beta = A * mass_r, T = the shortest candidate meeting the limits."""
    from .plan import take_shortest_feasible
    rules = rules or SegmentRules.for_profile(profile, 10)
    rows = np.asarray(rows, int)
    if rows.size == 0:
        return
    ratios = np.array(sorted(CHAIN_T_RATIOS))
    k = ratios.size
    Tf = pin.T_orig[rows, None] * ratios[None, :]
    bf = np.repeat(alpha * pin.mass_r[rows, None], k, axis=1)
    ok, tp, ia, iv = _figures(strokes, rows, pin, Tf, bf, profile, rules)
    take_shortest_feasible(plan, pin, rows, alpha, tp, ok, iv, ia)
