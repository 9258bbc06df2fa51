"""store50: StrokeStore's size, CPU and the RSS it gives back (benchmarks/store50/README.md).

  bench.py cpu FILE        bytes a stroke (fixed + vertices); append / load CPU (process_time,
                           best of 5), compiled and pure, file and memory, after analyse and
                           after plan_inputs; the collector on and off (the pipeline runs
                           analyse and planning with it off); the bytes of the strokes' own
                           objects as analyse made them and as load made them
  bench.py rss FILE [mem]  one process: analyse; RSS; spill; del strokes; trim_heap; RSS; load
                           all back; RSS; every restored stroke compared with a digest of its
                           original (taken before the del); mem: the in-memory variant
  bench.py cg FILE [N]     for callgrind: analyse, then N (0 or 1) append + load (compiled, file)
"""
import gc
import hashlib
import struct
import sys
import time
from array import array

from gcode_opt import features as feat, stroke_store as ss, strokes as stm
from gcode_opt.pipeline import Options, analyse, trim_heap
from gcode_opt.profile import load_profile
from gcode_opt.schedule import plan_inputs


def _strokes(path):
    prof = load_profile("prusa-mk3s")
    opts = Options(features=feat.default_selection(path)[0])
    sts, _ = analyse(path, prof, opts)
    return sts, lambda: plan_inputs(sts, prof, opts)


def rss_mb():
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024


def _canon(v):
    t = type(v)
    if t is float:
        return struct.pack("=d", v)
    if t is array:
        return b"A" + v.tobytes()
    if t is stm.Points:
        return b"P" + v.xy.tobytes()
    if t in (int, bool) or v is None:
        return repr(v).encode()
    if t.__name__ == "Arc":
        return b"R" + b"".join(_canon(getattr(v, nm)) for nm in t.__slots__)
    if t.__name__ == "ChainMemo":
        return b"M"
    return b"#%d" % id(v)                 # (shared objects: the same object; the store keeps them alive)


def digest(st):
    h = hashlib.blake2b(digest_size=16)
    for f in stm.FIELDS:
        h.update(f.encode() + (b"N" if f == "curv" else _canon(getattr(st, f))))
    return h.digest()


def vertex_bytes(sts):
    n = 0
    for s in sts:
        if s.pts is not None:
            n += 8 * len(s.pts.xy)
        if s._ends is not None:
            n += 8 * len(s._ends)
    return n


def deep_bytes(sts):
    """bytes of the strokes' own objects (an object shared by several strokes counted once)"""
    seen, n = set(), 0
    for st in sts:
        n += sys.getsizeof(st)
        for f in stm.FIELDS:
            v = getattr(st, f)
            if v is None or type(v) in (str, bool) or type(v).__name__ == "Limits" or id(v) in seen:
                continue
            seen.add(id(v))
            n += sys.getsizeof(v)
            if type(v) is stm.Points:
                n += sys.getsizeof(v.xy)
            elif type(v).__name__ == "Arc":
                n += sum(sys.getsizeof(getattr(v, nm)) for nm in ("cx", "cy", "r", "theta0", "sweep", "length_d",
                                                                  "end_off_d"))
    return n


def best_of(fn, reps=5):
    best = 1e9
    for _ in range(reps):
        t0 = time.process_time()
        fn()
        best = min(best, time.process_time() - t0)
    return best


def cpu(path):
    sts, plan = _strokes(path)
    n = len(sts)
    gc.collect()
    gc.freeze()
    for phase in ("analyse", "plan_inputs"):
        if phase == "plan_inputs":
            plan()
            gc.collect()
            gc.freeze()
        with ss.StrokeStore() as st:
            st.append(sts)
            vb = vertex_bytes(sts)
            print(f"{phase}: {n} strokes, {st.nbytes / 2**20:.2f} MB of records: {(st.nbytes - vb) / n:.0f} B a "
                  f"stroke fixed + {vb / 2**20:.2f} MB vertices and ends ({vb / n:.0f} B a stroke)")
        for pure in (False, True):
            for in_memory in (False, True):
                for gc_on in (True, False):
                    if not gc_on:
                        gc.disable()
                    stores = []

                    def app():
                        s = ss.StrokeStore(in_memory=in_memory, pure=pure)
                        s.append(sts)
                        stores.append(s)
                    t_app = best_of(app, 3 if pure else 5)
                    store = stores[-1]
                    t_load = best_of(lambda: store.load(0, n), 3 if pure else 5)
                    gc.enable()
                    for s in stores:
                        s.close()
                    print(f"  {'pure' if pure else 'C   '} {'memory' if in_memory else 'file  '} "
                          f"gc {'on ' if gc_on else 'off'}: append {t_app * 1e3:6.1f} ms, load {t_load * 1e3:6.1f} ms "
                          f"({(t_app + t_load) / n * 1e6:.2f} us a stroke both ways)")
        for pure in (False, True):
            with ss.StrokeStore(pure=pure) as st:
                st.append(sts)
                t = {nm: best_of(lambda: st.column(nm), 5 if not pure else 2) for nm in ("v0", "layer", "v1_fw")}
            print(f"  {'pure' if pure else 'C   '} file column: " + ", ".join(f"{k} {v * 1e3:.1f} ms" for k, v in t.items()))
        with ss.StrokeStore() as st:
            st.append(sts)
            back = st.load(0, n)
        print(f"  objects' bytes (getsizeof, each object once, shared str / Limits / None / bools left out): "
              f"as analyse made them {deep_bytes(sts) / 2**20:.2f} MB, as load made them {deep_bytes(back) / 2**20:.2f} MB")
        del back


def rss(path, in_memory):
    sts, plan = _strokes(path)
    del plan                              # (its closure holds the strokes)
    n = len(sts)
    digests = [digest(s) for s in sts]
    gc.collect()
    trim_heap()
    r0 = rss_mb()
    store = ss.StrokeStore(in_memory=in_memory)
    t0 = time.process_time()
    store.append(sts)
    t1 = time.process_time()
    del sts
    gc.collect()
    trim_heap()
    r1 = rss_mb()
    t2 = time.process_time()
    back = store.load(0, n)
    t3 = time.process_time()
    r2 = rss_mb()
    bad = sum(digest(s) != d for s, d in zip(back, digests))
    print(f"{'memory' if in_memory else 'file'}: {n} strokes ({store.nbytes / 2**20:.1f} MB of records); RSS after "
          f"analyse {r0:.1f} MB, spilled + dropped + trim_heap {r1:.1f} MB ({r0 - r1:+.1f} given back), "
          f"loaded back {r2:.1f} MB; append {(t1 - t0) * 1e3:.0f} ms, load {(t3 - t2) * 1e3:.0f} ms; "
          f"restored unequal: {bad}")


def cg(path, reps):
    sts, _ = _strokes(path)
    for _ in range(reps):
        with ss.StrokeStore() as st:
            st.append(sts)
            back = st.load(0, len(st))
            del back


if __name__ == "__main__":
    mode, path = sys.argv[1], sys.argv[2]
    if mode == "cpu":
        cpu(path)
    elif mode == "rss":
        rss(path, len(sys.argv) > 3 and sys.argv[3] == "mem")
    else:
        cg(path, int(sys.argv[3]) if len(sys.argv) > 3 else 1)
