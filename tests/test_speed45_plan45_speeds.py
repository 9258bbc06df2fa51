"""Issue 8, round 45 (plan45): InteriorSpeeds keeps the last call's split (each branch's rows
and its constants taken at them) and takes it again where a call's split is the same (the
planner's bisection keeps one for most of its steps), instead of six takes a branch a call.
One object is called through a sequence of betas whose splits repeat, change and come back,
and every call must be interior_speed's bits (the reference) and a fresh object's."""
import numpy as np

from gcode_opt.laws.line import GAMMA_SWITCH, InteriorSpeeds, interior_speed
from gcode_opt.plan import GAMMA_HI, GAMMA_LO


def _bits(x):
    return np.asarray(x, float).view(np.int64)


def _laws(rng, n):
    L = rng.uniform(0.01, 100.0, n)
    T = L / rng.uniform(2.0, 400.0, n)
    v0 = rng.uniform(0.0, 250.0, n) * (rng.random(n) < 0.8)
    v1 = rng.uniform(0.0, 250.0, n) * (rng.random(n) < 0.7)
    v0[:10] = v1[:10] = L[:10] / T[:10]               # A = 0 and delta = 0 (rho NaN)
    return L, T, v0, v1


def test_a_bisection_through_one_object():
    """_beta_bisect's steps: every row halves its own bracket; the split moves early, then stays."""
    rng = np.random.default_rng(45)
    n = 2000
    L, T, v0, v1 = _laws(rng, n)
    sp = InteriorSpeeds(L, T, v0, v1)
    cap = rng.uniform(10.0, 300.0, n)
    lo, hi = np.full(n, np.log(GAMMA_LO)), np.full(n, np.log(GAMMA_HI))
    reused = 0
    for _ in range(32):
        g = np.exp(0.5 * (lo + hi))
        beta = (T / g) ** 2
        last = sp._split
        got = sp(beta)
        reused += last is not None and sp._split is last
        assert np.array_equal(_bits(got), _bits(interior_speed(L, T, beta, v0, v1)))
        assert np.array_equal(_bits(got), _bits(InteriorSpeeds(L, T, v0, v1)(beta)))
        ok = got <= cap
        mid = 0.5 * (lo + hi)
        hi, lo = np.where(ok, mid, hi), np.where(ok, lo, mid)
    assert reused > 5                   # the kept split was taken again


def test_splits_that_change_and_come_back():
    rng = np.random.default_rng(8)
    n = 1500
    L, T, v0, v1 = _laws(rng, n)
    sp = InteriorSpeeds(L, T, v0, v1)
    ga = np.exp(rng.uniform(np.log(1e-4), np.log(1e6), n))
    gb = ga.copy()
    gb[::7] = GAMMA_SWITCH * 10.0 ** rng.choice([-3.0, 3.0], gb[::7].size)      # another split
    gc = np.full(n, GAMMA_SWITCH / 2)                                             # one branch
    gr = np.roll(ga, 1)                 # as many rows a branch as ga, other rows
    for g in (ga, ga, gb, ga * (1 + 1e-9), gb, gc, ga, gr, ga, ga):
        beta = (T / g) ** 2
        assert np.array_equal(_bits(sp(beta)), _bits(interior_speed(L, T, beta, v0, v1)))
    for part in (sp.take(np.arange(0, n, 3)), InteriorSpeeds.concat([sp, sp])):
        m = part.T.size
        for g in (np.resize(ga, m), np.resize(gb, m), np.resize(ga, m)):
            beta = (part.T / g) ** 2
            Lp, v0p, v1p = (np.resize(x[np.arange(0, n, 3)], m) if m < n else np.concatenate([x, x])
                            for x in (L, v0, v1))
            assert np.array_equal(_bits(part(beta)), _bits(interior_speed(Lp, part.T, beta, v0p, v1p)))
