"""Issue 8, stop 18 (D8): curve candidates rejected on a probe, and w'' not computed where
it is not read.

88 % of the gyroid plate's curve candidates break the acceleration cap (the retry at
beta/4 breaks it for all of them).  curves.surely_over evaluates the law at 17 points of
the uniform grid _true_figures_rows also uses; a law over a limit there by more than
PROBE_MARGIN_R is rejected, and the full figures (quadrature + 129-point grid) are made for
the others only (curves.true_figures(..., idx)).  CircleBatch.eval_tau(..., w2=False)
skips w'' (a cube per point), which the curve planner never reads.

The candidate tables must be the same bits as 9bb98a8's, whose code is copied below."""
import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt import plan as plan_mod
from gcode_opt import schedule as sc
from gcode_opt.laws import circle
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_CURVE

S = "sample_gcode/"


# ---------------------------------------------------------------- 9bb98a8's forms
def _old_true_figures_rows(law, R, geos, tau, wq):
    m = tau.shape[1]
    tu = np.broadcast_to(curves._UNIFORM_TAU[None, :], (len(geos), curves._UNIFORM_TAU.size))
    phi, w, w1, _ = law.eval_tau(np.concatenate([tau, tu], axis=1))      # with w'' (the default)
    T = law.T_t[:, None]
    s = R[:, None] * phi
    v = R[:, None] * w / T
    at = R[:, None] * w1 / T ** 2
    kap = curves._kappa_rows(geos, s)
    v2 = v * v
    kv2 = kap * v2
    a2 = at * at + kv2 * kv2
    iv = law.T_t * np.sum(wq * v2[:, :m], axis=1)
    ia = law.T_t * np.sum(wq * a2[:, :m], axis=1)
    ia = ia + np.array([g.end_terms(a, b) for g, a, b in zip(geos, R * law.w0, R * law.w1)])
    return iv, ia, np.max(v, axis=1), np.sqrt(np.max(a2, axis=1)), np.min(v, axis=1)


def _old_true_figures(law, R, geos):
    out = np.empty((5, len(geos)))
    for sl, tau, wq in law.grid_chunks():
        out[:, sl] = _old_true_figures_rows(law.rows(sl), R[sl], geos[sl], tau, wq)
    return tuple(out)


def _old_candidates_curve(pin, rows, strokes, profile):
    rows = np.asarray(rows, int)
    k = len(curves.CURVE_COLS)
    geos = [g for i in rows for g in [curves.geom(strokes[i], profile)] * k]
    S_, v0, v1, vc, ac = (np.repeat(x[rows], k) for x in (pin.L, pin.v0, pin.v1, pin.v_cap, pin.a_cap))

    def solve_figures(idx, T, beta):
        gs = [geos[q] for q in idx]
        law, R = curves._solve(None, gs, S_[idx], T, beta, v0[idx], v1[idx])
        iv, ia, pv, pa, mv = _old_true_figures(law, R, gs)
        ok = ((pv <= vc[idx] * (1 + plan_mod.SPEED_TOL_R)) & (pa <= ac[idx] * (1 + plan_mod.SPEED_TOL_R))
              & (mv >= -1e-9 * (1 + vc[idx])))
        return iv, ia, ok

    return plan_mod.candidate_table(pin, rows, curves.CURVE_COLS, solve_figures, curves.GAMMA_MIN)


# ---------------------------------------------------------------- real curve strokes
_CACHE = {}


def _curves_of(name, profile):
    key = (name, profile)
    if key not in _CACHE:
        prof = load_profile(profile)
        opts = Options()
        strokes, _ = analyse(S + name, prof, opts)
        pin = sc.plan_inputs(strokes, prof, opts)
        rows = np.array([i for i in sc._rows_by_kind(strokes)[K_CURVE] if not pin.fault[i]], int)
        _CACHE[key] = (strokes, pin, rows, prof)
    return _CACHE[key]


def _bits(a, b):
    return np.asarray(a).tobytes() == np.asarray(b).tobytes()


FILES = [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_gyroid.gcode", "voron24"),
         ("prusa_gyroid_fullspeed.gcode", "prusa-mk3s"), ("prusa_concentric.gcode", "prusa-mk3s")]


@pytest.mark.parametrize("name,profile", FILES)
def test_curve_candidates_same_bits(name, profile, monkeypatch):
    strokes, pin, rows, prof = _curves_of(name, profile)
    assert rows.size > 20
    seen = []
    probe = curves.surely_over
    monkeypatch.setattr(curves, "surely_over", lambda *a: seen.append(probe(*a)) or seen[-1])
    got = curves.candidates_curve(pin, rows, strokes, prof)
    want = _old_candidates_curve(pin, rows, strokes, prof)
    for g, w in zip(got, want):
        assert g.shape == w.shape and _bits(g, w)
    assert seen and sum(int(o.sum()) for o in seen) > 0          # the probe did reject laws


def test_a_probe_that_rejects_good_laws_is_caught(monkeypatch):
    """The comparison above fails for a probe that rejects laws the full figures accept
    (the mutant: a margin of -50 %)."""
    strokes, pin, rows, prof = _curves_of(*FILES[0])
    want = _old_candidates_curve(pin, rows, strokes, prof)
    monkeypatch.setattr(curves, "PROBE_MARGIN_R", -0.5)
    got = curves.candidates_curve(pin, rows, strokes, prof)
    assert not all(_bits(g, w) for g, w in zip(got, want))


def _laws(name, profile, beta_r=1.0):
    """The first solve of candidate_table on a file's curves: (law, R, geos, v_lim, a_lim)."""
    strokes, pin, rows, prof = _curves_of(name, profile)
    k = len(curves.CURVE_COLS)
    geos = [g for i in rows for g in [curves.geom(strokes[i], prof)] * k]
    S_, v0, v1, vc, ac = (np.repeat(x[rows], k) for x in (pin.L, pin.v0, pin.v1, pin.v_cap, pin.a_cap))
    T = (pin.T_orig[rows, None] * plan_mod.T_RATIOS[None, curves.CURVE_COLS]).ravel()
    beta = beta_r * np.minimum(plan_mod._largest_beta_under_speed_cap(S_, T, v0, v1, vc),
                               (T / curves.GAMMA_MIN) ** 2)
    law, R = curves._solve(None, geos, S_, T, beta, v0, v1)
    tol = 1 + plan_mod.SPEED_TOL_R
    return law, R, geos, vc * tol, ac * tol


@pytest.mark.parametrize("beta_r", [1.0, 0.25])
def test_probe_rejects_only_what_the_full_figures_reject(beta_r):
    for name, profile in FILES[:3]:
        law, R, geos, v_lim, a_lim = _laws(name, profile, beta_r)
        over = curves.surely_over(law, R, geos, v_lim, a_lim)
        iv, ia, pv, pa, mv = _old_true_figures(law, R, geos)
        full_bad = ~((pv <= v_lim) & (pa <= a_lim))
        assert not (over & ~full_bad).any()
        # and its speeds and accelerations are the full grid's at its points, to rounding
        assert over.sum() > 0.5 * full_bad.sum()


def test_true_figures_of_some_rows_same_bits():
    law, R, geos, _, _ = _laws(*FILES[2])
    assert len(geos) > circle.EVAL_CHUNK + 100                 # more than one chunk
    full = _old_true_figures(law, R, geos)
    rng = np.random.default_rng(3)
    for idx in (np.arange(0), np.array([0]), np.sort(rng.choice(len(geos), circle.EVAL_CHUNK + 90, replace=False)),
                np.arange(len(geos))):
        got = curves.true_figures(law, R, geos, idx)
        rest = np.setdiff1d(np.arange(len(geos)), idx)
        for g, f in zip(got, full):
            assert _bits(g[idx], f[idx])
            assert np.isnan(g[rest]).all()
    for g, f in zip(curves.true_figures(law, R, geos), full):
        assert _bits(g, f)


def test_take_is_the_rows_batch():
    law, R, geos, _, _ = _laws(*FILES[0])
    idx = np.array([5, 2, 40])
    sub = law.take(idx)
    tau = np.broadcast_to(np.linspace(0.0, 1.0, 33)[None, :], (3, 33))
    for i, row in enumerate(idx.tolist()):
        one = law.rows(slice(row, row + 1)).eval_tau(tau[:1])
        for a, b in zip(sub.eval_tau(tau)[:3], one[:3]):
            assert _bits(a[i], b[0])


def _arcs(seed, nb, steep):
    rng = np.random.default_rng(seed)
    phi = rng.uniform(0.05, 3.0, nb) * rng.choice([1.0, -1.0], nb)
    gam2 = 10.0 ** rng.uniform(-3, 7.0, nb)           # the layers regime from ~1e4 up
    u0 = phi * rng.uniform(0.0, 6.0 if steep else 2.0, nb)
    u1 = phi * rng.uniform(0.0, 6.0 if steep else 2.0, nb)
    T = np.full(nb, 0.1)
    return circle.solve_circles(phi, T, T * T / gam2, u0 / T, u1 / T, 2.0)


@pytest.mark.parametrize("seed,steep", [(0, False), (1, True)])
def test_eval_tau_without_w2_same_bits(seed, steep):
    batch = _arcs(seed, 200, steep)
    assert batch.regime.any() and (~batch.regime).any()       # both regimes
    tau = np.broadcast_to(np.linspace(0.0, 1.0, 57)[None, :], (len(batch), 57))
    full = batch.eval_tau(tau)
    part = batch.eval_tau(tau, w2=False)
    assert part[3] is None and full[3] is not None
    for a, b in zip(part[:3], full[:3]):
        assert _bits(a, b)
