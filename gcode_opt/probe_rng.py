"""Deterministic pseudo-random draws for the bit probes (chains, curves, laws.circle,
firmware.resonance check once per run that a compiled loop gives numpy's bits on varied
numbers).  The probes need varied numbers, not a statistical generator: importing
numpy.random for them loaded it, `secrets`, `hmac` and hashlib's OpenSSL into every run
(~6.3 MB resident, ~40 M instructions).  SplitMix64 over a counter, in numpy uint64
arithmetic (wrapping); the methods the probes call, with numpy's names (normal is a
bell-shaped stand-in: see there)."""
from __future__ import annotations

import numpy as np

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)


class ProbeRng:
    """rng = ProbeRng(seed): rng.uniform(low, high, size), rng.normal(size=),
    rng.exponential(scale, size), rng.lognormal(mean, sigma, size), rng.choice(a, size),
    as numpy's Generator names them (other numbers: the same seed gives the same draws
    here on every machine)."""

    def __init__(self, seed: int):
        self._next = (np.array([seed], np.uint64) * _GOLDEN)[0]     # (arrays wrap without a warning)

    def _bits(self, n: int):
        """n 64-bit words: SplitMix64's output for the next n counters (in place: the
        probes draw ~10^6 numbers a run)."""
        z = np.arange(1, n + 1, dtype=np.uint64)
        z *= _GOLDEN
        z += self._next
        self._next = z[-1] if n else self._next
        for shift, mul in ((30, _M1), (27, _M2)):
            z ^= z >> np.uint64(shift)
            z *= mul
        z ^= z >> np.uint64(31)
        return z

    def random(self, size):
        """Uniform on (0, 1): 32 random bits and a half each, two from each 64-bit word
        (never 0: normal's logarithm; the probes need spread, not 53-bit resolution)."""
        shape = () if size is None else size
        n = int(np.prod(shape))
        return _unit(self._bits((n + 1) // 2).view(np.uint32)[:n]).reshape(shape)

    def randoms(self, sizes, k: int):
        """The draws of a loop that, for each n of sizes in turn, takes k random(n): k
        arrays, the j-th the j-th draws of all sizes one after the other -- the same numbers
        (and the same state after), from one _bits call and a few whole-array steps instead
        of k numpy calls a size (a probe over many small sizes: ~0.1 M instructions a
        call).  With normal_of, uniform_of, exponential_of: the loop's other draws."""
        n = np.asarray(sizes, np.intp)
        w = (n + 1) // 2                              # each draw's 64-bit words
        bits = self._bits(int(k * w.sum())).view(np.uint32)
        # size i's k draws: its block of k w_i words, (k, 2 w_i) 32-bit words, each row's
        # first n_i; the blocks side by side (copies of slices: a gather of every number
        # with a computed index was ~5 M instructions more on _int_r2_probe's 0.3 M)
        ends = np.cumsum(2 * k * w).tolist()
        blocks = [bits[e - 2 * k * wi:e].reshape(k, 2 * wi)[:, :ni]
                  for e, wi, ni in zip(ends, w.tolist(), n.tolist())]
        rows = np.concatenate(blocks, axis=1) if blocks else np.zeros((k, 0), np.uint32)
        return list(_unit(rows))

    def uniform(self, low=0.0, high=1.0, size=None):
        return self.uniform_of(self.random(size), low, high)

    def normal(self, loc=0.0, scale=1.0, size=None):
        """A logistic draw scaled to unit variance (log(u / (1 - u)) sqrt(3) / pi): bell-shaped
        like numpy's normal, with heavier tails, at one logarithm a number (the probes need
        numbers spread over many magnitudes, not a normal law)."""
        return self.normal_of(self.random(size), loc, scale)

    def exponential(self, scale=1.0, size=None):
        return self.exponential_of(self.random(size), scale)

    # the draws of uniform, normal and exponential from random's u (randoms' arrays)
    @staticmethod
    def uniform_of(u, low=0.0, high=1.0):
        if type(low) is float and type(high) is float and low == 0.0 and high == 1.0 \
                and type(u) is np.ndarray and u.ndim:
            return u            # 0 + 1 u is u's bits (u in (0, 1)): two passes fewer a mask
        return low + (high - low) * u

    @staticmethod
    def normal_of(u, loc=0.0, scale=1.0):
        x = scale * 0.5513288954217921 * np.log(u / (1.0 - u))
        if type(loc) is float and type(scale) is float and loc == 0.0 and scale > 0.0 \
                and type(u) is np.ndarray and u.ndim:
            # 0 + x is x's bits: x is never -0.0 (log of u / (1 - u) > 0 is not; u is never
            # 1/2), and a pass fewer a draw
            return x
        return loc + x

    @staticmethod
    def exponential_of(u, scale=1.0):
        return -scale * np.log1p(-u)

    def lognormal(self, mean=0.0, sigma=1.0, size=None):
        return np.exp(self.normal(mean, sigma, size))

    def choice(self, a, size):
        a = np.asarray(a)
        return a[(self.random(size) * a.size).astype(np.intp)]


def _unit(u32):
    """random's numbers of 32-bit words: (u + 0.5) / 2^32."""
    u = u32.astype(np.float64)
    u += 0.5
    u *= 1.0 / 4294967296.0
    return u
