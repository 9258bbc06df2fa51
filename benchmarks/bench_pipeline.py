"""End-to-end speed on the largest bundled sample, measured in one run:

  * bare loop: read every line, split it, write it to a temp file (the file's I/O);
  * gcode-opt's reader alone (words + machine state);
  * the firmware model alone (one simulation of the file);
  * the whole `process` job (analyse + plan + rewrite + measure = 2 simulations).

    python benchmarks/bench_pipeline.py [FILE.gcode] [--profile NAME]

Prints lines/s and each figure's ratio to the bare loop (best of 3; compare ratios)."""
from __future__ import annotations

import argparse
import glob
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from gcode_opt.firmware.simulate import simulate_file  # noqa: E402
from gcode_opt.pipeline import Options, process  # noqa: E402
from gcode_opt.profile import load_profile  # noqa: E402
from gcode_opt.state import events  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


def best_of(fn, runs=3):
    ts = []
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return min(ts)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("file", nargs="?")
    ap.add_argument("--profile", default="prusa-mk3s")
    a = ap.parse_args()
    path = a.file or max(glob.glob(os.path.join(HERE, "..", "sample_gcode", "*.gcode")), key=os.path.getsize)
    prof = load_profile(a.profile)
    with open(path, newline="") as fh:
        n = sum(1 for _ in fh)
    tmpdir = tempfile.mkdtemp()
    out = os.path.join(tmpdir, "out.gcode")

    def bare():
        with open(path, newline="") as fi, open(out, "w", newline="") as fo:
            for raw in fi:
                raw.split()
                fo.write(raw)

    def reader():
        for _ in events(path, prof):
            pass

    def model():
        simulate_file(path, prof)

    def job():
        process(path, out, prof, Options())

    rows = [("bare read-split-write loop", best_of(bare)), ("reader (words + machine state)", best_of(reader)),
            ("firmware model (1 simulation)", best_of(model)), ("gcode-opt process (end to end)", best_of(job))]
    t_bare = rows[0][1]
    print(f"{os.path.relpath(path)}: {n} lines, {os.path.getsize(path) / 1e6:.2f} MB, profile {a.profile}")
    for name, t in rows:
        print(f"  {name:<34} {n / t:>11,.0f} lines/s   x{t / t_bare:7.1f} the bare loop   ({t * 1e3:7.1f} ms)")


if __name__ == "__main__":
    main()
