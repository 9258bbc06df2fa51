"""The strokes' fields the steps after planning read, as compact per-stroke columns
(StrokeColumns): the strokes' first-line order and output lines (pipeline.stroke_lines),
the summary's per-stroke rows, by-kind sums and coverage (summary.build_summary).

Each column made once, when planning has set its field for good (corners.py lowers v0 and
v1 in plan_inputs; nothing after writes them), from the strokes by compiled gathers
(line_spans, stroke_fields, objfields.codes: no Python object a value): the pipeline makes
the lines with the first measure and the rest once the passes are done (add_fields).  The steps after
planning then need no stroke object: a windowed pipeline can let a window's strokes go
once it is planned and written, keeping these (~90 bytes a stroke).

A column reads back the same values of the same types as the attributes: a float column is
an array only where every value is a float (the array's tolist: those floats), else the
list of the values; a text column (feature, kind, layer) is a code a stroke into the table
of its distinct values (values equal as dict keys are one: str, int and None here)."""
from __future__ import annotations

from operator import attrgetter

import numpy as np

from . import objfields
from .distinct import value_codes
from .stored_strokes import stored
from .strokes import Stroke, line_spans, stroke_fields

FLOATS = ("length_d", "v0", "v1", "v_feed", "int_v2")     # the summary's rows and sums
CODED = ("feature", "kind", "layer")


class StrokeColumns:
    """Per-stroke columns (by stroke index) of the fields read after planning:
    first_idx, last_idx, n_moves (int64 arrays); FLOATS (float64 arrays, or lists where a
    value is not a float); CODED: code_of[name] ({value: code}, in the order first met) and
    codes[name] (an intp array)."""

    __slots__ = ("n", "first_idx", "last_idx", "n_moves", "floats", "code_of", "codes")

    def __init__(self, strokes, fields=True):
        """fields False: the lines alone (what measure reads), the rest by add_fields.
        strokes: a list, or kept in a StrokeStore (stored: read from its records)."""
        self.n = len(strokes)
        self.first_idx, self.last_idx = line_columns(strokes)
        self.n_moves, self.floats, self.code_of, self.codes = None, {}, {}, {}
        if fields:
            self.add_fields(strokes)

    def add_fields(self, strokes):
        """The columns besides the lines (the summary's), of the same strokes: the pipeline
        makes them once the passes' memory is let go (held through measure, they raised
        its peak on the rectilinear plate, 81 -> 85 MB)."""
        assert len(strokes) == self.n
        got = stored(strokes)
        if got is not None:
            self._add_stored(*got)
            return
        self.n_moves = n_moves(strokes, (self.first_idx, self.last_idx))
        self.floats = _float_columns(strokes, FLOATS)
        for name in CODED:
            self.code_of[name], self.codes[name] = _coded(strokes, name)

    def _add_stored(self, store, window):
        """add_fields of strokes kept in a StrokeStore: read from its records' fields, no
        stroke made (_stored_columns), where every value is one those columns hold; else
        each window's strokes made and read as a list's (_add_loaded)."""
        self.n_moves = self.last_idx - self.first_idx + 1         # (a store holds Stroke only)
        got = _stored_columns(store)
        if got is None:
            self._add_loaded(store, window)
            return
        self.floats, coded = got
        for name, (code_of, codes) in coded.items():
            self.code_of[name], self.codes[name] = code_of, codes

    def _add_loaded(self, store, window):
        """The float and coded columns of strokes kept in a StrokeStore, each window's
        strokes made, read as a list's and let go (the same columns: the floats joined, each
        coded field's codes in one dict, filled in the order first met as over the whole
        list)."""
        parts = {name: [np.zeros(0)] for name in FLOATS}           # (no stroke: empty float columns)
        got = {name: [np.zeros(0, np.intp)] for name in CODED}
        for name in CODED:
            self.code_of[name] = {}
        for lo in range(0, self.n, window):
            win = store.load(lo, lo + window)
            for name, col in _float_columns(win, FLOATS).items():
                parts[name].append(col)
            for name in CODED:
                got[name].append(_coded_into(win, name, self.code_of[name]))
            del win
        for name, cols in parts.items():
            self.floats[name] = (np.concatenate(cols) if all(isinstance(c, np.ndarray) for c in cols)
                                 else [x for c in cols for x in (c.tolist() if isinstance(c, np.ndarray) else c)])
        for name, codes in got.items():
            self.codes[name] = np.concatenate(codes)

    @classmethod
    def of(cls, strokes):
        """strokes as columns: a StrokeColumns as it is, a list of strokes read into one."""
        return strokes if isinstance(strokes, cls) else cls(strokes)

    def __len__(self):
        return self.n

    def float_values(self, name, rows):
        """The values of float field `name` at rows (an intp array), as a list (Python
        floats, or the objects the strokes held)."""
        col = self.floats[name]
        if isinstance(col, np.ndarray):
            return col[rows].tolist()
        return objfields.items(col, rows)

    def float_array(self, name, rows):
        """The float field `name` at rows, a float64 array."""
        col = self.floats[name]
        if isinstance(col, np.ndarray):
            return col[rows]
        return np.fromiter(objfields.items(col, rows), float, len(rows))

    def values(self, name, rows):
        """The coded field `name` (feature, kind, layer) at rows, a list of the values."""
        return objfields.items(list(self.code_of[name]), self.codes[name][rows])


def line_columns(strokes):
    """(first_idx, last_idx) of every stroke, two int64 arrays, of a StrokeColumns, a
    list of strokes or strokes kept in a StrokeStore (stored: its records' columns,
    no stroke made)."""
    if isinstance(strokes, StrokeColumns):
        return strokes.first_idx, strokes.last_idx
    got = stored(strokes)
    if got is not None:
        return got[0].lines()          # (its lines side: 32 bytes a record read, not the records)
    return line_spans(strokes)


def first_lines(strokes):
    """line_columns(strokes)[0] (of strokes kept in a StrokeStore: its lines side read)."""
    got = stored(strokes)
    return line_columns(strokes)[0] if got is None else got[0].column("first_idx")


def n_moves(strokes, spans=None):
    """Every stroke's n_moves, an int64 array (Stroke's from its lines in rows, spans:
    line_spans(strokes) where the caller has them; another kind of stroke: its own
    n_moves)."""
    n = len(strokes)
    if n and set(map(type, strokes)) == _STROKE_ONLY:       # (the type test in C: ~35 k strokes)
        lo, hi = spans if spans is not None else line_spans(strokes)
        return hi - lo + 1
    return np.fromiter((s.n_moves for s in strokes), np.int64, n)


_STROKE_ONLY = {Stroke}


def _float_columns(strokes, names):
    """{name: float64 array where every stroke's value is a float, else the list of the
    values}, read in one compiled pass where the strokes are StrokeBase."""
    got = stroke_fields(strokes, names)
    out = {}
    for j, name in enumerate(names):
        if got is not None and not got[1][:, j].any():        # (kind 0: a float, every one)
            out[name] = got[0][:, j]                          # (a view: no copy of the columns made)
            continue
        vals = list(map(attrgetter(name), strokes))
        out[name] = np.array(vals, float) if set(map(type, vals)) <= _FLOAT_ONLY else vals
    return out


_FLOAT_ONLY = {float}


def _coded(strokes, name):
    """({value: code}, in the order first met; each stroke's code) of field `name` (kind:
    "line" where a stroke has none, as the summary read it)."""
    code_of = {}
    code = objfields.codes(strokes, name, code_of, add=True)
    if code is not None:
        return code_of, code
    get = kind_of if name == "kind" else attrgetter(name)
    return value_codes(list(map(get, strokes)))


def _coded_into(strokes, name, code_of):
    """Each stroke's code of field `name` (as _coded reads it) in code_of, a value not in it
    added with the next code (the dict carried from window to window)."""
    code = objfields.codes(strokes, name, code_of, add=True)
    if code is not None:
        return code
    get = kind_of if name == "kind" else attrgetter(name)
    vals = list(map(get, strokes))
    for v in vals:
        code_of.setdefault(v, len(code_of))
    return np.fromiter(map(code_of.__getitem__, vals), np.intp, len(vals))


# StrokeStore.fields' kinds (ints) of a value: a float, None, a shared object (feature,
# kind: a str, its table index), an int in an object slot (layer: its int64 bits)
_K_FLOAT, _K_NONE, _K_SHARED, _K_INT = 0, 1, 5, 6
_SHARED = ("feature", "kind")


def _stored_columns(store):
    """(FLOATS' columns, {CODED name: (code_of, codes)}) of every record of store as
    _add_loaded makes them of its strokes, read from the records' fields (StrokeStore.fields
    a batch at a time: the store's fields side, no record read) with no stroke made
    (windowed gyroid plate: ~0.01 s against ~0.027 s); None where a value is not one these
    hold (a float field not a float, feature or kind neither a shared str nor None, a
    layer not an int): the caller then makes the strokes."""
    n = len(store)
    names = ("layer",) + FLOATS + _SHARED      # (the store's fields side's order: its columns as they are)
    nf = len(FLOATS)
    floats = {name: np.empty(n) for name in FLOATS}
    tokens = {name: np.empty(n, np.int64) for name in _SHARED}    # a table index, -1 for None
    layers = np.empty(n, np.int64)
    at = 0
    for vals, kinds in store.fields(np.arange(n, dtype=np.int64), names, ints=True):
        m = len(vals)
        shared = kinds[:, 1 + nf:]
        if ((kinds[:, 1:1 + nf] != _K_FLOAT).any() or not ((shared == _K_SHARED) | (shared == _K_NONE)).all()
                or (kinds[:, 0] != _K_INT).any()):
            return None
        layers[at:at + m] = vals[:, 0].view(np.int64)
        for j, name in enumerate(FLOATS, 1):
            floats[name][at:at + m] = vals[:, j]
        for j, name in enumerate(_SHARED):
            tokens[name][at:at + m] = np.where(shared[:, j] == _K_SHARED, vals[:, 1 + nf + j], -1.0)
        at += m
    coded = {name: _first_met_codes(tokens.pop(name), _shared_value(store)) for name in _SHARED}
    coded["layer"] = _first_met_codes(layers, int)
    return floats, coded


def _shared_value(store):
    """A token of _stored_columns (a table index, -1: None) -> its value."""
    return lambda k: None if k < 0 else store.shared(k)


def _first_met_codes(tokens, value):
    """({value(token): code}, in the order the tokens are first met; each token's code,
    an intp array), tokens an int64 array, tokens of equal values one code (as a dict
    filled value by value in that order).  By the runs of equal tokens (a layer's or a
    feature's strokes follow each other): their tokens coded by one compiled pass."""
    code_of = {}
    if not tokens.size:
        return code_of, np.zeros(0, np.intp)
    starts = np.flatnonzero(tokens[1:] != tokens[:-1]) + 1
    run_tokens = tokens[np.r_[0, starts]].tolist()
    by_token, run_codes = value_codes(run_tokens)
    code = np.array([code_of.setdefault(value(k), len(code_of)) for k in by_token], np.intp)
    return code_of, np.repeat(code[run_codes], np.diff(np.r_[0, starts, tokens.size]))


def kind_of(s):
    return getattr(s, "kind", "line")
