"""Issue 8 (chains, round 3): laws/line._horner_nms sums only the terms of the (n, m, S1)
series its batch needs (_nms_terms); the values are those of all 24 terms (the form it
replaced, written out here), bit for bit, on a million γ² over the small branch's whole
range and on the chains' range (γ <= 0.1), and the line law's integrals with them."""
import numpy as np
import pytest

from gcode_opt.laws import line
from gcode_opt.laws.line import _NMS_COEF, _NTERMS, LineLaw


def _full(z2):
    out = np.empty((3,) + z2.shape)
    out[...] = _NMS_COEF[-1].reshape(3, 1)
    for c in _NMS_COEF[-2::-1]:
        np.multiply(out, z2, out=out)
        np.add(out, c.reshape(3, 1), out=out)
    return out


@pytest.mark.parametrize("zmax", [1e-6, 1e-4, 0.01, 0.3, 2.0, 16.0])
def test_fewer_terms_same_bits(zmax):
    rng = np.random.default_rng(int(zmax * 1e6) % 1000)
    z2 = np.concatenate([[zmax, 0.0], zmax * rng.random(200_000) ** rng.uniform(0.2, 3.0)])
    n, m, s1 = line._horner_nms(z2)
    want = _full(z2)
    assert line._nms_terms(z2) < _NTERMS           # the shortcut was taken
    for got, w in zip((n, m, s1), want):
        assert got.tobytes() == w.tobytes()


def test_term_count_grows_with_gamma_and_nan_takes_all():
    ks = [line._nms_terms(np.array([z])) for z in (0.0, 1e-4, 0.01, 1.0, 16.0)]
    assert ks == sorted(ks) and ks[0] == 1 and ks[2] <= 8
    assert line._nms_terms(np.array([0.01, np.nan])) == _NTERMS
    assert line._nms_terms(np.array([])) == _NTERMS


def test_chain_piece_integrals_same_bits(monkeypatch):
    """Line-law integrals of chain-like pieces (γ <= 0.1) with the shortcut and without."""
    rng = np.random.default_rng(7)
    T = rng.uniform(0.005, 0.2, 100_000)
    beta = (T / rng.uniform(0.0, 0.1, T.size).clip(1e-6)) ** 2
    args = (rng.uniform(0.1, 5.0, T.size), T, beta, rng.uniform(0, 80, T.size), rng.uniform(0, 80, T.size))
    got = LineLaw(*args).integrals()
    monkeypatch.setattr(line, "_nms_terms", lambda z2: _NTERMS)
    want = LineLaw(*args).integrals()
    for a, b in zip(got, want):
        assert a.tobytes() == b.tobytes()


def test_s1_fewer_terms_same_bits():
    rng = np.random.default_rng(11)
    for zmax in (0.05, 0.5, 2.0):
        z = np.concatenate([[zmax, -zmax, 0.0], zmax * rng.uniform(-1, 1, 200_000)])
        want = np.full(z.shape, _NMS_COEF[-1, 2])
        for c in _NMS_COEF[-2::-1, 2]:
            want = want * (z * z) + c
        got = line._s1(z)
        assert line._nms_terms(z * z, line._S1_ZMAX) < _NTERMS
        assert got.tobytes() == want.tobytes()


@pytest.mark.parametrize("gamma", [0.0, 0.01, 0.1, 3.99, 4.0, 50.0, "mixed"])
def test_end_accels_are_evals_bits(gamma):
    """LineLaw.end_accels (closed-form g'(0), h'(0)) gives eval(0 / T, "a")'s bits, in
    either γ branch and in a batch of both."""
    rng = np.random.default_rng(3)
    n = 5000
    T = rng.uniform(0.003, 0.2, n)
    if gamma == "mixed":
        beta = (T / rng.uniform(0.0, 12.0, n)) ** 2
    else:
        beta = np.full(n, np.inf) if gamma == 0.0 else (T / gamma) ** 2
    law = LineLaw(rng.uniform(0.05, 5.0, n), T, beta, rng.uniform(0, 90, n), rng.uniform(0, 90, n))
    a0, a1 = law.end_accels()
    assert a0.tobytes() == law.eval(np.zeros(n), "a")[2].tobytes()
    assert a1.tobytes() == law.eval(T, "a")[2].tobytes()
