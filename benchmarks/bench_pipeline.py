"""Speed and memory of `gcode-opt process`, per phase and end to end, in CPU time.

    python benchmarks/bench_pipeline.py [FILE.gcode ...] [--profile NAME] [--runs N] [--json OUT]

--pure runs every case in pure Python (GCODE_OPT_PURE_PYTHON=1); the heading names the cores
that ran (compiled "c" or "python").

Default files: the largest bundled sample, and the two large plates of
sample_gcode/make_corpus.sh (plate_gyroid 461 k lines, plate_rectilinear 186 k lines) if they
are in its cache folder (make them with `bash sample_gcode/make_corpus.sh`).

Every case runs in a fresh subprocess, so the peak RSS it reports is its own
(getrusage ru_maxrss, imports included; the figure after the imports is given apart).
Inside that subprocess the case and a bare read-split-write loop over the same file
alternate N times; each is timed in CPU seconds (time.process_time, not wall clock: a
shared machine's load does not count) and the median is kept.  So every ratio to the bare
loop is measured in the same run, on the same file, under the same load.

Cases (each includes the ones above it, the phase is the difference):
  read+state   words + machine state over every line (state.events)
  strokes      + stroke grouping (strokes.group_strokes, curve vertex splitter)
  analyse      + the firmware model on the original (pipeline.analyse: pass 1)
  process      the whole job; its phases plan, rewrite, measure (= the firmware model on
               the output, read+state of the output and the ringing Collector riding on it
               included), ringing (a pass of its own only when the last measure played a
               part of the file) and summary come from summary["timing_s"], the CPU seconds
               pipeline.process measures itself.
"""
from __future__ import annotations

import argparse
import glob
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..")
LARGE_DIR = os.path.join(os.environ.get("XDG_CACHE_HOME", os.path.expanduser("~/.cache")), "gcode-opt-corpus")
CASES = ("bare", "read+state", "strokes", "analyse", "process")


def _peak_mb() -> float:
    from gcode_opt.rss import peak_rss_mb      # VmHWM: ru_maxrss counts the parent's at the fork
    return peak_rss_mb()


def bare_loop(path, out):
    """The file's own I/O: read every line, split it, write it."""
    with open(path, newline="") as fi, open(out, "w", newline="") as fo:
        for raw in fi:
            raw.split()
            fo.write(raw)


def run_case(case, path, profile_name, runs):
    """In this (fresh) process: `runs` alternations of the case and the bare loop."""
    sys.path.insert(0, ROOT)
    from gcode_opt import curves
    from gcode_opt.pipeline import Options, analyse, process
    from gcode_opt.profile import load_profile
    from gcode_opt.state import events
    from gcode_opt.strokes import group_strokes
    rss_import = _peak_mb()
    prof = load_profile(profile_name)
    tmpdir = tempfile.mkdtemp(prefix="bench-")
    out = os.path.join(tmpdir, "out.gcode")
    opts = Options()
    timing = []

    def fn():
        if case == "read+state":
            for _ in events(path, prof):
                pass
        elif case == "strokes":
            split = curves.vertex_splitter(prof) if opts.max_turn_deg > 0 else None
            for _ in group_strokes(events(path, prof), opts.features, opts.min_length_d, opts.max_turn_deg,
                                   split):
                pass
        elif case == "analyse":
            analyse(path, prof, opts)
        elif case == "process":
            from gcode_opt import pipeline
            last = getattr(pipeline, "LAST_REMEASURE", {})
            last.clear()
            s = process(path, out, prof, opts)
            # a second pass plays only the stretches around the blocks that changed
            timing.append(dict(s.get("timing_s", {}), rewrite_passes=s.get("rewrite_passes"),
                               remeasured_lines=last.get("played_lines")))

    t_case, t_bare = [], []
    for _ in range(runs):
        t0 = time.process_time()
        bare_loop(path, out)
        t_bare.append(time.process_time() - t0)
        if case != "bare":
            t0 = time.process_time()
            fn()
            t_case.append(time.process_time() - t0)
    for f in os.listdir(tmpdir):
        os.unlink(os.path.join(tmpdir, f))
    os.rmdir(tmpdir)
    res = {"case": case, "cpu_s": statistics.median(t_case) if t_case else statistics.median(t_bare),
           "cpu_runs_s": t_case or t_bare, "bare_cpu_s": statistics.median(t_bare),
           "peak_rss_mb": _peak_mb(), "rss_after_import_mb": rss_import}
    if timing:
        res["timing_s"] = {k: statistics.median([t[k] for t in timing]) for k in timing[0]
                           if timing[0][k] is not None}
    if getattr(opts, "peak_rss_mb", None):        # the process's running peak at the end of each phase
        res["peak_rss_by_phase_mb"] = opts.peak_rss_mb
    res["cores"] = _cores()
    return res


def _cores():
    """Which code ran the per-line parts: the compiled cores ("c") or pure Python."""
    from gcode_opt import state
    from gcode_opt.firmware import simulate
    from gcode_opt import emit
    from gcode_opt.laws import chain
    return {"firmware model": simulate.CORE, "reader": getattr(state, "CORE", "python"),
            "chains": getattr(chain, "CORE", "python"), "rewrite": getattr(emit, "CORE", "python")}


def measure_file(path, profile_name, runs, pure=False):
    with open(path, newline="") as fh:
        n = sum(1 for _ in fh)
    rows = {}
    env = dict(os.environ)
    if pure:
        env["GCODE_OPT_PURE_PYTHON"] = "1"
    for case in CASES:
        r = subprocess.run([sys.executable, os.path.abspath(__file__), "--case", case, "--profile", profile_name,
                            "--runs", str(runs if case != "process" else max(1, runs)), path],
                           capture_output=True, text=True, check=True, env=env)
        rows[case] = json.loads(r.stdout.strip().splitlines()[-1])
    return n, rows


def phases(n, rows):
    """(phase, CPU s, ratio to the bare loop of that same subprocess, peak RSS MB) rows."""
    bare = rows["bare"]["bare_cpu_s"]
    out = [("bare read-split-write loop", bare, 1.0, rows["bare"]["peak_rss_mb"])]
    prev = 0.0
    for case, name in (("read+state", "read + machine state"), ("strokes", "stroke grouping"),
                       ("analyse", "firmware model on the original")):
        t = rows[case]["cpu_s"]
        out.append((name, t - prev, (t - prev) / rows[case]["bare_cpu_s"], rows[case]["peak_rss_mb"]))
        prev = t
    p = rows["process"]
    ts = p.get("timing_s", {})
    peak = p.get("peak_rss_by_phase_mb") or {}
    for key, name in (("plan", "planning"), ("rewrite", "rewrite"),
                      ("measure", "firmware model on the output (+ ringing)"),
                      ("ringing", "ringing pass of its own"), ("summary", "summary")):
        if key in ts:
            out.append((name, ts[key], ts[key] / p["bare_cpu_s"], peak.get(key) or p["peak_rss_mb"]))
    out.append(("process, end to end", p["cpu_s"], p["cpu_s"] / p["bare_cpu_s"], p["peak_rss_mb"]))
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("files", nargs="*")
    ap.add_argument("--profile", default="prusa-mk3s")
    ap.add_argument("--runs", type=int, default=3, help="alternations per case (median kept)")
    ap.add_argument("--case", choices=CASES, help=argparse.SUPPRESS)    # internal: one case, JSON out
    ap.add_argument("--json", help="write every figure to this file")
    ap.add_argument("--pure", action="store_true",
                    help="pure Python (GCODE_OPT_PURE_PYTHON=1): the figures without the compiled cores")
    a = ap.parse_args()
    if a.case:
        print(json.dumps(run_case(a.case, a.files[0], a.profile, a.runs)))
        return
    files = a.files or ([max(glob.glob(os.path.join(ROOT, "sample_gcode", "*.gcode")), key=os.path.getsize)]
                        + sorted(glob.glob(os.path.join(LARGE_DIR, "plate_*.gcode"))))
    report = []
    for path in files:
        n, rows = measure_file(path, a.profile, a.runs, a.pure)
        ph = phases(n, rows)
        cores = ", ".join(f"{k} {v}" for k, v in rows["process"].get("cores", {}).items())
        print(f"{os.path.relpath(path)}: {n:,} lines, {os.path.getsize(path) / 1e6:.2f} MB, profile {a.profile}, "
              f"median of {a.runs} (CPU time); cores: {cores}")
        print(f"  {'phase':<32} {'CPU s':>8} {'lines/s':>12} {'x bare':>8} {'peak RSS MB':>12}")
        for name, t, r, rss in ph:
            lps = n / t if t > 0 else float("inf")
            print(f"  {name:<32} {t:8.3f} {lps:12,.0f} {r:8.1f} {rss:12.1f}")
        ts = rows['process'].get('timing_s', {})
        replayed = ts.get("remeasured_lines")
        print(f"  (RSS after the imports: {rows['read+state']['rss_after_import_mb']:.1f} MB; "
              f"rewrite+measure passes: {ts.get('rewrite_passes')}"
              + (f"; the second measure played {replayed:,.0f} lines of the first pass's file" if replayed else "")
              + ")")
        report.append({"file": path, "lines": n, "cases": rows,
                       "phases": [{"phase": p, "cpu_s": t, "x_bare": r, "peak_rss_mb": m} for p, t, r, m in ph]})
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(report, fh, indent=1)


if __name__ == "__main__":
    main()
