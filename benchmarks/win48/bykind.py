"""win48 scratch (Q2): the candidate step's CPU by kind, all strokes vs K windows (best of 3
of each kind's total).  Usage: bykind.py FILE [K ...]"""
import os
import sys
import time

from gcode_opt import schedule

sys.path.insert(0, os.path.dirname(__file__))
import windows  # noqa: E402

acc = {}
for k, kind in schedule.KINDS.items():
    def timed(*a, _f=kind.candidates, _k=k):
        t0 = time.process_time()
        try:
            return _f(*a)
        finally:
            acc[_k] = acc.get(_k, 0.0) + time.process_time() - t0
    kind.candidates = timed

path = sys.argv[1]
for K in [1] + [int(k) for k in sys.argv[2:]]:
    best = {}
    for rep in range(3):
        acc.clear()
        _, cpu, *_ = windows.tables(path, K)
        for k, t in acc.items():
            best[k] = min(best.get(k, 1e9), t)
        best["all"] = min(best.get("all", 1e9), cpu)
    print(f"K={K}: " + ", ".join(f"{k} {t:.3f}" for k, t in best.items()), flush=True)
