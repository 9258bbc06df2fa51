"""win48 scratch (Q2): how many line strokes' candidate inputs are distinct (plan._same_inputs,
what pieces_once makes once) in all strokes vs summed over K windows.  Usage: FILE [K ...]"""
import os
import sys

import numpy as np

from gcode_opt.plan import _same_inputs
from gcode_opt.schedule import K_LINE

sys.path.insert(0, os.path.dirname(__file__))
import windows  # noqa: E402

path = sys.argv[1]
prof, opts, strokes, pin, rows = windows.setup(path)
r = rows[K_LINE]
for K in [1] + [int(k) for k in sys.argv[2:]]:
    b = np.linspace(0, len(strokes), K + 1).astype(int)
    made = 0
    for lo, hi in zip(b[:-1], b[1:]):
        w = r[(r >= lo) & (r < hi)]
        s = _same_inputs(pin.take(w)) if w.size else None
        made += w.size if s is None else s[0].size
    print(f"K={K}: {r.size} lines, candidate rows made {made} ({made / r.size:.0%})")
