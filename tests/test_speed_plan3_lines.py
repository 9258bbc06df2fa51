"""Issue 8, stop 18 (D8): segments.plan_segments makes the lines' feeds (segment_feeds) and
predicted figures (predict) for all strokes of one knot count at once
(_finish_feeds_and_figures, _predict_rows) after _finish(defer=True) has made each
stroke's knots and accelerations.  The plans must be the same bits and types as
9bb98a8's plan_segments and _finish, copied below."""
import numpy as np
import pytest

from gcode_opt import plan as plan_mod
from gcode_opt import schedule as sc
from gcode_opt import segments as seg
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_LINE

S = "sample_gcode/"


# ---------------------------------------------------------------- 9bb98a8's forms
def _old_plan_segments(strokes, T, beta, rules):
    """Segments that make the firmware play each stroke's law (L, T, beta, v0, v1): a
    list with a seg.SegmentPlan, or None where no plan beats the original.

    A stroke too short or quick for two segments, or whose segments would not beat the
    original trapezoid, gets the one-move trapezoid of the same duration with the least
    int a^2 (trapezoid.py) instead, when that beats the original."""
    n = np.array([seg.segment_count(t, st.length_d, rules.n_max, rules.seg_t, rules.min_seg_d)
                  for st, t in zip(strokes, T)], dtype=int)
    ok = np.flatnonzero(n >= 2)
    plans = [None] * len(strokes)
    T, beta = np.asarray(T), np.asarray(beta)
    for a in range(0, ok.size, seg.KNOT_CHUNK):       # bounded memory; every step is per stroke
        rows = ok[a:a + seg.KNOT_CHUNK]
        knots = seg.law_knots([strokes[i] for i in rows], T[rows], beta[rows], n[rows])
        for i, (sk, vk) in zip(rows, knots):
            plans[i] = _old_finish(strokes[i], sk, vk, rules)
    short = [i for i, p in enumerate(plans) if p is None or not p.int_a2 < strokes[i].int_a2]
    if short:
        rows = np.array(short, int)
        for i, p in zip(short, seg.line_trapezoids([strokes[i] for i in short], T[rows], beta[rows], rules)):
            if p is not None and p.int_a2 < strokes[i].int_a2 and (plans[i] is None or p.int_a2 < plans[i].int_a2):
                plans[i] = p
    return plans


def _old_accel_top(stroke):
    """The highest acceleration a segment of this stroke may carry: the one in force,
    capped by the per-axis limits along its direction (plan_inputs' a_cap)."""
    a = stroke.accel
    if abs(stroke.ux) > 1e-12:
        a = min(a, stroke.lim.ax_max / abs(stroke.ux))
    if abs(stroke.uy) > 1e-12:
        a = min(a, stroke.lim.ay_max / abs(stroke.uy))
    return a


def _old_finish(stroke, sk, vk, rules):
    """Accelerations (incl. what the corners need) and feeds for one stroke's knots."""
    u = (stroke.ux, stroke.uy)
    # a corner slower than seg.FULL_STOP_V is a halt already: not worth an acceleration spike
    v0 = stroke.v0 if stroke.v0 >= seg.FULL_STOP_V else 0.0
    v1 = stroke.v1 if stroke.v1 >= seg.FULL_STOP_V else 0.0
    jd = stroke.lim.jd

    def needs(sk):
        return (seg.accel_to_pass_junction(rules.junction, v0, stroke.prev_u, u, sk[1] - sk[0], jd),
                seg.accel_to_pass_junction(rules.junction, v1, u, stroke.next_u, sk[-1] - sk[-2], jd))

    if rules.min_move_d > 0.0:
        # time-even knots crowd where the law is slow (into a stop, at a corner slowed to
        # ~1 mm/s by a command): no segment the firmware would drop
        sk, vk = seg._merge_short(sk, vk, rules.min_edge_d(*u), stroke.ends_d)
    acc = seg.ramp_accels(sk, vk)
    need0, need1 = needs(sk)
    slow0, slow1 = seg.slowed_ends(stroke)
    e0 = e1 = 0.0
    # Klipper's and Marlin's corner speeds scale with the entering block's acceleration:
    # a gently ramping first segment would slow the corner.  A lead-in at the corner speed
    # carries the acceleration the corner needs without changing speed.  An end slowed
    # below the firmware's junction speed (corners.py) needs one too: its feed, the corner
    # speed, is what makes the firmware slow down there.
    if need0 > acc[0] or need1 > acc[-1] or slow0 or slow1:
        e_min = rules.min_edge_d(*u)
        # (a corner slowed by a junction command needs neither: the command sets it)
        e0 = min(seg.EDGE_D, max(stroke.v0 * seg.EDGE_T, 0.05, e_min)) if (
            need0 > acc[0] and v0 >= seg.EDGE_MIN_V and not stroke.corner_cmd0) or slow0 else 0.0
        e1 = min(seg.EDGE_D, max(stroke.v1 * seg.EDGE_T, 0.05, e_min)) if (
            need1 > acc[-1] and v1 >= seg.EDGE_MIN_V and not stroke.corner_cmd1) or slow1 else 0.0
        # a lead-in squeezes the first ramp into a shorter segment: keep its acceleration
        # within what the machine allows (Marlin caps M204 at M201's limit: the ramp would
        # fall short of its knot)
        a_top = _old_accel_top(stroke)
        if slow0 or slow1:            # a slowed end must have its edge: make room for it
            sk, vk = seg._room_for_edges(sk, vk, e0 if slow0 else 0.0, e1 if slow1 else 0.0, a_top, stroke.ends_d)
        e0 = min(e0, 0.99 * max(seg._ramp_room(sk[1], vk[0], vk[1], a_top), 0.0), 0.4 * sk[1])
        e1 = min(e1, 0.99 * max(seg._ramp_room(sk[-1] - sk[-2], vk[-2], vk[-1], a_top), 0.0), 0.4 * (sk[-1] - sk[-2]))
        e0, e1 = (e if e >= e_min else 0.0 for e in (e0, e1))   # no sliver the firmware would drop
        sk, vk = seg.with_edges(sk, vk, e0, e1)
        acc = seg.ramp_accels(sk, vk)
        need0, need1 = needs(sk)
    acc[0] = max(acc[0], min(need0, stroke.accel))
    acc[-1] = max(acc[-1], min(need1, stroke.accel))
    if rules.junction == "jd":
        for k in range(1, len(acc)):
            need = seg.accel_to_pass_junction("jd", vk[k], u, u, sk[k + 1] - sk[k], jd)
            acc[k] = max(acc[k], min(need, stroke.accel))
    if rules.junction == "scv":
        acc = np.maximum(acc, np.minimum(seg.rounding_junction_accels(sk, vk), stroke.accel))
    step_v = np.inf
    if rules.junction == "jerk":         # per-axis jerk limit -> limit on the change of F
        step_v = 0.9 * min(stroke.lim.jerk_x, stroke.lim.jerk_y) / max(abs(stroke.ux), abs(stroke.uy))
    acc = seg.hold_cruise_accels(acc, stroke.accel)
    feeds = seg.segment_feeds(vk, stroke.v_feed, step_v)
    if slow0 or slow1:
        if (slow0 and not e0) or (slow1 and not e1):
            return None                   # no room for the lead-in / lead-out: not as planned
        if slow0:
            feeds[0] = max(stroke.v0, seg.MIN_FEED_V)
        if slow1:
            feeds[-1] = max(stroke.v1, seg.MIN_FEED_V)
    t_pred, a2_pred = seg.predict(sk, vk, acc)
    return seg.SegmentPlan(sk, vk, acc, feeds, t_pred, a2_pred)




# ---------------------------------------------------------------- comparisons
def _same_plan(a, b):
    if a is None or b is None:
        assert a is None and b is None
        return
    for f in ("s", "v", "accel", "feed"):
        x, y = getattr(a, f), getattr(b, f)
        assert type(x) is type(y) and x.dtype == y.dtype and x.shape == y.shape, f
        assert x.tobytes() == y.tobytes(), (f, x, y)
    for f in ("time_t", "int_a2"):
        x, y = getattr(a, f), getattr(b, f)
        assert type(x) is type(y) and np.float64(x).tobytes() == np.float64(y).tobytes(), (f, x, y)
    assert a.shape == b.shape and a.first_cmds == b.first_cmds


def _line_laws(name, profile, corners=0.0):
    prof = load_profile(profile)
    opts = Options()
    opts.corner_budget_r = corners
    strokes, _ = analyse(S + name, prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    rows = np.array([i for i in sc._rows_by_kind(strokes)[K_LINE] if not pin.fault[i]], int)
    T, beta, I, _ = plan_mod.candidates_auto(pin.take(rows))
    sts, Ts, bs = [], [], []
    for col in range(0, T.shape[1], 3):                 # several laws a stroke
        ok = np.isfinite(I[:, col])
        sts += [strokes[i] for i in rows[ok]]
        Ts.append(T[ok, col])
        bs.append(beta[ok, col])
    return sts, np.concatenate(Ts), np.concatenate(bs), seg.SegmentRules.for_profile(prof, opts.max_segments)


@pytest.mark.parametrize("name,profile,corners", [
    ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 0.0),    # classic jerk: feeds in a tent
    ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 0.05),   # corners slowed by junction commands
    ("prusa_mk3s_rectilinear.gcode", "generic-marlin", 0.3),   # slowed ends: lead-ins and their feeds
    pytest.param("prusa_mk3s_rectilinear.gcode", "voron24", 0.05, marks=pytest.mark.slow),   # Klipper
    ("prusa_gyroid.gcode", "ender3", 0.0),                  # Marlin JD
    ("prusa_benchy_like.gcode", "prusa-mk4", 0.0)])
def test_plan_segments_same_plans(name, profile, corners):
    sts, T, beta, rules = _line_laws(name, profile, corners)
    assert len(sts) > 200
    got = seg.plan_segments(sts, T, beta, rules)
    want = _old_plan_segments(sts, T, beta, rules)
    assert len(got) == len(want)
    assert sum(p is not None and p.shape == "law" for p in got) > 100
    if profile == "generic-marlin":
        assert sum(any(seg.slowed_ends(st)) for st in sts) > 1000   # slowed ends' feeds were set
    for a, b in zip(got, want):
        _same_plan(a, b)


def test_predict_rows_same_as_predict():
    rng = np.random.default_rng(8)
    for m, k in ((1, 2), (5, 3), (300, 7), (40, 30), (20, 140)):
        S_ = np.concatenate([np.zeros((m, 1)), np.cumsum(rng.uniform(1e-3, 2.0, (m, k - 1)), axis=1)], axis=1)
        V = rng.uniform(0.0, 150.0, (m, k))
        A = rng.uniform(0.0, 4000.0, (m, k - 1))
        A[0, 0] = 0.0
        t, a2 = seg._predict_rows(S_, V, A)
        for r in range(m):
            want = seg.predict(S_[r], V[r], A[r])
            assert type(t[r]) is float and type(a2[r]) is float
            assert (t[r], a2[r]) == want and np.float64(t[r]).tobytes() == np.float64(want[0]).tobytes()


@pytest.fixture(autouse=True)
def _no_jerk_corners(monkeypatch):
    """The plans pinned here are those of the code before segments' classic-jerk corner step
    (session 29, segments.JERK_CORNERS): off here.  tests/test_speed29_jerkentry_corners.py
    checks that step, and that plan_segments with it is these plans with their ends cut."""
    monkeypatch.setattr(seg, "JERK_CORNERS", False)
