"""A windowed run's chain calls (issue 8, chains56): schedule._chain_calls cuts a run's chain
rows into windows of rows, joining consecutive windows while a call has at most
window // CHAIN_CALL_SHARE rows (a later run re-plans few chains a window: ~30 on the gyroid
plate at 1 k, each call paying its set-up by segment count).  The parts against a rule
written here; and on real samples (chains crossing windows, two budget runs) the joined
calls' figures and remade plans the eager reference's (LAZY_CHAINS off) bit for bit, at
the default share and with every window joined."""
import numpy as np
import pytest

from gcode_opt import schedule as sc

from test_speed52_runs52_windows import seg_bits
from test_speed53_plans53_lazy import FIGURES, _stored_plan
from test_speed54_chainplans_lazy import _eager


def _parts_by_rule(rows, window, most):
    """The parts as the rule reads: whole windows in order, a window joined to the part
    before while the part stays within most rows."""
    parts = []
    for w in sorted(set((rows // window).tolist())):
        win = rows[rows // window == w].tolist()
        if parts and len(parts[-1]) + len(win) <= most:
            parts[-1] += win
        else:
            parts.append(win)
    return parts


@pytest.mark.parametrize("window", (1, 4, 37, 64, 1024))
def test_chain_calls_join_small_windows(window):
    rng = np.random.default_rng(window)
    for _ in range(30):
        n = int(rng.integers(0, 6 * window + 3))
        dense = rng.random() < 0.5              # (windows fuller than the share, and sparse ones)
        rows = np.flatnonzero(rng.random(n) < (0.9 if dense else 0.05)).astype(np.int64)
        got = [p.tolist() for p in sc._chain_calls(rows, window)]
        assert got == _parts_by_rule(rows, window, max(1, window // sc.CHAIN_CALL_SHARE))
        assert sum(map(len, got)) == rows.size


# (sample, profile, window, share): the default share (prusa_gyroid at 64: its last windows'
# chains joined), a window's rows (fullspeed at 37: 7..33 chains a window), every window joined
# (fullspeed's with -m slow)
CASES = [("prusa_gyroid.gcode", "prusa-mk3s", 64, sc.CHAIN_CALL_SHARE),
         ("prusa_gyroid_fullspeed.gcode", "prusa-mk3s", 37, 1),
         pytest.param("prusa_gyroid_fullspeed.gcode", "prusa-mk3s", 37, 1e-9, marks=pytest.mark.slow),
         ("prusa_gyroid.gcode", "prusa-mk3s", 64, 1e-9)]


@pytest.mark.parametrize("name,prof_name,window,share", CASES)
def test_joined_chain_calls_are_the_eager_plans(name, prof_name, window, share, monkeypatch):
    fig, reason, segs, _ = _eager(name, prof_name, window, monkeypatch)
    monkeypatch.setattr(sc, "CHAIN_CALL_SHARE", share)
    calls = []
    chain_plans = sc._chain_plans

    def spy(strokes, plan, rules, profile, rows, spill=None):
        calls.append(rows.copy())
        return chain_plans(strokes, plan, rules, profile, rows, spill)
    monkeypatch.setattr(sc, "_chain_plans", spy)
    strokes, store, _, _, plan, pin = _stored_plan(name, prof_name, window)
    with store:
        joined = [r for r in calls if np.unique(r // window).size > 1]
        assert joined                           # (calls over several windows were made)
        assert all(r.size <= max(1, int(window / share)) for r in joined)
        assert_eager_plan(plan, pin, strokes, (fig, reason, segs), window)


def assert_eager_plan(plan, pin, strokes, eager, step, timed_only=False):
    """plan (a windowed run's) has the eager run's figures and reasons, re-times more than 50
    chains, and the rewrite's remake (segs_for, step rows at a time: the spill's records)
    gives every row (timed_only: every re-timed chain) the eager run's segment plan, bit
    for bit."""
    fig, reason, segs = eager
    for k in FIGURES:
        assert getattr(plan, k).tobytes() == fig[k].tobytes(), k
    assert list(plan.reason) == reason
    timed = np.flatnonzero(plan.retime & (pin.plan_kind_codes == sc.C_CHAIN))
    assert timed.size > 50
    every = np.arange(len(strokes))
    for a in range(0, every.size, step):
        rows = every[a:a + step]
        sc.segs_for(plan, rows, strokes)
        for i in (np.intersect1d(rows, timed) if timed_only else rows).tolist():
            assert seg_bits(plan.segs[i]) == segs[i], i


def _items_of_many_sources(store, pin, prof, parts=6):
    """[(stroke, its memo's source, its row there, T, beta)] of the sample's chains, their
    candidates made in parts (a _Source each, as a windowed run's windows make them), each
    at a column of its table (the columns in turn); and the number of sources."""
    strokes = store.load(0, len(store))         # (fresh memos)
    rows = np.flatnonzero(pin.plan_kind_codes == sc.C_CHAIN)
    sc._rebuild_geometry(strokes, rows, np.full(rows.size, sc.C_CHAIN), prof)
    for part in np.array_split(rows, parts):
        sc.chains.candidates_chain(pin, part, strokes, prof)
    items = []
    for j, st in enumerate(map(strokes.__getitem__, rows.tolist())):
        src, i = st.chain_T.src, st.chain_T.src_i
        c = j % src.T.shape[1]
        T, beta = src.T[[i]][0, c], src.beta[[i]][0, c]
        if np.isfinite(T) and np.isfinite(beta):
            items.append((st, src, i, float(T), float(beta)))
    return items, len({id(it[1]) for it in items})


def _knots_bits(got):
    return [tuple(np.ascontiguousarray(a).tobytes() if isinstance(a, np.ndarray) else repr(a) for a in g)
            for g in got]


@pytest.mark.parametrize("laws", (False, pytest.param(True, marks=pytest.mark.slow)))
def test_knots_again_over_several_sources(laws, monkeypatch):
    """_knots_again solves the chains of several sources of the same columns together: each
    one's knots (and law) those of its source's chains solved alone."""
    _, store, prof, _, _, pin = _stored_plan("prusa_gyroid_fullspeed.gcode", "prusa-mk3s", 37)
    with store:
        items, n_src = _items_of_many_sources(store, pin, prof)
        assert n_src == 6 and len(items) > 100
        assert len(sc.chains._by_columns(items)) < n_src        # (sources joined)
        got = _knots_bits(sc.chains._knots_again(items, prof, laws))
        by_src = {}
        for q, it in enumerate(items):
            by_src.setdefault(id(it[1]), []).append(q)
        want = [None] * len(items)
        for qs in by_src.values():      # (each source's chains alone)
            for q, k in zip(qs, _knots_bits(sc.chains._knots_again([items[q] for q in qs], prof, laws))):
                want[q] = k
        assert got == want


def _batch(rng, m, n):
    """(ends a row, V, A, F, time_t, int_a2) of m chains of n segments, some rows broken
    (non-finite, negative or zero, ends not increasing, the first end 0, figures not finite)."""
    from array import array
    E = np.cumsum(rng.uniform(0.1, 2.0, (m, n)), axis=1)
    V, A, F = rng.uniform(0.0, 50.0, (m, n + 1)), rng.uniform(1.0, 900.0, (m, n)), rng.uniform(1.0, 90.0, (m, n))
    V[rng.random((m, n + 1)) < 0.02] = 0.0          # (>= 0: fine)
    t, a2 = rng.uniform(0.1, 2.0, m), rng.uniform(0.1, 5.0, m)
    for i in np.flatnonzero(rng.random(m) < 0.5).tolist():
        j, k = int(rng.integers(0, max(n, 1))), int(rng.choice((1, 5, 8, 9) if n == 0 else 10))
        X = (E, V, A, F, E, V, A, F, t, a2)[k]
        bad = (np.nan, -1e-300, 0.0, np.inf, E[i, j - 1] if j else 0.0, np.nan, -0.0, -np.inf, np.nan, np.inf)[k]
        if X.ndim == 1:
            X[i] = bad
        else:
            X[i, j] = bad
    return [array("d", E[i].tobytes()) for i in range(m)], V, A, F, t.tolist(), a2.tolist()


def _plans(batch):
    ends, V, A, F, t, a2 = batch
    return [sc.RowPlan(ends[i], V, A, F, i, t[i], a2[i]) for i in range(len(ends))]


@pytest.mark.parametrize("knots", (60, 300, 1 << 14))
def test_ends_settle_is_settle_ends_plans(knots, monkeypatch):
    """_EndsSettle's verdicts (fault "" or left None) = _settle_ends_plans' batch by batch, on
    batches of 0..6 segments with broken rows, flushed every few batches or once (the batches
    of knots or more settled alone)."""
    monkeypatch.setattr(sc.chains, "SETTLE_KNOTS", knots)
    rng = np.random.default_rng(knots)
    batches = [_batch(rng, int(rng.integers(1, 40)), int(rng.integers(0, 7))) for _ in range(60)]
    want, got = [], []
    settle = sc.chains._EndsSettle()
    for b in batches:
        ref, mine = _plans(b), _plans(b)
        sc.chains._settle_ends_plans(ref, *b[:4])
        settle.add(mine, *b[:4])
        want.append(ref)
        got.append(mine)
    settle.flush()
    want = [p.fault for ps in want for p in ps]
    assert [p.fault for ps in got for p in ps] == want
    assert 0.2 < want.count("") / len(want) < 0.9       # (both verdicts met)


def test_base_rows_of_spilled_laws(monkeypatch, tmp_path):
    """_base_rows of a windowed run's kept laws (spilled: _FigsCol, _SpilledRows of one block)
    reads each block once, without indexing its arrays one by one, the same numbers as they
    give indexed."""
    from test_speed55_memo55_spill import _windowed
    _, _, _, kept = _windowed(monkeypatch, True, folder=tmp_path)
    bases = list({id(k.base): k.base for k in kept if type(k) is sc.chains._KeptLaws}.values())
    assert len(bases) > 3           # (finish57: a call's groups in bases of up to FINISH_ROWS rows)
    assert any(type(b[0]) is sc.chains._RaggedMask for b in bases)
    rng = np.random.default_rng(5)
    want = []
    for b in bases:
        qq = np.flatnonzero(b[3].rows.pos() >= 0)
        qq = rng.permutation(qq)[:max(1, qq.size // 2)]
        want.append((qq, [np.asarray(x).tobytes() for x in (b[3][qq], b[4][qq], b[5][qq], b[6][qq], _mask_rows(b, qq),
                                                            b[2][qq], b[1][np.arange(len(b[1]))])]))

    def no(*a):
        raise AssertionError("a spilled array indexed alone")
    monkeypatch.setattr(sc.chains._SpilledRows, "__getitem__", no)
    monkeypatch.setattr(sc.chains._FigsCol, "__getitem__", no)
    for b, (qq, bits) in zip(bases, want):
        got = sc.chains._base_rows(b, qq)
        tj = got[6][np.arange(got[6].shape[0])]
        mask = (got[4][0].tobytes() + np.asarray(got[4][1], np.int64).tobytes() if type(got[4]) is tuple
                else got[4].tobytes())          # (a merged base's: bools, widths)
        assert [np.asarray(x).tobytes() for x in got[:4]] + [mask] + [x.tobytes() for x in (got[5], tj)] == bits


def _mask_rows(b, qq):
    """The binding masks of the rows qq of the base b: a _PackedMask's rows, or a merged base's
    (_RaggedMask) rows' bools one after the other then their widths, cut row by row from its
    bits unpacked whole."""
    if type(b[0]) is not sc.chains._RaggedMask:
        return b[0][qq]
    m = b[0]
    bools = np.unpackbits(np.asarray(m.bits[np.arange(len(m.bits))])).astype(bool)
    rows, at = [], 0
    for g in range(m.w.size):
        for _ in range(int(m.at[g + 1] - m.at[g])):
            rows.append((bools[at:at + int(m.w[g])], int(m.w[g])))
            at += int(m.w[g])
    return np.concatenate([np.concatenate([rows[q][0] for q in qq]).astype(bool).view(np.uint8),
                           np.array([rows[q][1] for q in qq], np.int64).view(np.uint8)])
