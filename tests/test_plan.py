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
