"""budget59 (benchmarks/budget59.md): the windowed budget runs' pieces made with fewer calls
give what they gave before, bit for bit.

- geom_keep.GeomKeep._give_parts (the runs' rows asked in part: a window's curves, then
  its chains; a later run's few chains): the asked rows' columns gathered once a record,
  each part's block taking its run of them.  Every field a consumer reads is the geometry
  build_geoms makes of those strokes, whatever the pattern asked (parts asked whole, in
  part, not at all), and κ made later in one block leaves the others' as they were."""
import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt.schedule import C_CHAIN, C_CURVE
# (the same sample, windows and store as the kept geometry's own tests)
from test_speed57_geom57 import WINDOW, _fields, _kept


def _patterns(codes):
    """Rows asked in part, the runs' ways and others: each window's chains (their parts
    whole), its curves, every third curve or chain, a run of consecutive rows, one row a
    window."""
    ours = np.flatnonzero((codes == C_CURVE) | (codes == C_CHAIN))
    win = ours // WINDOW
    first = ours[np.r_[True, win[1:] != win[:-1]]]
    return {"chains": np.flatnonzero(codes == C_CHAIN), "curves": np.flatnonzero(codes == C_CURVE),
            "third": ours[::3], "run": ours[ours.size // 3:ours.size // 3 + 2 * WINDOW], "one": first}


def _row_kept(st):
    """What the kept record gave row st.curv of its block, as bits: lengths, caps, κ, κ_eff,
    cap, end turns, its limits object and acceleration, whether κ and κ_eff are still to
    make, its chain caps."""
    b, k = st.curv._b, st.curv._k
    lim = b._lim

    def row(x):
        return None if x is None else np.asarray(x[k]).tobytes()
    return (row(b.d), row(b._caps), row(b._kv), row(b._ke), row(b.cap), repr(b.cos_end[k]), b.cap_min,
            id(lim[1][int(lim[2][k])]), row(lim[3]), b._ke_miss is not None and bool(b._ke_miss[k]),
            b._kv_miss is not None and bool(b._kv_miss[k]), st.curv.chain_caps)


def _whole(store, keep, kappa):
    """_row_kept of every curve and chain of the store given its geometry a whole window
    at a time (the candidates' way: _give_whole, the record's doubles as they are), read
    at once (build_geoms lets go of the caps and κ of the blocks alive)."""
    out = {}
    for lo in range(0, len(store), WINDOW):
        sts = store.load(lo, lo + WINDOW)
        keep.give(np.arange(lo, lo + len(sts)), sts, kappa=kappa)
        out.update((lo + k, _row_kept(st)) for k, st in enumerate(sts) if st.curv is not None)
    return out


@pytest.mark.parametrize("prof_name", ["prusa-mk3s", "voron24"])     # classic jerk; Klipper's (caps kept)
@pytest.mark.parametrize("kappa", [False, True])
def test_parts_given_are_the_made_geometry(tmp_path, prof_name, kappa):
    prof, store, keep, codes = _kept(tmp_path, prof_name)
    whole = _whole(store, keep, kappa)
    # (classic jerk: the chains' caps kept as bytes)
    assert prof.junction != "jerk" or sum(type(w[-1]) is bytes for w in whole.values()) > 10
    for name, rows in _patterns(codes).items():
        assert rows.size > 1, name
        given, want = store.take(rows), store.take(rows)
        n0 = keep.given
        keep.give(rows, given, kappa=kappa)
        assert keep.given - n0 == rows.size, name
        curves.build_geoms(want, prof, jerk1=True)
        blocks = {id(st.curv._b): st.curv._b for st in given}
        assert sum(b.d.shape[0] for b in blocks.values()) == rows.size, name    # (the rows asked alone)
        for r, a in zip(rows.tolist(), given):       # (as given: before any field is read, and made then)
            assert a.curv._b._pts[a.curv._k] is a.pts
            assert _row_kept(a) == whole[r], (name, r)
        for r, a, b in zip(rows.tolist(), given, want):
            chain = codes[r] == C_CHAIN
            assert _fields(a, chain, prof) == _fields(b, chain, prof), (name, r)


def test_kappa_made_in_one_block_leaves_the_others(tmp_path):
    """κ not given (the runs' ask): made when read, block by block; a block's rows made
    leave every other block's κ, κ_eff and their rows still to make as they were."""
    prof, store, keep, codes = _kept(tmp_path, "prusa-mk3s")
    rows = np.flatnonzero((codes == C_CURVE) | (codes == C_CHAIN))[::2]
    given, want = store.take(rows), store.take(rows)
    keep.give(rows, given)
    curves.build_geoms(want, prof, jerk1=True)
    blocks = list({id(st.curv._b): st.curv._b for st in given}.values())
    missing = [b for b in blocks if b._ke_miss is not None or b._kv_miss is not None]
    assert len(missing) > 3

    def state(b):
        return tuple(None if x is None else x.copy() for x in (b._ke_miss, b._kv_miss))
    before = {id(b): state(b) for b in blocks}
    made = missing[len(missing) // 2]
    made.make_kappa(range(made.d.shape[0]))
    assert made._ke_miss is None and made._kv_miss is None
    for b in blocks:
        if b is made:
            continue
        for x, y in zip(state(b), before[id(b)]):
            assert (x is None) == (y is None) and (x is None or (x == y).all())
    for r, a, b in zip(rows.tolist(), given, want):
        chain = codes[r] == C_CHAIN
        assert float(a.curv.kappa_eff).hex() == float(b.curv.kappa_eff).hex(), r
        assert _fields(a, chain, prof) == _fields(b, chain, prof), r


# ---------------------------------------------------------------- the chain spill's records
# - schedule._blocks_records: a put's blocks written into one array, every record's head
#   (and first knot) put in one step, a block made by the replay taken as it is (not a
#   gathered copy of its rows): each row's record the one written plan by plan (_spill_arrays).
from test_speed57_out57_readback import _records_by_row     # noqa: E402
import test_speed58_budget58 as _b58                         # noqa: E402
planned = _b58.planned                                      # (the runs' puts: a module fixture)
from gcode_opt import schedule as sc                         # noqa: E402


def _records(puts, n, made, monkeypatch=None):
    """Each put's rows' records (bytes; None: none) of a _ChainSpill of the puts (made: the
    blocks each is given); with monkeypatch, the plans not in a block given written one by
    one (no grouping by block)."""
    spill = sc._ChainSpill.make(n)
    try:
        with pytest.MonkeyPatch.context() as mp:
            if monkeypatch:
                mp.setattr(sc, "_row_plan_blocks", lambda ps: ([], [q for q, p in enumerate(ps) if p is not None]))
            for (rows, T, beta, plans, _), blocks in zip(puts, made):
                spill.put(rows, T, beta, plans, blocks)
        return [_records_by_row(spill, rows) for rows, *_ in puts]
    finally:
        spill.close()


def test_made_block_records_are_the_one_by_one_records(planned):
    puts = planned[-1]
    n = max(int(r.max()) for r, *_ in puts) + 1
    want = _records(puts, n, [[] for _ in puts], True)         # (every plan by _spill_arrays)
    assert sum(r is not None for w in want for r in w) > 100
    assert _records(puts, n, [b for *_, b in puts]) == want   # (the replay's blocks)
    # a put's blocks and plans one by one together (the first block left out), and blocks
    # given the first places of their rows only (the rest left out)
    mixed = [b[1:] + [(ii[:ii.size // 2], V, A, F, ends) for ii, V, A, F, ends in b[:1] if ii.size > 1]
             for *_, b in puts]
    assert sum(len(b) for b in mixed) > 3
    assert _records(puts, n, mixed, True) == want


def test_lone_plan_records_are_the_one_by_one_records(planned):
    """A put of one plan written by itself (no block): its whole record."""
    puts = planned[-1]
    n = max(int(r.max()) for r, *_ in puts) + 1
    want = _records(puts[:3], n, [[] for _ in puts[:3]], True)   # (a later put's record replaces a row's)
    lone = []
    for rows, T, beta, plans, _ in puts[:3]:
        q = next(q for q, p in enumerate(plans) if p is not None)
        lone.append((rows[q:q + 1], T[q:q + 1], beta[q:q + 1], plans[q:q + 1], None))
    got = _records(lone, n, [None] * len(lone), True)
    assert got == [[w[next(q for q, p in enumerate(plans) if p is not None)]] for w, (_, _, _, plans, _)
                   in zip(want, puts[:3])]
    assert all(g[0] is not None for g in got)


# ---------------------------------------------------------------- the line spill's records
# - line_spill._block_records: a block's plans' figures, verdicts and shapes read by objfields'
#   compiled passes (where built): the records the plans written one by one (_record) give.
from gcode_opt import line_spill as ls                      # noqa: E402
from gcode_opt.segments import RowPlan                      # noqa: E402
from test_speed52_runs52_windows import seg_bits            # noqa: E402


def _line_block(m=40, n=5):
    """RowPlans of one block of m rows (n segments): shapes law and trapezoid mixed, verdicts
    "" (made), None and a reason, figures of every sign, a NaN among them."""
    rng = np.random.default_rng(59)
    S = np.cumsum(rng.random((m, n + 1)), axis=1)
    V, A, F = rng.random((m, n + 1)), rng.random((m, n)) + 1.0, rng.random((m, n)) + 1.0
    plans = [RowPlan(S, V, A, F, i, float(rng.normal()), float(rng.normal())) for i in range(m)]
    for i, p in enumerate(plans):
        p.shape = ("law", "trapezoid")[i % 3 == 1]
        p.fault = ("", None, "a reason")[i % 5 % 3]
    plans[7].time_t = float("nan")
    return plans


def test_line_block_records_are_the_one_by_one_records(monkeypatch):
    plans = _line_block()
    cls, T, beta = np.arange(5, 5 + len(plans), dtype=np.int64), np.linspace(1, 2, len(plans)), np.full(len(plans), .3)
    assert len(ls._row_blocks(plans)[0]) == 1               # (one block: its records made together)
    got = []
    for one_by_one in (False, True):
        if one_by_one:
            monkeypatch.setattr(ls, "_row_blocks", lambda ps: ([], [q for q, p in enumerate(ps) if p is not None]))
        spill = ls.LineSpill.make()
        spill.put(plans, cls, T, beta)
        rows, back, rest = spill.take(np.arange(len(plans)), cls, T, beta)
        assert rows.size == len(plans) and not rest.size
        got.append([(seg_bits(p), p.fault, p.shape, type(p)) for p in back])
        spill.close()
    assert got[0] == got[1]
    assert {g[1] for g in got[0]} == {"", None} and {g[2] for g in got[0]} == {"law", "trapezoid"}
