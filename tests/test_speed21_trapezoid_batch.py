"""Issue 8 (session 21, trapezoid): segments.line_trapezoids solves the one-move
trapezoids of all its strokes' variants at once (least_a2_trapezoids: the grids as rows,
the same elementwise operations, so the same bits), _line_trapezoid_edges split into
_edges_prep / _edges_finish.  Below: verbatim copies of 512b101's least_a2_trapezoid,
line_trapezoids, _line_trapezoid and _line_trapezoid_edges (renamed _old_*, calling each
other) as the reference; compared bit for bit on real strokes (bundled samples under
voron24, prusa-mk3s, ender3 (Marlin JD), prusa-mk4) and on random trapezoid arguments."""

import numpy as np
import pytest

from gcode_opt import plan as plan_mod
from gcode_opt import schedule as sc
from gcode_opt import segments as seg
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.segments import (CRUISE_A, EDGE_D, EDGE_MIN_V, EDGE_T, FULL_STOP_V, MIN_FEED_V, TRAP_GRID,
                                SegmentPlan, SegmentRules, _accel_top, accel_to_pass_junction,
                                hold_cruise_accels, jerk_step_v, law_peak_speeds, predict_peaked,
                                slowed_ends, trapezoid_knot_speeds, trapezoid_time)
from gcode_opt.strokes import K_LINE

S = "sample_gcode/"


# ---------------------------------------------------------------- 512b101's forms (verbatim)


def _old_least_a2_trapezoid(L, T, v0, v1, v_lo, v_hi, a_max, a_min_fn=None, extra_fn=None):
    """The one-move trapezoid (accelerate at a from v0 to vp, cruise, brake at a to v1) of
    length L (mm) that takes at most T (s) with the least int a^2 dt = a (2 vp - v0 - v1).

    For a peak vp the slowest ramp that still takes T is a = G / (T - L/vp) with
    G = ((vp - v0)^2 + (vp - v1)^2) / (2 vp) (the time the ramps lose against cruising at
    vp, times a); a_min_fn(vp) may raise it (what the junctions need), which only makes
    the move quicker, and so does the least a whose ramps fit in L; extra_fn(vp, a) adds
    to the cost (an arc's centripetal part).  vp is searched in [max(v_lo, v0, v1, L/T),
    v_hi] (a grid dense near its low end, refined twice around the best point), a <= a_max.  At
    rest-to-rest the optimum is the 1/3 - 1/3 - 1/3 trapezoid, vp = 1.5 L/T, whose
    13.5 L^2/T^3 is within 12.5 % of the optimal law's 12 L^2/T^3.
    Returns (vp, a, time_t, int_a2) or None."""
    lo = max(v_lo, v0, v1, L / T * (1.0 + 1e-9))
    if not (lo <= v_hi and L > 0 and T > 0 and a_max > 0):
        return None

    def cost(vp):
        G = ((vp - v0) ** 2 + (vp - v1) ** 2) / (2.0 * vp)
        with np.errstate(divide="ignore", invalid="ignore"):
            a = G / (T - L / vp)
        a = np.where(np.isfinite(a) & (a > 0), a, np.where(G <= 1e-12, 2 * CRUISE_A, np.inf))
        if a_min_fn is not None:
            a = np.maximum(a, a_min_fn(vp))
        a = np.maximum(a, (2.0 * vp * vp - v0 * v0 - v1 * v1) / (2.0 * L))   # the ramps fit in L (quicker still)
        fits = a <= a_max
        c = a * (2.0 * vp - v0 - v1) + (0.0 if extra_fn is None else extra_fn(vp, a))
        return a, np.where(fits, c, np.inf)

    grid = lo + (v_hi - lo) * np.concatenate([[0.0], np.geomspace(1e-6, 1.0, TRAP_GRID - 1)])
    for step in range(3):
        a, c = cost(grid)
        k = int(np.argmin(c))
        if not np.isfinite(c[k]):
            return None
        vp, a = grid[k], a[k]
        # refine around the best point (c is smooth in vp there): the geometric grid's
        # neighbours lie within +-16 % of vp - lo, each refinement narrows 16-fold
        w = 0.25 * (vp - lo) / 16 ** step
        grid = np.append(np.linspace(max(lo, vp - w), min(v_hi, vp + w), 33), vp)
    t, i2 = trapezoid_time(L, vp, a, v0, v1)
    return float(vp), float(a), float(t), float(i2)


def _old_line_trapezoids(strokes, T, beta, rules: SegmentRules):
    """SegmentPlan per line stroke: its one-move trapezoid of duration <= T (None where
    there is none).  Every original vertex stays a knot (collinear, one F and one
    acceleration: the firmware plans them as one trapezoid); a lead-in / lead-out at the
    corner speed carries what the corner needs (Klipper, Marlin JD) as in _finish."""
    if not len(strokes):
        return []
    peaks = law_peak_speeds(strokes, T, beta)
    return [_old_line_trapezoid(st, float(t), float(p), rules) for st, t, p in zip(strokes, T, peaks)]


def _old_line_trapezoid(st, T, v_peak, rules):
    """The better of: lead-in / lead-out at the corner speeds carrying what the corners
    need, or none and the whole move carrying it (a lead-in at a slow corner can take
    most of a short stroke's time).  A slowed end (corners.py) always has its edge."""
    slow = any(slowed_ends(st))
    got = [p for p in (_old_line_trapezoid_edges(st, T, v_peak, rules, True),
                       None if slow else _old_line_trapezoid_edges(st, T, v_peak, rules, False)) if p is not None]
    return min(got, key=lambda p: p.int_a2) if got else None


def _old_line_trapezoid_edges(st, T, v_peak, rules, edges, fixed_a=None):
    """fixed_a: the move's own acceleration, v_peak its feed (slowed_original), instead of
    the least-int a^2 trapezoid of duration T."""
    u = (st.ux, st.uy)
    v0 = st.v0 if st.v0 >= FULL_STOP_V else 0.0
    v1 = st.v1 if st.v1 >= FULL_STOP_V else 0.0
    L, jd, a_top = st.length_d, st.lim.jd, _accel_top(st)
    v_lo, v_hi = 0.0, v_peak
    if rules.junction == "jerk" and fixed_a is None:   # F within the jerk of the slicer's F (segment_feeds)
        step_v = jerk_step_v(st)
        v_lo, v_hi = st.v_feed - step_v, min(v_hi, st.v_feed + step_v)
    # lead-in / lead-out at the corner speeds where the corner needs more than a gentle ramp
    e_min = rules.min_edge_d(*u)
    slow0, slow1 = slowed_ends(st)
    cmd0, cmd1 = getattr(st, "corner_cmd0", False), getattr(st, "corner_cmd1", False)
    e0 = min(EDGE_D, max(v0 * EDGE_T, 0.05, e_min), 0.25 * L) if (
        (v0 >= EDGE_MIN_V and not cmd0) or slow0) and edges else 0.0
    e1 = min(EDGE_D, max(v1 * EDGE_T, 0.05, e_min), 0.25 * L) if (
        (v1 >= EDGE_MIN_V and not cmd1) or slow1) and edges else 0.0
    d0, d1 = st.ends_d[0], L - (st.ends_d[-2] if len(st.ends_d) > 1 else 0.0)   # first, last move
    need0 = accel_to_pass_junction(rules.junction, v0, st.prev_u, u, e0 or d0, jd) if v0 > 0 else 0.0
    need1 = accel_to_pass_junction(rules.junction, v1, u, st.next_u, e1 or d1, jd) if v1 > 0 else 0.0
    if (slow0 and e0 < e_min) or (slow1 and e1 < e_min):
        return None                       # a slowed end without its edge would not be slowed
    e0 = e0 if (need0 > 0.0 or slow0) and e0 >= e_min else 0.0
    e1 = e1 if (need1 > 0.0 or slow1) and e1 >= e_min else 0.0
    t_edges = (e0 / v0 if e0 else 0.0) + (e1 / v1 if e1 else 0.0)
    Lm = L - e0 - e1
    if Lm <= 0 or T - t_edges <= 0 or (fixed_a is not None and not fixed_a > 0):
        return None
    # Marlin JD: collinear blocks shorter than 1 mm cap v^2 at d a / 0.033
    if rules.junction == "jd" and (min(np.diff([0.0] + list(st.ends_d))) < rules.min_seg_d or
                                   (0 < e0 < rules.min_seg_d) or (0 < e1 < rules.min_seg_d)):
        return None
    a_min = None
    if not e0 and need0 > 0 or not e1 and need1 > 0:    # the original passed them with at most a_top
        floor_a = min(max(need0 if not e0 else 0.0, need1 if not e1 else 0.0), a_top)
        a_min = lambda vp: np.full_like(vp, floor_a)
    if fixed_a is not None:
        vp, a = v_peak, fixed_a
        if a_min is not None:
            a = max(a, float(a_min(np.array([vp]))[0]))
    else:
        got = _old_least_a2_trapezoid(Lm, T - t_edges, v0, v1, v_lo, v_hi, a_top, a_min)
        if got is None:
            return None
        vp, a, _, _ = got
    # knots: the edges, every original vertex, the ends
    inner = np.array([d for d in st.ends_d[:-1] if e0 < d < L - e1], float)
    s = np.concatenate([[0.0], [e0] if e0 else [], inner, [L - e1] if e1 else [], [L]])
    v = trapezoid_knot_speeds(s - e0, Lm, vp, a, v0, v1)
    v[0], v[-1] = v0, v1
    if e0:
        v[1] = v0
    if e1:
        v[-2] = v1
    acc = np.full(len(s) - 1, a)
    feed = np.full(len(s) - 1, vp)
    if e0:
        acc[0], feed[0] = min(max(need0, a), st.accel), max(v0, MIN_FEED_V)
    if e1:
        acc[-1], feed[-1] = min(max(need1, a), st.accel), max(v1, MIN_FEED_V)
    if rules.junction == "jd":
        for k in range(1, len(acc)):
            need = accel_to_pass_junction("jd", v[k], u, u, s[k + 1] - s[k], jd)
            if need > acc[k] * (1 + 1e-9):
                return None             # a raised ramp would not be the planned trapezoid
    acc = hold_cruise_accels(acc, st.accel)
    t_pred, a2_pred = predict_peaked(s, v, acc, feed)
    return SegmentPlan(s, v, acc, feed, t_pred, a2_pred, "trapezoid")


# ---------------------------------------------------------------- helpers
def _bits(x):
    return np.float64(x).tobytes()


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
        assert type(x) is type(y) and _bits(x) == _bits(y), (f, x, y)
    assert a.shape == b.shape and a.first_cmds == b.first_cmds


def _line_laws(path, profile, corners=0.0, every=6, stride=3):
    prof = load_profile(profile)
    opts = Options()
    opts.corner_budget_r = corners
    strokes, _ = analyse(path, prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    rows = np.array([i for i in sc._rows_by_kind(strokes)[K_LINE] if not pin.fault[i]], int)
    T, beta, I, _ = plan_mod.candidates_auto(pin.take(rows))
    sts, Ts, bs = [], [], []
    for col in range(0, T.shape[1], every):             # several laws a stroke
        ok = np.isfinite(I[:, col])
        sts += [strokes[i] for i in rows[ok]]
        Ts.append(T[ok, col])
        bs.append(beta[ok, col])
    T, beta = np.concatenate(Ts)[::stride], np.concatenate(bs)[::stride]
    return sts[::stride], T, beta, seg.SegmentRules.for_profile(prof, opts.max_segments)


def _check_rows(args):
    """least_a2_trapezoids on rows (L, T, v0, v1, v_lo, v_hi, a_max, floor) against the
    reference one call a row (floor -inf: no a_min_fn)."""
    cols = np.array(args, float).T
    vp, a = seg.least_a2_trapezoids(*cols)
    n_none = 0
    for r, (L, T, v0, v1, v_lo, v_hi, a_max, fl) in enumerate(args):
        fn = None if fl == -np.inf else (lambda x, fl=fl: np.full_like(x, fl))
        want = _old_least_a2_trapezoid(L, T, v0, v1, v_lo, v_hi, a_max, fn)
        if want is None:
            n_none += 1
            assert np.isnan(vp[r]) and np.isnan(a[r]), (r, args[r], vp[r], a[r])
        else:
            assert _bits(vp[r]) == _bits(want[0]) and _bits(a[r]) == _bits(want[1]), (r, args[r], vp[r], want)
    return n_none


CASES = [
    (S + "prusa_mk3s_rectilinear.gcode", "voron24", 0.3),       # slowed ends and commands
    (S + "prusa_gyroid.gcode", "voron24", 0.0),
    (S + "prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 0.0),
    (S + "prusa_gyroid.gcode", "ender3", 0.0),                  # Marlin JD
]


@pytest.mark.parametrize("path,profile,corners", CASES)
def test_line_trapezoids_same_plans(path, profile, corners):
    sts, T, beta, rules = _line_laws(path, profile, corners)
    assert len(sts) > 200
    calls = []
    real = _old_least_a2_trapezoid

    def spy(L, T_, v0, v1, v_lo, v_hi, a_max, a_min_fn=None, extra_fn=None):
        fl = -np.inf if a_min_fn is None else float(a_min_fn(np.array([1.0]))[0])
        calls.append((L, T_, v0, v1, v_lo, v_hi, a_max, fl))
        return real(L, T_, v0, v1, v_lo, v_hi, a_max, a_min_fn, extra_fn)
    globals()["_old_least_a2_trapezoid"] = spy
    try:
        want = _old_line_trapezoids(sts, T, beta, rules)
    finally:
        globals()["_old_least_a2_trapezoid"] = real
    got = seg.line_trapezoids(sts, T, beta, rules)
    assert len(got) == len(want)
    assert sum(p is not None for p in want) > 20
    for a, b in zip(got, want):
        _same_plan(a, b)
    # the captured real calls, row by row and as one batch
    assert len(calls) > 100
    if rules.junction != "jerk":                    # the corners' a_min floor was passed
        assert any(c[-1] > -np.inf for c in calls)
    _check_rows(calls)
    # slowed_original's path (fixed_a) and both variants through the kept wrapper
    for st, t, p in list(zip(sts, T, law_peak_speeds(sts, T, beta)))[::7]:
        _same_plan(seg._line_trapezoid_edges(st, np.inf, st.v_feed, rules, True, fixed_a=_accel_top(st)),
                   _old_line_trapezoid_edges(st, np.inf, st.v_feed, rules, True, fixed_a=_accel_top(st)))
        for e in (True, False):
            _same_plan(seg._line_trapezoid_edges(st, float(t), float(p), rules, e),
                       _old_line_trapezoid_edges(st, float(t), float(p), rules, e))


def test_least_a2_trapezoids_random():
    rng = np.random.default_rng(21)
    rows = []
    for _ in range(3000):
        L = float(rng.choice([rng.uniform(0.01, 5.0), rng.uniform(1e-6, 1e-3), 0.0, 50.0]))
        T = float(rng.choice([rng.uniform(0.002, 0.3), 1e-5, 1e-300, 2.0]))   # T > 0: callers check
        v0 = float(rng.choice([0.0, rng.uniform(0, 300)]))
        v1 = float(rng.choice([0.0, rng.uniform(0, 300), v0]))
        v_lo = float(rng.choice([0.0, rng.uniform(0, 200)]))
        v_hi = float(rng.choice([rng.uniform(0, 500), rng.uniform(500, 5000), np.inf, v0, 0.0,
                                 max(v_lo, v0, v1, L / T * (1.0 + 1e-9))]))
        a_max = float(rng.choice([rng.uniform(500, 20000), 1e-9, 0.0, 1e6, np.inf]))
        fl = float(rng.choice([-np.inf, -np.inf, rng.uniform(0, 20000), 0.0, 1e7]))
        rows.append((L, T, v0, v1, v_lo, v_hi, a_max, fl))
    for _ in range(2000):                      # ordinary: mostly feasible
        L = float(rng.uniform(0.05, 5.0))
        v0, v1 = float(rng.choice([0.0, rng.uniform(0, 150)])), float(rng.choice([0.0, rng.uniform(0, 150)]))
        T = L / float(rng.uniform(5, 300)) * float(rng.uniform(1.0, 3.0))
        v_lo = float(rng.choice([0.0, rng.uniform(0, 100)]))
        v_hi = float(rng.uniform(50, 600))
        a_max = float(rng.uniform(500, 20000))
        fl = float(rng.choice([-np.inf, rng.uniform(0, 5000)]))
        rows.append((L, T, v0, v1, v_lo, v_hi, a_max, fl))
    for _ in range(40):                        # best at lo (cruise at v0 = v1): a zero-width refinement
        v = float(rng.uniform(20, 100))          # grid in the same batch as the others (linspace's step 0)
        rows.append((1.0, 1.0, v, v, 0.0, float(rng.uniform(100, 300)), 1e4, float(rng.choice([-np.inf, 500.0]))))
    rows.append((3.0, 0.05, 0.0, 0.0, 0.0, 50.0, 1e5, -np.inf))          # None: too slow
    rows.append((1.0, 0.1, 0.0, 0.0, 0.0, 1e4, 1e9, -np.inf))
    n_none = _check_rows(rows)
    assert 100 < n_none < len(rows) - 1000
    # one at a time and empty
    rng.shuffle(rows)
    _check_rows(rows)
    for r in rows[:50]:
        _check_rows([r])
    vp, a = seg.least_a2_trapezoids(*np.zeros((8, 0)))
    assert vp.shape == (0,) and a.shape == (0,)


def test_rows_linspace_is_linspace():
    rng = np.random.default_rng(5)
    a = rng.uniform(0, 100, 400)
    b = a + rng.choice([0.0, 1e-310, 5e-324, 1.0, 1e-12], 400) * rng.uniform(0, 3, 400)
    a[:5], b[:5] = 1.0, 1.0
    a[5:40] = rng.uniform(0, 1e-306, 35)             # denormal steps
    b[5:40] = a[5:40] + rng.uniform(0, 1e-308, 35)
    got = seg._rows_linspace(a, b, 33)
    for i in range(len(a)):
        assert got[i].tobytes() == np.linspace(a[i], b[i], 33).tobytes(), i
