"""cand52: the default command's RSS now and peak RSS (MB) at the candidates' points (no
tracemalloc): before / after each Candidates.piece, of_pieces, _candidates, each trim_heap,
plan_strokes.  Consecutive repeats folded (the largest peak kept).

    PYTHONPATH=TREE python benchmarks/cand52/rss_points.py FILE"""
import sys

import hooks

from gcode_opt import features as feat, malloc_policy, pipeline, plan, schedule
from gcode_opt.profile import load_profile
from gcode_opt.rss import peak_rss_mb

points = []


def rss_now_mb():
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * 4096 / 2**20


def point(label):
    p = (label, rss_now_mb(), peak_rss_mb())
    if points and points[-1][0] == label:
        points[-1] = (label, p[1], max(p[2], points[-1][2]), points[-1][3] + 1)
    else:
        points.append((*p, 1))


def wrap(owner, name, label, static=False):
    hooks.wrap(owner, name, point, label, after_label="after " + label, static=static)


wrap(plan.Candidates, "piece", "piece", static=True)
hooks.wrap_of_pieces(point)
wrap(schedule, "_candidates", "_candidates")
wrap(pipeline, "trim_heap", "trim_heap")
wrap(schedule, "plan_strokes", "plan_strokes")
wrap(pipeline, "plan_strokes", "plan_strokes")
malloc_policy.apply()
path = sys.argv[1]
pipeline._process(path, "/tmp/cand52_rss.gcode", load_profile("prusa-mk3s"),
                  pipeline.Options(features=feat.default_selection(path)[0]))
print("point, times, RSS now MB, peak RSS MB")
for p in points:
    print(f"  {p[0]:<24} x{p[3]:<4} {p[1]:7.1f} {p[2]:7.1f}")
