"""Line candidates (s24, lineplan): plan._candidates_auto leaves out the entries whose
length no motion within the caps can cover (plan.out_of_reach), and candidates_auto
bisects every chunk's entries at once (plan._beta_bisect).  Which candidates are feasible,
and every feasible entry's T, beta, I and KE, must be the bits of 479aedb's
_candidates_auto (kept verbatim below, as in test_speed22_budget_candidates.py: it calls
interior_speed, end_speeds, line_law and _feasible, which this change leaves alone), chunk
by chunk; infeasible entries keep T and beta / I stay non-NaN / inf as there.  Real inputs
(bundled samples, and a slice of the rectilinear plate when the corpus is there), and
random inputs placed on both sides of out_of_reach's bound."""
import os

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
PLATE = os.path.expanduser("~/.cache/gcode-opt-corpus/plate_rectilinear.gcode")


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


def _unreached(p):
    """How many live entries (T >= t_seg_min) out_of_reach leaves out."""
    T = p.T_orig[:, None] * T_RATIOS[None, :]
    r, c = np.nonzero(T >= p.t_seg_min[:, None])
    return int(plan_mod.out_of_reach(p.L[r], T[r, c], p.v0[r], p.v1[r], p.v_cap[r], p.a_cap[r]).sum())


def _line_pin(path, profile):
    prof = load_profile(profile)
    opts = Options()
    strokes, _ = analyse(path, prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    rows = np.array([i for i in sc._rows_by_kind(strokes)[K_LINE] if not pin.fault[i]], int)
    return pin.take(rows)


@pytest.mark.parametrize("name,profile", [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"),
                                          ("prusa_gyroid.gcode", "prusa-mk3s"),
                                          ("prusa_klipper.gcode", "voron24"),
                                          ("cura_box.gcode", "prusa-mk3s")])
def test_real_line_candidates_same_bits(name, profile):
    p = _line_pin(S + name, profile)
    assert len(p.L) > 50
    # the entries left out are compared too: they must be the reference's infeasible ones
    assert _unreached(p) > 0
    for chunk in (plan_mod.CANDIDATE_CHUNK, 97, 13):     # one piece; bisections of many chunks at once
        assert _same(candidates_ref(p, chunk), plan_mod.candidates_auto(p, chunk)) > 0


@pytest.mark.skipif(not os.path.exists(PLATE), reason="corpus not downloaded")
def test_rectilinear_plate_slice_same_bits():
    """Three default chunks of the plate's line strokes (a fifth of them), where a quarter
    of the live entries are out of reach."""
    p = _line_pin(PLATE, "prusa-mk3s")
    p = p.take(np.arange(3 * plan_mod.CANDIDATE_CHUNK + 500))
    assert _unreached(p) > 5000
    assert _same(candidates_ref(p), plan_mod.candidates_auto(p)) > 10000


def _reach_d(T, v0, v1, v_top, a_top):
    """The farthest a motion from v0 to v1 in T goes with v <= v_top, |a| <= a_top (scalars)."""
    up, down = (v_top - v0) / a_top, (v_top - v1) / a_top
    if up + down <= T:
        return v_top * T - (v_top - v0) ** 2 / (2 * a_top) - (v_top - v1) ** 2 / (2 * a_top)
    vp = (a_top * T + v0 + v1) / 2
    return (vp * vp - v0 * v0) / (2 * a_top) + (vp * vp - v1 * v1) / (2 * a_top)


@pytest.mark.parametrize("seed", [0, 1])
def test_random_inputs_around_the_bound(seed):
    """Strokes whose lengths sit around the reach of their caps at T_orig x T_RATIOS (from
    well inside to 2 % beyond), so that the bound decides near its margin; the same bits
    as the reference, and what is left out is infeasible there."""
    rng = np.random.default_rng(seed)
    n = 1500
    v_cap = rng.uniform(20.0, 250.0, n)
    a_cap = rng.uniform(300.0, 8000.0, n)
    v0 = v_cap * rng.uniform(0.0, 1.0, n) * (rng.random(n) < 0.8)
    v1 = v_cap * rng.uniform(0.0, 1.0, n) * (rng.random(n) < 0.8)
    T = rng.uniform(0.01, 0.5, n)
    col = rng.integers(0, len(T_RATIOS), n)
    Tc = T * T_RATIOS[col]
    ok = np.abs(v1 - v0) <= a_cap * Tc
    reach = np.array([_reach_d(t, a, b, vc, ac) for t, a, b, vc, ac in zip(Tc, v0, v1, v_cap, a_cap)])
    L = np.where(ok, reach, v_cap * Tc * 0.5) * rng.choice([0.9, 0.999, 1.0, 1.0000005, 1.000002, 1.001, 1.02], n)
    p = PlanInput(L, v0, v1, v_cap, a_cap, T, np.ones(n), np.ones(n), np.zeros(n))
    assert _unreached(p) > 1000
    want = candidates_ref(p, 256)
    got = plan_mod.candidates_auto(p, 256)
    assert _same(want, got) > 1000
    # every entry the bound leaves out is the reference's infeasible
    Tt = p.T_orig[:, None] * T_RATIOS[None, :]
    out = plan_mod.out_of_reach(p.L[:, None], Tt, p.v0[:, None], p.v1[:, None], p.v_cap[:, None], p.a_cap[:, None])
    assert out.sum() > 1000 and not np.isfinite(want[2][out]).any()
    # and at the stroke's own column, a length just beyond its reach (x 1.001) is out
    far = ok & (L >= reach * 1.001)
    assert far.sum() > 50 and out[np.flatnonzero(far), col[far]].all()


def test_out_of_reach_is_false_where_the_bound_does_not_apply():
    L, T = np.array([10.0] * 6), np.array([0.01] * 6)
    v0 = np.array([0.0, 300.0, -1.0, 0.0, np.nan, 0.0])
    v1 = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    v_cap = np.array([100.0, 100.0, 100.0, np.nan, 100.0, np.inf])
    a_cap = np.full(6, 1000.0)
    # only the first has a bound to go by (10 mm in 10 ms at <= 100 mm/s: out of reach)
    assert plan_mod.out_of_reach(L, T, v0, v1, v_cap, a_cap).tolist() == [True] + [False] * 5


def test_interior_speeds_concat_and_take():
    rng = np.random.default_rng(3)
    n = 3000
    L = rng.uniform(0.01, 100.0, n)
    T = L / rng.uniform(2.0, 400.0, n)
    v0 = rng.uniform(0.0, 250.0, n) * (rng.random(n) < 0.8)
    v1 = rng.uniform(0.0, 250.0, n) * (rng.random(n) < 0.7)
    beta = (T / np.exp(rng.uniform(np.log(1e-4), np.log(1e6), n))) ** 2     # both branches, mixed
    beta[:30] = np.inf
    parts = [InteriorSpeeds(L[a:a + 700], T[a:a + 700], v0[a:a + 700], v1[a:a + 700]) for a in range(0, n, 700)]
    sp = InteriorSpeeds.concat(parts)
    assert np.array_equal(_bits(sp(beta)), _bits(interior_speed(L, T, beta, v0, v1)))
    b = np.flatnonzero(rng.random(n) < 0.4)
    assert np.array_equal(_bits(sp.take(b)(beta[b])), _bits(interior_speed(L[b], T[b], beta[b], v0[b], v1[b])))


def test_cubic_interior_speeds_same_bits():
    """InteriorSpeeds.cubic() is interior_speed at beta = inf (the reference: the general
    function, untouched): ordinary laws, A = 0 with delta = 0 (-delta/A NaN), A = 0 alone
    (+-inf), a speed through 0 (|r| >= 1 cannot occur at gamma = 0, r is +-0 or NaN)."""
    rng = np.random.default_rng(9)
    n = 50000
    L = rng.uniform(0.01, 100.0, n)
    T = L / rng.uniform(2.0, 400.0, n)
    v0 = rng.uniform(0.0, 250.0, n) * (rng.random(n) < 0.8)
    v1 = rng.uniform(0.0, 250.0, n) * (rng.random(n) < 0.7)
    v0[40:60] = v1[40:60] = L[40:60] / T[40:60]
    L[60:80] = T[60:80] * (v0[60:80] + v1[60:80]) / 2          # A = 0 exactly
    v0[80:100], v1[80:100] = 0.0, 3 * L[80:100] / T[80:100]
    want = interior_speed(L, T, np.inf, v0, v1)
    sp = InteriorSpeeds(L, T, v0, v1)
    assert np.array_equal(_bits(sp.cubic()), _bits(want))
    assert np.array_equal(_bits(sp.cubic()), _bits(sp(np.full(n, np.inf))))
    b = np.flatnonzero(rng.random(n) < 0.3)
    assert np.array_equal(_bits(sp.take(b).cubic()), _bits(want[b]))
