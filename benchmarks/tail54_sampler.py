"""The resident set step by step of one `gcode-opt` command, sampled (tail54): a thread reads
/proc/self/statm every ~0.3 ms and keeps the largest RSS seen under a label: the innermost
watched step running, or "after STEP" from its return to the next step's start.  VmHWM (--profile-time's per-phase peaks)
is updated by the kernel only at some events and the child's ru_maxrss differs from it by
~1-2 MB: this shows where inside the tail the resident set is highest.  Linux only.

    PYTHONPATH=TREE python benchmarks/tail54_sampler.py process FILE -o OUT --json J -q --profile P
"""
import importlib
import os
import sys
import threading
import time

STEPS = (("pipeline", "analyse"), ("pipeline", "_planned"), ("pipeline", "plan_strokes"), ("pipeline", "rewrite"),
         ("pipeline", "stroke_lines"), ("pipeline", "measure"), ("pipeline", "_ringing_after"),
         ("stroke_columns", "StrokeColumns.add_fields"), ("summary", "build_summary"), ("summary", "dump_json"))


def main(argv):
    label, peaks = ["start"], {}

    def sample():
        fd = os.open("/proc/self/statm", os.O_RDONLY)
        page_mb = os.sysconf("SC_PAGE_SIZE") / (1 << 20)
        while True:
            os.lseek(fd, 0, 0)
            rss = int(os.read(fd, 100).split()[1]) * page_mb
            name = label[-1]
            peaks[name] = max(peaks.get(name, 0.0), rss)     # (dicts keep the order first seen)
            time.sleep(0.0003)

    def watched(fn, name):
        def step(*a, **k):
            label.append(name)
            try:
                return fn(*a, **k)
            finally:
                label.pop()
                label[-1] = "after " + name
        return step

    for mod, path in STEPS:
        owner = importlib.import_module("gcode_opt." + mod)
        *outer, name = path.split(".")
        for part in outer:
            owner = getattr(owner, part)
        setattr(owner, name, watched(getattr(owner, name), path))
    threading.Thread(target=sample, daemon=True).start()
    from gcode_opt import cli
    try:
        cli.main(argv)
    except SystemExit:
        pass
    label.append("exit")
    time.sleep(0.05)
    for name, mb in list(peaks.items()):
        print(f"  {mb:6.1f} MB  {name}", file=sys.stderr)


if __name__ == "__main__":
    main(sys.argv[1:])
