"""The report's per-stroke rows held as columns (a dict a stroke with nested dicts and a float
object a figure took ~1.1 kB a stroke: ~90 MB on the rectilinear plate).

    rows = StrokeTable()
    rows.append(row)           # the row dict data._stroke_rows makes (it is not kept)
    rows.col("time_s", "before")   # one figure of every row, a list in row order
    rows[i], iter(rows)        # the row dicts again, made on demand, equal to those appended

Each figure is a column of its type (float 'd', int 'q', a string as a code); a value of
another type (None, a 0 that is an int where the rest are floats) is kept aside by row, so
the rows made again are the rows appended, value, type and key order (the JSON's bytes)."""
from __future__ import annotations

from array import array

_MISSING = object()          # the row has no such key (e.g. the law's figures without a summary)


class _Column:
    """One figure of every row: values of the column's type in an array, the rest by row."""

    def __init__(self, kind):
        self.kind = kind                     # float, int or str
        self.vals = array({float: "d", int: "q", str: "I"}[kind])
        self.codes, self.names = {}, []      # str: value -> code, code -> value
        self.other = {}                      # row -> a value not of the column's type

    def append(self, row, v):
        vals = self.vals
        if type(v) is not self.kind:
            self.other[row] = v
            vals.append(0)
        elif self.kind is str:
            c = self.codes.get(v)
            if c is None:
                c = self.codes[v] = len(self.names)
                self.names.append(v)
            vals.append(c)
        else:
            vals.append(v)

    def __getitem__(self, row):
        v = self.other.get(row, _MISSING)
        if v is not _MISSING or row in self.other:
            return v
        return self.names[self.vals[row]] if self.kind is str else self.vals[row]

    def tolist(self):
        out = self.vals.tolist()
        if self.kind is str:
            names = self.names
            out = [names[c] for c in out]
        for row, v in self.other.items():
            out[row] = v
        return out


def _kind(v):
    return type(v) if type(v) in (float, int, str) else float


class StrokeTable:
    """Rows of the same keys (nested dicts one level deep) as columns by key path; a row's
    layout (its key paths in order) is kept once for all rows that share it."""

    def __init__(self):
        self.cols = {}                       # key path -> _Column
        self.layouts, self._layout_code = [], {}
        self.layout = array("H")             # row -> its layout's code
        self.n = 0

    def append(self, row: dict):
        paths = []
        for k, v in row.items():
            if type(v) is dict:
                for k2, v2 in v.items():
                    paths.append(((k, k2), v2))
            else:
                paths.append(((k,), v))
        key = tuple(p for p, _ in paths)
        code = self._layout_code.get(key)
        if code is None:
            code = self._layout_code[key] = len(self.layouts)
            self.layouts.append(key)
        self.layout.append(code)
        i = self.n
        for p, v in paths:
            col = self.cols.get(p)
            if col is None:
                col = self.cols[p] = _Column(_kind(v))
                for r in range(i):           # rows before without this key
                    col.append(r, _MISSING)
            col.append(i, v)
        for p, col in self.cols.items():     # keys this row has not
            if len(col.vals) == i:
                col.append(i, _MISSING)
        self.n = i + 1

    def __len__(self):
        return self.n

    def col(self, *path):
        """The value at key path of every row, in row order (_MISSING where a row has none)."""
        col = self.cols.get(tuple(path))
        return col.tolist() if col is not None else [_MISSING] * self.n

    def has(self, *path):
        """Whether every row has key path."""
        return all(v is not _MISSING for v in self.col(*path))

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[k] for k in range(*i.indices(self.n))]
        if i < 0:
            i += self.n
        if not 0 <= i < self.n:
            raise IndexError(i)
        row = {}
        for p in self.layouts[self.layout[i]]:
            v = self.cols[p][i]
            if len(p) == 1:
                row[p[0]] = v
            else:
                row.setdefault(p[0], {})[p[1]] = v
        return row

    def __iter__(self):
        return (self[i] for i in range(self.n))

    def __eq__(self, other):                 # as the list of rows it stands for
        if isinstance(other, (StrokeTable, list)):
            return len(self) == len(other) and all(a == b for a, b in zip(self, other))
        return NotImplemented

    __hash__ = None

    def __repr__(self):
        return repr(list(self))

    def rows(self, idx):
        """The row dicts of rows idx."""
        return [self[i] for i in idx]


class RowStream(list):
    """A StrokeTable as json's encoder (the pure-Python one, json.dump's) reads a list: its
    rows made one at a time as written, never all at once."""

    def __init__(self, table):
        super().__init__()
        self.table = table

    def __iter__(self):
        return iter(self.table)

    def __len__(self):
        return len(self.table)
