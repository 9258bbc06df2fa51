"""Fields of many objects read in one compiled pass (laws/_curvecore.c obj_floats,
obj_codes, obj_ids), in place of np.fromiter(map(attrgetter(name), objs), ...): ~500
instructions an element through map, attrgetter and numpy's conversion of each value, a
few dozen in C.  Each function answers None where the core is not built or a value is
not of the one type whose conversion it repeats (then the caller reads them as before:
the same values, the same errors)."""
from __future__ import annotations

import os
from operator import attrgetter

import numpy as np

from . import native

_CORE, _ = native.load("_gcode_opt_curvecore",
                       os.path.join(os.path.dirname(os.path.abspath(__file__)), "laws", "_curvecore.c"),
                       "curve core")
_FLOATS = getattr(_CORE, "obj_floats", None)
_CODES = getattr(_CORE, "obj_codes", None)
_IDS = getattr(_CORE, "obj_ids", None)
_LIST_PUT = getattr(_CORE, "list_put", None)
_LIST_TAKE = getattr(_CORE, "list_take", None)
# obj_codes / obj_ids write C longs: where numpy's intp is another C type (Windows: 'q'),
# they are not used (the callers read the values as before) rather than refusing the buffer
if memoryview(np.empty(0, np.intp)).format != "l":
    _CODES = _IDS = _LIST_PUT = _LIST_TAKE = None


def floats(objs, names):
    """np.array([[getattr(o, f) for f in names] for o in objs], float) (a (len(objs),
    len(names)) array) where objs is a list and each value a float, an np.float64 (its
    double is a float's) or a bool, else None."""
    if _FLOATS is None or type(objs) is not list:
        return None
    out = np.empty((len(objs), len(names)))
    return out if _FLOATS(objs, tuple(names), out, np.float64) else None


def float_col(objs, name):
    """np.fromiter(map(attrgetter(name), objs), float, len(objs)) where each value is a
    float, an np.float64 or a bool, else None."""
    got = floats(objs, (name,))
    return None if got is None else got.reshape(-1)


def codes(objs, name, code_of, add=False):
    """np.fromiter(map(code_of.__getitem__, map(attrgetter(name), objs)), np.intp) (name
    None: of the objects themselves; code_of None: the values themselves, ints), a value
    missing from code_of added to it with the next code len(code_of) when add (the dict is
    then changed, in the order the values come), else None (code_of as far as it got)."""
    if _CODES is None or type(objs) is not list:
        return None
    out = np.empty(len(objs), np.intp)
    return out if _CODES(objs, name, code_of, add, out) else None


def ids(objs, name):
    """(the distinct objects, by identity, that are the objects' attribute name, in the
    order first met; each object's place in that list, an intp array), or None."""
    if _IDS is None or type(objs) is not list:
        return None
    which = np.empty(len(objs), np.intp)
    firsts = _IDS(objs, name, which)
    return None if firsts is None else (firsts, which)


def by_identity(objs, name):
    """ids(objs, name), or where it answers None the same by Python's reads: (the distinct
    objects, by identity, that are the objects' attribute name, in the order first met;
    each object's place in that list, an intp array)."""
    got = ids(objs, name)
    if got is not None:
        return got
    vals = list(map(attrgetter(name), objs))
    first = dict(zip(map(id, vals), vals))          # id -> object, in the order first met
    at = dict(zip(first, range(len(first))))
    return list(first.values()), np.fromiter(map(at.__getitem__, map(id, vals)), np.intp, len(vals))


_FILL = Ellipsis        # list_put's `at` for one value put at every row


def _int_rows(rows):
    """rows as list_put reads them (a C-contiguous intp array), or None."""
    return rows if type(rows) is np.ndarray and rows.dtype == np.intp and rows.flags.c_contiguous else None


def put_at(dst, rows, src, at=None):
    """for k, i in enumerate(rows): dst[i] = src[at[k]] (at None: src[k]) in one compiled
    pass (~15 instructions a row; the Python loop ~190): dst and src lists, rows and at
    intp arrays (at None: src as long as rows).  The same items and, on a row out of
    range, the same IndexError after the same rows.  False (nothing done) where the core
    is not built or the arguments are not of these types."""
    rows = _int_rows(rows)
    if (_LIST_PUT is None or rows is None or type(dst) is not list or type(src) is not list
            or (at is None and len(src) != rows.size)):
        return False
    if at is not None:
        at = _int_rows(at)
        if at is None or at.size != rows.size:
            return False
    _LIST_PUT(dst, rows, src, at)
    return True


def fill_at(dst, rows, value):
    """for i in rows: dst[i] = value, as put_at (False: nothing done)."""
    rows = _int_rows(rows)
    if _LIST_PUT is None or rows is None or type(dst) is not list:
        return False
    _LIST_PUT(dst, rows, value, _FILL)
    return True


def items(src, rows):
    """[src[i] for i in rows] (rows an int array; src a list, or any sequence): take's one
    compiled pass where it can, else item by item (the same items, the same IndexError)."""
    rows = np.asarray(rows, np.intp)
    got = take(src, rows)
    return got if got is not None else list(map(src.__getitem__, rows.tolist()))


def take(src, rows):
    """[src[i] for i in rows] (src a list, rows an intp array) in one compiled pass (the
    same IndexError where a row is out of range), or None where not built or not of
    these types."""
    rows = _int_rows(rows)
    if _LIST_TAKE is None or rows is None or type(src) is not list:
        return None
    return _LIST_TAKE(src, rows)
