"""Issue 8 (chains' memory): the candidate table keeps each candidate's knot speeds and
segment durations (_KeptLaws), not its accelerations and feeds; the plan chosen is
finished again (_replay) with the table's numbers, row by row, whatever rows are replayed
together.  The chains' memos share one array of rows per batch (ChainMemo.put_shared) and
answer as the dict they replaced.  _windows (the lookahead windows of a batch of chains in
one convolution) gives each chain's _window."""
import random

import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.schedule import plan_inputs
from gcode_opt.segments import SegmentRules
from gcode_opt.strokes import K_CHAIN

SAMPLE = "sample_gcode/prusa_gyroid_fullspeed.gcode"
_CACHE = {}


def _chains(prof_name):
    if prof_name not in _CACHE:
        prof = load_profile(prof_name)
        opts = Options()
        opts.ringing = False
        strokes, _ = analyse(SAMPLE, prof, opts)
        pin = plan_inputs(strokes, prof, opts)
        rows = np.array([i for i, s in enumerate(strokes) if chains.plan_kind(s) == K_CHAIN], int)
        _CACHE[prof_name] = (strokes, pin, rows, prof)
    return _CACHE[prof_name]


@pytest.mark.parametrize("prof_name", ["prusa-mk3s", "voron24"])
def test_plans_replayed_together_are_each_rows_own(prof_name):
    strokes, pin, rows, prof = _chains(prof_name)
    rules = SegmentRules.for_profile(prof, 10)
    for i in rows.tolist():
        strokes[i].chain_T = chains.ChainMemo()
    T, beta, I, _ = chains.candidates_chain(pin, rows, strokes, prof, rules)
    rng = np.random.default_rng(1)
    cols = chains.CHAIN_COLS[rng.integers(0, len(chains.CHAIN_COLS), rows.size)]   # a column per chain
    r = np.arange(rows.size)
    ok = np.isfinite(I[r, cols])
    assert ok.sum() > 100
    sts = [strokes[i] for i in rows[ok]]
    got = chains.plan_chain_segments(sts, T[r, cols][ok], beta[r, cols][ok], rules, prof)
    lazy = 0
    for st, p, t, b in zip(sts, got, T[r, cols][ok], beta[r, cols][ok]):
        kept, row = st.chain_T.plan_of(chains.law_T(st, t), float(b))
        lazy += isinstance(kept, chains._KeptLaws)
        want = kept.plan(row, st, rules, prof)           # the row replayed alone
        for f in ("s", "v", "accel", "feed"):
            assert np.array_equal(getattr(p, f), getattr(want, f)), f
        assert p.time_t == want.time_t and p.int_a2 == want.int_a2
        # and the table's own prediction for it
        assert p.time_t == float(t)
    assert lazy == len(sts)


def test_kept_laws_hold_no_accelerations_or_feeds():
    strokes, pin, rows, prof = _chains("prusa-mk3s")
    rules = SegmentRules.for_profile(prof, 10)
    for i in rows.tolist():
        strokes[i].chain_T = chains.ChainMemo()
    chains.candidates_chain(pin, rows, strokes, prof, rules)
    bases = {}
    for i in rows.tolist():
        m = strokes[i].chain_T
        for *_, kept in m.rows():
            bases[id(kept.base)] = kept.base
    # s30: (binding mask, pieces' durations, their offsets, T, beta, t, a2, profile) only:
    # the rows' laws, not even their knots (made again for the row chosen); s34: the mask
    # as bits, its rows given back as bools; each row's pieces (first, count) of durations
    # shared by a chunk's rows
    assert bases and all(len(b) == 8 and type(b[0]) is chains._PackedMask and b[0].bits.dtype == np.uint8
                         and len(b[0].shape) == 2 and b[0][[0]].dtype == bool and b[1].ndim == 1
                         and b[2].shape == (b[0].shape[0], 2) and all(x.ndim == 1 for x in b[3:7])
                         for b in bases.values())
    n_rows = sum(b[0].shape[0] for b in bases.values())
    assert n_rows >= 3 * rows.size


def test_windows_of_a_batch_are_each_chains_own():
    strokes, pin, rows, prof = _chains("prusa-mk3s")
    from gcode_opt import curves
    gs = [curves.geom(strokes[i], prof) for i in rows.tolist()]
    by_n = {}
    for g in gs:
        by_n.setdefault(g.d.size, []).append(g)
    assert len(by_n) > 5 and max(len(v) for v in by_n.values()) > 5
    for group in by_n.values():
        got = chains._windows(group, prof)
        for g, w in zip(group, got, strict=True):
            assert np.array_equal(w, chains._window(g, prof))


def test_chain_memo_with_shared_rows_answers_as_a_dict():
    rng = random.Random(17)
    vals = [0.5, 1.0, 1.25, 2.0, -0.0, 0.0, 3.0]
    for _ in range(300):
        memo, ref = chains.ChainMemo(), {}
        for _ in range(rng.randrange(0, 6)):
            kind = rng.randrange(3)
            k = rng.randrange(1, 4)
            rows = [(rng.choice(vals), rng.choice(vals), rng.choice(vals), float(rng.randrange(5))) for _ in range(k)]
            kept = object()
            if kind == 0:
                for row in reversed(rows):
                    memo.put(*row[:3], kept, int(row[3]))
            elif kind == 1:
                memo.put_rows(np.array(rows, float).tobytes(), k, kept)
            else:
                from array import array
                other = [(9.0, 9.0, 9.0, 0.0)] * rng.randrange(3)       # other chains' rows around
                figs = array("d", [x for row in other + rows + other for x in row])
                memo.put_shared(figs, len(other), k, kept)
            for row in reversed(rows):               # the first row is the newest
                ref[row[0]] = row[1]
                ref[("law", row[1], row[2])] = (kept, int(row[3]))
        for t in vals + [7.0, 9.0]:
            assert memo.law_of(t) == ref.get(t, t)
            for b in vals + [9.0]:
                got, want = memo.plan_of(t, b), ref.get(("law", t, b))
                assert (got is None) == (want is None)
                if want is not None:
                    assert got[0] is want[0] and got[1] == want[1]
