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
from gcode_opt.laws.line import InteriorSpeeds, interior_speed
from gcode_opt.pipeline import Options, analyse
from gcode_opt.plan import T_RATIOS, PlanInput
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_LINE

S = "sample_gcode/"
PLATE = os.path.expanduser("~/.cache/gcode-opt-corpus/plate_rectilinear.gcode")


# 479aedb's candidates (kept verbatim there) and the bitwise comparison
from test_speed22_budget_candidates import _bits, _same, candidates_ref  # noqa: E402


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
