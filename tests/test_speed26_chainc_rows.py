"""Issue 8 (s26, chainc): less per-row Python around the chains' C calls, the same bits.
Each change is held to the code it replaced (kept here verbatim from ad24489) on real
chains of the sample gyroid files, under classic jerk (prusa-mk3s) and square corner
velocity (klipper):

  _table_rows   each group's candidate rows gathered from the columns' laws stacked
                (one fancy index over (column, vertex)), not one mask and gather a column;
  _cf_rows      the chains' numbers for chain_finish read in C from each stroke's slots
                (chain core cf_rows), not a tuple of Python floats a chain; the Python
                path (no core, or the core declines) is the old one."""
import math

import numpy as np
import pytest

from gcode_opt import chains, curves
from gcode_opt.laws import chain as chain_law

from chain_cases import chain_strokes, fresh_chains, float_bits

CASES = [("sample_gcode/prusa_gyroid_fullspeed.gcode", "prusa-mk3s"),
         ("sample_gcode/prusa_gyroid_fullspeed_klipper.gcode", "voron24"),
         ("sample_gcode/prusa_gyroid_fullspeed.gcode", "ender3")]
_chains, _fresh, _bits = chain_strokes, fresh_chains, float_bits

needs_core = pytest.mark.skipif(chain_law.CORE_MOD is None, reason="chain core not built")


# ---------------------------------------------------------------- _table_rows (ad24489)
def _ref_table_rows(sts, base, res, use, T, profile, grouped):
    gs = [curves.geom(st, profile) for st in sts]
    nseg = np.array([g.d.size for g in gs], int)
    has = use.any(axis=1)
    if grouped:
        groups = []
        rows = use.sum(axis=1)
        for q in np.unique(nseg[has]).tolist():
            J = np.flatnonzero(has & (nseg == q))
            cut = np.cumsum(rows[J]) // chains.FINISH_ROWS
            groups += np.split(J, np.flatnonzero(np.diff(cut)) + 1)
    else:
        groups = [np.array([j]) for j in np.flatnonzero(has).tolist()]
    v0, v1 = base.v0, base.v1
    for J in groups:
        n = int(nseg[J[0]])
        rj, rc = np.nonzero(use[J])
        j = J[rj]
        R = j.size
        vk = np.empty((R, n + 1))
        tk = np.empty((R, n + 1))
        iv = np.empty(R)
        vk[:, 0], vk[:, -1] = v0[j], v1[j]
        tk[:, 0] = 0.0
        tk[:, -1] = T[j, rc]
        for c in range(use.shape[1]):
            q = rc == c
            if not q.any():
                continue
            ix = base.voff[j[q]][:, None] + np.arange(n - 1)
            vk[q, 1:-1] = res[c].vert_v[ix]
            tk[q, 1:-1] = res[c].vert_t[ix]
            iv[q] = res[c].iv[j[q]]
        yield J, rj, rc, vk, np.diff(tk, axis=1), np.bincount(rj, None, J.size), iv


@pytest.mark.parametrize("path,prof_name", CASES)
def test_table_rows_are_the_column_by_column_gather(path, prof_name, monkeypatch):
    strokes, pin, rows, prof, rules = _fresh(path, prof_name)
    assert rows.size > 100
    new = chains._table_rows
    seen = {"groups": 0, "rows": 0, "cols": set(), "spans": 0}

    def both(sts, base, res, use, T, profile, grouped, laws=None):
        got = list(new(sts, base, res, use, T, profile, grouped, laws))
        want = list(_ref_table_rows(sts, base, res, use, T, profile, grouped))
        assert len(got) == len(want)
        for g, w in zip(got, want):
            assert len(g) == len(w) == 7
            for a, b in zip(g, w):
                assert a.shape == b.shape and a.dtype == b.dtype
                assert _bits(a) == _bits(b) if a.dtype.kind == "f" else np.array_equal(a, b)
            if laws is not None:         # (s62: the rows' spans made for the groups at once, sliced)
                want_sp = chains._at_both(laws.P0, laws.PN, g[2], g[0][g[1]]).astype(np.int32)
                assert g.spans.dtype == want_sp.dtype and np.array_equal(g.spans, want_sp)
                seen["spans"] += 1
            seen["groups"] += 1
            seen["rows"] += g[1].size
            seen["cols"] |= set(g[2].tolist())
        yield from got

    monkeypatch.setattr(chains, "_table_rows", both)
    chains.candidates_chain(pin, rows, strokes, prof, rules)
    assert seen["groups"] > 5 and seen["rows"] > 2 * rows.size and len(seen["cols"]) > 1
    assert seen["spans"] == seen["groups"]


def test_table_rows_mutant_is_caught():
    """The comparison above fails on a gather that takes the wrong column's laws."""
    class L:
        pass
    res = {}
    for c in range(2):
        res[c] = L()
        res[c].vert_v = np.arange(6.0) + 10 * c
        res[c].vert_t = np.arange(6.0) * 0.1 + c
        res[c].iv = np.array([1.0, 2.0]) + c
    base = L()
    base.v0, base.v1, base.voff = np.array([1.0, 2.0]), np.array([3.0, 4.0]), np.array([0, 3, 6])
    use = np.array([[True, True], [False, True]])
    T = np.array([[1.0, 2.0], [1.5, 2.5]])

    class G:
        d = np.ones(4)

    class S:
        curv = G()
    sts = [S(), S()]
    old_geom = curves.geom
    try:
        curves.geom = lambda st, profile: st.curv
        got = list(chains._table_rows(sts, base, res, use, T, None, True))
        want = list(_ref_table_rows(sts, base, res, use, T, None, True))
        for g, w in zip(got, want):
            for a, b in zip(g, w):
                assert np.array_equal(a, b)
        res[0].vert_v, res[1].vert_v = res[1].vert_v, res[0].vert_v        # the wrong column
        got = list(chains._table_rows(sts, base, res, use, T, None, True))
        assert not np.array_equal(got[0][3], want[0][3])
    finally:
        curves.geom = old_geom


# ---------------------------------------------------------------- _cf_rows
def _ref_rows(sts):
    return np.array([chains._cf_row(st) for st in sts], float).reshape(len(sts), chains._CF_ROW)


@needs_core
@pytest.mark.parametrize("path,prof_name", CASES)
def test_cf_rows_core_is_cf_row(path, prof_name):
    strokes, pin, rows, prof = _chains(path, prof_name)
    sts = [strokes[i] for i in rows.tolist()]
    want = _ref_rows(sts)
    assert (want[:, 13] == 1.0).any() and (want[:, 14] == 1.0).any()      # neighbours read (None: the edge test)
    core = chain_law.CORE_MOD
    Q = np.empty((len(sts), chains._CF_ROW))
    assert core.cf_rows(sts, chains.Stroke, Q) == 1                        # not declined
    assert _bits(Q) == _bits(want)
    assert _bits(chains._cf_rows(sts)) == _bits(want)
    assert _bits(chains._cf_rows(sts, False)) == _bits(want)               # the Python path


@needs_core
def test_cf_rows_core_edge_values_and_declines():
    strokes, pin, rows, prof = _chains(*CASES[0])
    st = strokes[int(rows[0])]
    saved = (st.accel, st._pux, st._puy, st._nux, st._nuy, st.lim)
    core = chain_law.CORE_MOD
    Q = np.empty((1, chains._CF_ROW))
    try:
        # Python's min keeps the first of the least and a nan first: as the core
        for accel in (math.nan, 0.0, -0.0, 1e9, st.lim.ax_max, np.float64(5.0)):
            st.accel = accel
            st.prev_u, st.next_u = (0.6, -0.8), None
            assert core.cf_rows([st], chains.Stroke, Q) == 1
            assert _bits(Q) == _bits(_ref_rows([st]))
        st.accel = saved[0]
        for bad in (lambda: setattr(st, "accel", 1000),                     # an int: declined
                    lambda: setattr(st, "_puy", None),                      # half a direction
                    lambda: setattr(st, "v0", "x")):
            st.accel, st._pux, st._puy = saved[0], 0.6, -0.8
            v0 = st.v0
            bad()
            assert core.cf_rows([st], chains.Stroke, Q) == 0
            st.v0 = v0
        st.accel, st._pux, st._puy = saved[0], 0.6, -0.8

        class Other:
            pass
        o = Other()
        for f in ("accel", "v_feed", "v0", "v1", "lim", "_pux", "_puy", "_nux", "_nuy"):
            setattr(o, f, getattr(st, f))
        assert core.cf_rows([o], chains.Stroke, Q) == 0                    # not a Stroke: declined
        with pytest.raises(ValueError):
            core.cf_rows([st], chains.Stroke, np.empty((2, chains._CF_ROW)))
    finally:
        st.accel, st._pux, st._puy, st._nux, st._nuy, st.lim = saved


@needs_core
def test_cf_rows_declined_falls_back_to_python(monkeypatch):
    strokes, pin, rows, prof = _chains(*CASES[0])
    sts = [strokes[i] for i in rows.tolist()[:50]]
    want = _ref_rows(sts)
    monkeypatch.setattr(chains, "Stroke", object)                            # every stroke declined
    assert _bits(chains._cf_rows(sts)) == _bits(want)


# ---------------------------------------------------------------- _tod_core_at
def _tod_calls(path, prof_name, monkeypatch):
    """(law, pj, x) of every solve_fixed's free-vertex evaluation of a candidate table."""
    strokes, pin, rows, prof, rules = _fresh(path, prof_name)
    calls = []
    orig = chain_law._tod_core_at

    def rec(core, law, pj, x, max_iter=200):
        calls.append((law, np.array(pj), np.array(x)))
        return orig(core, law, pj, x, max_iter)
    monkeypatch.setattr(chain_law, "_tod_core_at", rec)
    chains.candidates_chain(pin, rows[:300], strokes, prof, rules)
    monkeypatch.undo()
    return calls


@needs_core
@pytest.mark.parametrize("path,prof_name", CASES[:2])
def test_tod_core_at_is_times_and_speeds_of_the_taken_laws(path, prof_name, monkeypatch):
    calls = _tod_calls(path, prof_name, monkeypatch)
    assert len(calls) >= 10 and sum(pj.size for _, pj, _ in calls) > 1000
    core = chain_law.CORE_MOD
    for law, pj, x in calls:
        want = chain_law._times_and_speeds(law.take(pj), x)
        got = chain_law._tod_core_at(core, law, pj, x)
        assert got is not None
        for a, b in zip(got, want, strict=True):
            assert _bits(a) == _bits(b)
    # out of steps (the laws still going evaluated in numpy, as _tod_core does)
    law, pj, x = max(calls, key=lambda c: c[1].size)
    for mi in (1, 2, 3):
        got = chain_law._tod_core_at(core, law, pj, x, max_iter=mi)
        want = chain_law._tod_core(core, law.take(pj), x, max_iter=mi)
        for a, b in zip(got, want, strict=True):
            assert _bits(a) == _bits(b)
    # a mutant of the index (the laws taken one place off) is seen
    bad = np.roll(pj, 1)
    got = chain_law._tod_core_at(core, law, bad, x)
    want = chain_law._times_and_speeds(law.take(pj), x)
    assert _bits(got[0]) != _bits(want[0])


@needs_core
def test_tod_core_at_declines(monkeypatch):
    calls = _tod_calls(*CASES[0], monkeypatch)
    law, pj, x = calls[0]
    core = chain_law.CORE_MOD
    assert chain_law._tod_core_at(core, law, pj[:0], x[:0]) is None            # no laws
    assert chain_law._tod_core_at(core, law, pj, x[:-1]) is None               # shapes
    small = law._c["small"].copy()
    try:
        law._c["small"] = small.copy()
        law._c["small"][pj[0]] = False                                        # a law out of the series branch
        assert chain_law._tod_core_at(core, law, pj, x) is None
        law._c["small"][:] = True
        other = np.setdiff1d(np.arange(law.T.size), pj)
        if other.size:                                                         # only the taken laws count
            law._c["small"][other[0]] = False
            assert chain_law._tod_core_at(core, law, pj, x) is not None
    finally:
        law._c["small"] = small


# ---------------------------------------------------------------- _remember (ad24489)
def _ref_remember(sts, j, c, t, good, T, beta, kept, src=None, a=0):
    # (s34: one kept laws for the batch, shared by its chains, a row its batch row)
    R = j.size
    first = np.r_[True, j[1:] != j[:-1]]
    tab = np.stack([t, T[j, c], beta[j, c], np.arange(R, dtype=float)], axis=1)
    q = np.flatnonzero(good)
    q = q[np.lexsort((-q, j[q]))]
    from array import array
    figs = array("d")
    figs.frombytes(np.ascontiguousarray(tab[q]).tobytes())
    cnt = np.bincount(j[q], None, j[-1] + 1 if R else 0)
    lo = 0
    for jj in j[first].tolist():
        k = int(cnt[jj])
        if k:
            memo = sts[jj].chain_T
            if src is not None:
                chains._own_source(memo, src, a + jj)
            memo.put_shared(figs, lo, k, kept)
            lo += k


def _memo_state(strokes, rows):
    out = []
    for i in rows.tolist():
        m = strokes[i].chain_T
        rs = [(r[0], r[1], r[2], r[3], type(r[4]).__name__, getattr(r[4], "lo", None), getattr(r[4], "k", None))
              for r in m.rows()]
        out.append((rs, m.src_i, m.src is None, m.seg_tin))
    return out


@pytest.mark.parametrize("path,prof_name", CASES)
def test_remember_is_put_shared_and_own_source(path, prof_name, monkeypatch):
    """The memos after a candidate table, and after a second table of other durations
    (memos with rows and a source already: the old path), are those of ad24489's code."""
    states = []
    for fn in (chains._remember, _ref_remember):
        strokes, pin, rows, prof, rules = _fresh(path, prof_name)
        monkeypatch.setattr(chains, "_remember", fn)
        chains.candidates_chain(pin, rows, strokes, prof, rules)
        s1 = _memo_state(strokes, rows)
        saved = pin.T_orig.copy()
        pin.T_orig[rows] *= 1.01
        try:
            chains.candidates_chain(pin, rows, strokes, prof, rules)
        finally:
            pin.T_orig[:] = saved
        states.append((s1, _memo_state(strokes, rows)))
        monkeypatch.undo()
    assert states[0] == states[1]
    assert sum(len(s[0]) for s in states[0][1]) > sum(len(s[0]) for s in states[0][0]) > rows.size
