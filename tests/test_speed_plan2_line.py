"""Round 2 of issue 8's planning CPU: LineLaw's γ series by one in-place Horner pass for
n, m and S1 together (line._horner_nms) and the chains' J at three durations with the
T-free parts computed once (chain._J3).  The replaced forms are kept here as references
(copied from a071b70: _horner allocating two arrays a term, three separate series, and
_J through a LineLaw per duration); the new code must give the same bits."""
import numpy as np
import pytest

from gcode_opt.laws import chain, line
from gcode_opt.laws.line import GAMMA_SWITCH, LineLaw, _M_COEF, _N_COEF, _S1_COEF


def _horner_ref(coef, z2):
    out = np.full_like(z2, coef[-1])
    for c in coef[-2::-1]:
        out = out * z2 + c
    return out


def _gammas(seed, n=4000):
    rng = np.random.default_rng(seed)
    g = np.concatenate([rng.uniform(0.0, GAMMA_SWITCH, n), 10.0 ** rng.uniform(-12, 0.6, n),
                        [0.0, 5e-324, 1e-300, 0.1, 1.0, np.nextafter(GAMMA_SWITCH, 0.0), GAMMA_SWITCH]])
    return np.minimum(g, GAMMA_SWITCH)


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape and a.dtype == b.dtype
    assert np.array_equal(a.view(np.int64), b.view(np.int64))


@pytest.mark.parametrize("seed", [0, 1])
def test_horner_in_place_same_bits(seed):
    z2 = _gammas(seed) ** 2
    for coef in (_N_COEF, _M_COEF, _S1_COEF):
        _same(line._horner(coef, z2), _horner_ref(coef, z2))
        _same(line._horner(coef, z2[:8000].reshape(2, -1)[:, ::3]), _horner_ref(coef, z2[:8000].reshape(2, -1)[:, ::3]))


def test_horner_scalar_input():
    for g in (0.0, 0.1, 3.9):
        z2 = np.asarray(g) ** 2                     # a numpy scalar, as _s1 passes it
        a, b = line._horner(_S1_COEF, z2), _horner_ref(_S1_COEF, z2)
        assert type(a) is type(b) and a == b
        n, m, s1 = line._horner_nms(np.asarray(g) * np.asarray(g))
        assert n == _horner_ref(_N_COEF, z2) and m == _horner_ref(_M_COEF, z2)
        assert s1 == _horner_ref(_S1_COEF, z2)


@pytest.mark.parametrize("seed", [0, 1])
def test_small_coeffs_same_bits(seed):
    gs = _gammas(seed)
    c = line._small_coeffs(gs, None)
    n, m = _horner_ref(_N_COEF, gs * gs), _horner_ref(_M_COEF, gs * gs)
    s1 = _horner_ref(_S1_COEF, np.asarray(gs, dtype=float) ** 2)
    sh2 = line._shc(gs / 2)
    _same(c["n"], n)
    _same(c["Ig1"], m / (2 * n * n))
    _same(c["Igp"], s1 / (2 * n * n))
    _same(c["Ih"], 2 * s1 / sh2**2)
    _same(c["kappa_over_gamma"], 2 * n / sh2)
    assert c["n"].base is None or c["n"].base.size == c["n"].size    # not a view of the 3 rows


def _J_ref(L, T, beta, va, vb):
    iv, ia = LineLaw(L, T, beta, va, vb).integrals()
    return iv + beta * ia


def _pieces(seed, n=3000):
    rng = np.random.default_rng(seed)
    T = 10.0 ** rng.uniform(-4, 0, n)
    beta = np.where(rng.random(n) < 0.8, (T / 0.1) ** 2, 10.0 ** rng.uniform(-8, 2, n))
    beta[:5] = np.inf
    L = rng.uniform(0.01, 20.0, n)
    va, vb = rng.uniform(0, 300, n), rng.uniform(0, 300, n)
    return L, T, beta, va, vb


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_J3_same_bits_as_three_line_laws(seed):
    """Since session 20 (chainprim) _J3's series branch (γ < GAMMA_SWITCH) uses the
    deterministic sinh and cube of laws/prims.py where LineLaw has np.sinh and ** 3: there
    the last bits differ (a tolerance check, rtol 1e-13); the other branch is LineLaw's
    but for prims.cube (all of _J3's T³), bit for bit where T ** 3 is cube(T)."""
    L, T, beta, va, vb = _pieces(seed)
    h = chain.FD_H_R * T
    got = chain._J3(L, T - h, T, T + h, beta, va, vb)
    for g, Tk in zip(got, (T - h, T, T + h)):
        want = _J_ref(L, Tk, beta, va, vb)
        small = Tk / np.sqrt(beta) < GAMMA_SWITCH
        assert 0 < small.sum() < small.size
        same3 = Tk ** 3 == (Tk * Tk) * Tk
        assert np.count_nonzero(~small & same3) > 100
        _same(g[~small & same3], want[~small & same3])
        np.testing.assert_allclose(g, want, rtol=1e-13, atol=0)


def test_J3_raises_as_line_law():
    L, T, beta, va, vb = _pieces(3, 20)
    for k, bad in enumerate([(L, T * np.where(np.arange(20) == 4, np.nan, 1.0), beta, va, vb),
                             (L, T, np.where(np.arange(20) == 4, 0.0, beta), va, vb),
                             (np.where(np.arange(20) == 4, np.inf, L), T, beta, va, vb)]):
        Lb, Tb, bb, ab, cb = bad
        with pytest.raises(ValueError) as want:
            _J_ref(Lb, Tb, bb, ab, cb)
        with pytest.raises(ValueError) as got:
            chain._J3(Lb, Tb, Tb, Tb, bb, ab, cb)
        assert str(got.value) == str(want.value)


def _shc_ref(z):
    z = np.asarray(z, dtype=float)
    safe = np.where(z == 0.0, 1.0, z)
    return np.where(z == 0.0, 1.0, np.sinh(safe) / safe)


def test_shc_same_bits():
    rng = np.random.default_rng(5)
    z = np.concatenate([rng.uniform(-4, 4, 1000), 10.0 ** rng.uniform(-300, 0.6, 1000)])
    _same(line._shc(z), _shc_ref(z))
    zz = z.copy()
    zz[::7] = 0.0                                   # with zeros: the np.where path
    _same(line._shc(zz), _shc_ref(zz))
    _same(line._shc(z.reshape(40, 50)), _shc_ref(z.reshape(40, 50)))
    for s in (0.0, 0.5, np.float64(2.0)):
        a, b = line._shc(s), _shc_ref(s)
        assert type(a) is type(b) and a == b


def _tod_ref(law, s_targets, max_iter=200):
    """time_of_distance of a071b70: every element through every step."""
    T = law.T
    lo_s, hi_s = np.minimum(0.0, law.L), np.maximum(0.0, law.L)
    target = np.clip(np.asarray(s_targets, dtype=float), lo_s, hi_s)
    shape = np.broadcast_shapes(target.shape, T.shape)
    target = np.broadcast_to(target, shape)
    sgn = np.where(law.L < 0, -1.0, 1.0)
    lo = np.zeros(shape)
    hi = np.broadcast_to(T, shape).copy()
    with np.errstate(divide="ignore", invalid="ignore"):
        t = lo + (hi - lo) * np.where(law.L != 0, target / law.L, 0.5)
    scale = np.maximum(np.abs(law.L), 1e-300)
    for _ in range(max_iter):
        s, v, _a = law.eval(t, "sv")
        f = sgn * (s - target)
        lo = np.where(f <= 0, t, lo)
        hi = np.where(f >= 0, t, hi)
        done = (np.abs(f) <= 4 * np.finfo(float).eps * scale) | (hi - lo <= 4 * np.finfo(float).eps * T)
        if np.all(done):
            break
        with np.errstate(divide="ignore", invalid="ignore"):
            t_newton = t - f / (sgn * v)
        ok = (sgn * v > 0) & (t_newton > lo) & (t_newton < hi)
        t = np.where(done, t, np.where(ok, t_newton, 0.5 * (lo + hi)))
    return t


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_time_of_distance_rows_same_bits(seed):
    L, T, beta, va, vb = _pieces(seed, 2000)
    rng = np.random.default_rng(seed + 10)
    T = T * 1e3 * L / 300.0                         # moderate speeds: monotone laws mostly
    L[:20] = -L[:20]                                # L < 0 and L = 0 take their own branches
    L[20:25] = 0.0
    beta[25:60] = (T[25:60] / 7.0) ** 2             # γ above the switch
    law = LineLaw(L, T, beta, va * 0.2, vb * 0.2)
    s = L * rng.uniform(-0.1, 1.1, L.size)           # some targets outside [0, L]: clamped
    _same(line.time_of_distance(law, s), _tod_ref(law, s))
    _same(line.time_of_distance(law, s, max_iter=3), _tod_ref(law, s, max_iter=3))
    k = line.time_of_distance(law.expand_dims(), s[:, None] * np.linspace(0, 1, 5))  # 2-D: general loop
    _same(k, _tod_ref(law.expand_dims(), s[:, None] * np.linspace(0, 1, 5)))
