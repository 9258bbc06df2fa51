"""laws/line.py's _shc and _atanhc (most of the run's np.where elements: the chains' figures
and the lines' interior speeds call them on arrays of every law) patch the elements that are
not their quotient by masked stores instead of np.where (session 41).  The np.where forms
they replace are the reference here (copied from d0fd8ab): the same bits on arrays with and
without zeros, signed zeros, |r| >= 1, ±inf, NaN, 0-d, 2-d and strided inputs."""
import warnings

import numpy as np
import pytest

from gcode_opt.laws.line import _atanhc, _shc


def _shc_ref(z):
    z = np.asarray(z, dtype=float)
    zero = z == 0.0
    if z.ndim and not zero.any():
        return np.sinh(z) / z
    safe = np.where(zero, 1.0, z)
    return np.where(zero, 1.0, np.sinh(safe) / safe)


def _atanhc_ref(r):
    r = np.asarray(r, dtype=float)
    inside = np.abs(r) < 1
    rs = np.where(inside & (r != 0), r, 0.5)
    return np.where(r == 0, 1.0, np.where(inside, np.arctanh(rs) / rs, np.inf))


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and np.array_equal(a.view(np.int64), b.view(np.int64))


def _cases(rng, wide):
    """Varied arrays: dense random, sparse and dense zeros, specials, every length 0 .. 40."""
    out = []
    specials = np.array([0.0, -0.0, np.inf, -np.inf, np.nan, 1.0, -1.0, 1.5, -2.0, 5e-324, -5e-324,
                         1e-300, 0.999999999, -0.9999999999999999, 710.0, -711.0, 1e-8])
    for n in list(range(0, 41)) + [257, 1000, 4099]:
        x = rng.uniform(-wide, wide, n) * np.exp(rng.uniform(-30.0, 0.0, n))
        out.append(x)
        for p in (0.01, 0.3, 0.9):
            y = x.copy()
            y[rng.random(n) < p] = 0.0
            out.append(y)
            z = y.copy()
            put = rng.random(n) < p
            z[put] = rng.choice(specials, n)[put]
            out.append(z)
    out.append(specials)
    out.append(-specials)
    out.append(np.zeros(7))
    out.append(np.full(5, -0.0))
    return out


@pytest.mark.parametrize("fn, ref, wide", [(_shc, _shc_ref, 30.0), (_atanhc, _atanhc_ref, 1.2)])
def test_same_bits_as_np_where_forms(fn, ref, wide):
    rng = np.random.default_rng(41)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        with np.errstate(all="ignore"):
            for x in _cases(rng, wide):
                assert _same(fn(x), ref(x)), x
                big = np.tile(x, 3)
                assert _same(fn(big[::3]), ref(big[::3])), x            # strided
                if x.size and x.size % 2 == 0:
                    m = x.reshape(2, -1)
                    assert _same(fn(m), ref(m)), x                      # 2-d
                    assert _same(fn(m.T), ref(m.T)), x                  # 2-d, not C-contiguous
                for v in x[:8].tolist():                                # 0-d
                    assert _same(fn(v), ref(v)), v
                    assert _same(fn(np.float64(v)), ref(np.float64(v))), v


def test_input_not_written():
    r = np.array([0.0, 0.5, 2.0, -0.0, np.nan, 0.25])
    keep = r.copy()
    with np.errstate(all="ignore"):
        _atanhc(r)
        _shc(r)
    assert _same(r, keep)
