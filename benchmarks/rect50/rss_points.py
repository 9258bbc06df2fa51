"""rect50 scratch: the process's RSS (VmRSS) and peak (VmHWM) before and after the steps of a
run (analyse, plan_inputs, _candidates, each budget run's plan_auto and segment steps, the
trims, rewrite, stroke_lines, measure, the ringing), no tracemalloc: which step sets the
peak.  The command line's order (blas and malloc_policy before the imports; cli.main), but
the package's modules imported before main to be wrapped: the heap's layout differs from
the command's by up to ~2 MB, so compare trees with this script, not with its figures
against --profile-time's.  Usage: rss_points.py FILE"""
import sys

from gcode_opt import blas, malloc_policy
blas.one_thread_from_start()
malloc_policy.apply()
from gcode_opt import cli, pipeline, schedule, plan as plan_mod  # noqa: E402

STEPS = [(pipeline, "analyse"), (pipeline, "plan_inputs"), (schedule, "_candidates"), (pipeline, "trim_heap"),
         (pipeline, "plan_strokes"), (pipeline, "measure"), (pipeline, "rewrite"), (pipeline, "stroke_lines"),
         (pipeline, "_ringing_after"), (schedule, "plan_auto"), (schedule, "_keep_made_plans"),
         (schedule, "line_classes"), (plan_mod.Candidates, "of_pieces"), (pipeline, "set_aside_for_rewrite"),
         (pipeline, "_first_line_order"), (pipeline, "_departures"), (pipeline, "drop_cached")]


def install(mark):
    """mark("> name") before and mark("< name") after each of STEPS and each kind's segments."""
    def wrapped(f, label):
        def g(*a, **k):
            mark("> " + label)
            r = f(*a, **k)
            mark("< " + label)
            return r
        return g
    for mod, name in STEPS:
        setattr(mod, name, wrapped(getattr(mod, name), name))
    for k in schedule.KINDS.values():
        k.segments = wrapped(k.segments, "segments")


def status():
    d = {}
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(("VmHWM:", "VmRSS:")):
                d[line[:5]] = int(line.split()[1]) / 1024.0
    return d["VmRSS"], d["VmHWM"]


def main(path):
    points = []
    install(lambda label: points.append((label,) + status()))
    points.append(("start",) + status())
    cli.main(["process", path, "-o", "/tmp/rect50_pts.gcode", "-q"])
    points.append(("end",) + status())
    last_hwm = 0.0
    for label, rss, hwm in points:
        flag = " *" if hwm > last_hwm + 0.5 else ""
        print(f"  {label:<32} rss {rss:6.1f}  hwm {hwm:6.1f}{flag}")
        last_hwm = max(last_hwm, hwm)


if __name__ == "__main__":
    main(sys.argv[1])
