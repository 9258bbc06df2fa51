"""Issue 8, round 46 (newton46): the line candidates' beta (gamma_v, the least gamma whose
law's peak speed is under the cap) without its 32 bisection steps: plan._log_gamma_root
estimates the root (the table model's root, a Newton step with its slope, secants), replays
the bisection's path through the estimate without evaluating, and checks that path's last
bracket at its two ends (the bisection itself where a check fails).  ~4 speed evaluations a
law where the bisection made 33, and the bisection's bits.

References: the bisection as it stood (0b09fc6's _beta_bisect, its bisection verbatim below): the same
bits, beta and interior speed; and, independent of both, a bisection of the same test run
to full double precision (until its bracket's ends are adjacent doubles) and the full law's
peak_speed (LineLaw): the answer is the feasible end of a bracket of width <= ROOT_TOL_Y
(23.03 / 2^32 = 5.4e-9 in log gamma) holding the root, y_exact - noise <= y <= y_exact +
ROOT_TOL_Y + noise (noise: see _noise_y)."""
import os

import numpy as np
import pytest

from gcode_opt import plan as plan_mod
from gcode_opt.laws import line as line_mod
from gcode_opt.laws.line import InteriorSpeeds, end_speeds, line_law, peak_root_guess
from gcode_opt.plan import GAMMA_HI, GAMMA_LO, SPEED_TOL_R, T_RATIOS

from test_speed22_budget_candidates import _random_inputs  # noqa: E402  (tests/ is on the path)


# ---------------------------------------------------------------- 0b09fc6, verbatim
def _bisection_ref(prep, iters=32):
    """_beta_bisect's bisection of one _beta_prep state's rows b: (beta_b, v_crit_b)."""
    Tb, capb, v_endb, speeds = prep[2], prep[3], prep[4], prep[5]
    lo = np.full(Tb.shape, np.log(GAMMA_LO))
    hi = np.full_like(lo, np.log(GAMMA_HI))
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        g = np.exp(mid)
        ok = np.maximum(v_endb, speeds((Tb / g) ** 2)) <= capb
        hi = np.where(ok, mid, hi)
        lo = np.where(ok, lo, mid)
    gamma = np.exp(hi)
    beta_b = (Tb / gamma) ** 2
    return beta_b, speeds(beta_b)


def _bits(x):
    return np.ascontiguousarray(x, float).view(np.int64)

PLATE = os.path.expanduser("~/.cache/gcode-opt-corpus/plate_rectilinear.gcode")
Y_LO, Y_HI = np.log(GAMMA_LO), np.log(GAMMA_HI)
ROOT_TOL_Y = (Y_HI - Y_LO) * 2.0 ** -32      # the bracket of the 32 halvings the search replaced


def _noise_y(L, T, v0, v1, y):
    """Where the speed's own rounding (a few 1e-16 of it) makes the test pass and fail by
    turns near the root, "the root" is any point of that stretch: its width in log gamma,
    8 eps / the speed's relative slope there (~1e-15 at gamma ~ 1, 3e-10 at gamma ~ 0.008:
    the speed's change is ~gamma^2 / 240 of it, at gamma ~ 1e5 ~2 / gamma)."""
    sp = InteriorSpeeds(L, T, v0, v1)
    v_a, v_b = sp((T / np.exp(y - 1e-3)) ** 2), sp((T / np.exp(y + 1e-3)) ** 2)
    slope_r = np.abs(v_a - v_b) / (2e-3 * np.abs(v_a + v_b) / 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(slope_r > 0, np.maximum(8 * np.finfo(float).eps / slope_r, 1e-13), np.inf)   # (flat: anywhere)


def _exact_log_gamma(L, T, v0, v1, v_cap):
    """(y_lo, y_hi) of a bisection of the planner's test on log gamma over (Y_LO, Y_HI] run
    until its ends are adjacent doubles: y_hi passes (or is Y_HI, untested), y_lo does not
    (or is Y_LO)."""
    cap = v_cap * (1 + SPEED_TOL_R)
    v_end = np.maximum(*end_speeds(L, T, v0, v1))
    sp = InteriorSpeeds(L, T, v0, v1)
    lo, hi = np.full(L.shape, Y_LO), np.full(L.shape, Y_HI)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        live = (mid > lo) & (mid < hi)
        if not live.any():
            break
        ok = np.maximum(v_end, sp((T / np.exp(mid)) ** 2)) <= cap
        hi = np.where(live & ok, mid, hi)
        lo = np.where(live & ~ok, mid, lo)
    return lo, hi


def _check(L, T, v0, v1, v_cap, clean_r=0.5):
    """The search's beta of every law against the references; returns how many were
    searched.  clean_r: the least share of them whose root no rounding blurs (_noise_y)."""
    beta, v_crit = plan_mod._largest_beta_plain(L, T, v0, v1, v_cap)
    want = _bisection_ref(plan_mod._beta_prep(L, T, v0, v1, v_cap))
    cap = v_cap * (1 + SPEED_TOL_R)
    v_end = np.maximum(*end_speeds(L, T, v0, v1))
    cubic_ok = np.maximum(v_end, InteriorSpeeds(L, T, v0, v1).cubic()) <= cap
    assert np.array_equal(np.isinf(beta), cubic_ok)
    s = np.flatnonzero(~cubic_ok)
    prep = plan_mod._beta_prep(L, T, v0, v1, v_cap)
    assert np.array_equal(prep[1], s)
    y = plan_mod._log_gamma_root(prep[5], prep[2], prep[3], prep[4])[0]
    assert beta[s].tobytes() == ((T[s] / np.exp(y)) ** 2).tobytes()
    y_lo, y_hi = _exact_log_gamma(L[s], T[s], v0[s], v1[s], v_cap[s])
    noise = _noise_y(L[s], T[s], v0[s], v1[s], y)
    assert np.all(y >= y_hi - noise)                         # on the feasible side of the root
    assert np.all(y <= y_hi + ROOT_TOL_Y + noise)            # within the bracket width
    clean = noise < 1e-3 * ROOT_TOL_Y                        # (most: where rounding cannot blur it)
    assert np.all(y[clean] <= y_hi[clean] + ROOT_TOL_Y) and clean.mean() > clean_r
    # the bisection's bits, but where the test passes and fails by turns over a stretch that
    # reaches a middle of its path (then any end of that stretch's brackets is the root)
    differ = (_bits(beta[s]) != _bits(want[0])) | (_bits(v_crit[s]) != _bits(want[1]))
    assert not (differ & clean).any()
    # the speed returned is the law's own at that beta, and the law passes the planner's test
    sp = InteriorSpeeds(L[s], T[s], v0[s], v1[s])
    assert np.array_equal(_bits(v_crit[s]), _bits(sp(beta[s])))
    passed = (y_hi < Y_HI) | (v_end[s] <= cap[s]) & (np.maximum(v_end[s], v_crit[s]) <= cap[s])
    assert np.all(np.maximum(v_end[s], v_crit[s])[passed] <= cap[s][passed])
    # and its full law (LineLaw's peak speed) is under the cap too
    peak = line_law(L[s], T[s], beta[s], v0[s], v1[s]).peak_speed()
    assert np.all(peak[passed] <= cap[s][passed])
    return s.size


def _random_laws(n, seed):
    """(L, T, v0, v1, v_cap) of test_speed22's random strokes (their original durations)."""
    p = _random_inputs(n, seed)
    return p.L, p.T_orig, p.v0, p.v1, p.v_cap


def _strokes(rng, n):
    """(L, T): lengths and durations of strokes at 20 to 200 mm/s."""
    L = rng.uniform(1.0, 50.0, n)
    return L, L / rng.uniform(20.0, 200.0, n)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_laws_against_full_precision_bisection(seed):
    assert _check(*_random_laws(4000, seed)) > 1000


def _at_root(L, T, v0, v1, y):
    """The cap (v_cap, before SPEED_TOL_R) whose root is at log gamma y for each law."""
    v = InteriorSpeeds(L, T, v0, v1)((T / np.exp(y)) ** 2)
    return np.maximum(v, np.maximum(*end_speeds(L, T, v0, v1))) / (1 + SPEED_TOL_R)


def test_roots_near_the_ends_and_no_root():
    """Roots just inside GAMMA_LO and GAMMA_HI, at the table model's ends and beyond them,
    laws over the cap everywhere (v_end over it: y = Y_HI, untested, as the bisection's) and
    laws under it everywhere but the cubic."""
    rng = np.random.default_rng(3)
    n = 600
    L, T = _strokes(rng, n)
    v0, v1 = (rng.uniform(0.0, 40.0, n) * (rng.random(n) < 0.7) for _ in range(2))
    y = rng.choice([Y_LO + 1e-9, Y_LO + 1e-3, -6.5, -6.0, -2.0, 0.0, 3.0, 7.0, 7.5, 12.0, Y_HI - 1e-3], n)
    v_cap = _at_root(L, T, v0, v1, y)
    v_cap[:50] = np.maximum(v0, v1)[:50] * 0.9           # the end speed over the cap (some equal 0: NaN-free)
    v_cap[50:60] *= 1 - 1e-15                              # roots a rounding away
    assert _check(L, T, v0, v1, v_cap, clean_r=0.2) > 500    # (most of these roots are where gamma is tiny)
    beta = plan_mod._largest_beta_plain(L[:50], T[:50], v0[:50], v1[:50], v_cap[:50])[0]
    over = np.isfinite(beta)
    assert np.array_equal(beta[over], (T[:50][over] / np.exp(np.log(GAMMA_HI))) ** 2)


def test_large_rho_and_symmetric_laws():
    """|rho| = |delta / A| up to ~1 (the model's worst) and rho = 0 (v0 = v1, its best)."""
    rng = np.random.default_rng(4)
    n = 2000
    L, T = _strokes(rng, n)
    v0 = rng.uniform(0.0, 1.0, n) * L / T
    v1 = np.where(rng.random(n) < 0.3, v0, rng.uniform(0.0, 1.0, n) * L / T)
    y = rng.uniform(-5.0, 8.0, n)
    assert _check(L, T, v0, v1, _at_root(L, T, v0, v1, y)) > 1500


def test_dense_path_is_the_plain_search_elementwise():
    """_largest_beta_under_speed_cap of broadcast (n, k) laws: the same bits as the search
    of each law alone and in one flat batch (every step is the row's own)."""
    L, T, v0, v1, v_cap = _random_laws(300, 5)
    Tk = T[:, None] * T_RATIOS[None, :]
    got = plan_mod._largest_beta_under_speed_cap(L[:, None], Tk, v0[:, None], v1[:, None], v_cap[:, None])
    flat = plan_mod._largest_beta_plain(*(np.broadcast_to(a, Tk.shape).ravel() for a in
                                          (L[:, None], Tk, v0[:, None], v1[:, None], v_cap[:, None])))[0]
    assert got.tobytes() == flat.reshape(Tk.shape).tobytes()
    for i in (0, 17, 299):
        one = plan_mod._largest_beta_under_speed_cap(L[i], Tk[i, 3], v0[i], v1[i], v_cap[i])
        assert one.shape == () and one.tobytes() == got[i, 3].tobytes()


def test_underflowing_beta_still_raises_and_odd_laws_bisect_as_before():
    """Laws the search would not take (a beta to try underflowing; T not finite and > 0)
    go to the bisection kept as it was: it raises where it raised."""
    L, T = np.array([1.0, 1e-300]), np.array([0.05, 1e-302])
    v0 = v1 = np.array([20.0, 1e-300])
    assert not plan_mod._plain_laws(L, T, v0, v1)
    with pytest.raises(ValueError):
        plan_mod._largest_beta_under_speed_cap(L, T, v0, v1, np.array([1e9, 1e9]))
    with pytest.raises(ValueError):
        plan_mod._largest_beta_under_speed_cap(L, np.array([0.05, np.nan]), v0, v1, np.array([30.0, 30.0]))


def test_few_speed_evaluations(monkeypatch):
    """The point of the change: ~4 interior-speed evaluations a searched law (33 before)."""
    L, T, v0, v1, v_cap = _random_laws(4000, 6)
    line_mod._peak_table_rows()                         # (the table's own, once a process)
    count = [0, 0]
    call = InteriorSpeeds.__call__

    def counted(self, beta):
        count[0] += np.size(beta)
        count[1] += 1
        return call(self, beta)

    monkeypatch.setattr(InteriorSpeeds, "__call__", counted)
    beta = plan_mod._largest_beta_plain(L, T, v0, v1, v_cap)[0]
    searched = np.count_nonzero(np.isfinite(beta))
    assert searched > 1000
    assert count[0] <= 5.0 * searched and count[1] <= plan_mod.ROOT_MODEL_STEPS + 2 * plan_mod.PATH_CHECKS + 1


def _bisect_threshold(r):
    """The bisection of the test mid >= r (a monotone test: its threshold r)."""
    lo, hi = np.full(r.shape, Y_LO), np.full(r.shape, Y_HI)
    for _ in range(32):
        mid = 0.5 * (lo + hi)
        ok = mid >= r
        hi = np.where(ok, mid, hi)
        lo = np.where(ok, lo, mid)
    return lo, hi


def test_bisection_path_is_the_bisection():
    """Replayed through any point (middles of the path themselves, their neighbours, the
    range's ends and beyond, NaN), the path ends where the bisection of that threshold does."""
    rng = np.random.default_rng(9)
    r = rng.uniform(Y_LO - 1.0, Y_HI + 1.0, 3000)
    lo, hi = _bisect_threshold(r)
    edge = np.concatenate([lo, hi, np.nextafter(hi, np.inf), np.nextafter(lo, -np.inf),
                           [Y_LO, Y_HI, np.nextafter(Y_LO, np.inf), np.nextafter(Y_HI, -np.inf), -np.inf, np.inf, np.nan]])
    r = np.concatenate([r, edge])
    want = _bisect_threshold(r)
    got = plan_mod._bisection_path(r)
    assert all(np.array_equal(_bits(a), _bits(b)) for a, b in zip(got, want))


@pytest.mark.parametrize("off", [-2, -1, 1, 3, np.nan])
def test_wrong_estimates_still_give_the_bisection(monkeypatch, off):
    """Estimates off by whole brackets of the path (or none): the checks find it, the path is
    replayed through the side they tell, and the bisection itself ends it if need be."""
    L, T, v0, v1, v_cap = _random_laws(1500, 11)
    prep = plan_mod._beta_prep(L, T, v0, v1, v_cap)
    want = _bisection_ref(prep)
    true = plan_mod._root_estimates

    def off_by(sp, T_, cap, v_end):
        return true(sp, T_, cap, v_end) + off * ROOT_TOL_Y

    monkeypatch.setattr(plan_mod, "_root_estimates", off_by)
    got = plan_mod._largest_beta_plain(L, T, v0, v1, v_cap)
    b = prep[1]
    assert np.array_equal(_bits(got[0][b]), _bits(want[0])) and np.array_equal(_bits(got[1][b]), _bits(want[1]))


def test_peak_root_guess_and_table():
    """The model's table: P0 strictly falls (its inverse is np.interp's), and the guess is
    near the true root of P(gamma, rho) = w for |rho| <= 0.9 (the reference: the bisection
    above on the law L = 1, T = 1, v0 = -rho, v1 = rho, whose interior speed is P)."""
    y_n, P0, _, _ = line_mod._peak_table_rows()
    assert np.all(np.diff(P0) < 0)
    rng = np.random.default_rng(8)
    n = 3000
    rho = rng.uniform(-0.9, 0.9, n)
    y_true = rng.uniform(y_n[0] + 0.5, y_n[-1] - 0.5, n)
    one = np.ones(n)
    w = InteriorSpeeds(one, one, -rho, rho)(np.exp(-2.0 * y_true))
    y, slope = peak_root_guess(rho * rho, w)
    err = np.abs(y - y_true)
    assert np.median(err) < 1e-4 and err.max() < 3e-3
    assert np.all(slope < 0)
    # NaN inputs give a point of the table's range (the search then takes its bracket's middle)
    y_nan, _ = peak_root_guess(np.array([np.nan, 0.0]), np.array([1.2, np.nan]))
    assert np.all((y_nan >= y_n[0]) & (y_nan <= y_n[-1]))


@pytest.mark.skipif(not os.path.exists(PLATE), reason="corpus not downloaded")
def test_rectilinear_plate_rows():
    """The plate's own searched rows (its first chunks' live entries whose cubic is over the cap)."""
    from test_speed24_lineplan_candidates import _line_pin
    p = _line_pin(PLATE, "prusa-mk3s").take(np.arange(3 * plan_mod.CANDIDATE_CHUNK))
    T = p.T_orig[:, None] * T_RATIOS[None, :]
    flat = np.flatnonzero(T >= p.t_seg_min[:, None])
    r = flat // T.shape[1]
    args = (p.L[r], T.ravel()[flat], p.v0[r], p.v1[r], p.v_cap[r])
    keep = ~plan_mod.out_of_reach(*args, p.a_cap[r])
    assert _check(*(a[keep] for a in args)) > 2000
