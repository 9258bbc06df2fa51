"""The chains' finishing groups with fewer numpy calls a group (session 51, chainw51: a
window's ~33 groups by segment count each paid its set-up), the same bits as the code it
replaced.  The replaced functions are copied here verbatim (from 3356fa2): _remember,
_row_steps, _Finisher._finish, _finish_core and _LawCols.rows; each run of the candidates
with them (monkeypatched in) is compared with a run of the new code, bit for bit: the
candidate tables (Candidates: cnt, first, col, vals, t_pos), every chain's memo rows (t,
T, beta, row) and the knots its kept laws give back (_KeptLaws.row), under classic jerk
(prusa-mk3s) and square corner velocity (voron24), in one call and in windows (K 1, 8,
32: candidates_in_windows, whose windows are the same bits as one call).  Direct checks:
_run_starts, _at_both and _row_steps against the numpy expressions they stand for."""
import math
from array import array
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt import curves
from gcode_opt import features as feat
from gcode_opt import schedule
from gcode_opt.chains import (GROUP_JUNCTIONS, ROW_RANGE_COLS, TRAP_GRID, _at, _Cells, _cf_consts, _cf_rows,
                              _CF_NO_W, _chain_law, _finish_rows_dt, _finish_stacked_dt, _KeptLaws,
                              _own_source, _PackedMask, _row_int, _row_ranges, _turn_cosines, _window_sums)
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_CHAIN

SAMPLES = Path(__file__).resolve().parent.parent / "sample_gcode"


# ---------------------------------------------------------------- the replaced code (3356fa2), verbatim
def _finish_core_old(sts, gs, own, vk, tk, rules, profile, predict, core=None, du=None):
    """_finish_stacked_dt's numbers by the chain core's chain_finish (one C call for the
    batch: the same operations in numpy's order, the same bits: tests/test_speed21_chainfin_core.py),
    under a junction law of GROUP_JUNCTIONS that is the profile's; None (the numpy code
    then) when the core is missing or stale, or declines the inputs (a non-finite one, a
    classic-jerk tent input that is not finite and > 0).  core: the module (None = the
    chain core if it is there, False = never).  du: curves.stack_du(gs), or None (made here)."""
    core = _chain_law.CORE_MOD if core is None else core
    fn = getattr(core, "chain_finish", None) if core else None
    if fn is None or rules.junction not in GROUP_JUNCTIONS or profile.junction != rules.junction:
        return None
    jerk = rules.junction == "jerk"
    n, m, R = gs[0].d.size, len(sts), vk.shape[0]
    # (np.array of the rows, not np.stack: the same copy, a third of the time on ~10^2 chains)
    D, U = curves.stack_du(gs) if du is None else du
    if vk.shape != (R, n + 1) or tk.shape != (R, n) or D.shape != (m, n) or U.shape != (m, n, 2):
        return None
    # the turns' cosines, g.cos_turn of every chain in one pass over the stack (the same
    # two-term sum of products a row, the same bits; ~34 k property calls on the gyroid plate)
    C = _turn_cosines(U, core) if n > 1 else np.empty((m, 0))
    W, ws = _CF_NO_W, 0
    if profile.block_buffer > 0:       # _windows' convolution, each chain's window at W[q ws:q ws + n]
        nb = max(profile.block_buffer - 3, 1)
        ext = np.empty((m, n + nb))
        ext[:, :n] = D
        ext[:, n:] = D[:, n - 1:n]
        W, ws = _window_sums(ext.ravel(), nb, core), n + nb
    # each chain's numbers in one pass over the chains, one row a chain (_cf_rows), then as
    # columns: the values the columns were given one list each before
    Q = _cf_rows(sts, core)
    pu, nu = Q[:, 9:11], Q[:, 11:13]
    P = np.zeros((m, 18))
    P[:, 0] = Q[:, 0]                  # _a_top
    P[:, 8] = Q[:, 2]
    P[:, 9] = Q[:, 3]
    # the end turns, curves.dot2(prev_u, u[0]) and dot2(u[-1], next_u) of predict_chains (its
    # two products and their sum; nan: no neighbour)
    P[:, 10] = pu[:, 0] * U[:, 0, 0] + pu[:, 1] * U[:, 0, 1]
    P[:, 11] = U[:, -1, 0] * nu[:, 0] + U[:, -1, 1] * nu[:, 1]
    if jerk:
        P[:, 1] = Q[:, 1]
        P[:, 3] = Q[:, 4]
        P[:, 4] = Q[:, 5]
        P[:, 2] = curves.JERK_F_STEP_R * np.minimum(P[:, 3], P[:, 4])     # step_v: the numpy code's
    else:
        P[:, 2] = math.inf
        P[:, 5] = Q[:, 6]
        P[:, 6] = Q[:, 7]
        P[:, 7] = Q[:, 8]
        hp = Q[:, 13] != 0.0
        hn = Q[:, 14] != 0.0
        P[hp, 12:14], P[hp, 14] = pu[hp], 1.0
        P[hn, 15:17], P[hn, 17] = nu[hn], 1.0
    acc, feed = np.empty((R, n)), np.empty((R, n))
    t, a2, fits = np.empty(R), np.empty(R), np.empty(R, bool)
    if not fn(0 if jerk else 1, 1 if predict else 0, np.ascontiguousarray(own, np.int64),
              np.ascontiguousarray(vk, float), np.ascontiguousarray(tk, float), D, U, C, W, ws,
              P, TRAP_GRID, _cf_consts(profile), acc, feed, t, a2, fits):
        return None
    return (acc, feed, t, a2, fits) if predict else (acc, feed, None, None, fits)



def _row_steps_old(tk):
    """np.diff(tk, axis=1) (the same values) for a 2-D tk of times: where its rows are short
    and it is C-contiguous, one subtraction over tk's flat values (the row ends' steps
    across rows discarded) and a copy of the rest, not numpy's row-by-row buffered
    subtraction of two strided views (~85 instructions an element at 7 columns, ~25 so;
    long rows subtract well as they are)."""
    if tk.ndim != 2 or not 2 <= tk.shape[1] <= ROW_RANGE_COLS + 1 or tk.shape[0] < 2 \
            or tk.dtype != np.float64 or not tk.flags.c_contiguous:
        return np.diff(tk, axis=1)
    R, w = tk.shape
    f = tk.ravel()
    d = np.empty(R * w)
    np.subtract(f[1:], f[:-1], out=d[:-1])
    return d.reshape(R, w)[:, :-1].copy()



def _remember(sts, j, c, t, good, T, beta, kept, src=None, a=0):
    """Each chain's memo (ChainMemo.put_shared: one array for the batch) of its good rows:
    predicted time, law T, beta, and its row in kept (the batch's kept laws, shared by its
    chains: the batch row); rows of one chain are consecutive in j.  src: the _Source of
    the rows (chain sts[jj] is its row a + jj)."""
    R = j.size
    first = np.r_[True, j[1:] != j[:-1]]
    # the good rows, each chain's newest (last) first: one buffer, a slice per chain; its
    # (t, T, beta, row) made of those rows only (the same numbers as a table of every row
    # gathered at them; the row its index, exact as a float)
    q = np.flatnonzero(good)
    q = q[np.lexsort((-q, j[q]))]
    jq, cq = j[q], c[q]
    figs = array("d")
    figs.frombytes(np.stack([t[q], _at(T, jq, cq), _at(beta, jq, cq), q.astype(float)], axis=1).tobytes())
    cnt = np.bincount(j[q], None, j[-1] + 1 if R else 0).tolist()
    lo = 0
    for jj in j[first].tolist():
        k = cnt[jj]
        if k:
            memo = sts[jj].chain_T
            if memo.figs is None and memo.src is None:
                # a chain's first rows (the table's usual case): what _own_source and
                # put_shared set on a memo without rows nor source, set here
                if src is not None:
                    memo.src, memo.src_i = src, a + jj
                memo.figs, memo.kept, memo.at, memo.n = figs, kept, _row_int(lo), k
                memo.seg_tin = None
            else:
                if src is not None:
                    _own_source(memo, src, a + jj)
                memo.put_shared(figs, _row_int(lo), k, kept)
            lo += k



def _finish_old(self, rs):
    profile, rules = self.profile, self.rules
    if self.grouped:
        sts = [r.sts[j] for r in rs for j in r.J.tolist()]
        gs = [curves.geom(st, profile) for st in sts]
        off = np.cumsum([0] + [r.J.size for r in rs])
        own = np.concatenate([o + r.rj for o, r in zip(off, rs)])
        vk = rs[0].vk if len(rs) == 1 else np.concatenate([r.vk for r in rs])
        dt = rs[0].dt if len(rs) == 1 else np.concatenate([r.dt for r in rs])
        _, _, t, a2, _ = _finish_stacked_dt(sts, gs, own, vk, dt, rules, profile)
        del vk, dt
    else:
        r = rs[0]
        _, _, t, a2, _ = _finish_rows_dt(r.sts[int(r.J[0])], r.vk, r.dt, rules, profile)
    tab = self.tab
    lo = 0
    for r in rs:
        R = r.rj.size
        tr, a2r = t[lo:lo + R], a2[lo:lo + R]
        lo += R
        j = r.J[r.rj]
        good = np.isfinite(a2r) & np.isfinite(tr) & (tr > 0)
        tab.put(r.a + j[good], r.rc[good], tr[good], a2r[good], r.iv[good])
        # (the rows' laws, not their knots: ~1/3 of the bytes, held until a plan is made;
        # one _KeptLaws for the rows of all these chains, each row its batch row)
        # (beta of T: its cells are made from T's, at their places, not held as a table of their own)
        tc = _Cells(r.T, j, r.rc) if self.T_outer is None else _Cells(self.T_outer, r.a + j, r.rc)
        bc = _Cells(r.beta, j, r.rc) if self.beta_fn is None else tc.of(self.beta_fn)
        kb = (_PackedMask(r.bnd), r.tj, r.spans, tc, bc, tr, a2r, profile)
        r.vk = r.dt = r.bnd = None
        _remember(r.sts, j, r.rc, tr, good, r.T, r.beta, _KeptLaws(self.key, kb, 0, R), self.src, r.a)



def _law_rows_old(self, j, rc, n, at=None, spans=None):
    """(bnd (R, n - 1), PT, spans (R, 2)) of the rows (chain j[i], column rc[i]) of
    chains of n segments: row i's pieces' durations PT[a:a + c], (a, c) = spans[i]
    (int32: a chunk's pieces are ~10^5).  at: _table_rows' (flat index of these rows'
    vertices, the width, vmap and vertex offsets it was made for), or None.  (spans:
    _table_rows' since s62, not read: the replaced code made them here.)"""
    R = j.size
    if (n > 1 and at is not None and at[2] is self.vmap and at[3] is self.voff and self.BB.flags.c_contiguous
            and self.BB.shape[1] == at[1]):
        bnd = self.BB.ravel().take(at[0])      # (_at's gather at the same places)
    elif n > 1:
        ix = _row_ranges(self.voff[j], n - 1)
        bnd = _at(self.BB, rc[:, None], ix if self.vmap is None else self.vmap[ix])
    else:
        bnd = np.empty((R, 0), bool)
    return bnd, self.PT, np.stack([_at(self.P0, rc, j), _at(self.PN, rc, j)], axis=1).astype(np.int32)





def _old_code(monkeypatch):
    """The replaced functions in place of the new ones (the callers look them up in chains)."""
    monkeypatch.setattr(chains, "_finish_core", _finish_core_old)
    monkeypatch.setattr(chains, "_row_steps", _row_steps_old)
    monkeypatch.setattr(chains, "_remember", _remember)
    monkeypatch.setattr(chains._Finisher, "_finish", _finish_old)
    monkeypatch.setattr(chains._LawCols, "rows", _law_rows_old)
    monkeypatch.setattr(chains, "_finish_ragged", lambda *a, **k: None)     # (s52: not in the replaced code)


# ---------------------------------------------------------------- runs compared
def _run(path, profile, K):
    """(candidate tables, every chain's memo rows and their kept laws' knots) of the
    candidates of the file: one call (K 0) or candidates_in_windows over K even windows."""
    prof = load_profile(profile)
    opts = Options(features=feat.default_selection(str(path))[0])
    strokes, _ = analyse(str(path), prof, opts)
    pin = schedule.plan_inputs(strokes, prof, opts)
    rows = schedule._rows_by_kind(strokes, schedule._plan_kind_codes_of(strokes, pin))
    failed = schedule._faults_of(pin.fault)
    if K == 0:
        cands, _ = schedule._candidates(strokes, pin, prof, opts, rows, failed)
    else:
        bounds = np.linspace(0, len(strokes), K + 1).astype(int)
        cands, _ = schedule.candidates_in_windows(strokes, pin, prof, opts, rows, failed, bounds)
    # every row's entries in row order (their places in the arrays are the pieces' order)
    cnt = cands.cnt
    at = np.repeat(cands.first - np.cumsum(cnt) + cnt, cnt) + np.arange(int(cnt.sum()))
    tables = [x.tobytes() for x in (cnt, cands.t_pos, cands.col[at], cands.vals[:, at])]
    memos = []
    for i in rows[K_CHAIN].tolist():
        m = strokes[i].chain_T
        if m is None or m.figs is None:
            memos.append(None)
            continue
        got = []
        for t, T, beta, r, kept in m.rows():
            knots = kept.row(int(r), strokes[i]) if type(kept) is _KeptLaws else None
            got.append((t, T, beta, r, None if knots is None else
                        tuple(np.asarray(x).tobytes() for x in knots)))
        memos.append(got)
    assert sum(g is not None for g in memos) > 50        # (the chains made memos: the comparison is not empty)
    return tables, memos, sorted(failed)


CASES = [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_gyroid.gcode", "voron24")]


@pytest.mark.parametrize("name,profile", CASES)
def test_finishing_same_bits_as_replaced_code(monkeypatch, name, profile):
    path = SAMPLES / name
    new = {K: _run(path, profile, K) for K in (0, 1, 8, 32)}
    with monkeypatch.context() as mp:
        _old_code(mp)
        old = {K: _run(path, profile, K) for K in (0, 8)}
    for K in (0, 8):
        assert new[K] == old[K]
    for K in (1, 8, 32):              # windows: the same bits as one call
        assert new[K][0] == new[0][0] and new[K][2] == new[0][2]


def test_finish_core_same_as_replaced(monkeypatch):
    """_finish_core (P's columns copied in one gather) against the replaced code on every
    finishing batch of the sample, both junction laws: the same arrays, bit for bit."""
    for profile in ("prusa-mk3s", "voron24"):
        calls = []
        orig = chains._finish_core

        def spy(*a, **k):
            got = orig(*a, **k)
            calls.append((a, k, got))
            return got
        with monkeypatch.context() as mp:
            mp.setattr(chains, "_finish_core", spy)
            mp.setattr(chains, "_finish_ragged", lambda *a, **k: None)   # (s52: every batch by _finish_core)
            _run(SAMPLES / "prusa_gyroid.gcode", profile, 8)
        assert len(calls) > 10
        for a, k, got in calls:
            ref = _finish_core_old(*a, **k)
            assert (got is None) == (ref is None)
            for x, y in zip(got or (), ref or ()):
                assert (x is None and y is None) or np.asarray(x).tobytes() == np.asarray(y).tobytes()


def test_run_starts_at_both_row_steps():
    rng = np.random.default_rng(5)
    for n in (0, 1, 2, 7):
        j = np.sort(rng.integers(0, 3, n))
        assert np.array_equal(chains._run_starts(j), np.r_[True, j[1:] != j[:-1]][:n])
    A, B = rng.normal(size=(40, 5)), rng.normal(size=(40, 5))
    r, c = rng.integers(0, 40, 30), rng.integers(0, 5, 30)
    ref = np.stack([_at(A, r, c), _at(B, r, c)], axis=1)
    assert chains._at_both(A, B, r, c).tobytes() == ref.tobytes()
    P0, PN = rng.integers(0, 1 << 20, (5, 40)), rng.integers(0, 9, (5, 40))
    assert chains._at_both(P0, PN, c, r).astype(np.int32).tobytes() == \
        np.stack([_at(P0, c, r), _at(PN, c, r)], axis=1).astype(np.int32).tobytes()
    assert chains._at_both(A, B[:, ::-1], r, c).tobytes() == np.stack([_at(A, r, c), _at(B[:, ::-1], r, c)],
                                                                        axis=1).tobytes()
    for w in (1, 2, ROW_RANGE_COLS + 1, ROW_RANGE_COLS + 2, 40):
        tk = np.cumsum(rng.uniform(0.001, 1.0, (6, w)), axis=1)
        for x in (tk, tk[:1], np.asfortranarray(tk), tk[:, ::2]):
            assert chains._row_steps(x).tobytes() == np.diff(x, axis=1).tobytes()
            assert chains._row_steps(x).shape == np.diff(x, axis=1).shape
