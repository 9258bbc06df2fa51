"""rect50 scratch: tracemalloc (started after the imports, 1 frame) at the points of
rss_points.py: traced now and the traced peak since the last point; snapshots by site at the
points named on the command line (their n-th occurrence: LABEL@N).  Usage:
traced_points.py FILE [LABEL@N ...]"""
import sys
import tracemalloc

from gcode_opt import blas, malloc_policy
blas.one_thread_from_start()
malloc_policy.apply()
from gcode_opt import cli, pipeline, schedule, segments, plan as plan_mod  # noqa: E402
from gcode_opt.rss import peak_rss_mb  # noqa: E402

points = []
want = set(sys.argv[2:])
seen = {}
snaps = []


def mark(label):
    cur, peak = tracemalloc.get_traced_memory()
    tracemalloc.reset_peak()
    seen[label] = seen.get(label, 0) + 1
    points.append((label, cur / 2**20, peak / 2**20, peak_rss_mb()))
    key = f"{label}@{seen[label]}"
    if key in want:
        snap = tracemalloc.take_snapshot().filter_traces([tracemalloc.Filter(False, tracemalloc.__file__)])
        snaps.append((key, cur, snap.statistics("lineno")[:40], snap.statistics("filename")[:20]))
        del snap
        tracemalloc.reset_peak()


def wrap(mod, name, label=None):
    f = getattr(mod, name)
    label = label or name

    def g(*a, **k):
        mark("> " + label)
        r = f(*a, **k)
        mark("< " + label)
        return r
    setattr(mod, name, g)


for mod, name in [(pipeline, "analyse"), (pipeline, "plan_inputs"), (schedule, "_candidates"),
                  (pipeline, "trim_heap"), (pipeline, "plan_strokes"), (pipeline, "measure"),
                  (pipeline, "rewrite"), (pipeline, "stroke_lines"), (pipeline, "_ringing_after"),
                  (schedule, "plan_auto"), (schedule, "_keep_made_plans"), (schedule, "line_classes"),
                  (plan_mod.Candidates, "of_pieces"), (pipeline, "set_aside_for_rewrite"),
                  (pipeline, "_first_line_order"), (pipeline, "_departures"), (pipeline, "drop_cached")]:
    wrap(mod, name)
for k in schedule.KINDS.values():
    f = k.segments

    def seg(*a, _f=f, **kw):
        mark("> segments")
        r = _f(*a, **kw)
        mark("< segments")
        return r
    k.segments = seg

tracemalloc.start(1)
mark("start")
cli.main(["process", sys.argv[1], "-o", "/tmp/rect50_tr.gcode", "-q"])
mark("end")
print("point, traced now MB, traced peak since the last point MB, peak RSS MB")
for p in points:
    print(f"  {p[0]:<26} {p[1]:7.1f} {p[2]:7.1f} {p[3]:6.0f}")
for key, cur, lines, files in snaps:
    print(f"== {key}: {cur / 2**20:.1f} MB traced")
    for s in files:
        print(f"  {s.size / 2**20:7.2f} MB {s.count:9d} blocks  {s.traceback[0].filename.split('/')[-1]}")
    for s in lines:
        fr = s.traceback[0]
        print(f"  {s.size / 2**20:7.2f} MB {s.count:9d} blocks  {fr.filename.split('/')[-1]}:{fr.lineno}")
