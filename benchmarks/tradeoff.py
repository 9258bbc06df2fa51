"""The trade-off on a real file: inertia-norm reduction against the print-time budget
(--max-slowdown) and the allowed speed overshoot (--overshoot), all figures from the
firmware model.

    python benchmarks/tradeoff.py [FILE.gcode] [--profile NAME]

Prints a Markdown table (the README's is made with this)."""
from __future__ import annotations

import argparse
import os
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from gcode_opt.pipeline import Options, process  # noqa: E402
from gcode_opt.profile import load_profile  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("file", nargs="?", default=os.path.join(HERE, "..", "sample_gcode", "prusa_mk3s_rectilinear.gcode"))
    ap.add_argument("--profile", default="prusa-mk3s")
    a = ap.parse_args()
    prof = load_profile(a.profile)
    out = os.path.join(tempfile.mkdtemp(), "o.gcode")
    budgets = [0.0, 0.01, 0.03, 0.05, 0.10]
    overshoots = [0.0, 0.10, 0.25, 0.50]
    print(f"{os.path.basename(a.file)}, profile {a.profile}: int|a|^2 dt change on the re-timed strokes "
          f"(whole file in brackets) / whole-file print-time change (firmware model)\n")
    print("| max-slowdown \\ overshoot | " + " | ".join(f"{o:.0%}" for o in overshoots) + " |")
    print("|---" * (len(overshoots) + 1) + "|")
    for b in budgets:
        cells = []
        for o in overshoots:
            s = process(a.file, out, prof, Options(max_slowdown_r=b, overshoot_r=o))
            da = s["retimed_strokes"]["int_a2"]["change"]
            dt = s["print_time_s"]["change"]
            dw = s["whole_file"]["int_a2_change"]
            cells.append(f"{da * 100:+.0f}% ({dw * 100:+.0f}%) / {dt * 100:+.1f}%" if da is not None
                         else "none re-timed")
        print(f"| {b:.0%} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
