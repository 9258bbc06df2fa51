"""Issue 8 (s42, alloc42): _allocate_rows' decade search (plan._Rise, the core's
alloc_rise) costs again, at each decade, only the groups whose choice's cost reaches the
second least cost kept from their last costing (the others' choice cannot have moved),
and makes margins and tols at the last decade only.  Checked, bit for bit:
- alloc_rise against alloc_rows at rising lambdas, on random candidates with ties (equal
  candidates, equal T at other I, T = 0), inf, -inf and NaN costs, rows of no candidate;
- _allocate_rows (groups of same rows, and one row a group) and _allocate (the core and
  numpy, where nothing changed) against int 08b1ea3's _bisect (copied below): choices,
  lambda and every spent() the search decides on, at budgets that end the search at
  several decades, at lambda 0 and at 1e30."""
import numpy as np
import pytest

from gcode_opt import plan as plan_mod
from test_speed49_tie49_twins import no_tie_break

# the reference here is the allocation before round 49's tie-break (plan._break_ties, checked by
# test_speed49_tie49_twins against brute force): it is turned off
pytestmark = pytest.mark.usefixtures(no_tie_break.__name__)


NEW_BISECT = plan_mod._bisect     # (the tests patch plan_mod._bisect)


def _old_bisect(J, live, step, spent, budget_t, settle):
    """int 08b1ea3's _bisect."""
    j_lo, m_lo, _ = step(0.0, live)
    if spent() <= budget_t:
        J[live] = j_lo
        return J, 0.0
    lo, hi = 0.0, 1.0
    while True:
        j_hi, m_hi, tol_hi = step(hi, live)
        if not (spent() > budget_t and hi < 1e30):
            break
        hi *= 10.0
    J[live] = j_hi
    act = live
    for _ in range(80):
        keep = (j_lo != j_hi) | ~(m_lo > tol_hi) | ~(m_hi > tol_hi)
        if settle and not keep.all():
            q = np.flatnonzero(keep)
            act, j_lo, m_lo, j_hi, m_hi, tol_hi = (a.take(q) for a in (act, j_lo, m_lo, j_hi, m_hi, tol_hi))
        mid = 0.5 * (lo + hi)
        j_mid, m_mid, tol_mid = step(mid, act)
        J[act] = j_mid
        if spent() > budget_t:
            lo, j_lo, m_lo = mid, j_mid, m_mid
        else:
            hi, j_hi, m_hi, tol_hi = mid, j_mid, m_mid, tol_mid
    J[act] = j_hi
    return J, hi


def _spying(bisect, log, costed):
    """bisect with its spent() logged at each call (the bits the search decides on) and
    the rows its steps cost (with all their margins) counted in costed[0]."""
    def run(J, live, step, spent, budget_t, settle, rise=None):
        def spent_logged():
            s = spent()
            log.append(np.float64(s).tobytes())
            return s

        def step_counted(lam, rows, *more):
            costed[0] += len(rows)
            return step(lam, rows, *more)
        if rise is None or bisect is _old_bisect:        # (the old search has no rise)
            return bisect(J, live, step_counted, spent_logged, budget_t, settle)
        return bisect(J, live, step_counted, spent_logged, budget_t, settle, rise)
    return run


def _tables(seed, n=600, k=7, plain=True):
    """(Tx, Ix, finite, T_orig): the original last; candidates trade time for cost over
    many decades of I / T, with repeats (equal rows of T and I), equal T at other I (they
    tie once lambda T swamps I), rows of one finite candidate, and I = inf (not finite)."""
    rng = np.random.default_rng(seed)
    T_orig = rng.choice([0.5, 1.0, 2.0, 3.0], n) * rng.choice([1.0, 1.5], n)
    x = rng.choice([0.1, 0.25, 0.5, 0.75, 0.9], (n, k - 1))
    Tx = np.empty((n, k))
    Tx[:, :-1] = T_orig[:, None] * (1.0 - x)
    Tx[:, -1] = T_orig
    scale = 10.0 ** rng.integers(-2, 9, (n, 1)).astype(float)
    Ix = np.empty((n, k))
    Ix[:, :-1] = x * scale * rng.choice([1.0, 1.0, 3.0], (n, k - 1))
    Ix[:, -1] = 0.0
    same = rng.random(n) < 0.1                      # ties at every lambda: a candidate repeated
    Tx[same, 1], Ix[same, 1] = Tx[same, 0], Ix[same, 0]
    eqT = rng.random(n) < 0.1                       # the same T, another I: tie at large lambda
    Tx[eqT, 2] = Tx[eqT, 3]
    finite = rng.random((n, k)) < 0.8
    finite[:, -1] = True
    finite[rng.random(n) < 0.1, :-1] = False        # one finite candidate: the original
    Ix[~finite] = np.inf
    if not plain:
        Tx[~finite & (rng.random((n, k)) < 0.5)] = np.nan
    return Tx, Ix, finite, T_orig


def _budgets(Tx, Ix, finite, T_orig):
    """budgets around each decade's spending (and beyond either end)."""
    out = [1.0, -1e9]
    for lam in (0.5, 3.0, 40.0, 700.0, 2e4, 5e6, 3e8):
        cost = np.where(finite, Ix + lam * np.nan_to_num(Tx), np.inf)
        j = np.argmin(cost, axis=1)
        out.append(float(np.sum(np.nan_to_num(Tx)[np.arange(len(j)), j] - T_orig)))
    return out


def _run(monkeypatch, bisect, fn, *args):
    log, costed = [], [0]
    monkeypatch.setattr(plan_mod, "_bisect", _spying(bisect, log, costed))
    J, lam = fn(*args)
    return np.asarray(J).copy(), np.float64(lam).tobytes(), log, costed[0]


@pytest.mark.parametrize("use_core", [True, False])
@pytest.mark.parametrize("plain", [True, False])
@pytest.mark.parametrize("seed", range(3))
def test_allocate_is_the_old_search(monkeypatch, seed, plain, use_core):
    if use_core and plan_mod._alloc_core() is None:
        pytest.skip("the compiled core is not built")
    monkeypatch.setattr(plan_mod, "USE_CORE", use_core)
    Tx, Ix, finite, T_orig = _tables(seed, plain=plain)
    settle = bool(np.all(Ix[finite] >= 0.0) and np.all(Tx >= 0.0))
    assert settle == plain
    decades = set()
    for budget in _budgets(Tx, Ix, finite, T_orig):
        def go():
            return plan_mod._allocate(Tx.copy(), Ix.copy(), finite, T_orig, budget, settle)
        old = _run(monkeypatch, _old_bisect, go)
        new = _run(monkeypatch, NEW_BISECT, go)
        assert np.array_equal(old[0], new[0]) and old[1] == new[1] and old[2] == new[2]
        assert new[3] == old[3]         # (no rise: the same steps)
        decades.add(len(old[2]))
    assert len(decades) >= 4            # the searches ended at several decades


def _rows_view(seed, settle=True):
    """(vals, rv) of _tables' rows as Candidates.rows_view holds them: each row's finite
    candidates in column order, then its original; rows repeated (the same entries and
    originals: groups) and rows of no candidate."""
    Tx, Ix, finite, T_orig = _tables(seed, n=200)
    rng = np.random.default_rng(seed + 100)
    fin = finite[:, :-1]
    cnt = fin.sum(axis=1).astype(np.intp)
    vT, vI = Tx[:, :-1][fin], Ix[:, :-1][fin]
    first = (np.cumsum(cnt) - cnt).astype(np.intp)
    rows = np.concatenate([np.arange(200), rng.integers(0, 200, 300)])   # repeats: groups
    vals = (vT, None, vI)
    rv = plan_mod._RowsView(first[rows], cnt[rows], T_orig[rows].copy(), Ix[rows, -1].copy(), settle)
    return vals, rv, Tx, Ix, T_orig


@pytest.mark.parametrize("grouped", [True, False])
@pytest.mark.parametrize("seed", range(3))
def test_allocate_rows_is_the_old_search(monkeypatch, seed, grouped):
    core = plan_mod._alloc_core()
    if core is None:
        pytest.skip("the compiled core is not built")
    vals, rv, Tx, Ix, T_orig = _rows_view(seed)
    if grouped:
        assert rv.reps is not None and rv.reps.size < rv.cnt.size
    else:
        rv.reps = rv.inv = None
    decades, fewer = set(), 0
    budgets = _budgets(Tx, Ix, np.isfinite(Ix), T_orig)
    for budget in budgets + [b * 1.75 for b in budgets]:
        def go():
            return plan_mod._allocate_rows(vals, rv, budget, core)
        old = _run(monkeypatch, _old_bisect, go)
        new = _run(monkeypatch, NEW_BISECT, go)
        assert np.array_equal(old[0], new[0]) and old[1] == new[1] and old[2] == new[2]
        decades.add(len(old[2]))
        fewer += new[3] < old[3]
    assert len(decades) >= 4 and fewer >= 3


def _rise_tables(seed, n=3000):
    rng = np.random.default_rng(seed)
    cnt = rng.integers(0, 6, n).astype(np.intp)
    first = (np.cumsum(cnt) - cnt).astype(np.intp)
    nnz = int(cnt.sum())
    vT = rng.choice([0.0, 0.5, 1.0, 1.5, 2.0], nnz)
    vI = rng.choice([0.0, 0.5, 3.0, 10.0, 250.0, 1e4], nnz) * rng.choice([1.0, 1.0, 1.0, 7.0], nnz)
    odd = rng.random(nnz)
    vI[odd < 0.03] = np.inf
    vI[(odd >= 0.03) & (odd < 0.04)] = np.nan
    vI[(odd >= 0.04) & (odd < 0.045)] = -np.inf
    dup = np.flatnonzero((rng.random(nnz) < 0.1)[1:]) + 1         # equal candidates: ties at every lambda
    vT[dup], vI[dup] = vT[dup - 1], vI[dup - 1]
    T_orig = rng.choice([0.5, 1.0, 2.0], n)
    I_orig = rng.choice([0.0, 1.0, 40.0], n)
    return vT, vI, first, cnt, T_orig, I_orig


@pytest.mark.parametrize("seed", range(4))
def test_alloc_rise_is_alloc_rows(seed):
    core = plan_mod._alloc_core()
    if core is None:
        pytest.skip("the compiled core is not built")
    tables = _rise_tables(seed)
    n = tables[2].size
    rows = np.flatnonzero(np.random.default_rng(seed).random(n) < 0.9)
    m = rows.size

    def full(lam, ref=None):
        dT = np.zeros(n)
        j, mg, tol = np.empty(m, np.intp), np.empty(m), np.empty(m)
        core.alloc_rows(*tables, rows, lam, plan_mod.MARGIN_R, dT, j, mg, tol, *(() if ref is None else (ref,)))
        return j, dT, mg, tol

    ref = np.empty((m, 3))
    j, dT, mg, tol = full(0.0, ref)
    want = full(0.0)
    assert np.array_equal(j, want[0])
    for x, y in zip((dT, mg, tol), want[1:]):
        assert np.array_equal(x.view(np.int64), y.view(np.int64))
    costed = []
    for lam in (0.0, 0.1, 0.3, 1.0, 2.0, 10.0, 10.0, 55.0, 1e3, 3e4, 1e6, 1e9, 1e15, 1e30):
        mg, tol, kept = np.full(m, -7.0), np.full(m, -7.0), np.full(m, -1, np.intp)
        c = core.alloc_rise(*tables, rows, lam, j, ref, dT, plan_mod.MARGIN_R, mg, tol, kept)
        costed.append(c)
        want_j, want_dT, want_mg, want_tol = full(lam)
        assert np.array_equal(j, want_j)
        assert np.array_equal(dT.view(np.int64), want_dT.view(np.int64))
        kept = kept[:m - c]            # the rows kept; the others' margins and tols are made
        again = np.setdiff1d(np.arange(m), kept)
        assert np.array_equal(kept, np.sort(kept)) and again.size == c
        assert (mg[kept] == -7.0).all() and (tol[kept] == -7.0).all()
        assert np.array_equal(mg[again].view(np.int64), want_mg[again].view(np.int64))
        assert np.array_equal(tol[again].view(np.int64), want_tol[again].view(np.int64))
    assert 0 < min(costed) and max(costed) < 0.6 * m     # some rows costed again, most not
    bad = rows.copy()
    bad[np.flatnonzero(tables[3][rows])[0]] = n          # a row costed again (ref: NaN) out of range
    ref[:, 0] = np.nan
    mg, tol, kept = np.empty(m), np.empty(m), np.empty(m, np.intp)
    with pytest.raises(IndexError):
        core.alloc_rise(*tables, bad, 1e30, j, ref, dT, plan_mod.MARGIN_R, mg, tol, kept)
    with pytest.raises(ValueError):
        core.alloc_rise(*tables, rows, 1e30, j, ref[:-1], dT, plan_mod.MARGIN_R, mg, tol, kept)


@pytest.mark.parametrize("seed", range(3))
def test_rise_last_is_a_step_on_every_group(seed):
    """_Rise's decades then last(): every group's choice, margin and tol at the last
    lambda, and every row's T - T_orig, are a step's on every group there."""
    core = plan_mod._alloc_core()
    if core is None:
        pytest.skip("the compiled core is not built")
    tables = _rise_tables(seed)
    n = tables[2].size
    inv = np.random.default_rng(seed).integers(0, n, 3 * n).astype(np.intp)     # rows of the groups
    live = np.flatnonzero(tables[3] != 0)

    def stepper(spread):
        def step(lam, g, ref=None):
            j, margin, tol = np.empty(g.size, np.intp), np.empty(g.size), np.empty(g.size)
            core.alloc_rows(*tables, g, lam, plan_mod.MARGIN_R, spread.dT_u, j, margin, tol,
                            *(() if ref is None else (ref,)))
            spread.rows_of(g)
            return j, margin, tol
        return step

    for lams in ((1.0,), (1.0, 10.0, 100.0), (0.5, 3.0, 3.0, 1e4, 1e9)):
        spread = plan_mod._RowSpread(inv, n)
        spread.dT_u[:] = 0.0
        rise = plan_mod._Rise(core, tables, spread)
        rise.start(stepper(spread), live)
        for lam in lams:
            rise(lam)
        got = rise.last(lams[-1])
        ref_spread = plan_mod._RowSpread(inv, n)
        ref_spread.dT_u[:] = 0.0
        want = stepper(ref_spread)(lams[-1], live)
        for a, b in zip(got, want):
            assert np.array_equal(np.asarray(a).view(np.int64), np.asarray(b).view(np.int64))
        assert np.array_equal(spread.dT.view(np.int64), ref_spread.dT.view(np.int64))
        assert 0 < rise.n_kept < live.size
