"""General-curve law: ellipse against direct minimisation, circle/line limits, polylines."""
import numpy as np
import pytest
from scipy.special import ellipeinc

from gcode_opt.laws.circle import solve_circle
from gcode_opt.laws.curve import curvature_from_polyline, solve_curve, split_at_corners
from gcode_opt.laws.direct import ellipse_path, minimise_law


class Ellipse:
    """x = a cos p, y = b sin p (b > a): exact arc length s(p) = b E(p | 1 − a²/b²), κ(s)."""

    def __init__(self, a, b):
        self.a, self.b, self.m = a, b, 1.0 - a * a / (b * b)
        self.length = self.s_of_p(2 * np.pi)

    def s_of_p(self, p):
        return self.b * ellipeinc(p, self.m)

    def _g(self, p):
        return self.a**2 * np.sin(p)**2 + self.b**2 * np.cos(p)**2   # |r'(p)|²

    def p_of_s(self, s):
        p = 2 * np.pi * np.asarray(s, float) / self.length
        for _ in range(40):                                          # Newton, ds/dp = |r'|
            p = p - (self.s_of_p(p) - s) / np.sqrt(self._g(p))
        return p

    def kappa(self, s):
        return self.a * self.b / self._g(self.p_of_s(s))**1.5

    def dkappa_ds(self, s):
        p = self.p_of_s(s)
        g = self._g(p)
        dg = 2 * (self.a**2 - self.b**2) * np.sin(p) * np.cos(p)
        return -1.5 * self.a * self.b * dg / g**2.5 / np.sqrt(g)


ELLIPSE = Ellipse(1.0, 2.0)


@pytest.mark.parametrize("alpha", [1e-3, 1e-2, 0.1, 1.0])
def test_ellipse_full_turn_matches_direct_minimisation(alpha):
    e = ELLIPSE
    law = solve_curve(e.kappa, e.dkappa_ds, e.length, 1.0, alpha)
    direct = minimise_law(ellipse_path(e.a, e.b), 0.0, 2 * np.pi, 1.0, alpha, n_basis=64)
    assert abs(law.cost() - direct.J) <= 1e-6 * direct.J
    t = np.linspace(0, 1, 101)
    s_direct = e.s_of_p(direct.eval(t)[0])
    np.testing.assert_allclose(law.eval(t)[0], s_direct, atol=1e-5 * e.length)
    H = law.hamiltonian(t)
    assert np.ptp(H) <= 1e-6 * np.abs(H).max()


def test_ellipse_with_end_speeds_matches_direct():
    e = ELLIPSE
    v0, v1 = 5.0, 12.0                                   # arc-length speeds at p = 0 and 2π
    law = solve_curve(e.kappa, e.dkappa_ds, e.length, 1.0, 0.01, v0, v1)
    # at p = 0, 2π: |r'| = b
    direct = minimise_law(ellipse_path(e.a, e.b), 0.0, 2 * np.pi, 1.0, 0.01, v0 / e.b, v1 / e.b,
                          n_basis=64)
    assert abs(law.cost() - direct.J) <= 1e-6 * direct.J
    s, v, _ = law.eval(np.array([0.0, 1.0]))
    np.testing.assert_allclose(v, [v0, v1], rtol=1e-10)


def test_constant_curvature_equals_circle_solver():
    R, phi, T, beta, v0, v1 = 3.0, 1.5 * np.pi, 0.8, 5e-3, 2.0, 9.0
    const = lambda s: np.full_like(np.asarray(s, float), 1.0 / R)
    zero = lambda s: np.zeros_like(np.asarray(s, float))
    law = solve_curve(const, zero, R * phi, T, beta, v0, v1)
    circ = solve_circle(phi, T, beta, v0 / R, v1 / R, R=R)
    t = np.linspace(0, T, 51)
    for a, b, sc in zip(law.eval(t), circ.eval_s(t), (R * phi, R * phi / T, R * phi / T**2)):
        np.testing.assert_allclose(a, b, atol=1e-8 * sc)
    assert law.cost() == pytest.approx(circ.cost(), rel=1e-9)
    assert law.peak_accel() == pytest.approx(circ.peak_accel(), rel=1e-4)


def test_zero_curvature_is_the_exponential_line_law():
    L_d, T_t, beta, v0, v1 = 15.0, 0.3, 1e-3, 40.0, 10.0
    zero = lambda s: np.zeros_like(np.asarray(s, float))
    law = solve_curve(zero, zero, L_d, T_t, beta, v0, v1)
    rb = np.sqrt(beta)
    eT = np.exp(-T_t / rb)
    A = np.array([[1, 0, 1, eT], [1, T_t, eT, 1], [0, 1, -1 / rb, eT / rb],
                  [0, 1, -eT / rb, 1 / rb]])
    c = np.linalg.solve(A, [0, L_d, v0, v1])
    t = np.linspace(0, T_t, 201)
    s_line = c[0] + c[1] * t + c[2] * np.exp(-t / rb) + c[3] * np.exp(-(T_t - t) / rb)
    np.testing.assert_allclose(law.eval(t)[0], s_line, atol=1e-10 * L_d)


def _rounded(points):
    return np.round(points, 3)          # slicer output: 0.001 mm resolution


@pytest.mark.parametrize("R_d, seg_d", [(10.0, 0.3), (2.0, 0.2), (40.0, 0.5)])
def test_polyline_curvature_of_rounded_circle(R_d, seg_d):
    th = np.arange(0, 1.5 * np.pi, seg_d / R_d)
    pc = curvature_from_polyline(_rounded(np.c_[R_d * np.cos(th), R_d * np.sin(th)]))
    n = th.size
    inner = slice(n // 10, n - n // 10)
    np.testing.assert_allclose(pc.kappa_v[inner], 1.0 / R_d, rtol=0.02)
    s_mid = pc.s_d[n // 2]
    assert pc.kappa(s_mid) == pytest.approx(1.0 / R_d, rel=0.02)
    assert abs(pc.dkappa_ds(pc.s_d[inner])).max() < 0.05 / R_d   # no spikes from rounding


def test_polyline_curvature_of_rounded_ellipse():
    a, b = 20.0, 10.0
    p = np.linspace(0, 2 * np.pi, 600)
    g = a * a * np.sin(p)**2 + b * b * np.cos(p)**2
    pc = curvature_from_polyline(_rounded(np.c_[a * np.cos(p), b * np.sin(p)]))
    inner = slice(60, -60)
    np.testing.assert_allclose(pc.kappa_v[inner], (a * b / g**1.5)[inner], rtol=0.04)


def test_split_square_at_corners():
    corners = [(0, 0), (10, 0), (10, 10), (0, 10), (0, 0)]
    pts = np.vstack([np.c_[np.linspace(x0, x1, 21)[:-1], np.linspace(y0, y1, 21)[:-1]]
                     for (x0, y0), (x1, y1) in zip(corners[:-1], corners[1:])] + [[0, 0]])
    assert split_at_corners(_rounded(pts), 45.0) == [(0, 20), (20, 40), (40, 60), (60, 80)]
    # a rounded (filleted) corner turning 90° in 3 × 30° steps is not a corner at 45°
    fillet = np.array([[0, 0], [5, 0], [5 + np.cos(np.pi / 6), np.sin(np.pi / 6)],
                       [5 + np.cos(np.pi / 6) + np.cos(np.pi / 3), np.sin(np.pi / 6) + np.sin(np.pi / 3)],
                       [5 + np.cos(np.pi / 6) + np.cos(np.pi / 3), 5.0]])
    assert split_at_corners(fillet, 45.0) == [(0, 4)]
    assert split_at_corners(fillet, 20.0) == [(0, 1), (1, 2), (2, 3), (3, 4)]


def test_polyline_arc_law_close_to_exact_circle_law():
    R_d, phi, T, beta = 8.0, np.pi, 0.25, 1e-4
    th = np.linspace(0, phi, int(R_d * phi / 0.3) + 1)
    pc = curvature_from_polyline(_rounded(np.c_[R_d * np.cos(th), R_d * np.sin(th)]))
    law = solve_curve(pc.kappa, pc.dkappa_ds, pc.length_d, T, beta, 50.0, 50.0,
                      d2kappa_ds2=pc.d2kappa_ds2)
    circ = solve_circle(phi, T, beta, 50.0 / R_d, 50.0 / R_d, R=R_d)
    assert law.cost() == pytest.approx(circ.cost(), rel=1e-2)
    assert law.peak_accel() == pytest.approx(circ.peak_accel(), rel=2e-2)


from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as hst  # noqa: E402


@settings(max_examples=60, deadline=None)
@given(hst.lists(hst.tuples(hst.floats(1e-3, 1e3), hst.floats(-0.5, 0.5)), min_size=2, max_size=12),
       hst.floats(0.05, 5.0))
def test_polyline_curvature_is_finite_whatever_the_lengths(segs, smooth_d):
    """Issue 7: segments of very different lengths (a 28 mm line ending a chain of 0.5 mm
    connectors) made every kernel weight of an end vertex underflow: 0/0.  Any chain of
    lengths 1e-3..1e3 mm and turns up to 0.5 rad gives finite curvatures, of magnitude
    at most the largest turn over the shortest spreading length."""
    from gcode_opt.laws.curve import curvature_from_polyline
    x, y, h = 0.0, 0.0, 0.0
    pts = [(x, y)]
    for d, turn in segs:
        h += turn
        x, y = x + d * np.cos(h), y + d * np.sin(h)
        pts.append((x, y))
    pc = curvature_from_polyline(pts, smooth_d=smooth_d)
    assert np.isfinite(pc.kappa_v).all()
    d = np.array([s[0] for s in segs])
    bound = 0.5 / (0.5 * (d[:-1] + d[1:]).min()) if len(d) > 1 else 0.0
    assert np.abs(pc.kappa_v).max() <= bound * (1 + 1e-9) + 1e-12
