"""Round 46 (lay46): laws/circle._solve_layers_batch leaves out its starting bracket's check
(two layer residuals an arc) where _bracket_holds proves the residual negative at lo and
positive at hi, from a bound on the layer integrals (_layer_int_bound).

The bound is checked against the integrals themselves (_layer_int of _layer_d at σ = 1) on
random arcs at the bracket's ends and at random cruise values; the bracket check against the
residuals (_layers_total); and the solver against the replaced code (its bracket loop run
always, kept here verbatim) on the pipeline's arcs and random ones: the same bits."""
from pathlib import Path

import numpy as np
import pytest

from gcode_opt.laws import circle
from gcode_opt.pipeline import Options, process
from gcode_opt.profile import load_profile

S = Path(__file__).resolve().parent.parent / "sample_gcode"


def _random_arcs(seed, nb):
    """Φ, γ², u0, u1 over many decades, ends often zero or of either sign."""
    rng = np.random.default_rng(seed)
    phi = rng.uniform(-1, 1, nb) * 10.0 ** rng.uniform(-6, 3, nb)
    u0 = rng.uniform(-1, 1, nb) * 10.0 ** rng.uniform(-6, 3, nb) * rng.choice([0.0, 1.0], nb)
    u1 = rng.uniform(-1, 1, nb) * 10.0 ** rng.uniform(-6, 3, nb) * rng.choice([0.0, 1.0], nb)
    gam2 = 10.0 ** rng.uniform(-8, 6, nb)
    return phi, gam2, u0, u1


def _bracket(phi, u0, u1):
    """_solve_layers_batch's starting bracket."""
    span = np.abs(phi) + np.abs(u0) + np.abs(u1) + 1.0
    return np.minimum.reduce([phi, u0, u1]) - span, np.maximum.reduce([phi, u0, u1]) + span


def _layer_integral(u, wc, gam2):
    d0 = u - wc
    return circle._layer_int(d0, circle._layer_d(1.0, d0, wc, gam2), wc, gam2)


def test_bound_holds_and_is_close():
    """_layer_int_bound >= |∫₀¹ d| (to rounding: 1e-12 relative, and 1e-14 absolute for the
    integral's own rounding where d0 is tiny beside w_c: the bracket check's margin is 1 % of
    the span >= 1), and within 5 % of it somewhere: a bound 5 % lower fails this test."""
    phi, gam2, u0, u1 = _random_arcs(1, 200000)
    lo, hi = _bracket(phi, u0, u1)
    rng = np.random.default_rng(2)
    anywhere = u0 + rng.uniform(-1, 1, phi.size) * 10.0 ** rng.uniform(-6, 3, phi.size)
    worst = 0.0
    with np.errstate(all="ignore"):
        for u in (u0, u1):
            for wc in (lo, hi, anywhere):
                got = np.abs(_layer_integral(u, wc, gam2))
                bound = circle._layer_int_bound(u, wc, gam2, np.empty_like(u), np.empty_like(u))
                fin = np.isfinite(got)
                assert fin.mean() > 0.99
                assert (got[fin] <= bound[fin] * (1.0 + 1e-12) + 1e-14).all()
                big = fin & (bound > 1e-6)
                worst = max(worst, float(np.max(got[big] / bound[big])))
    assert worst > 0.95


def test_bracket_holds_where_certified():
    """Where _bracket_holds, the residual is < 0 at lo and > 0 at hi (so the check would
    widen nothing); it certifies most random arcs."""
    phi, gam2, u0, u1 = _random_arcs(3, 200000)
    lo, hi = _bracket(phi, u0, u1)
    ok = circle._bracket_holds(phi, gam2, u0, u1, lo, hi)
    with np.errstate(all="ignore"):
        glo, ghi = circle._layers_totals((lo, hi), phi, gam2, u0, u1)
    assert ok.mean() > 0.5
    assert (glo[ok] < 0).all() and (ghi[ok] > 0).all()


def test_degenerate_arcs():
    """NaN arcs are not certified (nor would the check widen their bracket: NaN residuals are
    not 'bad'); with these among them the solver gives the replaced code's bits."""
    phi, gam2, u0, u1 = (np.array(v, float) for v in ([1.0, np.nan, 1.0, 1.0, 0.0], [1.0, 1.0, np.inf, 1.0, 0.0],
                                                       [0.0, 0.0, 0.0, np.nan, 0.0], [0.0, 0.0, 0.0, 0.0, 0.0]))
    lo, hi = _bracket(phi, u0, u1)
    assert circle._bracket_holds(phi, gam2, u0, u1, lo, hi).tolist() == [True, False, True, False, False]
    for sl in (slice(None), slice(0, 1), slice(2, 3), slice(4, 5)):
        args = (phi[sl], gam2[sl], u0[sl], u1[sl])
        with np.errstate(all="ignore"):
            assert _bits(circle._solve_layers_batch(*args), _solve_layers_batch_ea254da(*args))


def _solve_layers_batch_ea254da(phi, gam2, u0, u1):
    """circle._solve_layers_batch at ea254da, verbatim."""
    span = np.abs(phi) + np.abs(u0) + np.abs(u1) + 1.0
    lo, hi = np.minimum.reduce([phi, u0, u1]) - span, np.maximum.reduce([phi, u0, u1]) + span
    for _ in range(60):             # make sure the bracket holds (the layer integrals are O(log))
        glo, ghi = circle._layers_totals((lo, hi), phi, gam2, u0, u1)
        bad_lo, bad_hi = glo > 0, ghi < 0
        if not (bad_lo.any() or bad_hi.any()):
            break
        lo = np.where(bad_lo, lo - 2.0 * span, lo)
        hi = np.where(bad_hi, hi + 2.0 * span, hi)
        span = np.where(bad_lo | bad_hi, 2.0 * span, span)
    wc = phi.astype(float).copy()
    wc = np.clip(wc, lo, hi)
    act = np.arange(wc.size)
    x, p_, g2, a0, a1, sp, lo_a, hi_a = (v[act] for v in (wc, phi, gam2, u0, u1, span, lo, hi))
    xp = gp = None
    for _ in range(circle._LAYERS_ITER if act.size else 0):
        if xp is None:
            h = 1e-7 * (np.abs(x) + 1e-3 * sp)
            g, gh = circle._layers_totals((x, x + h), p_, g2, a0, a1)
            dg = (gh - g) / h
        else:
            (g,) = circle._layers_totals((x,), p_, g2, a0, a1)
            dg = (g - gp) / (x - xp)
        lo_a = np.where(g < 0, x, lo_a)
        hi_a = np.where(g > 0, x, hi_a)
        new = x - g / np.where(dg > 0, dg, np.inf)
        outside = ~((new > lo_a) & (new < hi_a)) | ~np.isfinite(new)
        new = np.where(outside, 0.5 * (lo_a + hi_a), new)
        done = np.abs(new - x) <= 1e-15 * sp
        xp, gp, x = x, g, new
        if done.any():
            wc[act[done]] = x[done]
            keep = ~done
            act, x, xp, gp, p_, g2, a0, a1, sp, lo_a, hi_a = (
                v[keep] for v in (act, x, xp, gp, p_, g2, a0, a1, sp, lo_a, hi_a))
            if act.size == 0:
                return wc
    wc[act] = x
    return wc


def _bits(a, b):
    return a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.fixture(scope="module")
def layer_calls(tmp_path_factory):
    """(Φ, γ², u0, u1) of every _layer_regime call of the pipeline on the bundled gyroid."""
    got = []
    real = circle._layer_regime
    mp = pytest.MonkeyPatch()

    def rec(phi, T_t, beta_s2, w0, w1):
        got.append((phi.copy(), T_t * T_t / beta_s2, w0 * T_t, w1 * T_t))
        return real(phi, T_t, beta_s2, w0, w1)
    try:
        mp.setattr(circle, "_layer_regime", rec)
        process(str(S / "prusa_gyroid.gcode"), str(tmp_path_factory.mktemp("lay46") / "o.gcode"),
                load_profile("prusa-mk3s"), Options())
    finally:
        mp.undo()
    assert sum(c[0].size for c in got) > 400
    return got


def test_solver_same_bits_as_replaced_on_pipeline_calls(layer_calls):
    certified = 0
    for phi, gam2, u0, u1 in layer_calls:
        lo, hi = _bracket(phi, u0, u1)
        certified += bool(circle._bracket_holds(phi, gam2, u0, u1, lo, hi).all())
        with np.errstate(all="ignore"):
            assert _bits(circle._solve_layers_batch(phi, gam2, u0, u1), _solve_layers_batch_ea254da(phi, gam2, u0, u1))
    assert certified == len(layer_calls)       # the check left out on every call


def test_solver_same_bits_as_replaced_on_random_arcs():
    for seed in range(4):
        phi, gam2, u0, u1 = _random_arcs(10 + seed, 3000)
        for sl in (slice(None), slice(0, 7), slice(0, 1)):
            args = (phi[sl], gam2[sl], u0[sl], u1[sl])
            with np.errstate(all="ignore"):
                assert _bits(circle._solve_layers_batch(*args), _solve_layers_batch_ea254da(*args))
