"""rep52 scratch: what is live at `process --report`'s peak, by allocation site (tracemalloc,
started after the imports).  Snapshots at the report's phase points (after each trace_file,
after the stroke rows, inside the ringing: after each RowTable, after build_report, after
render_html); the one with most traced memory is grouped by file:line (top 25).  Per point:
traced now, the traced peak since the last point and peak RSS.
Usage: memory.py FILE [process options...]  (runs `process FILE -o /tmp/rep52_mem.gcode --report ...`)"""
import os
import sys
import tracemalloc

from gcode_opt import cli, ringing as rg
from gcode_opt.report import data, html
from gcode_opt.rss import peak_rss_mb

best = {"cur": -1}
points = []


TRACE = os.environ.get("REP52_TRACE", "1") != "0"     # 0: peak RSS per point only (no tracing)


def point(label):
    if not TRACE:
        points.append((label, 0.0, 0.0, peak_rss_mb()))
        return
    cur, peak = tracemalloc.get_traced_memory()
    tracemalloc.reset_peak()
    points.append((label, cur / 2**20, peak / 2**20, peak_rss_mb()))
    if cur > best["cur"]:
        snap = tracemalloc.take_snapshot().filter_traces([tracemalloc.Filter(False, tracemalloc.__file__)])
        best.update(cur=cur, label=label, lines=snap.statistics("lineno")[:25], n=len(points))
        del snap
        tracemalloc.reset_peak()


def wrap(mod, name, label, before=False):
    f = getattr(mod, name)

    def g(*a, **k):
        if before:
            point("before " + label)
        r = f(*a, **k)
        point("after " + label)
        return r
    setattr(mod, name, g)


wrap(data, "trace_file", "trace_file")
wrap(data, "_stroke_rows", "_stroke_rows")
wrap(data, "_headline", "_headline")
wrap(data, "_traced", "_traced")
wrap(rg, "busiest_stretch_rows", "busiest_stretch_rows")
wrap(rg, "stretch_rows", "stretch_rows")
wrap(data, "_coverage", "_coverage")
wrap(data, "_warnings", "_warnings")
wrap(html, "build_report", "build_report")
wrap(html, "render_html", "render_html")

if TRACE:
    tracemalloc.start(1)
path = sys.argv[1]
rc = cli.main(["process", path, "-o", "/tmp/rep52_mem.gcode", "-q", "--report", "/tmp/rep52_mem.html"]
              + sys.argv[2:])
print(f"rc {rc}; whole-run peak RSS {peak_rss_mb():.0f} MB")
print(f"{'point':34s} {'traced MB':>9s} {'peak since last':>15s} {'peak RSS':>8s}")
for label, cur, peak, rss in points:
    print(f"{label:34s} {cur:9.1f} {peak:15.1f} {rss:8.0f}")
if not TRACE:
    sys.exit(0)
print(f"\nlargest at point {best['n']} ({best['label']}), {best['cur'] / 2**20:.1f} MB traced:")
for s in best["lines"]:
    print(f"  {s.size / 2**20:8.1f} MB {s.count:9d}  {s.traceback}")
