"""win50: CPU of the candidate step, one call (schedule._candidates) vs
schedule.candidates_in_windows at K contiguous windows of strokes, best of 3
(time.process_time), a fresh analyse + plan_inputs each; by part.  K 0 = the one call.
Usage: candidates_cpu.py FILE K [K ...]   (DECIDE=1: decide_first)"""
import collections
import os
import sys
import time

import numpy as np

from gcode_opt import curves, schedule
from gcode_opt import features as feat
from gcode_opt import plan as plan_mod
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_ARC, K_CHAIN, K_CURVE, K_LINE

acc = collections.defaultdict(float)


def timed(name, fn):
    def w(*a, **k):
        t = time.process_time()
        try:
            return fn(*a, **k)
        finally:
            acc[name] += time.process_time() - t
    return w


NAMES = {K_LINE: "lines", K_CURVE: "curves", K_CHAIN: "chains", K_ARC: "arcs"}
for k, kind in schedule.KINDS.items():
    if k != K_CURVE:                    # (the curves' kind calls curves.candidates_curve, timed below)
        kind.candidates = timed(NAMES[k], kind.candidates)
curves.candidates_curve = timed("curves", curves.candidates_curve)
curves.curve_grid_levels = timed("levels", curves.curve_grid_levels)
plan_mod.PiecesMemo.add = timed("lines", plan_mod.PiecesMemo.add)
plan_mod.Candidates.of_pieces = classmethod(timed("of_pieces", plan_mod.Candidates.of_pieces.__func__))


def setup(path):
    prof = load_profile("prusa-mk3s")
    opts = Options(features=feat.default_selection(path)[0])
    strokes, _ = analyse(path, prof, opts)
    pin = schedule.plan_inputs(strokes, prof, opts)
    rows = schedule._rows_by_kind(strokes, schedule._plan_kind_codes_of(strokes, pin))
    return prof, opts, strokes, pin, rows


def main():
    path = sys.argv[1]
    decide = bool(int(os.environ.get("DECIDE", "0")))
    for K in [int(x) for x in sys.argv[2:]]:
        runs = []
        for _ in range(3):
            prof, opts, strokes, pin, rows = setup(path)
            failed = schedule._faults_of(pin.fault)
            acc.clear()
            t = time.process_time()
            if K == 0:
                schedule._candidates(strokes, pin, prof, opts, rows, failed)
            else:
                bounds = np.linspace(0, len(strokes), K + 1).astype(int)
                schedule.candidates_in_windows(strokes, pin, prof, opts, rows, failed, bounds, None, decide)
            runs.append((time.process_time() - t, dict(acc)))
        best = min(runs, key=lambda r: r[0])
        print(f"K={K or '1 (one call)'}: best {best[0]:.3f} s (runs {', '.join(f'{r[0]:.3f}' for r in runs)}); "
              + ", ".join(f"{k} {v:.3f}" for k, v in sorted(best[1].items())), flush=True)


if __name__ == "__main__":
    main()
