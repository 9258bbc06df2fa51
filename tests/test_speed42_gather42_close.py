"""Session 42 (gather42): FlatLaws.close(pieces=False) makes the chains' figures on the
pieces in the parts' (blocks') order and puts only the figures in chain order
(_block_figures), not gathering every piece column into chain order first: held bit for
bit to the chain-order path (the same close with _block_figures declining), through
solve_flat with one and several active-set steps (one part, several parts)."""
import numpy as np
import pytest

from gcode_opt.laws import chain as chain_law

from chain_cases import synthetic_chains

FIELDS = ("piece_T", "piece_off", "iv", "peak_v", "min_v", "ia", "peak_a", "vert_v", "vert_t", "conv", "lam",
          "bound")


def _solve(probs):
    fl = chain_law._Flat(probs)
    return chain_law.solve_flat(fl, chain_law.cold_binding(fl), np.zeros(fl.sv.size), np.zeros(len(probs), bool),
                                pieces=False)


@pytest.mark.skipif(chain_law.CORE_MOD is None, reason="the chain core is not built")
@pytest.mark.parametrize("iters", [1, 3, 50])
@pytest.mark.parametrize("seed", [1, 4, 9, 13])
def test_block_figures_same_bits(iters, seed, monkeypatch):
    probs = synthetic_chains(60, seed, min_vertices=2, min_cap=10.0)
    monkeypatch.setattr(chain_law, "MAX_ACTIVE_ITERS", iters)
    used = []
    real = chain_law.FlatLaws._block_figures

    def spy(self, *a):
        used.append(real(self, *a))
        return used[-1]

    monkeypatch.setattr(chain_law.FlatLaws, "_block_figures", spy)
    got = _solve(probs)
    assert used == [True]                     # (the blocks' path was taken)
    monkeypatch.setattr(chain_law.FlatLaws, "_block_figures", lambda self, *a: False)
    want = _solve(probs)
    for f in FIELDS:
        a, b = getattr(got, f), getattr(want, f)
        if b is None:
            assert a is None, f
            continue
        a, b = np.asarray(a), np.asarray(b)
        assert a.dtype == b.dtype and a.shape == b.shape, f
        assert np.array_equal(a.view(np.uint8), b.view(np.uint8)), f
