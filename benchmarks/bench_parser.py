"""Parser speed, measured in one run: bare read-split loop vs gcode-opt's reader (words
only, and words + machine state) vs pygcode (if installed: `pip install pygcode`).

    python benchmarks/bench_parser.py [FILE.gcode]

Prints lines/s and the ratio of each to the bare loop.  Timings are the best of 3 runs
(shared machines are noisy; compare ratios, not absolute numbers)."""
from __future__ import annotations

import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from gcode_opt.profile import load_profile  # noqa: E402
from gcode_opt.state import MachineState  # noqa: E402
from gcode_opt.words import command_of, params_of, split_comment, strip_checksum  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT = os.path.join(HERE, "..", "sample_gcode", "prusa_gyroid.gcode")


def best(fn, lines, runs=3):
    t = min(_once(fn, lines) for _ in range(runs))
    return t


def _once(fn, lines):
    t0 = time.perf_counter()
    fn(lines)
    return time.perf_counter() - t0


def bare(lines):
    n = 0
    for raw in lines:
        n += len(raw.split())
    return n


def words_only(lines):
    for raw in lines:
        code, _ = split_comment(raw)
        code, _ = strip_checksum(code)
        if command_of(code) in ("G0", "G1", "G2", "G3", "G92", "M204"):
            params_of(code)


def with_state(lines):
    st = MachineState(load_profile("generic-klipper"))
    for i, raw in enumerate(lines):
        st.step(i, raw)


def pygcode_parse(lines):
    from pygcode import Line
    errors = 0
    for raw in lines:
        try:
            Line(raw.rstrip("\r\n"))
        except Exception:
            errors += 1
    return errors


def main():
    path = sys.argv[1] if len(sys.argv) > 1 else DEFAULT
    with open(path, newline="") as fh:
        lines = fh.readlines()
    n = len(lines)
    t_bare = best(bare, lines)
    rows = [("bare str.split loop", t_bare), ("gcode-opt words", best(words_only, lines)),
            ("gcode-opt words + machine state", best(with_state, lines))]
    try:
        import pygcode  # noqa: F401  (only to know whether it is installed)
        t0 = time.perf_counter()
        errs = pygcode_parse(lines)
        rows.append((f"pygcode Line() ({errs} lines raised)", time.perf_counter() - t0))
    except ImportError:
        rows.append(("pygcode (not installed)", float("nan")))
    print(f"{path}: {n} lines")
    for name, t in rows:
        print(f"  {name:<40} {n / t:>12,.0f} lines/s   x{t / t_bare:6.1f} the bare loop")


if __name__ == "__main__":
    main()
