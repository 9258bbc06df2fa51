"""Peak RSS and CPU of the steps after the plan -- rewrite, measure's stroke reads and
measure, the summary's columns and the summary -- with the strokes as a list (today) or
kept in a StrokeStore and made a window at a time (stored_strokes.stored_rows: the rewrite
makes only the re-timed rows' strokes, a window at a time; the measure's line columns and
the summary's columns read from the store), after a list-mode plan (the first pass of
pipeline._process, one pass), and whether the windowed steps give the same bits (the
written file, out_ranges, the measured figures and the summary's JSON).  One mode a process:

    PYTHONPATH=TREE python benchmarks/win52/rewrite.py FILE list|stored [WINDOW] [--trace]
    PYTHONPATH=TREE python benchmarks/win52/rewrite.py FILE dump FOLDER [WINDOW]
    PYTHONPATH=TREE python benchmarks/win52/rewrite.py FILE fresh_list|fresh_stored FOLDER [WINDOW] [--trace]

(dump: the plan and the strokes (their chains' memos let go: the plan's state, which the
steps after it do not read) pickled to FOLDER by one process; fresh_*: read back by a
fresh one -- the strokes a window at a time into a StrokeStore, or all into a list -- so
that the steps after the plan run on a heap that planning never grew: their peak as a
windowed pipeline would see it, not planning's freed arenas.)

Each phase's peak is its own: the high-water mark is reset before it (/proc/self/clear_refs
"5": VmHWM = the resident set then), so a phase after planning shows its own peak, not
planning's.  "rss0" is the resident set at the phase's start (planning's freed arenas
trimmed); "peak" its own high-water mark.  --trace: tracemalloc's live and peak (what
Python and numpy hold, not the heap's layout) per phase too (slow); with WIN52_TOP=PHASE
also what is live as that phase starts, by source line (stderr).  --drop-segs: the segment
plans let go after the rewrite (today they are held through measure for a second pass's
reuse): what measure would peak at without them.
Prints one JSON line."""
import hashlib
import json
import os
import pickle
import sys
import tempfile
import time

import numpy as np

from gcode_opt import features as feat
from gcode_opt import pipeline as pl
from gcode_opt.profile import load_profile
from gcode_opt.schedule import drop_cached, plan_inputs, plan_strokes, set_aside_for_rewrite
from gcode_opt.firmware.simulate import LineRanges, SimResult
from gcode_opt.stored_strokes import StoredStrokes
from gcode_opt.stroke_columns import StrokeColumns
from gcode_opt.stroke_store import StrokeStore


def _status(key):
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(key):
                return int(line.split()[1]) / 1024.0


def _reset_peak():
    with open("/proc/self/clear_refs", "w") as fh:
        fh.write("5")


def _digest(*xs):
    h = hashlib.blake2b(digest_size=8)
    for x in xs:
        h.update(np.ascontiguousarray(x).tobytes() if isinstance(x, np.ndarray) else repr(x).encode())
    return h.hexdigest()


def _file_digest(path):
    h = hashlib.blake2b(digest_size=8)
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


class Phases:
    def __init__(self, trace):
        self.out, self.trace = {}, trace
        self.name = None

    def start(self, name):
        pl.trim_heap()
        self.name = name
        self.rss0 = _status("VmRSS:")
        self.cpu0 = time.process_time()
        if self.trace:
            import tracemalloc
            tracemalloc.reset_peak()
            self.live0 = tracemalloc.get_traced_memory()[0]
            if os.environ.get("WIN52_TOP") == name:       # what is live as the phase starts, by line
                for st in tracemalloc.take_snapshot().statistics("lineno")[:15]:
                    print(f"{name}: {st.size / 2**20:6.2f} MB {st.count:8d} {st.traceback[0]}", file=sys.stderr)
        _reset_peak()

    def stop(self):
        got = {"rss0": round(self.rss0, 1), "peak": round(_status("VmHWM:"), 1),
               "cpu_s": round(time.process_time() - self.cpu0, 3)}
        if self.trace:
            import tracemalloc
            live, peak = tracemalloc.get_traced_memory()
            got.update(py_live0=round(self.live0 / 2**20, 1), py_peak=round(peak / 2**20, 1))
        self.out[self.name] = got


def _planned(path, ph):
    """analyse, plan_inputs and the budget runs as _process's first pass: (strokes, pin,
    plan, sim0, opts, prof)"""
    prof = load_profile("prusa-mk3s")
    opts = pl.Options(features=feat.default_selection(path)[0])
    opts.ringing_parts, opts.summary_rows = True, "table"      # (as --json)
    ph.start("analyse+plan")
    strokes, sim0 = pl.analyse(path, prof, opts)
    pin = plan_inputs(strokes, prof, opts)
    plan = plan_strokes(strokes, pin, prof, opts, opts.max_slowdown_r * sim0.time_t)
    set_aside_for_rewrite(pin, None, last=True)
    ph.stop()
    for st in strokes:                 # (what _process lets go after the rewrite: planning's cache)
        st.curv = None
    return strokes, pin, plan, sim0, opts, prof


def dump(path, folder, window):
    """the plan (and what the steps after it read) pickled to folder/plan.pkl, the strokes
    to folder/strokes.pkl a window at a time (one pickle each)"""
    strokes, pin, plan, sim0, opts, prof = _planned(path, Phases(False))
    opts.progress = None
    pin.L                              # (the arrays set aside read back: set aside again by the reader)
    sim = SimResult()                  # (the compiled result as the Python one: picklable)
    for k, v in sim0.as_dict().items():
        setattr(sim, k, v)
    sim0 = sim
    # (protocol 4: arrays read back into memory of their own -- 5 leaves them views of the
    # pickle's bytes, which the compiled rewrite declines: the Python path, ~10x the CPU)
    with open(os.path.join(folder, "plan.pkl"), "wb") as fh:
        pickle.dump((len(strokes), pin, plan, sim0, opts, prof), fh, protocol=4)
    with open(os.path.join(folder, "strokes.pkl"), "wb") as fh:
        for lo in range(0, len(strokes), window):
            part = strokes[lo:lo + window]
            for st in part:            # (the chains' memos: the plan's state, not the steps after it)
                if st.chain_T is not None:
                    st.chain_T = None
            pickle.dump(part, fh, protocol=4)


def _canonical_dtypes(segs):
    """the segment plans' float64 arrays as views of the canonical float64 dtype: pickle
    gives each array a dtype object of its own, and the compiled rewrite reads an array in
    place only where its dtype is THE float64 one (else it declines: the Python path)"""
    f64, views = np.dtype(np.float64), {}
    for seg in segs:
        for name in ("_s", "_v", "_accel", "_feed"):
            x = getattr(seg, name, None) if seg is not None else None
            if type(x) is np.ndarray and x.dtype is not f64 and x.dtype == f64:
                v = views.get(id(x))
                if v is None:
                    v = views[id(x)] = (x, x.view(np.float64))      # (x kept: its id stays its own)
                setattr(seg, name, v[1])


def _loaded(folder, ph, mode, window, tmp_folder):
    """a dump read back in this (fresh) process: (strokes: a list, or a StoredStrokes whose
    store was filled a window at a time, pin, plan, sim0, opts, prof)"""
    ph.start("load")
    store = StrokeStore(folder=tmp_folder) if mode == "fresh_stored" else None
    strokes = []
    with open(os.path.join(folder, "strokes.pkl"), "rb") as fh:      # (first: the windows' transients freed
        while True:                                                  # before the plan's objects are made)
            try:
                part = pickle.load(fh)
            except EOFError:
                break
            if store is None:
                strokes += part
            else:
                store.append(part)
            del part
    pl.trim_heap()
    with open(os.path.join(folder, "plan.pkl"), "rb") as fh:
        n, pin, plan, sim0, opts, prof = pickle.load(fh)
    pin.set_aside(tmp_folder)
    _canonical_dtypes(plan.segs)
    assert n == (len(strokes) if store is None else len(store))
    ph.stop()
    return (strokes if store is None else StoredStrokes(store, window)), pin, plan, sim0, opts, prof


def main(path, mode, window=4096, trace=False, dumped=None):
    if trace:
        import tracemalloc
        tracemalloc.start()
    ph = Phases(trace)
    out = {"file": os.path.basename(path), "mode": mode, "window": window}
    folder = tempfile.mkdtemp(prefix="win52_")
    if mode.startswith("fresh"):
        strokes, pin, plan, sim0, opts, prof = _loaded(dumped, ph, mode, window, folder)
    else:
        strokes, pin, plan, sim0, opts, prof = _planned(path, ph)
    n = len(strokes)
    store = getattr(strokes, "store", None)
    if mode == "stored":
        ph.start("spill")
        store = StrokeStore(folder=folder)
        store.append(strokes)
        strokes = StoredStrokes(store, window)
        ph.stop()
    tmp = os.path.join(folder, "out.gcode")
    ph.start("rewrite")
    with open(tmp, "w", encoding="utf-8", errors="surrogateescape", newline="") as fh:
        out_ranges = pl.rewrite(path, fh, strokes, plan, prof, opts)
    if "--drop-segs" in sys.argv:      # (what measure would hold without the segment plans: a lead)
        plan.segs = None
        out["segs_dropped"] = True
    ph.stop()
    ph.start("columns")
    cols = StrokeColumns(strokes, fields=False)
    order = pl._first_line_order(cols)
    lines = pl.stroke_lines(cols, order, out_ranges)
    ph.stop()
    ph.start("measure")
    watch = None if lines is None else LineRanges.of_rows(lines[0][order], lines[1][order])
    ring = pl._ring_collector(prof, opts)
    sim1, t1, a21, v21, led = pl.measure(tmp, prof, out_ranges, opts, watch, ring)
    ph.stop()
    ph.start("summary")
    plan.segs = None
    pin.seg_cache = None
    drop_cached(pin)
    pl.trim_heap()
    cols.add_fields(strokes)
    strokes = None
    if store is not None:
        store.close()
    pl.trim_heap()
    ringing, ringing_error = pl._ringing_after(tmp, prof, opts, ring, path)
    from gcode_opt.summary import build_summary
    summary = build_summary(path, "out.gcode", tmp, os.path.getsize(path), prof, opts, cols, pin, plan, sim0, sim1,
                            out_ranges, t1, a21, v21, 0.0, ringing=ringing)
    ph.stop()
    if summary.get("per_stroke") is not None:
        summary["per_stroke"] = list(summary["per_stroke"])
    out["phases"] = ph.out
    out["strokes"] = n
    out["retimed"] = int(np.count_nonzero(plan.retime))
    out["digest"] = {"file": _file_digest(tmp), "out_ranges": _digest(*pl.range_columns(out_ranges)),
                     "lines": _digest(*(lines or ())), "figures": _digest(t1, a21, v21, sim1.time_t),
                     "summary": _digest(json.dumps(summary, sort_keys=True, default=repr)),
                     "columns": _digest(cols.n_moves, *(np.asarray(cols.floats[k], float) for k in sorted(cols.floats)),
                                        *(cols.codes[k] for k in sorted(cols.codes)),
                                        *(list(cols.code_of[k]) for k in sorted(cols.code_of)))}
    if os.environ.get("WIN52_SUMMARY"):
        with open(os.environ["WIN52_SUMMARY"], "w") as fh:
            json.dump(summary, fh, sort_keys=True, indent=1, default=repr)
    os.unlink(tmp)
    os.rmdir(folder)
    print(json.dumps(out))


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if a not in ("--trace", "--drop-segs")]
    if args[1] == "dump":
        dump(args[0], args[2], int(args[3]) if args[3:] else 4096)
    elif args[1].startswith("fresh"):
        main(args[0], args[1], int(args[3]) if args[3:] else 4096, "--trace" in sys.argv, dumped=args[2])
    else:
        main(args[0], args[1], *([int(args[2])] if args[2:] else []), trace="--trace" in sys.argv)
