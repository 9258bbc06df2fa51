"""Session 20 (chainprim, issue 8): the deterministic primitives of the chains' Newton loops
(laws/prims.py: sinh by its series from + - * / only, cube = (x * x) * x) and their C
twins in laws/_chaincore.c (p_sinh, p_cube; exposed for this test as prims_c).

- accuracy of prims.sinh vs math.sinh (libm) and vs the exact value (mpmath), dense grid
  and random: <= 2 ULP from math.sinh for |z| <= 2, <= 1 ULP from the exact value for
  |z| <= 1 and <= 1.5 ULP for 1 < |z| <= 2 (the
  chains' laws are all at γ <= GAMMA_MIN = 0.1: their arguments are within 0.1); over
  the rest of the series branch (2 < |z| <= GAMMA_SWITCH = 4) <= 4 ULP from math.sinh,
  <= 3 ULP from the exact value (the positive series' roundings grow with z³ S1 / sinh z);
- oddness, 0, shc's 1 at 0, cube's operation order;
- C == numpy bit for bit on the same values, and a mutant (one coefficient an ulp off in
  the C call) that this comparison sees."""
import math

import numpy as np
import pytest

from gcode_opt.laws import chain as lc
from gcode_opt.laws import prims
from gcode_opt.laws.line import GAMMA_SWITCH


def _ulps(a, b):
    """ULP distance of doubles of one sign."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert np.all((a >= 0) == (b >= 0))
    return np.abs(a.view(np.int64) - b.view(np.int64))


def _grid(lo, hi, n, seed):
    rng = np.random.default_rng(seed)
    return np.concatenate([np.linspace(lo, hi, n), rng.uniform(lo, hi, n)])


def _libm(z):
    return np.array([math.sinh(x) for x in z.tolist()])


@pytest.mark.parametrize("lo,hi,tol", [(0.0, 0.2, 2), (0.2, 1.0, 2), (1.0, 2.0, 2), (2.0, GAMMA_SWITCH, 4)])
def test_sinh_vs_libm(lo, hi, tol):
    z = _grid(lo, hi, 100001, int(hi * 10))
    got = prims.sinh(z)
    u = _ulps(got, _libm(z))
    assert u.max() <= tol, (u.max(), z[np.argmax(u)])
    assert np.mean(u == 0) > 0.5                     # mostly libm's own bits
    # tiny and huge-exponent-range arguments: sinh z = z to the last bit
    tiny = 10.0 ** np.random.default_rng(3).uniform(-300, -9, 2000)
    assert np.array_equal(prims.sinh(tiny), tiny)


@pytest.mark.parametrize("lo,hi,tol", [(0.0, 1.0, 1), (1.0, 2.0, 1.5), (2.0, GAMMA_SWITCH, 3)])
def test_sinh_vs_exact(lo, hi, tol):
    mpmath = pytest.importorskip("mpmath")
    mpmath.mp.dps = 40
    z = _grid(lo, hi, 1500, 7)
    got = prims.sinh(z)
    err = max(float(abs(mpmath.mpf(g) - mpmath.sinh(mpmath.mpf(x))) / mpmath.mpf(math.ulp(g)))
              for x, g in zip(z.tolist(), got.tolist()) if x)
    assert err <= tol, err


def test_sinh_shc_cube_basics():
    z = _grid(0.0, GAMMA_SWITCH, 5000, 1)
    assert np.array_equal(prims.sinh(-z), -prims.sinh(z))            # odd, bit for bit
    assert prims.sinh(0.0) == 0.0 and np.isnan(prims.sinh(np.nan))
    x = np.random.default_rng(2).normal(size=5000)
    assert np.array_equal(prims.cube(x), (x * x) * x)
    s = prims.shc(np.array([0.0, -0.0, 0.5, -0.5]))
    assert s[0] == s[1] == 1.0 and s[2] == s[3] == prims.sinh(0.5) / 0.5
    assert prims.shc(0.0) == 1.0 and prims.shc(0.25) == prims.sinh(0.25) / 0.25
    assert prims.SINH_TERMS == 17 and prims.SINH_COEF.size == 17


needs_core = pytest.mark.skipif(lc.CORE_MOD is None, reason=f"the chain core is not used here ({lc.CORE_WHY})")


@needs_core
def test_c_primitives_same_bits():
    rng = np.random.default_rng(4)
    z = np.concatenate([_grid(-GAMMA_SWITCH, GAMMA_SWITCH, 20001, 5), rng.normal(0, 0.1, 20000), [0.0, -0.0]])
    sh, cu, sc = np.empty(z.size), np.empty(z.size), np.empty(z.size)
    lc.CORE_MOD.prims_c(z, prims.SINH_COEF, sh, cu, sc)
    assert np.array_equal(sh.view(np.int64), prims.sinh(z).view(np.int64))
    assert np.array_equal(cu.view(np.int64), prims.cube(z).view(np.int64))
    assert np.array_equal(sc.view(np.int64), prims.shc(z).view(np.int64))
    # mutant: the first coefficient 1e-10 off in the C call: the comparison above sees it
    bad = prims.SINH_COEF.copy()
    bad[0] *= 1 + 1e-10
    lc.CORE_MOD.prims_c(z, bad, sh, cu, sc)
    assert not np.array_equal(sh.view(np.int64), prims.sinh(z).view(np.int64))
