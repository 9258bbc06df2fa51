"""heap49 scratch (issue 8, memory): where the process's RSS exceeds what is live, and why.

At the pipeline's phase points (analyse, plan_inputs, _candidates, each trim_heap, each
budget run's plan_auto and segment steps, rewrite, measure) it prints the resident set
(VmRSS, anonymous, AnonHugePages), glibc's main heap (mallinfo2: arena, in use, free, top
chunk) and CPython's small-object allocator (obmalloc: 1 MiB arenas, bytes in allocated
blocks).  With --sample a thread reads VmRSS, the [heap] mappings' Rss and mallinfo2 every
~1 ms and reports the largest RSS and the largest RSS less the heap's resident free bytes
(the peak a heap with no slack at all would have had).

The command line's order is kept: blas and malloc_policy are applied before the pipeline
is imported (python -m gcode_opt applies them before its imports too).  Measure with the
tree's bytecode compiled (python -m compileall gcode_opt, or one run of
/work/tools/cg.sh): without it every module is compiled on import, which leaves the
compiler's freed memory in the heap (small file +3.3 MiB, rectilinear +1.4 MiB).

Usage: PYTHONPATH=TREE python rss_above_live.py FILE [--sample]"""
import ctypes
import os
import re
import sys
import threading
import time

from gcode_opt import blas, malloc_policy
from gcode_opt.rss import heap_rss_mb

blas.one_thread_from_start()
malloc_policy.apply()
from gcode_opt import cli, pipeline, schedule  # noqa: E402  (after the policy, as the command line does)

MIB = float(1 << 20)
libc = ctypes.CDLL(None)


class _MallInfo2(ctypes.Structure):
    _fields_ = [(n, ctypes.c_size_t) for n in ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks",
                                                 "fsmblks", "uordblks", "fordblks", "keepcost")]


libc.mallinfo2.restype = _MallInfo2


def status_mib():
    """VmRSS, RssAnon, VmHWM and AnonHugePages, MiB."""
    got = {}
    with open("/proc/self/status") as fh:
        for line in fh:
            key, _, val = line.partition(":")
            if key in ("VmRSS", "RssAnon", "VmHWM"):
                got[key] = int(val.split()[0]) / 1024.0
    with open("/proc/self/smaps_rollup") as fh:
        for line in fh:
            if line.startswith("AnonHugePages"):
                got["THP"] = int(line.split()[1]) / 1024.0
    return got


def obmalloc_mib():
    """(arenas held, bytes in allocated blocks) of CPython's obmalloc, MiB (its stats go to fd 2)."""
    rd, wr = os.pipe()
    saved = os.dup(2)
    os.dup2(wr, 2)
    try:
        sys._debugmallocstats()
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(wr)
    chunks = []
    while True:
        b = os.read(rd, 1 << 16)
        if not b:
            break
        chunks.append(b)
    os.close(rd)
    txt = b"".join(chunks).decode()

    def field(name):
        return int(re.search(re.escape(name) + r"\s*=\s*([\d,]+)", txt).group(1).replace(",", ""))
    return field("# arenas allocated current") * 1.0, field("bytes in allocated blocks") / MIB


rows = []
where = ["start"]


def point(label):
    where[0] = label
    rows.append((label, status_mib(), libc.mallinfo2(), obmalloc_mib()))


def wrap(obj, name, label):
    f = getattr(obj, name)

    def g(*a, **k):
        point("> " + label)
        r = f(*a, **k)
        point("< " + label)
        return r
    setattr(obj, name, g)


for mod, name in ((pipeline, "analyse"), (pipeline, "plan_inputs"), (schedule, "_candidates"),
                  (pipeline, "trim_heap"), (pipeline, "plan_strokes"), (schedule, "plan_auto"),
                  (pipeline, "rewrite"), (pipeline, "measure")):
    wrap(mod, name, name)
for kind_name, kind in schedule.KINDS.items():
    wrap(kind, "segments", "segments " + kind_name)

trace = []
stop = threading.Event()


def sampler():
    while not stop.is_set():
        st, heap, m = status_mib(), heap_rss_mb(), libc.mallinfo2()
        trace.append((where[0], st["VmRSS"], heap, m.uordblks / MIB))
        time.sleep(0.001)


if "--sample" in sys.argv:
    threading.Thread(target=sampler, daemon=True).start()
code = cli.main(["process", sys.argv[1], "-o", "/tmp/heap49_rss_above_live.gcode", "-q"])
stop.set()
point("end")
print(f"{'point':26} {'RSS':>6} {'HWM':>6} {'anon':>6} {'THP':>4} | heap: {'arena':>6} {'inuse':>6} {'free':>6} "
      f"{'top':>5} | obmalloc: {'arenas':>6} {'alloc':>6}")
for label, st, m, ob in rows:
    print(f"{label:26} {st['VmRSS']:6.1f} {st['VmHWM']:6.1f} {st['RssAnon']:6.1f} {st.get('THP', 0):4.0f} |       "
          f"{m.arena / MIB:6.1f} {m.uordblks / MIB:6.1f} {m.fordblks / MIB:6.1f} {m.keepcost / MIB:5.1f} |           "
          f"{ob[0]:6.0f} {ob[1]:6.1f}")
if trace:
    # (a sample's reads are not one instant: one whose heap Rss is off by a trim is dropped)
    ok = [t for t in trace if t[2] >= t[3] - 1.0]
    top = max(trace, key=lambda t: t[1])
    best = max(ok, key=lambda t: t[1] - max(0.0, t[2] - t[3]))
    print(f"largest RSS {top[1]:.1f} MiB (after '{top[0]}'; heap resident {top[2]:.1f}, in use {top[3]:.1f}); "
          f"largest RSS less the heap's resident free bytes {best[1] - max(0.0, best[2] - best[3]):.1f} MiB "
          f"(after '{best[0]}')")
sys.exit(code)
