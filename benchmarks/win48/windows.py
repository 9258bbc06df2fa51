"""win48 scratch (Q1, Q2): candidate tables of all strokes vs the same strokes in K contiguous
windows (by stroke index).  Each configuration gets a fresh analyse + plan_inputs (chains write
their memos into st.chain_T while making candidates: a second pass over the same strokes would
not start from the same state).  Usage: windows.py FILE [K ...]"""
import sys
import time

import numpy as np

from gcode_opt import features as feat
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.schedule import _candidates, _faults_of, _rows_by_kind, _plan_kind_codes_of, plan_inputs


def setup(path):
    prof = load_profile("prusa-mk3s")
    opts = Options(features=feat.default_selection(path)[0])
    strokes, _ = analyse(path, prof, opts)
    pin = plan_inputs(strokes, prof, opts)
    rows = _rows_by_kind(strokes, _plan_kind_codes_of(strokes, pin))
    return prof, opts, strokes, pin, rows


def tables(path, K):
    """[(lo, hi, Candidates)] of K windows, and the CPU seconds of the candidate step."""
    prof, opts, strokes, pin, rows = setup(path)
    n = len(strokes)
    bounds = np.linspace(0, n, K + 1).astype(int)
    out, cpu = [], 0.0
    for lo, hi in zip(bounds[:-1], bounds[1:]):
        rw = {k: r[(r >= lo) & (r < hi)] for k, r in rows.items()}
        failed = _faults_of(pin.fault)
        t0 = time.process_time()
        cands, _ = _candidates(strokes, pin, prof, opts, rw, failed)
        cpu += time.process_time() - t0
        out.append((lo, hi, cands))
    kinds = {k: r.size for k, r in rows.items()}
    return out, cpu, n, kinds, rows


def entries(c, ii):
    """(cnt, t_pos, col, vals) of rows ii, entries concatenated in row order."""
    cnt = c.cnt[ii]
    idx = np.repeat(c.first[ii] - np.cumsum(cnt) + cnt, cnt) + np.arange(cnt.sum())
    return cnt, c.t_pos[ii], c.col[idx], c.vals[:, idx]


def compare(full, win, rows):
    every = np.sort(np.concatenate([r for r in rows.values()]))
    kind_of = np.full(full.cnt.size, "", object)
    for k, r in rows.items():
        kind_of[r] = k
    res = {}
    for lo, hi, c in win:
        ii = every[(every >= lo) & (every < hi)]
        a, b = entries(full, ii), entries(c, ii)
        if not np.array_equal(a[0], b[0]):
            bad = ii[a[0] != b[0]]
            for k in set(kind_of[bad]):
                res.setdefault(k, [0, 0, 0.0])[0] += int((kind_of[bad] == k).sum())
            continue
        rowd = np.repeat(ii, a[0])
        tp = a[1] != b[1]
        for i in ii[tp]:
            res.setdefault(kind_of[i], [0, 0, 0.0])[0] += 1
        d = (a[3] != b[3]) & ~(np.isnan(a[3]) & np.isnan(b[3]))
        d |= (a[2] != b[2])[None, :]
        ent = d.any(axis=0)
        with np.errstate(all="ignore"):
            rel = np.abs(a[3] - b[3]) / np.maximum(np.abs(a[3]), 1e-300)
        rel = np.where(d, rel, 0.0)
        for k in set(kind_of[rowd[ent]]):
            m = kind_of[rowd] == k
            r = res.setdefault(k, [0, 0, 0.0])
            r[1] += int((ent & m).sum())
            r[2] = max(r[2], float(np.nanmax(rel[:, ent & m])))
    return res


def main():
    path = sys.argv[1]
    Ks = [int(k) for k in sys.argv[2:]] or [2, 8, 32]
    best = {}
    ref = None
    for K in [1] + Ks:
        cpus = []
        for rep in range(3):
            win, cpu, n, kinds, rows = tables(path, K)
            cpus.append(cpu)
            if rep == 0 and K == 1:
                ref = win[0][2]
                print(f"strokes {n}; by kind {kinds}; entries {ref.vals.shape[1]}", flush=True)
            if rep == 0 and K > 1:
                print(f"K={K}: differing (rows with other cnt/t_pos, entries, max rel) by kind:",
                      compare(ref, win, rows) or "none (same bits)", flush=True)
        best[K] = min(cpus)
        print(f"K={K}: candidate step CPU best of 3 {best[K]:.3f} s (runs {', '.join(f'{c:.3f}' for c in cpus)})",
              flush=True)


if __name__ == "__main__":
    main()
