"""The not-a-knot cubic spline through (x_i, y_i), what scipy's CubicSpline(x, y) makes by
default, in numpy alone.  The report draws the optimal law along a curve (laws.curve's
PolylineCurvature); scipy.interpolate for this one spline raised `process --report`'s
resident set by ~45 MB (its import: scipy.sparse, scipy.linalg, scipy.special) and cost ~0.5 s.

The slopes solve the classic tridiagonal system (continuous second derivative at the
interior knots, the third derivative continuous at the second and the last-but-one: not a
knot), by elimination without pivoting; each piece is then the cubic Hermite of its end
values and slopes.  Agrees with scipy's to rounding (tests/test_speed56_rep56_spline.py)."""
from __future__ import annotations

import numpy as np


class NotAKnotCubic:
    """s(x) on [x_0, x_n], called as spline(x, nu=0) for the value or its nu-th derivative
    (nu 0..3); x outside is extrapolated from the end pieces (as scipy's)."""
    __slots__ = ("x", "c")

    def __init__(self, x, y):
        x = np.asarray(x, float)
        y = np.asarray(y, float)
        dx = np.diff(x)
        slope = np.diff(y) / dx
        n = x.size
        if n == 2:                               # a line
            s = np.array([slope[0], slope[0]])
        elif n == 3:                             # not-a-knot on 3 points: the parabola through them
            c2 = (slope[1] - slope[0]) / (dx[0] + dx[1])
            s = np.array([slope[0] - c2 * dx[0], slope[0] + c2 * dx[0], slope[1] + c2 * dx[1]])
        else:
            s = _slopes(dx, slope)
        t = (s[:-1] + s[1:] - 2.0 * slope) / dx
        self.x = x
        # the pieces' power coefficients in (x - x_i): c[0] x^3 + c[1] x^2 + c[2] x + c[3]
        self.c = np.stack([t / dx, (slope - s[:-1]) / dx - t, s[:-1], y[:-1]])

    def __call__(self, xq, nu=0):
        xq = np.asarray(xq, float)
        i = np.clip(np.searchsorted(self.x, xq, side="right") - 1, 0, self.x.size - 2)
        h = xq - self.x[i]
        c3, c2, c1, c0 = (self.c[k][i] for k in range(4))
        if nu == 0:
            return ((c3 * h + c2) * h + c1) * h + c0
        if nu == 1:
            return (3.0 * c3 * h + 2.0 * c2) * h + c1
        if nu == 2:
            return 6.0 * c3 * h + 2.0 * c2
        if nu == 3:
            return 6.0 * c3
        raise ValueError(f"derivative order {nu} not in 0..3")


def _slopes(dx, slope):
    """The knots' slopes of the not-a-knot spline (n >= 4 knots): the tridiagonal system
    sub[i] s[i-1] + diag[i] s[i] + sup[i] s[i+1] = rhs[i], solved by elimination."""
    n = dx.size + 1
    sub, diag, sup, rhs = np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n)
    diag[1:-1] = 2.0 * (dx[:-1] + dx[1:])
    sub[1:-1] = dx[1:]
    sup[1:-1] = dx[:-1]
    rhs[1:-1] = 3.0 * (dx[1:] * slope[:-1] + dx[:-1] * slope[1:])
    # not a knot at x_1 and x_{n-2}
    diag[0], sup[0] = dx[1], dx[0] + dx[1]
    rhs[0] = ((dx[0] + 2.0 * sup[0]) * dx[1] * slope[0] + dx[0] ** 2 * slope[1]) / sup[0]
    diag[-1], sub[-1] = dx[-2], dx[-1] + dx[-2]
    rhs[-1] = (dx[-1] ** 2 * slope[-2] + (2.0 * sub[-1] + dx[-1]) * dx[-2] * slope[-1]) / sub[-1]
    for i in range(1, n):                        # forward elimination (Thomas)
        w = sub[i] / diag[i - 1]
        diag[i] -= w * sup[i - 1]
        rhs[i] -= w * rhs[i - 1]
    s = np.empty(n)
    s[-1] = rhs[-1] / diag[-1]
    for i in range(n - 2, -1, -1):
        s[i] = (rhs[i] - sup[i] * s[i + 1]) / diag[i]
    return s
