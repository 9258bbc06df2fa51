"""arcs53: CPU (time.process_time, median of N, a fresh analyse + plan_inputs each) of the
candidates phase: one call (schedule._candidates, W 0) or schedule.candidates_in_windows at
windows of W strokes; and the arcs Newton solved (circle.NEWTON_ARCS).

    PYTHONPATH=TREE python benchmarks/arcs53/cand_cpu.py FILE PROFILE N W [W ...]"""
import statistics
import sys
import time

import numpy as np

from gcode_opt import features as feat
from gcode_opt import schedule
from gcode_opt.laws import circle
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile


def main(path, prof_name, n, wins):
    prof = load_profile(prof_name)
    opts = Options(features=feat.default_selection(path)[0])
    for w in wins:
        times, newton = [], 0
        for _ in range(n):
            strokes, _ = analyse(path, prof, opts)
            pin = schedule.plan_inputs(strokes, prof, opts)
            rows = schedule._rows_by_kind(strokes, schedule._plan_kind_codes_of(strokes, pin))
            failed = schedule._faults_of(pin.fault)
            n0 = circle.NEWTON_ARCS[0]
            t = time.process_time()
            if w == 0:
                schedule._candidates(strokes, pin, prof, opts, rows, failed)
            else:
                bounds = np.unique(np.r_[np.arange(0, len(strokes), w), len(strokes)])
                schedule.candidates_in_windows(strokes, pin, prof, opts, rows, failed, bounds)
            times.append(time.process_time() - t)
            newton = circle.NEWTON_ARCS[0] - n0
            del strokes, pin
        print(f"{path.split('/')[-1]} {prof_name} W={w or 'one call'}: median {statistics.median(times):.3f} s "
              f"(runs {', '.join(f'{x:.3f}' for x in times)}); newton {newton}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], int(sys.argv[3]), [int(x) for x in sys.argv[4:]])
