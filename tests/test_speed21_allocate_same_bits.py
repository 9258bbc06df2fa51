"""Speed 21, allocate: plan._allocate's choices by the compiled core's alloc_choices (one pass
a row: the same costs, argmin's first, the second least, margins, and take()'s T - T_orig),
rows with at most one finite candidate taken once, _narrow_tables without a sort.  (J, hi)
must be the same bits as d3559db's _allocate, copied verbatim below with its helpers
(plan_mod's constants), on tables captured from the bundled samples' runs (prusa-mk3s,
voron24, auto), on random tables with ties, inf, duplicate columns, one or no finite
candidate, overflows, and with and without the core.

Big plates, by hand (not stored): capture with
    PYTHONPATH=. python benchmarks/capture_allocate.py /tmp/gyroid.npz PLATE.gcode --profile prusa-mk3s
then  GCODE_OPT_ALLOC_NPZ=/tmp/gyroid.npz:/tmp/rect.npz python -m pytest -q tests/test_speed21_allocate_same_bits.py"""
import os
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import plan as plan_mod
from test_speed49_tie49_twins import no_tie_break

# the reference here is the allocation before round 49's tie-break (plan._break_ties, checked by
# test_speed49_tie49_twins against brute force): it is turned off
pytestmark = pytest.mark.usefixtures(no_tie_break.__name__)

ALLOCATE_ROWS = plan_mod.ALLOCATE_ROWS
NARROW_ROWS = plan_mod.NARROW_ROWS
MARGIN_R = plan_mod.MARGIN_R
NARROW_COLS = plan_mod.NARROW_COLS

SAMPLES = Path(__file__).resolve().parent.parent / "sample_gcode"


# ---------------------------------------------------------------- d3559db's forms (verbatim)
def _allocate(Tx, Ix, finite, T_orig, budget_t, settle):
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
        narrow = _narrow_tables(Tx, Ix, finite)
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
        candidate, or an overflow: argmin's first inf may be another column).  The
        narrow tables are column-major (w, rows): the least (argmin's first: a later
        column replaces it only where strictly less) and the second least (the least
        of the others, a tie included) are kept column by column, elementwise, on
        arrays of rows instead of reductions along rows of w entries.  The costs hold
        no NaN (finite T >= 0, finite lambda, I finite or inf), so these are argmin's
        and min's choices and values; only the sign of a zero second least may differ,
        which only comparisons and abs() read."""
        is_n, pos, col, Tn, In = narrow
        p = pos[r]
        cost = In[:, p]
        cost += lam * Tn[:, p]
        jn, c1, c2 = _least_two(cost)
        if np.isinf(c1).any():
            return None
        return col[p, jn].astype(np.intp), c1, c2

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
        rows, so that the cost matrices stay small (row-wise: the same numbers).  Narrow
        rows go by blocks of NARROW_ROWS (thin's arrays are a row's 8 columns, not 24:
        fewer, larger numpy calls), the others by ALLOCATE_ROWS; a narrow block thin()
        declines goes by ALLOCATE_ROWS as before."""
        if narrow is not None and len(r) > ALLOCATE_ROWS:
            nr = narrow[0][r]
            if nr.all():
                if len(r) > NARROW_ROWS:
                    parts = [choices(lam, r[a:a + NARROW_ROWS]) for a in range(0, len(r), NARROW_ROWS)]
                    return tuple(np.concatenate(x) for x in zip(*parts))
                got = thin(lam, r)
                if got is not None:
                    return margins(*got)
            elif nr.any():
                return tuple(_merge(nr, x, y) for x, y in zip(choices(lam, r[nr]), choices(lam, r[~nr])))
        if len(r) > ALLOCATE_ROWS:
            parts = [choices(lam, r[a:a + ALLOCATE_ROWS]) for a in range(0, len(r), ALLOCATE_ROWS)]
            return tuple(np.concatenate(x) for x in zip(*parts))
        return margins(*block(lam, r))

    def margins(j, c1, c2):
        if k < 2:
            return j, c1, c2
        with np.errstate(invalid="ignore"):
            margin = np.where(np.isinf(c2), np.inf, c2 - c1)
        return j, margin, MARGIN_R * (np.abs(c1) + np.abs(c2))

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


def _least_two(cost):
    """Of each column of cost (w, m), holding no NaN: the row of its least entry (the
    first if several), that entry, and the second least (the least of the others: the
    least again where two rows hold it).  Kept row by row, elementwise: a later row
    replaces the least only where it is strictly less (argmin's first)."""
    c1 = cost[0]
    jn = np.zeros(cost.shape[1], np.intp)
    c2 = np.full(cost.shape[1], np.inf)
    for q in range(1, cost.shape[0]):
        x = cost[q]
        lt = x < c1
        c2 = np.where(lt, c1, np.minimum(c2, x))
        c1 = np.where(lt, x, c1)
        jn = np.where(lt, q, jn)
    return jn, c1, c2


def _narrow_tables(Tx, Ix, finite):
    """(is_narrow per row, row -> narrow row, narrow column -> column, T, I) of the rows
    with at most NARROW_COLS finite entries, those first in column order (T and I
    column-major: (NARROW_COLS, narrow rows)); None when
    there are none or the tables are no wider (a stroke's T and I are its own row's)."""
    n, k = Ix.shape
    w = max(NARROW_COLS, 2)
    if k <= w:
        return None
    is_n = finite.sum(axis=1) <= w
    if not is_n.any():
        return None
    col = np.argsort(~finite[is_n], axis=1, kind="stable")[:, :w]
    # column-major (w, rows): allocate's thin() works on whole columns
    Tn = np.ascontiguousarray(np.take_along_axis(Tx[is_n], col, axis=1).T)
    In = np.ascontiguousarray(np.take_along_axis(Ix[is_n], col, axis=1).T)
    pos = np.full(n, -1)
    pos[is_n] = np.arange(int(is_n.sum()))
    return is_n, pos, col.astype(np.int16 if k < 2 ** 15 else np.intp), Tn, In


def _merge(mask, a, b):
    """One array of mask's length: a where mask, b elsewhere."""
    out = np.empty(mask.size, np.result_type(a, b))
    out[mask], out[~mask] = a, b
    return out


_ref_allocate, _ref_narrow_tables = _allocate, _narrow_tables


# ---------------------------------------------------------------- comparisons
def _core_modes():
    modes = [False]
    if plan_mod.USE_CORE and plan_mod._alloc_core() is not None:
        modes.append(True)
    return modes


def _same(Tx, Ix, finite, T_orig, budget_t, settle, monkeypatch):
    j_ref, hi_ref = _ref_allocate(Tx.copy(), Ix.copy(), finite.copy(), T_orig.copy(), budget_t, settle)
    for use in _core_modes():
        monkeypatch.setattr(plan_mod, "USE_CORE", use)
        j, hi = plan_mod._allocate(Tx.copy(), Ix.copy(), finite.copy(), T_orig.copy(), budget_t, settle)
        assert j.dtype == j_ref.dtype, use
        assert np.array_equal(j, j_ref), (use, np.flatnonzero(j != j_ref)[:10])
        assert np.float64(hi).view(np.int64) == np.float64(hi_ref).view(np.int64), (use, hi, hi_ref)
    monkeypatch.setattr(plan_mod, "USE_CORE", True)


def _ext(T, I, T_orig, I_orig):
    Tx = np.concatenate([T, T_orig[:, None]], axis=1)
    Ix = np.concatenate([I, I_orig[:, None]], axis=1)
    finite = np.isfinite(Ix)
    settle = bool(np.all(Ix[finite] >= 0.0) and np.all(Tx >= 0.0))
    return Tx, Ix, finite, settle


def _tables(rng, n, k=23):
    """Shaped like the real ones: most rows a few finite laws, some wide, some with one
    (the original) or none; exact duplicates, last-bit differences, crossings at lambdas
    the bisection visits."""
    T_orig = rng.uniform(0.02, 3.0, n)
    T = T_orig[:, None] * np.linspace(0.7, 1.5, k)[None, :]
    I_orig = rng.uniform(1e2, 1e7, n)
    I = I_orig[:, None] * rng.uniform(0.05, 1.3, (n, k))
    width = rng.choice([0, 1, 2, 5, 8, 9, 18, 23], n, p=[0.25, 0.1, 0.1, 0.25, 0.05, 0.05, 0.1, 0.1])
    for i in range(n):
        drop = rng.permutation(k)[width[i]:]
        I[i, drop] = np.inf
        T[i, drop] = rng.choice([0.0, 5.0])
    if k < 10:
        return T, I, T_orig, I_orig
    I[::13, 3] = I[::13, 2]
    T[::13, 3] = T[::13, 2]
    I[::7, 6] = np.nextafter(I[::7, 5], np.inf)
    T[::7, 6] = T[::7, 5]
    T[::11, 4] = T[::11, k - 1]                    # equal durations, other costs
    for i, lam in zip(range(1, n, 5), np.tile(2.0 ** np.arange(-3, 9), n)):
        I[i, 8] = I[i, 9] + lam * (T[i, 9] - T[i, 8])
    return T, I, T_orig, I_orig


# ---------------------------------------------------------------- real tables
CASES = [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_gyroid.gcode", "voron24"), ("prusa_gyroid.gcode", "auto"),
         ("prusa_klipper.gcode", "auto"), ("cura_box.gcode", "voron24"), ("prusa_concentric_arcs.gcode", "prusa-mk3s")]


def _capture(path, profile, tmp_path, monkeypatch):
    """The arguments of every _allocate call of a run (copies: it writes into Ix)."""
    from gcode_opt.cli import main
    calls = []
    orig = plan_mod._allocate

    def spy(Tx, Ix, finite, T_orig, budget_t, settle):
        calls.append((Tx.copy(), Ix.copy(), finite.copy(), np.array(T_orig, float), budget_t, settle))
        return orig(Tx, Ix, finite, T_orig, budget_t, settle)

    monkeypatch.setattr(plan_mod, "_allocate", spy)
    # the dense tables (the compiled core's allocation on Candidates' rows is held to these by
    # tests/test_mem27_alloc_rows.py)
    monkeypatch.setattr(plan_mod.Candidates, "rows_view", lambda self, rows, T_orig, I_orig: None)
    try:
        main(["process", str(path), "-o", str(tmp_path / "out.gcode"), "-q", "--profile", profile])
    except SystemExit:
        pass
    monkeypatch.setattr(plan_mod, "_allocate", orig)
    return calls


@pytest.mark.parametrize("name,profile", CASES)
def test_real_tables_same_bits(name, profile, tmp_path, monkeypatch):
    path = SAMPLES / name
    if not path.exists():
        pytest.skip(f"{name} not bundled")
    calls = _capture(path, profile, tmp_path, monkeypatch)
    assert calls
    for Tx, Ix, finite, T_orig, b, settle in calls:
        assert Tx.shape[0] > 100
        _same(Tx, Ix, finite, T_orig, b, settle, monkeypatch)
        # and under other budgets (an early stop at 0, the decade search's top)
        for b2 in (0.0, 0.5 * b, 3.0 * b, -1.0):
            _same(Tx, Ix, finite, T_orig, b2, settle, monkeypatch)


@pytest.mark.skipif(not os.environ.get("GCODE_OPT_ALLOC_NPZ"), reason="captured plates: by hand")
def test_captured_plates_same_bits(monkeypatch):
    for path in os.environ["GCODE_OPT_ALLOC_NPZ"].split(":"):
        d = np.load(path)
        i = 0
        while f"a{i}_Tx" in d:
            _same(d[f"a{i}_Tx"], d[f"a{i}_Ix"], d[f"a{i}_finite"], d[f"a{i}_T_orig"],
                  float(d[f"a{i}_budget"]), bool(d[f"a{i}_settle"]), monkeypatch)
            i += 1
        assert i > 0


# ---------------------------------------------------------------- random tables
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_tables_same_bits(seed, monkeypatch):
    rng = np.random.default_rng(seed)
    T, I, T_orig, I_orig = _tables(rng, 2500)
    Tx, Ix, finite, settle = _ext(T, I, T_orig, I_orig)
    for b in (0.0, 1.0, 20.0, 150.0, 1e9, -1.0):
        _same(Tx, Ix, finite, T_orig, b, settle, monkeypatch)


def test_all_fixed_and_tiny_tables(monkeypatch):
    """Every row with one finite candidate or none; one row; no live row left."""
    rng = np.random.default_rng(4)
    T, I, T_orig, I_orig = _tables(rng, 300)
    I[:, :] = np.inf
    I[::3, 5] = 1.0
    Tx, Ix, finite, settle = _ext(T, I, T_orig, I_orig)
    for b in (0.0, 10.0, -1.0):
        _same(Tx, Ix, finite, T_orig, b, settle, monkeypatch)
    T, I, T_orig, I_orig = _tables(np.random.default_rng(5), 40)
    for rows in (slice(0, 1), slice(0, 2), slice(0, 40)):
        Tx, Ix, finite, settle = _ext(T[rows], I[rows], T_orig[rows], I_orig[rows])
        for b in (0.0, 0.01, -1.0):
            _same(Tx, Ix, finite, T_orig[rows], b, settle, monkeypatch)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_overflow_and_not_plain(monkeypatch):
    """Costs that overflow (a fixed row's only cost too: it must stay in the steps), an
    infinite or negative T, negative and NaN costs: the numpy paths and the guards."""
    rng = np.random.default_rng(9)
    T, I, T_orig, I_orig = _tables(rng, 600)
    T2, To2, Io2 = T.copy(), T_orig.copy(), I_orig.copy()
    T2[:60] *= 1e290
    To2[:60] *= 1e290
    Io2[:60] = 1e300
    Io2[60:90] = 1e305                             # fixed rows whose only cost is near overflow
    for b in (0.0, 10.0, -1.0, -1e300):
        _same(*_ext(T2, I, To2, Io2)[:3], To2, b, _ext(T2, I, To2, Io2)[3], monkeypatch)
    for mod in ("inf_t", "neg_t", "neg_i", "nan_i"):
        T3, I3 = T.copy(), I.copy()
        if mod == "inf_t":
            T3[::11, 4] = np.inf
        elif mod == "neg_t":
            T3[::9, 1] = -0.5
        elif mod == "neg_i":
            I3[::7, 2] = -50.0
        else:
            I3[::5, 0] = np.nan
        Tx, Ix, finite, settle = _ext(T3, I3, T_orig, I_orig)
        _same(Tx, Ix, finite, T_orig, 10.0, settle, monkeypatch)


def test_narrow_tables_same_as_sorted():
    rng = np.random.default_rng(2)
    for n, k in ((700, 24), (50, 10), (5, 9)):
        T, I, T_orig, I_orig = _tables(rng, n, k - 1)
        Tx, Ix, finite, _ = _ext(T, I, T_orig, I_orig)
        Ix[~finite] = np.inf
        old, new = _ref_narrow_tables(Tx, Ix, finite), plan_mod._narrow_tables(Tx, Ix, finite)
        assert (old is None) == (new is None)
        if old is None:
            continue
        for a, b in zip(old, new):
            assert a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b)
            assert b.flags.c_contiguous


def test_core_fallback(monkeypatch):
    """A core without alloc_choices (stale or older build) or none: the numpy path."""
    import types
    from gcode_opt.firmware import simulate
    monkeypatch.setattr(simulate, "_core", types.SimpleNamespace())
    assert plan_mod._alloc_core() is None
    rng = np.random.default_rng(7)
    T, I, T_orig, I_orig = _tables(rng, 400)
    Tx, Ix, finite, settle = _ext(T, I, T_orig, I_orig)
    _same(Tx, Ix, finite, T_orig, 15.0, settle, monkeypatch)
    monkeypatch.setattr(simulate, "_core", None)
    assert plan_mod._alloc_core() is None
    _same(Tx, Ix, finite, T_orig, 15.0, settle, monkeypatch)


def test_core_checks_its_arguments():
    core = plan_mod._alloc_core()
    if core is None:
        pytest.skip("no compiled core")
    Tx, Ix = np.zeros((3, 4)), np.ones((3, 4))
    out = [np.empty(2, np.intp), np.empty(2), np.empty(2)]
    with pytest.raises(IndexError):
        core.alloc_choices(Tx, Ix, 4, np.array([0, 3], np.intp), 1.0, 1e-9, np.zeros(3), np.zeros(3), *out)
    with pytest.raises(ValueError):
        core.alloc_choices(Tx, Ix, 5, np.array([0, 1], np.intp), 1.0, 1e-9, np.zeros(3), np.zeros(3), *out)
