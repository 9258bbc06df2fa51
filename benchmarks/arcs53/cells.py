"""arcs53: the candidate cells that differ between one call (schedule._candidates) and
schedule.candidates_in_windows at windows of W strokes, on the samples with arcs or curves;
and the arcs sent to Newton (circle.NEWTON_ARCS) by each.

    PYTHONPATH=TREE python benchmarks/arcs53/cells.py [SAMPLE:PROFILE ...] [--windows 1,7,37,256]"""
import sys
import time

import numpy as np

from gcode_opt import features as feat
from gcode_opt.laws import circle
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.schedule import _candidates, _faults_of, _plan_kind_codes_of, _rows_by_kind, candidates_in_windows, plan_inputs
from gcode_opt.strokes import K_ARC, K_CURVE

CASES = ["prusa_gyroid_arcs.gcode:prusa-mk3s", "prusa_concentric_arcs.gcode:prusa-mk3s",
         "prusa_benchy_like.gcode:prusa-mk3s", "prusa_benchy_like.gcode:voron24", "prusa_gyroid.gcode:prusa-mk3s",
         "prusa_concentric.gcode:prusa-mk3s",
         "edge/arcs.gcode:prusa-mk3s", "edge/arc_variants.gcode:prusa-mk3s"]


def setup(path, prof_name):
    prof = load_profile(prof_name)
    opts = Options(features=feat.default_selection(path)[0])
    strokes, _ = analyse(path, prof, opts)
    pin = plan_inputs(strokes, prof, opts)
    rows = _rows_by_kind(strokes, _plan_kind_codes_of(strokes, pin))
    return prof, opts, strokes, pin, rows


def entries(c):
    cnt = c.cnt
    at = np.repeat(c.first - np.cumsum(cnt) + cnt, cnt) + np.arange(int(cnt.sum()))
    return cnt, c.t_pos, c.col[at], c.vals[:, at], np.repeat(np.arange(cnt.size), cnt)


def main(argv):
    wins = [1, 7, 37, 256]
    if "--windows" in argv:
        k = argv.index("--windows")
        wins = [int(x) for x in argv[k + 1].split(",")]
        argv = argv[:k] + argv[k + 2:]
    for case in argv or CASES:
        name, prof_name = case.split(":")
        path = "sample_gcode/" + name
        prof, opts, strokes, pin, rows = setup(path, prof_name)
        n0 = circle.NEWTON_ARCS[0]
        t0 = time.process_time()
        ref, _ = _candidates(strokes, pin, prof, opts, rows, _faults_of(pin.fault))
        t_ref = time.process_time() - t0
        nw_ref = circle.NEWTON_ARCS[0] - n0
        kind = {}
        for k in (K_ARC, K_CURVE):
            for i in rows.get(k, np.zeros(0, int)).tolist():
                kind[i] = k
        print(f"{case}: {len(strokes)} strokes, arcs {rows.get(K_ARC, np.zeros(0)).size}, "
              f"curves {rows.get(K_CURVE, np.zeros(0)).size}; one call {t_ref:.2f} s CPU, newton {nw_ref}")
        a = entries(ref)
        for w in wins:
            prof, opts, strokes, pin, rows = setup(path, prof_name)
            bounds = np.unique(np.r_[np.arange(0, len(strokes), w), len(strokes)])
            n0 = circle.NEWTON_ARCS[0]
            t0 = time.process_time()
            got, _ = candidates_in_windows(strokes, pin, prof, opts, rows, _faults_of(pin.fault), bounds)
            t = time.process_time() - t0
            b = entries(got)
            same_shape = all(np.array_equal(x, y) for x, y in zip(a[:3], b[:3]))
            if not same_shape:
                print(f"  window {w}: counts / columns differ ({t:.2f} s)")
                continue
            diff = (a[3].view(np.int64) != b[3].view(np.int64))
            cells = np.flatnonzero(diff.any(axis=0))
            srows = np.unique(a[4][cells])
            by = {}
            for r in srows.tolist():
                by[kind.get(r, "other")] = by.get(kind.get(r, "other"), 0) + 1
            rel = 0.0
            if cells.size:
                x, y = a[3][:, cells], b[3][:, cells]
                with np.errstate(all="ignore"):
                    rel = float(np.nanmax(np.abs(x - y) / np.abs(x)))
            print(f"  window {w}: {int(diff.sum())} cells differ (rows T,beta,I,KE: {diff.sum(axis=1).tolist()}), "
                  f"{cells.size} candidates of {srows.size} strokes {by}, max rel {rel:.2g}; "
                  f"newton {circle.NEWTON_ARCS[0] - n0}; {t:.2f} s CPU")


if __name__ == "__main__":
    main(sys.argv[1:])
