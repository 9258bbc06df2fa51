"""Issue 8 (s32, chainplan): the chains' segment planning with less per-chain Python, the
same bits.  Each new piece is held to the code it replaced (kept here verbatim from
e9d4ed5) on real chains of the sample files, under classic jerk (prusa-mk3s) and Klipper
SCV (voron24):

  ChainMemo.ask      law_T / law_of / _find and plan_of in one call, against those
                     functions and plan_chain_segments' old tests around them, on real
                     memos and on memos whose rows repeat a duration in another column;
  curves.seg_counts  against g.d.size (and a geometry of another make);
  _inner_s_stacked   against _inner_s, bit for bit;
  _laws_of           rows grouped by their base with numpy, against the dict of lists;
  _knots_again       chains of the same solve inputs solved once, against solving each.

(plan_chain_segments as a whole: tests/test_speed24_chainplan_batch.py, against its
verbatim reference over three budget runs.)"""

import numpy as np
import pytest

from gcode_opt import chains, curves

from chain_cases import fresh_chains, float_bits

CASES = [("sample_gcode/prusa_gyroid_fullspeed.gcode", "prusa-mk3s"),
         ("sample_gcode/prusa_gyroid_fullspeed_klipper.gcode", "voron24")]


def _tabled(path, prof_name):
    """Fresh chains of the sample with their candidate table made (memos filled)."""
    strokes, pin, rows, prof, rules = fresh_chains(path, prof_name)
    T, beta, I, _ = chains.candidates_chain(pin, rows, strokes, prof, rules)
    return strokes, pin, rows, prof, rules, T, beta, I


# ---------------------------------------------------------------- ChainMemo.ask
def ref_ask(st, t, b, key):
    """plan_chain_segments' look-up at e9d4ed5: its first loop, then plan_of for a chain
    its last plan does not serve (verbatim but for the names)."""
    memo = st.chain_T
    seg = memo.seg
    if seg is not None and memo.seg_tin == t:
        lt = memo.seg_T
    else:
        lt = chains.law_T(st, t)
    if seg is not None and memo.seg_T == lt and memo.seg_beta == b and memo.seg_key == key:
        return lt, seg, None
    return lt, None, memo.plan_of(lt, b)


def _same_answer(got, want):
    lt, seg, hit = got
    wlt, wseg, whit = want
    return (float_bits(lt) == float_bits(wlt) and seg is wseg
            and (hit is None) == (whit is None) and (hit is None or (hit[0] is whit[0] and hit[1] == whit[1])))


@pytest.mark.parametrize("path,prof_name", CASES)
def test_ask_as_law_T_and_plan_of(path, prof_name):
    strokes, pin, rows, prof, rules, T, beta, I = _tabled(path, prof_name)
    key = chains._rules_key(rules, prof)
    ok = np.isfinite(I)
    n = 0
    for j, i in enumerate(rows.tolist()):
        st = strokes[i]
        qs = [(float(T[j, c]), float(beta[j, c])) for c in np.flatnonzero(ok[j]).tolist()]
        qs += [(float(T[j, 0]) * 1.013, float(beta[j, 0])), (float(pin.T_orig[i]), 1.0)]
        for t, b in qs:
            for seg_state in range(4):
                memo = st.chain_T
                memo.seg = memo.seg_T = memo.seg_beta = memo.seg_key = memo.seg_tin = None
                if seg_state:             # a last plan: for this t, for its law, for another key
                    memo.seg = object()
                    memo.seg_T, memo.seg_beta, memo.seg_key = memo.law_of(t), b, key if seg_state < 3 else "x"
                    memo.seg_tin = t if seg_state == 1 else t * 2
                assert _same_answer(memo.ask(t, b, key), ref_ask(st, t, b, key))
                n += 1
        st.chain_T.seg = None
    assert n > 1000


def test_ask_on_rows_repeating_a_duration_in_another_column():
    """figs.index finds the duration first as another row's law T or beta: the newest
    row whose predicted time it is gives the law T (law_of), then the newest row of that
    (T, beta) the plan (plan_of), not the first one found."""
    memo = chains.ChainMemo()
    kept = [object() for _ in range(4)]
    memo.put(2.0, 3.0, 9.0, kept[0], 0)      # (t_pred, T, beta, row), oldest first
    memo.put(1.0, 2.0, 5.0, kept[1], 1)
    memo.put(3.0, 1.0, 2.0, kept[2], 2)
    memo.put(2.0, 3.0, 5.0, kept[3], 3)
    key = "k"
    for t in (1.0, 2.0, 3.0, 5.0, 9.0, 4.0):
        for b in (2.0, 5.0, 9.0, 1.0):
            assert _same_answer(memo.ask(t, b, key), ref_ask(_St(memo), t, b, key))
    assert memo.ask(2.0, 5.0, key)[2] == (kept[3], 3)
    assert memo.ask(2.0, 9.0, key)[2] == (kept[0], 0)
    assert memo.ask(4.0, 1.0, key) == (4.0, None, None)
    assert chains.ChainMemo().ask(1.5, 2.0, key) == (1.5, None, None)


class _St:
    def __init__(self, memo):
        self.chain_T = memo


# ---------------------------------------------------------------- seg_counts, _inner_s_stacked
@pytest.mark.parametrize("path,prof_name", CASES)
def test_seg_counts_and_stacked_arc_lengths(path, prof_name):
    strokes, pin, rows, prof, rules = fresh_chains(path, prof_name)
    gs = [curves.geom(strokes[i], prof) for i in rows.tolist()]
    assert curves.seg_counts(gs) == [g.d.size for g in gs]

    class _G:                             # a geometry of another make: its d
        d = np.ones(7)
    assert curves.seg_counts(gs[:3] + [_G()]) == [g.d.size for g in gs[:3]] + [7]
    by_n = {}
    for g in gs:
        by_n.setdefault(g.d.size, []).append(g)
    order = [g for n in sorted(by_n) for g in by_n[n]]
    Ds = [curves.stack_du(by_n[n])[0] for n in sorted(by_n)]
    assert float_bits(chains._inner_s_stacked(order, Ds)) == float_bits(chains._inner_s(order))
    assert float_bits(chains._inner_s_stacked(order, [])) == float_bits(chains._inner_s(order))


# ---------------------------------------------------------------- _laws_of
def ref_laws_of(Qs, items, profile):
    """chains._laws_of at e9d4ed5 (verbatim but for the names and s34's pieces' spans)."""
    order = [q for Q in Qs for q in Q]
    m = len(order)
    sts = [items[q][0] for q in order]
    kept = [items[q][1] for q in order]
    nv = np.fromiter((kp.base[0].shape[1] for kp in kept), np.int64, m)      # vertices a row
    voff = np.zeros(m + 1, np.int64)
    np.cumsum(nv, out=voff[1:])
    by = {}
    for i, (kp, q) in enumerate(zip(kept, order)):
        e = by.get(id(kp.base))
        if e is None:
            e = by[id(kp.base)] = (kp.base, [], [])
        e[1].append(i)
        e[2].append(kp.lo + items[q][2])
    TL, beta, tp, a2 = np.empty(m), np.empty(m), np.empty(m), np.empty(m)
    bound = np.empty(int(voff[-1]), bool)
    cnt = np.empty(m, np.int64)
    parts = []
    for b, ii, qq in by.values():
        ii, qq = np.array(ii), np.array(qq)
        TL[ii], beta[ii], tp[ii], a2[ii] = b[3][qq], b[4][qq], b[5][qq], b[6][qq]
        w = b[0].shape[1]
        if w:
            bound[(voff[ii][:, None] + np.arange(w)).ravel()] = b[0][qq].ravel()
        # (s34: a row's pieces are (first, count) = b[2][row] of the chunk's shared b[1])
        p0 = b[2][qq, 0].astype(np.int64)
        cnt[ii] = b[2][qq, 1]
        parts.append((ii, p0, b[1]))
    poff = np.zeros(m + 1, np.int64)
    np.cumsum(cnt, out=poff[1:])
    tj = np.empty(int(poff[-1]))
    for ii, p0, piece_t in parts:       # each row's pieces to its place in the order
        c = cnt[ii]
        at = np.cumsum(c) - c
        k = int(c.sum())
        src = np.repeat(p0 - at, c) + np.arange(k)
        dst = np.repeat(poff[ii] - at, c) + np.arange(k)
        tj[dst] = piece_t[src]
    cv = np.concatenate(chains._chain_caps(sts, [curves.geom(st, profile) for st in sts], profile))
    return sts, nv, voff, bound, tj, TL, beta, tp, a2, cv


def _kept_items(strokes, rows, T, beta, I, last=False):
    """[(stroke, _KeptLaws, row)] of each chain's first (or last) feasible candidate."""
    ok = np.isfinite(I)
    items = []
    for j, i in enumerate(rows.tolist()):
        cs = np.flatnonzero(ok[j])
        if cs.size:
            c = int(cs[-1] if last else cs[0])
            hit = strokes[i].chain_T.plan_of(chains.law_T(strokes[i], T[j, c]), float(beta[j, c]))
            if hit is not None and isinstance(hit[0], chains._KeptLaws):
                items.append((strokes[i], hit[0], hit[1]))
    return items


@pytest.mark.parametrize("path,prof_name", CASES)
@pytest.mark.parametrize("last,drop_caps", [(False, False), (True, False), (False, True)])
def test_laws_of_as_e9d4ed5(path, prof_name, last, drop_caps):
    """drop_caps: every fifth chain's vertex caps let go (_drop's state: made again)."""
    strokes, pin, rows, prof, rules, T, beta, I = _tabled(path, prof_name)
    items = _kept_items(strokes, rows, T, beta, I, last)
    assert len(items) > 100
    if drop_caps:
        for st, _, _ in items[::5]:
            st.curv.chain_caps = None
    rng = np.random.default_rng(5)
    idx = rng.permutation(len(items)).tolist()          # the rows' bases interleaved
    Qs = [idx[a:a + 37] for a in range(0, len(idx), 37)]
    want = ref_laws_of(Qs, items, prof)
    got = chains._laws_of(Qs, items, prof)
    assert got[0] == want[0] and [g is curves.geom(st, prof) for g, st in zip(got[10], got[0])] == [True] * len(got[0])
    for g, w in zip(got[1:10], want[1:10]):
        assert g.dtype == w.dtype and g.tobytes() == w.tobytes()
    assert len({id(kp.base) for _, kp, _ in items}) > 1


# ---------------------------------------------------------------- _knots_again
def ref_knots_again(items, profile):
    """chains._knots_again at e9d4ed5 (verbatim but for the names): every chain solved."""
    out = [None] * len(items)
    by_src = {}
    for q, it in enumerate(items):
        by_src.setdefault(id(it[1]), []).append(q)
    for qs in by_src.values():
        src = items[qs[0]][1]
        idx = np.array([items[q][2] for q in qs], int)
        Tt, bt = src.T[idx], src.beta[idx]
        cols = []
        for q, Tr, br in zip(qs, Tt, bt):
            hit = np.flatnonzero((Tr == items[q][3]) & (br == items[q][4]))
            if hit.size == 0:
                raise ValueError("chain candidate not in its table")
            cols.append(int(hit[0]))
        for a in range(0, len(qs), chains.SOLVE_CHUNK):
            sl = slice(a, min(a + chains.SOLVE_CHUNK, len(qs)))
            sts = [items[q][0] for q in qs[sl]]
            want = cols[sl]
            need = set()
            for c in want:
                while c not in need:
                    need.add(c)
                    c = src.prev.get(c, c)
            base = chains._flat_chains(sts, profile)
            m, nv = len(sts), base.sv.size
            res = {}
            for c in src.order:
                if c not in need:
                    continue
                fl = base.with_T(Tt[sl, c], bt[sl, c])
                if c in src.prev:
                    p = src.prev[c]
                    s0 = res[p]
                    vt = s0.vert_t * (Tt[sl, c] / Tt[sl, p])[fl.ch]
                    res[c] = chains.solve_flat(fl, s0.bound.copy(), vt, np.ones(m, bool), pieces=False)
                else:
                    res[c] = chains.solve_flat(fl, chains.cold_binding(fl), np.zeros(nv), np.zeros(m, bool),
                                               pieces=False)
            for jj, (q, c) in enumerate(zip(qs[sl], want)):
                n = curves.geom(sts[jj], profile).d.size
                o = int(base.voff[jj])
                vk = np.empty((1, n + 1))
                tk = np.empty((1, n + 1))
                vk[0, 0], vk[0, -1] = base.v0[jj], base.v1[jj]
                tk[0, 0] = 0.0
                tk[0, -1] = Tt[a + jj, c]
                vk[0, 1:-1] = res[c].vert_v[o:o + n - 1]
                tk[0, 1:-1] = res[c].vert_t[o:o + n - 1]
                out[q] = (vk, np.diff(tk, axis=1))
    return out


@pytest.mark.parametrize("path,prof_name", CASES)
def test_knots_again_solves_equal_chains_once(path, prof_name, monkeypatch):
    """Every chain's every feasible candidate made again (items of one _Source, the rows
    repeated so that equal chains are there for sure, in two chunks), against solving each
    chain; and _same_chains did find equal chains to merge."""
    strokes, pin, rows, prof, rules, T, beta, I = _tabled(path, prof_name)
    ok = np.isfinite(I)
    items = []
    for j, i in enumerate(rows.tolist()):
        memo = strokes[i].chain_T
        for c in np.flatnonzero(ok[j]).tolist():
            items.append((strokes[i], memo.src, memo.src_i, chains.law_T(strokes[i], T[j, c]), float(beta[j, c])))
    items = items + items[::3]
    assert len({id(it[1]) for it in items}) == 1 and len(items) > 300
    merged = []
    real = chains._same_chains

    def spy(*a):
        got = real(*a)
        merged.append(0 if got is None else a[0].S.size - got[0].size)
        return got
    monkeypatch.setattr(chains, "_same_chains", spy)
    monkeypatch.setattr(chains, "SOLVE_CHUNK", len(items) // 2 + 1)
    want = ref_knots_again(items, prof)
    got = chains._knots_again(items, prof)
    assert len(merged) == 2 and all(k > 0 for k in merged)
    for (gv, gt), (wv, wt) in zip(got, want):
        assert float_bits(gv) == float_bits(wv) and float_bits(gt) == float_bits(wt)


# ---------------------------------------------------------------- _window_sums
def test_window_sums_as_np_convolve():
    """The core's window sums where its probe takes them, np.convolve's bits either way,
    on segment-like lengths and on values whose sums depend on the order of additions;
    a window the machine's dot adds in another order (OpenBLAS's vector kernel: 16 terms
    and more here) is left to np.convolve, and so is every window without the core."""
    core = chains._chain_law.CORE_MOD
    if core is None or not hasattr(core, "window_sums"):
        pytest.skip("no chain core")
    rng = np.random.default_rng(11)
    taken = []
    for nb in range(1, 40):
        ok = chains._window_sums_ok(core.window_sums, nb)
        taken.append(ok)
        for x in (rng.uniform(0.05, 1.5, 3 * nb + 50),
                  rng.lognormal(0.0, 5.0, 200) * rng.choice([-1.0, 1.0], 200)):
            want = np.convolve(x, np.ones(nb), "valid")
            for c in (core, None):
                assert float_bits(chains._window_sums(x, nb, c)) == float_bits(want)
            if ok:        # the core's own sums: the same bits
                out = np.empty(want.size)
                core.window_sums(x, nb, out)
                assert float_bits(out) == float_bits(want)
    assert taken[12]                        # prusa-mk3s: block_buffer 16, windows of 13
    # a window the probe turns down gives other bits in the core (the probe has to look)
    bad = [nb for nb, ok in zip(range(1, 40), taken) if not ok]
    if bad:
        x = rng.lognormal(0.0, 6.0, 4 * bad[0] + 64) * rng.choice([-1.0, 1.0], 4 * bad[0] + 64)
        out = np.empty(x.size - bad[0] + 1)
        core.window_sums(x, bad[0], out)
        assert float_bits(out) != float_bits(np.convolve(x, np.ones(bad[0]), "valid"))


@pytest.mark.parametrize("path,prof_name,taken", [("sample_gcode/prusa_gyroid_fullspeed.gcode", "prusa-mk3s", True),
                                                  ("sample_gcode/prusa_gyroid_fullspeed.gcode", "prusa-mk4", False)])
def test_candidate_table_with_core_windows_as_np_convolve(path, prof_name, taken, monkeypatch):
    """The candidate table (every row finished: _finish_core with the lookahead windows)
    with the core's window sums and with np.convolve's, bit for bit; prusa-mk4's windows
    of 29 (OpenBLAS's vector kernel in np.convolve's dot here) left to np.convolve."""
    if chains._chain_law.CORE_MOD is None:
        pytest.skip("no chain core")
    got = {}
    for name, ok in (("core", None), ("numpy", False)):
        strokes, pin, rows, prof, rules = fresh_chains(path, prof_name)
        nb = max(prof.block_buffer - 3, 1)
        assert prof.block_buffer > 0 and prof.junction in chains.GROUP_JUNCTIONS
        monkeypatch.setattr(chains, "_WINDOW_SUMS_OK", {} if ok is None else {nb: False})
        got[name] = chains.candidates_chain(pin, rows, strokes, prof, rules)
        if ok is None:
            assert chains._WINDOW_SUMS_OK.get(nb) is taken
    for a, b in zip(got["core"], got["numpy"]):
        assert float_bits(a) == float_bits(b)
