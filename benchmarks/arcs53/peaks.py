"""arcs53: whether CircleBatch.peak_speed (read on the batch's largest panel levels, then
polished by Newton) gives an arc other bits in a batch than alone: TRIALS batches of 30 random
arcs (levels 3..10), each arc's peak in its batch against its own batch of one.

    PYTHONPATH=TREE python benchmarks/arcs53/peaks.py [TRIALS]"""
import sys

import numpy as np

from gcode_opt.laws import circle


def main(trials):
    rng = np.random.default_rng(1)
    differ, levels, arcs = 0, set(), 0
    for _ in range(trials):
        nb = 30
        R = rng.uniform(1, 20, nb)
        S = R * rng.uniform(0.2, 6, nb)
        T = S / rng.uniform(20, 150, nb)
        beta = 10.0 ** rng.uniform(-6, -1, nb)
        v0, v1 = rng.uniform(0, 1, nb) * S / T, rng.uniform(0, 1, nb) * S / T
        law = circle.solve_circles(S / R, T, beta, v0 / R, v1 / R, R)
        peak = law.peak_speed()
        for i in range(nb):
            one = law.take([i])
            levels.add(one.panel_levels())
            differ += int(one.peak_speed()[0] != peak[i])
            arcs += 1
    print(f"{arcs} arcs, own levels {sorted(levels)}: {differ} peak speeds differ alone vs in their batch")


if __name__ == "__main__":
    main(int(sys.argv[1]) if sys.argv[1:] else 40)
