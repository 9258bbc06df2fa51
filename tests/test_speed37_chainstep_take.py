"""Issue 8 (s37, chainstep): solve_flat's step without the per-step mask gathers.

- active_step reads the step's binding masks in hist[-1] (bv None) instead of the caller's
  gather bound[vi], and writes the done chains' vertex speeds and times into FlatLaws'
  vert_v, vert_t itself (FlatLaws.take(verts=False) then gathers no vertex);
- FlatLaws.take copies the done chains' pieces and knots as blocks (_blocks: take_blocks,
  whole runs) instead of boolean masks over them.

Held bit for bit to the code they replace: active_step with the gathered bv and no vertex
outputs, every step of real and random chains; FlatLaws.take as it stood at 2bec3b7
(verbatim, OldTake); _blocks to the mask x[np.repeat(done, np.diff(off))]."""
import numpy as np
import pytest

from gcode_opt.laws import chain as lc

from test_speed21_chainsolve_core import _flats  # noqa: E402
from test_speed36_chainglue_blocks import _problems  # noqa: E402

needs_core = pytest.mark.skipif(lc.CORE_MOD is None, reason=f"the chain core is not used here ({lc.CORE_WHY})")


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


class OldTake(lc.FlatLaws):
    """FlatLaws with take as it stood at 2bec3b7 (verbatim)."""

    def take(self, st, done, cyc):
        if not done.any():
            return
        if done.all():              # (a batch's last step: every array whole, not masked)
            done = dv = pd = slice(None)
        else:
            dv, pd = done[st.rank], done[st.owner]
        vd = st.vi[dv]              # (one mask gather for both)
        self.vert_v[vd] = st.vert_v[dv]
        self.vert_t[vd] = st.vert_t[dv]
        c = st.active[done]
        self.conv[c] = st.conv[done] & ~cyc[done]
        self.lam[c] = st.lam[done]
        npc = np.diff(st.koff)[done] - 1          # pieces per chain: its knots - 1
        if not self.pieces:
            self._parts.append((c, npc, st.L[pd], st.Tj[pd], st.beta[pd], st.va[pd], st.vb[pd]))
            return
        kd = pd if isinstance(pd, slice) else np.repeat(done, np.diff(st.koff))
        self._parts.append((c, npc, st.L[pd], st.Tj[pd], st.beta[pd], st.va[pd], st.vb[pd],
                            st.a0[pd], st.a1[pd], st.ks[kd], st.kv[kd], st.kt[kd]))


FIELDS = {True: ("L", "T", "beta", "v0", "v1", "a0", "a1", "ks", "kv", "kt", "poff", "koff", "iv", "ia",
                 "peak_v", "min_v", "peak_a"),
          False: ("piece_T", "piece_off", "iv", "peak_v", "min_v")}


def _solve(fl, bound, vt, warm, pieces, cls, monkeypatch):
    monkeypatch.setattr(lc, "FlatLaws", cls)
    res = lc.solve_flat(fl, bound.copy(), vt.copy(), warm.copy(), pieces=pieces)
    monkeypatch.undo()
    assert type(res) is cls
    return res


def _cases():
    out = []
    for seed in (1, 7):
        fl = lc._Flat(_problems(60, seed))
        out.append((fl, lc.cold_binding(fl), np.zeros(fl.sv.size), np.zeros(fl.S.size, bool)))
    return out


@needs_core
@pytest.mark.parametrize("iters", [1, 2, 50])
@pytest.mark.parametrize("pieces", [True, False])
def test_solve_flat_equals_the_old_take(pieces, iters, monkeypatch):
    """The new take (vertices by active_step, blocks) and the 2bec3b7 take (the vertices and
    pieces by masks; active_step then writes no vertex): the same laws and figures."""
    cases = _cases() + ([c for prof in ("prusa-mk3s",) for c in _flats(prof)] if iters == 50 else [])
    for fl, b, vt, w in cases:
        monkeypatch.setattr(lc, "MAX_ACTIVE_ITERS", iters)
        got = _solve(fl, b, vt, w, pieces, lc.FlatLaws, monkeypatch)
        monkeypatch.setattr(lc, "MAX_ACTIVE_ITERS", iters)
        want = _solve(fl, b, vt, w, pieces, OldTake, monkeypatch)
        for f in FIELDS[pieces] + ("vert_v", "vert_t", "conv", "lam", "bound"):
            assert _same(getattr(got, f), getattr(want, f)), f


@needs_core
def test_active_step_reads_bv_in_hist(monkeypatch):
    """Every active_step call of real and random solves, run again with bv gathered
    (bound[vi], the old call) and no vertex outputs: the same masks, done, cyc, bound, vt,
    warm; the vertex outputs are the done chains' vert_v, vert_t, nothing else touched."""
    core = lc.CORE_MOD
    calls = []

    class Spy:
        def __getattr__(self, name):
            return getattr(core, name)

        def active_step(self, *a):
            a = list(a)
            hist = a[9]
            assert a[2] is None
            old = list(a)
            old[2] = np.ascontiguousarray(hist[-1][a[0]]).view(np.uint8)    # the old bound[st.vi]
            old[13:17] = [x.copy() for x in a[13:17]]                        # new, done, cyc, bound
            old[17] = a[17].copy()                                           # vt
            old[19] = a[19].copy()                                           # warm
            old = old[:21]                                                   # no vertex outputs
            rv0, rt0 = (None, None) if len(a) < 23 or a[21] is None else (a[21].copy(), a[22].copy())
            core.active_step(*old)
            out = core.active_step(*a)
            for i in (13, 14, 15, 16, 17, 19):
                assert _same(a[i], old[i]), i
            if rv0 is not None:
                done = a[14].view(bool)
                dv = np.repeat(done, np.diff(a[1]))
                ev, et = rv0.copy(), rt0.copy()
                ev[a[0][dv]] = a[3][dv]
                et[a[0][dv]] = a[18][dv]
                assert _same(a[21], ev) and _same(a[22], et)
            calls.append(int(np.count_nonzero(a[14])))
            return out
    monkeypatch.setattr(lc, "CORE_MOD", Spy())
    for fl, b, vt, w in _cases() + _flats("voron24"):
        lc.solve_flat(fl, b.copy(), vt.copy(), w.copy())
    assert len(calls) >= 10 and sum(0 < n for n in calls) >= 5


@needs_core
@pytest.mark.parametrize("seed", range(8))
def test_blocks_are_the_mask(seed):
    """_blocks (take_blocks' runs) and the boolean mask it replaces: the same items."""
    rng = np.random.default_rng(seed)
    na = int(rng.integers(0, 30))
    sizes = rng.integers(0 if seed % 2 else 1, 6, na)
    off = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    done = rng.random(na) < [0.0, 1.0, 0.5, 0.2, 0.8, 0.5, 0.5, 0.5][seed]
    arrays = tuple(rng.standard_normal(int(off[-1])) for _ in range(int(rng.integers(1, 8))))
    mask = np.repeat(done, sizes)
    got = lc._blocks(arrays, off, done, int(mask.sum()))
    assert len(got) == len(arrays)
    for g, x in zip(got, arrays):
        assert _same(g, x[mask])


@needs_core
def test_take_blocks_refuses_bad_shapes():
    core = lc.CORE_MOD
    off = np.array([0, 2, 5], np.int64)
    done = np.array([1, 0], np.uint8)
    x = np.arange(5.0)
    with pytest.raises(ValueError):
        core.take_blocks(off, done, (x,), (np.empty(3),))        # 2 items are taken, not 3
    with pytest.raises(ValueError):
        core.take_blocks(off, done, (x[:4],), (np.empty(2),))    # off[-1] items
    with pytest.raises(TypeError):
        core.take_blocks(off, done, [x], [np.empty(2)])
    out = np.empty(2)
    core.take_blocks(off, done, (x,), (out,))
    assert out.tolist() == [0.0, 1.0]
