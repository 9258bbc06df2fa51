"""memo53: process CPU of the candidate step (candidates_in_windows over K even windows; K 0:
schedule._candidates, the one call), after a fresh analyse + plan_inputs (gc.freeze as the
pipeline), the chains' kind alone (candidates_chain's own time, summed) and the whole step;
plus the chains' candidates_chain and solve_flat calls, and the tables' digest (same bits).

    PYTHONPATH=TREE python benchmarks/memo53/cand_cpu.py FILE K [REPEATS]"""
import gc
import hashlib
import sys
import time

import numpy as np

from gcode_opt import chains, schedule
from gcode_opt import features as feat
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile

path, K = sys.argv[1], int(sys.argv[2])
reps = int(sys.argv[3]) if len(sys.argv) > 3 else 3
calls = {"cand": 0, "solve_flat": 0}
spent = [0.0]


def counted(fn, name, timed=False):
    def wrapped(*a, **k):
        calls[name] += 1
        t0 = time.process_time()
        try:
            return fn(*a, **k)
        finally:
            if timed:
                spent[0] += time.process_time() - t0
    return wrapped


chains.solve_flat = counted(chains.solve_flat, "solve_flat")
schedule.KINDS[schedule.K_CHAIN].candidates = counted(chains.candidates_chain, "cand", True)
prof = load_profile("prusa-mk3s")
opts = Options(features=feat.default_selection(path)[0])
out = []
for _ in range(reps):
    strokes, _ = analyse(path, prof, opts)
    pin = schedule.plan_inputs(strokes, prof, opts)
    rows = schedule._rows_by_kind(strokes, schedule._plan_kind_codes_of(strokes, pin))
    failed = schedule._faults_of(pin.fault)
    gc.collect()
    gc.freeze()
    calls.update(cand=0, solve_flat=0)
    spent[0] = 0.0
    t0 = time.process_time()
    if K == 0:
        cands, _ = schedule._candidates(strokes, pin, prof, opts, rows, failed)
    else:
        bounds = np.linspace(0, len(strokes), K + 1).astype(int)
        cands, _ = schedule.candidates_in_windows(strokes, pin, prof, opts, rows, failed, bounds)
    whole = time.process_time() - t0
    h = hashlib.sha1()         # every row's entries in row order (the tables' layout aside)
    cnt = cands.cnt
    at = np.repeat(cands.first - np.cumsum(cnt) + cnt, cnt) + np.arange(int(cnt.sum()))
    for a in (cnt, cands.t_pos, cands.col[at], cands.vals[:, at]):
        h.update(np.ascontiguousarray(a).tobytes())
    out.append((whole, spent[0]))
    print(f"K={K} step {whole:.3f} s chains {spent[0]:.3f} s candidates_chain calls {calls['cand']} "
          f"solve_flat calls {calls['solve_flat']} digest {h.hexdigest()[:16]}", flush=True)
    gc.unfreeze()
    del strokes, pin, cands
    gc.collect()
w, c = np.median(np.array(out), axis=0)
print(f"median K={K}: step {w:.3f} s, chains {c:.3f} s")
