"""Arc-law cost on real files: the circle-law solves the planner makes per G2/G3.

Usage: PYTHONPATH=. python benchmarks/bench_arc_strokes.py [file.gcode ...] [--profile NAME]
For every arc stroke of the file (selected features: sparse + solid infill): the candidate
table (7 durations, one circle-law solve + integrals + peaks each, batched), and the final
solve of the chosen laws (knots for emission).  Prints ms per arc for both."""
from __future__ import annotations

import sys
import time

import numpy as np

import os as _os
import sys as _sys
_sys.path.insert(0, _os.path.join(_os.path.dirname(_os.path.abspath(__file__)), ".."))

from gcode_opt import arcs
from gcode_opt.pipeline import Options, analyse, plan_inputs
from gcode_opt.profile import load_profile


def main(argv):
    prof_name = "prusa-mk3s"
    if "--profile" in argv:
        k = argv.index("--profile")
        prof_name = argv[k + 1]
        del argv[k:k + 2]
    files = argv[1:] or ["sample_gcode/prusa_concentric_arcs.gcode", "sample_gcode/prusa_gyroid_arcs.gcode"]
    prof = load_profile(prof_name)
    opts = Options()
    for f in files:
        strokes, _ = analyse(f, prof, opts)
        pin = plan_inputs(strokes, prof, opts)
        rows = np.array([i for i, s in enumerate(strokes) if s.kind == "arc"], int)
        if rows.size == 0:
            print(f"{f}: no arc strokes")
            continue
        arcs.candidates_arc(pin, rows[:2], strokes)            # warm caches
        t0 = time.perf_counter()
        T, beta, I, KE = arcs.candidates_arc(pin, rows, strokes)
        t_cand = time.perf_counter() - t0
        n_solves = int(np.isfinite(I).sum())
        j = arcs.ARC_COLS[2]
        ok = np.isfinite(I[:, j])
        sub = [strokes[i] for i in rows[ok]]
        t0 = time.perf_counter()
        arcs.arc_knots(sub, T[ok, j], beta[ok, j], np.full(ok.sum(), 10), prof)
        t_final = time.perf_counter() - t0
        print(f"{f} ({prof_name}): {rows.size} arc strokes")
        print(f"  candidate table: {1e3 * t_cand / rows.size:.3f} ms/arc "
              f"({len(arcs.ARC_T_RATIOS)} durations, {n_solves} feasible laws)")
        print(f"  chosen law + knots: {1e3 * t_final / max(ok.sum(), 1):.3f} ms/arc ({ok.sum()} arcs)")


if __name__ == "__main__":
    main(sys.argv)
