"""Issue 8 (s30, chains' memory): the candidate table keeps each row's law (its binding
mask and its pieces' durations, _KeptLaws) instead of its knot speeds and segment
durations, and makes the knots of the row chosen again (_Flat.vertices_at: solve_flat's
operations after its Newton on the durations); _figures takes the chains in the order of
their number of segments (each count's last batch finished early).  These tests hold:
  - vertices_at to solve_flat's own vertex speeds and times, bit for bit, column by column
    of the candidate table's solves, with the chain core and without it (numpy);
  - every kept row's knots made again (_gather_rows) to the knots _table_rows gave the
    finishing (the code of 71ac544 kept exactly those), bit for bit;
  - _figures' tables to those of the chains in their own order, unsorted, bit for bit;
and that the comparisons catch a law off by one ulp in one piece's duration."""
import numpy as np
import pytest

from gcode_opt import chains, curves
from gcode_opt.laws import chain as lc

from chain_cases import chain_strokes, fresh_chains, float_bits

CASES = [("sample_gcode/prusa_gyroid_fullspeed.gcode", "prusa-mk3s"),
         ("sample_gcode/prusa_gyroid_fullspeed_klipper.gcode", "voron24")]
_chains, _fresh, _bits = chain_strokes, fresh_chains, float_bits


def _column_solves(strokes, pin, rows, prof):
    """The candidate table's solves of the first chunk (_figures' columns, warm-started
    as there): [(flat chains at the column's T, FlatLaws)]."""
    rows = rows[:chains.SOLVE_CHUNK]
    T = pin.T_orig[rows, None] * chains.T_RATIOS[None, chains.CHAIN_COLS]
    beta = (T / chains.GAMMA_MIN) ** 2
    sts = [strokes[i] for i in rows.tolist()]
    base = chains._flat_chains(sts, prof)
    m, nv = len(sts), base.sv.size
    out, prev = [], None
    for c in range(T.shape[1]):
        fl = base.with_T(T[:, c], beta[:, c])
        if prev is None:
            res = lc.solve_flat(fl, lc.cold_binding(fl), np.zeros(nv), np.zeros(m, bool), pieces=False)
        else:
            vt = prev.vert_t * (T[:, c] / T[:, c - 1])[fl.ch]
            res = lc.solve_flat(fl, prev.bound.copy(), vt, np.ones(m, bool), pieces=False)
        out.append((fl, res))
        prev = res
    return out


@pytest.mark.parametrize("core", [True, False])
@pytest.mark.parametrize("path,prof_name", CASES)
def test_vertices_at_are_solve_flats_vertices(path, prof_name, core, monkeypatch):
    strokes, pin, rows, prof, _ = _fresh(path, prof_name)
    if not core:
        monkeypatch.setattr(lc, "CORE_MOD", None)
    n = 0
    for fl, res in _column_solves(strokes, pin, rows, prof):
        assert res.piece_off[-1] == res.piece_T.size and res.bound.any() and not res.bound.all()
        v, t = fl.vertices_at(res.bound, res.piece_T)
        assert _bits(v) == _bits(res.vert_v) and _bits(t) == _bits(res.vert_t)
        n += fl.S.size
    assert n > 100


def test_vertices_at_catches_an_ulp():
    """The comparison above fails on one piece's duration one ulp off."""
    strokes, pin, rows, prof, _ = _fresh(*CASES[0])
    fl, res = _column_solves(strokes, pin, rows, prof)[0]
    Tj = res.piece_T.copy()
    q = int(np.argmax(res.piece_off[1:] - res.piece_off[:-1] > 2))     # a chain of >= 3 pieces
    Tj[res.piece_off[q]] = np.nextafter(Tj[res.piece_off[q]], np.inf)
    v, t = fl.vertices_at(res.bound, Tj)
    assert _bits(t) != _bits(res.vert_t)


def _record_table_rows(monkeypatch, seen):
    """chains._table_rows wrapped: each row it yields goes into seen[id(stroke)] as
    (T, vk, dt), in order."""
    real = chains._table_rows

    def spy(sts, base, res, use, T, profile, grouped, laws=None):
        for item in real(sts, base, res, use, T, profile, grouped, laws):
            J, rj, rc, vk, dt = item[:5]
            j = J[rj]
            for q in range(rj.size):
                seen.setdefault(id(sts[j[q]]), []).append((float(T[j[q], rc[q]]), vk[q].copy(), dt[q].copy()))
            yield item

    monkeypatch.setattr(chains, "_table_rows", spy)


@pytest.mark.parametrize("path,prof_name", CASES)
def test_kept_rows_made_again_are_the_tables_knots(path, prof_name, monkeypatch):
    """Every row the table finished: its knots as _table_rows gave them (the knots 71ac544
    kept) against the knots _gather_rows makes again from the row's kept law, bit for bit;
    and the table's T, beta, predicted figures kept with it."""
    strokes, pin, rows, prof, rules = _fresh(path, prof_name)
    seen = {}                         # id(stroke) -> [(T, beta, vk, dt)] of its rows, in order
    _record_table_rows(monkeypatch, seen)
    chains.candidates_chain(pin, rows, strokes, prof, rules)
    by_n, n_rows = {}, 0
    for i in rows.tolist():
        st = strokes[i]
        for t, TL, b, r, kept in st.chain_T.rows():
            assert type(kept) is chains._KeptLaws and kept.st is None     # (one a batch, shared)
            by_n.setdefault(curves.geom(st, prof).d.size, []).append((st, kept, int(r), TL, b, t))
    for items in by_n.values():
        vk, dt, tp, a2 = chains._gather_rows([x[1] for x in items], [x[2] for x in items],
                                             [x[0] for x in items], prof)
        for q, (st, kept, r, TL, b, t) in enumerate(items):
            want = [x for x in seen[id(st)] if x[0] == TL]
            assert len(want) == 1
            assert _bits(vk[q]) == _bits(want[0][1]) and _bits(dt[q]) == _bits(want[0][2])
            assert tp[q] == t and kept.base[3][kept.lo + r] == TL and kept.base[4][kept.lo + r] == b
            one = kept.row(r, st)         # (one row alone: the same)
            assert _bits(one[0]) == _bits(vk[q]) and _bits(one[1]) == _bits(dt[q]) and one[2] == t
            n_rows += 1
    assert n_rows > 3 * rows.size > 300


@pytest.mark.parametrize("path,prof_name", CASES + [("sample_gcode/prusa_gyroid_fullspeed.gcode", "ender3")])
def test_figures_in_segment_order_are_the_unsorted_tables(path, prof_name, monkeypatch):
    strokes, pin, rows, prof, rules = _fresh(path, prof_name)
    monkeypatch.setattr(chains, "SOLVE_CHUNK", 64)          # many chunks, many early batches
    monkeypatch.setattr(chains, "SOLVE_SEGS", 64 * 12)
    T = pin.T_orig[rows, None] * chains.T_RATIOS[None, chains.CHAIN_COLS]
    beta = (T / chains.GAMMA_MIN) ** 2
    nseg = np.array([curves.geom(strokes[i], prof).d.size for i in rows.tolist()])
    assert not np.all(nseg[1:] >= nseg[:-1])                 # (the sort does move rows)
    got = chains._figures(strokes, rows, pin, T, beta, prof, rules)
    _fresh(path, prof_name)
    want = chains._figures_sorted(strokes, rows, pin, T, beta, prof, rules)     # rows as they are
    for g, w in zip(got, want, strict=True):
        assert g.dtype == w.dtype and _bits(g) == _bits(w)
    assert np.isfinite(got[2]).sum() > 3 * rows.size


def _same_plan(p, w):
    for f in ("s", "v", "accel", "feed"):
        a, b = np.asarray(getattr(p, f), float), np.asarray(getattr(w, f), float)
        if a.shape != b.shape or _bits(a) != _bits(b):
            return False
    return _bits(p.time_t) == _bits(w.time_t) and _bits(p.int_a2) == _bits(w.int_a2)


@pytest.mark.parametrize("prof_name", ["prusa-mk3s", "voron24", "ender3"])
def test_replay_of_kept_laws_is_the_replay_of_the_tables_knots(prof_name, monkeypatch):
    """_replay (with its drop) of one row of each chain kept by its law: the plans are those
    _replay makes of the same rows kept as the knots the table finished (a base of the
    knots themselves, as 71ac544 kept them), bit for bit; ender3 (junction deviation)
    replays chain by chain."""
    path = CASES[1][0] if prof_name == "voron24" else CASES[0][0]
    strokes, pin, rows, prof, rules = _fresh(path, prof_name)
    seen = {}
    _record_table_rows(monkeypatch, seen)
    chains.candidates_chain(pin, rows, strokes, prof, rules)
    rng = np.random.default_rng(5)
    items, legacy = [], []
    for i in rows.tolist():
        st = strokes[i]
        got = st.chain_T.rows()
        if not got:
            continue
        t, TL, b, r, kept = got[int(rng.integers(0, len(got)))]
        want = [x for x in seen[id(st)] if x[0] == TL][0]
        items.append((st, kept, int(r)))
        legacy.append((st, chains._KeptLaws(kept.key, (want[1][None, :], want[2][None, :], np.array([t]),
                                                       np.array([kept.base[6][kept.lo + int(r)]])), 0, 1), 0))
    want = chains._replay(legacy, rules, prof)
    got = chains._replay(items, rules, prof, drop=True)
    assert len(got) > 100 and all(_same_plan(p, w) for p, w in zip(got, want, strict=True))
    assert all(isinstance(st.chain_T.kept, chains._Again) for st, _, _ in items)
