"""cand52: what the candidates phase holds and allocates, by site (tracemalloc, started
after plan_inputs).  Runs benchmarks/win51/phases.py's path to the candidates (mode list or
stored_nomemo, WINDOW) with points after each window_pieces call, each kind's candidates,
before / inside / after Candidates.of_pieces; prints per point the traced memory now and the
traced peak since the last point, then by site (file:line) the snapshot with the most
traced memory, and the one at POINT (argv 4, a label prefix) if given.

    PYTHONPATH=TREE python benchmarks/cand52/trace.py FILE list|stored_nomemo|default WINDOW [POINT]"""
import os
import sys
import tracemalloc

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "win51"))
import phases  # noqa: E402

import hooks  # noqa: E402

from gcode_opt import chains, curves, plan, schedule  # noqa: E402
from gcode_opt.rss import peak_rss_mb  # noqa: E402

points, snaps = [], {}
want = sys.argv[4] if len(sys.argv) > 4 else None


def point(label):
    if not tracemalloc.is_tracing():
        return
    cur, peak = tracemalloc.get_traced_memory()
    points.append((label, cur / 2**20, peak / 2**20, peak_rss_mb()))
    keep = want is not None and label.startswith(want) and want not in snaps
    if keep or cur > snaps.get("best", (0,))[0]:
        snap = tracemalloc.take_snapshot().filter_traces([tracemalloc.Filter(False, tracemalloc.__file__)])
        if keep:
            snaps[want] = (cur, label, snap.statistics("lineno")[:30])
        if cur > snaps.get("best", (0,))[0]:
            snaps["best"] = (cur, label, snap.statistics("lineno")[:30])
        del snap
    tracemalloc.reset_peak()


def wrap(mod, name, label, before=False):
    hooks.wrap(mod, name, point, label, before)


wrap(curves, "candidates_curve", "curves")
wrap(chains, "candidates_chain", "chains")
wrap(plan.PiecesMemo, "add", "lines memo add")
wrap(plan.Candidates, "piece", "piece")
wrap(plan, "_entry_columns", "entry columns", before=True)
wrap(schedule, "window_pieces", "window_pieces")
hooks.wrap_of_pieces(point)
schedule.Candidates = plan.Candidates
f_cw = schedule.candidates_in_windows


def cw(*a, **k):
    tracemalloc.start(1)
    point("start")
    return f_cw(*a, **k)


phases.candidates_in_windows = cw
if sys.argv[2] == "default":        # the command's path: _candidates of every stroke at once
    from gcode_opt import features as feat, pipeline
    from gcode_opt.profile import load_profile
    f_c = schedule._candidates

    def whole(*a, **k):
        tracemalloc.start(1)
        point("start")
        r = f_c(*a, **k)
        point("after _candidates")
        tracemalloc.stop()
        return r
    schedule._candidates = whole
    pipeline._process(sys.argv[1], "/tmp/cand52_trace.gcode", load_profile("prusa-mk3s"),
                      pipeline.Options(features=feat.default_selection(sys.argv[1])[0]))
else:
    sys.stdout = open(os.devnull, "w")
    phases.main(sys.argv[1], sys.argv[2], int(sys.argv[3]), "candidates")
    sys.stdout = sys.__stdout__
last = None
print("point (repeats folded), traced now MB, max traced peak since the last point MB, peak RSS MB")
rows = []
for p in points:
    if rows and rows[-1][0] == p[0]:
        rows[-1] = (p[0], p[1], max(rows[-1][2], p[2]), p[3], rows[-1][4] + 1)
    else:
        rows.append((*p, 1))
for r in rows:
    print(f"  {r[0]:<24} x{r[4]:<5} {r[1]:7.2f} {r[2]:7.2f} {r[3]:6.1f}")
print(f"traced peak over the phase: {max(p[2] for p in points):.2f} MB")
for key, (cur, label, lines) in snaps.items():
    print(f"snapshot {key}: at '{label}', {cur / 2**20:.2f} MB traced; by line:")
    for s in lines:
        fr = s.traceback[0]
        print(f"  {s.size / 2**20:7.2f} MB {s.count:9d} blocks  {fr.filename.split('/')[-1]}:{fr.lineno}")
