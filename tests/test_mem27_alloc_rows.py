"""Issue 8 (s25, s27: the plan's peak memory): with the compiled core, plan_auto allocates
the budget on the candidates where Candidates holds them (rows_view: each row's feasible
candidates, then its original; the core's alloc_rows), not on the dense (n, k + 1) tables
nor on packed copies of them (s25's, ~10 MB at the rectilinear plate's peak).  The reference is the dense allocation (Candidates.allocation_tables, _allocate)
by numpy (USE_CORE off) and by the core: the same choices and the same lambda, bit for bit,
on the candidates of real sample files at several budgets and on random tables; tables
whose costs could overflow are left to the dense path."""
import os

import numpy as np
import pytest

from gcode_opt import pipeline, schedule
from gcode_opt import plan as plan_mod
from gcode_opt.plan import Candidates, T_RATIOS
from gcode_opt.profile import load_profile

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")

pytestmark = pytest.mark.skipif(plan_mod._alloc_core() is None, reason="the compiled core is not built")


def _dense(cands, g, T_orig, I_orig, budget, use_core, monkeypatch):
    monkeypatch.setattr(plan_mod, "USE_CORE", use_core)
    Tx, Ix, finite, settle = cands.allocation_tables(g, T_orig, I_orig)
    got = plan_mod._allocate(Tx, Ix, finite, T_orig, budget, settle)
    monkeypatch.setattr(plan_mod, "USE_CORE", True)
    return got


def _packed(cands, g, T_orig, I_orig, budget):
    rv = cands.rows_view(g, T_orig, I_orig)
    assert rv is not None
    j, lam = plan_mod._allocate_rows(cands.vals, rv, budget, plan_mod._alloc_core())
    return rv.columns(cands.mask[g], j, cands.shape[1]), lam


def _same(cands, g, T_orig, I_orig, budget, monkeypatch):
    jp, lp = _packed(cands, g, T_orig, I_orig, budget)
    for use_core in (False, True):
        jd, ld = _dense(cands, g, T_orig, I_orig, budget, use_core, monkeypatch)
        assert np.array_equal(jp, jd)
        assert np.float64(lp).tobytes() == np.float64(ld).tobytes()
    return jp, lp


def _sample_cands(name, prof):
    profile = load_profile(prof)
    opts = pipeline.Options()
    opts.ringing = False
    strokes, sim0 = pipeline.analyse(os.path.join(SAMPLES, name), profile, opts)
    pin = schedule.plan_inputs(strokes, profile, opts)
    failed = {i: str(r) for i, r in enumerate(pin.fault) if r}
    cands, _ = schedule._candidates(strokes, pin, profile, opts, schedule._rows_by_kind(strokes), failed)
    g = np.setdiff1d(np.arange(len(strokes)), np.array(sorted(failed), int))
    g = g[np.isfinite(pin.T_orig[g]) & np.isfinite(pin.I_orig[g])]
    return cands, g, pin, opts.max_slowdown_r * sim0.time_t


@pytest.mark.parametrize("name,prof", [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"),
                                       ("prusa_gyroid_fullspeed.gcode", "prusa-mk3s"),
                                       ("prusa_klipper.gcode", "voron24")])
def test_rows_allocation_is_the_dense_one_on_samples(name, prof, monkeypatch):
    cands, g, pin, budget = _sample_cands(name, prof)
    T_orig, I_orig = pin.T_orig[g], pin.I_orig[g]
    cnt = cands.mask[g].sum(axis=1)
    assert (cnt >= 8).any()                            # wide rows among the others
    lams = []
    for r in (0.05, 0.3, 1.0, 3.0, 1e3):
        j, lam = _same(cands, g, T_orig, I_orig, r * budget, monkeypatch)
        lams.append(lam)
        assert (j < cands.shape[1]).any()
    assert lams[0] > lams[2] > 0.0 and lams[-1] == 0.0     # bisected and early answers both checked


@pytest.mark.parametrize("seed", range(6))
def test_rows_allocation_is_the_dense_one_on_random_tables(seed, monkeypatch):
    rng = np.random.default_rng(seed)
    n, k = 700, len(T_RATIOS)
    T_orig = rng.uniform(0.01, 2.0, n)
    T = T_orig[:, None] * T_RATIOS[None, :]
    I = rng.uniform(0.0, 50.0, (n, k)) * (1.0 + T_RATIOS[None, ::-1])
    # rows from none to all feasible, ties between candidates, zero costs
    I[rng.random((n, k)) < rng.uniform(0.0, 1.0, (n, 1))] = np.inf
    I[rng.random((n, k)) < 0.02] = 0.0
    I[::7, 3] = I[::7, 4] = 10.0
    beta, KE = np.ones((n, k)), np.ones((n, k))
    cands = Candidates.of_tables(T, beta, I, KE, T_orig)
    g = np.sort(rng.choice(n, n - 50, replace=False))      # (rows left out hold entries: gathered)
    I_orig = rng.uniform(10.0, 60.0, n)
    for budget in (0.0, 0.01, 0.1, 0.5, 5.0, -1.0):
        _same(cands, g, T_orig[g], I_orig[g], budget * T_orig.sum(), monkeypatch)


def test_tables_that_could_overflow_stay_dense(monkeypatch):
    n, k = 50, len(T_RATIOS)
    T_orig = np.linspace(0.5, 1.5, n)
    I = np.full((n, k), 5.0)
    I[3, 2] = 1e305
    cands = Candidates.of_tables(T_orig[:, None] * T_RATIOS[None, :], np.ones((n, k)), I, np.ones((n, k)), T_orig)
    g = np.arange(n)
    assert cands.rows_view(g, T_orig, np.full(n, 9.0)) is None
    I[3, 2] = 5.0
    cands = Candidates.of_tables(T_orig[:, None] * T_RATIOS[None, :], np.ones((n, k)), I, np.ones((n, k)), T_orig)
    assert cands.rows_view(g, T_orig, np.full(n, 9.0)) is not None
    assert cands.rows_view(g, T_orig, np.r_[np.nan, np.full(n - 1, 9.0)]) is None
    # plan_auto then answers as the dense tables do (rows_view declined)
    pin = plan_mod.PlanInput(np.ones(n), np.zeros(n), np.zeros(n), np.ones(n), np.ones(n), T_orig, np.full(n, 9.0),
                             np.ones(n), np.zeros(n))
    I[3, 2] = 1e305
    cands = Candidates.of_tables(T_orig[:, None] * T_RATIOS[None, :], np.ones((n, k)), I, np.ones((n, k)), T_orig)
    a = plan_mod.plan_auto(pin, 0.2, cands, [g])
    monkeypatch.setattr(plan_mod, "USE_CORE", False)
    b = plan_mod.plan_auto(pin, 0.2, cands, [g])
    assert (a.T == b.T).all() and (a.retime == b.retime).all() and a.lam == b.lam


def test_plan_auto_on_rows_is_plan_auto_dense(monkeypatch):
    cands, g, pin, budget = _sample_cands("prusa_gyroid_fullspeed.gcode", "prusa-mk3s")
    a = plan_mod.plan_auto(pin, budget, cands, [g])
    monkeypatch.setattr(Candidates, "rows_view", lambda self, rows, T_orig, I_orig: None)
    b = plan_mod.plan_auto(pin, budget, cands, [g])
    for f in ("retime", "T", "beta", "I_law", "KE_law"):
        x, y = getattr(a, f), getattr(b, f)
        assert np.array_equal(np.asarray(x, float).view(np.int64), np.asarray(y, float).view(np.int64)), f
    assert (a.reason == b.reason).all() and a.lam == b.lam and a.retime.sum() > 100


def test_rows_allocation_copies_no_table():
    """What the allocation holds beside the candidates: a few numbers a row, not a copy of
    the feasible entries (s25's packed tables: each row's entries, original and filler)."""
    import tracemalloc
    rng = np.random.default_rng(7)
    n, k = 20000, len(T_RATIOS)
    T_orig = rng.uniform(0.01, 2.0, n)
    I = rng.uniform(0.0, 50.0, (n, k)) * (1.0 + T_RATIOS[None, ::-1])
    I[rng.random((n, k)) < 0.2] = np.inf
    cands = Candidates.of_tables(T_orig[:, None] * T_RATIOS[None, :], np.ones((n, k)), I, np.ones((n, k)), T_orig)
    g = np.arange(n)
    I_orig = rng.uniform(10.0, 60.0, n)
    entries_b = 2 * cands.vals.shape[1] * 8             # their T and I: ~18 a row, ~290 bytes
    tracemalloc.start()
    try:
        rv = cands.rows_view(g, T_orig, I_orig)
        j, lam = plan_mod._allocate_rows(cands.vals, rv, 0.05 * T_orig.sum(), plan_mod._alloc_core())
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert lam > 0.0 and (j < rv.cnt).any()
    assert peak < 0.5 * entries_b


@pytest.mark.parametrize("name,prof", [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24")])
def test_line_candidates_by_chunks_are_the_whole(name, prof, monkeypatch):
    """schedule._candidates makes the lines' tables CANDIDATE_ROWS rows at a time: the
    same sparse tables, bit for bit, as all rows in one call (CANDIDATE_ROWS past the
    file's rows), with chunks that cut plan.py's own batches too."""
    got = []
    for rows_at_once in (10 ** 9, 777):
        monkeypatch.setattr(schedule, "CANDIDATE_ROWS", rows_at_once)
        cands, g, pin, _ = _sample_cands(name, prof)
        got.append(cands)
    a, b = got
    assert a.vals.shape[1] > 1000 and (np.bincount(np.flatnonzero(a.mask.any(axis=1)) // 777).size > 3)
    assert np.array_equal(a.mask, b.mask) and np.array_equal(a.t_pos, b.t_pos)
    assert np.array_equal(a.first, b.first) and np.array_equal(a.cnt, b.cnt)
    assert np.array_equal(a.vals.view(np.int64), b.vals.view(np.int64))


@pytest.mark.parametrize("chunk", [7, 300, 10 ** 6])
def test_line_pieces_chunk_by_chunk_are_the_whole_tables_made_sparse(chunk):
    """plan.candidate_pieces (each chunk's tables made sparse as soon as made) gives the
    entries Candidates.piece gives on candidates_auto's dense tables of all the rows."""
    profile = load_profile("prusa-mk3s")
    opts = pipeline.Options()
    strokes, _ = pipeline.analyse(os.path.join(SAMPLES, "prusa_mk3s_rectilinear.gcode"), profile, opts)
    pin = schedule.plan_inputs(strokes, profile, opts)
    rows = schedule._rows_by_kind(strokes)["line"]
    p = pin.take(rows)
    got, _ = Candidates.of_pieces(len(strokes), plan_mod.candidate_pieces(p, rows, pin.T_orig, chunk=chunk), pin.T_orig)
    want, _ = Candidates.of_pieces(len(strokes), [Candidates.piece(rows, plan_mod.candidates_auto(p), pin.T_orig)],
                                   pin.T_orig)
    assert got.vals.shape[1] > 1000
    assert np.array_equal(got.mask, want.mask) and np.array_equal(got.t_pos, want.t_pos)
    assert np.array_equal(got.vals.view(np.int64), want.vals.view(np.int64))
