"""Issue 8, session 52 (memo52: the chains' memos, compact): a finishing batch's kept laws
read their rows' law T, beta and predicted time in the memos' rows array (figs: those very
doubles, 4 a row, _remember) through _FigsCol, where they held the batch's predicted times
(8 bytes a row) and the cells' places of T and beta in the candidates' table (_Cells, 4
bytes a row): ~1 MB less on the gyroid plate's ~82 k rows, held from the candidates to
the first budget run (each batch row's place in figs made from figs' 4th column when the
replay first reads it, _FigsRows).  The replaced _Finisher._finish is copied here verbatim (872f8f0);
the candidates made with it (monkeypatched in) and with the new code are compared bit for
bit on the samples' chains under classic jerk and square corner velocity: the candidate
tables, every memo row, each kept row's (T, beta, predicted time, ∫|a|²) and knots
(_KeptLaws.row), and the plans of two budget runs (plan_chain_segments: kept rows replayed,
then other rows made again after the drop)."""
import tracemalloc
from array import array

import numpy as np
import pytest

from chain_cases import float_bits, fresh_chains
from gcode_opt import chains
from gcode_opt.chains import (_Cells, _finish_rows_dt, _finish_stacked_dt, _KeptLaws, _PackedMask, _remember,
                              curves)

SAMPLES = ["sample_gcode/prusa_gyroid.gcode", "sample_gcode/prusa_gyroid_fullspeed.gcode"]
PROFILES = ["prusa-mk3s", "voron24"]


# ---------------------------------------------------------------- the replaced code (872f8f0), verbatim
def _finish_old(self, rs):
    profile, rules = self.profile, self.rules
    if self.grouped:
        sts = [r.sts[j] for r in rs for j in r.J.tolist()]
        gs = [curves.geom(st, profile) for st in sts]
        if len(rs) == 1:             # (a window's batches: most are one group's rows)
            own = rs[0].rj
        else:
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
        j = r.j
        good = np.isfinite(a2r) & np.isfinite(tr) & (tr > 0)
        if good.all():               # (the usual case: the rows as they are, not gathered)
            tab.put(r.a + j, r.rc, tr, a2r, r.iv)
        else:
            tab.put(r.a + j[good], r.rc[good], tr[good], a2r[good], r.iv[good])
        # (the rows' laws, not their knots: ~1/3 of the bytes, held until a plan is made;
        # one _KeptLaws for the rows of all these chains, each row its batch row)
        # (beta of T: its cells are made from T's, at their places, not held as a table of their own)
        tc = _Cells(r.T, j, r.rc) if self.T_outer is None else _Cells(self.T_outer, r.a + j, r.rc)
        bc = _Cells(r.beta, j, r.rc) if self.beta_fn is None else tc.of(self.beta_fn)
        kb = (_PackedMask(r.bnd), r.tj, r.spans, tc, bc, tr, a2r, profile)
        r.vk = r.dt = r.bnd = None
        _remember(r.sts, j, r.rc, tr, good, r.T, r.beta, _KeptLaws(self.key, kb, 0, R), self.src, r.a)



# ---------------------------------------------------------------- runs compared
def _plans_bits(plans):
    return [None if p is None else (float_bits(p.s), float_bits(p.v), float_bits(p.accel), float_bits(p.feed),
                                    float_bits(p.time_t), float_bits(p.int_a2)) for p in plans]


def _run(path, prof_name):
    """(candidate tables, memo rows with their kept laws' figures and knots, the plans of two
    budget runs) of the sample's chains: the first run at each chain's second memo row (a
    kept row, replayed), the second at its newest row (dropped by the first: made again)."""
    strokes, pin, rows, prof, rules = fresh_chains(path, prof_name)
    tables = [float_bits(a) for a in chains.candidates_chain(pin, rows, strokes, prof, rules)]
    sts = [strokes[i] for i in rows.tolist()]
    memos, asks = [], []
    for st in sts:
        got = []
        for t, TL, b, r, kept in st.chain_T.rows():
            q = [kept.lo + int(r)]
            base = kept.base
            got.append((t, TL, b, r, float_bits(base[3][q]), float_bits(base[4][q]), float_bits(base[5][q]),
                        float_bits(base[6][q]), tuple(float_bits(x) for x in kept.row(int(r), st))))
            # (each read is the memo row's own numbers)
            assert float_bits(base[3][q]) == float_bits(TL) and float_bits(base[4][q]) == float_bits(b)
            assert float_bits(base[5][q]) == float_bits(t)
        memos.append(got)
        rs = st.chain_T.rows()
        asks.append((rs[min(1, len(rs) - 1)][:3], rs[0][:3]) if rs else None)
    ok = [k for k, a in enumerate(asks) if a is not None]
    assert len(ok) > 50
    sts = [sts[k] for k in ok]
    runs = []
    for w in (0, 1):
        T = np.array([asks[k][w][0] for k in ok])
        beta = np.array([asks[k][w][2] for k in ok])
        runs.append(_plans_bits(chains.plan_chain_segments(sts, T, beta, rules, prof)))
    return tables, memos, runs


@pytest.mark.parametrize("path", SAMPLES)
@pytest.mark.parametrize("prof_name", PROFILES)
def test_kept_laws_read_in_figs_same_bits_as_replaced(monkeypatch, path, prof_name):
    new = _run(path, prof_name)
    with monkeypatch.context() as mp:
        mp.setattr(chains._Finisher, "_finish", _finish_old)
        mp.setattr(chains, "_finish_ragged", lambda *a, **k: None)    # (s52, cpu52: not in the replaced code)
        old = _run(path, prof_name)
    assert new[0] == old[0]
    assert new[1] == old[1]
    assert new[2] == old[2]


def test_kept_laws_hold_figs_columns():
    strokes, pin, rows, prof, rules = fresh_chains(SAMPLES[0], "prusa-mk3s")
    chains.candidates_chain(pin, rows, strokes, prof, rules)
    n = 0
    for i in rows.tolist():
        m = strokes[i].chain_T
        if m.figs is None:
            continue
        base = m.kept.base
        assert [type(c) for c in base[3:6]] == [chains._FigsCol] * 3 and [c.col for c in base[3:6]] == [1, 2, 0]
        assert all(c.rows is base[3].rows and c.rows.figs is m.figs for c in base[3:6])
        assert base[3].rows._pos is None           # (the rows' places made when first read)
        n += 1
    assert n > 50


def test_figs_col_reads_rows_and_refuses_rows_not_kept():
    rows = np.array([[1.5, 2.0, 400.0, 3.0], [-0.0, 7.0, 4900.0, 0.0], [2.5, 3.0, 900.0, 1.0]])
    figs = array("d", rows.ravel().tolist())
    # (figs' rows 0, 1, 2 are batch rows 3, 0, 1: their 4th column; batch row 2 not kept)
    base = chains._figs_base((0, 1, 2, None, None, None, 6, 7), figs, 4)
    assert base[:3] == (0, 1, 2) and base[6:] == (6, 7)
    tp, TL, b = base[5], base[3], base[4]
    assert tp.shape == (4,) and tp.ndim == 1
    assert float_bits(tp[[0, 1, 3]]) == float_bits([-0.0, 2.5, 1.5])
    assert float_bits(TL[np.array([3, 1])]) == float_bits([2.0, 3.0]) and float(b[0]) == 4900.0
    with pytest.raises(IndexError):
        tp[[2]]
    figs.append(1.0)                     # (no buffer left exported by a read)


def test_kept_laws_hold_less():
    """The candidates' live memory after candidates_chain: at least 10 bytes a kept row less
    than with the replaced finishing (its predicted times, 8 bytes a row, and the cells'
    places, 4; measured ~12)."""
    def traced(finish):
        strokes, pin, rows, prof, rules = fresh_chains(SAMPLES[1], "prusa-mk3s")
        old, old_r = chains._Finisher._finish, chains._finish_ragged
        chains._Finisher._finish = finish
        chains._finish_ragged = lambda *a, **k: None     # (s52, cpu52: both sides batch by batch)
        try:
            tracemalloc.start()
            a = tracemalloc.get_traced_memory()[0]
            chains.candidates_chain(pin, rows, strokes, prof, rules)
            got = tracemalloc.get_traced_memory()[0] - a
            tracemalloc.stop()
        finally:
            chains._Finisher._finish, chains._finish_ragged = old, old_r
        n = sum(strokes[i].chain_T.n for i in rows.tolist())
        return got, n
    new, n = traced(chains._Finisher._finish)
    old, n_old = traced(_finish_old)
    assert n == n_old > 200
    assert old - new >= 10 * n
