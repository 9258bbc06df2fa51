"""The vertex-capped chain law (laws/chain.py) against an independent minimisation of J.

The oracle knows nothing of line laws or active sets: the motion has a constant
acceleration on each interval of a fine grid in s (every vertex a node; v² linear in s),
for which T, ∫ṡ²dt and ∫s̈²dt are exact per interval; SLSQP minimises J over the node
speeds under the time equality and v(s_i) <= c_i.  That restriction is an upper bound converging as h²; the
figure compared is the Richardson extrapolation of grids m and 2m per segment.

Chains: real gyroid infill (PrusaSlicer, prusa_gyroid_fullspeed*.gcode), the vertex caps
computed by the firmware junction laws (curves.vertex_cap x CAP_MARGIN).
"""
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import minimize

from gcode_opt.laws.chain import ChainProblem, solve_chain, solve_chains
from gcode_opt.laws.line import line_law

SAMPLES = Path(__file__).resolve().parent.parent / "sample_gcode"


# ------------------------------------------------------------------ the oracle
def oracle_J(s_v, c_v, S, T, beta, v0, v1, m):
    """min J over motions with a constant acceleration on each of m equal intervals per
    segment (u = v² linear in s: exact figures per interval), SLSQP on the node values u."""
    knots = np.concatenate([[0.0], s_v, [S]])
    grid = np.concatenate([np.linspace(a, b, m + 1)[:-1] for a, b in zip(knots[:-1], knots[1:])] + [[S]])
    h = np.diff(grid)
    n = grid.size
    vidx = np.arange(1, len(knots) - 1) * m - 1          # vertex nodes among the unknowns

    def parts(x):
        u = np.concatenate([[v0 * v0], x, [v1 * v1]])
        ua, ub = u[:-1], u[1:]
        p, q = np.sqrt(ua), np.sqrt(ub)
        t = 2.0 * h / (p + q)
        with np.errstate(divide="ignore", invalid="ignore"):
            dt_a = np.where(p > 0, -h / (p * (p + q) ** 2), 0.0)
            dt_b = np.where(q > 0, -h / (q * (p + q) ** 2), 0.0)
            dw_a = np.where(p > 0, 1.0 + q / (2.0 * p), 1.0)
            dw_b = np.where(q > 0, 1.0 + p / (2.0 * q), 1.0)
        D = ub - ua
        k = 1.0 / (4.0 * h * h)
        ia = k * D * D * t
        W = ua + p * q + ub
        iv = W / 3.0 * t
        f = iv + beta * ia
        fa = (dw_a / 3.0 * t + W / 3.0 * dt_a) + beta * (-2.0 * k * D * t + k * D * D * dt_a)
        fb = (dw_b / 3.0 * t + W / 3.0 * dt_b) + beta * (2.0 * k * D * t + k * D * D * dt_b)
        return t, dt_a, dt_b, f, fa, fb

    def J(x):
        _, _, _, f, fa, fb = parts(x)
        g = np.zeros(n)
        g[:-1] += fa
        g[1:] += fb
        return float(np.sum(f)), g[1:-1]

    def duration(x):
        t, dt_a, dt_b, _, _, _ = parts(x)
        g = np.zeros(n)
        g[:-1] += dt_a
        g[1:] += dt_b
        return float(np.sum(t)), g[1:-1]

    sel = np.eye(n - 2)[vidx]
    c2 = c_v * c_v
    cons = [{"type": "eq", "fun": lambda x: duration(x)[0] / T - 1.0, "jac": lambda x: duration(x)[1] / T},
            {"type": "ineq", "fun": lambda x: (c2 - x[vidx]) / c2, "jac": lambda x: -sel / c2[:, None]}]
    ur = (S / T) ** 2                      # SLSQP works on y = u / ur (order 1)
    x0 = np.full(n - 2, ur)
    x0[vidx] = np.minimum(x0[vidx], c2)
    scale = J(x0)[0]
    res = minimize(lambda y: (J(y * ur)[0] / scale, J(y * ur)[1] * ur / scale), x0 / ur, jac=True,
                   method="SLSQP", bounds=[(1e-8, None)] * (n - 2),
                   constraints=[{"type": c["type"], "fun": (lambda y, f=c["fun"]: f(y * ur)),
                                 "jac": (lambda y, g=c["jac"]: g(y * ur) * ur)} for c in cons],
                   options={"maxiter": 1000, "ftol": 1e-11})
    x = res.x * ur
    assert abs(duration(x)[0] / T - 1.0) < 1e-6
    assert np.all(x[vidx] <= c2 * (1 + 1e-6))
    return J(x)[0]


def oracle_extrapolated(s_v, c_v, S, T, beta, v0, v1, m=4):
    j1 = oracle_J(s_v, c_v, S, T, beta, v0, v1, m)
    j2 = oracle_J(s_v, c_v, S, T, beta, v0, v1, 2 * m)
    return (4.0 * j2 - j1) / 3.0, j2


def check_chain(pts, caps, v0, v1, T, beta):
    pts = np.asarray(pts, float)
    d = np.hypot(*np.diff(pts, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(d)])
    caps = np.asarray(caps, float)
    law = solve_chain(s[1:-1], caps, s[-1], T, beta, v0, v1)
    assert law.converged
    assert law.knot_t[-1] == pytest.approx(T, rel=1e-9)
    assert np.all(law.vert_v <= caps * (1 + 1e-6))
    j_law = law.J
    j_or, j_fine = oracle_extrapolated(s[1:-1], caps, s[-1], T, beta, v0, v1)
    # the fine grid is a restriction of the problem: never below the true minimum
    assert j_law <= j_fine * (1 + 1e-6)
    return j_law, j_or, law


# ------------------------------------------------------------------ fast: 4 real chains
# (vertices, caps x CAP_MARGIN, v0, v1, original duration) from prusa_gyroid_fullspeed
# (MK3S, classic jerk, 80 mm/s) and prusa_gyroid_fullspeed_klipper (scv 5, 147 mm/s)
REAL = [
    ([[123.926, 140.932], [124.362, 141.218], [124.799, 141.944], [125.236, 142.578], [125.673, 142.985],
      [126.11, 143.248], [126.983, 143.535], [127.42, 143.547]],
     [20.159, 124.685, 39.328, 38.941, 31.769, 22.678], 14.586, 14.645, 0.12519),
    ([[127.42, 143.547], [127.857, 143.262], [128.293, 142.536], [128.73, 141.901], [129.167, 141.495],
      [129.604, 141.231], [130.477, 140.944], [130.914, 140.932]],
     [20.014, 124.061, 38.986, 39.497, 31.546, 22.678], 14.645, 14.609, 0.125433),
    ([[100.084, 100.393], [98.954, 100.05], [97.787, 99.611], [96.65, 99.096], [95.55, 98.508],
      [94.491, 97.85], [93.729, 97.303]],
     [132.788, 131.985, 131.782, 132.868, 129.722], 8.899, 3.855, 0.06394),
    ([[104.018, 62.973], [104.208, 63.2], [104.645, 63.524], [105.081, 63.725], [105.955, 63.868],
      [106.392, 63.762], [106.829, 63.411], [107.124, 63.057]],
     [36.546, 41.878, 31.928, 21.428, 19.51, 43.281], 8.98, 8.868, 0.074119),
]


@pytest.mark.parametrize("k,ratio,beta_mode", [(0, 1.05, "cubic"), (2, 1.0, "cubic"), (3, 1.02, "moderate")])
def test_real_chain_matches_oracle(k, ratio, beta_mode):
    pts, caps, v0, v1, t = REAL[k]
    T = t * ratio
    # the planner's weight (gamma = T/sqrt(beta) = 0.1: inertia dominates) and one where
    # the speed term matters (gamma ~ 1 per segment)
    beta = (T / 0.1) ** 2 if beta_mode == "cubic" else (T / (len(pts) - 1)) ** 2
    j_law, j_or, _ = check_chain(pts, caps, v0, v1, T, beta)
    assert abs(j_law - j_or) <= 0.01 * j_or


def test_no_binding_cap_is_the_line_law():
    """Caps far above the law: one piece, the straight-line law itself."""
    s_v = np.array([1.0, 2.0, 3.0])
    law = solve_chain(s_v, np.full(3, 1e3), 4.0, 0.1, 0.01, 30.0, 30.0)
    ref = line_law(4.0, 0.1, 0.01, 30.0, 30.0)
    iv, ia = ref.integrals()
    assert law.binding.size == 0
    assert law.J == pytest.approx(float(iv + 0.01 * ia), rel=1e-12)


def test_every_cap_binding_gives_valleys():
    """Caps below the mean speed everywhere: every vertex binds, and each binds rightly
    (the speed has a valley there: s̈ after >= s̈ before)."""
    n = 8
    s_v = np.arange(1, n) * 0.7
    law = solve_chain(s_v, np.full(n - 1, 20.0), n * 0.7, n * 0.7 / 24.0, 1.0, 20.0, 20.0)
    assert law.binding.tolist() == list(range(n - 1))
    p = law.pieces
    from gcode_opt.laws.line import LineLaw
    lw = LineLaw(p.L, p.T, p.beta, p.v0, p.v1)
    assert np.all(lw.eval(np.zeros_like(p.T))[2][1:] >= lw.eval(p.T)[2][:-1])
    # equal segments, equal caps: the time is shared equally
    assert np.allclose(np.diff(law.knot_t), law.knot_t[-1] / n, rtol=1e-6)


# ------------------------------------------------------------------ slow: >= 20 chains from the samples
def _sample_chains(name, limit):
    from gcode_opt import curves
    from gcode_opt.detect import auto_profile
    from gcode_opt.pipeline import Options, analyse
    from gcode_opt.strokes import K_CURVE
    path = str(SAMPLES / name)
    prof = auto_profile(path).profile
    strokes, _ = analyse(path, prof, Options())
    out = []
    for st in strokes:
        if st.kind not in (K_CURVE, "chain") or min(st.v0, st.v1) < 2.0:
            continue
        g = curves.geom(st, prof)
        if not 4 <= len(g.d) <= 12:
            continue
        caps = curves.CAP_MARGIN * np.array([curves.vertex_cap(prof, st.lim, st.accel, tuple(g.u[k]),
                                                               tuple(g.u[k + 1]), g.d[k], g.d[k + 1])
                                             for k in range(len(g.d) - 1)])
        if (caps < st.v_feed).sum() >= 2:
            out.append((g.pts, caps, st.v0, st.v1, st.time_t))
    step = max(len(out) // limit, 1)
    return out[::step][:limit]


@pytest.mark.slow
def test_twenty_four_real_chains_match_oracle():
    chains = (_sample_chains("prusa_gyroid_fullspeed.gcode", 12)
              + _sample_chains("prusa_gyroid_fullspeed_klipper.gcode", 12))
    assert len(chains) >= 20
    worst = 0.0
    for i, (pts, caps, v0, v1, t) in enumerate(chains):
        ratio = (1.0, 1.05, 1.1)[i % 3]
        T = t * ratio
        beta = (T / 0.1) ** 2 if i % 2 == 0 else (T / (len(pts) - 1)) ** 2
        j_law, j_or, _ = check_chain(pts, caps, v0, v1, T, beta)
        worst = max(worst, abs(j_law - j_or) / j_or)
    assert worst <= 0.01, worst


# ------------------------------------------------------------------ warm starts and batches (issue 8)
def _synthetic_chains(n_chains, seed=7):
    """Chains of 6-20 segments of 0.4-1.0 mm, caps 15-45 mm/s, run at a mean 45 mm/s: most
    caps bind, some do not."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n_chains):
        n = int(rng.integers(6, 21))
        d = rng.uniform(0.4, 1.0, n)
        s = np.cumsum(d)
        out.append(ChainProblem(s[:-1], rng.uniform(15.0, 45.0, n - 1), s[-1], s[-1] / 45.0,
                                (s[-1] / 45.0 / 0.1) ** 2, rng.uniform(10, 30), rng.uniform(10, 30)))
    return out


def _same_law(a, b, rtol):
    assert a.converged and b.converged
    assert abs(a.J - b.J) <= rtol * abs(b.J)
    np.testing.assert_allclose(a.vert_v, b.vert_v, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(a.vert_t, b.vert_t, rtol=1e-6, atol=1e-12)


def test_a_chains_law_does_not_depend_on_its_batch():
    """Each chain is solved alone and in a batch with others (whose Newton and active-set
    steps take longer): the same law (converged chains leave the batch)."""
    probs = _synthetic_chains(12)
    together = solve_chains(probs)
    assert sum(lw.binding.size for lw in together) > 0
    for pr, lw in zip(probs, together):
        _same_law(lw, solve_chains([pr])[0], 1e-12)


def test_warm_start_from_a_nearby_duration_gives_the_cold_law():
    """The candidates are solved warm from the neighbouring duration's binding set and
    vertex times (chains._figures); the law must be the one a cold start finds, also when
    the binding set changes between the two durations."""
    probs = _synthetic_chains(12, seed=11)
    near = solve_chains(probs)
    changed = 0
    for ratio in (1.02, 1.25):
        far = [ChainProblem(p.s_v, p.c_v, p.S, p.T * ratio, p.beta * ratio ** 2, p.v0, p.v1) for p in probs]
        cold = solve_chains(far)
        warm = solve_chains(far, [lw.binding for lw in near], [lw.vert_t * ratio for lw in near])
        for w, c, n0 in zip(warm, cold, near):
            _same_law(w, c, 1e-9)
            changed += not np.array_equal(c.binding, n0.binding)
    assert changed > 0          # the check covered binding sets that move with T
