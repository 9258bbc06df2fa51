"""rect50 scratch: the process's RSS (VmRSS) and peak (VmHWM) at many points of a run, no
tracemalloc (its own memory would move the figures): which step sets the peak.  Points:
before/after each wrapped function.  Usage: rss_points.py FILE"""
import sys

from gcode_opt import blas, malloc_policy
blas.one_thread_from_start()
malloc_policy.apply()
from gcode_opt import cli
from gcode_opt import features as feat, pipeline, schedule, plan as plan_mod, segments
from gcode_opt.pipeline import Options
from gcode_opt.profile import load_profile

points = []


def status():
    d = {}
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(("VmHWM:", "VmRSS:")):
                d[line[:5]] = int(line.split()[1]) / 1024.0
    return d["VmRSS"], d["VmHWM"]


def mark(label):
    rss, hwm = status()
    points.append((label, rss, hwm))


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
                  (schedule, "plan_auto"), (schedule, "_keep_made_plans"), (schedule, "_rebuild_geometry"),
                  (schedule, "_attach_commands"), (schedule, "_lead_out_where_no_command"),
                  (plan_mod.Candidates, "of_pieces"), (pipeline, "set_aside_for_rewrite"),
                  (pipeline, "block_digests"), (pipeline, "remeasure")]:
    if hasattr(mod, name):
        wrap(mod, name)
for k in schedule.KINDS.values():
    f = k.segments
    def seg(*a, _f=f, **kw):
        mark("> segments")
        r = _f(*a, **kw)
        mark("< segments")
        return r
    k.segments = seg

mark("start")
cli.main(["process", sys.argv[1], "-o", "/tmp/rect50_pts.gcode", "-q"])
mark("end")
last_hwm = 0
prev = None
for lab, rss, hwm in points:
    if lab == prev and hwm == last_hwm:
        continue
    flag = " *" if hwm > last_hwm + 0.5 else ""
    print(f"  {lab:<32} rss {rss:6.1f}  hwm {hwm:6.1f}{flag}")
    last_hwm, prev = hwm, lab
