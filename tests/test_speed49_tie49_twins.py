"""Round 49 (tie49): the budget allocation breaks ties between strokes whose switch points are
equal to rounding (plan._break_ties): every stroke whose choice changes within TIE_R (1e-9,
relative) above the lambda found takes its choice there, as strokes with the same figures (a
group: the same bits) always did together.  The same stroke on two copies of an object has the
same figures up to an ulp or two; the bisection left whichever of them that rounding put last
at the slower choice, so a change at rounding level anywhere upstream (the circle law's early
stop) swapped which copy was re-timed.

Checked here, on every allocation path (the compiled dense core, numpy's dense tables, the
compiled rows view plan_auto uses): twin strokes with one candidate and their original, the
budget room for some of them, all keep their original, as twins with the same bits do, under a
perturbation of 1 ulp (either way) of any one figure of any twin (T, I of the candidate, of the
original); twins of a random multi-candidate stroke among random strokes, the budget landing on
their switch point: every choice is the brute-force argmin of I + lambda T just above that
switch point (the twins all at their faster choice), the budget met, and the same choices under
random 1-ulp perturbations of the twins' figures."""
import numpy as np
import pytest

from gcode_opt import plan as plan_mod
from gcode_opt.plan import Candidates

CORE = plan_mod._alloc_core() is not None


@pytest.fixture
def no_tie_break(monkeypatch):
    """The allocation without the tie-break (the bisection's choices, its steps only), for
    the tests whose reference is the allocation before it."""
    monkeypatch.setattr(plan_mod, "_break_ties", lambda *args: None)


def _paths():
    """(name, allocate(T, I, T_orig, I_orig, budget) -> (chosen column, k: original))."""
    def dense(use_core):
        def run(T, I, T_orig, I_orig, budget, mp):
            mp.setattr(plan_mod, "USE_CORE", use_core)
            return plan_mod.allocate(T.copy(), I.copy(), T_orig, I_orig, budget)[0]
        return run

    def rows(T, I, T_orig, I_orig, budget, mp):
        n, k = T.shape
        cands = Candidates.of_tables(T, np.zeros_like(T), I, np.zeros_like(T), T_orig)
        rv = cands.rows_view(np.arange(n), T_orig, I_orig)
        assert rv is not None
        j, _ = plan_mod._allocate_rows(cands.vals, rv, budget, plan_mod._alloc_core())
        return rv.columns(cands.mask, j, k)
    out = [("numpy", dense(False))]
    if CORE:
        out += [("core", dense(True)), ("rows", rows)]
    return out


PATHS = _paths()


def _ulp(x, way):
    return np.nextafter(x, np.inf if way > 0 else -np.inf)


def _twins(n_twins=5):
    """Twins with one candidate (T 1, I 1) and their original (T 0.5, I 3): each re-timed
    costs 0.5 s and saves 2 (switch point lambda 4, the same for all)."""
    T = np.ones((n_twins, 1))
    I = np.ones((n_twins, 1))
    return T, I, np.full(n_twins, 0.5), np.full(n_twins, 3.0)


@pytest.mark.parametrize("name,run", PATHS)
def test_twins_taken_alike_whatever_their_last_bits(name, run, monkeypatch):
    T, I, T_orig, I_orig = _twins()
    budget = 2.6 * 0.5          # room for 2 of the 5 (2.6 of them)
    want = np.ones(5, int)      # as twins of the same bits: all keep their original (column 1)
    assert np.array_equal(run(T, I, T_orig, I_orig, budget, monkeypatch), want)
    for r in range(T.shape[0]):
        for way in (1, -1):
            for a in range(4):
                x = [z.copy() for z in (T, I, T_orig, I_orig)]
                x[a][r] = _ulp(x[a][r], way)
                got = run(*x, budget, monkeypatch)
                assert np.array_equal(got, want), (name, r, way, a, got)


def _background(rng, n, k):
    """Random strokes: k candidates each (some infeasible), T >= 0."""
    T_orig = rng.uniform(0.05, 1.0, n)
    T = T_orig[:, None] * rng.uniform(0.8, 2.0, (n, k))
    I_orig = rng.uniform(1.0, 5.0, n)
    I = I_orig[:, None] * rng.uniform(0.1, 1.2, (n, k))
    I[rng.random((n, k)) < 0.3] = np.inf
    return T, I, T_orig, I_orig


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("name,run", PATHS)
def test_twins_among_random_strokes(name, run, seed, monkeypatch):
    rng = np.random.default_rng(49 + seed)
    n, k, m = 400, 6, 6
    T, I, T_orig, I_orig = _background(rng, n, k)
    # m copies of stroke 0 spread among the others (row order: their places)
    at = np.sort(rng.choice(np.arange(1, n), m - 1, replace=False))
    twins = np.concatenate([[0], at])
    T[twins], I[twins], T_orig[twins], I_orig[twins] = T[0], I[0], T_orig[0], I_orig[0]
    I[0, :2] = np.inf            # (a stroke with a few candidates: 4 of them and its original)
    I[twins] = I[0]
    # a budget whose lambda lands on one of the twins' switch points: the total at lambda just
    # below and just above it, and a budget between
    Tx = np.column_stack([T, T_orig])
    Ix = np.column_stack([I, I_orig])
    lam_sw = _switch_points(Tx[0], Ix[0])
    assert lam_sw.size
    lam0 = lam_sw[lam_sw.size // 2]

    def spent(lam):
        j = np.argmin(np.where(np.isfinite(Ix), Ix + lam * Tx, np.inf), axis=1)
        return (Tx[np.arange(n), j] - T_orig), j
    lo, j_lo = spent(lam0 * (1 - 1e-7))
    hi, j_hi = spent(lam0 * (1 + 1e-7))
    assert np.flatnonzero(j_lo != j_hi).tolist() == twins.tolist()
    # room for half of the twins' change (the others are the same at both ends)
    budget = float(hi.sum() + 0.5 * (lo.sum() - hi.sum()))
    want = run(T, I, T_orig, I_orig, budget, monkeypatch)
    assert _spent_of(want, Tx, T_orig) <= budget
    # the brute-force choices just above the twins' switch point (the twins at the faster)
    assert np.array_equal(want, j_hi)
    for trial in range(12):
        x = [z.copy() for z in (T, I, T_orig, I_orig)]
        for _ in range(3):
            a = rng.integers(4)
            r = twins[rng.integers(m)]
            if a < 2:            # (a finite entry: an infeasible one stays inf)
                c = rng.choice(np.flatnonzero(np.isfinite(I[r])))
                x[a][r, c] = _ulp(x[a][r, c], rng.choice([1, -1]))
            else:
                x[a][r] = _ulp(x[a][r], rng.choice([1, -1]))
        got = run(*x, budget, monkeypatch)
        assert np.array_equal(got, want), (name, trial)


def _switch_points(t, i):
    """The lambdas where a stroke's choice (argmin of i + lambda t over its finite entries)
    changes: its lower envelope's corners, walked from lambda 0."""
    fin = np.isfinite(i)
    t, i = t[fin], i[fin]
    out = []
    lam = 0.0
    j = int(np.argmin(i + lam * t))
    while True:
        faster = t < t[j]
        if not faster.any():
            break
        cross = (i[faster] - i[j]) / (t[j] - t[faster])
        c = int(np.argmin(cross))
        lam = float(cross[c])
        j = int(np.flatnonzero(faster)[c])
        out.append(lam)
    return np.array(out)


def _spent_of(cols, Tx, T_orig):
    return float(np.sum(Tx[np.arange(cols.size), cols] - T_orig))
