"""_Flat.take: the kept chains' vertices copied as whole runs (_blocks) are the bits of the
index gather it replaced (sv[vs], cv[vs] with vs the kept chains' vertex indices)."""
import numpy as np
import pytest

from gcode_opt.laws import chain


def _reference(fl, keep):
    keep = np.asarray(keep, np.int64)
    vs = np.repeat(fl.voff[keep] - np.concatenate([[0], np.cumsum(fl.nv[keep])[:-1]]), fl.nv[keep])
    vs = vs + np.arange(int(fl.nv[keep].sum()))
    return (fl.sv[vs], fl.cv[vs], fl.nv[keep], fl.S[keep], fl.T[keep], fl.beta[keep], fl.v0[keep], fl.v1[keep])


def _flat(rng, m):
    nv = rng.integers(1, 7, m)              # (a chain has a vertex at least)
    n = int(nv.sum())
    r = lambda k: rng.random(k) * 10.0
    return chain._Flat.of_arrays(r(n), r(n), nv, r(m) + 1.0, r(m) + 1.0, r(m), r(m), r(m))


@pytest.mark.parametrize("seed", range(12))
def test_take_same_bits(seed):
    rng = np.random.default_rng(seed)
    m = int(rng.integers(1, 40))
    fl = _flat(rng, m)
    for keep in (np.flatnonzero(rng.random(m) < p) for p in (0.0, 0.3, 0.7, 1.0)):
        keep = keep if keep.size else np.zeros(0, np.int64)
        for ks in (keep, list(keep), keep[::-1], np.concatenate([keep, keep[:1]])):   # not ascending: the index path
            got = fl.take(ks)
            want = _reference(fl, ks)
            for g, w in zip((got.sv, got.cv, got.nv, got.S, got.T, got.beta, got.v0, got.v1), want):
                assert g.dtype == w.dtype and g.shape == w.shape
                assert np.array_equal(g.view(np.uint8), w.view(np.uint8))
            assert np.array_equal(got.voff, np.concatenate([[0], np.cumsum(want[2])]))
