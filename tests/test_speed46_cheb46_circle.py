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
* the compiled form and the numpy fallback give the same bits (AVX and scalar)."""
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
    real = circle.solve_circles
    mp = pytest.MonkeyPatch()

    def rec(phi_total, T, beta, w0=0.0, w1=0.0, R=1.0):
        phi, T_t, beta_s2, w0_, w1_ = (np.broadcast_arrays(*(np.atleast_1d(np.asarray(v, float))
                                                             for v in (phi_total, T, beta, w0, w1))))
        rows.append((phi.copy(), T_t * T_t / beta_s2, w0_ * T_t, w1_ * T_t))
        return real(phi_total, T, beta, w0, w1, R)
    from gcode_opt import curves
    try:
        mp.setattr(curves, "solve_circles", rec)
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
