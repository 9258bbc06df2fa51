"""Issue 8, stop 18 (D8): curves.plan_curve_segments finishes the curves of one knot count in
arrays (curves.finish_curves: _finish_rows, _jerk_junction_rows, _predict_rows) instead of
one finish_curve call per stroke.  Every SegmentPlan field must be the same bits and type
as 9bb98a8's loop over finish_curve, copied below (it calls the live junction_accels and
predict_curve, which tests/test_speed_budget.py pins to their earlier forms)."""

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt import schedule as sc
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.segments import SegmentPlan, SegmentRules, hold_cruise_accels, segment_feeds
from gcode_opt.strokes import K_CURVE

S = "sample_gcode/"


def _old_finish_curve(st, sk, vk, rules, profile):
    g = curves.geom(st, profile)
    d = sk[1:] - sk[:-1]
    v2 = vk * vk
    acc = np.abs(v2[1:] - v2[:-1]) / (2.0 * d)
    a_top = min(st.accel, st.lim.ax_max, st.lim.ay_max)
    acc = curves.junction_accels(st, g, vk, acc, rules, profile)
    step_v = np.inf
    if rules.junction == "jerk":
        step_v = curves.JERK_F_STEP_R * min(st.lim.jerk_x, st.lim.jerk_y)
    acc = hold_cruise_accels(acc, a_top)
    feeds = segment_feeds(vk, st.v_feed, step_v)
    c0 = None if st.prev_u is None else curves.dot2(st.prev_u, g.u[0])
    c1 = None if st.next_u is None else curves.dot2(g.u[-1], st.next_u)
    t_pred, a2_pred = curves.predict_curve(sk, vk, acc, g.cos_turn, c0, c1)
    return SegmentPlan(sk, vk, acc, feeds, t_pred, a2_pred)


def _same_plan(a, b):
    for f in ("s", "v", "accel", "feed"):
        x, y = getattr(a, f), getattr(b, f)
        assert type(x) is type(y) and x.dtype == y.dtype and x.shape == y.shape, f
        assert x.tobytes() == y.tobytes(), (f, x, y)
    for f in ("time_t", "int_a2"):
        x, y = getattr(a, f), getattr(b, f)
        assert type(x) is type(y), (f, type(x), type(y))
        assert np.float64(x).tobytes() == np.float64(y).tobytes(), (f, x, y)
    assert a.shape == b.shape and a.first_cmds == b.first_cmds
    # stop 19 (D9): finish_curves keeps schedule.seg_fault's verdict "" on the plans whose
    # blocks pass its checks (segments.fine_rows); the old plan has none yet: its own verdict
    assert a.fault == b.fault or (a.fault == "" and b.fault is None and sc.seg_fault(b) == "")


def _curve_knots_of(name, profile):
    prof = load_profile(profile)
    opts = Options()
    strokes, _ = analyse(S + name, prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    rows = np.array([i for i in sc._rows_by_kind(strokes)[K_CURVE] if not pin.fault[i]], int)
    T, beta, I, _ = curves.candidates_curve(pin, rows, strokes, prof)
    sts, Ts, bs = [], [], []
    for col in range(T.shape[1]):                      # every finite candidate: several laws a stroke
        ok = np.isfinite(I[:, col])
        sts += [strokes[i] for i in rows[ok]]
        Ts.append(T[ok, col])
        bs.append(beta[ok, col])
    Tc, bc = np.concatenate(Ts), np.concatenate(bs)
    return sts, curves.curve_knots(sts, Tc, bc, prof), prof, SegmentRules.for_profile(prof, opts.max_segments)


@pytest.mark.parametrize("name,profile", [("prusa_gyroid.gcode", "prusa-mk3s"),      # jerk, buffer 16
                                          ("prusa_gyroid.gcode", "prusa-mk4"),       # jerk, buffer 32
                                          ("prusa_gyroid.gcode", "voron24"),         # scv, no buffer
                                          ("prusa_gyroid.gcode", "ender3"),          # jd, buffer 16
                                          ("prusa_concentric.gcode", "prusa-mk3s")])
def test_finish_curves_same_plans(name, profile):
    sts, knots, prof, rules = _curve_knots_of(name, profile)
    assert len(sts) > 50
    got = curves.finish_curves(sts, knots, rules, prof)
    n_ends = 0
    for st, (sk, vk), g in zip(sts, knots, got):
        _same_plan(g, _old_finish_curve(st, sk, vk, rules, prof))
        n_ends += st.prev_u is not None or st.next_u is not None
    assert n_ends > 10


def test_edge_knots_same_plans():
    """Cruise segments (ramp accelerations 0), stops at the ends, a NaN speed, one-segment
    strokes, a stroke that cruises whole: the array form takes them as finish_curve does."""
    sts, knots, prof, rules = _curve_knots_of("prusa_gyroid.gcode", "prusa-mk3s")
    rng = np.random.default_rng(5)
    knots2 = []
    for k, (sk, vk) in enumerate(knots[:300]):
        vk = vk.copy()
        pick = k % 6
        if pick == 0:
            vk[1:-1] = vk[1]                              # cruise inside
        elif pick == 1:
            vk[0] = vk[-1] = 0.0
        elif pick == 2:
            vk[:] = vk[0]                                 # cruises whole
        elif pick == 3:
            vk[rng.integers(1, vk.size - 1)] = np.nan
        elif pick == 4:
            vk = vk * rng.uniform(0.5, 1.5)
        knots2.append((sk, vk))
    got = curves.finish_curves(sts[:300], knots2, rules, prof)
    for st, (sk, vk), g in zip(sts[:300], knots2, got):
        _same_plan(g, _old_finish_curve(st, sk, vk, rules, prof))


def test_predict_rows_sums_in_the_1d_order():
    """_predict_rows against predict_curve on random rows of many shapes (the row sums must
    add in the 1-D pairwise order: a sequential row sum would differ)."""
    rng = np.random.default_rng(11)
    for m, n in ((1, 2), (3, 7), (50, 9), (400, 17), (40, 130)):
        S_ = np.concatenate([np.zeros((m, 1)), np.cumsum(rng.uniform(1e-3, 2.0, (m, n)), axis=1)], axis=1)
        V = rng.uniform(0.0, 150.0, (m, n + 1))
        A = rng.uniform(0.0, 4000.0, (m, n))
        cos_turn = rng.uniform(0.5, 1.0, (m, n - 1))
        c0 = [None if rng.random() < 0.3 else float(rng.uniform(0.5, 1.0)) for _ in range(m)]
        c1 = [None if rng.random() < 0.3 else float(rng.uniform(0.5, 1.0)) for _ in range(m)]
        t, a2 = curves._predict_rows(S_, V, A, cos_turn, c0, c1)
        for k in range(m):
            want = curves.predict_curve(S_[k], V[k], A[k], cos_turn[k], c0[k], c1[k])
            assert type(t[k]) is type(want[0]) and type(a2[k]) is type(want[1])
            assert np.float64(t[k]).tobytes() == np.float64(want[0]).tobytes()
            assert np.float64(a2[k]).tobytes() == np.float64(want[1]).tobytes()


def test_a_sequential_row_sum_would_be_caught(monkeypatch):
    """The mutant: row sums added left to right (not numpy's pairwise order)."""
    def seq(x, axis=None):
        out = x[:, 0].copy()
        for j in range(1, x.shape[1]):
            out = out + x[:, j]
        return out
    rng = np.random.default_rng(12)
    m, n = 200, 40
    S_ = np.concatenate([np.zeros((m, 1)), np.cumsum(rng.uniform(1e-3, 2.0, (m, n)), axis=1)], axis=1)
    V = rng.uniform(0.0, 150.0, (m, n + 1))
    A = rng.uniform(0.0, 4000.0, (m, n))
    cos_turn = rng.uniform(0.5, 1.0, (m, n - 1))
    monkeypatch.setattr(curves, "_add", seq)
    t, _ = curves._predict_rows(S_, V, A, cos_turn, [None] * m, [None] * m)
    monkeypatch.undo()
    want = [curves.predict_curve(S_[k], V[k], A[k], cos_turn[k])[0] for k in range(m)]
    assert any(a != b for a, b in zip(t, want))
