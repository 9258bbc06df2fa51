"""Issue 8, session 46 (alloc46): _allocate_rows' spent() is _RowSpread.total, which keeps
each sum of every row's T - T_orig by the bits of the step groups' values while the steps
are on one array of at most MEMO_GROUPS groups (the bisection's late steps), instead of
summing every row again.  Compared with the replaced code (verbatim copies of 0b09fc6's
_allocate_rows and _RowSpread below): the same choices, lambda and every spent() value
in the same order, bit for bit, on random tables (groups, ties, small and large live sets,
budgets at each decade) and on the samples' own allocations."""
import os

import numpy as np
import pytest

from gcode_opt import pipeline, schedule
from gcode_opt import plan as plan_mod
from gcode_opt.plan import MARGIN_R, _bisect, _Rise
from gcode_opt.profile import load_profile

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")

from test_speed49_tie49_twins import no_tie_break  # noqa: E402

# the reference here is the allocation before round 49's tie-break (plan._break_ties, checked by
# test_speed49_tie49_twins against brute force): it is turned off
pytestmark = [pytest.mark.skipif(plan_mod._alloc_core() is None, reason="the compiled core is not built"),
              pytest.mark.usefixtures(no_tie_break.__name__)]


# ---------------------------------------------------------------- 0b09fc6, verbatim (but _bisect
# read from plan at the call, as the new code reads it: the logging below replaces it there)
def _allocate_rows_0b09fc6(vals, rv, budget_t, core):
    reps, inv = rv.reps, rv.inv
    vT, vI = np.ascontiguousarray(vals[0]), np.ascontiguousarray(vals[2])
    first, cnt, T_orig, I_orig = ((rv.first, rv.cnt, rv.T_orig, rv.I_orig) if reps is None else
                                  (a.take(reps) for a in (rv.first, rv.cnt, rv.T_orig, rv.I_orig)))
    J = np.empty(cnt.size, np.intp)
    spread = _RowSpread0b09fc6(inv, cnt.size)
    # groups with no candidate keep their original (column 0) at every lambda
    fixed = np.flatnonzero(cnt == 0)
    J[fixed] = 0
    spread.dT_u[fixed] = T_orig[fixed] - T_orig[fixed]
    live = np.flatnonzero(cnt != 0)
    tables = (vT, vI, first, cnt, T_orig, I_orig)

    def step(lam, g, ref=None):
        j, margin, tol = np.empty(g.size, np.intp), np.empty(g.size), np.empty(g.size)
        out = (j, margin, tol) if ref is None else (j, margin, tol, ref)
        core.alloc_rows(*tables, np.ascontiguousarray(g, np.intp), lam, MARGIN_R, spread.dT_u, *out)
        spread.rows_of(g)
        return j, margin, tol

    rise = _Rise(core, tables, spread)
    J, lam = plan_mod._bisect(J, live, step, lambda: float(np.sum(spread.dT)), budget_t, rv.settle, rise)
    return (J if inv is None else J[inv]), lam


class _RowSpread0b09fc6:
    __slots__ = ("inv", "dT_u", "dT", "g_n", "rows", "inv_rows")

    def __init__(self, inv, n_groups):
        self.inv = inv
        self.dT_u = np.empty(n_groups)
        self.dT = self.dT_u if inv is None else np.empty(inv.size)
        self.g_n = -1                 # the last step's number of groups (-1: no step yet)
        self.rows = self.inv_rows = None

    def refresh(self):
        """Every row's value again from its group's (after _Rise changed some groups')."""
        if self.inv is not None:
            np.take(self.dT_u, self.inv, out=self.dT)

    def rows_of(self, g):
        if self.inv is None:
            return
        if self.g_n < 0:
            self.dT[:] = self.dT_u[self.inv]
            live = np.zeros(self.dT_u.size, bool)
            live[g] = True
            self.rows = np.flatnonzero(live[self.inv])
            self.inv_rows = self.inv[self.rows]
            self.g_n = g.size
            return
        if g.size != self.g_n:        # fewer groups: their rows among the last ones'
            keep = np.zeros(self.dT_u.size, bool)
            keep[g] = True
            keep = np.flatnonzero(keep.take(self.inv_rows))     # (its places once, then takes)
            self.rows, self.inv_rows = self.rows.take(keep), self.inv_rows.take(keep)
            self.g_n = g.size
        self.dT[self.rows] = self.dT_u.take(self.inv_rows)


# ---------------------------------------------------------------- the comparison
def _logged(fn, monkeypatch, *args):
    """fn(*args)'s (choices, lambda's bits, every spent() value's bits in order)."""
    log = []

    def bisect(J, live, step, spent, budget_t, settle, rise=None):
        def spent_logged():
            s = spent()
            log.append(np.float64(s).tobytes())
            return s
        return _bisect(J, live, step, spent_logged, budget_t, settle, rise)
    monkeypatch.setattr(plan_mod, "_bisect", bisect)
    J, lam = fn(*args)
    monkeypatch.setattr(plan_mod, "_bisect", _bisect)
    return np.asarray(J).copy(), np.float64(lam).tobytes(), log


def _same(vals, rv, budget, monkeypatch):
    core = plan_mod._alloc_core()
    new = _logged(plan_mod._allocate_rows, monkeypatch, vals, rv, budget, core)
    old = _logged(_allocate_rows_0b09fc6, monkeypatch, vals, rv, budget, core)
    assert np.array_equal(new[0], old[0]) and new[1] == old[1] and new[2] == old[2]
    return old


def _random_view(rng, n_u, n):
    """(vals, rv): n rows drawn from n_u distinct ones (groups of the same entries and
    originals), each with 0-6 candidates trading time for cost over decades of I / T,
    with repeated candidates and equal T at other I (ties)."""
    T_orig = rng.choice([0.5, 1.0, 2.0, 3.0], n_u) * rng.choice([1.0, 1.5], n_u)
    cnt = rng.integers(0, 7, n_u).astype(np.intp)
    first = (np.cumsum(cnt) - cnt).astype(np.intp)
    row = np.repeat(np.arange(n_u), cnt)
    x = rng.choice([0.1, 0.25, 0.5, 0.75, 0.9], row.size)
    vT = T_orig[row] * (1.0 - x)
    vI = x * 10.0 ** rng.integers(-2, 9, n_u).astype(float)[row] * rng.choice([1.0, 1.0, 3.0], row.size)
    tie = np.flatnonzero(rng.random(row.size) < 0.15)
    tie = tie[tie > 0]
    vT[tie], vI[tie] = vT[tie - 1], np.where(rng.random(tie.size) < 0.5, vI[tie - 1], vI[tie])
    rows = np.concatenate([np.arange(n_u), rng.integers(0, n_u, n - n_u)])
    rng.shuffle(rows)
    I_orig = np.zeros(n_u)
    rv = plan_mod._RowsView(first[rows], cnt[rows], T_orig[rows].copy(), I_orig[rows].copy(), True)
    return (vT, None, vI), rv


def _budgets(vT, vI, rv):
    """Budgets around the spending at each decade of lambda (and beyond either end)."""
    out = [1.0, 0.0, -1e9]
    for lam in (0.5, 3.0, 40.0, 700.0, 2e4, 5e6, 3e8):
        dT = np.zeros(rv.cnt.size)
        for r in range(rv.cnt.size):
            a, c = rv.first[r], rv.cnt[r]
            cost = np.append(vI[a:a + c] + lam * vT[a:a + c], rv.I_orig[r] + lam * rv.T_orig[r])
            j = int(np.argmin(cost))
            dT[r] = (vT[a + j] if j < c else rv.T_orig[r]) - rv.T_orig[r]
        out.append(float(dT.sum()))
    return out


@pytest.mark.parametrize("n_u,n", [(12, 30), (40, 200), (300, 900), (2000, 2000)])
@pytest.mark.parametrize("seed", range(3))
def test_sums_and_choices_are_the_old_ones(n_u, n, seed, monkeypatch):
    rng = np.random.default_rng(1000 * seed + n)
    vals, rv = _random_view(rng, n_u, n)
    late = 0
    for budget in _budgets(vals[0], vals[2], rv):
        for grouped in (True, False):
            r = plan_mod._RowsView(rv.first, rv.cnt, rv.T_orig, rv.I_orig, True)
            if not grouped:
                r.reps = r.inv = None
            log = _same(vals, r, budget, monkeypatch)[2]
            late += len(log) > 60
    assert late >= 4              # bisections that ran their late steps


def _sample_allocations(name, prof):
    """The budget runs' _allocate_rows arguments on a sample (captured)."""
    calls = []
    real = plan_mod._allocate_rows

    def spy(vals, rv, budget_t, core):
        calls.append((vals, rv, budget_t))
        return real(vals, rv, budget_t, core)
    profile = load_profile(prof)
    opts = pipeline.Options()
    opts.ringing = False
    strokes, sim0 = pipeline.analyse(os.path.join(SAMPLES, name), profile, opts)
    pin = schedule.plan_inputs(strokes, profile, opts)
    mp = pytest.MonkeyPatch()
    mp.setattr(plan_mod, "_allocate_rows", spy)
    try:
        schedule.plan_strokes(strokes, pin, profile, opts, opts.max_slowdown_r * sim0.time_t)
    finally:
        mp.undo()
    return calls


@pytest.mark.parametrize("name,prof", [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"),
                                       ("prusa_gyroid.gcode", "prusa-mk3s")])
def test_samples_allocations_are_the_old_ones(name, prof, monkeypatch):
    calls = _sample_allocations(name, prof)
    assert calls
    for vals, rv, budget in calls:
        for b in (budget, 0.5 * budget, 0.05 * budget, 2.0 * budget):
            _same(vals, rv, b, monkeypatch)


def test_total_keeps_a_sum_only_for_its_groups():
    """total() is np.sum(dT) at every state: a sum kept for one array of groups is not
    given for another, nor after refresh() (the decade search's writes)."""
    inv = np.array([0, 1, 1, 2, 0, 2, 3], np.intp)
    s = plan_mod._RowSpread(inv, 4)
    s.dT_u[:] = [0.1, 0.2, 0.3, 0.4]
    g = np.array([0, 1, 2, 3], np.intp)
    s.rows_of(g)
    assert s.total() == float(np.sum(s.dT_u[inv]))
    g2 = np.array([1, 2], np.intp)
    for v in ([0.5, 0.25], [0.125, 0.25], [0.5, 0.25]):
        s.dT_u[g2] = v
        s.rows_of(g2)
        assert s.total() == float(np.sum(s.dT_u[inv]))
    s.dT_u[3] = 7.0                   # a write the memo does not see, then refresh
    s.refresh()
    assert s.total() == float(np.sum(s.dT_u[inv]))
    s.rows_of(g2.copy())              # another array, the same groups: kept sums not used
    assert s.total() == float(np.sum(s.dT_u[inv]))
