"""Where planning's CPU goes: schedule.plan_strokes split into its phases.

Usage: PYTHONPATH=. python benchmarks/bench_planning.py [file.gcode ...] [--profile NAME|auto]
       [--runs N] [--end-to-end]
For each file: analyse once (not timed here: the per-line half), then N runs (default 3) of
plan_inputs + plan_strokes with every phase wrapped in a CPU timer (time.process_time):
  inputs    plan_inputs (limits; each curve's geometry is built by the first run and kept
            on its stroke, so use >= 3 runs: the median is then a later run's)
  line      line candidates (plan.candidates_auto)
  arc       arc candidates (arcs.candidates_arc)
  curve     curve candidates (curves.candidates_curve)
  chain     chain candidates (chains.candidates_chain; a chain is a curve whose vertices
            cap the speed below F, counted apart from the curves here)
  alloc     the time budget's allocation (plan.plan_auto, every re-plan)
  seg-*     segment planning per kind (every re-plan)
Prints the median over runs, in ms per stroke of the phase's kind and in total ms, and the
peak RSS (resource.getrusage, the whole process: it includes analyse; give one file per
process for a per-file figure).  --end-to-end also
times pipeline.process on the file (median CPU time, lines/s).
"""
from __future__ import annotations

import os
import resource
import statistics
import sys
import tempfile
import time

_HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(_HERE, ".."))

from gcode_opt import arcs, chains, curves, schedule  # noqa: E402
from gcode_opt.pipeline import Options, analyse, process  # noqa: E402
from gcode_opt.profile import load_profile  # noqa: E402
from gcode_opt.strokes import K_ARC, K_CHAIN, K_CURVE, K_LINE  # noqa: E402

DEFAULT_FILES = ["sample_gcode/prusa_concentric.gcode", "sample_gcode/prusa_gyroid.gcode",
                 "sample_gcode/prusa_mk3s_rectilinear.gcode"]


class Timers:
    """CPU seconds per phase, accumulated by wrapping the functions schedule.py calls."""

    def __init__(self):
        self.t = {}

    def wrap(self, owner, name, phase):
        fn = getattr(owner, name)

        def timed(*a, **k):
            t0 = time.process_time()
            try:
                return fn(*a, **k)
            finally:
                self.t[phase] = self.t.get(phase, 0.0) + time.process_time() - t0
        setattr(owner, name, timed)
        return lambda: setattr(owner, name, fn)

    def wrap_kind(self, kind, name, phase):
        """A registry entry (schedule.KINDS) holds its functions itself: wrap them there."""
        return self.wrap(schedule.KINDS[kind], name, phase)


def _profile(name, path):
    if name == "auto":
        from gcode_opt.detect import detect_profile
        name, _ = detect_profile(path)
    return load_profile(name), name


def plan_phases(path, prof, opts, runs):
    strokes, sim0 = analyse(path, prof, opts)
    budget_t = opts.max_slowdown_r * sim0.time_t
    count = {k: sum(1 for s in strokes if s.kind == k) for k in (K_LINE, K_ARC, K_CURVE)}
    per_run = []
    for _ in range(runs):
        for st in strokes:            # chains keep their last segment plan: start afresh
            st.chain_T = None
        tm = Timers()
        undo = [tm.wrap(schedule, "candidates_auto", "line"),
                tm.wrap(arcs, "candidates_arc", "arc"),
                tm.wrap(curves, "candidates_curve", "curve"),
                tm.wrap(schedule, "plan_auto", "alloc"),
                tm.wrap(schedule, "plan_segments", "seg-line"),
                tm.wrap(arcs, "plan_arc_segments", "seg-arc"),
                tm.wrap_kind(K_CURVE, "segments", "seg-curve"),
                tm.wrap_kind(K_CHAIN, "candidates", "chain"),
                tm.wrap_kind(K_CHAIN, "segments", "seg-chain")]
        try:
            t0 = time.process_time()
            pin = schedule.plan_inputs(strokes, prof, opts)
            tm.t["inputs"] = time.process_time() - t0
            t0 = time.process_time()
            plan = schedule.plan_strokes(strokes, pin, prof, opts, budget_t)
            tm.t["plan_strokes"] = time.process_time() - t0
        finally:
            for u in undo:
                u()
        per_run.append(tm.t)
    count[K_CURVE] -= sum(1 for s in strokes if chains.plan_kind(s) == K_CHAIN)
    count[K_CHAIN] = sum(1 for s in strokes if chains.plan_kind(s) == K_CHAIN)
    med = {k: statistics.median(r.get(k, 0.0) for r in per_run) for k in per_run[0]}
    return med, count, len(strokes), int(plan.retime.sum())


def end_to_end(path, prof, opts, runs):
    cpu = []
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "out.gcode")
        for _ in range(runs):
            t0 = time.process_time()
            process(path, out, prof, opts)
            cpu.append(time.process_time() - t0)
    return statistics.median(cpu)


def main(argv):
    prof_name, runs, e2e = "auto", 3, False
    if "--profile" in argv:
        k = argv.index("--profile")
        prof_name = argv[k + 1]
        del argv[k:k + 2]
    if "--runs" in argv:
        k = argv.index("--runs")
        runs = int(argv[k + 1])
        del argv[k:k + 2]
    if "--end-to-end" in argv:
        argv.remove("--end-to-end")
        e2e = True
    files = argv[1:] or DEFAULT_FILES
    kind_of = {"line": K_LINE, "arc": K_ARC, "curve": K_CURVE, "seg-line": K_LINE, "seg-arc": K_ARC,
               "seg-curve": K_CURVE, "chain": K_CHAIN, "seg-chain": K_CHAIN}
    for f in files:
        prof, name = _profile(prof_name, f)
        opts = Options()
        with open(f, "rb") as fh:
            n_lines = sum(1 for _ in fh)
        med, count, n, n_re = plan_phases(f, prof, opts, runs)
        print(f"{f} ({name}): {n_lines} lines, {n} strokes "
              f"(line {count[K_LINE]}, arc {count[K_ARC]}, curve {count[K_CURVE]}, chain {count[K_CHAIN]}), "
              f"{n_re} re-timed; "
              f"median of {runs} runs, CPU")
        print(f"  {'phase':<13}{'total ms':>10}{'ms/stroke':>11}")
        for ph in ("inputs", "line", "arc", "curve", "chain", "alloc", "seg-line", "seg-arc", "seg-curve",
                   "seg-chain", "plan_strokes"):
            k = kind_of.get(ph)
            per = count[k] if k else n
            ms = 1e3 * med.get(ph, 0.0)
            print(f"  {ph:<13}{ms:>10.1f}{(ms / per if per else float('nan')):>11.4f}")
        rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print(f"  peak RSS so far {rss_mb:.0f} MB")
        if e2e:
            t = end_to_end(f, prof, opts, runs)
            print(f"  process end to end: {t:.2f} s CPU, {n_lines / t:.0f} lines/s; "
                  f"peak RSS so far {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")
        sys.stdout.flush()


if __name__ == "__main__":
    main(sys.argv)
