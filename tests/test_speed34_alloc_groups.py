"""Issue 8 (s34, alloc: the budget runs' CPU).  plan._allocate_rows allocates once per
group of rows with the same costs (the same entries, as lines that repeat share them,
and the same originals: plan._same_rows), not once per row, and spreads each group's
T - T_orig over its rows for the sum the budget is checked against.  Checked:
- _same_rows' groups against the rows' keys grouped by a dict (the reference);
- the choices and lambda, bit for bit, against every row allocated on its own (each row
  its own group: the allocation as it was) and against the dense tables by numpy, on a
  sample's lines repeated (shared entries) with some originals made to differ, at
  budgets that bisect, stop early and spend nothing.
"""
import os

import numpy as np
import pytest

from gcode_opt import plan as plan_mod
from gcode_opt import schedule as sc
from gcode_opt.pipeline import Options, analyse
from gcode_opt.plan import Candidates
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_LINE

S = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "sample_gcode")

pytestmark = pytest.mark.skipif(plan_mod._alloc_core() is None, reason="the compiled core is not built")


def _bits(x):
    return np.ascontiguousarray(x, float).view(np.int64)


def _groups_by_dict(first, cnt, T_orig, I_orig):
    """(reps, inv) by each row's key in a dict, in row order."""
    at, reps, inv = {}, [], []
    for r in range(first.size):
        key = (int(first[r]), int(cnt[r]), T_orig[r].tobytes(), I_orig[r].tobytes())
        if key not in at:
            at[key] = len(reps)
            reps.append(r)
        inv.append(at[key])
    return np.array(reps, np.intp), np.array(inv, np.intp)


@pytest.mark.parametrize("seed", range(4))
def test_same_rows_are_the_keys_grouped(seed):
    rng = np.random.default_rng(seed)
    n = 3000
    first = rng.integers(0, 10, n).astype(np.intp)
    cnt = rng.integers(0, 3, n).astype(np.intp)
    T_orig = rng.choice([0.5, 1.0, -0.0, 0.0], n)          # -0.0 and 0.0: other bits, other groups
    I_orig = rng.choice([2.0, 3.0], n)
    reps, inv = plan_mod._same_rows(first, cnt, T_orig, I_orig)
    want_reps, want_inv = _groups_by_dict(first, cnt, T_orig, I_orig)
    assert np.array_equal(reps, want_reps) and np.array_equal(inv, want_inv)
    assert 100 < reps.size < n // 4
    e_reps, e_inv = plan_mod._same_rows(first[:0], cnt[:0], T_orig[:0], I_orig[:0])
    assert e_reps.size == e_inv.size == 0


@pytest.fixture(scope="module")
def repeated():
    """Candidates of a sample's lines, each row three times (shared entries), with one
    row in five of the last copy given another original (same entries, another group)."""
    prof = load_profile("prusa-mk3s")
    opts = Options()
    strokes, sim0 = analyse(os.path.join(S, "prusa_mk3s_rectilinear.gcode"), prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    rows = np.array([i for i in sc._rows_by_kind(strokes)[K_LINE] if not pin.fault[i]], int)
    p = pin.take(np.repeat(rows, 3))
    p.I_orig = p.I_orig.copy()
    p.I_orig[2::15] *= 1.25
    n = len(p.L)
    cands, _ = Candidates.of_pieces(n, plan_mod.pieces_once(plan_mod.candidate_pieces, p, np.arange(n), p.T_orig),
                                    p.T_orig)
    return cands, p, float(p.T_orig.sum())


def _one_group_a_row(rv):
    rv.reps = rv.inv = None
    return rv


@pytest.mark.parametrize("budget_r", [0.0, 0.02, 0.1, 0.4, 1e3])
def test_grouped_allocation_is_the_row_by_row_one(repeated, budget_r, monkeypatch):
    cands, p, total_t = repeated
    g = np.arange(len(p.L))
    budget = budget_r * total_t
    core = plan_mod._alloc_core()
    rv = cands.rows_view(g, p.T_orig, p.I_orig)
    assert rv.reps.size < 0.45 * g.size and (rv.cnt[rv.reps] > 0).sum() > 50
    j, lam = plan_mod._allocate_rows(cands.vals, rv, budget, core)
    j0, lam0 = plan_mod._allocate_rows(cands.vals, _one_group_a_row(cands.rows_view(g, p.T_orig, p.I_orig)),
                                       budget, core)
    assert np.array_equal(j, j0) and np.float64(lam).tobytes() == np.float64(lam0).tobytes()
    if 0.0 < budget_r < 1.0:
        assert lam > 0.0 and (j < rv.cnt).any() and (j == rv.cnt).any()
    # and the dense tables' allocation by numpy (the reference of the compiled one)
    monkeypatch.setattr(plan_mod, "USE_CORE", False)
    Tx, Ix, finite, settle = cands.allocation_tables(g, p.T_orig, p.I_orig)
    jd, ld = plan_mod._allocate(Tx, Ix, finite, p.T_orig, budget, settle)
    assert np.array_equal(rv.columns(cands.mask[g], j, cands.shape[1]), jd)
    assert np.float64(lam).tobytes() == np.float64(ld).tobytes()
