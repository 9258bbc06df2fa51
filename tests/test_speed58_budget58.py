"""The windowed budget runs' chains (issue 8, budget58): a windowed run's chain strokes made of
their records alone with their kept memos (schedule._chain_strokes: the store's take), not their
windows loaded.  The strokes are the ones a window's load makes (every field; the memo the very
object the StoredStrokes keeps for the row), no window is loaded by the runs' chain plans, and
the plans' figures are the reference's (every plan kept: schedule.LAZY_CHAINS off); where a
memo is not kept yet the windows are loaded as before."""
import struct
from array import array

import numpy as np
import pytest

from gcode_opt import schedule as sc
from gcode_opt import strokes as stm
from gcode_opt.stored_strokes import StoredStrokes

from test_speed52_runs52_windows import seg_bits
from test_speed53_plans53_lazy import FIGURES, _stored_plan

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
    loads = []
    chain_plans = sc._chain_plans

    def counted(strokes, *a, **k):
        n0 = strokes.loads
        out = chain_plans(strokes, *a, **k)
        loads.append((a[3].size, strokes.loads - n0))
        return out
    mp.setattr(sc, "_chain_plans", counted)
    try:
        strokes, store, _, _, plan, pin = _stored_plan(*CASE)
    finally:
        mp.undo()
    yield strokes, plan, pin, ref, loads
    store.close()


def test_runs_chain_plans_load_no_window(planned):
    strokes, plan, pin, (fig, reason, segs), loads = planned
    assert len(loads) > 1 and sum(n for n, _ in loads) > 100       # (chains planned by the runs)
    assert [k for _, k in loads] == [0] * len(loads)
    for k in FIGURES:
        assert getattr(plan, k).tobytes() == fig[k].tobytes(), k
    assert list(plan.reason) == reason
    timed = np.flatnonzero(plan.retime & (pin.plan_kind_codes == sc.C_CHAIN))
    assert timed.size > 50
    every = np.arange(len(strokes))
    for a in range(0, every.size, 64):          # (the rewrite's chains' plans: the reference's bits)
        rows = every[a:a + 64]
        sc.segs_for(plan, rows, strokes)
        for i in np.intersect1d(rows, timed).tolist():
            assert seg_bits(plan.segs[i]) == segs[i], i
    sc.segs_for(plan, every[:0], strokes)


def test_chain_strokes_are_the_loaded_ones(planned):
    strokes, plan, pin, _, _ = planned
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
    strokes, plan, pin, _, _ = planned
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
