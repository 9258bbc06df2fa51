"""rep53: peak RSS of `process --report` phase by phase.  At each point: the resident set now,
the peak since the last point (VmHWM, reset after each point by writing 5 to
/proc/self/clear_refs) and glibc's heap; REP53_TRACE=1 also traces (tracemalloc, sites of the
point with most traced memory; doubles the RSS, so read only its traced column then).
Usage: phases.py FILE [process options...]  (runs `process FILE -o /tmp/rep53_ph.gcode -q --report ...`)"""
import os
import sys
import tracemalloc

from gcode_opt import cli
from gcode_opt.report import data, html, plots, ringing as rep_ringing
from gcode_opt.rss import heap_rss_mb

TRACE = os.environ.get("REP53_TRACE", "0") == "1"
points = []
best = {"cur": -1}


def _status(key):
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(key):
                return int(line.split()[1]) / 1024.0


def point(label):
    hwm, rss = _status("VmHWM:"), _status("VmRSS:")
    with open("/proc/self/clear_refs", "w") as fh:
        fh.write("5")
    cur = peak = 0.0
    if TRACE:
        cur, peak = (x / 2**20 for x in tracemalloc.get_traced_memory())
        tracemalloc.reset_peak()
        if cur > best["cur"]:
            snap = tracemalloc.take_snapshot()
            best.update(cur=cur, label=label, lines=snap.statistics("lineno")[:25])
            del snap
    points.append((label, rss, hwm, heap_rss_mb(), cur, peak))


def wrap(mod, name, before=False):
    f = getattr(mod, name)

    def g(*a, **k):
        if before:
            point("before " + name)
        r = f(*a, **k)
        point("after " + name)
        return r
    setattr(mod, name, g)


for mod, name, before in ((data, "trace_file", True), (data, "trace_fences", True), (data, "StrokeHeads", False),
                          (data, "_traced", True), (data, "_stroke_rows", False), (data, "_headline", False),
                          (data, "_coverage", False), (data, "_warnings", False), (data, "_representatives", False),
                          (data, "_map_layer", False), (html, "build_report", False),
                          (rep_ringing, "ringing_plot", False), (plots, "reduction_chart", False),
                          (plots, "stroke_chart", False), (plots, "layer_map", True), (html, "render_html", False)):
    if hasattr(mod, name):
        wrap(mod, name, before)

if TRACE:
    tracemalloc.start(1)
rc = cli.main(["process", sys.argv[1], "-o", "/tmp/rep53_ph.gcode", "-q", "--report", "/tmp/rep53_ph.html"]
              + sys.argv[2:])
point("end")
print(f"rc {rc}; whole-run peak RSS {max(p[2] for p in points):.0f} MB")
print(f"{'point':28s} {'RSS now':>8s} {'peak since last':>15s} {'heap':>6s} {'traced':>7s} {'tr.peak':>7s}")
for label, rss, hwm, heap, cur, peak in points:
    print(f"{label:28s} {rss:8.0f} {hwm:15.0f} {heap:6.0f} {cur:7.1f} {peak:7.1f}")
if TRACE:
    print(f"\nlargest at {best['label']}, {best['cur']:.1f} MB traced:")
    for s in best["lines"]:
        print(f"  {s.size / 2**20:8.1f} MB {s.count:9d}  {s.traceback}")
