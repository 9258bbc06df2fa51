"""The strokes of a StrokeStore seen a window of rows at a time (the windowed pipeline's
stroke sets: issue 8, benchmarks/win51, win52; pipeline._process with GCODE_OPT_WINDOWED=1).
Window j is the rows [j * window, (j + 1) * window).  Two views, one family (StoreWindows):

- StoredStrokes, planning's (plan_inputs' candidates, the budget runs): a sequence of every
  stroke, indexed and iterated as the list is, that holds `held` windows (HELD: one) as
  objects at a time.  s[i] loads i's window (store.load) if it is not held, letting go of
  the window used least recently when `held` are held; while a window is held, s[i] is the
  same object each time.  A window let go whose strokes may have changed (writeback=True: every window; else
  those marked by changed(i)) is written back (store.rewrite) first.  The store keeps no
  cache: curv comes back None, chain_T an empty ChainMemo (stroke_store), so a consumer's
  caches on a stroke last as long as its window (on_load may make them again for a window
  as it is loaded, in one batch; keep: fields kept in side tables past their window).
- HeldRows, the steps after planning's (the rewrite): a list of one slot a stroke, only the
  rows asked for made, a window's at a time (stored_rows).

The hazard (benchmarks/win51/audit.md): a consumer that keeps a stroke past its window (a
list of strokes, a dict keyed by stroke, a memo) reads a copy that is no longer the row's,
and its changes to it are lost.  Consumers read a window's rows while it is held (e.g.
schedule.candidates_in_windows with bounds on the window's multiples)."""
from __future__ import annotations

import gc
from collections import OrderedDict
from functools import partial
from operator import attrgetter, is_not

import numpy as np

from . import objfields
from .distinct import distinct

_IS_NOT_NONE = partial(is_not, None)
_CURV = attrgetter("curv")


class StoreWindows:
    """A StrokeStore's rows in windows of `window` rows (row // window)."""

    def __init__(self, store, window):
        if window < 1:
            raise ValueError(f"{type(self).__name__}: window must be >= 1")
        self.store, self.window = store, int(window)

    def __len__(self):
        return len(self.store)

    def bounds(self):
        """The windows' first rows and the end: candidates_in_windows' bounds."""
        return list(range(0, len(self), self.window)) + [len(self)]

    def ends(self, order):
        """The end (in order) of each run of order's rows in one window."""
        w = np.asarray(order, np.int64) // self.window
        return (np.flatnonzero(w[1:] != w[:-1]) + 1).tolist() + [len(w)]


# windows a StoredStrokes holds by default: one.  The pipeline's candidates and runs read the
# windows in turn (gyroid plate at 1 k and 4 k, rectilinear at 1 k: the same windows loaded
# as with two held), so a second held window only added its strokes, with their curve
# geometry, to the peaks (benchmarks/store54.md)
HELD = 1


class StoredStrokes(StoreWindows):
    """Every stroke of store, a few windows of them objects at a time (the module's doc)."""

    def __init__(self, store, window=4096, held=HELD, writeback=False, on_load=None, keep=(), geoms=None):
        if held < 1:
            raise ValueError("StoredStrokes: held must be >= 1")
        super().__init__(store, window)
        self.held, self.writeback = int(held), writeback
        self.on_load = on_load           # on_load(first row, strokes) after a window is loaded (caches)
        # keep: fields whose objects outlive their window in side tables, put back (where not
        # None) when the row is loaded again (chain_T: the chains' memos, whose state the budget
        # runs' bits depend on; the store keeps only an empty memo).  A table is a list of one
        # slot a row, made at the first object kept: a dict {row: object} held an int and a
        # hash entry a row besides (gyroid plate's 16 k memos: 1.1 MB -> 0.28 MB)
        self._side = dict.fromkeys(keep)
        self._aside = None               # the chains' memos set aside (set_aside_memos)
        # geoms: the curve geometry of the rows kept (geom_keep.GeomKeep, of `window` rows a
        # window: planned_strokes'), given back where asked (schedule._rebuild_geometry)
        self.geoms = geoms
        self._wins = OrderedDict()       # window index -> its strokes (a list), least recent first
        self._dirty = set()              # windows marked changed
        self.loads = 0                   # windows loaded (a measure of the access pattern)
        self._lo = self._hi = 0          # the window used last: its rows [_lo, _hi), its strokes
        self._cur = None
        # freeze: the caller's freeze() (pipeline._strokes_frozen's: every object then alive
        # out of the collector's view), or None; the steps after planning hold their
        # strokes frozen (stored_rows: HeldRows)
        self.freeze = None

    def _win(self, j):
        w = self._wins.get(j)
        if w is None:
            w = self._load(j)
        else:
            self._wins.move_to_end(j)
        self._lo, self._hi, self._cur = j * self.window, j * self.window + len(w), w
        return w

    def _load(self, j):
        while len(self._wins) >= self.held:
            self._let_go(next(iter(self._wins)))
        lo = j * self.window
        w = self._wins[j] = self.store.load(lo, lo + self.window, self._kept(lo, min(lo + self.window, len(self))))
        self.loads += 1
        if self.on_load is not None:
            self.on_load(lo, w)
        return w

    def set_aside_memos(self, folder=None) -> bool:
        """The chains' memos kept in the side table (chain_T) and their rows written to a
        file in folder and let go until a memo is handed out again (a window's load,
        kept_at: chains.MemosAside), for the steps after planning, which read none (a
        re-plan does).  The held windows are let go first (their memos then in the side table).
        False where no memo is kept or the file cannot be made or written (all kept)."""
        side = self._side.get("chain_T")
        if side is None or self._aside is not None:
            return False
        self.let_go()
        from .chains import MemosAside
        try:
            self._aside = MemosAside(side, folder)
        except OSError:
            return False
        return True

    def _restore_memos(self):
        """The memos set aside read back, before a memo is handed out."""
        if self._aside is not None:
            self._aside.restore()
            self._aside = None

    def _kept(self, lo, hi):
        """{field: the side table's objects of rows lo..hi-1} (None where none kept): what
        the store's load puts in those fields as it makes the strokes (the chains' memos: no
        empty memo made and replaced, no setattr a row here)."""
        self._restore_memos()
        got = {}
        for name, side in self._side.items():
            if side is not None:
                vals = got[name] = side[lo:hi]
                if len(vals) < hi - lo:                               # (the store appended to since)
                    vals += [None] * (hi - lo - len(vals))
        return got

    def kept_at(self, rows):
        """{field: the side tables' objects of rows (sorted, an int array)} where every kept
        field holds one for each of them -- what the store's take needs to make the strokes
        a window's load makes (schedule._chain_strokes) -- else None (no field kept, or a row
        without its object yet).  The held windows are let go first (their objects then in
        the side tables, their changes written back: the store holds every change)."""
        if not self._side or not len(rows):
            return None
        self.let_go()
        self._restore_memos()
        got = {}
        for name, side in self._side.items():
            if side is None or len(side) <= rows[-1]:
                return None
            vals = objfields.take(side, rows)          # (one compiled pass where built)
            if vals is None:
                vals = list(map(side.__getitem__, rows.tolist()))
            got[name] = vals
            if not all(map(_IS_NOT_NONE, vals)):
                return None
        return got

    def take(self, rows):
        """New strokes of rows (sorted, an int64 array) made of their records alone (the
        store's take), not their windows loaded: the same strokes a window's load makes of
        them -- the side tables' objects put in where kept, the objects of kept fields made
        now kept in them (a later load of the row gives them back, as a window let go
        leaves them), on_load's caches made (its rows(rows, strokes)).  The held windows are
        let go first: one let go later would put its own objects of these rows in the side
        tables.  A row taken must not be read through a window while its taken stroke is in
        use (the module's hazard: two objects of one row)."""
        self.let_go()
        rows = np.asarray(rows, np.int64)
        if not rows.size:
            return []
        got = self.store.take(rows, self._kept_rows(rows))
        for name in self._side:
            vals = list(map(attrgetter(name), got))
            if not any(map(_IS_NOT_NONE, vals)):
                continue
            side = self._side[name]
            if side is None:
                side = self._side[name] = [None] * len(self)
            if len(side) <= rows[-1]:          # (the store appended to since the table was made)
                side += [None] * (int(rows[-1]) + 1 - len(side))
            for i, v in zip(rows.tolist(), vals):
                side[i] = v
        if self.on_load is not None:
            self.on_load.rows(rows, got)
        return got

    def _kept_rows(self, rows):
        """take's over: {field: the side table's objects of rows (None where none)}."""
        got = {}
        for name, side in self._side.items():
            if side is not None:
                n = len(side)
                got[name] = [side[i] if i < n else None for i in rows.tolist()]
        return got or None

    def _let_go(self, j):
        w = self._wins.pop(j)
        if w is self._cur:
            self._lo = self._hi = 0
            self._cur = None
        lo = j * self.window
        for name, side in self._side.items():
            vals = list(map(attrgetter(name), w))
            if side is None:
                if not any(map(_IS_NOT_NONE, vals)):
                    continue
                side = self._side[name] = [None] * len(self)
            if len(side) < lo + len(w):        # (the store appended to since the table was made)
                side += [None] * (lo + len(w) - len(side))
            side[lo:lo + len(w)] = vals
        if self.writeback or j in self._dirty:
            self.store.rewrite(np.arange(lo, lo + len(w), dtype=np.int64), w)
        self._dirty.discard(j)

    def _row(self, i):
        n = len(self)
        i = int(i)
        if i < 0:
            i += n
        if not 0 <= i < n:
            raise IndexError("StoredStrokes: row out of range")
        return i

    def __getitem__(self, i):
        if type(i) is not slice and self._lo <= i < self._hi:     # (the window used last: most reads)
            return self._cur[i - self._lo]
        if isinstance(i, slice):
            return [self[k] for k in range(*i.indices(len(self)))]
        i = self._row(i)
        j, k = divmod(i, self.window)
        return self._win(j)[k]

    def __iter__(self):
        for j in range(0, -(-len(self) // self.window)):
            yield from self._win(j)

    def column(self, name):
        """store.column(name) as the strokes are now: the held windows whose strokes may have
        changed written back first (they stay held).  A field read this way decodes no
        stroke (plan_strokes' corner_cmd0 loaded every window, a pass of its own)."""
        for j, w in self._wins.items():
            if self.writeback or j in self._dirty:
                lo = j * self.window
                self.store.rewrite(np.arange(lo, lo + len(w), dtype=np.int64), w)
        return self.store.column(name)

    def changed(self, i):
        """Row i's stroke was (or will be) changed: its window is written back when let go."""
        self._dirty.add(self._row(i) // self.window)

    def let_go(self):
        """Every window let go (written back where due)."""
        for j in list(self._wins):
            self._let_go(j)


class StrokeRows:
    """The strokes rows (sorted int array) of a sequence of strokes, as a sequence read in
    slices (segments.line_classes reads a chunk at a time): a window's strokes are objects
    while it is held, not all of rows at once as a list of them would make them."""

    def __init__(self, strokes, rows):
        self.strokes, self.rows = strokes, np.asarray(rows)

    def __len__(self):
        return self.rows.size

    def __getitem__(self, i):
        if isinstance(i, slice):
            return list(map(self.strokes.__getitem__, self.rows[i].tolist()))
        return self.strokes[int(self.rows[i])]

    def __iter__(self):
        return map(self.strokes.__getitem__, self.rows.tolist())


WINDOW = 4096     # rows a window of a StrokeStore given as it is (a StoredStrokes: its own)


def stored(strokes):
    """(the StrokeStore, rows a window) that keeps strokes -- a StoredStrokes (its windows
    let go first, written back where due: the store then holds every change) or the
    StrokeStore itself -- or None: a list (or any other sequence) is the strokes themselves."""
    if type(strokes) is list:
        return None
    from .stroke_store import StrokeStore
    if isinstance(strokes, StoredStrokes):
        strokes.let_go()
        return strokes.store, strokes.window
    if isinstance(strokes, StrokeStore):
        return strokes, WINDOW
    return None


def stored_rows(strokes):
    """A HeldRows over the StrokeStore that keeps strokes (stored), or None (a list); a
    StoredStrokes' freeze goes with it."""
    got = stored(strokes)
    return None if got is None else HeldRows(*got, freeze=getattr(strokes, "freeze", None))


class HeldRows(StoreWindows):
    """Strokes of a StrokeStore made a window of rows at a time, each at its row of a list of
    one slot a stroke (slots: None where no stroke is held), which the steps after planning
    index by stroke index as they index the list of strokes (ends(order): where hold is
    due).  Only the rows asked for are made (the rewrite's re-timed rows, not the rest of
    their window); the last ones held are let go as the next are.  freeze: a function
    that moves every object alive out of the garbage collector's view (the pipeline's,
    gc.freeze) called once a hold's strokes are made, or None: the list path's strokes are
    frozen, the held ones were walked by every young collection of the rewrite's plans
    (rectilinear plate, windowed: ~40 M instructions; its collections found no garbage,
    and a frozen stroke let go is still freed by its count)."""

    def __init__(self, store, window, freeze=None):
        super().__init__(store, window)
        self.freeze = freeze
        self.slots = [None] * len(store)
        self._held = np.zeros(0, np.intp)
        self.made = 0                 # strokes made (a measure of the access pattern)

    def hold(self, rows):
        """The strokes of rows (and only those) in their slots; the ones held before let go.
        The slots put by one compiled pass each where built (objfields: the two Python
        loops were ~1/3 of the windowed rewrite's holds, ~23 k rows on the gyroid plate)."""
        slots = self.slots
        if not objfields.fill_at(slots, self._held, None):
            for r in self._held.tolist():
                slots[r] = None
        rows = np.array(rows, np.int64)     # (a copy: _held is not the caller's array)
        # (np.unique would import numpy.ma: distinct.py; rows already ascending, the
        # rewrite's windows, taken as they are: a sort of them was ~100 instructions a row)
        if not (rows.ndim == 1 and (rows.size < 2 or (rows[1:] > rows[:-1]).all())):
            rows = distinct(rows)
        rows = rows.astype(np.intp, copy=False)
        self._held = rows
        # (the collector off until they are frozen: its first collection walked them all)
        paused = self.freeze is not None and gc.isenabled()
        if paused:
            gc.disable()
        try:
            made = self.store.take(rows) if len(rows) else []
            self.made += len(made)
            if not objfields.put_at(slots, rows, made):
                for r, st in zip(rows.tolist(), made):
                    slots[r] = st
            if made and self.freeze is not None:
                self.freeze()
        finally:
            if paused:
                gc.enable()


def curve_geometry(codes, profile, geoms=None):
    """StoredStrokes' on_load for planning (a _CurveGeometry): a window's curve and chain
    geometry as plan_inputs made it: given back by geoms (a geom_keep.GeomKeep, κ at the
    vertices included: the candidates read it) where it keeps it, else made in one batch
    (chains.classify's build_geoms: a chain without κ, which it never reads), not stroke
    by stroke when read (benchmarks/win51: ~3.5x the candidates' time).  codes: the
    strokes' plan_kind codes (pin.plan_kind_codes).  The curves and the chains in one call
    (a block a vertex count of both: the blocks' set-up paid once, benchmarks/wincpu54.md),
    κ made for the curves' rows alone."""
    return _CurveGeometry(codes, profile, geoms)


class _CurveGeometry:
    """curve_geometry's: (lo, strokes) a window's strokes of rows lo..; rows(rows, strokes)
    the strokes of rows (sorted; StoredStrokes.take's)."""

    def __init__(self, codes, profile, geoms):
        self.codes, self.profile, self.geoms = codes, profile, geoms

    def __call__(self, lo, sts):
        self.rows(np.arange(lo, lo + len(sts), dtype=np.int64), sts)

    def rows(self, rows, sts):
        from . import curves
        from .schedule import C_CHAIN, C_CURVE
        if self.geoms is not None:
            self.geoms.give(rows, sts, kappa=True)
        c = self.codes[rows]
        at = np.flatnonzero((c == C_CURVE) | (c == C_CHAIN)).tolist()
        if None not in map(_CURV, map(sts.__getitem__, at)):      # (every one given: the plates' case)
            return
        at = [k for k in at if sts[k].curv is None]
        todo = [sts[k] for k in at]
        curve = {id(sts[k]) for k in at if c[k] == C_CURVE}
        curves.build_geoms(todo, self.profile, jerk1=True,
                           kappa=lambda bsts, cap: np.fromiter(map(curve.__contains__, map(id, bsts)), bool,
                                                               len(bsts)))


def join_plan_inputs(parts):
    """The PlanInputs of consecutive windows of strokes as one, as plan_inputs of all of them
    gives it: each array of one row a stroke joined, each list joined, and each dict by row
    (arcs' arc_gentle) with its rows moved by its window's first row."""
    from .plan import PlanInput
    pin = PlanInput.__new__(PlanInput)
    at = np.cumsum([0] + [len(p.L) for p in parts])
    for k in dict.fromkeys(k for p in parts for k in vars(p)):
        vals = [vars(p).get(k) for p in parts]
        v = next(x for x in vals if x is not None)
        if isinstance(v, np.ndarray):
            setattr(pin, k, np.concatenate(vals))
        elif isinstance(v, dict):
            setattr(pin, k, {int(i) + int(a): x for a, d in zip(at, vals) if d for i, x in d.items()})
        else:
            setattr(pin, k, [x for p in vals for x in p])
    return pin
