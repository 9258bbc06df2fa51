"""_Flat._fixed_knots: the pieces' weights gathered by take (beta.take(active).take(owner))
are the bits of the indexing it replaced (beta[active][owner]), on varied chains and
active subsets, by the core's knots and numpy's."""
import numpy as np
import pytest

from gcode_opt.laws import chain as chain_law

from chain_cases import synthetic_chains


@pytest.mark.parametrize("core", [True, False])
@pytest.mark.parametrize("seed", [3, 4, 9])
def test_fixed_knots_beta_same_bits(seed, core, monkeypatch):
    if not core:
        monkeypatch.setattr(chain_law, "CORE_MOD", None)
    rng = np.random.default_rng(seed)
    probs = synthetic_chains(40, seed, min_vertices=2, min_cap=10.0)
    fl = chain_law._Flat(probs)
    fl.beta = rng.random(fl.S.size) * 5.0          # distinct weights: a wrong chain shows
    m = fl.S.size
    for p in (1.0, 0.5, 0.2):
        active = np.flatnonzero(rng.random(m) < p)
        if active.size == 0:
            active = np.array([m - 1])
        bound = rng.random(fl.sv.size) < 0.3
        pre = fl._fixed_knots(active, bound, np.zeros(fl.sv.size), np.zeros(m, bool))
        kn, beta = pre[5], pre[6]
        want = fl.beta[active][kn[4]]
        assert beta.dtype == want.dtype and beta.shape == want.shape
        assert np.array_equal(beta.view(np.uint8), want.view(np.uint8))
