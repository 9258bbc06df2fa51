"""Deterministic primitives of the chains' Newton loops (laws/chain.py, _chaincore.c).

numpy's sinh and power(x, 3) are not libm's on every machine (SIMD versions: SVML on
AVX-512), so a law computed with them differs between machines in the last bits.  The
chains' time sharing and time-of-distance use these instead: made of + - * / only (IEEE,
correctly rounded, the same everywhere), the same operations in the same order here
(numpy) and in _chaincore.c (C, -ffp-contract=off), so the C core gives these bits and
every machine gives the same bits.

    cube(x)  = (x * x) * x
    sinh(z)  = z + cube(z) * S1(z²)      S1(w) = Σ_j w^j / (2j + 3)!  (line.py's _S1_COEF)

S1 by Horner from its last term, always SINH_TERMS terms: those full double accuracy needs
at |z| = GAMMA_SWITCH (the series branch of the line law: γ < 4; the chains' laws are at
γ ≈ 0.1, where the terms past the 7th add nothing).  A fixed number of terms: the value is
a function of z alone (not of the batch it comes in).  Accuracy
(tests/test_speed20_chainprim_prims.py, dense grid and random): within 2 ULP of math.sinh
for |z| <= 2 (the chains' arguments are all below ~0.1: γ <= GAMMA_MIN), within 4 ULP for
2 < |z| <= 4; from the exact value (mpmath) <= 0.7 ULP for |z| <= 1, <= 1.3 ULP for
|z| <= 2, <= 2.5 ULP for |z| <= 4 (the roundings of the positive series and of z³ grow
with z³ S1 / sinh z, 0.85 at z = 4).  Only for |z| <= GAMMA_SWITCH (beyond, the fixed
series is truncated too early).
"""
from __future__ import annotations

import numpy as np

from .line import _S1_COEF, _S1_ZMAX, GAMMA_SWITCH, _nms_terms

SINH_TERMS = _nms_terms(np.array([GAMMA_SWITCH * GAMMA_SWITCH]), _S1_ZMAX)   # 17
SINH_COEF = np.ascontiguousarray(_S1_COEF[:SINH_TERMS])


def cube(x):
    """x³ as (x * x) * x."""
    x = np.asarray(x, dtype=float)
    return (x * x) * x


def sinh(z):
    """sinh z for |z| <= GAMMA_SWITCH: z + cube(z) * S1(z²) (see the module)."""
    z = np.asarray(z, dtype=float)
    z2 = z * z
    s = np.empty(z2.shape)
    s[...] = SINH_COEF[-1]
    for c in SINH_COEF[-2::-1]:
        np.multiply(s, z2, out=s)
        np.add(s, c, out=s)
    return (z + cube(z) * s)[()]


def shc(z):
    """sinh(z)/z with this sinh, 1 at z = 0 (as line._shc with np.sinh)."""
    z = np.asarray(z, dtype=float)
    zero = z == 0.0
    if z.ndim and not zero.any():
        return sinh(z) / z
    safe = np.where(zero, 1.0, z)
    return np.where(zero, 1.0, sinh(safe) / safe)
