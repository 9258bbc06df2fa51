"""ProbeRng.randoms by blocks of slices (session 39b) and uniform's shortcut for the unit
interval against the definitions they replace: the loop of k random(n) a size, and
low + (high - low) * random(size) -- the same numbers, bit for bit, and the same state after."""
import numpy as np
import pytest

from gcode_opt.probe_rng import ProbeRng


def _loop(seed, sizes, k):
    """randoms' definition: for each n of sizes in turn, k random(n); the j-th draws of
    all sizes one after the other."""
    rng = ProbeRng(seed)
    out = [[] for _ in range(k)]
    for n in sizes:
        for j in range(k):
            out[j].append(rng.random(n))
    return [np.concatenate(x) if x else np.zeros(0) for x in out], rng


def _size_lists():
    gen = np.random.default_rng(39)
    yield (0,)
    yield (1,)
    yield (0, 0, 3)
    yield (2, 1, 2, 1)
    yield (4097, 5003, 20011)
    for _ in range(6):          # varied lists: odd and even, zeros, small and large
        yield tuple(int(x) for x in gen.choice([0, 1, 2, 3, 7, 8, 9, 127, 128, 129, 1000, 4097],
                                               int(gen.integers(1, 30))))


@pytest.mark.parametrize("sizes", list(_size_lists()))
@pytest.mark.parametrize("k", [1, 2, 3, 8])
def test_randoms_are_the_loop(sizes, k):
    for seed in (0, 13, 2 ** 40 + 7):
        want, rng_loop = _loop(seed, sizes, k)
        rng = ProbeRng(seed)
        got = rng.randoms(sizes, k)
        assert len(got) == k
        for g, w in zip(got, want):
            assert g.dtype == np.float64 and g.shape == w.shape and g.tobytes() == w.tobytes()
        assert rng.random(5).tobytes() == rng_loop.random(5).tobytes()


def _formula(rng, low, high, size):
    u = rng.random(size)
    return low + (high - low) * u


@pytest.mark.parametrize("low,high", [(0.0, 1.0), (-0.0, 1.0), (0, 1), (0.0, 2.0), (-1.0, 1.0),
                                      (np.float64(0.0), np.float64(1.0))])
@pytest.mark.parametrize("size", [None, 1, 2, 7, 4000, (3, 5), (1, 32, 21)])
def test_uniform_is_the_formula(low, high, size):
    a, b = ProbeRng(11), ProbeRng(11)
    for _ in range(3):
        got, want = a.uniform(low, high, size), _formula(b, low, high, size)
        assert type(got) is type(want) and np.shape(got) == np.shape(want)
        assert np.asarray(got).dtype == np.asarray(want).dtype
        assert np.asarray(got).tobytes() == np.asarray(want).tobytes()


def test_uniform_of_unit_keeps_the_bits_of_randoms_rows():
    rng = ProbeRng(5)
    for u in rng.randoms((1, 9, 128, 3), 4):
        assert ProbeRng.uniform_of(u).tobytes() == (0.0 + (1.0 - 0.0) * u).tobytes()
        assert ProbeRng.uniform_of(u, 0.0, 1.0).tobytes() == (0.0 + 1.0 * u).tobytes()


def _normal_formula(rng, loc, scale, size):
    u = rng.random(size)
    return loc + scale * 0.5513288954217921 * np.log(u / (1.0 - u))


@pytest.mark.parametrize("loc,scale", [(0.0, 1.0), (-0.0, 1.0), (0.0, 3.5), (0.0, -1.0), (0, 1),
                                       (1.5, 1.0), (np.float64(0.0), 1.0)])
@pytest.mark.parametrize("size", [None, 1, 7, 20000, (3, 5)])
def test_normal_is_the_formula(loc, scale, size):
    a, b = ProbeRng(19), ProbeRng(19)
    for _ in range(3):
        got, want = a.normal(loc, scale, size), _normal_formula(b, loc, scale, size)
        assert type(got) is type(want) and np.shape(got) == np.shape(want)
        assert np.asarray(got).dtype == np.asarray(want).dtype
        assert np.asarray(got).tobytes() == np.asarray(want).tobytes()


def test_normal_of_edges_keep_the_bits():
    # the unit interval's ends as _unit makes them, and numbers by 1/2 (x near 0)
    u = np.array([0.5 / 2 ** 32, 1.0 - 0.5 / 2 ** 32, 0.5 - 0.5 / 2 ** 32, 0.5 + 0.5 / 2 ** 32,
                  0.5 - 2.0 ** -53, 0.5 + 2.0 ** -52, 0.25, 0.75])
    for scale in (1.0, 2.0 ** -1074 * 2 ** 60, 1e300):
        assert ProbeRng.normal_of(u, 0.0, scale).tobytes() == \
            (0.0 + scale * 0.5513288954217921 * np.log(u / (1.0 - u))).tobytes()
