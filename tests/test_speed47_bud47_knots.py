"""Issue 8, session 47 (bud47): the budget runs' curve and line segments.

* curves.plan_curve_segments: the laws' knot speeds of every stroke end to end
  (_knot_speeds: their knots joined as bytes, each chunk's knots interpolated in one
  compiled call, the running max of a strictly increasing row taken as the row itself),
  then finished by knot count from those arrays (_finish_flat), not a (s, v) pair and an
  np.interp a stroke, stacked again by finish_curves.  The same SegmentPlans, bit for bit,
  as 882d7e9's curve_knots (copied below, verbatim) finished stroke by stroke
  (test_speed_plan3_finish._old_finish_curve, which pins finish_curves).
* segments.plan_once(cmd=...): the strokes' corner_cmd0 given as a bool array (plan_strokes
  reads them once) picks the same twins as reading them from every stroke.
"""
import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt import schedule as sc
from gcode_opt import segments as sg
from gcode_opt.curves import KNOT_ROWS, _interp, _row_scale, _solve, geom, knots_s
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.segments import SegmentRules
from gcode_opt.strokes import K_CURVE

from test_speed_plan3_finish import _old_finish_curve, _same_plan  # noqa: E402
from test_speed30_lineplan_same import _setup  # noqa: E402

S = "sample_gcode/"


def old_curve_knots(strokes, T, beta, profile):
    """882d7e9's curves.curve_knots, verbatim."""
    m = len(strokes)
    if m == 0:
        return []
    geos = [geom(st, profile) for st in strokes]
    S = np.array([st.length_d for st in strokes])
    v0 = np.array([st.v0 for st in strokes])
    v1 = np.array([st.v1 for st in strokes])
    T, beta = np.asarray(T, float), np.asarray(beta, float)
    law, R = _solve(None, geos, S, T, beta, v0, v1)
    out = []
    # evaluated by chunks of KNOT_ROWS laws (each law's figures are its own, whatever its
    # chunk): ~15 arrays of 513 points a law, ~30 MB at once by law.row_chunks' 512 laws
    for sl in [slice(a, a + KNOT_ROWS) for a in range(0, m, KNOT_ROWS)]:
        sub = law.rows(sl)
        tau = np.broadcast_to(np.linspace(0.0, 1.0, 513)[None, :], (len(sub), 513))
        phi, w, _, _ = sub.eval_tau(tau, w2=False, w1=False)
        # per law R phi, max(R w / T, 0) and the running max of s, in one call each for the
        # chunk (elementwise, and an exact max: the same numbers as law by law)
        s_run = np.maximum.accumulate(_row_scale(phi, R[sl]), axis=1)
        vd = np.maximum(_row_scale(w, R[sl], T[sl], 1), 0.0)
        for k, i in enumerate(range(m)[sl]):
            s = knots_s(strokes[i].ends_d)
            v = _interp(s, s_run[k], vd[k], None, None)      # np.interp's core, the same bits
            v[0], v[-1] = v0[i], v1[i]
            out.append((s, v))
    return out


def _curve_laws(name, profile):
    """(strokes, T, beta, profile, rules): every finite curve candidate of a sample (several
    laws a stroke, strokes of every knot count)."""
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


def _same_knots(got, want):
    assert len(got) == len(want)
    for (s, v), (s0, v0) in zip(got, want):
        assert s.dtype == s0.dtype == v.dtype == v0.dtype == np.float64
        assert s.tobytes() == s0.tobytes() and v.tobytes() == v0.tobytes()


@pytest.mark.parametrize("name,profile", [("prusa_gyroid.gcode", "prusa-mk3s"),      # jerk
                                          ("prusa_gyroid.gcode", "voron24"),         # scv
                                          ("prusa_gyroid.gcode", "ender3"),          # jd
                                          ("prusa_concentric.gcode", "prusa-mk3s")])
def test_plan_curve_segments_same_plans(name, profile):
    sts, T, beta, prof, rules = _curve_laws(name, profile)
    assert len(sts) > 50
    want = old_curve_knots(sts, T, beta, prof)
    _same_knots(curves.curve_knots(sts, T, beta, prof), want)
    got = curves.plan_curve_segments(sts, T, beta, rules, prof)
    sizes = set()
    for st, (sk, vk), g in zip(sts, want, got):
        _same_plan(g, _old_finish_curve(st, sk, vk, rules, prof))
        sizes.add(sk.size)
    assert len(sizes) > 3                             # several knot counts


def test_knots_without_core(monkeypatch):
    """The path without the compiled interp_rows: np.interp a stroke, the same knots."""
    sts, T, beta, prof, _ = _curve_laws("prusa_gyroid.gcode", "prusa-mk3s")
    want = old_curve_knots(sts[:200], T[:200], beta[:200], prof)
    monkeypatch.setattr(curves, "_INTERP_ROWS", None)
    _same_knots(curves.curve_knots(sts[:200], T[:200], beta[:200], prof), want)


def test_running_max_and_interp_rows():
    """_running_max_rows is np.maximum.accumulate on rows strictly increasing, equal
    neighbours, a dip, NaN, -0.0; _interp_chunk is np.interp of each row's points (outside
    the grid, at a knot, NaN) whichever path takes the row."""
    rng = np.random.default_rng(47)
    n = 33
    rows = [np.cumsum(rng.uniform(0.01, 1.0, n)) for _ in range(4)]
    r = np.cumsum(rng.uniform(0.01, 1.0, n)); r[7] = r[6]; rows.append(r)          # a flat step
    r = np.cumsum(rng.uniform(0.01, 1.0, n)); r[9] = r[8] - 0.5; rows.append(r)    # a dip
    r = np.cumsum(rng.uniform(0.01, 1.0, n)); r[3] = np.nan; rows.append(r)        # NaN
    r = np.cumsum(rng.uniform(0.01, 1.0, n)); r[0] = -0.0; r[1] = 0.0; rows.append(r)
    x = np.array(rows)
    want = np.maximum.accumulate(x, axis=1)
    got, inc = curves._running_max_rows(x.copy())
    assert got.tobytes() == want.tobytes()
    assert inc.tolist() == [True] * 4 + [False] * 4
    fp = rng.uniform(0.0, 50.0, x.shape)
    pts = []
    for k in range(len(rows)):
        p = np.sort(rng.uniform(-1.0, want[k, -1] + 1.0 if np.isfinite(want[k, -1]) else 40.0, rng.integers(1, 9)))
        pts.append(np.concatenate([p, want[k, [0, 5, -1]], [np.nan]]))
    off = np.zeros(len(pts) + 1, np.int64)
    np.cumsum([p.size for p in pts], out=off[1:])
    s = np.concatenate(pts)
    expect = np.concatenate([np.interp(p, want[k], fp[k]) for k, p in enumerate(pts)])
    for core in (curves._INTERP_ROWS, None):
        out = np.full(s.size, -1.0)
        if core is None:
            saved, curves._INTERP_ROWS = curves._INTERP_ROWS, None
        try:
            curves._interp_chunk(s, off, want, fp, inc, out)
        finally:
            if core is None:
                curves._INTERP_ROWS = saved
        assert out.tobytes() == expect.tobytes()


def test_knots_flat_of_other_ends():
    """Strokes whose ends_d is not an array of doubles: knots_s one by one, the same."""
    class St:
        def __init__(self, e):
            self.ends_d = e
    from array import array
    sts = [St(array("d", [1.0, 2.5])), St([0.5, 1.0, 3.0]), St(array("d")), St(np.array([2.0]))]
    s, off = curves._knots_flat(sts)
    assert off.tolist() == [0, 3, 7, 8, 10]
    assert s.tobytes() == np.concatenate([knots_s(st.ends_d) for st in sts]).tobytes()
    s, off = curves._knots_flat(sts[:1] + sts[2:3])
    assert s.tolist() == [0.0, 1.0, 2.5, 0.0] and off.tolist() == [0, 3, 4]


@pytest.mark.parametrize("corners", [False, True])
def test_plan_once_cmd_same_twins(corners):
    """plan_once with the strokes' corner_cmd0 as an array: the same plans, the same
    objects shared and copied, as reading them from the strokes (corners.py's slowed
    corners on: some strokes have a command of their own)."""
    prof, opts, strokes, pin, rows = _setup(S + "prusa_mk3s_rectilinear.gcode", "prusa-mk3s", corners)
    rules = SegmentRules.for_profile(prof, opts.max_segments)
    sts = [strokes[i] for i in rows.tolist()]
    same = sg.line_classes(sts)
    T = pin.T_orig[rows] * 0.9
    beta = np.full(rows.size, 1e-4)
    cmd = np.array([bool(st.corner_cmd0) for st in sts])
    assert cmd.any() == corners
    fn = lambda s, t, b: sg.plan_segments(s, t, b, rules)     # noqa: E731
    want = sg.plan_once(fn, sts, T, beta, same)
    got = sg.plan_once(fn, sts, T, beta, same, cmd)
    assert want is not None and len(got) == len(want)
    firsts_w, firsts_g = {}, {}
    for q, (a, b) in enumerate(zip(got, want)):
        assert (a is None) == (b is None)
        if a is None:
            continue
        assert a.s.tobytes() == b.s.tobytes() and a.feed.tobytes() == b.feed.tobytes()
        # the same sharing: a plan object first seen at the same row on both sides
        assert firsts_g.setdefault(id(a), q) == firsts_w.setdefault(id(b), q)


@pytest.mark.parametrize("profile", ["prusa-mk3s", "voron24"])
def test_curve_plans_without_passes(monkeypatch, profile):
    """No compiled field pass (objfields.floats answers None): the strokes' fields read as
    lists (_row_fields, _knot_speeds), the same plans."""
    sts, T, beta, prof, rules = _curve_laws("prusa_gyroid.gcode", profile)
    want = old_curve_knots(sts, T, beta, prof)
    from gcode_opt import objfields
    monkeypatch.setattr(objfields, "_FLOATS", None)
    got = curves.plan_curve_segments(sts, T, beta, rules, prof)
    for st, (sk, vk), g in zip(sts, want, got):
        _same_plan(g, _old_finish_curve(st, sk, vk, rules, prof))


def test_row_fields_as_the_lists():
    """_row_fields' arrays are the old lists' numbers, bit for bit: Python's min of the
    accel and the axis caps (a tie, a NaN first or later), the jerk step, v_feed."""
    sts, _, _, _, _ = _curve_laws("prusa_gyroid.gcode", "prusa-mk3s")

    class Lim:
        def __init__(self, ax, ay, jx, jy):
            self.ax_max, self.ay_max, self.jerk_x, self.jerk_y = ax, ay, jx, jy

    class St:
        def __init__(self, accel, v_feed, lim):
            self.accel, self.v_feed, self.lim = accel, v_feed, lim
    nan = float("nan")
    odd = [St(1000.0, 50.0, Lim(1000.0, 800.0, 8.0, 8.0)), St(nan, 50.0, Lim(900.0, 800.0, nan, 8.0)),
           St(700.0, 20.0, Lim(nan, 600.0, 8.0, nan)), St(700.0, 20.0, Lim(500.0, nan, 10.0, 7.5)),
           St(-0.0, 1.0, Lim(0.0, 0.0, 0.0, -0.0)), St(2000.0, 80.0, Lim(1500.0, 1500.0, 9.0, 10.0))]
    for group in (sts, odd):
        a_top, step, vf = curves._row_fields(list(group), True)
        want_a = [min(st.accel, st.lim.ax_max, st.lim.ay_max) for st in group]
        want_s = [curves.JERK_F_STEP_R * min(st.lim.jerk_x, st.lim.jerk_y) for st in group]
        assert np.asarray(a_top).tobytes() == np.array(want_a, float).tobytes()
        assert np.asarray(step).tobytes() == np.array(want_s, float).tobytes()
        assert np.asarray(vf).tobytes() == np.array([st.v_feed for st in group], float).tobytes()
        assert curves._row_fields(list(group), False)[1] is None
