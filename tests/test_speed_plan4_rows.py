"""Issue 8, stop 19 (D9): schedule.SegmentCache reuses curve segment plans row by row
(lookup_rows) when their last batch gave each row its own bits: no circle law of it went to
Newton (laws/circle.NEWTON_ARCS), no stroke failed, and this BLAS gives rows their own
bits (circle.rows_invariant).  The gyroid plate's second budget run re-solved ~3.5 k
curves at the (T, beta) of the first.  These tests check the claim it rests on (a
curve's plan is the same bits in any batch that sends nothing to Newton) and that
plan_strokes gives the same plans as with batch reuse only (ddecd40's behaviour)."""
import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt import schedule as sc
from gcode_opt.laws import circle
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.segments import SegmentRules
from gcode_opt.strokes import K_CURVE

S = "sample_gcode/"


def _same_plan(a, b):
    assert (a is None) == (b is None)
    if a is None:
        return
    for f in ("s", "v", "accel", "feed"):
        x, y = getattr(a, f), getattr(b, f)
        assert type(x) is type(y) and x.dtype == y.dtype and x.shape == y.shape
        assert x.tobytes() == y.tobytes(), f
    for f in ("time_t", "int_a2"):
        x, y = getattr(a, f), getattr(b, f)
        assert type(x) is type(y) and np.float64(x).tobytes() == np.float64(y).tobytes(), f
    assert a.shape == b.shape and a.fault == b.fault and a.first_cmds == b.first_cmds


def _curve_laws(name, profile):
    prof = load_profile(profile)
    opts = Options()
    strokes, _ = analyse(S + name, prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    rows = np.array([i for i in sc._rows_by_kind(strokes)[K_CURVE] if not pin.fault[i]], int)
    T, beta, I, _ = curves.candidates_curve(pin, rows, strokes, prof)
    sts, Ts, bs = [], [], []
    for col in range(T.shape[1]):
        ok = np.isfinite(I[:, col])
        sts += [strokes[i] for i in rows[ok]]
        Ts.append(T[ok, col])
        bs.append(beta[ok, col])
    return sts, np.concatenate(Ts), np.concatenate(bs), prof, SegmentRules.for_profile(prof, opts.max_segments)


@pytest.mark.parametrize("name,profile", [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_gyroid.gcode", "voron24"),
                                          ("prusa_concentric.gcode", "ender3"),
                                          ("prusa_gyroid_fullspeed.gcode", "prusa-mk4")])
def test_curve_plans_do_not_depend_on_the_batch(name, profile):
    """A batch whose solves sent no law to Newton gives each of its curves the plan of the
    whole set; a stroke solved alone without Newton, the plan it has in the whole set."""
    assert circle.rows_invariant()
    sts, T, beta, prof, rules = _curve_laws(name, profile)
    assert len(sts) > 150
    full = curves.plan_curve_segments(sts, T, beta, rules, prof)
    rng = np.random.default_rng(len(sts))
    own = 0
    for size in (2, 3, 7, 31, 97, len(sts) // 3):
        for _ in range(10 if size < 5 else 3):
            sub = rng.permutation(rng.choice(len(sts), size, replace=False))      # any order too
            n0 = circle.NEWTON_ARCS[0]
            got = curves.plan_curve_segments([sts[i] for i in sub], T[sub], beta[sub], rules, prof)
            if circle.NEWTON_ARCS[0] != n0:
                continue
            own += 1
            for i, p in zip(sub.tolist(), got):
                _same_plan(p, full[i])
    alone = 0
    for i in range(0, len(sts), 3):
        n0 = circle.NEWTON_ARCS[0]
        p = curves.plan_curve_segments([sts[i]], T[[i]], beta[[i]], rules, prof)[0]
        if circle.NEWTON_ARCS[0] == n0:
            alone += 1
            _same_plan(p, full[i])
    assert alone > 20 and own >= 1


def _plans(name, profile, rows_kinds, monkeypatch, slowdown=None):
    monkeypatch.setattr(sc, "ROW_KINDS", rows_kinds)
    prof = load_profile(profile)
    opts = Options()
    if slowdown is not None:
        opts.max_slowdown_r = slowdown
    strokes, sim = analyse(S + name, prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    hits = []
    real = sc.SegmentCache.lookup_rows

    def spy(self, kind, rows, T, beta):
        got = real(self, kind, rows, T, beta)
        hits.append(len(got))
        return got
    monkeypatch.setattr(sc.SegmentCache, "lookup_rows", spy)
    plan = sc.plan_strokes(strokes, pin, prof, opts, opts.max_slowdown_r * sim.time_t)
    return plan, hits


@pytest.mark.parametrize("name,profile,slowdown", [("prusa_gyroid.gcode", "prusa-mk3s", None),       # rows reused
                                                   ("prusa_gyroid.gcode", "voron24", None),          # reused, Newton elsewhere
                                                   ("prusa_gyroid.gcode", "prusa-mk4", 0.01),
                                                   ("prusa_gyroid.gcode", "ender3", None),           # Newton: whole batches
                                                   ("prusa_benchy_like.gcode", "prusa-mk3s", None)])
def test_plan_strokes_same_with_row_reuse(name, profile, slowdown, monkeypatch):
    new, hits = _plans(name, profile, (K_CURVE,), monkeypatch, slowdown)
    old, hits_old = _plans(name, profile, (), monkeypatch, slowdown)
    assert sum(hits_old) == 0
    for k in ("retime", "T", "beta", "I_law", "t_pred", "a2_pred"):
        assert getattr(new, k).tobytes() == getattr(old, k).tobytes(), k
    assert list(new.reason) == list(old.reason)
    for a, b in zip(new.segs, old.segs):
        _same_plan(a, b)


def test_row_reuse_happens(monkeypatch):
    """The budget loop runs twice on this sample and its second run reuses curves by rows."""
    _, hits = _plans("prusa_gyroid.gcode", "prusa-mk3s", (K_CURVE,), monkeypatch)
    assert len(hits) == 2 and hits[1] > 40


def test_no_row_reuse_after_newton(monkeypatch):
    """A batch that sent a law to Newton is reused only whole (as before)."""
    real = circle._precond_cheb

    def lazy(n, phi, gam2, u0, u1, w_start, *tol):      # every third law left to Newton
        w, cc, ok = real(n, phi, gam2, u0, u1, w_start, *tol)
        ok[::3] = False
        return w, cc, ok
    monkeypatch.setattr(circle, "_precond_cheb", lazy)
    _, hits = _plans("prusa_gyroid.gcode", "prusa-mk3s", (K_CURVE,), monkeypatch)
    assert len(hits) == 2 and sum(hits) == 0


def test_lookup_rows_needs_the_same_law():
    cache = sc.SegmentCache()
    rows = np.array([2, 5, 9])
    T = np.array([0.0, 0.0, 1.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 3.0])
    beta = np.full(10, 4.0)
    segs = {2: "a", 5: "b", 9: "c"}
    cache.store(K_CURVE, rows, T, beta, segs, {}, own=True)
    T2 = T.copy()
    T2[5] = np.nextafter(2.0, 3.0)
    assert cache.lookup_rows(K_CURVE, np.array([2, 5, 9, 3]), T2, beta) == {2: "a", 9: "c"}
    cache.store(K_CURVE, rows, T, beta, segs, {}, own=False)
    assert cache.lookup_rows(K_CURVE, rows, T, beta) == {}
