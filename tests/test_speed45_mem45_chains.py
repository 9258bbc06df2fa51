"""Issue 8, session 45 (mem45: the chains' memory held through the plan, at the same bits):
a candidate table's weights beta are made from its law durations T where they are T's
((T / GAMMA_MIN)², _BetaOfT, _Cells' fn), not held as a table of their own; classify keeps
a chain's caps under classic jerk as the bytes of its doubles (_caps_array, _kept_caps,
_join_caps, _caps_sizes), not an array object each; the kept rows' and memos' row numbers
are shared int objects (_ROW_INTS).  Each new path is held to the code it replaced
(verbatim copies of f656414's below), bit for bit, on real samples and random inputs."""
import numpy as np
import pytest

from chain_cases import float_bits, fresh_chains
from gcode_opt import chains, curves
from gcode_opt.chains import CHAIN_CAP_MARGIN, CHAIN_COLS, GAMMA_MIN, ChainMemo, _figures
from gcode_opt.laws.chain import _Flat
from gcode_opt.plan import T_RATIOS, empty_table
from gcode_opt.segments import SegmentRules

SAMPLE = "sample_gcode/prusa_gyroid_fullspeed.gcode"
PROFILES = ["prusa-mk3s", "voron24"]      # classic jerk, square corner velocity


# ---- references: f656414's code (verbatim but for its module's names)
def ref_candidates_chain(pin, rows, strokes, profile, rules=None):
    """candidates_chain with the beta table made and handed to _figures (f656414)."""
    rules = rules or SegmentRules.for_profile(profile, 10)
    rows = np.asarray(rows, int)
    if rows.size == 0:
        return empty_table(pin, rows)[1:]
    Tc = pin.T_orig[rows, None] * T_RATIOS[None, CHAIN_COLS]
    bc = (Tc / GAMMA_MIN) ** 2
    ok, tp, ia, iv = _figures(strokes, rows, pin, Tc, bc, profile, rules)
    _, T, beta, I, KE = empty_table(pin, rows)
    T[:, CHAIN_COLS] = tp
    I[:, CHAIN_COLS] = np.where(ok, ia, np.inf)
    KE[:, CHAIN_COLS] = iv
    beta[:, CHAIN_COLS] = bc
    return T, beta, I, KE


def ref_classify_block(b, sts, jerk, fresh=False, memo=None, unput=False, hit=None):
    """_classify_block of f656414: each chain's caps a copy of its row (an array).  Called as
    classify calls it now (ana64): geometries classify left unput are put first, as
    build_geoms then did; memo and hit unused (a new ChainMemo a chain, the feeds' test)."""
    if unput:
        curves.put_rows(b, sts, None, False)
    if not (b.cap_min and isinstance(b.cap, np.ndarray) and b.caps.ndim == 2 and b.caps.shape[1] > 0):
        return False
    if not fresh and jerk and any(st.curv._j1 is not curves._FROM_BLOCK for st in sts):
        return False
    if fresh:
        ks, cap = None, b.cap
    else:
        ks = np.array([st.curv._k for st in sts], np.int64)
        cap = b.cap[ks]
    feed = np.array([st.v_feed for st in sts], float)
    hit_a = np.flatnonzero(cap < feed)
    hit = hit_a.tolist()
    if not hit:
        return True
    caps1 = None
    if jerk and b.caps_jerk1 is not None:
        caps1 = CHAIN_CAP_MARGIN * b.caps_jerk1.take(hit_a if ks is None else ks[hit_a], axis=0)
    for i, q in enumerate(hit):
        st = sts[q]
        st.chain_T = ChainMemo()
        g = st.curv
        if caps1 is not None and g.chain_caps is None:
            g.chain_caps = caps1[i].copy()
            g.caps_jerk1 = None
    return True


def ref_flat_chains(sts, profile):
    """_flat_chains of f656414: the caps as arrays, concatenated."""
    gs = [curves.geom(st, profile) for st in sts]
    caps = chains._chain_caps(sts, gs, profile)
    return _Flat.of_arrays(chains._inner_s(gs), np.concatenate(caps),
                           np.array([c.size for c in caps], int),
                           np.array([st.length_d for st in sts], float), np.zeros(len(sts)), np.ones(len(sts)),
                           np.array([st.v0 for st in sts], float), np.array([st.v1 for st in sts], float))


# ---- beta of T
def _beta_table(T):
    return (T / GAMMA_MIN) ** 2


def test_beta_of_T_reads_as_the_table():
    rng = np.random.default_rng(45)
    T = rng.lognormal(-1.0, 1.5, (40, 5))
    T[3, 1] = 1e-300                                   # (a square that underflows)
    B = _beta_table(T)
    bt = chains._BetaOfT(T)
    assert bt.shape == B.shape and bt.ndim == 2
    for ix in (slice(5, 17), np.array([3, 0, 3, 39]), 7, (4, 2), (np.array([1, 2]), np.array([4, 0]))):
        got, want = bt[ix], B[ix]
        assert np.shape(got) == np.shape(want) and float_bits(got) == float_bits(want)


def test_cells_of_T_give_the_beta_tables_cells():
    rng = np.random.default_rng(7)
    T = rng.lognormal(-1.0, 1.5, (60, 5))
    view = T[10:50]
    row, col = rng.integers(0, 40, 300), rng.integers(0, 5, 300)
    tc = chains._Cells(view, row, col)
    bc = tc.of(chains._chain_beta)
    want = chains._Cells(_beta_table(view), row, col)
    assert bc.at is tc.at and bc.table is tc.table and bc.shape == want.shape
    for q in ([5, 0, 5], np.arange(300), np.array([299, 3], np.int64), slice(10, 40)):
        assert float_bits(bc[q]) == float_bits(want[q])
    for q in list(range(300)) + [np.int64(12)]:   # one cell: a numpy scalar's ** 2 is not the array's
        got = bc[q]
        assert type(got) is np.float64 and float_bits(got) == float_bits(want[q])


def test_outer_T_reads_as_the_table():
    rng = np.random.default_rng(11)
    base = rng.lognormal(-1.0, 2.0, 37)
    base[4] = 0.0
    f = T_RATIOS[CHAIN_COLS]
    want = base[:, None] * f[None, :]
    T = chains._OuterT(base, f)
    assert T.shape == want.shape and T.ndim == 2 and float_bits(np.array(T, float, order="C")) == float_bits(want)
    for ix in (3, slice(5, 30), np.array([36, 0, 36, 2]), (4, 1), (slice(2, 9), 3)):
        assert float_bits(T[ix]) == float_bits(want[ix])
    perm = rng.permutation(37)
    assert float_bits(np.asarray(T.take(perm, axis=0))) == float_bits(want.take(perm, axis=0))
    flat = rng.integers(-want.size, want.size, 500).astype(np.int32)
    assert float_bits(np.take(T, flat)) == float_bits(np.take(want, flat))
    got = np.take(T, np.int32(7))
    assert type(got) is np.float64 and float_bits(got) == float_bits(np.take(want, 7))
    with pytest.raises(IndexError):
        np.take(T, np.array([want.size]))
    row, col = rng.integers(0, 37, 200), rng.integers(0, f.size, 200)
    tc, wc = chains._Cells(T, row, col), chains._Cells(want, row, col)
    for q in (np.arange(200), [4, 4, 0], 17):
        assert float_bits(tc[q]) == float_bits(wc[q])
        assert float_bits(tc.of(chains._chain_beta)[q]) == float_bits(chains._Cells(_beta_table(want), row, col)[q])


def _memo_rows(strokes, rows):
    """Every chain's memo rows, and each row's kept figures (law T, beta, predicted time,
    ∫|a|²) read from its kept laws, and its source's T and beta row."""
    out = []
    for i in rows.tolist():
        m = strokes[i].chain_T
        for t, TL, b, r, kept in m.rows():
            q = [int(r)]
            base = kept.base
            out.append((t, TL, b, r, float_bits(base[3][q]), float_bits(base[4][q]), float_bits(base[5][q]),
                        float_bits(base[6][q]), float_bits(base[4][q[0]])))
        src = m.src
        if src is not None:
            out.append((float_bits(src.T[[m.src_i]]), float_bits(src.beta[[m.src_i]])))
    return out


@pytest.mark.parametrize("prof_name", PROFILES)
def test_candidates_chain_as_with_the_beta_table(prof_name):
    strokes, pin, rows, prof, rules = fresh_chains(SAMPLE, prof_name)
    want = ref_candidates_chain(pin, rows, strokes, prof, rules)
    want_rows = _memo_rows(strokes, rows)
    strokes, pin, rows, prof, rules = fresh_chains(SAMPLE, prof_name)
    got = chains.candidates_chain(pin, rows, strokes, prof, rules)
    assert [float_bits(a) for a in got] == [float_bits(a) for a in want]
    assert len(want_rows) > 3 * rows.size
    assert _memo_rows(strokes, rows) == want_rows
    # the source's beta its T's; the kept laws' T, beta and predicted times read in the memos'
    # rows (memo52: _FigsCol, where _Cells of the source's T held their places)
    m = strokes[int(rows[0])].chain_T
    assert type(m.src.beta) is chains._BetaOfT and m.src.beta.T is m.src.T and type(m.src.T) is chains._OuterT
    assert all(type(c) is chains._FigsCol and c.rows.figs is m.figs for c in m.kept.base[3:6])


# ---- the shared row numbers
def test_row_ints_are_shared():
    n = len(chains._ROW_INTS)
    assert n > chains.FINISH_ROWS and list(chains._ROW_INTS) == list(range(n))
    assert chains._row_ints(n) is chains._ROW_INTS and list(chains._row_ints(n + 3)) == list(range(n + 3))
    big = 1000 + 7                      # (an int Python does not cache itself)
    assert chains._row_int(big) is chains._ROW_INTS[big] and chains._row_int(int("12345")) == 12345


@pytest.mark.parametrize("prof_name", PROFILES)
def test_plans_and_memos_hold_the_shared_row_numbers(prof_name):
    strokes, pin, rows, prof, rules = fresh_chains(SAMPLE, prof_name)
    T, beta, _, _ = chains.candidates_chain(pin, rows, strokes, prof, rules)
    sts = [strokes[i] for i in rows.tolist()]
    for st in sts:
        m = st.chain_T
        if m.figs is not None:
            assert m.at is chains._row_int(m.at)
    c = int(CHAIN_COLS[0])
    plans = chains.plan_chain_segments(sts, T[:, c], beta[:, c], rules, prof)
    rowed = [p for p in plans if type(p).__name__ == "RowPlan"]
    assert rowed
    for p in rowed:
        assert p._row is chains._ROW_INTS[p._row]


# ---- the chains' caps kept as bytes
def _classified(prof_name, ref):
    strokes, pin, rows, prof, rules = fresh_chains(SAMPLE, prof_name)
    sts = [strokes[i] for i in rows.tolist()]
    for st in sts:                      # (classify them again, each a curve)
        st.chain_T = None
        st.curv = None
    saved = chains._classify_block
    if ref:
        chains._classify_block = ref_classify_block
    try:
        chains.classify(sts, list(range(len(sts))), prof)
    finally:
        chains._classify_block = saved
    return sts, prof


@pytest.mark.parametrize("prof_name", PROFILES)
def test_classify_keeps_the_caps_bytes(prof_name):
    ref, prof = _classified(prof_name, True)
    want = [(st.chain_T is not None, None if st.curv.chain_caps is None else float_bits(st.curv.chain_caps))
            for st in ref]
    got_sts, _ = _classified(prof_name, False)
    kinds = {type(st.curv.chain_caps) for st in got_sts}
    got = [(st.chain_T is not None, None if st.curv.chain_caps is None
            else float_bits(chains._caps_array(st.curv.chain_caps))) for st in got_sts]
    assert got == want and any(m for m, _ in want)
    if prof.junction == "jerk":        # (the caps were made at classify: bytes, not arrays)
        assert bytes in kinds and np.ndarray not in kinds
    # what the laws read: vertex_caps (an array of those doubles), the flat chains
    for st, (_, w) in zip(got_sts, want):
        if st.chain_T is not None and w is not None:
            v = chains.vertex_caps(st, prof)
            assert isinstance(v, np.ndarray) and v.dtype == np.float64 and float_bits(v) == w
    chained = [st for st in got_sts if st.chain_T is not None]
    chained_ref = [st for st in ref if st.chain_T is not None]
    a, b = chains._flat_chains(chained, prof), ref_flat_chains(chained_ref, prof)
    for f in ("sv", "cv", "nv", "S", "v0", "v1", "voff"):
        assert float_bits(getattr(a, f)) == float_bits(getattr(b, f)), f
    assert a.cv.flags.writeable


def _caps_case(rng):
    out = []
    for _ in range(int(rng.integers(1, 30))):
        x = rng.lognormal(3.0, 1.0, int(rng.integers(0, 12)))
        x[rng.random(x.size) < 0.1] = np.inf
        out.append(x.tobytes() if rng.random() < 0.5 else x)
    return out


@pytest.mark.parametrize("seed", range(8))
def test_join_caps_as_concatenate(seed):
    rng = np.random.default_rng(seed)
    for caps in (_caps_case(rng), [c.tobytes() if isinstance(c, np.ndarray) else c for c in _caps_case(rng)],
                 [np.frombuffer(c, float).copy() if isinstance(c, bytes) else c for c in _caps_case(rng)]):
        arrs = [np.frombuffer(c, float) if isinstance(c, bytes) else c for c in caps]
        assert float_bits(chains._join_caps(caps)) == float_bits(np.concatenate(arrs))
        assert chains._caps_sizes(caps).tolist() == [a.size for a in arrs]
        assert [float_bits(chains._caps_array(c)) for c in caps] == [float_bits(a) for a in arrs]


@pytest.mark.parametrize("prof_name", PROFILES)
def test_kept_caps_with_dropped_and_made_caps(prof_name):
    """_kept_caps of chains whose caps are kept (bytes), dropped (made again: the batch
    under classic jerk, or vertex_caps) and made by vertex_caps (arrays): _chain_caps'
    arrays, as f656414's _chain_caps (vertex_caps of each) gave them."""
    strokes, pin, rows, prof, rules = fresh_chains(SAMPLE, prof_name)
    sts = [strokes[i] for i in rows.tolist()]
    gs = [curves.geom(st, prof) for st in sts]
    want = [float_bits(chains.vertex_caps(st, prof)) for st in sts]
    for q in range(0, len(sts), 3):          # every third dropped, every third kept as bytes
        gs[q].chain_caps = None
        if q + 1 < len(sts):
            gs[q + 1].chain_caps = gs[q + 1].chain_caps.tobytes()
    got = chains._kept_caps(sts, gs, prof)
    assert {type(c) for c in got} == {bytes, np.ndarray}
    assert [float_bits(chains._caps_array(c)) for c in got] == want
    assert [float_bits(c) for c in chains._chain_caps(sts, gs, prof)] == want
