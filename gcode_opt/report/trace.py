"""Play one file through the firmware model and keep what the report draws.

``trace_file(path, profile)`` returns a ``Trace``: the ``SimResult``, the ``LineRecord``
figures of every moving line and the ``Move`` of every moving line (as columns by line:
LineTable, MoveTable -- a dict of objects took ~0.5 kB a line), and every planned block as columns
of numpy arrays (start/end point, speeds, acceleration and the three trapezoid phase
times), so a stroke's as-executed speed profile can be rebuilt phase by phase.
"""
from __future__ import annotations

import math
from array import array
from bisect import bisect_left, bisect_right
from operator import attrgetter

import numpy as np

from .. import state as st
from ..firmware.simulate import simulate_events

BLOCK_FIELDS = ("idx", "x0", "y0", "x1", "y1", "d", "start_v", "cruise_v", "end_v", "accel",
                "accel_t", "cruise_t", "decel_t", "v2_int", "nominal_v")


LINE_FIELDS = ("start_v", "end_v", "peak_v", "time_t", "int_a2", "int_a2_j", "int_v2", "peak_a")
MOVE_FIELDS = ("x0", "y0", "z0", "x1", "y1", "z1", "e", "v")
# of the processed file the report reads the stroke sums and maxima, and which blocks extrude
# in a layer (x0, y0: the trace's own cursor)
PROCESSED_LINE_FIELDS = ("time_t", "int_a2", "int_a2_j", "int_v2", "peak_v", "peak_a")
PROCESSED_MOVE_FIELDS = ("x0", "y0", "e")


def _pos(idx, i):
    """Position of source line i in the sorted index column idx, or -1."""
    k = bisect_left(idx, i)
    return k if k < len(idx) and idx[k] == i else -1


class _Rows:
    """Float fields of one record a row, row-major in array('d') chunks of CHUNK rows (one
    extend a record; reads give Python floats), rows by sorted source line (idx).  Chunks,
    not one array: one array grown by realloc to tens of MB left glibc's heap about twice
    its size (the smaller copies it left behind below the mmap threshold: the gyroid
    plate's original, 461 k lines, took `--report`'s heap from 34 to 178 MB for ~73 MB of
    tables)."""
    CHUNK = 1 << 13          # rows a chunk (LineTable: 512 kB)

    def __init__(self, fields, what):
        self.idx = array("q")
        self.fields, self.what = fields, what
        self._j = {k: j for j, k in enumerate(fields)}
        self._w = len(fields)
        self._chunks = [array("d")]
        self._full = self.CHUNK * self._w       # a chunk's doubles when full
        self._get = attrgetter(*fields)

    def _add(self, rec):
        idx = self.idx
        if idx and rec.idx <= idx[-1]:
            raise ValueError(f"{self.what} out of order at line {rec.idx + 1}")
        idx.append(rec.idx)
        c = self._chunks[-1]
        if len(c) == self._full:
            c = array("d")
            self._chunks.append(c)
        c.extend(self._get(rec))

    def __contains__(self, i):
        return _pos(self.idx, i) >= 0

    def __len__(self):
        return len(self.idx)

    def column(self, attr, lo=0, hi=None):
        """attr of rows lo..hi-1 (array('d'))."""
        w, j, C = self._w, self._j[attr], self.CHUNK
        hi = len(self.idx) if hi is None else min(hi, len(self.idx))
        out = array("d")
        for c in range(lo // C, (hi - 1) // C + 1) if hi > lo else ():
            a, b = max(lo - c * C, 0), min(hi - c * C, C)
            out.extend(self._chunks[c][a * w + j:b * w:w])
        return out

    def _row(self, k):
        """Row k's values (array('d'))."""
        w, C = self._w, self.CHUNK
        a = (k % C) * w
        return self._chunks[k // C][a:a + w]

    def _at(self, k, attr):
        return self._chunks[k // self.CHUNK][(k % self.CHUNK) * self._w + self._j[attr]]

    def _np_column(self, attr):
        """attr of every row as a numpy array (a copy)."""
        j, w = self._j[attr], self._w
        parts = [np.frombuffer(c, dtype=float).reshape(-1, w)[:, j] for c in self._chunks if len(c)]
        return np.concatenate(parts) if parts else np.zeros(0)


class LineTable(_Rows):
    """The LineRecord figures the report reads (fields: some of LINE_FIELDS), one row per
    moving line by sorted source line; was a dict of records (~0.3 kB a line)."""

    def __init__(self, fields=LINE_FIELDS):
        super().__init__(fields, "line records")

    add = _Rows._add

    def value(self, i, attr, default=KeyError):
        """attr of line i; default when line i did not move (KeyError: raise it)."""
        k = _pos(self.idx, i)
        if k >= 0:
            return self._at(k, attr)
        if default is KeyError:
            raise KeyError(i)
        return default

    def span(self, first_idx, last_idx, attr):
        """attr of the moving lines first_idx..last_idx, in line order."""
        return self.column(attr, bisect_left(self.idx, first_idx), bisect_right(self.idx, last_idx))

    def span_sum(self, first_idx, last_idx, attr):
        return float(sum(self.span(first_idx, last_idx, attr)))

    def span_max(self, first_idx, last_idx, attr):
        vals = self.span(first_idx, last_idx, attr)
        return float(max(vals)) if vals else 0.0


SPAN_SUMS = ("time_t", "int_a2", "int_a2_j", "int_v2")      # what the report sums over a fence's lines
SPAN_MAXES = ("peak_v", "peak_a")                           # and takes the maximum of


def disjoint_spans(spans) -> bool:
    """spans ((first, last) line pairs) in order, each non-empty and after the one before."""
    prev = None
    for a, b in spans:
        if a > b or (prev is not None and a <= prev):
            return False
        prev = b
    return True


class SpanFigures:
    """The processed file's line figures the report reads (SPAN_SUMS, SPAN_MAXES), kept only as
    each span's sum and maximum (spans: the fences' output lines, disjoint_spans) instead of a
    row a line.  Added up in line order from 0.0 as a record comes: the bits of sum() and max()
    over the span's lines (LineTable.span_sum / span_max); a span not given raises KeyError."""

    def __init__(self, spans, on_close=None):
        self.on_close = on_close              # on_close(k): span k's figures are final
        self.first, self.last = array("q"), array("q")
        for a, b in spans:
            self.first.append(a)
            self.last.append(b)
        n = len(self.first)
        self.sums = {k: array("d", bytes(8 * n)) for k in SPAN_SUMS}
        self.maxes = {k: array("d", bytes(8 * n)) for k in SPAN_MAXES}
        self.seen = bytearray(n)              # the span has a moving line (its maxima are set)
        self._k = 0                           # the first span not yet behind the records

    def add(self, rec):
        i, k, last = rec.idx, self._k, self.last
        while k < len(last) and last[k] < i:
            k += 1
        if k != self._k:
            self._closed(k)
        if k == len(last) or self.first[k] > i:
            return
        for f, col in self.sums.items():
            col[k] += getattr(rec, f)
        first = not self.seen[k]
        self.seen[k] = 1
        for f, col in self.maxes.items():
            v = getattr(rec, f)
            if first or v > col[k]:
                col[k] = v

    def _closed(self, k):
        """Spans before k are behind the records."""
        for j in range(self._k, k) if self.on_close is not None else ():
            self.on_close(j)
        self._k = k

    def finish(self):
        """The pass is over: every span is final."""
        self._closed(len(self.last))

    def _span(self, first_idx, last_idx):
        k = bisect_left(self.first, first_idx)
        if k == len(self.first) or self.first[k] != first_idx or self.last[k] != last_idx:
            raise KeyError((first_idx, last_idx))
        return k

    def span_sum(self, first_idx, last_idx, attr):
        return self.sums[attr][self._span(first_idx, last_idx)]

    def span_max(self, first_idx, last_idx, attr):
        k = self._span(first_idx, last_idx)
        return self.maxes[attr][k] if self.seen[k] else 0.0


class MoveView:
    """One row of a MoveTable with state.Move's names (the attributes the report reads)."""
    __slots__ = ("idx", "kind", "feature", "layer", "arc") + MOVE_FIELDS

    @property
    def length_d(self) -> float:          # as state.Move.length_d
        if self.kind == st.ARC:
            return self.arc.length_d
        return math.sqrt((self.x1 - self.x0) ** 2 + (self.y1 - self.y0) ** 2 + (self.z1 - self.z0) ** 2)


class MoveTable(_Rows):
    """The state.Move of every moving line by sorted source line: its float fields (some of
    MOVE_FIELDS) a row, kind, layer, feature (a code into `features`) as columns, the arcs'
    Arc by line; was a dict of Moves (~0.4 kB a line).  get / [] / values() give MoveViews;
    np(name) a column as numpy."""

    def __init__(self, fields=MOVE_FIELDS):
        super().__init__(fields, "moves")
        self.kind = array("b")
        self.layer = array("q")
        self.feature = array("H")
        self.features = []
        self._code = {}
        self.arcs = {}
        xyz = ("x0", "y0", "z0", "x1", "y1", "z1")
        self._xyz_j = tuple(self._j.get(f, -1) for f in xyz)
        self._xyz_first = self._xyz_j == tuple(range(6))

    def add(self, m):
        code = self._code.get(m.feature)
        if code is None:
            code = self._code[m.feature] = len(self.features)
            self.features.append(m.feature)
        self._add(m)
        self.kind.append(m.kind)
        self.layer.append(m.layer)
        self.feature.append(code)
        if m.arc is not None:
            self.arcs[m.idx] = m.arc

    def __iter__(self):
        return iter(self.idx)

    def group_of(self, i):
        """The coverage's group of line i: its feature, "travel" (no extrusion), "other" (no move)."""
        k = _pos(self.idx, i)
        if k < 0:
            return "other"
        return "travel" if not self._at(k, "e") > 0.0 else self.features[self.feature[k]]

    def xy0(self, i):
        k = _pos(self.idx, i)
        if k < 0:
            raise KeyError(i)
        return self._at(k, "x0"), self._at(k, "y0")

    def _view(self, k):
        v = MoveView()
        i = v.idx = self.idx[k]
        v.kind, v.layer, v.feature = self.kind[k], self.layer[k], self.features[self.feature[k]]
        v.arc = self.arcs.get(i)
        for f, x in zip(self.fields, self._row(k)):
            setattr(v, f, x)
        return v

    def get(self, i, default=None):
        k = _pos(self.idx, i)
        return self._view(k) if k >= 0 else default

    def __getitem__(self, i):
        k = _pos(self.idx, i)
        if k < 0:
            raise KeyError(i)
        return self._view(k)

    def values(self):
        return (self._view(k) for k in range(len(self.idx)))

    def rows_of(self, first_idx, last_idx):
        """The positions of the moves of lines first_idx..last_idx, in line order."""
        return range(bisect_left(self.idx, first_idx), bisect_right(self.idx, last_idx))

    def length_at(self, k):
        """The move at position k's length_d (MoveView.length_d, the same floats: no view made)."""
        if self.kind[k] == st.ARC:
            return self.arcs[self.idx[k]].length_d
        x0, y0, z0, x1, y1, z1 = self.xyz_at(k)
        return math.sqrt((x1 - x0) ** 2 + (y1 - y0) ** 2 + (z1 - z0) ** 2)

    def xyz_at(self, k):
        """(x0, y0, z0, x1, y1, z1) of the move at position k (a table of MOVE_FIELDS)."""
        c = self._chunks[k // self.CHUNK]
        a = (k % self.CHUNK) * self._w
        if self._xyz_first:
            return c[a:a + 6]
        if -1 in self._xyz_j:
            raise KeyError("this move table keeps no end points (x1, y1, z1)")
        return tuple(c[a + j] for j in self._xyz_j)

    def np(self, name):
        """A column as a numpy array: idx, kind, layer or a field."""
        if name in self._j:
            return self._np_column(name)
        col = getattr(self, name)
        return np.frombuffer(col, dtype={"q": np.int64, "b": np.int8}[col.typecode]) if len(col) else np.zeros(0)


class Trace:
    """Figures of one file as the firmware model executes it."""

    def __init__(self, res, lines, moves, blocks, n_lines):
        self.res = res              # SimResult
        self.lines = lines          # LineTable: the LineRecord figures by line
        self.moves = moves          # MoveTable: the state.Move of every moving line
        self.blocks = blocks        # field -> np.ndarray (BLOCK_FIELDS), in execution order
        self.n_lines = n_lines      # lines in the file

    def block_range(self, first_idx, last_idx):
        """Slice of the block arrays for source lines first_idx..last_idx (0-based)."""
        idx = self.blocks["idx"]
        lo = int(np.searchsorted(idx, first_idx, side="left"))
        hi = int(np.searchsorted(idx, last_idx, side="right"))
        return slice(lo, hi)

    kinetic = None               # array('d') of kinetic_term by block when the blocks are not kept
    _layer = None                # (layer, its block columns) taken from a replay

    def take_blocks(self, ft, layer):
        """The blocks a FenceTrace of the same file kept (its spans' and the layer's)."""
        self.blocks = ft.blocks
        self._layer = (layer, ft.layer_blocks(layer))

    def span_blocks(self, first_idx, last_idx, min_seg_t):
        """(blocks, shortest block time or None, blocks shorter than min_seg_t at their nominal
        speed) of source lines first_idx..last_idx."""
        sl, b = self.block_range(first_idx, last_idx), self.blocks
        seg_t = b["accel_t"][sl] + b["cruise_t"][sl] + b["decel_t"][sl]
        below = int(np.sum(b["d"][sl] < min_seg_t * b["nominal_v"][sl])) if min_seg_t > 0 else 0
        return int(sl.stop - sl.start), float(seg_t.min()) if len(seg_t) else None, below

    def kinetic_terms(self, mass_kg):
        """Each block's mass along it (mass_kg(ux, uy)) times its int v^2 dt."""
        if self.kinetic is not None:
            return np.frombuffer(self.kinetic, dtype=float) if len(self.kinetic) else np.zeros(0)
        b = self.blocks
        d = np.maximum(b["d"], 1e-12)
        return mass_kg((b["x1"] - b["x0"]) / d, (b["y1"] - b["y0"]) / d) * b["v2_int"]

    def layer_blocks(self, layer):
        """The block columns of the layer's extruding moves."""
        if self._layer is not None:
            if self._layer[0] != layer:
                raise KeyError(f"layer {layer}: its blocks were not kept")
            return self._layer[1]
        b, mv = self.blocks, self.moves
        idx = b["idx"]
        k = np.searchsorted(mv.np("idx"), idx)          # every block's move (its line)
        sel = (mv.np("layer")[k] == layer) & (mv.np("e")[k] > 0) if len(idx) else np.zeros(0, bool)
        return {f: col[sel] for f, col in b.items()}

    def line_sum(self, first_idx, last_idx, attr):
        return self.lines.span_sum(first_idx, last_idx, attr)

    def line_max(self, first_idx, last_idx, attr):
        return self.lines.span_max(first_idx, last_idx, attr)


def trace_file(path, profile, ringing=False, processed=False, spans=None, mass_xy=None) -> Trace:
    """ringing: also keep the rows of the commanded motion ringing.py solves (Trace.ring_rows,
    from the same firmware-model pass, with the idle row at both ends: ringing.Rows.padded);
    or a sink of them (on_block and rest, as ringing.Rows'), given the rows instead.  processed: keep only the line and move fields the
    report reads of the processed file (PROCESSED_LINE_FIELDS, PROCESSED_MOVE_FIELDS).  spans
    (with processed; disjoint_spans): the line figures only as these spans' sums and maxima
    (SpanFigures: line_sum / line_max of a span given, nothing by line).  mass_xy (the moving
    masses of X and Y, kg): no block columns, only each block's kinetic_term (Trace.kinetic;
    take_blocks() gives it the blocks the report draws)."""
    from .. import ringing as rg
    sink = ringing if hasattr(ringing, "on_block") else None      # rows given to a sink, not kept
    ring = sink or (rg.Rows.padded() if ringing else None)
    ring_line = ring_block = None
    if ring is not None:
        ring_line, ring_block, ring_dwell = rg.hooks(ring)
    if processed and spans is not None:
        lines = SpanFigures(spans)
    else:
        lines = LineTable(PROCESSED_LINE_FIELDS if processed else LINE_FIELDS)
    moves = MoveTable(PROCESSED_MOVE_FIELDS if processed else MOVE_FIELDS)
    cols = {k: array("d") for k in BLOCK_FIELDS} if mass_xy is None else None
    kinetic = array("d")
    cursor = [0.0, 0.0]
    count = [0]

    def feed():
        for idx, raw, ev in st.events(path, profile):
            count[0] = idx + 1
            if ev is not None and type(ev) is st.Move:
                moves.add(ev)
            yield idx, raw, ev

    def on_line(rec):
        lines.add(rec)
        if ring_line is not None:
            ring_line(rec)

    def on_block(b):
        if b.first:
            cursor[0], cursor[1] = moves.xy0(b.idx)
        row = block_row(b, cursor)
        if cols is None:
            kinetic.append(kinetic_term(mass_xy, row))
        else:
            for k, v in zip(BLOCK_FIELDS, row):
                cols[k].append(v)
        if ring_block is not None:
            ring_block(b)

    events = feed() if ring is None else rg.wrap_events(feed(), ring_dwell)
    res = simulate_events(events, profile, on_line=on_line, on_block=on_block)
    tr = Trace(res, lines, moves, _block_arrays(cols) if cols is not None else None, count[0])
    if cols is None:
        tr.kinetic = kinetic
    if ring is not None and sink is None:
        ring.close_padded()
    tr.ring_rows = ring.items if ring is not None and sink is None else None
    return tr


class FenceTrace(Trace):
    """The processed file as the report reads it, made as the pass goes (trace_fences): the
    line figures of the fences' spans (SpanFigures); of the blocks, no column a block
    (120 B) but, per span, what the stroke rows read (span_blocks); each block's kinetic
    term (kinetic_terms: np.sum over them is the whole file's); every field of the blocks
    of the spans kept (the representative strokes' curves: `blocks`, block_range) and of
    the extruding blocks of the layers the layer map may draw (a LayerPick's wanted layers;
    dropped once it says a layer cannot be drawn)."""

    def __init__(self, spans, keep, pick, mass_xy, min_seg_t):
        self.lines = SpanFigures(spans, on_close=self._span_closed)
        self.moves = None
        n = len(self.lines.first)
        self.n_blocks, self.below = array("q", bytes(8 * n)), array("q", bytes(8 * n))
        self.shortest = array("d", bytes(8 * n))
        self.keep = bytearray(n)
        for k in keep:
            self.keep[k] = 1
        self.kept = array("d")                    # rows of BLOCK_FIELDS of the kept spans' blocks
        self.layers = {}                          # layer -> rows of its extruding blocks
        self.pick, self.mass_xy, self.min_seg_t = pick, mass_xy, min_seg_t
        self.kinetic = array("d")
        self._k = 0

    def _span_closed(self, k):
        for layer in self.pick.closed(k, self.lines.sums["int_a2"][k] + self.lines.sums["int_a2_j"][k]):
            self.layers.pop(layer, None)

    def add(self, row, e, layer):
        """One block: row its BLOCK_FIELDS values, e and layer its move's."""
        i, d = row[0], row[5]
        self.kinetic.append(kinetic_term(self.mass_xy, row))
        k, last = self._k, self.lines.last
        while k < len(last) and last[k] < i:
            k += 1
        self._k = k
        if k < len(last) and self.lines.first[k] <= i:
            seg_t = row[10] + row[11] + row[12]
            if not self.n_blocks[k] or seg_t < self.shortest[k]:
                self.shortest[k] = seg_t
            self.n_blocks[k] += 1
            if self.min_seg_t > 0 and d < self.min_seg_t * row[14]:
                self.below[k] += 1
            if self.keep[k]:
                self.kept.extend(row)
        if e > 0.0 and self.pick.wanted(layer):
            rows = self.layers.get(layer)
            if rows is None:
                rows = self.layers[layer] = array("d")
            rows.extend(row)

    def finish(self, res, n_lines):
        self.lines.finish()
        self.res, self.n_lines = res, n_lines
        self.blocks = _row_columns(self.kept)
        self.kept = None

    def span_blocks(self, first_idx, last_idx, min_seg_t):
        k = self.lines._span(first_idx, last_idx)
        n = self.n_blocks[k]
        return n, self.shortest[k] if n else None, self.below[k]

    def kinetic_terms(self, mass_kg):
        return np.frombuffer(self.kinetic, dtype=float) if len(self.kinetic) else np.zeros(0)

    def layer_blocks(self, layer):
        rows = self.layers.get(layer)
        if rows is None and not self.pick.wanted(layer):
            raise KeyError(f"layer {layer}: its blocks were not kept")
        return _row_columns(rows if rows is not None else array("d"))


def block_row(b, cursor):
    """A planner block as the trace's row (BLOCK_FIELDS' order: its start and end point, the
    cursor moved to its end, and its ∫v² dt, v2), from the block's start point cursor [x, y]."""
    x0, y0 = cursor
    x1, y1 = x0 + b.d * b.ux, y0 + b.d * b.uy
    cursor[0], cursor[1] = x1, y1
    sv, cv, ev = b.start_v, b.cruise_v, b.end_v
    v2 = (b.accel_t * (sv * sv + sv * cv + cv * cv) + b.decel_t * (ev * ev + ev * cv + cv * cv)) / 3.0 \
        + b.cruise_t * cv * cv
    return (b.idx, x0, y0, x1, y1, b.d, sv, cv, ev, b.accel, b.accel_t, b.cruise_t, b.decel_t, v2, b.nominal_v)


def kinetic_term(mass_xy, row):
    """A block's mass along it times its int v^2 dt (row: its BLOCK_FIELDS values; mass_xy:
    the moving masses of X and Y, kg), as Trace.kinetic_terms computes it over the columns."""
    x0, y0, x1, y1, d = row[1:6]
    mx, my = mass_xy
    d = d if d >= 1e-12 else 1e-12
    ux, uy = (x1 - x0) / d, (y1 - y0) / d
    return (mx * ux * ux + my * uy * uy) * row[13]


def _row_columns(rows):
    """Rows of BLOCK_FIELDS (one array('d')) as the block columns."""
    m = np.frombuffer(rows, dtype=float).reshape(-1, len(BLOCK_FIELDS)) if len(rows) else \
        np.zeros((0, len(BLOCK_FIELDS)))
    return {k: (m[:, j].astype(int) if k == "idx" else m[:, j].copy()) for j, k in enumerate(BLOCK_FIELDS)}


def trace_fences(path, profile, spans, keep, pick, mass_xy, ring=None) -> FenceTrace:
    """The processed file's FenceTrace (spans: disjoint_spans; keep: the indices of the spans
    whose blocks are kept; pick: a LayerPick; mass_xy: the moving masses of X and Y, kg).
    ring: a sink of its ringing rows (ringing.Rows' on_block and rest)."""
    from collections import deque

    from .. import ringing as rg
    ft = FenceTrace(spans, keep, pick, mass_xy, profile.min_segment_time_t)
    ring_line = ring_block = ring_dwell = None
    if ring is not None:
        ring_line, ring_block, ring_dwell = rg.hooks(ring)
    recent = deque()                      # (idx, x0, y0, e, layer) of the moves not yet planned
    cursor = [0.0, 0.0]
    count = [0]
    Move = st.Move

    def feed():
        for idx, raw, ev in st.events(path, profile):
            count[0] = idx + 1
            if ev is not None and type(ev) is Move:
                recent.append((ev.idx, ev.x0, ev.y0, ev.e, ev.layer))
            yield idx, raw, ev

    def on_line(rec):
        ft.lines.add(rec)
        if ring_line is not None:
            ring_line(rec)

    def on_block(b):
        while recent[0][0] < b.idx:       # the block's move (blocks come in line order)
            recent.popleft()
        _i, mx0, my0, e, layer = recent[0]
        if b.first:
            cursor[0], cursor[1] = mx0, my0
        ft.add(block_row(b, cursor), e, layer)
        if ring_block is not None:
            ring_block(b)

    events = feed() if ring is None else rg.wrap_events(feed(), ring_dwell)
    res = simulate_events(events, profile, on_line=on_line, on_block=on_block)
    ft.finish(res, count[0])
    return ft


def _block_arrays(cols):
    """The block columns (array('d') by field, emptied) as numpy arrays, one field at a time:
    never more than one column held twice (copying them all at once held every block twice)."""
    blocks = {}
    for k in BLOCK_FIELDS:
        v = cols.pop(k)
        a = np.frombuffer(v, dtype=float) if len(v) else np.zeros(0)
        blocks[k] = a.astype(int) if k == "idx" else a.copy()
        del a, v
    return blocks


def count_lines(path) -> int:
    with open(path, "rb") as fh:
        return sum(1 for _ in fh)


def profile_points(blocks, sl, t0=0.0):
    """As-executed speed and tangential acceleration of blocks[sl] against time.

    Returns (t_v, v, t_a, a): piecewise-linear speed knots (mm/s) and a step function of
    acceleration (mm/s^2, two points per phase so it plots as steps), t from t0 (s)."""
    tv, vv, ta, aa = [], [], [], []
    t = t0
    for k in range(sl.start, sl.stop):
        sv, cv, ev = blocks["start_v"][k], blocks["cruise_v"][k], blocks["end_v"][k]
        acc = blocks["accel"][k]
        at, ct, dt = blocks["accel_t"][k], blocks["cruise_t"][k], blocks["decel_t"][k]
        for dur, v_end, a in ((at, cv, acc), (ct, cv, 0.0), (dt, ev, -acc)):
            if dur <= 0.0:
                continue
            if not tv:
                tv.append(t)
                vv.append(sv)
            ta += [t, t + dur]
            aa += [a, a]
            t += dur
            tv.append(t)
            vv.append(v_end)
    return np.array(tv), np.array(vv), np.array(ta), np.array(aa)
