"""Classic jerk: a re-timed line's first / last F must not lower its corner's junction
(segments.jerk_corner_fires / jerk_keep_corner).

Marlin's classic jerk takes the new block's NOMINAL velocity as its entry velocity: a
first segment's F lifted above the slicer's F (the law's overshoot) made the firmware enter
the corner slower than the plan's v0 (prusa_gyroid stroke 135: 16.1 mm/s, not 18.9), and
the re-timed lines ran ~0.96 s over their prediction on prusa_gyroid.  The checks here are
independent of the planner: the junction law of firmware/junction.py (the scalar one the
firmware model plays), and the firmware model itself (firmware/simulate.py) playing the
written file.
"""
import math
import random

import numpy as np
import pytest

from gcode_opt import pipeline, schedule, segments
from gcode_opt.firmware import junction as jn
from gcode_opt.firmware.simulate import simulate_file
from gcode_opt.pipeline import Options
from gcode_opt.profile import load_profile

SAMPLE = __file__.rsplit("/tests/", 1)[0] + "/sample_gcode/prusa_gyroid.gcode"


def _scalar_junction(pu, p_nom, u, nom, jx, jy, jz=0.4):
    p_safe = jn.marlin_safe_speed(pu[0], pu[1], 0.0, p_nom, jx, jy, jz)
    safe = jn.marlin_safe_speed(u[0], u[1], 0.0, nom, jx, jy, jz)
    return jn.marlin_jerk_junction_v(pu[0], pu[1], 0.0, p_nom, p_safe, u[0], u[1], 0.0, nom, safe, jx, jy, jz)


def test_junction_rows_match_the_scalar_law():
    rng = random.Random(29)
    rows = []
    for _ in range(3000):
        a, b = rng.uniform(-math.pi, math.pi), rng.uniform(-math.pi, math.pi)
        if rng.random() < 0.1:
            b = a                                     # straight on
        if rng.random() < 0.1:
            b = a + math.pi                           # reversal
        pu, u = (math.cos(a), math.sin(a)), (math.cos(b), math.sin(b))
        if rng.random() < 0.1:
            u = (1.0, 0.0) if rng.random() < 0.5 else (0.0, -1.0)
        rows.append((pu, rng.uniform(0.5, 200.0), u, rng.uniform(0.5, 200.0), rng.choice([8.0, 10.0, 20.0]),
                     rng.choice([8.0, 10.0, 12.0])))
    want = np.array([_scalar_junction(*r) for r in rows])
    arr = [np.array(x, float) for x in zip(*[(r[0][0], r[0][1], r[1], r[2][0], r[2][1], r[3], r[4], r[5])
                                             for r in rows])]
    got = jn_rows = jn.marlin_jerk_junction_v_rows(*arr)
    assert np.array_equal(got, want), np.max(np.abs(jn_rows - want))


class _St:
    """The fields of a line stroke the corner check and cut read."""

    def __init__(self, u, prev_u, next_u, v0, v1, v_feed, jerk=8.0):
        self.ux, self.uy = u
        self._pux, self._puy = (None, None) if prev_u is None else prev_u
        self._nux, self._nuy = (None, None) if next_u is None else next_u
        self.v0, self.v1, self.v_feed, self.accel = v0, v1, v_feed, 800.0

        class _L:
            jerk_x = jerk_y = jerk
            ax_max = ay_max = 1000.0
        self.lim = _L()


def test_cut_keeps_the_ramp_and_the_original_junction():
    # prusa_gyroid stroke 135's corner: a connector at F1200 (20 mm/s), the stroke turning
    # ~-150 deg, the law's first knot speed 23.47 over the slicer's 20 mm/s
    s2 = math.sqrt(0.5)
    pu = (-0.9407023423028565, -0.339233110391541)
    st = _St((-s2, -s2), pu, (0.4, 0.9165), 18.9, 8.0, 20.0)
    rules = segments.SegmentRules("jerk", 10, 0.0, 0.3, 0.06)
    sk = np.array([0.0, 1.05, 2.2, 3.4])
    vk = np.array([18.9, 23.47, 24.6, 8.0])
    acc = segments.ramp_accels(sk, vk)
    feeds = segments.segment_feeds(vk, st.v_feed, segments.jerk_step_v(st))
    f0, f1 = segments.jerk_corner_fires([st], feeds[:1], feeds[-1:], np.array([20.0]), np.array([st.ux]),
                                        np.array([st.uy]))
    assert f0[0] and not f1[0]                # the exit's F (24.6 -> 8 ramp: F 24.6 > 20) at a milder turn
    j_old = _scalar_junction(pu, 20.0, (st.ux, st.uy), 20.0, 8.0, 8.0)
    j_lifted = _scalar_junction(pu, 20.0, (st.ux, st.uy), feeds[0], 8.0, 8.0)
    assert j_lifted < st.v0 <= j_old          # the lifted F slows the corner below the plan
    plan = segments.jerk_keep_corner(st, sk, vk, acc, feeds, True, False, segments.jerk_step_v(st), rules)
    assert plan is not None and plan.s.size == sk.size + 1
    assert plan.feed[0] == 20.0 and plan.v[1] == 20.0
    assert _scalar_junction(pu, 20.0, (st.ux, st.uy), plan.feed[0], 8.0, 8.0) == j_old
    # the same ramp: the cut knot lies on the first chord, both parts at its acceleration
    assert plan.accel[0] == plan.accel[1] == acc[0]
    t0, a20 = segments.predict(sk, vk, acc)
    assert plan.time_t == pytest.approx(t0, rel=1e-12) and plan.int_a2 == pytest.approx(a20, rel=1e-12)
    # a corner at the slicer's F itself: a lead-in at it, the ramp beyond steeper
    st2 = _St((-s2, -s2), pu, None, 20.0, 8.0, 20.0)
    vk2 = np.array([20.0, 23.47, 24.6, 8.0])
    acc2 = segments.ramp_accels(sk, vk2)
    plan2 = segments.jerk_keep_corner(st2, sk, vk2, acc2, feeds, True, False, segments.jerk_step_v(st2), rules)
    assert plan2.feed[0] == 20.0 and plan2.v[0] == plan2.v[1] == 20.0 and plan2.s[1] == pytest.approx((0.06 + 0.002) / s2)
    assert plan2.accel[1] > acc2[0]
    # no lifted F, no cut
    assert not segments.jerk_corner_fires([st], np.array([20.0]), np.array([20.0]), np.array([20.0]),
                                          np.array([st.ux]), np.array([st.uy]))[0].any()


def _run(tmp_path, monkeypatch, fix=True, core=True):
    """prusa_gyroid under prusa-mk3s: the first plan, its measure, the written file."""
    if not fix:
        monkeypatch.setattr(segments, "jerk_corner_fires",
                            lambda sts, *a: (np.zeros(len(sts), bool), np.zeros(len(sts), bool)))
    monkeypatch.setattr(segments, "USE_CORE", core)
    cap = {}
    fit0, meas0 = schedule._fit_budget, pipeline.measure

    def fit(run, pin, budget_t):
        p = fit0(run, pin, budget_t)
        cap.setdefault("plans", []).append(p)
        return p

    def meas(path, profile, out_ranges, *a, **k):
        got = meas0(path, profile, out_ranges, *a, **k)
        if "m" not in cap:
            cap["m"] = (got, list(out_ranges), list(cap["plans"][-1].segs))
        return got

    monkeypatch.setattr(schedule, "_fit_budget", fit)
    monkeypatch.setattr(pipeline, "measure", meas)
    out = str(tmp_path / ("fix.gcode" if fix else "nofix.gcode"))
    opts = Options()
    opts.ringing = False
    summary = pipeline.process(SAMPLE, out, load_profile("prusa-mk3s"), opts)
    plan = cap["plans"][0]
    (sim1, t1, *_), out_ranges, segs = cap["m"]
    rows = np.array([r[2] for r in out_ranges], int)
    return summary, out, plan, t1, rows, out_ranges, segs


def test_written_lines_play_as_predicted(tmp_path, monkeypatch):
    summary, out, plan, t1, rows, out_ranges, segs = _run(tmp_path, monkeypatch)
    lines = np.array([getattr(segs[i], "shape", None) == "law" and len(segs[i].feed) > 0 for i in rows])
    d = (t1 - plan.t_pred[rows])[lines]
    # was +0.96 s over (sum) with a 16 ms p95 per stroke; now the model plays them as predicted
    assert d.sum() < 0.03 and d.max() < 0.005, (d.sum(), d.max())
    assert summary["rewrite_passes"] == 1
    # where an entry was cut (F_0 at the slicer's F, v at the cut = F_0), the firmware enters
    # the stroke at the planned corner speed (within what writing X/Y to 3 decimals turns
    # the directions: <= 1e-3 relative; without the cut it entered up to ~15 % slower)
    prof = load_profile("prusa-mk3s")
    starts = {}

    def on_block(b):
        starts.setdefault(b.idx, b.start_v)
    simulate_file(out, prof, on_block=on_block)
    checked = 0
    for j, i in enumerate(rows.tolist()):
        sg = segs[i]
        if not lines[j] or sg.feed.size < 2 or sg.v[1] != sg.feed[0] or sg.feed[1] <= sg.feed[0]:
            continue
        first = min(k for k in starts if out_ranges[j][0] <= k < out_ranges[j][1])
        assert starts[first] == pytest.approx(sg.v[0], rel=1e-3), (i, starts[first], sg.v[0])
        checked += 1
    assert checked >= 50


def test_without_the_cut_the_model_lags(tmp_path, monkeypatch):
    """The check above can fail: with the corners left as they were, the lines overrun."""
    _, _, plan, t1, rows, _, segs = _run(tmp_path, monkeypatch, fix=False)
    d = t1 - plan.t_pred[rows]
    assert d.sum() > 0.5


def test_pure_rows_path_same_file(tmp_path, monkeypatch):
    """_jerk_rows' numpy tail (the compiled core's reference) writes the same file."""
    _, out_c, *_ = _run(tmp_path / "c" if (tmp_path / "c").mkdir() is None else None, monkeypatch)
    _, out_p, *_ = _run(tmp_path / "p" if (tmp_path / "p").mkdir() is None else None, monkeypatch, core=False)
    assert open(out_c, "rb").read() == open(out_p, "rb").read()


@pytest.mark.parametrize("path,profile,corners", [("prusa_gyroid.gcode", "prusa-mk3s", 0.0),
                                                   ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 0.3)])
def test_plan_segments_is_the_old_plans_cut(path, profile, corners, monkeypatch):
    """plan_segments with the step (in _jerk_rows' blocks and after _finish) gives the plans
    it gave without it, each cut by the per-plan form _jerk_corner_plans: the same bits (the
    line trapezoids' fallback aside, which a cut plan's int a^2 may move: not seen here)."""
    import test_speed21_lineseg_same_bits as t21
    sts, T, beta, rules = t21._line_laws(t21.S + path, profile, corners, every=4)
    with np.errstate(all="ignore"):
        monkeypatch.setattr(segments, "JERK_CORNERS", False)
        old = segments.plan_segments(sts, T, beta, rules)
        monkeypatch.setattr(segments, "JERK_CORNERS", True)
        new = segments.plan_segments(sts, T, beta, rules)
    want = segments._jerk_corner_plans(sts, old, rules)
    cut = 0
    for a, b, o in zip(new, want, old):
        if a is None or b is None:
            assert a is None and b is None
            continue
        for f in ("s", "v", "accel", "feed"):
            assert np.array_equal(np.asarray(getattr(a, f)), np.asarray(getattr(b, f))), f
        assert a.time_t == b.time_t and a.int_a2 == b.int_a2
        if b is not o:
            cut += 1
            # the cut changes the motion by nothing (a ramp split) or a short lead-in's worth
            assert b.time_t == pytest.approx(o.time_t, rel=2e-3) and b.int_a2 <= o.int_a2 * 1.2 + 1e-9
    assert cut > 5, cut
