"""Curve-law cost on real files: the planner's work per curve stroke (polyline chain).

Usage: PYTHONPATH=. python benchmarks/bench_curve_strokes.py [file.gcode ...] [--profile NAME]
For every curve stroke of the file (sparse infill): geometry (κ(s), vertex caps), the
candidate table (7 durations, circle law at κ_eff batched, figures on the true κ(s)), and
the knots + segment plan of the T = T_orig laws.  Prints ms per curve."""
from __future__ import annotations

import sys
import time

import numpy as np

import os as _os
import sys as _sys
_sys.path.insert(0, _os.path.join(_os.path.dirname(_os.path.abspath(__file__)), ".."))

from gcode_opt import curves
from gcode_opt.pipeline import Options, analyse, plan_inputs
from gcode_opt.profile import load_profile
from gcode_opt.segments import SegmentRules


def main(argv):
    prof_name = "prusa-mk3s"
    if "--profile" in argv:
        k = argv.index("--profile")
        prof_name = argv[k + 1]
        del argv[k:k + 2]
    files = argv[1:] or ["sample_gcode/prusa_gyroid.gcode", "sample_gcode/prusa_concentric.gcode"]
    prof = load_profile(prof_name)
    opts = Options(features=("sparse_infill",))
    for f in files:
        strokes, _ = analyse(f, prof, opts)
        rows = np.array([i for i, s in enumerate(strokes) if s.kind == "curve"], int)
        if rows.size == 0:
            print(f"{f}: no curve strokes")
            continue
        t0 = time.perf_counter()
        pin = plan_inputs(strokes, prof, opts)          # builds each curve's geometry once
        t_geo = time.perf_counter() - t0
        t0 = time.perf_counter()
        T, beta, I, KE = curves.candidates_curve(pin, rows, strokes, prof)
        t_cand = time.perf_counter() - t0
        j = curves.CURVE_COLS[2]
        ok = np.isfinite(I[:, j])
        sub = [strokes[i] for i in rows[ok]]
        rules = SegmentRules.for_profile(prof, opts.max_segments)
        t0 = time.perf_counter()
        curves.plan_curve_segments(sub, T[ok, j], beta[ok, j], rules, prof)
        t_seg = time.perf_counter() - t0
        moves = sum(strokes[i].n_moves for i in rows)
        print(f"{f} ({prof_name}): {rows.size} curve strokes, {moves} G1 lines")
        print(f"  geometry + plan inputs: {1e3 * t_geo / rows.size:.3f} ms/curve")
        print(f"  candidate table: {1e3 * t_cand / rows.size:.3f} ms/curve "
              f"({len(curves.CURVE_T_RATIOS)} durations, {int(np.isfinite(I).sum())} feasible laws)")
        print(f"  chosen law + vertex knots + segments: {1e3 * t_seg / max(ok.sum(), 1):.3f} ms/curve ({ok.sum()})")


if __name__ == "__main__":
    main(sys.argv)
