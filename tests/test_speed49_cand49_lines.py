"""Issue 8 (s49, cand49): the lines' candidate step lets each chunk's state and dense tables
go once used (plan.candidate_pieces, _chunk_tables, _beta_search): the same pieces, bit for
bit, as the code it replaced (verbatim copies below, of 3673ec9), and no chunk's tables
held beside the next one's (the gyroid plate's candidates peak: ~1.4 MB traced less)."""
import gc
import weakref

import numpy as np
import pytest

from gcode_opt import plan as plan_mod
from gcode_opt.plan import (Candidates, InteriorSpeeds, PlanInput, _candidates_auto, _candidates_dense,
                            _live_entries, _live_tables, _log_gamma_root)


# ---- the code replaced (3673ec9), verbatim but for the module prefix ----
def _candidate_pieces_ref(p, rows, T_orig, chunk=plan_mod.CANDIDATE_CHUNK):
    rows = np.asarray(rows)
    if len(p.L) <= chunk:
        return [Candidates.piece(rows, _candidates_auto(p), T_orig)]
    return [Candidates.piece(rows[a:b], tables, T_orig) for a, b, tables in _chunk_tables_ref(p, chunk)]


def _chunk_tables_ref(p, chunk):
    n = len(p.L)
    step = chunk * plan_mod.BISECT_CHUNKS
    for a0 in range(0, n, step):
        chunks = [np.arange(a, min(a + chunk, n)) for a in range(a0, min(a0 + step, n), chunk)]
        live = [_live_entries(p.take(rows)) for rows in chunks]
        betas = _beta_search_ref([lv[1] for lv in live if lv is not None])
        for rows, lv in zip(chunks, live):
            q = p.take(rows)
            tables = _candidates_dense(q) if lv is None else _live_tables(q, lv[0], *next(betas))
            yield rows[0], rows[-1] + 1, tables      # (a run of rows: a slice, not an index)


def _beta_search_ref(preps):
    sizes = [pr[1].size for pr in preps]
    if sum(sizes):
        Tb, capb, v_endb = (np.concatenate([pr[k] for pr in preps]) for k in (2, 3, 4))
        y, v_crit_b = _log_gamma_root(InteriorSpeeds.concat([pr[5] for pr in preps]), Tb, capb, v_endb)
        beta_b = (Tb / np.exp(y)) ** 2
    at = 0
    for pr, m in zip(preps, sizes):
        v_crit, b = pr[0], pr[1]
        out = np.full(v_crit.shape, np.inf)
        if m:
            out[b] = beta_b[at:at + m]
            v_crit[b] = v_crit_b[at:at + m]
            at += m
        yield out, v_crit
# ----


def _pin(rng, n, odd=False):
    """Lines' inputs as the plates have them (tests/test_speed42_gather42_plan.py's); odd:
    some not plain (a duration whose square underflows: the dense path of their chunk)."""
    L = rng.uniform(0.1, 40.0, n)
    v0, v1 = rng.uniform(0.0, 120.0, n), rng.uniform(0.0, 120.0, n)
    v_cap = rng.uniform(20.0, 200.0, n)
    a_cap = rng.uniform(100.0, 4000.0, n)
    T_orig = L / rng.uniform(5.0, 150.0, n)
    if odd:
        T_orig[rng.integers(0, n, max(n // 50, 1))] = 1e-170     # (its square underflows)
    I_orig = rng.uniform(0.0, 1e4, n)
    return PlanInput(L, v0, v1, v_cap, a_cap, T_orig, I_orig, rng.uniform(0.1, 2.0, n),
                     T_orig * rng.uniform(0.5, 1.2, n))


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    if a.dtype == np.float64:
        a, b = a.view(np.int64), b.view(np.int64)
    return a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b)


@pytest.mark.parametrize("seed, n, chunk, odd", [(0, 1, 16, False), (1, 16, 16, False), (2, 17, 16, False),
                                                 (3, 300, 16, False), (4, 1000, 32, True), (5, 3000, 64, False),
                                                 (6, 5000, 2048, False)])
def test_candidate_pieces_as_before(seed, n, chunk, odd):
    rng = np.random.default_rng(seed)
    p = _pin(rng, n, odd)
    rows = np.sort(rng.choice(10 * n, n, replace=False))
    T_orig = np.zeros(10 * n)
    T_orig[rows] = p.T_orig
    if odd:         # (a chunk not plain takes _candidates_dense, which refuses these: both raise)
        with pytest.raises(ValueError):
            plan_mod.candidate_pieces(p, rows, T_orig, chunk)
        with pytest.raises(ValueError):
            _candidate_pieces_ref(p, rows, T_orig, chunk)
        return
    got = plan_mod.candidate_pieces(p, rows, T_orig, chunk)
    ref = _candidate_pieces_ref(p, rows, T_orig, chunk)
    assert len(got) == len(ref)
    for g, r in zip(got, ref):
        assert len(g) == len(r) == 5
        for a, b in zip(g, r):
            assert _same(a, b)


@pytest.mark.parametrize("seed", range(3))
def test_beta_search_as_before(seed):
    rng = np.random.default_rng(20 + seed)
    chunks = [_pin(rng, int(m)) for m in rng.integers(1, 400, 5)]
    states = [_live_entries(c) for c in chunks]
    preps = [s[1] for s in states]
    # the reference from fresh states (_beta_search writes v_crit in place)
    ref_preps = [_live_entries(c)[1] for c in chunks]
    got = list(plan_mod._beta_search(preps))
    ref = list(_beta_search_ref(ref_preps))
    assert len(got) == len(ref) == len(chunks)
    for (b1, v1), (b2, v2) in zip(got, ref):
        assert _same(b1, b2) and _same(v1, v2)
    assert all(len(pr) == 2 for pr in preps)       # the searched rows' inputs let go


def test_no_chunk_tables_beside_the_next(monkeypatch):
    """Each chunk's dense tables are let go before the next chunk's are made: when
    _live_tables is called for a chunk, the last chunk's tables are no more."""
    rng = np.random.default_rng(7)
    p = _pin(rng, 2000)
    rows = np.arange(2000)
    seen = []
    tables_of = plan_mod._live_tables

    def watched(*args):
        gc.collect()
        assert all(r() is None for r in seen), "a chunk's tables held beside the next one's"
        out = tables_of(*args)
        seen[:] = [weakref.ref(t) for t in out]
        return out
    monkeypatch.setattr(plan_mod, "_live_tables", watched)
    got = plan_mod.candidate_pieces(p, rows, p.T_orig, 64)
    assert len(got) == 32
