"""Session 32 (issue 8, memory): schedule._candidates lets each kind's dense candidate
table go once it is kept sparse (a loop variable held the last one through the next
kind's solve), and makes the lines' candidates last; the tables it gives are the same."""
import os
import weakref

import numpy as np

from gcode_opt import pipeline as pl
from gcode_opt import schedule as sc
from gcode_opt.profile import load_profile

SAMPLES = os.path.join(os.path.dirname(__file__), "..", "sample_gcode")


def _setup(name="prusa_gyroid.gcode", profile="prusa-mk3s"):
    prof = load_profile(profile)
    opts = pl.Options()
    strokes, _ = pl.analyse(os.path.join(SAMPLES, name), prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    return strokes, pin, prof, opts


def _run(strokes, pin, prof, opts):
    failed = {i: str(r) for i, r in enumerate(pin.fault) if r}
    cands, _ = sc._candidates(strokes, pin, prof, opts, sc._rows_by_kind(strokes), failed)
    return cands, failed


def test_dense_tables_freed_before_the_next_kind(monkeypatch):
    strokes, pin, prof, opts = _setup()
    rows = sc._rows_by_kind(strokes)
    dense = [k for k in sc.KINDS if k != sc.K_LINE and rows[k].size]
    assert len(dense) >= 2                      # curves and chains on this sample
    refs, order, alive_at_call = {}, [], {}
    for k in dense:
        real = sc.KINDS[k]

        def cand(pin_, r, sts, prof_, rules, k=k, real=real):
            # every table made before this call is dead by now
            alive_at_call[k] = [j for j, rs in refs.items() if any(w() is not None for w in rs)]
            order.append(k)
            tables = real.candidates(pin_, r, sts, prof_, rules)
            refs[k] = [weakref.ref(t) for t in tables]
            return tables
        monkeypatch.setitem(sc.KINDS, k, sc.Kind(cand, real.fixed_alpha, real.segments, real.adjust_inputs,
                                                 real.batch))
    _run(strokes, pin, prof, opts)
    assert order == dense
    assert all(not v for v in alive_at_call.values()), alive_at_call


def test_same_tables_as_the_kinds_in_their_own_order(monkeypatch):
    strokes, pin, prof, opts = _setup()
    got, failed = _run(strokes, pin, prof, opts)
    # the reference: the kinds in KINDS' order (lines first), as before this change
    monkeypatch.setattr(sc, "LINES_LAST", False)
    strokes2, pin2, _, _ = _setup()
    want, failed2 = _run(strokes2, pin2, prof, opts)
    assert failed == failed2
    assert np.array_equal(got.mask, want.mask)
    assert got.vals.tobytes() == want.vals.tobytes()
    assert np.array_equal(got.t_pos, want.t_pos)
    assert np.array_equal(got.first, want.first) and np.array_equal(got.cnt, want.cnt)
