"""Ellipse x = a cos p, y = b sin p (p the eccentric anomaly) in arc length: exact s(p),
its inverse, curvature κ(s) and dκ/ds -- what curve.py's law needs -- and the change of
variable back to p(t) (MATH.md: the paper's printed ellipse equation is wrong; the law
here is the arc-length form, valid for any curve)."""
from __future__ import annotations

import math

import numpy as np
from scipy.special import ellipeinc, ellipe


class Ellipse:
    def __init__(self, a_d: float, b_d: float):
        if not (a_d > 0 and b_d > 0):
            raise ValueError("ellipse semi-axes must be > 0")
        self.a, self.b = float(a_d), float(b_d)
        self.length_d = float(self.s_of_p(2.0 * math.pi))

    # |r'(p)| and its derivative
    def g(self, p):
        return np.sqrt((self.a * np.sin(p)) ** 2 + (self.b * np.cos(p)) ** 2)

    def dg(self, p):
        return (self.a ** 2 - self.b ** 2) * np.sin(p) * np.cos(p) / self.g(p)

    def s_of_p(self, p):
        """Arc length from p = 0 (exact, incomplete elliptic integral of the 2nd kind)."""
        p = np.asarray(p, float)
        a, b = self.a, self.b
        if b >= a:
            return b * ellipeinc(p, 1.0 - (a / b) ** 2)
        m = 1.0 - (b / a) ** 2
        return a * (ellipeinc(p - 0.5 * math.pi, m) + ellipe(m))

    def p_of_s(self, s):
        """Inverse of s_of_p (Newton from the proportional guess; g >= min(a, b) > 0)."""
        s = np.asarray(s, float)
        p = 2.0 * math.pi * s / self.length_d
        for _ in range(50):
            step = (self.s_of_p(p) - s) / self.g(p)
            p = p - step
            if np.all(np.abs(step) < 1e-15 * (1.0 + np.abs(p))):
                break
        return p

    def kappa_p(self, p):
        return self.a * self.b / self.g(p) ** 3

    # callables of s for curve.solve_curve
    def kappa(self, s):
        return self.kappa_p(self.p_of_s(s))

    def dkappa_ds(self, s):
        p = self.p_of_s(s)
        g = self.g(p)
        return -3.0 * self.a * self.b * self.dg(p) / g ** 4 / g

    def xy(self, p):
        return self.a * np.cos(p), self.b * np.sin(p)

    def p_law(self, s, sd, sdd):
        """(p, ṗ, p̈) from (s, ṡ, s̈): ṡ = g ṗ, s̈ = g' ṗ² + g p̈."""
        p = self.p_of_s(s)
        g = self.g(p)
        pd = sd / g
        pdd = (sdd - self.dg(p) * pd ** 2) / g
        return p, pd, pdd
