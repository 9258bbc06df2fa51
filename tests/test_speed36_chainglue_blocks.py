"""Issue 8 (s36, chain glue): FlatLaws.take keeps each step's done chains as blocks (chain
numbers and piece counts, not a chain number per piece) and close puts the blocks in
chain order by _block_order, not by a stable argsort of every piece's chain.  These tests
hold the new take/close to the code of 0252e9a (RefFlatLaws: take and close verbatim) bit
for bit, through solve_flat with one and several active-set steps, with and without the
pieces, and _block_order to the argsort it replaces."""
import numpy as np
import pytest

from gcode_opt.laws import chain as chain_law

from chain_cases import synthetic_chains


class RefFlatLaws(chain_law.FlatLaws):
    """FlatLaws with take and close as they stood at 0252e9a (verbatim)."""

    def take(self, st, done, cyc):
        if not done.any():
            return
        if done.all():
            done = dv = pd = slice(None)
        else:
            dv, pd = done[st.rank], done[st.owner]
        vd = st.vi[dv]
        self.vert_v[vd] = st.vert_v[dv]
        self.vert_t[vd] = st.vert_t[dv]
        c = st.active[done]
        self.conv[c] = st.conv[done] & ~cyc[done]
        self.lam[c] = st.lam[done]
        if not self.pieces:
            self._parts.append((st.active[st.owner[pd]], st.L[pd], st.Tj[pd], st.beta[pd], st.va[pd], st.vb[pd]))
            return
        nk = np.diff(st.koff)
        kd = pd if isinstance(pd, slice) else np.repeat(done, nk)
        self._parts.append((st.active[st.owner[pd]], st.L[pd], st.Tj[pd], st.beta[pd], st.va[pd], st.vb[pd],
                            st.a0[pd], st.a1[pd], np.repeat(st.active, nk)[kd], st.ks[kd], st.kv[kd], st.kt[kd]))

    def close(self, bound, pieces=True):
        cat = [np.concatenate(x) for x in zip(*self._parts)]
        del self._parts
        po = np.argsort(cat[0], kind="stable")
        m = self.fl.S.size
        self.poff = np.concatenate([[0], np.cumsum(np.bincount(cat[0], None, m))]).astype(int)
        self.bound = bound
        if not (pieces and self.pieces):
            self.L, self.T, self.beta, self.v0, self.v1 = (x[po] for x in cat[1:6])
            chain_law._flat_figures(self, full=False)
            self.piece_T, self.piece_off = self.T, self.poff
            for f in ("L", "T", "beta", "v0", "v1", "poff"):
                delattr(self, f)
            return
        ko = np.argsort(cat[8], kind="stable")
        self.L, self.T, self.beta, self.v0, self.v1, self.a0, self.a1 = (x[po] for x in cat[1:8])
        self.ks, self.kv, self.kt = (x[ko] for x in cat[9:12])
        self.koff = self.poff + np.arange(m + 1)
        chain_law._flat_figures(self)


def _problems(m, seed):
    return synthetic_chains(m, seed, min_vertices=3, min_cap=12.0)


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
@pytest.mark.parametrize("iters", [1, 2, 50])
@pytest.mark.parametrize("seed", [1, 7])
def test_flat_laws_equal_the_argsort_ones(pieces, iters, seed, monkeypatch):
    probs = _problems(60, seed)
    monkeypatch.setattr(chain_law, "MAX_ACTIVE_ITERS", iters)
    got = _solve(probs, pieces, chain_law.FlatLaws, monkeypatch)
    monkeypatch.setattr(chain_law, "MAX_ACTIVE_ITERS", iters)
    want = _solve(probs, pieces, RefFlatLaws, monkeypatch)
    assert type(want) is RefFlatLaws and type(got) is chain_law.FlatLaws
    for f in FIELDS[pieces] + ("vert_v", "vert_t", "conv", "lam", "bound"):
        a, b = getattr(got, f), getattr(want, f)
        assert a.dtype == b.dtype and np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), f


def test_the_chains_end_at_several_steps(monkeypatch):
    """The case above is the one close reorders: chains taken at different steps."""
    steps = []
    take = chain_law.FlatLaws.take
    monkeypatch.setattr(chain_law.FlatLaws, "take",
                        lambda self, st, done, cyc: (steps.append(int(np.count_nonzero(done))), take(self, st, done, cyc)))
    _solve(_problems(60, 1), False, chain_law.FlatLaws, monkeypatch)
    assert sum(n > 0 for n in steps) >= 3


@pytest.mark.parametrize("seed", range(6))
def test_block_order_is_the_stable_argsort(seed):
    rng = np.random.default_rng(seed)
    m = int(rng.integers(1, 40))
    chains = rng.permutation(m)[:int(rng.integers(0, m + 1))]      # some chains with no block
    counts = rng.integers(0, 6, chains.size)
    order, off = chain_law._block_order(chains, counts, m)
    per_item = np.repeat(chains, counts).astype(np.int64)
    assert np.array_equal(order, np.argsort(per_item, kind="stable"))
    assert np.array_equal(off, np.concatenate([[0], np.cumsum(np.bincount(per_item, None, m))]).astype(int))
