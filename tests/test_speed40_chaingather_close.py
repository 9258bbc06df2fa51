"""FlatLaws.close gathers the pieces and knots into chain order by take (numpy's plain
gather loop), not by indexing x[po]: held bit for bit to close as it stood at acdb7af
(RefFlatLaws.close verbatim), through solve_flat with one and several active-set steps,
with and without the pieces."""
import numpy as np
import pytest

from gcode_opt.laws import chain as chain_law

from chain_cases import synthetic_chains


class RefFlatLaws(chain_law.FlatLaws):
    """FlatLaws with close as it stood at acdb7af (verbatim)."""

    def close(self, bound, pieces=True):
        cat = [np.concatenate(x) for x in zip(*self._parts)]
        del self._parts
        m = self.fl.S.size
        chains, npc = cat[0], cat[1]
        po, self.poff = chain_law._block_order(chains, npc, m)
        self.bound = bound
        if not (pieces and self.pieces):
            self.L, self.T, self.beta, self.v0, self.v1 = (x[po] for x in cat[2:7])
            chain_law._flat_figures(self, full=False)
            self.piece_T, self.piece_off = self.T, self.poff
            for f in ("L", "T", "beta", "v0", "v1", "poff"):
                delattr(self, f)
            return
        self.L, self.T, self.beta, self.v0, self.v1, self.a0, self.a1 = (x[po] for x in cat[2:9])
        ko, self.koff = chain_law._block_order(chains, npc + 1, m)
        self.ks, self.kv, self.kt = (x[ko] for x in cat[9:12])
        chain_law._flat_figures(self)


def _solve(probs, pieces, cls, monkeypatch):
    monkeypatch.setattr(chain_law, "FlatLaws", cls)
    fl = chain_law._Flat(probs)
    res = chain_law.solve_flat(fl, chain_law.cold_binding(fl), np.zeros(fl.sv.size), np.zeros(len(probs), bool),
                               pieces=pieces)
    monkeypatch.undo()
    return res


FIELDS = {True: ("L", "T", "beta", "v0", "v1", "a0", "a1", "ks", "kv", "kt", "poff", "koff", "iv", "ia",
                 "peak_v", "min_v", "peak_a"),
          False: ("piece_T", "piece_off", "iv", "peak_v", "min_v")}


@pytest.mark.parametrize("pieces", [True, False])
@pytest.mark.parametrize("iters", [1, 3, 50])
@pytest.mark.parametrize("seed", [2, 5, 11])
def test_close_same_bits(pieces, iters, seed, monkeypatch):
    probs = synthetic_chains(50, seed, min_vertices=2, min_cap=10.0)
    monkeypatch.setattr(chain_law, "MAX_ACTIVE_ITERS", iters)
    got = _solve(probs, pieces, chain_law.FlatLaws, monkeypatch)
    monkeypatch.setattr(chain_law, "MAX_ACTIVE_ITERS", iters)
    want = _solve(probs, pieces, RefFlatLaws, monkeypatch)
    assert type(want) is RefFlatLaws and type(got) is chain_law.FlatLaws
    for f in FIELDS[pieces] + ("vert_v", "vert_t", "conv", "lam", "bound"):
        a, b = np.asarray(getattr(got, f)), np.asarray(getattr(want, f))
        assert a.dtype == b.dtype and a.shape == b.shape, f
        assert np.array_equal(a.view(np.uint8), b.view(np.uint8)), f
