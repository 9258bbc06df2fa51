"""The planner's choices, checked against the law's own figures (not the planner's code)."""
import numpy as np

from gcode_opt.laws.line import line_law
from gcode_opt.plan import PlanInput, candidates_auto, plan_auto, plan_fixed_alpha


def _trapezoid(L, v0, vc, A):
    """Rest-to-rest-ish trapezoid from v0 back to v0 at cruise vc, accel A: (T, int a^2)."""
    d_ramp = (vc ** 2 - v0 ** 2) / (2 * A)
    if 2 * d_ramp > L:
        vp = np.sqrt(A * L + v0 ** 2)
        return 2 * (vp - v0) / A, A * 2 * (vp - v0)
    return 2 * (vc - v0) / A + (L - 2 * d_ramp) / vc, A * 2 * (vc - v0)


def _inputs(Ls, v0=5.0, F=80.0, A=1000.0, overshoot=0.25):
    L = np.array(Ls, float)
    TI = np.array([_trapezoid(x, v0, F, A) for x in L])
    n = len(L)
    return PlanInput(L, np.full(n, v0), np.full(n, v0), np.full(n, F * (1 + overshoot)), np.full(n, A),
                     TI[:, 0], TI[:, 1], np.ones(n), np.full(n, 0.02))


def test_auto_candidates_respect_the_caps():
    p = _inputs([3.0, 10.0, 40.0, 100.0])
    T, beta, I, KE = candidates_auto(p)
    ok = np.isfinite(I)
    law = line_law(p.L[:, None], T, beta, p.v0[:, None], p.v1[:, None])
    assert np.all(law.peak_speed()[ok] <= p.v_cap[:, None].repeat(T.shape[1], 1)[ok] * (1 + 1e-5))
    assert np.all(law.peak_accel()[ok] <= 1000.0 * (1 + 1e-5))
    assert np.all(law.min_speed()[ok] >= -1e-6)
    # and each choice is the largest beta: 1 % more beta breaks the speed cap (unless cubic)
    finite_b = ok & np.isfinite(beta)
    law2 = line_law(p.L[:, None], T, beta * 1.01, p.v0[:, None], p.v1[:, None])
    assert np.all(law2.peak_speed()[finite_b] > p.v_cap[:, None].repeat(T.shape[1], 1)[finite_b] * (1 - 1e-9))


def test_auto_spends_no_more_than_the_budget_and_beats_the_trapezoid():
    p = _inputs(np.linspace(2.0, 120.0, 60))
    budget = 0.03 * p.T_orig.sum()
    plan = plan_auto(p, budget)
    dt = np.sum(np.where(plan.retime, plan.T - p.T_orig, 0.0))
    assert dt <= budget * (1 + 1e-9)
    assert plan.retime.sum() > 30
    assert np.all(plan.I_law[plan.retime] < p.I_orig[plan.retime])
    # the law's own integral, recomputed independently from the law object
    _, I = line_law(p.L, plan.T, plan.beta, p.v0, p.v1).integrals()
    assert np.allclose(I[plan.retime], plan.I_law[plan.retime], rtol=1e-12)
    # more budget never makes the total worse
    plan2 = plan_auto(p, 2 * budget)
    assert plan2.I_law.sum() <= plan.I_law.sum() * (1 + 1e-12)


def test_fixed_alpha_picks_the_shortest_feasible_duration():
    p = _inputs([10.0, 40.0, 100.0])
    plan = plan_fixed_alpha(p, alpha=0.01)
    assert plan.retime.all()
    beta = 0.01 * p.mass_r

    def feasible(T):
        law = line_law(p.L, T, beta, p.v0, p.v1)
        return ((law.peak_speed() <= p.v_cap * (1 + 1e-6)) & (law.peak_accel() <= p.a_cap * (1 + 1e-6))
                & (law.min_speed() >= -1e-9))
    assert feasible(plan.T).all()
    assert not feasible(plan.T * 0.995).any()


def test_a_nan_stroke_neither_is_chosen_nor_lifts_the_budget():
    """Issue 7: one stroke with a NaN original time kept the budget bisection from
    converging (every comparison with NaN is False), so the whole file got lambda = 0."""
    p = _inputs([5.0, 12.0, 30.0, 60.0, 8.0, 45.0])
    budget = 0.01 * float(p.T_orig.sum())
    ref = plan_auto(p, budget)
    assert ref.lam > 0                                          # the budget binds
    q = _inputs([5.0, 12.0, 30.0, 60.0, 8.0, 45.0, 20.0])
    cands = candidates_auto(q)
    q.T_orig[-1] = np.nan                                       # the firmware model's figure, poisoned
    got = plan_auto(q, budget, cands)
    assert not got.retime[-1]
    assert got.retime[:-1].tolist() == ref.retime.tolist() and np.allclose(got.T[:-1], ref.T)
    assert float(np.sum(got.T[:-1] - q.T_orig[:-1])) <= budget * (1 + 1e-9)


# ------------------------------------------------------------------ fast paths, same answers
def test_largest_beta_matches_an_independent_root_find():
    """The bisection (lean speed evaluations) lands on the root of peak_speed = cap found by
    brentq on the full law's peak_speed, within the bisection's resolution."""
    from scipy.optimize import brentq

    from gcode_opt.plan import GAMMA_HI, GAMMA_LO, SPEED_TOL_R, _largest_beta_under_speed_cap
    rng = np.random.default_rng(7)
    n = 60
    L = rng.uniform(1.0, 100.0, n)
    v0, v1 = rng.uniform(0.0, 60.0, n), rng.uniform(0.0, 60.0, n)
    v_cap = np.maximum(v0, v1) * rng.uniform(1.05, 1.6, n) + 1.0
    T = L / (v_cap * rng.uniform(0.75, 0.97, n))
    beta = _largest_beta_under_speed_cap(L, T, v0, v1, v_cap)
    checked = 0
    for i in range(n):
        def excess(lg):
            return float(line_law(L[i], T[i], (T[i] / np.exp(lg)) ** 2, v0[i], v1[i]).peak_speed()) \
                - v_cap[i] * (1 + SPEED_TOL_R)
        if excess(np.log(GAMMA_LO)) <= 0:          # even the cubic fits: beta = inf
            assert np.isinf(beta[i])
            continue
        assert excess(np.log(GAMMA_HI)) <= 0
        lg_ref = brentq(excess, np.log(GAMMA_LO), np.log(GAMMA_HI), xtol=1e-13, rtol=1e-15)
        lg = np.log(T[i] / np.sqrt(beta[i]))
        assert lg_ref - 1e-12 <= lg <= lg_ref + 1e-8      # on the feasible side, within 2^-32 of the range
        checked += 1
    assert checked > n // 3


def test_candidates_in_chunks_are_the_same_tables():
    p = _inputs(np.linspace(1.0, 150.0, 37))
    whole = candidates_auto(p, chunk=10 ** 6)
    chunked = candidates_auto(p, chunk=5)
    for a, b in zip(whole, chunked):
        assert np.array_equal(a, b, equal_nan=True)


def test_replans_reuse_segments_and_give_a_fresh_runs_plan(monkeypatch):
    """plan_strokes re-spends the budget a few times; segments reused from an earlier run
    (SegmentCache) must be exactly those a fresh segmentation gives."""
    from gcode_opt import schedule
    from gcode_opt.pipeline import Options, analyse
    from gcode_opt.profile import load_profile
    prof, opts = load_profile("prusa-mk3s"), Options()
    strokes, sim = analyse("sample_gcode/prusa_gyroid.gcode", prof, opts)
    budget = opts.max_slowdown_r * sim.time_t
    cached = schedule.plan_strokes(strokes, schedule.plan_inputs(strokes, prof, opts), prof, opts, budget)
    hits = []
    real = schedule.SegmentCache.lookup

    def counting(self, kind, rows, T, beta):
        got, bad = real(self, kind, rows, T, beta)
        hits.append(len(got) + len(bad))
        return got, bad
    monkeypatch.setattr(schedule.SegmentCache, "lookup", counting)
    real_same = schedule._RunMemo.put_same

    def counting_same(self, plan, idx, own):          # (s31: the last run's outcome, kept per row)
        rest = real_same(self, plan, idx, own)
        hits.append(idx.size - rest.size)
        return rest
    monkeypatch.setattr(schedule._RunMemo, "put_same", counting_same)
    schedule.plan_strokes(strokes, schedule.plan_inputs(strokes, prof, opts), prof, opts, budget)
    assert sum(hits) > 0                                  # the cache or the last run's is used on this file
    monkeypatch.setattr(schedule.SegmentCache, "lookup", lambda self, *a: ({}, {}))
    monkeypatch.setattr(schedule, "REUSE_RUNS", False)
    fresh = schedule.plan_strokes(strokes, schedule.plan_inputs(strokes, prof, opts), prof, opts, budget)
    assert np.array_equal(cached.retime, fresh.retime)
    assert np.array_equal(cached.T, fresh.T) and np.array_equal(cached.beta, fresh.beta)
    for a, b in zip(cached.segs, fresh.segs):
        assert (a is None) == (b is None)
        if a is not None:
            for k in ("s", "v", "accel", "feed"):
                assert np.array_equal(getattr(a, k), getattr(b, k))
            assert a.time_t == b.time_t and a.int_a2 == b.int_a2


def test_segments_in_knot_chunks_are_the_same(monkeypatch):
    """plan_segments evaluates the knots of a few strokes at a time: the same plans."""
    from gcode_opt import schedule, segments
    from gcode_opt.pipeline import Options, analyse
    from gcode_opt.profile import load_profile
    prof, opts = load_profile("prusa-mk3s"), Options()
    strokes, _ = analyse("sample_gcode/prusa_absolute_e.gcode", prof, opts)
    pin = schedule.plan_inputs(strokes, prof, opts)
    lines = [s for s in strokes if s.kind == "line"]
    rows = [i for i, s in enumerate(strokes) if s.kind == "line"]
    T, beta, I, _ = candidates_auto(pin.take(rows))
    j = np.argmax(np.isfinite(I), axis=1)                 # some feasible law per stroke
    Tj, bj = T[np.arange(len(rows)), j], beta[np.arange(len(rows)), j]
    rules = segments.SegmentRules.for_profile(prof, opts.max_segments)
    whole = segments.plan_segments(lines, Tj, bj, rules)
    monkeypatch.setattr(segments, "KNOT_CHUNK", 7)
    chunked = segments.plan_segments(lines, Tj, bj, rules)
    assert sum(p is not None for p in whole) > 100
    for a, b in zip(whole, chunked):
        assert (a is None) == (b is None)
        if a is not None:
            for k in ("s", "v", "accel", "feed"):
                assert np.array_equal(getattr(a, k), getattr(b, k))
