"""Issue 8 (memory, round 3): planning's peak memory.

* The candidate tables are kept sparse (plan.Candidates: the feasible entries only); they
  must answer as the dense tables the planner used to keep (scatter_candidates, below as it
  was), and plan_auto on them must give the plan the dense tables gave (allocate on each
  group's rows, then the chosen entries), bit for bit.
* plan.isolate leaves no reference cycle: its pieces go as soon as the caller drops them,
  not at the next full garbage collection.
* A curve's geometry (curves.CurveGeom) holds its numbers, not an array object per field
  and stroke.
* curve_knots evaluates its laws by chunks: the knots do not depend on the chunk size.
"""
import functools
import gc
import os
import tracemalloc
import weakref

import numpy as np

from gcode_opt import chains, curves
from gcode_opt import pipeline as pl
from gcode_opt import schedule as sc
from gcode_opt.plan import T_RATIOS, Candidates, allocate, candidates_auto, isolate, plan_auto
from gcode_opt.profile import load_profile
from gcode_opt.segments import SegmentRules

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")


def _scatter_reference(n, pieces, T_fill):
    """The dense tables as the planner built them before they were kept sparse."""
    k = T_fill.shape[1]
    T = np.full((n, k), np.nan)
    beta = np.full((n, k), np.inf)
    I = np.full((n, k), np.inf)
    KE = np.full((n, k), np.nan)
    for sub, (t, b, i, ke) in pieces:
        T[sub], beta[sub], I[sub], KE[sub] = t, b, i, ke
    covered = np.zeros(n, bool)
    for sub, _ in pieces:
        covered[sub] = True
    bad = ~np.isfinite(T) | np.isnan(beta) | np.isnan(I) | (np.isfinite(I) & ~np.isfinite(KE))
    I[bad] = np.inf
    T = np.where(np.isfinite(T), T, T_fill)
    nonfinite = np.flatnonzero(covered & bad.any(axis=1))
    I[nonfinite] = np.inf
    return T, beta, I, KE, nonfinite


def _plan_auto_reference(p, budget_t, T, beta, I, KE, groups):
    """plan_auto on dense tables, as it was."""
    n = len(p.L)
    fine = np.isfinite(p.T_orig) & np.isfinite(p.I_orig)
    groups = [g[fine[g]] for g in groups]
    groups = [g for g in groups if len(g)]
    total_t = sum(float(p.T_orig[g].sum()) for g in groups)
    j = np.full(n, T.shape[1], dtype=int)
    lam = []
    for g in groups:
        share = budget_t * float(p.T_orig[g].sum()) / total_t if total_t > 0 else 0.0
        j[g], lam_g = allocate(T[g], I[g], p.T_orig[g], p.I_orig[g], share)
        lam.append(lam_g)
    k = T.shape[1]
    rows = np.arange(n)
    use = j < k
    jj = np.minimum(j, k - 1)
    return dict(lam=max(lam) if lam else 0.0, retime=use, T=np.where(use, T[rows, jj], p.T_orig),
                beta=np.where(use, beta[rows, jj], np.inf), I_law=np.where(use, I[rows, jj], p.I_orig),
                KE_law=np.where(use, KE[rows, jj], np.nan), none=~np.isfinite(I).any(axis=1))


def _bits(a):
    return np.asarray(a, float).tobytes()


@functools.lru_cache(maxsize=1)
def _pieces(name, profile):
    """The sample's strokes, plan inputs, each kind's candidate pieces (isolate's), failed
    rows, print time and rows by kind (cached: the tests below only read them)."""
    prof = load_profile(profile)
    opts = pl.Options()
    strokes, sim0 = pl.analyse(os.path.join(SAMPLES, name), prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    rows = sc._rows_by_kind(strokes)
    failed = {i: str(r) for i, r in enumerate(pin.fault) if r}
    rules = SegmentRules.for_profile(prof, opts.max_segments)
    pieces = []
    for k, kind in sc.KINDS.items():
        ok = np.array([i for i in rows[k] if i not in failed], int)
        # (the lines' dense tables: their kind keeps them sparse chunk by chunk, held to
        # these by tests/test_mem27_alloc_rows.py)
        fn = ((lambda r: candidates_auto(pin.take(r))) if k == "line"
              else (lambda r, kind=kind: kind.candidates(pin, r, strokes, prof, rules)))
        pieces += isolate(fn, ok, "planning", failed)
    return strokes, pin, pieces, failed, sim0.time_t, rows


def test_sparse_candidates_answer_as_the_dense_tables_and_plan_the_same():
    strokes, pin, pieces, failed, total_t, rows = _pieces("prusa_gyroid.gcode", "prusa-mk3s")
    pieces, failed = list(pieces), dict(failed)
    n = len(strokes)
    kinds = {chains.plan_kind(st) for st in strokes}
    assert {"line", "curve", "chain"} <= kinds
    # a poisoned candidate (NaN beta) and a finite I with a NaN KE: their rows drop out
    sub, (t, b, i, ke) = pieces[0]
    b, ke = b.copy(), ke.copy()
    b[3, 8], ke[7, np.argmax(np.isfinite(i[7]))] = np.nan, np.nan
    pieces[0] = (sub, (t, b, i, ke))
    T, beta, I, KE, bad = _scatter_reference(n, pieces, pin.T_orig[:, None] * T_RATIOS[None, :])
    assert bad.size >= 1
    cands, bad_s = Candidates.of_pieces(n, [Candidates.piece(s, tb, pin.T_orig) for s, tb in pieces], pin.T_orig)
    assert bad_s.tolist() == bad.tolist()
    fin = np.isfinite(I)
    assert np.array_equal(cands.mask, fin)
    assert fin.mean() < 0.5                     # mostly infeasible: what the sparse form saves
    Td, bd, Id, KEd = cands
    for got, want in ((Td, T), (bd, beta), (Id, I), (KEd, KE)):
        assert _bits(got[fin]) == _bits(want[fin])
    assert np.isinf(Id[~fin]).all()
    # the plan, over one group (the planner's) and over groups by kind, at several budgets
    fail = np.array(sorted(set(failed) | set(bad.tolist())), int)
    one = [np.setdiff1d(np.arange(n), fail)]
    by_kind = [np.setdiff1d(r, fail) for r in rows.values()]
    for groups in (one, by_kind):
        for r in (0.0, 0.03, 0.2):
            got = plan_auto(pin, r * total_t, cands, groups)
            want = _plan_auto_reference(pin, r * total_t, T, beta, I, KE, groups)
            assert got.lam == want["lam"]
            assert np.array_equal(got.retime, want["retime"])
            for f in ("T", "beta", "I_law", "KE_law"):
                assert _bits(getattr(got, f)) == _bits(want[f]), f
            assert (got.reason == "no law within limits").tolist() == (want["none"] & ~want["retime"]).tolist()


def test_sparse_tables_are_smaller_than_the_dense_ones():
    strokes, pin, pieces, failed, total_t, rows = _pieces("prusa_gyroid.gcode", "prusa-mk3s")
    n = len(strokes)
    cands, _ = Candidates.of_pieces(n, [Candidates.piece(s, tb, pin.T_orig) for s, tb in pieces], pin.T_orig)
    held = cands.col.nbytes + cands.vals.nbytes + cands.first.nbytes + cands.cnt.nbytes + cands.t_pos.nbytes
    dense = 4 * n * len(T_RATIOS) * 8
    # a row: its first and count (intp) and t_pos, beside its entries' 4 doubles and column each
    assert held <= (4 * 8 + 1) * int(cands.mask.sum()) + n * 18
    assert held < 0.6 * dense


def test_isolate_keeps_no_cycle_and_retries_in_halves_in_order():
    gc.disable()
    try:
        refs = []

        def fn(r):
            if 5 in r.tolist():
                raise ValueError("bad row")
            a = np.arange(float(r.size))
            refs.append(weakref.ref(a))
            return a
        failed = {}
        pieces = isolate(fn, np.arange(10), "test", failed)
        assert [p[0].tolist() for p in pieces] == [[0, 1, 2, 3, 4], [6], [7, 8, 9]]
        assert failed == {5: "error: test (ValueError)"}
        assert all(r() is not None for r in refs)
        del pieces
        assert all(r() is None for r in refs)          # freed without a garbage collection
    finally:
        gc.enable()


def _curves(name="prusa_gyroid.gcode"):
    prof = load_profile("prusa-mk3s")
    strokes, _ = pl.analyse(os.path.join(SAMPLES, name), prof, pl.Options())
    return prof, [st for st in strokes if st.kind == "curve"]


def test_curve_geometry_holds_its_numbers_not_an_array_per_field():
    prof, sts = _curves()
    assert len(sts) > 50
    segs = sum(len(st.pts) - 1 for st in sts)
    gc.collect()
    tracemalloc.start()
    try:
        curves.build_geoms(sts, prof, jerk1=True)
        held, _ = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    # per segment: d, u (2), cos_turn, s_v, kappa_v, caps, caps at the whole jerk: 8 doubles;
    # per block of strokes of one vertex count its arrays' headers; per stroke a few hundred
    # bytes (an array object per field and stroke was ~0.9 kB more: ~380 kB here)
    blocks = len({len(st.pts) for st in sts})
    assert held <= 8 * 8 * segs + 1500 * blocks + 600 * len(sts), (held, segs, blocks, len(sts))
    by_n = {}
    for st in sts:
        by_n.setdefault(len(st.pts), []).append(st.curv)
    same = [gs for gs in by_n.values() if len(gs) > 1]
    assert same
    for gs in same:                           # rows of one block (a block holds <= 2^18 / n^2 strokes)
        assert all(g.d.base is not None and g.d.base is gs[0].d.base for g in gs)


def test_curve_knots_do_not_depend_on_the_chunk(monkeypatch):
    prof, sts = _curves()
    sts = sts[:40]
    T = np.array([st.time_t for st in sts]) * 1.05
    beta = (T / 0.7) ** 2
    ref = curves.curve_knots(sts, T, beta, prof)
    monkeypatch.setattr(curves, "KNOT_ROWS", 3)
    got = curves.curve_knots(sts, T, beta, prof)
    for (s0, v0), (s1, v1) in zip(ref, got):
        assert _bits(s0) == _bits(s1) and _bits(v0) == _bits(v1)


def test_batched_caps_by_chunks_are_the_same(monkeypatch):
    prof, sts = _curves()
    curves.build_geoms(sts, prof, jerk1=True)
    want = [(st.curv.caps.tobytes(), st.curv.caps_jerk1.tobytes()) for st in sts]
    for st in sts:
        st.curv = None
    monkeypatch.setattr(curves, "CAPS_CHUNK", 7)
    curves.build_geoms(sts, prof, jerk1=True)
    assert [(st.curv.caps.tobytes(), st.curv.caps_jerk1.tobytes()) for st in sts] == want


def test_a_replan_without_curve_geometry_rebuilds_it_in_a_batch_and_plans_the_same():
    """The pipeline may drop the curve geometry between passes (st.curv = None): a second
    plan_strokes rebuilds it in one batch (rows of shared blocks) and writes the very
    segments the first one did."""
    prof = load_profile("prusa-mk3s")
    opts = pl.Options()
    strokes, sim0 = pl.analyse(os.path.join(SAMPLES, "prusa_gyroid.gcode"), prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    budget = 0.03 * sim0.time_t
    first = sc.plan_strokes(strokes, pin, prof, opts, budget)
    kinds = [chains.plan_kind(st) for st in strokes]
    assert {"curve", "chain"} <= {k for k, r in zip(kinds, first.retime) if r}
    for st in strokes:
        st.curv = None
    pin.seg_cache = None                      # segment every stroke again
    again = sc.plan_strokes(strokes, pin, prof, opts, budget)
    assert np.array_equal(first.retime, again.retime)
    for a, b in zip(first.segs, again.segs):
        assert (a is None) == (b is None)
        if a is not None:
            assert all(_bits(getattr(a, f)) == _bits(getattr(b, f)) for f in ("s", "v", "accel", "feed"))
            assert a.time_t == b.time_t and a.int_a2 == b.int_a2
    rebuilt = [st.curv for st, r in zip(strokes, again.retime) if r and st.kind == "curve"]
    assert rebuilt and all(g is not None for g in rebuilt)
    assert len({id(g.d.base) for g in rebuilt}) < len(rebuilt)          # batched: blocks shared
