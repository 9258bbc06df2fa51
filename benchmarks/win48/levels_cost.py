"""win48 scratch (Q1): what deciding the curves' grid level for the whole file first would cost:
circle.grid_levels_of on the same arcs the curve candidates' screens solve (every call of
solve_circles_rough in one all-strokes candidate step), timed beside the step.  Usage: FILE"""
import os
import sys
import time

from gcode_opt.laws import circle

sys.path.insert(0, os.path.dirname(__file__))
import windows  # noqa: E402

calls = {"n": 0, "arcs": 0, "t": 0.0, "levels": 0}
_rough = circle.solve_circles_rough


def rough(phi, T, beta, w0, w1, *rest, **kw):
    t0 = time.process_time()
    lv = circle.grid_levels_of(phi, T, beta, w0, w1)
    calls["t"] += time.process_time() - t0
    calls["n"] += 1
    calls["arcs"] += len(phi)
    calls["levels"] = max(calls["levels"], lv or 0)
    return _rough(phi, T, beta, w0, w1, *rest, **kw)


circle.solve_circles_rough = rough
_, cpu, *_ = windows.tables(sys.argv[1], 1)
print(f"candidate step {cpu:.3f} s (with the levels inside); grid_levels_of on {calls['arcs']} arcs in "
      f"{calls['n']} calls: {calls['t']:.3f} s, largest level {calls['levels']}")
