"""win48 scratch (Q4): spilling the strokes after analyse and restoring them, Python level.

Layout (what a window's strokes would be written as): a fixed record per stroke of float64
columns (StrokeBase's 16 doubles, None as NaN with a has-bit column; the float object slots
z, v_feed, accel, _ss_a, _ss_c, v0_fw, v1_fw likewise), int64 first_idx / last_idx, small-int
columns (layer int32; feature, kind, lim as uint8 codes into per-file tables; e_rel,
corner_cmd0/1 as bits; the vertex and end counts), then the Points' xy and the _ends arrays
concatenated.  Planning's caches (curv, chain_T) and arc strokes (none on the plates) are left
out.  Spill: getattr per field per stroke (attrgetter + np.fromiter), the arrays' bytes joined,
written to a temporary file; restore: read back, Stroke.__new__ and setattr per field, Points and
arrays from the bytes.  Checked: every field of every restored stroke equals the original's.
C-level reference: strokes.stroke_fields (the core's read of the same double fields into one
array, no Python object a value).  Usage: spill.py FILE"""
import os
import sys
import tempfile
import time
from array import array
from operator import attrgetter

import numpy as np

from gcode_opt import features as feat, strokes as stm
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile

D_NONE = ("_pux", "_puy", "_nux", "_nuy", "_ss_e", "z", "v_feed", "accel", "_ss_a", "_ss_c", "v0_fw", "v1_fw")
D_ALWAYS = ("x0", "y0", "ux", "uy", "length_d", "e_per_mm", "v0", "v1", "time_t", "int_a2", "int_v2")
I64 = ("first_idx", "last_idx")
BITS = ("e_rel", "corner_cmd0", "corner_cmd1")
CODED = ("feature", "kind", "lim")


def spill(sts, fh):
    n = len(sts)
    cols = {}
    for f in D_ALWAYS:
        cols[f] = np.fromiter(map(attrgetter(f), sts), float, n)
    has = np.zeros(n, np.uint32)
    for b, f in enumerate(D_NONE):
        v = list(map(attrgetter(f), sts))
        isn = np.fromiter((x is None for x in v), bool, n)
        has |= (~isn).astype(np.uint32) << b
        cols[f] = np.fromiter((np.nan if x is None else x for x in v), float, n)
    for f in I64:
        cols[f] = np.fromiter(map(attrgetter(f), sts), np.int64, n)
    cols["layer"] = np.fromiter(map(attrgetter("layer"), sts), np.int32, n)
    bits = np.zeros(n, np.uint8)
    for b, f in enumerate(BITS):
        bits |= np.fromiter(map(attrgetter(f), sts), bool, n).astype(np.uint8) << b
    cols["bits"], cols["has"] = bits, has
    tables = {}
    for f in CODED:
        t = {}
        cols[f] = np.fromiter((t.setdefault(id(x), (len(t), x))[0] for x in map(attrgetter(f), sts)), np.uint8, n)
        tables[f] = [x for _, x in sorted(t.values(), key=lambda p: p[0])]
    pts = list(map(attrgetter("pts"), sts))
    ends = list(map(attrgetter("_ends"), sts))
    cols["n_pts"] = np.fromiter((-1 if p is None else len(p.xy) for p in pts), np.int32, n)
    cols["n_ends"] = np.fromiter((-1 if e is None else len(e) for e in ends), np.int32, n)
    layout = []
    for k, a in cols.items():
        fh.write(a.tobytes())
        layout.append((k, a.dtype, a.nbytes))
    xy = b"".join(p.xy.tobytes() for p in pts if p is not None)
    eb = b"".join(e.tobytes() for e in ends if e is not None)
    fh.write(xy)
    fh.write(eb)
    layout += [("xy", None, len(xy)), ("ends", None, len(eb))]
    return layout, tables, n


def restore(fh, layout, tables, n):
    fh.seek(0)
    cols = {}
    for k, dt, nb in layout:
        b = fh.read(nb)
        cols[k] = np.frombuffer(b, dt) if dt is not None else b
    new, Stroke, Points = stm.Stroke.__new__, stm.Stroke, stm.Points
    sts = [new(Stroke) for _ in range(n)]
    for f in D_ALWAYS + I64 + ("layer",):
        for s, v in zip(sts, cols[f].tolist()):
            setattr(s, f, v)
    has = cols["has"]
    for b, f in enumerate(D_NONE):
        h = ((has >> b) & 1).astype(bool).tolist()
        for s, v, hb in zip(sts, cols[f].tolist(), h):
            setattr(s, f, v if hb else None)
    bits = cols["bits"]
    for b, f in enumerate(BITS):
        for s, v in zip(sts, ((bits >> b) & 1).astype(bool).tolist()):
            setattr(s, f, v)
    for f in CODED:
        t = tables[f]
        for s, c in zip(sts, cols[f].tolist()):
            setattr(s, f, t[c])
    xy, eb = memoryview(cols["xy"]), memoryview(cols["ends"])
    a = 0
    for s, m in zip(sts, cols["n_pts"].tolist()):
        if m < 0:
            s.pts = None
        else:
            p = Points.__new__(Points)
            p.xy = d = array("d")
            d.frombytes(xy[a:a + 8 * m])
            s.pts = p
            a += 8 * m
    a = 0
    for s, m in zip(sts, cols["n_ends"].tolist()):
        if m < 0:
            s._ends = None
        else:
            s._ends = d = array("d")
            d.frombytes(eb[a:a + 8 * m])
            a += 8 * m
    for s in sts:
        s.arc = s.curv = s.chain_T = None
    return sts


def same(a, b):
    for s, t in zip(a, b):
        for f in stm.FIELDS:
            x, y = getattr(s, f), getattr(t, f)
            if f == "pts":
                x, y = (None if x is None else x.xy), (None if y is None else y.xy)
            if not (x == y or (x != x and y != y)) or type(x) is not type(y):
                return f
    return None


def main():
    path = sys.argv[1]
    prof = load_profile("prusa-mk3s")
    opts = Options(features=feat.default_selection(path)[0])
    sts, _ = analyse(path, prof, opts)
    n = len(sts)
    best = {}
    for rep in range(3):
        with tempfile.TemporaryFile(dir="/tmp") as fh:
            t0 = time.process_time()
            layout, tables, n = spill(sts, fh)
            fh.flush()
            t1 = time.process_time()
            back = restore(fh, layout, tables, n)
            t2 = time.process_time()
        for k, v in (("spill", t1 - t0), ("restore", t2 - t1)):
            best[k] = min(best.get(k, 1e9), v)
        if rep == 0:
            bad = same(sts, back)
            nbytes = sum(x[2] for x in layout)
            fixed = sum(x[2] for x in layout if x[1] is not None)
        del back
    names = ("x0", "y0", "ux", "uy", "length_d", "e_per_mm", "v0", "v1", "time_t", "int_a2", "int_v2",
             "_pux", "_puy", "_nux", "_nuy", "_ss_e", "z", "v_feed", "accel")
    tc = 1e9
    for rep in range(3):
        t0 = time.process_time()
        got = stm.stroke_fields(sts, names)
        tc = min(tc, time.process_time() - t0)
    a = np.zeros(nbytes // 8)
    tm = 1e9
    for rep in range(5):
        t0 = time.perf_counter()
        b = a.copy()
        tm = min(tm, time.perf_counter() - t0)
    del b
    print(f"{os.path.basename(path)}: {n} strokes; spilled {nbytes / 2**20:.2f} MB ({fixed / n:.0f} bytes a stroke fixed, "
          f"{(nbytes - fixed) / 2**20:.2f} MB vertices and ends); restored equal: {bad is None} ({bad})")
    print(f"  Python level, best of 3: spill {best['spill']:.3f} s, restore {best['restore']:.3f} s "
          f"({(best['spill'] + best['restore']) / n * 1e6:.1f} us a stroke both ways)")
    print(f"  C level: stroke_fields of {len(names)} doubles a stroke {tc * 1e3:.1f} ms"
          f" ({'ok' if got is not None else 'unavailable'}); memcpy of {nbytes / 2**20:.1f} MB {tm * 1e3:.1f} ms")


if __name__ == "__main__":
    main()
