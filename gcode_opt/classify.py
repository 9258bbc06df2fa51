"""Geometric feature labels for files without feature comments (issue 9 item 4) --
measured, NOT used by the pipeline (see below).

A run is a maximal chain of extruding XY moves at one Z, each starting where the last
ended.  A run whose end comes back to its start is a loop (perimeters, skirt); any other
run is "infill".  The closing gap is PrusaSlicer's seam gap (15 % of the nozzle, 0.06 mm
on a 0.4 mm nozzle), so loops are recognised within LOOP_TOL_D = 0.25 mm, well below
the ~0.9 mm smallest gap of an open solid-infill run measured on the corpus.

Measured on make_corpus.sh's bridges.gcode against its own ;TYPE: comments: every
perimeter/external/overhang/skirt move is a loop and every infill move is not (0 errors
in 50 k moves), but "infill" also takes bridge and top solid infill: of what the default
planner would re-time under these labels only ~89 % of the length is sparse or solid
infill, short of the 95 % asked for enabling it by default.  Concentric infill would
be loops.  So the pipeline does not use it; a file without comments keeps `other`."""
from __future__ import annotations

import math

from .state import ARC, LINE

LOOP_TOL_D = 0.25
LOOP = "loop"
OPEN = "open"


def runs(moves):
    """Extruding runs of Move objects: lists of consecutive chained extrusions."""
    cur = []
    for m in moves:
        xy = m.kind in (LINE, ARC) and (m.x1 != m.x0 or m.y1 != m.y0)
        if not (xy and m.e > 0.0 and m.z0 == m.z1):
            if (xy or m.z1 != m.z0 or m.e < 0.0) and cur:   # travel, Z hop or retraction ends a run
                yield cur
                cur = []
            continue
        if cur and (abs(m.x0 - cur[-1].x1) > 1e-9 or abs(m.y0 - cur[-1].y1) > 1e-9):
            yield cur
            cur = []
        cur.append(m)
    if cur:
        yield cur


def run_label(run, tol_d: float = LOOP_TOL_D) -> str:
    """LOOP if the run returns to its start within tol_d (and has >= 3 moves), else OPEN."""
    gap_d = math.hypot(run[-1].x1 - run[0].x0, run[-1].y1 - run[0].y0)
    return LOOP if len(run) >= 3 and gap_d <= tol_d else OPEN
