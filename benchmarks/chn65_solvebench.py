"""chn65: a solve_flat microbenchmark for the fixed cost of an active-set step: N cold solves
of the sample's first 8 chains (3 steps each).  Run from a tree root, PYTHONHASHSEED fixed:
  PYTHONHASHSEED=1 PYTHONPATH=. valgrind --tool=callgrind python benchmarks/chn65_solvebench.py 300
and subtract the same with N = 0 (the set-up): ~2.4 M instructions a solve at a2d6530."""
import sys

import numpy as np

sys.path.insert(0, "tests")
from chain_cases import fresh_chains  # noqa: E402
from gcode_opt import chains  # noqa: E402
from gcode_opt.laws import chain as LC  # noqa: E402

strokes, pin, rows, prof, rules = fresh_chains("sample_gcode/prusa_gyroid_fullspeed.gcode", "prusa-mk3s")
r = rows[:8]
T = pin.T_orig[r, None] * chains.T_RATIOS[None, chains.CHAIN_COLS]
beta = chains._chain_beta(T)
base = chains._flat_chains([strokes[i] for i in r.tolist()], prof)
fl = base.with_T(T[:, 0], beta[:, 0])
for _ in range(int(sys.argv[1])):
    LC.solve_flat(fl, LC.cold_binding(fl), np.zeros(fl.sv.size), np.zeros(fl.S.size, bool), pieces=False)
