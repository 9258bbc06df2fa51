"""plan.allocate settles strokes whose choice cannot change inside the bisection's bracket
and evaluates only the others (every stroke at every step where costs could cancel);
_reference below is allocate as it was before that change.  Both must give the same
choices and the same lambda, bit for bit."""
import os

import numpy as np
import pytest

from gcode_opt import pipeline as pl
from gcode_opt import plan as plan_mod
from gcode_opt import schedule as sc
from gcode_opt.profile import load_profile
from test_speed49_tie49_twins import no_tie_break

# the reference here is the allocation before round 49's tie-break (plan._break_ties, checked by
# test_speed49_tie49_twins against brute force): it is turned off
pytestmark = pytest.mark.usefixtures(no_tie_break.__name__)

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")


def _reference(T, I, T_orig, I_orig, budget_t):
    """allocate as it was: every stroke's choice at every bisection step."""
    Tx = np.concatenate([T, T_orig[:, None]], axis=1)
    Ix = np.concatenate([I, I_orig[:, None]], axis=1)
    finite = np.isfinite(Ix)

    def choose(lam):
        cost = np.where(finite, Ix + lam * Tx, np.inf)
        j = np.argmin(cost, axis=1)
        rows = np.arange(len(j))
        return j, float(np.sum(Tx[rows, j] - T_orig))

    j, dt = choose(0.0)
    if dt <= budget_t:
        return j, 0.0
    lo, hi = 0.0, 1.0
    while choose(hi)[1] > budget_t and hi < 1e30:
        hi *= 10.0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if choose(mid)[1] > budget_t:
            lo = mid
        else:
            hi = mid
    return choose(hi)[0], hi


def _same(args):
    j_ref, lam_ref = _reference(*args)
    j, lam = plan_mod.allocate(*args)
    assert np.array_equal(j, j_ref)
    assert lam == lam_ref


def _tables(name, profile):
    prof = load_profile(profile)
    opts = pl.Options()
    strokes, sim0 = pl.analyse(os.path.join(SAMPLES, name), prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    rows = sc._rows_by_kind(strokes)
    failed = {i: str(r) for i, r in enumerate(pin.fault) if r}
    (T, beta, I, KE), _ = sc._candidates(strokes, pin, prof, opts, rows, failed)
    fine = np.isfinite(pin.T_orig) & np.isfinite(pin.I_orig)
    return T[fine], I[fine], pin.T_orig[fine], pin.I_orig[fine], sim0.time_t


@pytest.mark.parametrize("name,profile", [("prusa_gyroid_fullspeed.gcode", "prusa-mk3s"),
                                          ("prusa_mk3s_rectilinear.gcode", "voron24")])
def test_real_tables_same_choices(name, profile):
    T, I, T_orig, I_orig, total_t = _tables(name, profile)
    assert len(T) > 100
    for r in (0.0, 0.001, 0.01, 0.03, 0.1, -0.01):        # -0.01: no plan fits, lambda runs away
        _same((T, I, T_orig, I_orig, r * total_t))


def test_near_ties_and_duplicates():
    """Candidates whose costs tie or nearly tie (duplicates, a last-bit difference) keep
    being evaluated: the result is the reference's."""
    rng = np.random.default_rng(7)
    n, k = 3000, 8
    T_orig = rng.uniform(0.05, 2.0, n)
    T = T_orig[:, None] * np.linspace(0.8, 1.2, k)[None, :]
    I_orig = rng.uniform(1e3, 1e7, n)
    I = I_orig[:, None] * rng.uniform(0.1, 1.2, (n, k))
    I[:, 3] = I[:, 2]                                     # exact duplicates
    T[:, 3] = T[:, 2]
    I[:, 5] = np.nextafter(I[:, 4], np.inf)               # a last-bit difference
    T[:, 5] = T[:, 4]
    I[rng.random((n, k)) < 0.1] = np.inf                  # infeasible candidates
    I[:40] = np.inf                                       # strokes with no law
    # lines that cross inside the bracket: the same cost at a lambda the bisection visits
    I[100:200, 6] = I[100:200, 7] + 5.0 * (T[100:200, 7] - T[100:200, 6])
    for b in (0.0, 0.5, 5.0, 20.0, 60.0, -1.0):
        _same((T, I, T_orig, I_orig, b))


def test_negative_or_nan_costs_take_the_reference_path():
    rng = np.random.default_rng(3)
    n, k = 500, 5
    T_orig = rng.uniform(0.1, 1.0, n)
    T = T_orig[:, None] * np.linspace(0.9, 1.1, k)[None, :]
    I = rng.uniform(-1.0, 1.0, (n, k))                    # a negative cost: could cancel
    I_orig = rng.uniform(0.0, 1.0, n)
    I[::17, 2] = np.nan
    for b in (0.0, 0.2, 2.0):
        _same((T, I, T_orig, I_orig, b))


def test_blocks_of_rows_give_the_same_choices(monkeypatch):
    """choices() by blocks of ALLOCATE_ROWS rows (bounded temporaries): the same result as
    one block, and as the reference."""
    T, I, T_orig, I_orig, total_t = _tables("prusa_gyroid_fullspeed.gcode", "prusa-mk3s")
    args = (T, I, T_orig, I_orig, 0.03 * total_t)
    one = plan_mod.allocate(*args)
    monkeypatch.setattr(plan_mod, "ALLOCATE_ROWS", 37)
    small = plan_mod.allocate(*args)
    assert np.array_equal(one[0], small[0]) and one[1] == small[1]
    _same(args)


def test_no_candidate_columns_and_no_strokes():
    rng = np.random.default_rng(5)
    T_orig = rng.uniform(0.1, 1.0, 50)
    I_orig = rng.uniform(0.0, 1.0, 50)
    for b in (0.0, -1.0):
        _same((np.empty((50, 0)), np.empty((50, 0)), T_orig, I_orig, b))
        _same((np.empty((0, 4)), np.empty((0, 4)), np.empty(0), np.empty(0), b))
