"""Line candidates made only where a law can be within limits (budget, s22): plan.
_candidates_auto skips the candidates shorter than t_seg_min (no law, whatever beta) and
bisects with laws/line.InteriorSpeeds (what does not depend on beta made once).  Which
candidates are feasible, and every feasible entry's T, beta, I and KE, must be the start
commit's (479aedb) bits, whose _candidates_auto and _largest_beta_under_speed_cap are kept
verbatim below as the reference (they call interior_speed, end_speeds, line_law and
_feasible, which this change leaves as they were); the infeasible entries keep T, and
beta / I stay non-NaN / inf as there.  Real inputs: the line strokes of bundled samples
under three profiles; random and odd inputs; inputs on which the reference raises."""
import numpy as np
import pytest

from gcode_opt import plan as plan_mod
from gcode_opt import schedule as sc
from gcode_opt.laws.line import InteriorSpeeds, end_speeds, interior_speed, line_law
from gcode_opt.pipeline import Options, analyse
from gcode_opt.plan import GAMMA_HI, GAMMA_LO, SPEED_TOL_R, T_RATIOS, PlanInput, _feasible
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_LINE

S = "sample_gcode/"


# ---------------------------------------------------------------- 479aedb, verbatim
def _largest_beta_under_speed_cap(L, T, v0, v1, v_cap, iters=32):
    L, T, v0, v1, v_cap = np.broadcast_arrays(*(np.asarray(a, float) for a in (L, T, v0, v1, v_cap)))
    lo = np.full(L.shape, np.log(GAMMA_LO))
    hi = np.full_like(lo, np.log(GAMMA_HI))
    cap = v_cap * (1 + SPEED_TOL_R)
    v_end = np.maximum(*end_speeds(L, T, v0, v1))
    cubic_ok = np.maximum(v_end, interior_speed(L, T, np.inf, v0, v1)) <= cap
    with np.errstate(all="ignore"):
        skip = cubic_ok & ((T / (2.0 * GAMMA_HI)) ** 2 > 0.0)
    if skip.any():
        gamma = np.full(L.shape, np.inf)
        b = ~skip
        if b.any():
            gamma[b] = np.exp(_bisect_log_gamma(L[b], T[b], v0[b], v1[b], cap[b], v_end[b], lo[b], hi[b], iters))
    else:
        gamma = np.exp(_bisect_log_gamma(L, T, v0, v1, cap, v_end, lo, hi, iters))
    return np.where(cubic_ok, np.inf, (T / gamma) ** 2)


def _bisect_log_gamma(L, T, v0, v1, cap, v_end, lo, hi, iters):
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        g = np.exp(mid)
        ok = np.maximum(v_end, interior_speed(L, T, (T / g) ** 2, v0, v1)) <= cap
        hi = np.where(ok, mid, hi)
        lo = np.where(ok, lo, mid)
    return hi


def _candidates_auto_ref(p):
    T = p.T_orig[:, None] * T_RATIOS[None, :]
    L, v0, v1 = p.L[:, None], p.v0[:, None], p.v1[:, None]
    v_cap, a_cap = p.v_cap[:, None], p.a_cap[:, None]
    beta = _largest_beta_under_speed_cap(L, T, v0, v1, v_cap)
    law = line_law(L, T, beta, v0, v1)
    ok = _feasible(law, v_cap, a_cap) & (T >= p.t_seg_min[:, None])
    KE, I = law.integrals()
    return T, beta, np.where(ok, I, np.inf), KE


def candidates_ref(p, chunk=plan_mod.CANDIDATE_CHUNK):
    n = len(p.L)
    if n <= chunk:
        return _candidates_auto_ref(p)
    out = [np.empty((n, len(T_RATIOS))) for _ in range(4)]
    for a in range(0, n, chunk):
        rows = np.arange(a, min(a + chunk, n))
        for o, piece in zip(out, _candidates_auto_ref(p.take(rows))):
            o[rows] = piece
    return tuple(out)


# ---------------------------------------------------------------- comparison
def _bits(x):
    return np.ascontiguousarray(x, float).view(np.int64)


def _same(want, got):
    """Feasible entries (finite I) and their four figures the same bits; T everywhere;
    beta's and I's NaNs where the reference has them (Candidates.piece reads those)."""
    assert all(a.shape == b.shape for a, b in zip(want, got))
    fw, fg = np.isfinite(want[2]), np.isfinite(got[2])
    assert np.array_equal(fw, fg)
    for a, b in zip(want, got):
        assert np.array_equal(_bits(a[fw]), _bits(b[fw]))
    assert np.array_equal(_bits(want[0]), _bits(got[0]))
    for k in (1, 2):
        assert np.array_equal(np.isnan(want[k]), np.isnan(got[k]))
    return int(fw.sum())


def _line_pin(path, profile):
    prof = load_profile(profile)
    opts = Options()
    strokes, _ = analyse(path, prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    rows = np.array([i for i in sc._rows_by_kind(strokes)[K_LINE] if not pin.fault[i]], int)
    return pin.take(rows)


@pytest.mark.parametrize("name,profile", [("prusa_gyroid.gcode", "prusa-mk3s"),
                                          ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"),
                                          ("prusa_benchy_like.gcode", "voron24"),
                                          ("prusa_klipper.gcode", "voron24"),
                                          ("cura_box.gcode", "prusa-mk3s")])
def test_real_line_candidates_same_bits(name, profile):
    p = _line_pin(S + name, profile)
    assert len(p.L) > 50
    n_feasible = _same(candidates_ref(p), plan_mod.candidates_auto(p))
    assert n_feasible > 0
    # in small chunks too (other batches for the adaptive series of the law's coefficients)
    _same(candidates_ref(p, chunk=97), plan_mod.candidates_auto(p, chunk=97))
    # and the sparse pieces the allocation keeps are the same
    for got_p, want_p in zip(plan_mod.Candidates.piece(np.arange(len(p.L)), plan_mod.candidates_auto(p), p.T_orig),
                             plan_mod.Candidates.piece(np.arange(len(p.L)), candidates_ref(p), p.T_orig)):
        assert np.array_equal(np.asarray(got_p).view(np.uint8), np.asarray(want_p).view(np.uint8))


def _random_inputs(n, seed):
    rng = np.random.default_rng(seed)
    L = rng.uniform(0.05, 80.0, n)
    T = L / rng.uniform(5.0, 300.0, n)
    v0 = rng.uniform(0.0, 150.0, n) * (rng.random(n) < 0.8)
    v1 = rng.uniform(0.0, 150.0, n) * (rng.random(n) < 0.8)
    v_cap = np.maximum(np.maximum(v0, v1), L / T) * rng.uniform(0.9, 1.8, n)
    a_cap = rng.uniform(200.0, 20000.0, n)
    t_seg = rng.uniform(0.0, 0.05, n)
    return PlanInput(L, v0, v1, v_cap, a_cap, T, np.ones(n), np.ones(n), t_seg)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_candidates_same_bits(seed):
    p = _random_inputs(3000, seed)
    assert _same(candidates_ref(p), plan_mod.candidates_auto(p)) > 100


def test_odd_inputs_same_bits_or_same_error():
    p = _random_inputs(300, 7)
    for f, k, x in (("v_cap", 3, np.nan), ("a_cap", 4, np.nan), ("t_seg_min", 5, np.nan), ("v_cap", 6, np.inf),
                    ("t_seg_min", 8, np.inf), ("v0", 9, 1e9), ("t_seg_min", 10, -1.0)):
        getattr(p, f)[k] = x
    _same(candidates_ref(p), plan_mod.candidates_auto(p))
    # what the reference raises on, the new raises on (it takes the reference's path)
    for f, x in (("T_orig", 0.0), ("T_orig", np.nan), ("L", np.inf), ("v1", np.nan), ("T_orig", 1e-302)):
        q = _random_inputs(50, 8)
        getattr(q, f)[11] = x
        if f == "T_orig" and x == 1e-302:
            q.L[11], q.v0[11], q.v1[11] = 1e-300, 1e-300, 1e-300
        try:
            want = candidates_ref(q)
        except ValueError:
            with pytest.raises(ValueError):
                plan_mod.candidates_auto(q)
            continue
        _same(want, plan_mod.candidates_auto(q))
    empty = _random_inputs(0, 0)
    assert all(a.shape == (0, len(T_RATIOS)) for a in plan_mod.candidates_auto(empty))


def test_interior_speeds_is_interior_speed():
    rng = np.random.default_rng(5)
    n = 20000
    L = rng.uniform(0.01, 100.0, n)
    T = L / rng.uniform(2.0, 400.0, n)
    v0 = rng.uniform(0.0, 250.0, n) * (rng.random(n) < 0.8)
    v1 = rng.uniform(0.0, 250.0, n) * (rng.random(n) < 0.7)
    gamma = np.exp(rng.uniform(np.log(1e-4), np.log(1e6), n))
    gamma[:20] = 4.0 * (1 + np.linspace(-1e-12, 1e-12, 20))
    beta = (T / gamma) ** 2
    beta[20:40] = np.inf
    # A = 0 and delta = 0 (-delta/A is NaN: the centre), A = 0 alone (+-inf), |r| >= 1
    v0[40:60] = v1[40:60] = L[40:60] / T[40:60]
    L[60:80] = T[60:80] * (v0[60:80] + v1[60:80]) / 2
    v0[80:100], v1[80:100] = 0.0, 3 * L[80:100] / T[80:100]
    gamma[80:90], beta[80:90] = 50.0, (T[80:90] / 50.0) ** 2
    sp = InteriorSpeeds(L, T, v0, v1)
    assert np.array_equal(_bits(sp(beta)), _bits(interior_speed(L, T, beta, v0, v1)))
    for sel in (gamma < 4.0, gamma >= 4.0, np.arange(n) % 3 == 0):      # one branch, both
        b = np.flatnonzero(sel)
        assert np.array_equal(_bits(sp.take(b)(beta[b])), _bits(interior_speed(L[b], T[b], beta[b], v0[b], v1[b])))
    with pytest.raises(ValueError):
        InteriorSpeeds(L[:2], np.array([1.0, 0.0]), v0[:2], v1[:2])
