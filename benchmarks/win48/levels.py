"""win48 scratch (Q1): is the curves' batch dependence the quadrature grid's panel levels (the
largest of a batch's arcs')?  Records the levels each CircleBatch grid plan takes, then with
every grid held at the full run's largest level (FIX=L), compares windows with the full run."""
import os
import sys


from gcode_opt.laws import circle

sys.path.insert(0, os.path.dirname(__file__))
import windows  # noqa: E402

seen = []
_orig = circle.CircleBatch._grid_plan
FIX = int(os.environ.get("FIX", "0"))
FIX_REF = int(os.environ.get("FIX_REF", os.environ.get("FIX", "0")))   # the full run's (default: FIX)


def _grid_plan(self):
    h, levels = _orig(self)
    seen.append(levels)
    return h, max(levels, FIX)


circle.CircleBatch._grid_plan = _grid_plan

path = sys.argv[1]
FIX, FIX_WIN = FIX_REF, FIX
ref, _, n, kinds, rows = windows.tables(path, 1)
FIX = FIX_WIN
print("FIX", FIX, "FIX_REF", FIX_REF, "full run: levels seen", sorted(set(seen)), flush=True)
for K in [int(k) for k in sys.argv[2:]] or [8]:
    seen.clear()
    win, _, _, _, rows = windows.tables(path, K)
    print(f"K={K}: levels seen {sorted(set(seen))}; differing:", windows.compare(ref[0][2], win, rows) or "none (same bits)",
          flush=True)
