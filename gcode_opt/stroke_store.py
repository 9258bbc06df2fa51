"""StrokeStore: strokes spilled as compact records (a temporary file, or bytes in memory) and
restored as new Stroke objects, a window at a time.

The strokes are the largest thing the run keeps (gyroid plate: 22 MB of its peak for 35 k
strokes); a windowed pipeline keeps only a window of them as objects.  A record holds every
field of strokes.FIELDS (the record layout: firmware/_core.c's "stroke store records"):

- the StrokeBase doubles bit for bit (None of a None-able one kept apart from a NaN: its
  `has` bit), first_idx / last_idx as int64;
- each object field by a tag and a payload: unset, None, False, True, a float (its bits), an
  int (int64), a shared object (a str or a state.Limits: its index in the store's intern
  table, restored as that SAME object), an array("d") (_ends) or a Points (pts) with its
  doubles, a state.Arc with its fields (a new Arc of equal fields);
- curv is a cache: restored None; chain_T: None, or a new EMPTY chains.ChainMemo (the memos
  themselves are kept apart, a later step).
A value of any other type (or a StrokeBase field kept as an object: a np.float64, an int in
a float field, a deleted field) is refused with a TypeError naming the stroke and field.

The compiled core (store_encode / store_decode / store_column) reads and fills the
StrokeBase directly; without it (GCODE_OPT_PURE_PYTHON=1, not built) the Python twin below
writes and reads the same bytes through getattr / setattr.
"""
from __future__ import annotations

import gc
import os
import struct
import tempfile
from array import array

import numpy as np

from . import strokes as stm
from .state import Arc, Limits

# the record's fields, in record order (firmware/_core.c: SD_NAMES, SI_NAMES, SO_NAMES)
D_NAMES = ("x0", "y0", "ux", "uy", "length_d", "e_per_mm", "v0", "v1", "time_t", "int_a2", "int_v2",
           "_pux", "_puy", "_nux", "_nuy", "_ss_e")
D_NONE0 = 11                 # from _pux on a double may be None
I_NAMES = ("first_idx", "last_idx")
O_NAMES = ("z", "_ends", "v_feed", "accel", "feature", "layer", "e_rel", "lim", "kind", "arc", "pts", "curv",
           "_ss_a", "_ss_c", "chain_T", "v0_fw", "v1_fw", "corner_cmd0", "corner_cmd1")
FIELD_CODE = {nm: k for k, nm in enumerate(D_NAMES + I_NAMES + O_NAMES)}
assert sorted(FIELD_CODE) == sorted(stm.FIELDS)
# column(): the numeric fields and their column's dtype (a bool field as int64 0 / 1)
INT_COLUMNS = frozenset(("first_idx", "last_idx", "layer", "e_rel", "corner_cmd0", "corner_cmd1"))
FLOAT_COLUMNS = frozenset(D_NAMES + ("z", "v_feed", "accel", "_ss_a", "_ss_c", "v0_fw", "v1_fw"))

(T_UNSET, T_NONE, T_FALSE, T_TRUE, T_FLOAT, T_INT, T_INTERN, T_DARRAY, T_POINTS, T_ARC, T_MEMO) = range(11)
ARC_NAMES = ("cx", "cy", "r", "theta0", "sweep", "length_d", "end_off_d", "cw", "off_circle")
_HEAD = struct.Struct(f"={len(D_NAMES)}d{len(I_NAMES)}qI{len(O_NAMES)}B")
_F64, _I64, _U32 = struct.Struct("=d"), struct.Struct("=q"), struct.Struct("=I")
_ARC = struct.Struct("=7dB")
_TAGS_AT = 8 * (len(D_NAMES) + len(I_NAMES)) + 4
# the side columns: each record's values of these int columns, 8 bytes each, beside the
# records (StrokeStore's side): the steps after planning read them of every stroke (the
# lines three times: the rewrite's order, measure's and the summary's columns; corner_cmd0
# the runs', layer the summary's), each a pass over every record's bytes.  (layer last: the
# fields sides' rows below start with SIDE, and the summary's fields follow layer)
SIDE = ("first_idx", "last_idx", "corner_cmd0", "layer")
SIDE_ROWS = 4096                 # the side read this many rows at a time (128 kB)
_K_BOOL, _K_INT = 2, 6           # store_fields' kinds (ints=True) of the values a side column holds


# the fields sides: SIDE's fields and the summary's (stroke_columns._stored_columns: layer,
# FLOATS, feature, kind, in its order, a pass over every record) as store_encode reads
# them (store_fields' reading, ints), taken as each record is written and kept beside
# the records: each record's values (8 bytes each) in one file, their kinds (a byte
# each) in another, the buffers encode fills written as they are.  fields() of names on
# the sides reads these rows, not the records (the summary's pass: rectilinear plate
# ~12 MB of records, each one's slots walked again).  Not segments' line classes'
# twenty fields (their pass, of the lines: their fields taken at every encode cost
# more than their pass saved, benchmarks/sto62.md)
FIELDS_SIDE = SIDE + ("length_d", "v0", "v1", "v_feed", "int_v2", "feature", "kind")
_FSIDE_CODES = tuple(FIELD_CODE[nm] for nm in FIELDS_SIDE)
_FSIDE_AT = {nm: j for j, nm in enumerate(FIELDS_SIDE)}
_K_OTHER = 3                     # fields' kind of another object (an int in an object slot, not ints)
SPARSE = 2                       # fields() reads the sides where a batch's rows span at most this many a row

GAP = 16384                  # bytes between two runs of records read by one preadv at most (not kept)
IOV_RUNS = 500               # runs a preadv reads at most (its buffers: under IOV_MAX, 1024)
BATCH = 1024                 # records encoded / read / decoded at a time (~0.5 MB of buffer each way)


def _kit():
    from .chains import ChainMemo
    return (stm.Stroke, stm.Points, array, Arc, Limits, ChainMemo)


def _refuse(row, name, v):
    return TypeError(f"StrokeStore: stroke {row}: field {name} holds "
                     f"{'no value' if v is _UNSET else 'a ' + type(v).__name__} (not storable; refused)")


_UNSET = object()
_SINGLE = {T_UNSET: _UNSET, T_NONE: None, T_FALSE: False, T_TRUE: True}


class _CCodec:
    """The compiled records (firmware/_core.c)."""

    def __init__(self, core, kit):
        self._core, self._kit = core, kit

    def encode(self, strokes, i0, i1, index, table, buf, lens, fields=None):
        if fields is not None and getattr(self._core, "STORE_ENCODE_FIELDS", 0):
            return self._core.store_encode(strokes, i0, i1, self._kit, index, table, buf, lens, *fields)
        nb = self._core.store_encode(strokes, i0, i1, self._kit, index, table, buf, lens)
        _fields_after(self, buf, lens[:i1 - i0], fields)     # (a core built before its fields: read after)
        return nb

    def decode(self, buf, offs, lens, table, out, over=None):
        self._core.store_decode(buf, offs, lens, self._kit, table, out, over)

    def column(self, buf, offs, lens, code, out, none):
        self._core.store_column(buf, offs, lens, code, out, none)

    def fields(self, buf, offs, lens, codes, vals, kinds, ints=False):
        # (a core built before store_fields, or before its ints: the Python reading)
        if ints and not getattr(self._core, "STORE_FIELDS_INTS", 0):
            _py_fields(buf, offs, lens, codes, vals, kinds, ints)
            return
        getattr(self._core, "store_fields", _py_fields)(buf, offs, lens, codes, vals, kinds, *((True,) if ints else ()))


class _PyCodec:
    """The same records written and read in Python (getattr / setattr: any Stroke class)."""

    def __init__(self, kit):
        self._kit = kit
        self.Stroke, self.Points, self.array, self.Arc, self.Limits, self.Memo = kit

    def _obj(self, row, k, v, index, table, tail):
        """slot k's value v: its tag, its payload appended to tail"""
        if v is _UNSET:
            return T_UNSET
        if O_NAMES[k] == "curv" or v is None:          # (curv: a cache, made again when read)
            return T_NONE
        if O_NAMES[k] == "chain_T":
            if type(v) is not self.Memo:
                raise _refuse(row, "chain_T", v)
            return T_MEMO
        if v is False or v is True:
            return T_TRUE if v else T_FALSE
        t = type(v)
        if t is float:
            tail.append(_F64.pack(v))
            return T_FLOAT
        if t is int:
            if not -2**63 <= v < 2**63:
                raise _refuse(row, O_NAMES[k], v)
            tail.append(_I64.pack(v))
            return T_INT
        if t is str or t is self.Limits:
            q = index.get(id(v))
            if q is None:
                q = index[id(v)] = len(table)
                table.append(v)
            tail.append(_U32.pack(q))
            return T_INTERN
        if t is self.array and v.typecode == "d":
            tail += (_U32.pack(len(v)), v.tobytes())
            return T_DARRAY
        if t is self.Points:
            xy = getattr(v, "xy", _UNSET)
            if type(xy) is not self.array or xy.typecode != "d":
                raise _refuse(row, "pts.xy", xy)
            tail += (_U32.pack(len(xy)), xy.tobytes())
            return T_POINTS
        if t is self.Arc:
            a = [getattr(v, nm, _UNSET) for nm in ARC_NAMES]
            for nm, x in zip(ARC_NAMES, a):
                if type(x) is not (float if nm not in ("cw", "off_circle") else bool):
                    raise _refuse(row, nm, x)
            tail.append(_ARC.pack(*a[:7], a[7] | a[8] << 1))
            return T_ARC
        raise _refuse(row, O_NAMES[k], v)

    def _record(self, st, row, index, table):
        if type(st) is not self.Stroke:
            raise TypeError(f"StrokeStore: stroke {row} is a {type(st).__name__}, not the store's Stroke")
        d, has = [], 0
        for k, nm in enumerate(D_NAMES):
            v = getattr(st, nm, _UNSET)
            if type(v) is float:
                d.append(v)
                if k >= D_NONE0:
                    has |= 1 << (k - D_NONE0)
            elif v is None and k >= D_NONE0:
                d.append(0.0)
            else:
                raise _refuse(row, nm, v)
        ii = [getattr(st, nm, _UNSET) for nm in I_NAMES]
        for nm, v in zip(I_NAMES, ii):
            if type(v) is not int or not -2**63 <= v < 2**63:
                raise _refuse(row, nm, v)
        tail = []
        tags = [self._obj(row, k, getattr(st, nm, _UNSET), index, table, tail) for k, nm in enumerate(O_NAMES)]
        return _HEAD.pack(*d, *ii, has, *tags) + b"".join(tail)

    def encode(self, strokes, i0, i1, index, table, buf, lens, fields=None):
        recs = [self._record(strokes[r], r, index, table) for r in range(i0, i1)]
        lens[:i1 - i0] = [len(x) for x in recs]
        data = b"".join(recs)
        buf[:] = data
        _fields_after(self, buf, lens[:i1 - i0], fields)
        return len(data)

    @staticmethod
    def _payload(mv, at, tag):
        """(value-ish, next offset) of a slot's payload at mv[at:]: a float / int / index / count"""
        if tag == T_FLOAT:
            return _F64.unpack_from(mv, at)[0], at + 8
        if tag == T_INT:
            return _I64.unpack_from(mv, at)[0], at + 8
        if tag == T_INTERN:
            return _U32.unpack_from(mv, at)[0], at + 4
        if tag in (T_DARRAY, T_POINTS):
            n = _U32.unpack_from(mv, at)[0]
            return n, at + 4 + 8 * n
        if tag == T_ARC:
            return None, at + _ARC.size
        if tag > T_MEMO:
            raise ValueError(f"StrokeStore: unknown tag {tag} (corrupt store)")
        return None, at

    def _doubles(self, mv, at, n):
        a = self.array("d")
        a.frombytes(mv[at + 4:at + 4 + 8 * n])
        return a

    def _value(self, mv, at, tag, table):
        x, nxt = self._payload(mv, at, tag)
        if tag in (T_FLOAT, T_INT):
            return x, nxt
        if tag == T_INTERN:
            return table[x], nxt
        if tag == T_DARRAY:
            return self._doubles(mv, at, x), nxt
        if tag == T_POINTS:
            p = self.Points.__new__(self.Points)
            p.xy = self._doubles(mv, at, x)
            return p, nxt
        if tag == T_ARC:
            f = _ARC.unpack_from(mv, at)
            a = self.Arc.__new__(self.Arc)
            for nm, v in zip(ARC_NAMES, f[:7] + (bool(f[7] & 1), bool(f[7] & 2))):
                setattr(a, nm, v)
            return a, nxt
        if tag == T_MEMO:
            return self.Memo(), nxt
        return _SINGLE[tag], nxt

    def decode(self, buf, offs, lens, table, out, over=None):
        given = [(over or {}).get(j) for j in range(len(O_NAMES))]     # (a slot's list, or None)
        with memoryview(buf) as mv:
            for q, (at, n) in enumerate(zip(offs.tolist(), lens.tolist())):
                h = _HEAD.unpack_from(mv, at)
                st = self.Stroke.__new__(self.Stroke)
                nd, ni = len(D_NAMES), len(I_NAMES)
                has = h[nd + ni]
                for k, nm in enumerate(D_NAMES):
                    none = k >= D_NONE0 and not has >> (k - D_NONE0) & 1
                    setattr(st, nm, None if none else h[k])
                for k, nm in enumerate(I_NAMES):
                    setattr(st, nm, h[nd + k])
                p = at + _HEAD.size
                for nm, tag, vals in zip(O_NAMES, h[nd + ni + 1:], given):
                    if vals is not None and vals[q] is not None:     # (over's object: the payload skipped)
                        v, p = vals[q], self._payload(mv, p, tag)[1]
                    else:
                        v, p = self._value(mv, p, tag, table)
                    if v is not _UNSET:
                        setattr(st, nm, v)
                if p != at + n:
                    raise ValueError("StrokeStore: a record's length is not its fields' (corrupt store)")
                out.append(st)

    def column(self, buf, offs, lens, code, out, none):
        is_int = out.dtype.kind == "i"
        nd, ni = len(D_NAMES), len(I_NAMES)
        with memoryview(buf) as mv:
            for q, at in enumerate(offs.tolist()):
                h = _HEAD.unpack_from(mv, at)
                isnone = False
                if code < nd:
                    x = h[code]
                    isnone = code >= D_NONE0 and not h[nd + ni] >> (code - D_NONE0) & 1
                elif code < nd + ni:
                    x = h[code]
                else:
                    tags = h[nd + ni + 1:]
                    p = at + _HEAD.size
                    for tag in tags[:code - nd - ni]:
                        p = self._payload(mv, p, tag)[1]
                    tag = tags[code - nd - ni]
                    if tag in (T_FLOAT, T_INT):
                        x = self._payload(mv, p, tag)[0]
                    elif tag in (T_FALSE, T_TRUE):
                        x = int(tag == T_TRUE)
                    elif tag in (T_NONE, T_UNSET):
                        isnone = True
                    else:
                        raise TypeError(f"store_column: record {q}'s field is not a number")
                if isnone:
                    if is_int:
                        raise TypeError(f"store_column: record {q}'s field is None (an int64 column)")
                    x = float("nan")
                if is_int and type(x) is float:
                    raise TypeError(f"store_column: record {q}'s field is a float (an int64 column)")
                out[q] = x
                if none is not None:
                    none[q] = isnone

    @staticmethod
    def fields(buf, offs, lens, codes, vals, kinds, ints=False):
        _py_fields(buf, offs, lens, codes, vals, kinds, ints)


def _fields_after(codec, buf, lens, fields):
    """encode's fields (codes, vals, kinds: None, nothing) read of the records just written
    at the start of buf (lens: their lengths), as fields(..., ints=True) reads them."""
    if fields is not None:
        codec.fields(buf, np.cumsum(lens) - lens, lens, *fields, True)


_NAN_BITS = struct.pack("=Q", 0x7ff8000000000000)    # (stroke_fields' None: np.array([None], float)'s NaN)
# store_fields' kind of an object slot's tag (the rest: 3, another object)
_SLOT_KIND = {T_FLOAT: 0, T_NONE: 1, T_FALSE: 2, T_TRUE: 2, T_UNSET: 4, T_INTERN: 5}


def _py_fields(buf, offs, lens, codes, vals, kinds, ints=False):
    """firmware/_core.c's store_fields in Python: each record's fields codes into the rows of
    vals (float64) and kinds (int8) as stroke_fields reads a stroke's (0 a float, 1 None, 2
    a bool, 3 another object, 4 unset), 5 a shared object (vals: its table index); an int
    field's int64 bits in vals; ints: an object slot's int is kind 6, its int64 bits in vals."""
    nd, ni = len(D_NAMES), len(I_NAMES)
    nan = _F64.unpack(_NAN_BITS)[0]
    last_slot = max([c - nd - ni for c in codes if c >= nd + ni], default=-1)
    with memoryview(buf) as mv:
        for q, at in enumerate(offs.tolist()):
            h = _HEAD.unpack_from(mv, at)
            has, tags = h[nd + ni], h[nd + ni + 1:]
            pos, p = [], at + _HEAD.size
            for tag in tags[:last_slot + 1]:
                pos.append(p)
                p = _PyCodec._payload(mv, p, tag)[1]
            for j, c in enumerate(codes):
                v, kind = 0.0, 0
                if c < nd:
                    v = h[c]
                    if c >= D_NONE0 and not has >> (c - D_NONE0) & 1:
                        v, kind = nan, 1
                elif c < nd + ni:
                    v = _F64.unpack(_I64.pack(h[c]))[0]
                else:
                    tag = tags[c - nd - ni]
                    kind = _SLOT_KIND.get(tag, 3)
                    if ints and tag == T_INT:
                        v, kind = _F64.unpack(_I64.pack(_PyCodec._payload(mv, pos[c - nd - ni], tag)[0]))[0], 6
                    elif kind in (0, 5):
                        v = float(_PyCodec._payload(mv, pos[c - nd - ni], tag)[0])
                    elif kind == 1:
                        v = nan
                    elif kind == 2:
                        v = float(tag == T_TRUE)
                vals[q, j], kinds[q, j] = v, kind


class _TempFile:
    """Records in an unnamed temporary file: spilled strokes hold no resident memory."""
    in_memory = False

    def __init__(self, folder=None):
        # (unbuffered: only its descriptor is read and written, pread / pwrite; a buffered
        # file held an 8 kB buffer it never used, one a file: records and three sides)
        self._fh = tempfile.TemporaryFile(dir=folder, buffering=0)
        self._fd = self._fh.fileno()

    def write(self, pos, data):
        mv = memoryview(data)
        while len(mv):
            n = os.pwrite(self._fd, mv, pos)
            mv, pos = mv[n:], pos + n

    def read_into(self, mv, pos):
        while len(mv):
            n = os.preadv(self._fd, [mv], pos)
            if n <= 0:
                raise OSError("StrokeStore: the temporary file ended early")
            mv, pos = mv[n:], pos + n

    def read_runs(self, mv, run_at, run_n, run_pos):
        """Each run's run_n bytes at file byte run_at into mv at run_pos (int64 arrays, a
        run each): runs after a gap of at most GAP bytes read by one preadv, the gap into a
        scratch buffer (a sparse take's runs, ~1.4-2.5 k reads a plate, were a syscall each)."""
        gap = run_at[1:] - run_at[:-1] - run_n[:-1]
        cut = np.flatnonzero((gap <= 0) | (gap > GAP)) + 1
        at, n, p, g = run_at.tolist(), run_n.tolist(), run_pos.tolist(), gap.tolist()
        scratch = None
        for f, e in zip([0] + cut.tolist(), cut.tolist() + [len(at)]):
            for f1 in range(f, e, IOV_RUNS):
                e1 = min(f1 + IOV_RUNS, e)
                if e1 - f1 == 1:
                    self.read_into(mv[p[f1]:p[f1] + n[f1]], at[f1])
                    continue
                if scratch is None:
                    scratch = memoryview(bytearray(GAP))
                iov = [mv[p[f1]:p[f1] + n[f1]]]
                for i in range(f1 + 1, e1):
                    iov += (scratch[:g[i - 1]], mv[p[i]:p[i] + n[i]])
                if os.preadv(self._fd, iov, at[f1]) != at[e1 - 1] + n[e1 - 1] - at[f1]:
                    for i in range(f1, e1):          # (a short read: run by run, as read_into reads)
                        self.read_into(mv[p[i]:p[i] + n[i]], at[i])

    def close(self):
        self._fh.close()


class _Memory:
    """Records in one bytearray (the in-memory variant: the bytes stay resident)."""
    in_memory = True

    def __init__(self, folder=None):
        self.data = bytearray()

    def write(self, pos, data):
        if pos == len(self.data):
            self.data += data
        else:
            self.data[pos:pos + len(data)] = data

    def read_into(self, mv, pos):
        if pos + len(mv) > len(self.data):
            raise OSError("StrokeStore: the records end early")
        mv[:] = memoryview(self.data)[pos:pos + len(mv)]

    def close(self):
        self.data = bytearray()


def _codec(pure):
    kit = _kit()
    core = stm._CORE
    if pure or core is None or not hasattr(core, "store_encode") or stm._BASE is None:
        return _PyCodec(kit)
    return _CCodec(core, kit)


def _dense(rows):
    """Do rows (int64, a fields() batch) ascend, spanning at most SPARSE rows a row
    (fields() then reads their span of the fields sides, not their records)?"""
    if len(rows) < 2:
        return True
    return int(rows[-1] - rows[0]) < SPARSE * len(rows) and bool((rows[1:] > rows[:-1]).all())


def _read_breaks(offs, lens, slack):
    """The records (their places in offs, >= 1) that start a read of their own: a record
    follows the one before it in the same read where it starts at that one's end, or a
    little after it (the gap read and not used), the smallest gaps first while their bytes
    add up to at most slack.  The rewrite's held rows (most of a window's, not all) came in
    ~190 runs a window, a read each (gyroid plate: 8.5 k reads); their gaps read, one."""
    gap = offs[1:] - offs[:-1] - lens[:-1]
    join = gap == 0
    ahead = np.flatnonzero(gap > 0)                 # (a record before the last one's end: a read of its own)
    if ahead.size and slack > 0:
        by = ahead[np.argsort(gap[ahead], kind="stable")]
        join[by[np.cumsum(gap[by]) <= slack]] = True
    return np.flatnonzero(~join) + 1


class StrokeStore:
    """Strokes appended in order (a stroke's index: how many were appended before it), read
    back as new Stroke objects (load, take), one numeric field as an array without making
    strokes (column), records re-encoded after a change (rewrite).  in_memory: the records
    in a bytearray instead of a temporary file (folder: where; default the system's).  pure:
    the Python twin even where the core is built (tests)."""

    def __init__(self, in_memory=False, folder=None, pure=False):
        self._codec = _codec(pure)
        self._io = (_Memory if in_memory else _TempFile)(folder)
        # each record's SIDE values, 8 * len(SIDE) bytes at that times its row; a column none
        # of whose values the side could hold (not an int or a bool: column() then reads the
        # records) in _side_off
        self._side_io = (_Memory if in_memory else _TempFile)(folder)
        self._side_off = set()
        # FIELDS_SIDE's values (float64) and kinds (int8) of each record, a row a record
        self._fvals_io = (_Memory if in_memory else _TempFile)(folder)
        self._fkinds_io = (_Memory if in_memory else _TempFile)(folder)
        self.in_memory, self.folder = in_memory, folder      # (other spills go where this one is)
        self._off = np.zeros(0, np.int64)        # record k at byte _off[k], _len[k] bytes long
        self._len = np.zeros(0, np.int64)
        self._n = 0
        self._end = 0                            # bytes of the store (dead records included)
        self._index, self._table = {}, []        # the interned objects: {id: k}, [object]

    @property
    def pure(self):
        return isinstance(self._codec, _PyCodec)

    def __len__(self):
        return self._n

    @property
    def nbytes(self):
        """Bytes of records written (a record rewritten longer leaves its old bytes dead)."""
        return self._end

    def _room(self, n):
        if n > len(self._off):
            cap = max(n, 2 * len(self._off), 1024)
            self._off = np.concatenate((self._off[:self._n], np.zeros(cap - self._n, np.int64)))
            self._len = np.concatenate((self._len[:self._n], np.zeros(cap - self._n, np.int64)))

    # The encode and read buffers are a call's own, not kept between calls: the windowed
    # pipeline encodes only until its plan inputs are made and reads no record during the
    # chains' solves, where kept they added ~1.8 MB (gyroid plate) to the peaks
    def _encode(self, strokes, i0, i1, buf):
        """(bytes of the records of strokes[i0:i1] at the start of buf, a bytearray; their
        lengths; their FIELDS_SIDE vals and kinds: the fields sides' rows, SIDE's columns
        among them) -- the sides' fields taken as each record is written (the compiled
        encode: no second walk of the records' slots)"""
        n = i1 - i0
        lens = np.empty(n, np.int64)
        vals, kinds = np.empty((n, len(FIELDS_SIDE))), np.empty((n, len(FIELDS_SIDE)), np.int8)
        nb = self._codec.encode(strokes, i0, i1, self._index, self._table, buf, lens, (_FSIDE_CODES, vals, kinds))
        return nb, lens, vals, kinds

    def _write_fields(self, row, vals, kinds):
        """The fields sides' rows of records row.. (encode's vals and kinds, as they are)."""
        self._fvals_io.write(8 * len(FIELDS_SIDE) * row, memoryview(vals.reshape(-1).view(np.uint8)))
        self._fkinds_io.write(len(FIELDS_SIDE) * row, memoryview(kinds.reshape(-1).view(np.uint8)))

    def append(self, strokes):
        """Records of strokes (a list) after the ones stored."""
        strokes = strokes if type(strokes) is list else list(strokes)
        self._room(self._n + len(strokes))
        end = self._end                # (a refused stroke: the store is left as it was)
        buf = bytearray()
        for b0 in range(0, len(strokes), BATCH):
            b1 = min(b0 + BATCH, len(strokes))
            nb, lens, fv, fk = self._encode(strokes, b0, b1, buf)
            self._io.write(end, memoryview(buf)[:nb])
            k0 = self._n + b0
            self._write_fields(k0, fv, fk)
            self._side_io.write(8 * len(SIDE) * k0, memoryview(self._side_values(fv, fk).reshape(-1).view(np.uint8)))
            self._len[k0:k0 + b1 - b0] = lens
            self._off[k0:k0 + b1 - b0] = end + np.cumsum(lens) - lens
            end += nb
        self._n += len(strokes)
        self._end = end

    def _rows(self, rows):
        rows = np.asarray(rows, np.int64)
        if rows.ndim != 1 or (len(rows) and (rows.min() < 0 or rows.max() >= self._n)):
            raise IndexError("StrokeStore: rows out of range")
        return rows

    def _batches(self, rows, size=BATCH):
        """(buffer, offsets in it, lengths) of the records of rows, size at a time: the
        in-memory bytes themselves, or the file's runs of records read into a buffer
        (_read_breaks; runs close together in one read: _TempFile.read_runs)"""
        buf = bytearray()
        for b0 in range(0, len(rows), size):
            r = rows[b0:b0 + size]
            offs, lens = self._off[r], self._len[r]
            if self._io.in_memory:
                yield self._io.data, offs, lens
                continue
            if (offs[1:] == offs[:-1] + lens[:-1]).all():   # (one run: a scan's batch, a window's load)
                total = int(offs[-1] + lens[-1] - offs[0])
                if len(buf) < total:
                    buf = np.empty(total, np.uint8)
                with memoryview(buf) as mv:
                    self._io.read_into(mv[:total], int(offs[0]))
                yield buf, offs - offs[0], lens
                continue
            brk = _read_breaks(offs, lens, int(lens.sum()))     # (the buffer: twice the records' bytes at most)
            first = np.concatenate(([0], brk))
            last = np.concatenate((brk, [len(r)])) - 1
            run_at = offs[first]
            run_n = offs[last] + lens[last] - run_at
            run_pos = np.cumsum(run_n) - run_n               # where each run goes in the buffer
            total = int(run_n.sum())
            if len(buf) < total:
                buf = np.empty(total, np.uint8)       # (not zeroed: every byte used is read into it)
            with memoryview(buf) as mv:
                self._io.read_runs(mv, run_at, run_n, run_pos)
            rel = offs - np.repeat(run_at - run_pos, last - first + 1)
            yield buf, rel, lens

    def take(self, rows, over=None):
        """New strokes of the records of rows (int64, in the order given; sorted reads best).
        over: {object field name (O_NAMES): a list of one value a row}: a row's stroke
        holds that object in that field where it is not None (not the record's value).
        The collector waits meanwhile: the new strokes hold no cycle, and its young
        collections walked them, over and over, for ~80 % of the time (rectilinear plate)."""
        rows = self._rows(rows)
        slots = {}
        for name, vals in (over or {}).items():
            if len(vals) != len(rows):
                raise ValueError("StrokeStore.take: over's values must be one a row")
            slots[O_NAMES.index(name)] = vals if type(vals) is list else list(vals)
        out = []
        was_on = gc.isenabled()
        gc.disable()
        try:
            for buf, offs, lens in self._batches(rows):
                at = len(out)
                self._codec.decode(buf, offs, lens, self._table, out,
                                   {j: vals[at:at + len(offs)] for j, vals in slots.items()} if slots else None)
        finally:
            if was_on:
                gc.enable()
        return out

    def load(self, i0, i1, over=None):
        """New strokes of records i0..i1-1 (over: take's, one value a record loaded)."""
        i0, i1 = max(i0, 0), min(i1, self._n)
        return self.take(np.arange(i0, max(i0, i1), dtype=np.int64), over)

    def _side_values(self, vals, kinds):
        """The SIDE values (a new int64 array, (rows, len(SIDE))) of records whose fields
        sides' rows the codec read as vals and kinds (encode's: FIELDS_SIDE, SIDE's first;
        fields(..., ints=True)'s reading; left as they are); a column with a value it cannot
        hold (not an int or a bool) put in _side_off.  A column at a time (a copy of the
        rows' first columns: a loop call a row)."""
        out = np.empty((len(vals), len(SIDE)), np.int64)
        for j, name in enumerate(SIDE):
            got = vals[:, j].view(np.int64)
            if j >= 2:
                k = kinds[:, j]
                if name not in self._side_off and not ((k == _K_INT) | (k == _K_BOOL)).all():
                    self._side_off.add(name)
                got = np.where(k == _K_BOOL, vals[:, j] != 0.0, got)
            out[:, j] = got
        return out

    def _write_side(self, rows, side, fvals, fkinds):
        """side (SIDE values, a row a record) and the fields sides' rows (encode's fvals,
        fkinds) written as rows': a write a run of consecutive rows."""
        brk = np.flatnonzero(rows[1:] != rows[:-1] + 1) + 1
        for f, e in zip([0] + brk.tolist(), brk.tolist() + [len(rows)]):
            self._side_io.write(8 * len(SIDE) * int(rows[f]), memoryview(side[f:e].reshape(-1).view(np.uint8)))
            self._write_fields(int(rows[f]), fvals[f:e], fkinds[f:e])

    def _side_columns(self, names):
        """The side columns names (int64 arrays) of every record, SIDE_ROWS at a time."""
        cols = [np.empty(self._n, np.int64) for _ in names]
        js = [SIDE.index(nm) for nm in names]
        part = np.empty((min(self._n, SIDE_ROWS), len(SIDE)), np.int64)
        for a in range(0, self._n, SIDE_ROWS):
            got = part[:min(SIDE_ROWS, self._n - a)]
            self._side_io.read_into(memoryview(got.reshape(-1).view(np.uint8)), 8 * len(SIDE) * a)
            for col, j in zip(cols, js):
                col[a:a + len(got)] = got[:, j]
        return cols

    def lines(self):
        """(first_idx, last_idx) of every record, two int64 arrays, read from the side
        (8 * len(SIDE) bytes a record), not from the records."""
        return tuple(self._side_columns(("first_idx", "last_idx")))

    def column(self, name, with_none=False):
        """Field `name` of every record, without making a stroke: a float64 array (a float
        field: a float's bits; None -- a None-able field's None, an unset slot -- as NaN) or
        an int64 one (first_idx, last_idx, layer; the bools as 0 / 1).  with_none: also a
        bool array, True where the value was None (a stored NaN is then told apart)."""
        if name not in FLOAT_COLUMNS and name not in INT_COLUMNS:
            raise ValueError(f"StrokeStore.column: {name!r} is not a numeric field")
        if name in SIDE and name not in self._side_off:     # (an int or a bool each: no record read)
            out = self._side_columns((name,))[0]
            return (out, np.zeros(self._n, bool)) if with_none else out
        out = np.empty(self._n, np.int64 if name in INT_COLUMNS else np.float64)
        none = np.zeros(self._n, np.uint8) if with_none else None
        at = 0
        for buf, offs, lens in self._batches(np.arange(self._n, dtype=np.int64)):
            n = len(offs)
            self._codec.column(buf, offs, lens, FIELD_CODE[name], out[at:at + n],
                               None if none is None else none[at:at + n])
            at += n
        return (out, none.astype(bool)) if with_none else out

    def fields(self, rows, names, size=BATCH, ints=False):
        """The fields `names` of the records of rows (int64), read as strokes.stroke_fields
        reads them of their strokes but no stroke made: (vals, kinds) of each `size` rows
        in turn, float64 and int8 arrays (rows, len(names)) -- kinds 0 a float, 1 None
        (vals the NaN stroke_fields gives it), 2 a bool (1.0 / 0.0), 3 another object
        (0.0), 4 an unset slot (0.0), 5 a shared object (a str, a Limits: vals its index
        for shared()); an int field (first_idx, last_idx): vals' column holds its int64
        bits (view it as int64).  ints: an int in an object slot (layer) is kind 6, vals its
        int64 bits (not 3, 0.0)."""
        codes = tuple(FIELD_CODE[nm] for nm in names)
        rows = self._rows(rows)
        at = [_FSIDE_AT.get(nm) for nm in names]
        for b0 in range(0, len(rows), size):
            r = rows[b0:b0 + size]
            if None not in at and _dense(r):           # (the fields sides' rows: no record read)
                yield self._side_fields(r, at, ints)
                continue
            for buf, offs, lens in self._batches(r, size):
                vals, kinds = np.empty((len(offs), len(codes))), np.empty((len(offs), len(codes)), np.int8)
                self._codec.fields(buf, offs, lens, codes, vals, kinds, ints)
                yield vals, kinds

    def _side_fields(self, rows, at, ints):
        """fields' (vals, kinds) of rows (ascending, _dense), the fields sides' columns at:
        the rows' span read and the rows picked (columns in the sides' order: views)."""
        a, z, w = int(rows[0]), int(rows[-1]) + 1, len(FIELDS_SIDE)
        vals, kinds = np.empty((z - a, w)), np.empty((z - a, w), np.int8)
        self._fvals_io.read_into(memoryview(vals.reshape(-1).view(np.uint8)), 8 * w * a)
        self._fkinds_io.read_into(memoryview(kinds.reshape(-1).view(np.uint8)), w * a)
        if z - a != len(rows):
            vals, kinds = vals[rows - a], kinds[rows - a]
        if at == list(range(at[0], at[0] + len(at))):
            vals, kinds = vals[:, at[0]:at[0] + len(at)], kinds[:, at[0]:at[0] + len(at)]
        else:
            vals, kinds = vals[:, at], kinds[:, at]
        if ints:                # (encode's reading)
            return vals, kinds
        # (not ints: an int in an object slot another object, 0.0) -- a column at a time (a
        # masked copy of the whole strided view: ~40 instructions an item)
        other = kinds == _K_INT
        for j in np.flatnonzero(other.any(axis=0)).tolist():
            o = other[:, j]
            vals[o, j], kinds[o, j] = 0.0, _K_OTHER
        return vals, kinds

    def shared(self, k):
        """The shared object (interned: fields' kind 5) of index k, the one its strokes hold."""
        return self._table[k]

    def rewrite(self, rows, strokes):
        """Records of rows (int64) made again from strokes (one a row: strokes changed since
        append).  A record of the same length is written in place, a longer or shorter one
        after the store's end (its old bytes left dead)."""
        rows = self._rows(rows)
        strokes = strokes if type(strokes) is list else list(strokes)
        if len(strokes) != len(rows):
            raise ValueError("StrokeStore.rewrite: one stroke a row")
        buf = bytearray()
        for b0 in range(0, len(rows), BATCH):
            b1 = min(b0 + BATCH, len(rows))
            r = rows[b0:b1]
            nb, lens, fvals, fkinds = self._encode(strokes, b0, b1, buf)
            side = self._side_values(fvals, fkinds)
            moved = lens != self._len[r]
            new_off = self._off[r].copy()
            new_off[moved] = self._end + np.cumsum(lens[moved]) - lens[moved]
            self._end += int(lens[moved].sum())
            bpos = np.cumsum(lens) - lens
            # runs adjacent both in the buffer and in the store: one write each
            brk = np.flatnonzero(new_off[1:] != new_off[:-1] + lens[:-1]) + 1
            first = np.concatenate(([0], brk))
            last = np.concatenate((brk, [len(r)])) - 1
            with memoryview(buf) as mv:
                for f, e in zip(first.tolist(), last.tolist()):
                    p0, p1 = int(bpos[f]), int(bpos[e] + lens[e])
                    self._io.write(int(new_off[f]), mv[p0:p1])
            self._write_side(r, side, fvals, fkinds)    # (after the records: a failed write leaves the sides as they were)
            self._off[r], self._len[r] = new_off, lens

    def close(self):
        """The records let go (the file removed); the store is empty."""
        self._io.close()
        self._side_io.close()
        self._fvals_io.close()
        self._fkinds_io.close()
        self._side_off = set()
        self._n = self._end = 0
        self._index, self._table = {}, []

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
