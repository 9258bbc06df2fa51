"""Issue 8 (s22, chains' memory): once a chain's plan is made (plan_chain_segments), its
candidate rows' knots (_KeptLaws) and its law's vertex caps are dropped (chains._drop); a
later plan of another candidate (a re-plan of the budget) solves the chain again along
the same columns from the same starts (_Again, _knots_again) and finishes it as the
candidate table did.  These tests hold the plans made that way to the table's own rows
replayed by the code of 479aedb (ref_replay, verbatim), bit for bit, on real files under
classic jerk and square corner velocity, and bound what the chains keep after planning."""
import gc
import tracemalloc

import numpy as np
import pytest

from gcode_opt import chains, curves
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.schedule import plan_inputs
from gcode_opt.segments import SegmentPlan, SegmentRules
from gcode_opt.strokes import K_CHAIN

FILES = ["sample_gcode/prusa_gyroid_fullspeed.gcode", "sample_gcode/prusa_gyroid_fullspeed_klipper.gcode"]
_CACHE = {}


def _chains(path, prof_name):
    key = (path, prof_name)
    if key not in _CACHE:
        prof = load_profile(prof_name)
        opts = Options()
        opts.ringing = False
        strokes, _ = analyse(path, prof, opts)
        pin = plan_inputs(strokes, prof, opts)
        rows = np.array([i for i, s in enumerate(strokes) if chains.plan_kind(s) == K_CHAIN], int)
        _CACHE[key] = (strokes, pin, rows, prof)
    return _CACHE[key]


# ---- reference: chains._replay as it stood at 479aedb (verbatim)
def ref_replay(items, rules, profile):
    """SegmentPlans of candidate rows kept as _KeptLaws, items [(stroke, kept, row)]:
    finished again (_finish_stacked_dt by groups of the same number of segments, as the
    table did, or _finish_rows_dt chain by chain); row by row the table's numbers."""
    _finish_rows_dt, _finish_stacked_dt = chains._finish_rows_dt, chains._finish_stacked_dt
    GROUP_JUNCTIONS, FINISH_ROWS, _knots_s = chains.GROUP_JUNCTIONS, chains.FINISH_ROWS, chains._knots_s
    out = [None] * len(items)
    grouped = rules.junction in GROUP_JUNCTIONS and profile.junction == rules.junction
    gs = [curves.geom(st, profile) for st, _, _ in items]
    sk = lambda st: _knots_s(st.ends_d)       # noqa: E731
    if not grouped:
        for q, (st, kept, r) in enumerate(items):
            vk, dt, t, a2 = kept.row(r, st)
            acc, feed, _, _, _ = _finish_rows_dt(st, vk[None, :], dt[None, :], rules, profile, predict=False)
            out[q] = SegmentPlan(sk(st), vk, acc[0], feed[0], t, a2)
        return out
    by_n = {}
    for q, g in enumerate(gs):
        by_n.setdefault(g.d.size, []).append(q)
    for qs in by_n.values():
        for a in range(0, len(qs), FINISH_ROWS):
            Q = qs[a:a + FINISH_ROWS]
            rows = [items[q][1].row(items[q][2], items[q][0]) for q in Q]
            vk, dt = np.stack([x[0] for x in rows]), np.stack([x[1] for x in rows])
            sts = [items[q][0] for q in Q]
            acc, feed, _, _, _ = _finish_stacked_dt(sts, [gs[q] for q in Q], np.arange(len(Q)), vk, dt, rules,
                                                    profile, predict=False)
            for i, q in enumerate(Q):
                out[q] = SegmentPlan(sk(sts[i]), vk[i], acc[i], feed[i], rows[i][2], rows[i][3])
    return out


def _bits(x):
    return np.ascontiguousarray(np.asarray(x, float)).view(np.int64)


def _same(p, w):
    for f in ("s", "v", "accel", "feed"):
        a, b = getattr(p, f), getattr(w, f)
        if a.shape != b.shape or not np.array_equal(_bits(a), _bits(b)):
            return False
    return _bits(p.time_t) == _bits(w.time_t) and _bits(p.int_a2) == _bits(w.int_a2)


def _table(path, prof_name):
    strokes, pin, rows, prof = _chains(path, prof_name)
    rules = SegmentRules.for_profile(prof, 10)
    for i in rows.tolist():
        strokes[i].chain_T = chains.ChainMemo()
        strokes[i].curv = None            # the geometry as planning makes it (its caps read once)
    curves.build_geoms([strokes[i] for i in rows.tolist()], prof, jerk1=True)
    T, beta, I, _ = chains.candidates_chain(pin, rows, strokes, prof, rules)
    return strokes, rows, prof, rules, T, beta, I


@pytest.mark.parametrize("path", FILES)
@pytest.mark.parametrize("prof_name", ["prusa-mk3s", "voron24"])
def test_dropped_rows_made_again_are_the_tables(path, prof_name):
    """Every good row of every chain: its plan made again after the drop (one batch of all,
    then subsets of one row a chain) is the 479aedb replay of the kept row, bit for bit."""
    strokes, rows, prof, rules, T, beta, I = _table(path, prof_name)
    items, want = [], []
    for i in rows.tolist():
        st = strokes[i]
        for t, TL, b, r, kept in st.chain_T.rows():
            assert type(kept) is chains._KeptLaws
            items.append((st, TL, b))
            want.append(ref_replay([(st, kept, int(r))], rules, prof)[0])
    assert len(items) > 1000
    for i in rows.tolist():
        chains._drop(strokes[i])
        assert curves.geom(strokes[i], prof).chain_caps is None
        assert isinstance(strokes[i].chain_T.kept, chains._Again)
    got = chains._again_plans([(st, st.chain_T.kept, TL, b) for st, TL, b in items], rules, prof)
    assert all(_same(p, w) for p, w in zip(got, want))
    rng = np.random.default_rng(7)
    for _ in range(2):
        seen, sel = set(), []
        for q in np.flatnonzero(rng.random(len(items)) < 0.2).tolist():
            if id(items[q][0]) not in seen:
                seen.add(id(items[q][0]))
                sel.append(q)
        got = chains._again_plans([(items[q][0], items[q][0].chain_T.kept, items[q][1], items[q][2]) for q in sel],
                                  rules, prof)
        assert len(sel) > 50 and all(_same(p, want[q]) for p, q in zip(got, sel))


@pytest.mark.parametrize("prof_name", ["prusa-mk3s", "voron24"])
def test_replans_after_the_drop_are_the_tables(prof_name):
    """plan_chain_segments twice, as the budget's runs call it: a column per chain, then
    another for some (their rows dropped by the first): each plan is the 479aedb replay
    of the table's row for that candidate."""
    strokes, rows, prof, rules, T, beta, I = _table(FILES[0], prof_name)
    r = np.arange(rows.size)
    want = {}
    for i in rows.tolist():
        st = strokes[i]
        for t, TL, b, row, kept in st.chain_T.rows():
            want[(i, TL, b)] = ref_replay([(st, kept, int(row))], rules, prof)[0]
    rng = np.random.default_rng(3)
    cols = chains.CHAIN_COLS[rng.integers(0, len(chains.CHAIN_COLS), rows.size)]
    for step in range(3):
        ok = np.isfinite(I[r, cols])
        sel = rows[ok]
        sts = [strokes[i] for i in sel]
        got = chains.plan_chain_segments(sts, T[r, cols][ok], beta[r, cols][ok], rules, prof)
        for i, st, p, t, b in zip(sel.tolist(), sts, got, T[r, cols][ok], beta[r, cols][ok]):
            assert _same(p, want[(i, chains.law_T(st, t), float(b))])
            assert isinstance(st.chain_T.kept, chains._Again)     # dropped once planned
        move = rng.random(rows.size) < 0.3            # some chains take a neighbouring candidate
        k = np.searchsorted(chains.CHAIN_COLS, cols)
        k = np.clip(k + np.where(rng.random(rows.size) < 0.5, -1, 1), 0, len(chains.CHAIN_COLS) - 1)
        cols = np.where(move, chains.CHAIN_COLS[k], cols)


def _retained_kb(prof_name):
    """kB a chain that chains.py's allocations keep after the candidates and one plan of
    each chain (the plans held, as the planner holds them)."""
    strokes, pin, rows, prof = _chains(FILES[0], prof_name)
    rules = SegmentRules.for_profile(prof, 10)
    for i in rows.tolist():
        strokes[i].chain_T = chains.ChainMemo()
        strokes[i].curv = None
    curves.build_geoms([strokes[i] for i in rows.tolist()], prof, jerk1=True)
    gc.collect()
    tracemalloc.start(8)
    try:
        s0 = tracemalloc.take_snapshot()
        T, beta, I, _ = chains.candidates_chain(pin, rows, strokes, prof, rules)
        r = np.arange(rows.size)
        c = np.argmin(np.where(np.isfinite(I), I + 1e3 * T, np.inf), axis=1)
        ok = np.isfinite(I[r, c])
        plans = chains.plan_chain_segments([strokes[i] for i in rows[ok]], T[r, c][ok], beta[r, c][ok], rules, prof)
        del T, beta, I
        gc.collect()
        s1 = tracemalloc.take_snapshot()
    finally:
        tracemalloc.stop()
    filt = [tracemalloc.Filter(True, "*gcode_opt/chains.py")]
    diff = s1.filter_traces(filt).compare_to(s0.filter_traces(filt), "filename")
    assert len(plans) > 200
    return sum(d.size_diff for d in diff) / 1e3 / rows.size


@pytest.mark.parametrize("prof_name", ["prusa-mk3s", "voron24"])
def test_chains_keep_little_after_planning(prof_name):
    """479aedb kept ~2.7-2.9 kB a chain here (every candidate row's knots, the caps, the
    plans); the plans and the candidates' figures alone ~1.5 kB."""
    kb = _retained_kb(prof_name)
    assert kb < 2.2, kb


def test_stacked_turn_cosines_are_each_geometrys_cos_turn():
    """_finish_core's C: one einsum over the stacked directions of a group of chains gives
    each geometry's own cos_turn, bit for bit (signed zeros included), on real chains."""
    import numpy as np
    from gcode_opt import curves
    from gcode_opt.pipeline import Options, analyse, plan_inputs
    from gcode_opt.profile import load_profile
    from pathlib import Path
    sample = Path(__file__).resolve().parents[1] / "sample_gcode" / "prusa_gyroid_fullspeed.gcode"
    prof = load_profile("prusa-mk3s")
    opts = Options()
    strokes, _ = analyse(str(sample), prof, opts)
    plan_inputs(strokes, prof, opts)
    by_n = {}
    for st in strokes:
        if st.kind == "curve":
            g = curves.geom(st, prof)
            if g.d.size > 1:
                by_n.setdefault(g.d.size, []).append(g)
    assert sum(len(v) for v in by_n.values()) > 100
    for n, gs in by_n.items():
        U = np.stack([g.u for g in gs])
        got = np.einsum("mij,mij->mi", U[:, :-1], U[:, 1:])
        want = np.stack([g.cos_turn for g in gs])
        assert np.array_equal(got.view(np.int64), want.view(np.int64)), n
