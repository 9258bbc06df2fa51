"""Issue 8, stop 19 (D9): plan._allocate's narrow tables are column-major and thin() keeps
the least, its first column and the second least column by column on arrays of rows
(instead of argmin and min along rows of 8 entries), narrow rows going by blocks of
NARROW_ROWS.  The choices and lambda must be the same bits as ddecd40's _allocate and
_narrow_tables, copied verbatim below (plan_mod.* for the module's constants),
on tables shaped like the real ones, with ties, signed zeros, overflows and NaN."""
import numpy as np
import pytest

from gcode_opt import plan as plan_mod


# ---------------------------------------------------------------- ddecd40's forms
NARROW_COLS = plan_mod.NARROW_COLS


def _old_allocate(Tx, Ix, finite, T_orig, budget_t, settle):
    """allocate on its extended tables (the original as the last column); settle: the
    costs cannot cancel (every finite I and every T >= 0), so the margin test holds.

    Where every T is finite and >= 0 ("plain"), Ix's entries that are not finite are set
    to inf in place: inf + lambda T is then the inf the choice gave them (lambda is
    finite), and the cost needs no mask.  Then the rows with at most NARROW_COLS finite
    candidates (most: a line has its original and ~5 laws of 24 columns) are costed on
    narrow tables holding their finite entries first, in column order: the same costs,
    the same least (argmin's first, mapped back to its column) and the same second least
    (the rest are inf in both), so the same choices and margins."""
    n, k = Ix.shape
    rows = np.arange(n)
    plain = bool(n and np.isfinite(Tx).all() and Tx.min() >= 0.0)
    narrow = None
    if plain:
        Ix[~finite] = np.inf
        narrow = _old_narrow_tables(Tx, Ix, finite)
    # each stroke's T - T_orig at its current choice, kept row by row as choices change:
    # the same array, so the same sum, as taking every row's again at each step
    dT = np.empty(n)

    def take(j, r):
        dT[r] = Tx[r, j] - T_orig[r]

    def spent():
        return float(np.sum(dT))

    def dense(lam, r):
        m = len(r)
        if not plain:
            cost = np.where(finite[r], Ix[r] + lam * Tx[r], np.inf)
        elif m and r[-1] - r[0] + 1 == m:          # a run of rows: views, not copies
            cost = Ix[r[0]:r[0] + m] + lam * Tx[r[0]:r[0] + m]
        else:
            cost = Ix[r] + lam * Tx[r]
        j = np.argmin(cost, axis=1)
        if k < 2:                 # one candidate: it cannot change
            return j, np.full(m, np.inf), np.zeros(m)
        ar = np.arange(m)
        c1 = cost[ar, j]
        if np.isnan(c1).any():    # argmin stops at a NaN: sort as before
            two = np.partition(cost, 1, axis=1)
            c1, c2 = two[:, 0], two[:, 1]
        else:                     # the second least: the least once the least is taken out
            cost[ar, j] = np.inf
            c2 = np.min(cost, axis=1)
        return j, c1, c2

    def thin(lam, r):
        """dense() of rows r, all narrow; None where a least cost is inf (no finite
        candidate, or an overflow: argmin's first inf may be another column)."""
        is_n, pos, col, Tn, In = narrow
        p = pos[r]
        cost = In[p] + lam * Tn[p]
        jn = np.argmin(cost, axis=1)
        ar = np.arange(len(r))
        c1 = cost[ar, jn]
        if np.isinf(c1).any():
            return None
        cost[ar, jn] = np.inf
        return col[p, jn].astype(np.intp), c1, np.min(cost, axis=1)

    def block(lam, r):
        if narrow is not None:
            nr = narrow[0][r]
            if nr.all():
                got = thin(lam, r)
                if got is not None:
                    return got
            elif nr.any():
                a, b = thin(lam, r[nr]), dense(lam, r[~nr])
                if a is not None:
                    return tuple(_merge(nr, x, y) for x, y in zip(a, b))
        return dense(lam, r)

    def choices(lam, r):
        """Choice and margin to the next candidate of rows r at lam (margin inf where only
        one candidate is finite or none is: then the choice cannot change).  By blocks of
        rows, so that the cost matrices stay small (row-wise: the same numbers)."""
        if len(r) > plan_mod.ALLOCATE_ROWS:
            parts = [choices(lam, r[a:a + plan_mod.ALLOCATE_ROWS]) for a in range(0, len(r), plan_mod.ALLOCATE_ROWS)]
            return tuple(np.concatenate(x) for x in zip(*parts))
        j, c1, c2 = block(lam, r)
        if k < 2:
            return j, c1, c2
        with np.errstate(invalid="ignore"):
            margin = np.where(np.isinf(c2), np.inf, c2 - c1)
        return j, margin, plan_mod.MARGIN_R * (np.abs(c1) + np.abs(c2))

    j_lo, m_lo, _ = choices(0.0, rows)
    take(j_lo, rows)
    if spent() <= budget_t:
        return j_lo, 0.0
    lo, hi = 0.0, 1.0
    while True:
        j_hi, m_hi, tol_hi = choices(hi, rows)
        take(j_hi, rows)
        if not (spent() > budget_t and hi < 1e30):
            break
        hi *= 10.0
    J = j_hi.copy()               # every stroke's choice; those of `act` are the bracket's ends'
    act = rows
    for _ in range(80):
        # the costs grow with lambda (T >= 0): the rounding anywhere in the bracket is
        # at most the top end's, tol_hi, which both margins must clear
        keep = (j_lo != j_hi) | ~(m_lo > tol_hi) | ~(m_hi > tol_hi)
        if settle and not keep.all():        # settled: J holds their choice for the rest of the bisection
            act, j_lo, m_lo, j_hi, m_hi, tol_hi = (a[keep] for a in (act, j_lo, m_lo, j_hi, m_hi, tol_hi))
        mid = 0.5 * (lo + hi)
        j_mid, m_mid, tol_mid = choices(mid, act)
        J[act] = j_mid
        take(j_mid, act)
        if spent() > budget_t:
            lo, j_lo, m_lo = mid, j_mid, m_mid
        else:
            hi, j_hi, m_hi, tol_hi = mid, j_mid, m_mid, tol_mid
    J[act] = j_hi
    return J, hi




def _old_narrow_tables(Tx, Ix, finite):
    """(is_narrow per row, row -> narrow row, narrow column -> column, T, I) of the rows
    with at most NARROW_COLS finite entries, those first in column order; None when
    there are none or the tables are no wider (a stroke's T and I are its own row's)."""
    n, k = Ix.shape
    w = max(NARROW_COLS, 2)
    if k <= w:
        return None
    is_n = finite.sum(axis=1) <= w
    if not is_n.any():
        return None
    col = np.argsort(~finite[is_n], axis=1, kind="stable")[:, :w]
    Tn = np.take_along_axis(Tx[is_n], col, axis=1)
    In = np.take_along_axis(Ix[is_n], col, axis=1)
    pos = np.full(n, -1)
    pos[is_n] = np.arange(int(is_n.sum()))
    return is_n, pos, col.astype(np.int16 if k < 2 ** 15 else np.intp), Tn, In


def _merge(mask, a, b):
    """One array of mask's length: a where mask, b elsewhere."""
    out = np.empty(mask.size, np.result_type(a, b))
    out[mask], out[~mask] = a, b
    return out


# ---------------------------------------------------------------- comparisons
def _ext(T, I, T_orig, I_orig):
    Tx = np.concatenate([T, T_orig[:, None]], axis=1)
    Ix = np.concatenate([I, I_orig[:, None]], axis=1)
    finite = np.isfinite(Ix)
    settle = bool(np.all(Ix[finite] >= 0.0) and np.all(Tx >= 0.0))
    return Tx, Ix, finite, settle


def _same_alloc(T, I, T_orig, I_orig, budget_t):
    Tx, Ix, finite, settle = _ext(T, I, T_orig, I_orig)
    j_ref, lam_ref = _old_allocate(Tx.copy(), Ix.copy(), finite.copy(), T_orig, budget_t, settle)
    j, lam = plan_mod._allocate(Tx, Ix, finite, T_orig, budget_t, settle)
    assert j.dtype == j_ref.dtype
    assert np.array_equal(j, j_ref)
    assert np.float64(lam).tobytes() == np.float64(lam_ref).tobytes()
    return j


def _tables(rng, n, k=23, zeros=False):
    """Most rows a few finite laws (narrow), some wide, some with none; duplicates, last-bit
    differences, lines crossing at lambdas the bisection visits, zero costs of both signs."""
    T_orig = rng.uniform(0.02, 3.0, n)
    T = T_orig[:, None] * np.linspace(0.7, 1.5, k)[None, :]
    I_orig = rng.uniform(1e2, 1e7, n)
    I = I_orig[:, None] * rng.uniform(0.05, 1.3, (n, k))
    width = rng.choice([0, 1, 2, 5, 7, 8, 9, 18, 23], n, p=[0.05, 0.15, 0.1, 0.3, 0.1, 0.05, 0.05, 0.1, 0.1])
    for i in range(n):
        drop = rng.permutation(k)[width[i]:]
        I[i, drop] = np.inf
        T[i, drop] = rng.choice([0.0, 5.0])
    I[::13, 3] = I[::13, 2]
    T[::13, 3] = T[::13, 2]
    I[::7, 6] = np.nextafter(I[::7, 5], np.inf)
    T[::7, 6] = T[::7, 5]
    I[::5, 9] = I[::5, 4] = np.minimum(I[::5, 9], I[::5, 4])       # ties on the least
    T[::5, 9] = T[::5, 4]
    for i, lam in zip(range(1, n, 5), np.tile(2.0 ** np.arange(-3, 9), n)):
        I[i, 8] = I[i, 9] + lam * (T[i, 9] - T[i, 8])
    if zeros:
        z = rng.random((n, k)) < 0.1
        I[z] = rng.choice([0.0, -0.0], int(z.sum()))
        T[z] = rng.choice([0.0, -0.0], int(z.sum()))
        T_orig[::17] = 0.0
        I_orig[::19] = -0.0
    return T, I, T_orig, I_orig


@pytest.mark.parametrize("seed", range(6))
def test_allocate_same_as_ddecd40(seed):
    rng = np.random.default_rng(seed)
    T, I, T_orig, I_orig = _tables(rng, 4000, zeros=seed % 2 == 1)
    total = float(np.sum(T_orig))
    for b in (0.0, 0.01 * total, 0.05 * total, 0.2 * total, 1.0, -1.0, 1e-300):
        _same_alloc(T, I, T_orig, I_orig, b)


@pytest.mark.parametrize("rows,narrow_rows", [(37, 64), (256, 256), (512, 100), (4096, 1 << 15)])
def test_allocate_blocks(monkeypatch, rows, narrow_rows):
    """Blocks of narrow rows only, of wide rows only and mixed, of every size: the same."""
    rng = np.random.default_rng(rows)
    T, I, T_orig, I_orig = _tables(rng, 3000)
    I[:300, :] = I_orig[:300, None] * rng.uniform(0.05, 1.3, (300, I.shape[1]))    # a wide run
    monkeypatch.setattr(plan_mod, "ALLOCATE_ROWS", rows)
    monkeypatch.setattr(plan_mod, "NARROW_ROWS", narrow_rows)
    total = float(np.sum(T_orig))
    for b in (0.02 * total, 0.1 * total):
        _same_alloc(T, I, T_orig, I_orig, b)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_allocate_overflow_and_odd_tables(monkeypatch):
    """Costs that overflow to inf (thin declines its block), infinite or negative T and
    NaN costs (the masked path), rows whose every candidate is inf."""
    monkeypatch.setattr(plan_mod, "ALLOCATE_ROWS", 300)
    monkeypatch.setattr(plan_mod, "NARROW_ROWS", 700)
    rng = np.random.default_rng(9)
    T, I, T_orig, I_orig = _tables(rng, 2000)
    T1, To1, Io1 = T.copy(), T_orig.copy(), I_orig.copy()
    T1[:40] *= 1e290
    To1[:40] *= 1e290
    Io1[:40] = 1e300
    for b in (0.0, 10.0, -1.0, -1e300):
        _same_alloc(T1, I, To1, Io1, b)
    Io2 = I_orig.copy()
    Io2[::3] = np.inf
    _same_alloc(T, I, T_orig, Io2, 50.0)
    T3 = T.copy()
    T3[::11, 4] = np.inf
    _same_alloc(T3, I, T_orig, I_orig, 10.0)
    I4 = I.copy()
    I4[::5, 0] = np.nan
    _same_alloc(T, I4, T_orig, I_orig, 10.0)


def test_narrow_tables_column_major():
    rng = np.random.default_rng(2)
    T, I, T_orig, I_orig = _tables(rng, 500)
    Tx, Ix, finite, _ = _ext(T, I, T_orig, I_orig)
    Ix[~finite] = np.inf
    old = _old_narrow_tables(Tx, Ix, finite)
    new = plan_mod._narrow_tables(Tx, Ix, finite)
    for a, b in zip(old[:3], new[:3]):
        assert a.dtype == b.dtype and np.array_equal(a, b)
    for a, b in zip(old[3:], new[3:]):
        assert b.flags.c_contiguous and b.tobytes() == np.ascontiguousarray(a.T).tobytes()


def _old_least_two(cost_rows):
    """ddecd40's thin() on a cost matrix (rows of candidates): argmin, its cost, and the min
    once the least is taken out."""
    cost = cost_rows.copy()
    jn = np.argmin(cost, axis=1)
    ar = np.arange(cost.shape[0])
    c1 = cost[ar, jn]
    cost[ar, jn] = np.inf
    return jn, c1, np.min(cost, axis=1)


@pytest.mark.parametrize("w", [2, 3, 8])
def test_least_two_same_as_argmin(w):
    rng = np.random.default_rng(w)
    for vals in ([0.0, 1.0, 2.0, np.inf], [0.0, -0.0, 3.0, 3.0, np.inf, 1e308], None):
        if vals is None:
            cost = rng.uniform(0.0, 1e6, (5000, w))
        else:
            cost = rng.choice(vals, (5000, w))          # ties everywhere
        jn, c1, c2 = plan_mod._least_two(np.ascontiguousarray(cost.T))
        j0, d1, d2 = _old_least_two(cost)
        assert jn.dtype == j0.dtype and np.array_equal(jn, j0)
        assert np.array_equal(c1, d1) and np.array_equal(c2, d2)     # equal values (+0 == -0)
        assert np.array_equal(np.signbit(c1), np.signbit(d1))        # the least is argmin's own entry
