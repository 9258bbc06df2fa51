"""Session 42 (gather42): plan.py's gathers by take and its repeated mask gathers by one
flatnonzero then takes (PlanInput.take, _live_entries, _live_tables, _bisect's settled
rows, _RowSpread.rows_of, _allocate_rows' groups): held bit for bit to the indexing they
replace (the functions as they stood, verbatim, in this file) on varied inputs."""
import numpy as np
import pytest

from gcode_opt import plan as plan_mod
from gcode_opt.plan import T_RATIOS, PlanInput, out_of_reach, _beta_prep

FIELDS = ("L", "v0", "v1", "v_cap", "a_cap", "T_orig", "I_orig", "mass_r", "t_seg_min")


def _pin(rng, n):
    L = rng.uniform(0.1, 40.0, n)
    v0, v1 = rng.uniform(0.0, 120.0, n), rng.uniform(0.0, 120.0, n)
    v_cap = rng.uniform(20.0, 200.0, n)
    a_cap = rng.uniform(100.0, 4000.0, n)
    T_orig = L / rng.uniform(5.0, 150.0, n)
    I_orig = rng.uniform(0.0, 1e4, n)
    return PlanInput(L, v0, v1, v_cap, a_cap, T_orig, I_orig, rng.uniform(0.1, 2.0, n),
                     T_orig * rng.uniform(0.5, 1.2, n))


def _bits_equal(a, b):
    if isinstance(a, (tuple, list)):
        assert type(a) is type(b) and len(a) == len(b)
        for x, y in zip(a, b):
            _bits_equal(x, y)
        return
    if hasattr(a, "__dict__") and not isinstance(a, np.ndarray):
        assert type(a) is type(b)
        for k in vars(a):
            _bits_equal(getattr(a, k), getattr(b, k))
        return
    a, b = np.asarray(a), np.asarray(b)
    assert a.dtype == b.dtype and a.shape == b.shape
    assert a.tobytes() == b.tobytes()


@pytest.mark.parametrize("seed", range(3))
def test_plan_input_take(seed):
    rng = np.random.default_rng(seed)
    p = _pin(rng, 40)
    rows = rng.integers(-40, 40, 25)               # (repeats and negative places too)
    q = p.take(rows)
    for f in FIELDS:
        _bits_equal(getattr(q, f), getattr(p, f)[rows])


def _live_entries_ref(p):
    """plan._live_entries as it stood (verbatim)."""
    T = p.T_orig[:, None] * T_RATIOS[None, :]
    with np.errstate(all="ignore"):
        plain = (np.isfinite(T).all() and bool((T > 0).all()) and np.isfinite(p.L).all()
                 and np.isfinite(p.v0).all() and np.isfinite(p.v1).all()
                 and bool(((T / (2.0 * plan_mod.GAMMA_HI)) ** 2 > 0.0).all()))
    if not plain:
        return None
    flat = np.flatnonzero(T >= p.t_seg_min[:, None])
    r = flat // T.shape[1]
    Tq = T.ravel()[flat]
    L, v0, v1, v_cap, a_cap = (a[r] for a in (p.L, p.v0, p.v1, p.v_cap, p.a_cap))
    reach = ~out_of_reach(L, Tq, v0, v1, v_cap, a_cap)
    if not reach.all():
        flat, Tq, L, v0, v1, v_cap = (x[reach] for x in (flat, Tq, L, v0, v1, v_cap))
    return flat.astype(np.int32), _beta_prep(L, Tq, v0, v1, v_cap)


@pytest.mark.parametrize("seed", range(5))
def test_live_entries_and_tables(seed):
    rng = np.random.default_rng(10 + seed)
    p = _pin(rng, int(rng.integers(1, 300)))
    got, want = plan_mod._live_entries(p), _live_entries_ref(p)
    flat = want[0]
    reach_all = flat.size == np.count_nonzero(p.T_orig[:, None] * T_RATIOS[None, :] >= p.t_seg_min[:, None])
    if seed == 0:
        assert not reach_all                        # (the cases drop unreachable entries)
    _bits_equal(got[0], want[0])
    _bits_equal(got[1][:5], want[1][:5])
    for f in ("L", "T", "v0", "v1"):
        if hasattr(want[1][5], f):
            _bits_equal(getattr(got[1][5], f), getattr(want[1][5], f))
    # _live_tables on those entries: the (T, beta, I, KE) tables (its own gathers by take)
    bq, v_crit = next(plan_mod._beta_search([got[1]]))
    _bits_equal(plan_mod._live_tables(p, got[0], bq, v_crit), _live_tables_ref(p, got[0], bq, v_crit))


def _live_tables_ref(p, flat, bq, v_crit):
    """plan._live_tables as it stood (verbatim)."""
    T = p.T_orig[:, None] * T_RATIOS[None, :]
    shape = T.shape
    beta = np.full(shape, np.inf)
    I = np.full(shape, np.inf)
    KE = np.full(shape, np.nan)
    if not flat.size:
        return T, beta, I, KE
    r = flat // shape[1]
    Tq = T.ravel()[flat]
    L, v0, v1, v_cap, a_cap = (a[r] for a in (p.L, p.v0, p.v1, p.v_cap, p.a_cap))
    a_peak, KEq, Iq = plan_mod._law_figures(L, Tq, bq, v0, v1)
    speeds = (*plan_mod.end_speeds(L, Tq, v0, v1), v_crit)
    ok = ((np.maximum.reduce(speeds) <= v_cap * (1 + plan_mod.SPEED_TOL_R))
          & (a_peak <= a_cap * (1 + plan_mod.SPEED_TOL_R))
          & (np.minimum.reduce(speeds) >= -1e-9 * (1 + v_cap)))
    beta.ravel()[flat] = bq
    I.ravel()[flat] = np.where(ok, Iq, np.inf)
    KE.ravel()[flat] = KEq
    return T, beta, I, KE


def _bisect_ref(J, live, step, spent, budget_t, settle):
    """plan._bisect as it stood (verbatim)."""
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
            act, j_lo, m_lo, j_hi, m_hi, tol_hi = (a[keep] for a in (act, j_lo, m_lo, j_hi, m_hi, tol_hi))
        mid = 0.5 * (lo + hi)
        j_mid, m_mid, tol_mid = step(mid, act)
        J[act] = j_mid
        if spent() > budget_t:
            lo, j_lo, m_lo = mid, j_mid, m_mid
        else:
            hi, j_hi, m_hi, tol_hi = mid, j_mid, m_mid, tol_mid
    J[act] = j_hi
    return J, hi


def _tables(rng, n, k):
    Tx = rng.uniform(0.5, 2.0, (n, k)) * rng.uniform(0.01, 1.0, n)[:, None]
    Ix = rng.uniform(0.0, 100.0, (n, k))
    finite = rng.random((n, k)) < 0.7
    finite[:, -1] = True
    Ix = np.where(finite, Ix, np.inf)
    Tx[rng.random((n, k)) < 0.1] = Tx[0, 0]           # (ties)
    return Tx, Ix, finite


@pytest.mark.parametrize("use_core", [True, False])
@pytest.mark.parametrize("seed", range(4))
def test_bisect_as_mask_gathers(seed, use_core, monkeypatch):
    rng = np.random.default_rng(20 + seed)
    n, k = int(rng.integers(2, 400)), 6
    Tx, Ix, finite = _tables(rng, n, k)
    T_orig = Tx[:, -1].copy()
    monkeypatch.setattr(plan_mod, "USE_CORE", use_core)
    for budget in (-0.3 * T_orig.sum(), -0.05 * T_orig.sum(), 0.0):
        got = plan_mod._allocate(Tx, Ix, finite, T_orig, budget, True)
        monkeypatch.setattr(plan_mod, "_bisect", _bisect_ref)
        want = plan_mod._allocate(Tx, Ix, finite, T_orig, budget, True)
        monkeypatch.undo()
        monkeypatch.setattr(plan_mod, "USE_CORE", use_core)
        _bits_equal(got[0], want[0])
        _bits_equal(got[1], want[1])


class _RowSpreadRef(plan_mod._RowSpread):
    """_RowSpread.rows_of as it stood (verbatim)."""

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
        if g.size != self.g_n:
            keep = np.zeros(self.dT_u.size, bool)
            keep[g] = True
            keep = keep[self.inv_rows]
            self.rows, self.inv_rows = self.rows[keep], self.inv_rows[keep]
            self.g_n = g.size
        self.dT[self.rows] = self.dT_u[self.inv_rows]


@pytest.mark.parametrize("seed", range(4))
def test_row_spread_rows_of(seed):
    rng = np.random.default_rng(30 + seed)
    ng = int(rng.integers(1, 60))
    inv = rng.integers(0, ng, int(rng.integers(ng, 200))).astype(np.intp)
    a, b = plan_mod._RowSpread(inv, ng), _RowSpreadRef(inv, ng)
    a.dT_u[:] = b.dT_u[:] = rng.random(ng)         # (the groups never live: set before the steps)
    g = np.sort(rng.choice(ng, int(rng.integers(1, ng + 1)), replace=False))
    for _ in range(8):
        vals = rng.random(ng)
        a.dT_u[g] = vals[g]
        b.dT_u[g] = vals[g]
        a.rows_of(g)
        b.rows_of(g)
        _bits_equal(a.dT, b.dT)
        _bits_equal(a.rows, b.rows)
        if g.size > 1:
            g = np.sort(rng.choice(g, int(rng.integers(1, g.size + 1)), replace=False))
