"""The whole one-pass command with the strokes never all alive, in one process: analyse
spilling to a StrokeStore, plan_inputs and the candidates a window at a time
(benchmarks/win51/phases.py), the budget runs over a StoredStrokes (benchmarks/win52/runs.py),
the rewrite, the measure and the summary reading the store a window at a time
(benchmarks/win52/rewrite.py) -- following pipeline._process's first pass -- against the
command itself (`list`: pipeline.process, the strokes a list), with each phase's own peak
RSS (VmHWM reset at its start, /proc/self/clear_refs "5"), the running peak and CPU.

    PYTHONPATH=TREE python benchmarks/win52/command.py PLATE list|stored OUT_FOLDER [WINDOW]
        [--drop-segs] [--drop-memos] [--runs-window N] [--held N] [--check REF.gcode REF.json] [--trace]

Options as `python -m gcode_opt process PLATE -o OUT --json J -q` (profile auto, default
features, --json's ringing parts and per-stroke rows).  --check: the written file byte for
byte and the JSON (but timing_s, elapsed_s, output) against the command's.  --drop-segs: each
window's segment plans (plan.segs) let go once the rewrite has written it (only right where
no second pass comes: _process's second pass reuses the first's plans).  --drop-memos: the
chains' memos (StoredStrokes' chain_T side table, which holds their kept plans) let go after
the budget runs (likewise: a second pass's runs start from them).  --trace:
tracemalloc's live memory by line at the end of the budget runs, and near the largest
traced size (a polling thread's snapshot; stderr).  WIN52_NO_RESET=1:
no VmHWM reset (the own peaks are the running ones; ru_maxrss the end-to-end peak).
--runs-window N / --held N: the budget runs and the steps after them over a StoredStrokes of
windows of N strokes / N windows held (default: the candidates' window, 2), the chains' memos
handed over.  A second rewrite pass is not run: the script says whether _process would have made one.
Prints one JSON line."""
import json
import os
import sys
import time


HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from rewrite import _reset_peak, _status  # noqa: E402  (this folder: a phase's own VmHWM)
from gcode_opt import features as feat  # noqa: E402
from gcode_opt import pipeline as pl  # noqa: E402
from gcode_opt import plan_windows  # noqa: E402
from gcode_opt import schedule as sc  # noqa: E402
from gcode_opt.cli import _load_profile  # noqa: E402


class Laps:
    """Each phase's own peak (VmHWM reset at its start), the running peak, CPU s."""

    def __init__(self, trace=False):
        self.own, self.peak, self.cpu = {}, {}, {}
        self.top = 0.0
        self.t0 = time.process_time()
        self.traced = {} if trace else None     # tracemalloc: (live at the end, peak) MB
        self.reset = not os.environ.get("WIN52_NO_RESET")     # (set: the peaks are the running ones)

    def __call__(self, name):
        own = _status("VmHWM:")
        self.top = max(self.top, own)
        self.own[name], self.peak[name] = round(own, 1), round(self.top, 1)
        t = time.process_time()
        self.cpu[name] = round(t - self.t0, 3)
        self.t0 = t
        if self.traced is not None:
            import tracemalloc
            live, top = tracemalloc.get_traced_memory()
            self.traced[name] = (round(live / 2**20, 1), round(top / 2**20, 1))
            tracemalloc.reset_peak()
        if self.reset:
            _reset_peak()


def options(path):
    """profile and Options as the command line's `process PLATE -q --json J`"""
    prof = _load_profile("auto", path, quiet=True)
    features, why = feat.default_selection(path)
    opts = pl.Options(features=features)
    opts.ringing_parts, opts.summary_rows = True, "table"
    return prof, opts, why


def _segs_let_go(plan):
    """pipeline.stored_rows made to let go each window's segment plans once the rewrite
    holds the next window (its rows are written then)"""
    made = pl.stored_rows

    def stored_rows(strokes):
        held = made(strokes)
        hold = held.hold

        def hold_next(rows):
            for r in held._held:
                plan.segs[r] = None
            hold(rows)
        held.hold = hold_next
        return held
    pl.stored_rows = stored_rows


def _trace_top(n=20):
    import tracemalloc
    snap = tracemalloc.take_snapshot()
    for st in snap.statistics("lineno")[:n]:
        print(f"runs end: {st.size / 2**20:6.2f} MB {st.count:8d} {st.traceback[0]}", file=sys.stderr)
    print(f"runs end: traced {tracemalloc.get_traced_memory()[0] / 2**20:.1f} MB", file=sys.stderr)


class PeakSnapshot:
    """tracemalloc's snapshot near the largest traced size: a thread polls the traced size
    and takes a snapshot each time it passes the last snapshot's by STEP (the phase then:
    the one after laps' last)"""
    STEP = 1 << 20

    def __init__(self, laps):
        import threading
        self.laps, self.snap, self.level, self.phase = laps, None, 0, None
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._poll, daemon=True)
        self.thread.start()

    def _poll(self):
        import tracemalloc
        while not self.stop.wait(0.002):
            now = tracemalloc.get_traced_memory()[0]
            if now > self.level + self.STEP:
                self.snap, self.level = tracemalloc.take_snapshot(), now
                self.phase = "after " + (list(self.laps.own)[-1] if self.laps.own else "start")

    def report(self, n=30):
        self.stop.set()
        self.thread.join()
        print(f"peak snapshot ({self.phase}): traced {self.level / 2**20:.1f} MB", file=sys.stderr)
        for st in self.snap.statistics("lineno")[:n]:
            print(f"  {st.size / 2**20:6.2f} MB {st.count:8d} {st.traceback[0]}", file=sys.stderr)


def windowed(path, out_path, prof, opts, window, freeze, lap, out, drop_segs=False, drop_memos=False, trace=False,
             runs_window=None, held=None):
    """_process's first pass with the strokes in a StrokeStore, read a window at a time"""
    from gcode_opt.stored_strokes import StoredStrokes, curve_geometry
    from gcode_opt.stroke_columns import StrokeColumns
    from gcode_opt.stroke_store import StrokeStore
    t_start = time.monotonic()
    folder = os.path.dirname(out_path)
    tmp = out_path + ".tmp"
    with StrokeStore() as store:
        with pl._young_frozen(freeze):
            store, sim0 = pl.analyse(path, prof, opts, store)
        lap("analyse")
        with pl._young_frozen(freeze):
            pin = plan_windows.plan_inputs_windowed(store, prof, opts, window)
        strokes = StoredStrokes(store, window, on_load=curve_geometry(pin.plan_kind_codes, prof), keep=("chain_T",))
        pl.trim_heap()
        lap("plan_inputs")
        with pl._young_frozen(freeze):      # (the candidates on the windows' bounds)
            pin.cached = plan_windows.candidates_windowed(strokes, pin, prof, opts)
        pl.trim_heap()
        lap("candidates")
        strokes.on_load = None      # (the runs make a window's curve geometry as they segment it)
        if runs_window or held:     # (the runs and after on other windows: the memos handed over)
            strokes.let_go()
            side = strokes._side
            strokes = StoredStrokes(store, runs_window or window, held=held or strokes.held, keep=("chain_T",))
            strokes._side = side
        with pl._young_frozen(freeze):
            plan = sc.plan_strokes(strokes, pin, prof, opts, opts.max_slowdown_r * sim0.time_t)
        sc.set_aside_for_rewrite(pin, folder, last=False)
        pl.trim_heap()
        if trace:
            _trace_top()
        lap("runs")
        if drop_segs:
            _segs_let_go(plan)
        if drop_memos:            # (a second pass's runs start from them: state, not cache)
            strokes.let_go()
            strokes._side["chain_T"].clear()
        digests = None if pl.LAZY_DIGESTS else pl.Digests(len(strokes))
        with open(tmp, "w", encoding="utf-8", errors="surrogateescape", newline="") as fh:
            out_ranges = pl.rewrite(path, fh, strokes, plan, prof, opts, digests)
            fh.flush()
            os.fsync(fh.fileno())
        pl.trim_heap()
        lap("rewrite")
        cols = StrokeColumns(strokes, fields=False)
        order = pl._first_line_order(cols)
        lines = pl.stroke_lines(cols, order, out_ranges)
        opts.lines_out = None
        watch = None if lines is None else pl.LineRanges.of_rows(lines[0][order], lines[1][order])
        ring = pl._ring_collector(prof, opts)
        sim1, t1, a21, v21, led = pl.measure(tmp, prof, out_ranges, opts, watch, ring)
        del watch, led, lines, order
        lap("measure")
        # would _process make a second pass?  (its test after measure)
        over_t = (sim1.time_t - sim0.time_t) - opts.max_slowdown_r * sim0.time_t
        departed = pl._departures(plan, out_ranges, t1)
        out["second_pass"] = bool(departed) or not (opts.alpha != "auto" or over_t <= 5e-4 * sim0.time_t)
        out["departed"] = len(departed)
        plan.segs = None
        pin.seg_cache = None
        sc.drop_cached(pin)
        pl.trim_heap()
        cols.add_fields(strokes)
        strokes = None
    pl.trim_heap()
    ringing, ringing_error = pl._ringing_after(tmp, prof, opts, ring, path)
    from gcode_opt.summary import build_summary
    with pl._young_frozen(freeze):
        summary = build_summary(path, out_path, tmp, os.path.getsize(path), prof, opts, cols, pin, plan, sim0,
                                sim1, out_ranges, t1, a21, v21, time.monotonic() - t_start, ringing=ringing)
    if ringing_error:
        summary["ringing_error"] = ringing_error
    # _process's last keys (timing_s: not compared)
    summary["timing_s"] = {}
    for key, mod in (("firmware_core", pl.fwsim), ("reader_core", pl.reader), ("chain_core", pl.chain_law),
                     ("emit_core", pl.emit_mod), ("curve_core", pl.circle_law)):
        summary[key] = mod.CORE
    summary["rewrite_passes"] = 1
    summary["warnings"] = pl._warnings_json(opts.reader_warnings)
    os.replace(tmp, out_path)
    lap("summary")
    return summary


VOLATILE = ("timing_s", "elapsed_s", "output")


def _same_json(a, b):
    """the keys where two summaries differ (but VOLATILE)"""
    return sorted(k for k in set(a) | set(b) if k not in VOLATILE and a.get(k) != b.get(k))


def main(path, mode, folder, window=1024, drop_segs=False, drop_memos=False, check=None, trace=False, runs_window=None,
         held=None):
    if trace:
        import tracemalloc
        tracemalloc.start()
    from gcode_opt.blas import blas_one_thread
    from gcode_opt.summary import dump_json
    lap = Laps(trace)
    lap("imports")
    peak = PeakSnapshot(lap) if trace else None
    prof, opts, why = options(path)
    name = os.path.basename(path).rsplit(".", 1)[0]
    out_path = os.path.join(folder, f"{name}_{mode}.gcode")
    out = {"file": os.path.basename(path), "mode": mode, "window": window if mode != "list" else None,
           "drop_segs": drop_segs, "drop_memos": drop_memos, "runs_window": runs_window, "held": held}
    if mode == "list":
        summary = pl.process(path, out_path, prof, opts)
        out["list_peak_mb"] = opts.peak_rss_mb
        out["list_cpu_s"] = {k: round(v, 3) for k, v in summary["timing_s"].items()}
        lap("command")
    else:
        with blas_one_thread(), pl._strokes_frozen() as freeze:
            summary = windowed(path, out_path, prof, opts, window, freeze, lap, out, drop_segs, drop_memos, trace,
                               runs_window, held)
    fi = summary.get("features")
    if isinstance(fi, dict) and why:           # (the command line's)
        fi["why"] = why
    json_path = os.path.join(folder, f"{name}_{mode}.json")
    with open(json_path, "w") as fh:
        dump_json(summary, fh)
    out.update(own_peak_mb=lap.own, peak_mb=lap.peak, cpu_s=lap.cpu, end_to_end_peak_mb=round(lap.top, 1))
    if peak is not None:
        peak.report()
    if not lap.reset:             # (a reset lowers ru_maxrss too: read only without them)
        import resource
        out["ru_maxrss_mb"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)
    if trace:
        out["traced_live_peak_mb"] = lap.traced
    if check:
        ref_gcode, ref_json = check
        with open(ref_gcode, "rb") as a, open(out_path, "rb") as b:
            out["same_file"] = a.read() == b.read()
        with open(ref_json) as a, open(json_path) as b:
            out["json_differs"] = _same_json(json.load(a), json.load(b))
    os.unlink(out_path)
    os.unlink(json_path)
    print(json.dumps(out))


if __name__ == "__main__":
    argv = sys.argv[1:]
    check = runs_window = held = None
    if "--check" in argv:
        at = argv.index("--check")
        check = argv[at + 1:at + 3]
        del argv[at + 1:at + 3]
    for opt in ("--runs-window", "--held"):
        if opt in argv:
            at = argv.index(opt)
            val = int(argv.pop(at + 1))
            runs_window, held = (val, held) if opt == "--runs-window" else (runs_window, val)
    args = [a for a in argv if not a.startswith("--")]
    main(args[0], args[1], args[2], *([int(args[3])] if args[3:] else []), drop_segs="--drop-segs" in sys.argv,
         drop_memos="--drop-memos" in sys.argv, check=check, trace="--trace" in sys.argv,
         runs_window=runs_window, held=held)
