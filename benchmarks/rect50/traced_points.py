"""rect50 scratch: tracemalloc (started after the imports, 1 frame) at rss_points.py's
points: traced now and the traced peak since the last point; snapshots by site at the
points named on the command line (their n-th occurrence: "LABEL@N", e.g. "< measure@1").
Usage: traced_points.py FILE [LABEL@N ...]"""
import sys
import tracemalloc

from rss_points import cli, install
from gcode_opt.rss import peak_rss_mb


def main(path, want):
    points, seen, snaps = [], {}, []

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
    install(mark)
    tracemalloc.start(1)
    mark("start")
    cli.main(["process", path, "-o", "/tmp/rect50_tr.gcode", "-q"])
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


if __name__ == "__main__":
    main(sys.argv[1], set(sys.argv[2:]))
