"""Issue 8 (s49, cand49): planning's tables held smaller through the budget runs, the same bits.

- plan._rows_of: a budget run's _RowsView reads Candidates.first / cnt and the PlanInput's
  T_orig / I_orig in place where its rows are every row (they were copied: a[rows]);
  checked against that indexing (the code it replaced) on every kind of rows.
- PlanInput.set_aside: the inputs only the candidates read (L, v0, v1, v_cap, a_cap,
  mass_r, t_seg_min) are let go after the candidates (written to a temporary file) and
  read back, bit for bit, by the first read of one of them; plan_strokes with them set
  aside against plan_strokes with them kept (set_aside declining), on sample files."""
import gc
import os
import warnings

import numpy as np
import pytest

from gcode_opt import pipeline, schedule
from gcode_opt.plan import Candidates, PlanInput, _rows_of
from gcode_opt.profile import load_profile

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")


def _odd_floats(rng, n):
    """Floats with the bit patterns a copy could lose: -0.0, infinities, NaNs with payloads."""
    x = rng.normal(size=n) * 10.0 ** rng.integers(-300, 300, n)
    special = np.array([-0.0, 0.0, np.inf, -np.inf, np.nan])
    x[rng.integers(0, n, n // 10)] = special[rng.integers(0, special.size, n // 10)]
    bits = x.view(np.int64)
    nan_at = np.flatnonzero(np.isnan(x))
    bits[nan_at] |= rng.integers(1, 1 << 20, nan_at.size)      # (payloads: still NaNs)
    return x


def _pin(rng, n):
    return PlanInput(*(_odd_floats(rng, n) for _ in range(9)))


@pytest.mark.parametrize("n", [0, 1, 2, 7, 1000])
def test_rows_of_is_the_indexing(n):
    rng = np.random.default_rng(n)
    a = rng.normal(size=n)
    cases = [np.arange(n), np.arange(n, dtype=np.int32), np.arange(n, dtype=np.uint64), np.arange(n)[::-1],
             rng.permutation(n), np.sort(rng.integers(0, max(n, 1), n)) if n else np.zeros(0, int),
             np.arange(max(n - 1, 0)), np.arange(1, n), np.zeros(0, int)]
    if n >= 2:
        c = np.arange(n)
        c[-2] = c[-1]                  # n rows from 0 to n - 1, one repeated: not every row
        cases.append(c)
        c = np.arange(n)
        c[0], c[1] = c[1], c[0]        # every row, out of order
        cases.append(c)
    for rows in cases:
        got = _rows_of(a, rows)
        ref = a[rows]                  # (the code replaced)
        assert got.dtype == ref.dtype and got.shape == ref.shape
        assert np.array_equal(got.view(np.int64), ref.view(np.int64))
        if rows.size == n and np.array_equal(rows, np.arange(n)):
            assert got is a            # every row in order: no copy
        else:
            assert got is not a


def _cands(rng, n, k=5):
    mask = rng.random((n, k)) < 0.4
    m = int(mask.sum())
    vals = np.abs(rng.normal(size=(4, m))) + 0.01
    return Candidates(mask, vals, np.ones(n, bool), np.abs(rng.normal(size=n)) + 0.1)


@pytest.mark.parametrize("n", [1, 50, 3000])
def test_rows_view_of_every_row_is_the_copies(n):
    """rows_view of every row (in place) against rows_view of the same rows given as
    copies and read by indexing (the code replaced): the same fields, bit for bit."""
    rng = np.random.default_rng(n + 1)
    c = _cands(rng, n)
    T, I = np.abs(rng.normal(size=n)) + 0.1, np.abs(rng.normal(size=n))
    g = np.arange(n)
    got = c.rows_view(g, _rows_of(T, g), _rows_of(I, g))
    assert got.first is c.first and got.cnt is c.cnt and got.T_orig is T and got.I_orig is I
    ref_first, ref_cnt = c.first[g], c.cnt[g]
    ref = c.rows_view(g[::-1][::-1].copy(), T[g], I[g])
    for name in ("first", "cnt", "T_orig", "I_orig", "reps", "inv"):
        a, b = getattr(got, name), getattr(ref, name)
        assert (a is None) == (b is None)
        if a is not None:
            assert a.dtype == b.dtype and np.array_equal(a, b)
    assert np.array_equal(got.first, ref_first) and np.array_equal(got.cnt, ref_cnt)
    assert got.settle == ref.settle


def test_set_aside_reads_back_the_same_bits():
    rng = np.random.default_rng(3)
    p = _pin(rng, 5000)
    p.t_seg_min = np.full(5000, 0.0375)
    before = {name: getattr(p, name).copy() for name in PlanInput.CANDIDATE_ONLY + ("T_orig", "I_orig")}
    kept = p.T_orig, p.I_orig
    assert p.set_aside()
    for name in PlanInput.CANDIDATE_ONLY:
        assert name not in p.__dict__               # let go
    assert p.T_orig is kept[0] and p.I_orig is kept[1]
    assert getattr(p, "cached", None) is None and not hasattr(p, "no_such_field")
    assert not p.set_aside()                        # (once)
    got = p.v_cap                                   # one read: all of them back
    assert "_aside" not in p.__dict__
    for name, ref in before.items():
        a = getattr(p, name)
        assert name in p.__dict__ and a.dtype == ref.dtype and a.shape == ref.shape
        assert np.array_equal(a.view(np.int64), ref.view(np.int64))
    assert got is p.v_cap
    q = p.take(np.arange(0, 5000, 7))               # the fault isolation's retries read them all
    assert np.array_equal(q.L.view(np.int64), before["L"][::7].view(np.int64))


def test_set_aside_declines_and_keeps_them(tmp_path):
    rng = np.random.default_rng(4)
    p = _pin(rng, 10)
    arrays = {name: getattr(p, name) for name in PlanInput.CANDIDATE_ONLY}
    assert not p.set_aside(str(tmp_path / "no such folder"))       # no file: all kept
    p.L = list(p.L)                                                  # not a plain array: all kept
    assert not p.set_aside(str(tmp_path))
    for name, a in arrays.items():
        assert name in p.__dict__ and (name == "L" or getattr(p, name) is a)


def _planned(name, monkeypatch, aside):
    if not aside:
        monkeypatch.setattr(PlanInput, "set_aside", lambda self, folder=None: False)
    profile = load_profile("prusa-mk3s")
    opts = pipeline.Options()
    strokes, sim0 = pipeline.analyse(os.path.join(SAMPLES, name), profile, opts)
    pin = schedule.plan_inputs(strokes, profile, opts)
    reads = []
    get = PlanInput.__getattr__

    def counted(self, field):
        if "_aside" in self.__dict__ and field in PlanInput.CANDIDATE_ONLY:
            reads.append(field)
        return get(self, field)
    monkeypatch.setattr(PlanInput, "__getattr__", counted)
    plan = schedule.plan_strokes(strokes, pin, profile, opts, opts.max_slowdown_r * sim0.time_t)
    monkeypatch.setattr(PlanInput, "__getattr__", get)
    return plan, pin, reads


@pytest.mark.parametrize("name", ["prusa_gyroid.gcode", "prusa_mk3s_rectilinear.gcode"])
def test_plan_strokes_with_the_inputs_set_aside(name, monkeypatch):
    plan, pin, reads = _planned(name, monkeypatch, True)
    assert "_aside" in pin.__dict__ and reads == []     # let go, and not read back by the runs
    with monkeypatch.context() as m:
        ref, ref_pin, _ = _planned(name, m, False)
    assert "_aside" not in ref_pin.__dict__
    for f in ("T", "beta", "I_law", "KE_law", "t_pred", "a2_pred"):
        a, b = np.asarray(getattr(plan, f), float), np.asarray(getattr(ref, f), float)
        assert np.array_equal(a.view(np.int64), b.view(np.int64)), f
    assert np.array_equal(plan.retime, ref.retime) and list(plan.reason) == list(ref.reason)
    assert len(plan.segs) == len(ref.segs)
    for s, r in zip(plan.segs, ref.segs):
        assert (s is None) == (r is None)
    for name_ in PlanInput.CANDIDATE_ONLY:              # read back, the same as kept
        a, b = getattr(pin, name_), getattr(ref_pin, name_)
        assert np.array_equal(np.asarray(a).view(np.int64), np.asarray(b).view(np.int64))


def test_set_aside_file_closed_when_read_back_or_dropped_unread():
    """The temporary file is closed when the inputs are read back, and when the PlanInput
    goes unread (the usual case: the runs do not read them; a job stopped by an error),
    without the file object's ResourceWarning (the fault isolation tests showed 19)."""
    rng = np.random.default_rng(5)
    p = _pin(rng, 100)
    assert p.set_aside()
    fh = p.__dict__["_aside"][0]
    p.L
    assert fh.closed
    q = _pin(rng, 100)
    assert q.set_aside()
    fh = q.__dict__["_aside"][0]
    assert not fh.closed
    with warnings.catch_warnings():
        warnings.simplefilter("error", ResourceWarning)
        del q
        gc.collect()
    assert fh.closed
