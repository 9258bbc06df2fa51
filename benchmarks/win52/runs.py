"""Peak RSS and CPU of the budget runs (schedule.plan_strokes) with the strokes as a list
(today) or never all in memory (analyse spilling to a StrokeStore; plan_inputs and the
candidates a window at a time, as benchmarks/win51/phases.py; then plan_strokes over the
same stored_strokes.StoredStrokes: line classes read a chunk at a time, the kinds of
schedule.WINDOW_KINDS segmented a window of rows at a time), and whether the windowed runs
give the same bits (digests of the plan: T, beta, retime, t_pred, a2_pred, reason, and every
row's segment plan).  One mode a process (peak RSS is a high-water mark):

    PYTHONPATH=TREE python benchmarks/win52/runs.py FILE list|stored|reload [WINDOW [KINDS]]

(reload: win51's way, every stroke loaded back as a list before the runs; KINDS: the kinds
segmented a window at a time, comma-separated, default schedule.WINDOW_KINDS)

prints one JSON line: peak MB after each phase, process CPU s after each, digests."""
import hashlib
import json
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "win51"))

import phases  # noqa: E402  (win51: the windowed phases up to the candidates)
from gcode_opt import features as feat  # noqa: E402
from gcode_opt import pipeline as pl  # noqa: E402
from gcode_opt import schedule as sc  # noqa: E402
from gcode_opt.profile import load_profile  # noqa: E402
from gcode_opt.rss import peak_rss_mb  # noqa: E402
from gcode_opt.stored_strokes import StoredStrokes, curve_geometry  # noqa: E402
from gcode_opt.stroke_store import StrokeStore  # noqa: E402


def seg_digest(segs):
    """A digest of every row's segment plan (None, or its arrays' bytes, figures, shape)."""
    h = hashlib.blake2b(digest_size=8)
    for p in segs:
        if p is None:
            h.update(b"-")
            continue
        for a in (p.s, p.v, p.accel, p.feed):
            h.update(np.ascontiguousarray(a, float).tobytes())
        h.update(repr((type(p).__name__, float(p.time_t), float(p.int_a2), p.shape, p.first_cmds)).encode())
    return h.hexdigest()


def plan_digests(plan):
    out = {k: phases._digest(getattr(plan, k)) for k in ("T", "beta", "retime", "t_pred", "a2_pred")}
    out["reason"] = phases._digest(np.asarray(plan.reason, object))
    out["segs"] = seg_digest(plan.segs)
    return out


def main(path, mode, window=1024, kinds=None):
    if kinds is not None:
        sc.WINDOW_KINDS = tuple(k for k in kinds.split(",") if k)
    prof = load_profile("prusa-mk3s")
    opts = pl.Options(features=feat.default_selection(path)[0])
    out = {"file": os.path.basename(path), "mode": mode, "window": window, "kinds": list(sc.WINDOW_KINDS),
           "peak_mb": {}, "cpu_s": {}}

    def lap(name):
        out["peak_mb"][name] = peak_rss_mb()
        out["cpu_s"][name] = round(time.process_time(), 3)
    lap("imports")
    if mode == "list":
        strokes, sim0 = pl.analyse(path, prof, opts)
        lap("analyse")
        pin = sc.plan_inputs(strokes, prof, opts)
    else:
        store = StrokeStore()
        store, sim0 = pl.analyse(path, prof, opts, store)
        lap("analyse")
        pin = phases.plan_inputs_windowed(store, prof, opts, window)
        strokes = StoredStrokes(store, window, on_load=curve_geometry(pin.plan_kind_codes, prof),
                                keep=("chain_T",))
    pl.trim_heap()
    lap("plan_inputs")
    rows = sc._rows_by_kind(strokes, sc._plan_kind_codes_of(strokes, pin))
    failed = sc._faults_of(pin.fault)
    bounds = list(range(0, len(strokes), window)) + [len(strokes)]
    cands, nonfinite = sc.candidates_in_windows(strokes, pin, prof, opts, rows, failed, bounds)
    sc.after_candidates(pin, rows, failed, nonfinite)     # (what _candidates does after its tables)
    pin.cached = (cands, None, failed)
    del cands
    pl.trim_heap()
    lap("candidates")
    if mode == "reload":                      # (win51: every stroke back as a list)
        strokes.let_go()
        memos = strokes._side.get("chain_T", {})
        strokes = store.load(0, len(store))
        for k, m in memos.items():
            strokes[k].chain_T = m
        del memos
        lap("reload")
    if mode == "stored":
        strokes.on_load = None      # (the runs make a window's curve geometry as they segment it)
    plan = sc.plan_strokes(strokes, pin, prof, opts, opts.max_slowdown_r * sim0.time_t)
    lap("runs")
    out["strokes"] = len(strokes)
    if mode == "stored":
        out["loads"] = strokes.loads
        out["whole_batches"] = sc.WHOLE_BATCHES[0]      # (circle kinds sent to Newton: one batch after all)
        out["lazy_lines"] = plan.remake is not None
        # the lines' plans the runs let go (plans53) made again, all at once, for the digests
        sc.segs_for(plan, np.arange(len(strokes)), strokes)
    out["plan"] = plan_digests(plan)
    print(json.dumps(out))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], *([int(sys.argv[3])] if sys.argv[3:] else []), *sys.argv[4:5])
