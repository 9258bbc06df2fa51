"""Round 48 (cheb48): curves.candidates_curve screens its candidates on rough circle laws
(circle.solve_circles_rough: the preconditioned iteration stopped at a step of 1e-7 of the
scale, N a rung lower, tails to 1e-8) before solving any in full.  A candidate whose rough
law's probe is over the |a| cap by SCREEN_BAND_R (1e-3) more than the probe's own margin,
and under the speed cap by as much, is over on |a| alone on its full law too; only the
others (~11 % of the plates' candidates) are solved in full, with the layer regime the
rough solve made (each arc's own numbers).  The same candidate tables, bit for bit.

Checked here:
* the tables against the code without the screen (solve_circles_rough giving None: every
  candidate solved in full and probed, as before), bit for bit, on the bundled curve files;
  and the screen did take most candidates;
* the premise, on real candidates: the rough laws' probe values (peak speed and |a| at the
  probe's 17 points) against the full laws', within SCREEN_BAND_R / 100; and the rough laws
  against an independent reference, scipy's solve_bvp (tol 1e-10) on the boundary-value
  problem, within 1e-6 of the scale (the rough laws' own error is ~1e-8);
* a screen that takes candidates not over (SCREEN_BAND_R = -0.5) is caught by the first check.
"""
import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt.laws import circle
from test_speed29_curvesolve_retry import _bits, _curves_of     # (the curve strokes of a bundled file)
from test_speed46_cheb46_circle import _bvp_w                   # (scipy's solve_bvp, tol 1e-10)

FILES = [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_gyroid.gcode", "voron24"),
         ("prusa_concentric.gcode", "prusa-mk3s"), ("prusa_gyroid_arcs.gcode", "prusa-mk3s")]


def _tables(name, profile, monkeypatch, screen=True):
    """candidates_curve's tables, and (candidates screened, candidates solved roughly).
    Every row solved (rows that read the same numbers are made once since round 65,
    curves._distinct_curve_rows, tested in test_speed65_crv_distinct): the screen's share
    is counted over the file's candidates, as this test was written."""
    strokes, pin, rows, prof = _curves_of(name, profile)
    monkeypatch.setattr(curves, "_distinct_curve_rows", lambda *a, **k: None)
    seen = [0, 0]
    real = circle.solve_circles_rough

    def rough(*args):
        seen[1] += np.size(args[0])
        return real(*args) if screen else None
    monkeypatch.setattr(circle, "solve_circles_rough", rough)
    full = curves.solve_circles
    solved = []
    monkeypatch.setattr(curves, "solve_circles", lambda *a, **k: solved.append(np.size(a[0])) or full(*a, **k))
    got = curves.candidates_curve(pin, rows, strokes, prof)
    monkeypatch.undo()
    return got, seen[1], solved


@pytest.mark.parametrize("name,profile", FILES)
def test_screened_tables_same_bits_as_unscreened(name, profile, monkeypatch):
    want, _, solved_all = _tables(name, profile, monkeypatch, screen=False)
    got, roughly, solved = _tables(name, profile, monkeypatch)
    assert all(_bits(g, w) for g, w in zip(got, want))
    assert np.isfinite(got[2]).sum() > 20
    print(name, profile, "screened roughly", roughly, "solved in full", sum(solved), "of", sum(solved_all))
    if name == "prusa_gyroid.gcode":        # (the others' candidates are mostly within the limits)
        assert roughly > 100 and sum(solved) < 0.5 * sum(solved_all)


def test_a_screen_that_takes_good_candidates_is_caught(monkeypatch):
    want, _, _ = _tables(*FILES[0], monkeypatch, screen=False)
    monkeypatch.setattr(curves, "SCREEN_BAND_R", -0.5)
    got, _, _ = _tables(*FILES[0], monkeypatch)
    assert not all(_bits(g, w) for g, w in zip(got, want))


def _probe_values(law, R, geos, memo):
    """(peak speed, peak |a|) at the probe's points: surely_over's numbers, before its tests."""
    vmax, amax = np.empty(len(law)), np.empty(len(law))
    for sl in law.row_chunks():
        sub = law.rows(sl)
        tau = np.broadcast_to(curves._PROBE_TAU[None, :], (len(sub), curves._PROBE_TAU.size))
        phi, w, w1, _ = sub.eval_tau(tau, w2=False)
        v = curves._row_scale(w, R[sl], sub.T_t, 1)
        at = curves._row_scale(w1, R[sl], sub.T_t, 2)
        kv2 = curves._kappa_rows(geos[sl], curves._row_scale(phi, R[sl]), curves._rows_of(memo, sl)) * (v * v)
        vmax[sl] = np.max(v, axis=1)
        amax[sl] = np.sqrt(np.max(at * at + kv2 * kv2, axis=1))
    return vmax, amax


@pytest.fixture(scope="module")
def screened_calls():
    """The screen's probes on the bundled gyroid's and concentric file's candidates:
    (rough law, R, geos, memo) a call (the screen's: curves.screen_a_only, round 64, or
    surely_over on rough laws, where it falls back or before)."""
    calls, made = [], []
    mp = pytest.MonkeyPatch()
    real, real_rough, real_screen = curves.surely_over, circle.solve_circles_rough, curves.screen_a_only
    try:
        def rough(*args):
            got = real_rough(*args)
            made.append(got[0])
            return got

        def rec(law, R, geos, v_lim, a_lim, memo=None, why=None):
            if any(law is x for x in made):
                calls.append((law, R, geos, memo))
            return real(law, R, geos, v_lim, a_lim, memo, why)

        def rec_screen(law, R, geos, v_lim, a_lim, memo=None):
            with mp.context() as m:         # (its fallback's surely_over not recorded twice)
                m.setattr(curves, "surely_over", real)
                if any(law is x for x in made):
                    calls.append((law, R, geos, memo))
                return real_screen(law, R, geos, v_lim, a_lim, memo)
        mp.setattr(circle, "solve_circles_rough", rough)
        mp.setattr(curves, "surely_over", rec)
        mp.setattr(curves, "screen_a_only", rec_screen)
        for name, prof in FILES[:3]:
            strokes, pin, rows, p = _curves_of(name, prof)
            curves.candidates_curve(pin, rows, strokes, p)
    finally:
        mp.undo()
    assert sum(len(c[0]) for c in calls) > 1000
    return calls


def test_rough_probe_values_within_a_hundredth_of_the_band(screened_calls):
    worst = 0.0
    for law, R, geos, memo in screened_calls:
        full = circle.solve_circles(law.phi_total, law.T_t, law.beta_s2, law.w0, law.w1, law.R_d)
        made = np.isfinite(law.coef).all(axis=1)
        for a, b in zip(_probe_values(law, R, geos, memo), _probe_values(full, R, geos, memo)):
            rel = np.abs(a - b)[made] / np.abs(b)[made]
            worst = max(worst, float(rel.max()))
    print("rough vs full probe values: worst relative difference", worst)
    assert worst <= curves.SCREEN_BAND_R / 100


def test_rough_laws_against_solve_bvp(screened_calls):
    rng = np.random.default_rng(48)
    tau = np.linspace(0.0, 1.0, 33)
    checked = 0
    for law, _, _, _ in screened_calls[:3]:
        for i in rng.choice(len(law), 4, replace=False).tolist():
            if law.regime[i] or not np.isfinite(law.coef[i]).all():
                continue
            one = law.take(np.array([i]))
            w = one.eval_tau(tau[None, :], w2=False)[1][0]
            T = law.T_t[i]
            gam2 = T * T / law.beta_s2[i]
            u0, u1, phi = law.w0[i] * T, law.w1[i] * T, law.phi_total[i]
            ref = _bvp_w(phi, gam2, u0, u1, tau)
            scale = max(abs(phi), abs(u0), abs(u1))
            assert np.abs(w - ref).max() <= 1e-6 * scale
            checked += 1
    assert checked >= 6
