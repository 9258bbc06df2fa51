"""win48 scratch (Q3): what is live at planning's peak, by allocation site (tracemalloc, started
after the imports).  Snapshots at the pipeline's phase points (after analyse, plan_inputs,
_candidates, before each trim_heap, after plan_strokes); the one with most traced memory is
grouped by file:line (top 25), and by module.  Also per point: traced now and the traced peak
since the last point (a transient between points shows only there).  Usage: memory.py FILE"""
import sys
import tracemalloc

from gcode_opt import features as feat, pipeline, schedule
from gcode_opt.pipeline import Options
from gcode_opt.profile import load_profile
from gcode_opt.rss import peak_rss_mb

best = {"cur": -1}
points = []


def point(label):
    cur, peak = tracemalloc.get_traced_memory()
    tracemalloc.reset_peak()
    points.append((label, cur / 2**20, peak / 2**20, peak_rss_mb()))
    if cur > best["cur"]:
        snap = tracemalloc.take_snapshot().filter_traces([tracemalloc.Filter(False, tracemalloc.__file__)])
        best.update(cur=cur, label=label, lines=snap.statistics("lineno")[:25],
                    files=snap.statistics("filename")[:15], n=len(points))
        del snap
        tracemalloc.reset_peak()


def wrap(mod, name, label):
    f = getattr(mod, name)

    def g(*a, **k):
        r = f(*a, **k)
        point(label)
        return r
    setattr(mod, name, g)


def wrap_before(mod, name, label):
    f = getattr(mod, name)

    def g(*a, **k):
        point(label)
        return f(*a, **k)
    setattr(mod, name, g)


wrap(pipeline, "analyse", "after analyse")
wrap(pipeline, "plan_inputs", "after plan_inputs")
wrap(schedule, "_candidates", "after _candidates")
wrap_before(pipeline, "trim_heap", "before trim_heap")
wrap(pipeline, "plan_strokes", "after plan_strokes")
wrap(pipeline, "measure", "after measure")

path = sys.argv[1]
prof = load_profile("prusa-mk3s")
opts = Options(features=feat.default_selection(path)[0])
tracemalloc.start(1)
pipeline._process(path, "/tmp/win48_mem.gcode", prof, opts)
print("point, traced now MB, traced peak since the last point MB, process peak RSS MB")
for p in points:
    print(f"  {p[0]:<22} {p[1]:7.1f} {p[2]:7.1f} {p[3]:6.0f}")
print(f"largest: point {best['n']} '{best['label']}', {best['cur'] / 2**20:.1f} MB traced")
print("by file:")
for s in best["files"]:
    print(f"  {s.size / 2**20:7.2f} MB {s.count:9d} blocks  {s.traceback[0].filename.split('site-packages/')[-1]}")
print("by line (top 25):")
for s in best["lines"]:
    fr = s.traceback[0]
    print(f"  {s.size / 2**20:7.2f} MB {s.count:9d} blocks  {fr.filename.split('/')[-1]}:{fr.lineno}")
