"""The windowed budget runs (issue 8, budget58).  A windowed run's chain strokes made of their
records alone with their kept memos (schedule._chain_strokes: the store's take), not their windows
loaded: the strokes are the ones a window's load makes (every field; the memo the very object the
StoredStrokes keeps for the row), no window is loaded by the runs' chain plans, and the plans'
figures are the reference's (every plan kept: schedule.LAZY_CHAINS off); where a memo is not kept
yet the windows are loaded as before.  The chain spill written from the replay's blocks as
plan_chain_segments made them (its blocks), not the plans grouped again: the same records.  The
lines judged on their keys' figures by arrays (_KeyFigures, _judge_rows): _keep_plans' answers."""
import struct
from array import array

import numpy as np
import pytest

from gcode_opt import schedule as sc
from gcode_opt import strokes as stm
from gcode_opt.stored_strokes import StoredStrokes

from test_speed52_runs52_windows import seg_bits
from test_speed53_plans53_lazy import FIGURES, _stored_plan
from test_speed56_chains56 import assert_eager_plan

CASE = ("prusa_gyroid.gcode", "prusa-mk3s", 64)
_UNSET = object()


def _same_field(x, y, where):
    """y equals x, by the bits of its numbers (independently of the store's code)."""
    assert type(y) is type(x), where
    if type(x) is float:
        assert struct.pack("=d", x) == struct.pack("=d", y), where
    elif type(x) is array:
        assert x.typecode == y.typecode and x.tobytes() == y.tobytes(), where
    elif type(x) is stm.Points:
        assert x.xy.tobytes() == y.xy.tobytes(), where
    elif x is None or type(x) in (int, bool, str):
        assert x == y, where
    else:
        for nm in getattr(x, "__slots__", ()):
            _same_field(getattr(x, nm, None), getattr(y, nm, None), f"{where}.{nm}")


@pytest.fixture(scope="module")
def planned():
    """(strokes, store, plan, pin) of the windowed runs (lazy chains: the memos kept in the
    StoredStrokes' side table), and the reference's figures (every plan kept)."""
    mp = pytest.MonkeyPatch()
    try:
        mp.setattr(sc, "LAZY_CHAINS", False)
        _, store, _, _, plan, _ = _stored_plan(*CASE)
        ref = {k: getattr(plan, k).copy() for k in FIGURES}, list(plan.reason), [seg_bits(p) for p in plan.segs]
        store.close()
    finally:
        mp.undo()
    loads, puts = [], []
    chain_plans, put = sc._chain_plans, sc._ChainSpill.put

    def counted(strokes, *a, **k):
        n0 = strokes.loads
        out = chain_plans(strokes, *a, **k)
        loads.append((a[3].size, strokes.loads - n0))
        return out

    def kept(self, rows, T, beta, plans, made=None):
        puts.append((rows, T, beta, plans, made))
        return put(self, rows, T, beta, plans, made)
    mp.setattr(sc, "_chain_plans", counted)
    mp.setattr(sc._ChainSpill, "put", kept)
    try:
        strokes, store, _, _, plan, pin = _stored_plan(*CASE)
    finally:
        mp.undo()
    yield strokes, plan, pin, ref, loads, puts
    store.close()


def test_runs_chain_plans_load_no_window(planned):
    strokes, plan, pin, ref, loads, _ = planned
    assert len(loads) > 1 and sum(n for n, _ in loads) > 100       # (chains planned by the runs)
    assert [k for _, k in loads] == [0] * len(loads)
    assert_eager_plan(plan, pin, strokes, ref, 64, timed_only=True)     # (the rewrite's plans too)
    sc.segs_for(plan, np.arange(0), strokes)


def test_chain_strokes_are_the_loaded_ones(planned):
    strokes, plan, pin, _, _, _ = planned
    rows = np.flatnonzero(pin.plan_kind_codes == sc.C_CHAIN)
    rows = rows[::2]                            # (rows of several windows, not all of a window)
    assert rows.size > 40 and np.unique(rows // strokes.window).size >= 3
    n0 = strokes.loads
    got = sc._chain_strokes(strokes, rows)
    assert strokes.loads == n0                  # (no window loaded)
    assert len(got) == rows.size
    for st, i in zip(got, rows.tolist()):
        ref = strokes[i]                        # (its window loaded: the memo from the side table)
        assert st is not ref and type(st) is type(ref)
        assert st.chain_T is ref.chain_T and st.chain_T is not None, i
        for f in stm.FIELDS:
            if f in ("chain_T", "curv"):
                continue
            _same_field(getattr(ref, f, _UNSET), getattr(st, f, _UNSET), f"{i}.{f}")
        assert st.curv is None                  # (a cache: made by _rebuild_geometry)
    strokes.let_go()


def test_chain_strokes_without_kept_memos_load_their_windows(planned):
    """A StoredStrokes keeping no memo for a row (none kept yet, or a row without one): its
    windows are loaded, the strokes are theirs (a memo the store made would be lost)."""
    strokes, plan, pin, _, _, _ = planned
    rows = np.flatnonzero(pin.plan_kind_codes == sc.C_CHAIN)[:40]
    fresh = StoredStrokes(strokes.store, strokes.window, held=10 ** 6, keep=("chain_T",))   # (its objects stay)
    got = sc._chain_strokes(fresh, rows)            # (no side table yet)
    assert fresh.loads > 0
    assert all(st is fresh[i] for st, i in zip(got, rows.tolist()))
    fresh.let_go()
    rows = np.r_[rows, np.flatnonzero(pin.plan_kind_codes != sc.C_CHAIN)[:3]]
    rows.sort()
    n0 = fresh.loads
    got = sc._chain_strokes(fresh, rows)            # (a row kept without a memo: None)
    assert fresh.loads > n0
    assert all(st is fresh[i] for st, i in zip(got, rows.tolist()))
    fresh.let_go()


class _Fig:
    """A plan as _keep_plans reads it: its verdict and figures."""
    __slots__ = ("fault", "int_a2", "time_t")

    def __init__(self, fault, int_a2, time_t):
        self.fault, self.int_a2, self.time_t = fault, int_a2, time_t


class _Plan:
    def __init__(self, n):
        self.retime = np.ones(n, bool)
        self.reason = np.full(n, "", object)
        self.t_pred, self.a2_pred = np.full(n, -1.0), np.full(n, -2.0)
        self.segs = [None] * n


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rows_judged_on_key_figures_as_keep_plans(seed):
    """_judge_rows on a _KeyFigures of keys' plans (fine, faulty, none, failed, beating or
    not, a NaN figure) gives what _keep_plans gives the rows holding their keys' plans."""
    rng = np.random.default_rng(seed)
    n_keys, n = 60, 500
    made, failed = [], []
    for k in range(n_keys):
        c = rng.integers(1 if k < 25 else 0, 10)     # (no failure among the first 25)
        failed.append("error: segments (boom)" if c == 0 else None)
        made.append(None if c <= 1 else _Fig("bad knots" if c == 2 else "", float("nan") if c == 3
                                             else float(rng.uniform(1, 10)), float(rng.uniform(0.1, 2))))
    rows = np.sort(rng.choice(2 * n, n, replace=False))
    key = rng.integers(0, n_keys, n)
    a2_row = np.array([f.int_a2 if f is not None else 5.0 for f in (made[k] for k in key.tolist())])
    a2_orig = a2_row * rng.choice([0.5, 1.0, 1.0 + 1e-12, 2.0], n)        # (beats, ties, rounding, not)
    ref, got = _Plan(2 * n), _Plan(2 * n)
    seg_l = [made[k] for k in key.tolist()]
    why = {i: failed[k] for i, k in zip(rows.tolist(), key.tolist()) if failed[k]}
    assert why and any(f is None for f in seg_l)
    sc._keep_plans(ref, None, rows, seg_l, why, None, a2_orig, in_place=True)
    figs = sc._KeyFigures()
    figs.add(made[:25])                          # (the keys in two parts, the first with no failure)
    figs.add(made[25:], failed[25:])
    figs.done()
    for a in range(0, n, 128):
        sc._judge_rows(got, rows[a:a + 128], key[a:a + 128], figs, a2_orig[a:a + 128])
    assert got.retime.tolist() == ref.retime.tolist()
    assert got.reason.tolist() == ref.reason.tolist()
    assert got.t_pred.tobytes() == ref.t_pred.tobytes()
    assert got.a2_pred.tobytes() == ref.a2_pred.tobytes()
    assert got.segs == ref.segs                  # (no plan put)
    kept = ref.retime[rows]
    assert kept.any() and not kept.all()
    assert {sc._NOT_BEATING, "bad knots", "error: segments (boom)"} <= set(ref.reason.tolist())


def _spilled(puts, made):
    """A _ChainSpill of the runs' puts (made: with the blocks given, else grouped by the
    spill), and each put's rows read back: (rows with a record, their plans' bits, others)."""
    spill = sc._ChainSpill.make(max(int(r.max()) for r, *_ in puts) + 1)
    out = []
    try:
        for rows, T, beta, plans, blocks in puts:
            spill.put(rows, T, beta, plans, blocks if made else None)
        for rows, T, beta, plans, _ in puts:
            got, back, other = spill.take(rows, T, beta)
            out.append((got.tolist(), [seg_bits(p) + (p.fault,) for p in back], other.tolist()))
    finally:
        spill.close()
    return out


def test_spill_of_made_blocks_is_the_grouped_one(planned):
    _, _, _, _, _, puts = planned
    assert len(puts) > 1 and all(b is not None for *_, b in puts)
    n_made = 0
    for rows, T, beta, plans, blocks in puts:        # (the blocks are the plans' own)
        for ii, V, A, F, ends in blocks:
            for i, q in enumerate(ii.tolist()):
                p = plans[q]
                assert type(p) is sc.RowPlan and p._v is V and p._accel is A and p._feed is F and p._row == i
                assert p._s is ends[i]
            n_made += ii.size
    assert n_made > 50
    ref = _spilled(puts, False)
    assert sum(len(g) for g, _, _ in ref) > 50
    assert _spilled(puts, True) == ref


def test_spill_of_made_blocks_writes_the_other_plans(planned):
    """Plans in no block given (a block left out, a block of another type) are grouped by
    the spill as before: the same records."""
    _, _, _, _, _, puts = planned
    ref = _spilled(puts, False)
    cut = []
    for rows, T, beta, plans, blocks in puts:
        odd = [(ii, V.astype(np.float32), A, F, ends) for ii, V, A, F, ends in blocks[1:2]]
        cut.append((rows, T, beta, plans, blocks[2:] + odd))
    assert _spilled(cut, True) == ref


def test_made_blocks_are_the_plans_places():
    """plan_chain_segments' blocks name the answer's places, where the replayed chains are a
    part of the chains asked (the others: a last plan kept, its rows dropped): each place's
    plan is the block's row, and the plans are those of a call without blocks."""
    from test_speed22_chainmem_drop import FILES, _table
    got = []
    for blocks in (None, []):
        strokes, rows, prof, rules, T, beta, I = _table(FILES[0], "prusa-mk3s")
        r = np.arange(rows.size)
        c = np.argmin(np.where(np.isfinite(I), I + 1e3 * T, np.inf), axis=1)
        ok = np.isfinite(I[r, c])
        sts, Tc, bc = [strokes[i] for i in rows[ok]], T[r, c][ok], beta[r, c][ok]
        sc.chains.plan_chain_segments(sts[::3], Tc[::3], bc[::3], rules, prof)    # (their last plans kept)
        plans = sc.chains.plan_chain_segments(sts, Tc, bc, rules, prof, remember=False, keep_laws=False,
                                              blocks=blocks)
        got.append([seg_bits(p) for p in plans])
    assert got[0] == got[1]
    placed = np.concatenate([ii for ii, *_ in blocks])
    assert placed.size > 100 and np.unique(placed).size == placed.size
    assert not np.isin(placed, np.arange(0, len(sts), 3)).any()     # (the kept last plans: not replayed)
    for ii, V, A, F, ends in blocks:
        for i, q in enumerate(ii.tolist()):
            p = plans[q]
            assert type(p) is sc.RowPlan and p._v is V and p._accel is A and p._feed is F and p._row == i
            assert p._s is ends[i]
