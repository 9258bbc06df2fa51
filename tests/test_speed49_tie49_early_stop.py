"""Round 49 (tie49): the circle law's preconditioned iteration (laws/circle.py _precond_cheb,
_curvecore.c pc_next) also stops once the steps left, a geometric series at the last step
ratio rho (step rho / (1 - rho)), are within its tolerance (_PRECOND_TOL, 1e-16 of the arc's
scale): the iterate is then within that of the fixed point, below the rounding of its values,
and the step (or two) that would only reach the rounding floor is not taken (~7.6 -> ~6 steps
an arc on the plates' curves).  The laws move at rounding level.

Checked here, on the curve rows of the bundled gyroid sample and on random (Phi, gamma, u0, u1):
* against the converged full iteration (the iteration as it was, _precond_cheb_np_3673ec9
  below, verbatim: it stops at a last step of 1e-16 of the scale, or at the rounding floor):
  the same arcs converge, node values within 1e-14 of the scale (the rounding floor of the
  residual, ~1e-16 relative times the conditioning of the collocation system, ~1e2), and
  fewer steps on average;
* against Newton on the same collocation equations (circle._newton_cheb: LU solves, not the
  preconditioned iteration; it stops at a step of 1e-13 of the scale, then quadratically
  close): node values within 1e-13 of the scale;
* the compiled form and the numpy fallback give the same bits (test_speed46_cheb46_circle's
  test_compiled_and_numpy_same_bits runs both on these rows, degenerate ones included)."""
import numpy as np
import pytest

from gcode_opt.laws import circle
from gcode_opt.laws.circle import _PRECOND_FLOOR, _PRECOND_ITER, _PRECOND_SLOW_R, _PRECOND_TOL, _mm_ordered
import test_speed46_cheb46_circle as c46
from test_speed46_cheb46_circle import _random_rows, _scale

curve_rows = c46.curve_rows       # (its fixture: the gyroid sample's curve rows)


def _precond_cheb_np_3673ec9(n, phi, gam2, u0, u1, w_start, tol=_PRECOND_TOL):
    """circle._precond_cheb_np at 3673ec9, verbatim, with each arc's number of steps."""
    w, cc, ok, scale = circle._precond_start(phi, u0, u1, w_start)
    pc = circle._precond_consts(n)
    steps = np.zeros(phi.size, int)
    if pc is None or phi.size == 0:
        return w, cc, ok, steps
    d2_t, q, lam_e, vinv_t, v_t, qv, e = pc
    act = np.arange(phi.size)
    last = np.full(phi.size, np.inf)
    for it in range(_PRECOND_ITER):
        steps[act] += 1
        wa, ca = w[act], cc[act]
        wi = wa[:, 1:-1]
        g2 = gam2[act]
        w2 = wi * wi
        r1 = _mm_ordered(wa, d2_t) - g2[:, None] * wi - 2.0 * wi * w2 - ca[:, None]
        r2 = (wa * q).sum(axis=1) - phi[act]
        den = lam_e[None, :] - (g2 + 3.0 * (w2.max(axis=1) + w2.min(axis=1)))[:, None]
        b = -_mm_ordered(r1, vinv_t)
        dc = (-r2 - ((b / den) * qv).sum(axis=1)) / ((qv * e) / den).sum(axis=1)
        dw = _mm_ordered((b + dc[:, None] * e) / den, v_t)
        w[act, 1:-1] = wi + dw
        cc[act] = ca + dc
        step = np.abs(dw).max(axis=1)
        # done: at the rounding floor of the residual (steps no longer shrink), or below it
        slow = (it >= 4) & ~(step < _PRECOND_SLOW_R * last[act])
        done = (step <= tol * scale[act]) | (slow & (step <= _PRECOND_FLOOR * scale[act]))
        ok[act[done]] = True
        keep = ~done & np.isfinite(step) & ~slow
        last[act] = step
        act = act[keep]
        if act.size == 0:
            break
    return w, cc, ok, steps


def _steps_now(n, phi, gam2, u0, u1, w0, monkeypatch):
    """Each arc's steps in circle._precond_cheb: the least iteration limit at which it converges."""
    steps = np.full(phi.size, _PRECOND_ITER + 1)
    for m in range(1, _PRECOND_ITER + 1):
        monkeypatch.setattr(circle, "_PRECOND_ITER", m)
        ok = circle._precond_cheb(n, phi, gam2, u0, u1, w0)[2]
        steps = np.where(ok & (steps > m), m, steps)
        if ok.all():
            break
    monkeypatch.undo()
    return steps


def _rows(curve_rows):
    phi, gam2, u0, u1 = curve_rows
    return [(phi[:1500], gam2[:1500], u0[:1500], u1[:1500]), _random_rows(49, 400)]


@pytest.mark.parametrize("n", [16, 20, 24, 32])
def test_early_stop_against_the_full_iteration(curve_rows, n, monkeypatch):
    for which, (phi, gam2, u0, u1) in enumerate(_rows(curve_rows)):
        w0 = np.repeat(phi[:, None], n + 1, axis=1)
        new = circle._precond_cheb(n, phi, gam2, u0, u1, w0)
        old = circle_full = _precond_cheb_np_3673ec9(n, phi, gam2, u0, u1, w0)
        # (an arc stalling right at the rounding floor may be left to Newton by one and not the
        # other: the floor tests compare rounding-level steps)
        assert (new[2] != old[2]).mean() <= 0.02
        ok = new[2] & old[2]
        assert ok.mean() > 0.9
        sc = _scale(phi, u0, u1)[ok]
        assert (np.abs(new[0][ok] - old[0][ok]).max(axis=1) <= 1e-14 * sc).all()
        assert (np.abs(new[1][ok] - old[1][ok]) <= 1e-12 * sc * (1.0 + gam2[ok] + sc * sc)).all()
        if which == 0:        # (the plates' kind of arcs: the steps saved)
            steps = _steps_now(n, phi, gam2, u0, u1, w0, monkeypatch)
            both = ok & (steps <= _PRECOND_ITER)
            assert steps[both].mean() < circle_full[3][both].mean() - 0.5
            assert (steps[both] <= circle_full[3][both]).all()


@pytest.mark.parametrize("n", [20, 32])
def test_early_stop_against_newton(curve_rows, n):
    for phi, gam2, u0, u1 in _rows(curve_rows):
        w0 = np.repeat(phi[:, None], n + 1, axis=1)
        w, cc, ok = circle._precond_cheb(n, phi, gam2, u0, u1, w0)
        ref, _, ok_ref = circle._newton_cheb(n, phi[ok], gam2[ok], u0[ok], u1[ok], w0[ok])
        assert ok.mean() > 0.9 and ok_ref.all()
        assert (np.abs(w[ok] - ref).max(axis=1) <= 1e-13 * _scale(phi, u0, u1)[ok]).all()
