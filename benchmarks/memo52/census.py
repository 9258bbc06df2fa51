"""memo52: what the chains' memos (st.chain_T, chains.ChainMemo) hold on a plate, at the
candidates' end and at the budget runs' points (tracemalloc started after the imports, 1
frame; chains.py's live bytes by line at each point) plus an object census of the memos
(counts, the shared arrays they reach and their bytes, each object counted once).

    PYTHONPATH=TREE python benchmarks/memo52/census.py FILE"""
import sys
import tracemalloc
from array import array

import numpy as np

from gcode_opt import chains, features as feat, pipeline, schedule
from gcode_opt.pipeline import Options
from gcode_opt.profile import load_profile

held = {}
points = []


def _nbytes(x, seen):
    """bytes of x's numbers (arrays, array('d'), _PackedMask, _Cells, _LawCols ...), each once"""
    if x is None or id(x) in seen:
        return 0
    seen.add(id(x))
    if isinstance(x, np.ndarray):
        return x.nbytes if x.base is None else _nbytes(x.base, seen)
    if isinstance(x, array):
        return x.itemsize * len(x)
    if isinstance(x, (tuple, list)):
        return sum(_nbytes(y, seen) for y in x)
    if isinstance(x, chains._PackedMask):
        return _nbytes(x.bits, seen)
    if isinstance(x, chains._Cells):
        return _nbytes(x.at, seen) + _nbytes(x.table, seen)
    if isinstance(x, chains._OuterT):
        return _nbytes(x.base, seen)
    if type(x).__name__ == "_FigsCol":          # (memo52: the rows' places in figs, once made)
        return _nbytes(x.rows._pos, seen)
    return 0


def census(strokes):
    memos = [st.chain_T for st in strokes if getattr(st, "chain_T", None) is not None]
    out = {"memos": len(memos)}
    figs, kept_kinds, segs, srcs = {}, {}, {}, {}
    rows = 0
    seen = set()
    kb = 0
    for m in memos:
        if m.figs is not None:
            figs[id(m.figs)] = m.figs
            rows += m.n
        ks = m.kept if isinstance(m.kept, list) else [m.kept]
        for k in ks:
            kept_kinds[type(k).__name__] = kept_kinds.get(type(k).__name__, 0) + 1
            if type(k) is chains._KeptLaws:
                kb += _nbytes(k.base, seen)
        segs[type(m.seg).__name__] = segs.get(type(m.seg).__name__, 0) + 1
        if m.src is not None:
            srcs[id(m.src)] = m.src
    out["rows"] = rows
    out["figs_arrays"] = len(figs)
    out["figs_MB"] = sum(len(f) * 8 for f in figs.values()) / 2**20
    out["kept_by_type"] = kept_kinds
    out["kept_laws_bases_MB"] = kb / 2**20
    out["seg_by_type"] = segs
    sb = set()
    out["sources"] = len(srcs)
    out["sources_MB"] = sum(_nbytes(s.T, sb) + _nbytes(s.beta, sb) for s in srcs.values()) / 2**20
    return out


def point(label):
    cur, peak = tracemalloc.get_traced_memory()
    tracemalloc.reset_peak()
    snap = tracemalloc.take_snapshot().filter_traces([tracemalloc.Filter(True, chains.__file__)])
    stats = snap.statistics("lineno")
    tot = sum(s.size for s in stats)
    cen = census(held["strokes"]) if "strokes" in held else {}
    points.append((label, cur / 2**20, peak / 2**20, tot / 2**20, stats[:12], cen))


def then_point(f, label, before=None):
    """f, then point(label) (label: a str, or a function of the call's count); before(args)."""
    calls = [0]

    def g(*a, **k):
        if before is not None:
            before(a)
        r = f(*a, **k)
        calls[0] += 1
        point(label if isinstance(label, str) else label(calls[0]))
        return r
    return g


schedule.plan_strokes = pipeline.plan_strokes = then_point(schedule.plan_strokes, "after plan_strokes",
                                                           lambda a: held.update(strokes=a[0]))
schedule._candidates = then_point(schedule._candidates, "after _candidates")
schedule.KINDS[chains.K_CHAIN].segments = then_point(chains.plan_chain_segments, lambda c: f"after chain run {c}")

path = sys.argv[1]
prof = load_profile("prusa-mk3s")
opts = Options(features=feat.default_selection(path)[0])
tracemalloc.start(1)
pipeline._process(path, "/tmp/memo52_census.gcode", prof, opts)
for label, cur, peak, tot, stats, cen in points:
    print(f"== {label}: traced {cur:.1f} MB (peak since last {peak:.1f}), chains.py {tot:.2f} MB")
    for s in stats:
        print(f"   {s.size / 2**20:6.2f} MB {s.count:8d} blocks  chains.py:{s.traceback[0].lineno}")
    print("   census:", cen)
