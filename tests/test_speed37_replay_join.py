"""Issue 8 (s37, replay): _laws_of joins the chosen chains' vertex caps by their bytes
(chains._join_d: one bytes.join of ~16 k arrays) where every one is a 1-d array of
numpy's float64, not by np.concatenate (~1.5 k instructions an array); anything else
(another dtype or byte order, 2-d, not contiguous) by np.concatenate.  Held to
np.concatenate bit for bit, dtype and shape, on varied arrays, and the replay's plans to
the knots the candidate table finished (test_speed30's comparison) with it."""
import numpy as np
import pytest

from gcode_opt import chains

from chain_cases import float_bits


def _cases(rng):
    def f8(n):
        return rng.standard_normal(n) * 10.0 ** rng.integers(-8, 8, n)
    yield [f8(int(k)) for k in rng.integers(0, 12, 300)]               # lengths 0.., empty ones among them
    yield [np.array([np.nan, -0.0, np.inf, 5e-324, -np.inf, 0.0])]
    yield [f8(3), f8(0)]
    yield [f8(4), f8(6)[::2], f8(2)]                                     # one not contiguous
    yield [f8(4), f8(3).astype(np.float32)]                              # another dtype
    yield [f8(4).astype(">f8"), f8(2)]                                   # another byte order
    yield [f8(6).reshape(2, 3), f8(3).reshape(1, 3)]                     # 2-d
    yield [np.arange(5), np.arange(3)]                                   # ints


@pytest.mark.parametrize("seed", range(4))
def test_join_d_is_concatenate(seed):
    rng = np.random.default_rng(seed)
    for arrs in _cases(rng):
        want = np.concatenate(arrs)
        got = chains._join_d(arrs)
        assert got.dtype == want.dtype and got.shape == want.shape
        assert got.tobytes() == want.tobytes()


def test_join_d_takes_the_bytes_path_for_doubles():
    rng = np.random.default_rng(7)
    arrs = [rng.standard_normal(int(k)) for k in rng.integers(0, 9, 50)]
    got = chains._join_d(arrs)
    assert not got.flags.writeable                      # (frombuffer of the joined bytes)
    assert float_bits(got) == float_bits(np.concatenate(arrs))
    assert chains._join_d([arrs[0], arrs[1][::-1]]).flags.writeable     # not contiguous: concatenate
