"""Pseudo-random draws for the run-time probes that check a compiled kernel or BLAS gives
numpy's bits (firmware/resonance.py, laws/circle.py): the probes' points only need to be
spread and repeatable.  numpy.random would cost its import (~10 ms, most of a small file's
run-time probes) on every run; a SplitMix64 stream in numpy integer arithmetic does not."""
from __future__ import annotations

import numpy as np

_GAMMA = np.uint64(0x9E3779B97F4A7C15)
_M1, _M2 = np.uint64(0xBF58476D1CE4E5B9), np.uint64(0x94D049BB133111EB)
_S30, _S27, _S31, _S11 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(11)


class Draws:
    """draws = Draws(seed): .uniform(lo, hi, size), .normal(size), .exponential(scale, size),
    as numpy.random.Generator's calls read (the numbers differ)."""

    def __init__(self, seed: int):
        self._state = np.uint64(seed & 0xFFFFFFFFFFFFFFFF)

    def _u64(self, n):
        with np.errstate(over="ignore"):
            z = self._state + _GAMMA * np.arange(1, n + 1, dtype=np.uint64)
            self._state = z[-1] if n else self._state
            z = (z ^ (z >> _S30)) * _M1
            z = (z ^ (z >> _S27)) * _M2
            return z ^ (z >> _S31)

    def _unit(self, size):
        """Uniform in [0, 1), 53 bits."""
        n = int(np.prod(size)) if np.ndim(size) else int(size)
        return ((self._u64(n) >> _S11).astype(np.float64) * 2.0 ** -53).reshape(size)

    def uniform(self, low=0.0, high=1.0, size=1):
        return low + (high - low) * self._unit(size)

    def normal(self, size=1):
        """Box-Muller on two uniform streams."""
        u1 = 1.0 - self._unit(size)            # in (0, 1]: log is finite
        u2 = self._unit(size)
        return np.sqrt(-2.0 * np.log(u1)) * np.cos(2.0 * np.pi * u2)

    def exponential(self, scale=1.0, size=1):
        return -scale * np.log(1.0 - self._unit(size))
