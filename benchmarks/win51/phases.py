"""Peak RSS and CPU of the first planning phases with the strokes as a list (today) or never
all in memory (analyse spilling to a StrokeStore; plan_inputs a window at a time; the
candidates over stored_strokes.StoredStrokes, windows on the same bounds), and whether the
windowed path gives the same bits (digests of every PlanInput array and of the candidate
tables).  One mode a process (peak RSS is a high-water mark):

    PYTHONPATH=TREE python benchmarks/win51/phases.py FILE list|stored|stored_nomemo|fused [WINDOW [candidates|runs]]

(stored_nomemo: the chains' memos let go with their window, as the store keeps them: empty;
fused: plan_inputs made for each window analyse spills, before it is written)

prints one JSON line: peak MB after each phase, process CPU s after each, digests."""
import hashlib
import json
import os
import sys
import time

import numpy as np

from gcode_opt import features as feat
from gcode_opt import pipeline as pl
from gcode_opt.plan_windows import plan_inputs_windowed  # noqa: F401  (the package's: runs.py reads it here)
from gcode_opt.stored_strokes import curve_geometry, join_plan_inputs
from gcode_opt.profile import load_profile
from gcode_opt.rss import peak_rss_mb
from gcode_opt.schedule import (_faults_of, _plan_kind_codes_of, after_candidates, _rows_by_kind, candidates_in_windows,
                               plan_inputs, plan_strokes)
from gcode_opt.stored_strokes import StoredStrokes
from gcode_opt.stroke_store import StrokeStore


def _digest(x):
    h = hashlib.blake2b(digest_size=8)
    if isinstance(x, np.ndarray) and x.dtype == object:
        h.update(repr(x.tolist()).encode())
    elif isinstance(x, np.ndarray):
        h.update(str(x.dtype).encode() + np.ascontiguousarray(x).tobytes())
    else:
        h.update(repr(x).encode())
    return h.hexdigest()


def pin_digests(pin):
    return {k: _digest(v) for k, v in sorted(vars(pin).items()) if not k.startswith("_")}


def cand_digest(c, n):
    cnt = c.cnt
    at = np.repeat(c.first - np.cumsum(cnt) + cnt, cnt) + np.arange(int(cnt.sum()))
    return _digest(np.concatenate([cnt.astype(float), c.t_pos.astype(float).ravel(), c.col[at].astype(float),
                                   c.vals[:, at].ravel()]))


_SPILL = pl._spill_finished


def _fused_plan_inputs(prof, opts):
    """analyse's spill made to take each window's plan_inputs first (the design's step A:
    no second load and write-back); returns the list the windows' PlanInputs go to"""
    parts = []

    def spill(store, strokes, sums):
        k = min(sums.done, len(strokes) - 1)
        if k > 0:
            parts.append(plan_inputs(strokes[:k], prof, opts))
        _SPILL(store, strokes, sums)
    pl._spill_finished = spill
    return parts


def main(path, mode, window=4096, to="runs"):
    prof = load_profile("prusa-mk3s")
    opts = pl.Options(features=feat.default_selection(path)[0])
    out = {"file": os.path.basename(path), "mode": mode, "window": window, "peak_mb": {}, "cpu_s": {}}

    def lap(name):
        out["peak_mb"][name] = peak_rss_mb()
        out["cpu_s"][name] = round(time.process_time(), 3)
    lap("imports")
    if mode == "list":
        strokes, sim0 = pl.analyse(path, prof, opts)
        lap("analyse")
        pin = plan_inputs(strokes, prof, opts)
    elif mode == "fused":
        store = StrokeStore()
        parts = _fused_plan_inputs(prof, opts)
        store, sim0 = pl.analyse(path, prof, opts, store)
        pl._spill_finished = _SPILL
        lap("analyse")
        n0 = sum(len(p.L) for p in parts)
        sts = store.load(n0, len(store))          # (the strokes spilled at analyse's end)
        parts.append(plan_inputs(sts, prof, opts))
        store.rewrite(np.arange(n0, len(store), dtype=np.int64), sts)
        del sts
        pin = join_plan_inputs(parts)
        strokes = StoredStrokes(store, window, on_load=curve_geometry(pin.plan_kind_codes, prof), keep=("chain_T",))
    else:
        store = StrokeStore()
        store, sim0 = pl.analyse(path, prof, opts, store)
        lap("analyse")
        pin = plan_inputs_windowed(store, prof, opts, window)
        strokes = StoredStrokes(store, window, on_load=curve_geometry(pin.plan_kind_codes, prof),
                                keep=("chain_T",) if mode == "stored" else ())
    pl.trim_heap()
    lap("plan_inputs")
    out["pin"] = pin_digests(pin)
    rows = _rows_by_kind(strokes, _plan_kind_codes_of(strokes, pin))
    failed = _faults_of(pin.fault)
    bounds = list(range(0, len(strokes), window)) + [len(strokes)]
    cands, nonfinite = candidates_in_windows(strokes, pin, prof, opts, rows, failed, bounds)
    lap("candidates")
    out["cands"] = cand_digest(cands, len(strokes))
    out["nonfinite"] = len(nonfinite)
    out["strokes"] = len(strokes)
    if mode != "list":
        out["loads"] = strokes.loads
    if to == "candidates":
        print(json.dumps(out))
        return
    # the budget runs as today (plan_strokes over a list of every stroke: the step not yet
    # windowed), on these candidates
    after_candidates(pin, rows, failed, nonfinite)     # (what _candidates does after its tables)
    pin.cached = (cands, None, failed)
    del cands
    if mode != "list":
        strokes.let_go()
        memos = strokes._side.get("chain_T", {})
        strokes = store.load(0, len(store))
        for k, m in memos.items():            # (the chains' memos: the runs start from them)
            strokes[k].chain_T = m
        del memos
        lap("reload")
    plan = plan_strokes(strokes, pin, prof, opts, opts.max_slowdown_r * sim0.time_t)
    lap("runs")
    out["plan"] = {k: _digest(getattr(plan, k)) for k in ("T", "beta", "retime", "t_pred", "a2_pred")}
    print(json.dumps(out))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], *([int(sys.argv[3])] if sys.argv[3:] else []), *sys.argv[4:5])
