"""Round 46 (cheb46): the circle law's preconditioned iteration (laws/circle.py _precond_cheb)
runs whole in the compiled core (_curvecore.c pc_solve, one pass over each arc's row), its three
matrix products sums in the order of k (circle._mm_ordered; the numpy fallback the same
operations) instead of BLAS calls of 32-row blocks.  The fixed point is the same collocation
solution; only the rounding of the products moves, so the laws move at rounding level.

Checked here:
* against the code it replaced (_precond_cheb_np_0b09fc6 below, verbatim: the same iteration
  with _rows_matmul's BLAS products): the same arcs converge, their node values agree to
  1e-13 of the arc's scale (at most 2 % of arcs, stalling right at the rounding floor, are
  left to Newton by one form and not the other; both stop at the rounding floor of the residual, ~1e-16 relative
  times the conditioning of the collocation system, ~1e2 at N = 20..32);
* against independent references: scipy.integrate.solve_bvp on the boundary-value problem
  w'' = γ²w + 2w³ + C, w(0) = u0, w(1) = u1, ∫w = Φ (C a free parameter; tol 1e-10, so
  agreement to 1e-7 of the scale), and Newton on the collocation equations at N = 64 (LU
  solves, not the preconditioned iteration; agreement to 1e-11 of the scale, the solver's
  _TAIL_TOL) -- on real curve rows of the bundled gyroid sample and on random (Φ, γ, u0, u1);
* the compiled form and the numpy fallback give the same bits (AVX and scalar).

The layer regime's cruise value (_solve_layers_batch) takes secant steps after its first one:
checked to be a bracketed root of the residual (evaluated directly), and against the Newton
steps it replaced (verbatim below): the same roots to 1e-13 of the span, the same regime
decisions, fewer residuals."""
import numpy as np
import pytest
from scipy.integrate import solve_bvp

from gcode_opt.laws import circle
from gcode_opt.laws.circle import (_PRECOND_FLOOR, _PRECOND_ITER, _PRECOND_SLOW_R, _PRECOND_TOL, _cheb_setup,
                                   _eig_setup, _rows_matmul, solve_circles)
from gcode_opt.pipeline import Options, process
from gcode_opt.profile import load_profile
from pathlib import Path

S = Path(__file__).resolve().parent.parent / "sample_gcode"
CORE = circle.CORE_MOD


def _precond_cheb_np_0b09fc6(n, phi, gam2, u0, u1, w_start):
    """circle._precond_cheb_np at 0b09fc6, verbatim (its products _rows_matmul's BLAS calls)."""
    cs = _cheb_setup(n)
    eg = _eig_setup(n)
    nb = phi.size
    w = w_start.copy()
    w[:, 0], w[:, -1] = u0, u1
    cc = np.zeros(nb)
    ok = np.zeros(nb, dtype=bool)
    if eg is None or nb == 0:
        return w, cc, ok
    # row-wise products only (_rows_matmul, sums along rows): an arc's iteration is its own,
    # bit for bit, whatever the batch
    d2_t = np.ascontiguousarray(cs["d2"][1:-1].T)
    q, lam_e, qv, e = cs["q"], eg["lam"], eg["qv"], eg["e"]
    scale = np.maximum.reduce([np.abs(phi), np.abs(u0), np.abs(u1), np.full(nb, 1e-300)])
    act = np.arange(nb)
    last = np.full(nb, np.inf)
    for it in range(_PRECOND_ITER):
        wa, ca = w[act], cc[act]
        wi = wa[:, 1:-1]
        g2 = gam2[act]
        w2 = wi * wi
        r1 = _rows_matmul(wa, d2_t) - g2[:, None] * wi - 2.0 * wi * w2 - ca[:, None]
        r2 = (wa * q).sum(axis=1) - phi[act]
        den = lam_e[None, :] - (g2 + 3.0 * (w2.max(axis=1) + w2.min(axis=1)))[:, None]
        b = -_rows_matmul(r1, eg["vinv_t"])
        dc = (-r2 - ((b / den) * qv).sum(axis=1)) / ((qv * e) / den).sum(axis=1)
        dw = _rows_matmul((b + dc[:, None] * e) / den, eg["v_t"])
        w[act, 1:-1] = wi + dw
        cc[act] = ca + dc
        step = np.abs(dw).max(axis=1)
        # done: at the rounding floor of the residual (steps no longer shrink), or below it
        slow = (it >= 4) & ~(step < _PRECOND_SLOW_R * last[act])
        done = (step <= _PRECOND_TOL * scale[act]) | (slow & (step <= _PRECOND_FLOOR * scale[act]))
        ok[act[done]] = True
        keep = ~done & np.isfinite(step) & ~slow
        last[act] = step
        act = act[keep]
        if act.size == 0:
            break
    return w, cc, ok


def _bits(a, b):
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


@pytest.fixture(scope="module")
def curve_rows(tmp_path_factory):
    """(Φ, γ², u0, u1) of every arc the curve planner solves on the bundled gyroid sample."""
    rows = []
    real, real_rough = circle.solve_circles, circle.solve_circles_rough
    mp = pytest.MonkeyPatch()

    def put(phi_total, T, beta, w0=0.0, w1=0.0):
        phi, T_t, beta_s2, w0_, w1_ = (np.broadcast_arrays(*(np.atleast_1d(np.asarray(v, float))
                                                             for v in (phi_total, T, beta, w0, w1))))
        rows.append((phi.copy(), T_t * T_t / beta_s2, w0_ * T_t, w1_ * T_t))

    def rec(phi_total, T, beta, w0=0.0, w1=0.0, R=1.0, layers=None):
        put(phi_total, T, beta, w0, w1)
        return real(phi_total, T, beta, w0, w1, R, layers)

    def rec_rough(phi_total, T, beta, w0=0.0, w1=0.0, R=1.0):     # (round 48: every candidate's screen)
        put(phi_total, T, beta, w0, w1)
        return real_rough(phi_total, T, beta, w0, w1, R)
    from gcode_opt import curves
    try:
        mp.setattr(curves, "solve_circles", rec)
        mp.setattr(circle, "solve_circles_rough", rec_rough)
        process(str(S / "prusa_gyroid.gcode"), str(tmp_path_factory.mktemp("c46") / "o.gcode"),
                load_profile("prusa-mk3s"), Options())
    finally:
        mp.undo()
    phi, gam2, u0, u1 = (np.concatenate([r[i] for r in rows]) for i in range(4))
    assert phi.size > 400
    return phi, gam2, u0, u1


def _random_rows(seed, nb):
    rng = np.random.default_rng(seed)
    phi = rng.uniform(0.05, 3.0, nb) * rng.choice([1.0, 1.0, -1.0, 4.0], nb)
    gam2 = np.exp(rng.uniform(np.log(0.01), np.log(60.0), nb))
    u0 = phi * rng.uniform(0.0, 1.6, nb)
    u1 = phi * rng.uniform(0.0, 1.6, nb)
    return phi, gam2, u0, u1


def _scale(phi, u0, u1):
    return np.maximum.reduce([np.abs(phi), np.abs(u0), np.abs(u1)])


def _against_replaced(n, phi, gam2, u0, u1):
    w0 = np.repeat(phi[:, None], n + 1, axis=1)
    new = circle._precond_cheb(n, phi, gam2, u0, u1, w0)
    old = _precond_cheb_np_0b09fc6(n, phi, gam2, u0, u1, w0)
    # (an arc whose steps stall right at the rounding floor may be left to Newton by one and
    # not the other: the floor tests compare rounding-level steps)
    assert (new[2] != old[2]).mean() <= 0.02
    ok = new[2] & old[2]
    sc = _scale(phi, u0, u1)[ok]
    assert ok.mean() > 0.9
    assert (np.abs(new[0][ok] - old[0][ok]).max(axis=1) <= 2e-14 * sc).all()
    assert (np.abs(new[1][ok] - old[1][ok]) <= 1e-12 * sc * (1.0 + gam2[ok] + sc * sc)).all()
    return new


def test_same_fixed_point_as_the_replaced_code_on_real_rows(curve_rows):
    phi, gam2, u0, u1 = curve_rows
    for n in (16, 20, 24, 32):
        _against_replaced(n, phi, gam2, u0, u1)


def test_same_fixed_point_as_the_replaced_code_on_random_rows():
    for n in (16, 20, 24, 32, 48):
        _against_replaced(n, *_random_rows(46 + n, 300))


def test_compiled_and_numpy_same_bits(curve_rows):
    if CORE is None:
        pytest.skip("no compiled curve core")
    phi, gam2, u0, u1 = curve_rows
    rp = _random_rows(7, 200)
    rp[0][3], rp[1][5], rp[2][7], rp[3][9] = 0.0, np.nan, np.inf, np.nan     # degenerate rows
    for args in ((phi[:400], gam2[:400], u0[:400], u1[:400]), rp):
        for n in (16, 20, 23, 24, 32, 64):
            w0 = np.repeat(np.nan_to_num(args[0])[:, None], n + 1, axis=1)
            with np.errstate(all="ignore"):
                want = circle._precond_cheb_np(n, *args, w0)
                for flag in (1, 0):
                    CORE.simd(flag)
                    try:
                        got = circle._precond_cheb_c(n, *args, w0)
                    finally:
                        CORE.simd(1)
                    fin = np.isfinite(want[0]).all(axis=1)     # (NaN rows: payloads may differ)
                    assert _bits(got[2], want[2]), n
                    assert _bits(got[0][fin], want[0][fin]) and _bits(got[1][fin], want[1][fin]), n


def _bvp_w(phi, gam2, u0, u1, tau):
    """w(τ) of the boundary-value problem by scipy's collocation (y = φ, w, w'; p = C)."""
    def f(t, y, p):
        return np.vstack([y[1], y[2], gam2 * y[1] + 2.0 * y[1] ** 3 + p[0]])

    def bc(ya, yb, p):
        return np.array([ya[0], yb[0] - phi, ya[1] - u0, yb[1] - u1])
    t = np.linspace(0.0, 1.0, 41)
    wl = u0 + (u1 - u0) * t
    y0 = np.vstack([phi * t, np.full_like(t, phi) + 0.0 * wl, np.zeros_like(t)])
    sol = solve_bvp(f, bc, t, y0, p=[-gam2 * phi - 2.0 * phi ** 3], tol=1e-10, max_nodes=200000)
    assert sol.success
    return sol.sol(tau)[1]


def _law_w(phi, gam2, u0, u1, tau):
    b = solve_circles(phi, np.sqrt(gam2), 1.0, u0 / np.sqrt(gam2), u1 / np.sqrt(gam2))
    assert not b.regime.any()
    return b.eval_tau(np.broadcast_to(tau, (phi.size, tau.size)), w2=False)[1], b


def test_laws_against_solve_bvp(curve_rows):
    phi, gam2, u0, u1 = curve_rows
    rng = np.random.default_rng(46)
    pick = rng.choice(phi.size, 12, replace=False)
    rp = _random_rows(3, 8)
    tau = np.linspace(0.0, 1.0, 17)
    for p, g, a0, a1 in ((phi[pick], gam2[pick], u0[pick], u1[pick]), rp):
        w, _ = _law_w(p, g, a0, a1, tau)
        for i in range(p.size):
            ref = _bvp_w(p[i], g[i], a0[i], a1[i], tau)
            assert np.abs(w[i] - ref).max() <= 1e-7 * _scale(p[i], a0[i], a1[i])


def test_laws_against_newton_at_n64(curve_rows):
    """The laws' node values against Newton's collocation (LU solves) on 65 nodes, evaluated
    through the laws' own Chebyshev series: agreement to the solver's tail tolerance."""
    phi, gam2, u0, u1 = curve_rows
    rp = _random_rows(11, 200)
    n = 64
    x = _cheb_setup(n)["tau"]
    for p, g, a0, a1 in ((phi[:300], gam2[:300], u0[:300], u1[:300]), rp):
        w, _ = _law_w(p, g, a0, a1, x)
        ref, _, ok = circle._newton_cheb(n, p, g, a0, a1, np.repeat(p[:, None], n + 1, axis=1))
        assert ok.all()
        assert (np.abs(w - ref).max(axis=1) <= 1e-11 * _scale(p, a0, a1)).all()


# ---------------------------------------------------------------- the layer regime's cruise value
# _solve_layers_batch: after the first step (a forward difference) the slope of each step is
# the secant through the last two iterates, one residual a step instead of two.

def _solve_layers_batch_8011c61(phi, gam2, u0, u1):
    """circle._solve_layers_batch at 8011c61, verbatim (Newton with a forward difference a step)."""
    _layers_totals, _LAYERS_ITER = circle._layers_totals, circle._LAYERS_ITER
    span = np.abs(phi) + np.abs(u0) + np.abs(u1) + 1.0
    lo, hi = np.minimum.reduce([phi, u0, u1]) - span, np.maximum.reduce([phi, u0, u1]) + span
    for _ in range(60):             # make sure the bracket holds (the layer integrals are O(log))
        glo, ghi = _layers_totals((lo, hi), phi, gam2, u0, u1)
        bad_lo, bad_hi = glo > 0, ghi < 0
        if not (bad_lo.any() or bad_hi.any()):
            break
        lo = np.where(bad_lo, lo - 2.0 * span, lo)
        hi = np.where(bad_hi, hi + 2.0 * span, hi)
        span = np.where(bad_lo | bad_hi, 2.0 * span, span)
    wc = phi.astype(float).copy()
    wc = np.clip(wc, lo, hi)
    act = np.arange(wc.size)        # an arc leaves the iteration once its step is below tolerance
    # the live arcs' numbers held packed (x: their w_c, lo_a/hi_a: their bracket), packed
    # again only when arcs leave, and each arc's w_c put into wc as it leaves: not eight
    # gathers and three scatters by act every step (the same numbers, element by element)
    x, p_, g2, a0, a1, sp, lo_a, hi_a = (v[act] for v in (wc, phi, gam2, u0, u1, span, lo, hi))
    for _ in range(_LAYERS_ITER if act.size else 0):
        h = 1e-7 * (np.abs(x) + 1e-3 * sp)
        g, gh = _layers_totals((x, x + h), p_, g2, a0, a1)
        lo_a = np.where(g < 0, x, lo_a)
        hi_a = np.where(g > 0, x, hi_a)
        dg = (gh - g) / h
        new = x - g / np.where(dg > 0, dg, np.inf)
        outside = ~((new > lo_a) & (new < hi_a)) | ~np.isfinite(new)
        new = np.where(outside, 0.5 * (lo_a + hi_a), new)
        done = np.abs(new - x) <= 1e-15 * sp
        x = new
        if done.any():
            wc[act[done]] = x[done]
            # (by the mask: taking them by index put the rectilinear plate's peak RSS up ~1 MB)
            keep = ~done
            act, x, p_, g2, a0, a1, sp, lo_a, hi_a = (v[keep] for v in (act, x, p_, g2, a0, a1, sp, lo_a, hi_a))
            if act.size == 0:
                return wc
    wc[act] = x                     # (the steps ran out: the last ones' w_c)
    return wc



def _slope(wc, phi, gam2, u0, u1):
    """The residual's slope at w_c (a central difference over 1e-6 of the span) and the span."""
    sp = np.abs(phi) + np.abs(u0) + np.abs(u1) + 1.0
    d = 1e-6 * sp
    return (circle._layers_total(wc + d, phi, gam2, u0, u1) - circle._layers_total(wc - d, phi, gam2, u0, u1)) / (2 * d), sp


def _layer_rows(seed, nb):
    """Random arcs over the regimes (γ from 0.03 to 1000: layers accepted and not), constant-
    speed ones (the exact solution w = Φ) among them."""
    rng = np.random.default_rng(seed)
    phi = rng.uniform(0.01, 6.0, nb) * rng.choice([1.0, -1.0, 30.0, 1e-3], nb)
    gam2 = 10.0 ** rng.uniform(-3, 6, nb)
    u0 = phi * rng.uniform(0.0, 3.0, nb) * rng.choice([1.0, 0.0, -1.0], nb)
    u1 = phi * rng.uniform(0.0, 3.0, nb) * rng.choice([1.0, 0.0, 1.0], nb)
    u0[:nb // 20] = u1[:nb // 20] = phi[:nb // 20]
    return phi, gam2, u0, u1


def test_layers_root_is_bracketed(curve_rows):
    """The cruise value is a root of the residual (_layers_total, evaluated here directly): the
    residual at w_c is at its rounding level, and where it has a slope (>= 1e-2; elsewhere it is
    flat at its rounding over a range of w_c, any point of which is a root) it changes sign
    within 1e-12 of the span on either side of w_c (the solver stops at steps of 1e-15)."""
    for phi, gam2, u0, u1 in (curve_rows, _layer_rows(1, 3000)):
        with np.errstate(all="ignore"):
            wc = circle._solve_layers_batch(phi, gam2, u0, u1)
            g = circle._layers_total(wc, phi, gam2, u0, u1)
            slope, sp = _slope(wc, phi, gam2, u0, u1)
            steep = slope >= 1e-2
            below = circle._layers_total(wc - 1e-12 * sp, phi, gam2, u0, u1)
            above = circle._layers_total(wc + 1e-12 * sp, phi, gam2, u0, u1)
        assert (np.abs(g) <= 1e-13 * sp).all()
        assert steep.mean() > 0.9
        assert (below[steep] <= 0).all() and (above[steep] >= 0).all()


def test_layers_same_root_and_regime_as_the_replaced_code(curve_rows):
    """Against the Newton steps it replaced: the same cruise values to 1e-13 of the span where
    the residual has a slope, the same regime decisions (_layer_regime's tail test), and
    fewer residuals."""
    count = [0]
    real = circle._layers_totals

    def counting(xs, phi, *rest):
        count[0] += len(xs) * phi.size
        return real(xs, phi, *rest)
    for phi, gam2, u0, u1 in (curve_rows, _layer_rows(2, 4000)):
        with np.errstate(all="ignore"):
            n0 = count[0]
            circle._layers_totals = counting
            try:
                new = circle._solve_layers_batch(phi, gam2, u0, u1)
                n_new = count[0] - n0
                old = _solve_layers_batch_8011c61(phi, gam2, u0, u1)
                n_old = count[0] - n0 - n_new
            finally:
                circle._layers_totals = real
            slope, sp = _slope(old, phi, gam2, u0, u1)
            steep = slope >= 1e-2
            assert (np.abs(new - old)[steep] <= 1e-13 * sp[steep]).all()
            assert n_new < 0.8 * n_old
            regime = []
            for wc in (new, old):
                tail = np.maximum(np.abs(circle._layer_d(1.0, u0 - wc, wc, gam2)),
                                  np.abs(circle._layer_d(1.0, u1 - wc, wc, gam2)))
                lam = np.sqrt(gam2 + 6.0 * wc * wc)
                regime.append((tail * (1.0 + lam) <= circle._LAYER_TAIL_TOL * _scale(phi, u0, u1)) & np.isfinite(wc))
        assert np.array_equal(regime[0], regime[1])
