"""segments.plan_segments' rows path with less per-stroke glue (lineseg, after 1927d34):
the segment counts in arrays (_segment_counts), law_knots evaluating s and v only and
handing its blocks on (_Knots.blocks) to _finish_jerk_rows, which takes them as they are
(_jerk_rows: the strokes' fields read into arrays once, _jerk_steps for jerk_step_v).
The plans must be the same bits, types and verdicts as 1927d34's, whose law_knots,
plan_segments, jerk_step_v, _finish_jerk_rows and _block_plans are copied verbatim below
(they call the live helpers they called then, which this change leaves as they were):
bundled samples under prusa-mk3s (classic jerk: the rows' path) and voron24, perturbed
(slowed ends, junction commands, other durations, negative / zero accelerations), and the
array helpers against their per-stroke forms on odd values."""
import math

import numpy as np
import pytest

from gcode_opt import plan as plan_mod
from gcode_opt import schedule as sc
from gcode_opt import segments as seg
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.segments import (KNOT_CHUNK, MIN_FEED_V, MIN_SEG_D, SegmentPlan, SegmentRules, _F64,  # noqa: F401
                                _finish, _finish_feeds_and_figures, _min_edge_d_rows, _predict_rows,
                                fine_rows, hold_cruise_accels_rows, line_law, line_trapezoids,
                                segment_count, settle_rows, slowed_ends, tent_feeds_rows,
                                time_of_distance)
from gcode_opt.strokes import K_LINE

S = "sample_gcode/"


# ---------------------------------------------------------------- 1927d34's forms, verbatim
def law_knots(strokes, T, beta, n):
    """Knots of many strokes at once (one vectorised law evaluation): for stroke i, the
    distances s (mm) and speeds v (mm/s) at n_i + 1 instants evenly spaced in time, plus
    every interior original vertex (law knots too close to a vertex dropped), with
    s_0 = 0, s_K = L and the end speeds exact.  Returns a list of (s, v)."""
    m = len(strokes)
    if m == 0:
        return []
    L = np.array([st.length_d for st in strokes])
    v0 = np.array([st.v0 for st in strokes])
    v1 = np.array([st.v1 for st in strokes])
    T, beta, n = np.asarray(T, float), np.asarray(beta, float), np.asarray(n, int)
    j = np.arange(n.max() + 1)
    tau = np.minimum(j[None, :] / n[:, None], 1.0)
    law = line_law(L[:, None], T[:, None], beta[:, None], v0[:, None], v1[:, None])
    s_all, v_all, _ = law.eval(tau * T[:, None])
    # interior vertices of multi-move strokes: one vectorised inversion s -> t
    owner, verts = [], []
    for i, st in enumerate(strokes):
        if st.n_moves > 1:
            owner += [i] * (st.n_moves - 1)
            verts += st.ends_d[:-1]
    vv = {}
    if verts:
        owner_a, verts_a = np.array(owner), np.array(verts)
        vl = line_law(L[owner_a], T[owner_a], beta[owner_a], v0[owner_a], v1[owner_a])
        _, v_vert, _ = vl.eval(np.asarray(time_of_distance(vl, verts_a), float), "v")
        for k, i in enumerate(owner):
            vv.setdefault(i, []).append((verts_a[k], float(v_vert[k])))
    out = [None] * m
    # strokes of one move, by knot count: their rows in one go (the same copies, the
    # same elementwise max and the same assignments as stroke by stroke); each stroke's
    # s and v are its rows of the blocks
    by_n = {}
    for i, k in enumerate(n.tolist()):
        if i not in vv:
            by_n.setdefault(k, []).append(i)
    for k, rows in by_n.items():
        g = np.array(rows, int)
        s = s_all[g, :k + 1]
        s[:, 0] = 0.0
        s[:, -1] = L[g]
        v = np.maximum(v_all[g, :k + 1], 0.0)
        v[:, 0] = v0[g]
        v[:, -1] = v1[g]
        for q, i in enumerate(rows):
            out[i] = (s[q], v[q])
    for i in vv:                  # strokes of several moves: their vertices' knots merged in
        s, v = s_all[i, :n[i] + 1].copy(), v_all[i, :n[i] + 1].copy()
        vs = np.array([p[0] for p in vv[i]])
        min_gap = min(MIN_SEG_D, L[i] / (4 * n[i]))
        gap = np.min(np.abs(s[:, None] - vs[None, :]), axis=1)
        keep = np.ones(len(s), bool)
        keep[1:-1] = gap[1:-1] >= min_gap
        s = np.concatenate([s[keep], vs])
        v = np.concatenate([v[keep], [p[1] for p in vv[i]]])
        order = np.argsort(s, kind="stable")
        s, v = s[order], v[order]
        s[0], s[-1] = 0.0, L[i]
        v = np.maximum(v, 0.0)
        v[0], v[-1] = v0[i], v1[i]
        out[i] = (s, v)
    return out



def plan_segments(strokes, T, beta, rules: SegmentRules):
    """Segments that make the firmware play each stroke's law (L, T, beta, v0, v1): a
    list with a SegmentPlan, or None where no plan beats the original.

    A stroke too short or quick for two segments, or whose segments would not beat the
    original trapezoid, gets the one-move trapezoid of the same duration with the least
    int a^2 (trapezoid.py) instead, when that beats the original."""
    n = np.array([segment_count(t, st.length_d, rules.n_max, rules.seg_t, rules.min_seg_d)
                  for st, t in zip(strokes, T)], dtype=int)
    ok = np.flatnonzero(n >= 2)
    plans = [None] * len(strokes)
    T, beta = np.asarray(T), np.asarray(beta)
    for a in range(0, ok.size, KNOT_CHUNK):       # bounded memory; every step is per stroke
        rows = ok[a:a + KNOT_CHUNK]
        sts = [strokes[i] for i in rows]
        knots = law_knots(sts, T[rows], beta[rows], n[rows])
        fast = _finish_jerk_rows(sts, knots, rules)
        pending = []
        for i, st, (sk, vk), got in zip(rows.tolist(), sts, knots, fast):
            if got is not None:                   # made by the rows' path
                plans[i] = got
                continue
            got = _finish(st, sk, vk, rules, defer=True)
            if got is not None:
                pending.append((i, got))
        for (i, _), plan in zip(pending, _finish_feeds_and_figures([g for _, g in pending])):
            plans[i] = plan
    short = [i for i, p in enumerate(plans) if p is None or not p.int_a2 < strokes[i].int_a2]
    if short:
        rows = np.array(short, int)
        for i, p in zip(short, line_trapezoids([strokes[i] for i in short], T[rows], beta[rows], rules)):
            if p is not None and p.int_a2 < strokes[i].int_a2 and (plans[i] is None or p.int_a2 < plans[i].int_a2):
                plans[i] = p
    return plans



def jerk_step_v(st):
    """Under classic jerk, how far a segment's F may step from the next one's (mm/s): 0.9 of
    the smaller axis jerk over the stroke's larger direction component (segment_feeds)."""
    return 0.9 * min(st.lim.jerk_x, st.lim.jerk_y) / max(abs(st.ux), abs(st.uy))


def _finish_jerk_rows(strokes, knots, rules):
    """The SegmentPlans _finish(st, sk, vk, rules, defer=True) and _finish_feeds_and_figures
    make of the strokes that take _finish's plainest path, for all of one knot count at
    once (their blocks go on to _block_plans as they are); None for the others (and for
    all of them under a junction law other than classic jerk), which go through _finish.

    The plainest path: classic jerk (accel_to_pass_junction gives 0.0 at both ends), no
    end slowed by corners.py, no knot merged by _merge_short (every segment at least
    min_edge_d long), and ramp accelerations at both ends not below 0 (0.0 > acc would
    add edges).  Then _finish computes ramp_accels (elementwise: the same here in rows),
    acc[0] = max(acc[0], min(0.0, accel)) and the same for acc[-1] (Python's max and min:
    np.where on the same comparisons), and step_v on Python floats (as here), and returns
    the knots it was given.  ~68 k strokes on the rectilinear plate: ~15 µs each there."""
    out = [None] * len(strokes)
    if rules.junction != "jerk":
        return out
    by_k = {}
    for q, (st, (sk, _)) in enumerate(zip(strokes, knots)):
        if type(sk) is np.ndarray and sk.ndim == 1 and sk.size >= 3 and sk.dtype == _F64:
            by_k.setdefault(sk.size, []).append(q)
    for qs in by_k.values():
        sts = [strokes[q] for q in qs]
        keep = [not (s0 or s1) for s0, s1 in map(slowed_ends, sts)]
        S = np.stack([knots[q][0] for q in qs])
        V = np.stack([np.asarray(knots[q][1], float) for q in qs])
        d = S[:, 1:] - S[:, :-1]
        if rules.min_move_d > 0.0:
            # _merge_short leaves the knots alone where the shortest segment is >= min_d
            min_d = _min_edge_d_rows(rules, sts)
            with np.errstate(invalid="ignore"):
                keep = [k and m for k, m in zip(keep, (d.min(axis=1) >= min_d).tolist())]
        v2 = V * V
        with np.errstate(all="ignore"):
            acc = np.abs(v2[:, 1:] - v2[:, :-1]) / (2.0 * d)
            z = np.array([min(0.0, st.accel) for st in sts], float)
            edge = (0.0 > acc[:, 0]) | (0.0 > acc[:, -1])
            acc[:, 0] = np.where(z > acc[:, 0], z, acc[:, 0])
            acc[:, -1] = np.where(z > acc[:, -1], z, acc[:, -1])
        take, step_v = [], []
        for k, (st, e) in enumerate(zip(sts, edge.tolist())):
            if keep[k] and not e:
                step_v.append(jerk_step_v(st))
                take.append(k)
        if not take:
            continue
        if len(take) < len(qs):
            S, V, acc = S[take], V[take], acc[take]
        grp = [(sts[k], knots[qs[k]][0], knots[qs[k]][1]) for k in take]
        for k, plan in zip(take, _block_plans(grp, S, V, acc, step_v, None)):
            out[qs[k]] = plan
    return out



def _block_plans(grp, S, V, acc, step_v, slow):
    """SegmentPlans of strokes of one knot count: grp [(stroke, sk, vk)], their knots and
    speeds S, V (rows), accelerations acc before hold_cruise_accels, step_v per row, slow
    [(slow0, slow1)] per row or None (no slowed end)."""
    A = hold_cruise_accels_rows(acc, np.array([g[0].accel for g in grp], float))
    need = np.maximum(np.maximum(V[:, :-1], V[:, 1:]), MIN_FEED_V)
    feeds = tent_feeds_rows(need, np.array([g[0].v_feed for g in grp], float), np.array(step_v, float))
    t_pred, a2_pred = _predict_rows(S, V, A)
    fine = fine_rows(S, V, A, feeds, t_pred, a2_pred)
    made = []
    for k, ((st, sk, vk), acc_k, f, t, a2) in enumerate(zip(grp, A, feeds, t_pred, a2_pred)):
        if slow is not None:
            slow0, slow1 = slow[k]
            if slow0:
                f[0] = max(st.v0, MIN_FEED_V)
            if slow1:
                f[-1] = max(st.v1, MIN_FEED_V)
            if slow0 or slow1:
                fine[k] = False                   # (a slowed end's feed was set after the check)
        made.append(SegmentPlan(sk, vk, acc_k, f, t, a2))
    settle_rows(made, fine, A, feeds)
    return made




# ---------------------------------------------------------------- helpers
def _same_plan(a, b):
    if a is None or b is None:
        assert a is None and b is None
        return
    # (a plan made with others may be a RowPlan: the same fields, read as rows of its blocks)
    assert isinstance(a, SegmentPlan) and isinstance(b, SegmentPlan)
    for f in ("s", "v", "accel", "feed"):
        x, y = getattr(a, f), getattr(b, f)
        assert type(x) is type(y) and x.dtype == y.dtype and x.shape == y.shape, f
        assert np.array_equal(np.asarray(x, float).view(np.int64), np.asarray(y, float).view(np.int64)), (f, x, y)
    for f in ("time_t", "int_a2"):
        x, y = getattr(a, f), getattr(b, f)
        assert type(x) is type(y) and np.float64(x).tobytes() == np.float64(y).tobytes(), (f, x, y)
    assert a.shape == b.shape and a.first_cmds == b.first_cmds and a.fault == b.fault


def _line_laws(path, profile, corners=0.0, every=3):
    """The line strokes of a sample and several candidate laws (T, beta) each."""
    prof = load_profile(profile)
    opts = Options()
    opts.corner_budget_r = corners
    strokes, _ = analyse(path, prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    rows = np.array([i for i in sc._rows_by_kind(strokes)[K_LINE] if not pin.fault[i]], int)
    T, beta, I, _ = plan_mod.candidates_auto(pin.take(rows))
    sts, Ts, bs = [], [], []
    for col in range(0, T.shape[1], every):
        ok = np.isfinite(I[:, col])
        sts += [strokes[i] for i in rows[ok]]
        Ts.append(T[ok, col])
        bs.append(beta[ok, col])
    return sts, np.concatenate(Ts), np.concatenate(bs), SegmentRules.for_profile(prof, opts.max_segments)


def _compare(sts, T, beta, rules):
    with np.errstate(all="ignore"):
        want = plan_segments(sts, T, beta, rules)
        got = seg.plan_segments(sts, T, beta, rules)
    assert len(got) == len(want)
    for a, b in zip(got, want):
        _same_plan(a, b)
    return want


_CACHE = {}


def _laws(path, profile, corners):
    key = (path, profile, corners)
    if key not in _CACHE:
        _CACHE[key] = _line_laws(S + path, profile, corners)
    return _CACHE[key]


CASES = [
    ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 0.0),
    ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 0.3),      # slowed ends, junction commands
    ("prusa_gyroid.gcode", "prusa-mk3s", 0.0),
    ("prusa_benchy_like.gcode", "voron24", 0.0),              # Klipper: every stroke per stroke
    ("prusa_klipper.gcode", "voron24", 0.05),
]


@pytest.mark.parametrize("path,profile,corners", CASES)
def test_plan_segments_same_as_1927d34(path, profile, corners):
    sts, T, beta, rules = _laws(path, profile, corners)
    assert len(sts) > 200
    want = _compare(sts, T, beta, rules)
    assert sum(p is not None and p.shape == "law" for p in want) > 50
    if rules.junction == "jerk":
        assert sum(p is not None and p.shape == "law" and p.fault == "" for p in want) > 50


class _Copy:
    """A stroke's fields, to perturb without touching the stroke."""
    def __init__(self, st):
        for f in type(st).__slots__:
            setattr(self, f, getattr(st, f))
        for f in dir(type(st)):                  # n_moves, prev_u, next_u, ...
            if isinstance(getattr(type(st), f), property):
                setattr(self, f, getattr(st, f))


@pytest.mark.parametrize("seed", [0, 1])
def test_plan_segments_perturbed_same_as_1927d34(seed):
    """Slowed ends, junction commands, odd accelerations, other durations, a small chunk
    (KNOT_CHUNK) and a min_move_d: the rows' path and the per-stroke path mixed."""
    rng = np.random.default_rng(seed)
    sts, T, beta, rules = _laws(*CASES[0])
    sts = [_Copy(st) for st in sts[:1500]]
    T, beta = T[:1500].copy(), beta[:1500].copy()
    for k, st in enumerate(sts):
        if k % 7 == 0:
            st.v0_fw = st.v0 + 1.0
        if k % 11 == 0:
            st.v1_fw, st.corner_cmd1 = st.v1 + 2.0, bool(k % 2)
        if k % 13 == 0:
            st.accel = float(rng.choice([-5.0, 0.0, -0.0, 1e-3, 2e5]))
        if k % 17 == 0:
            st.v_feed = st.v_feed * 0.5
    T *= rng.uniform(0.7, 1.6, T.size)
    for min_move_d in (0.0, 0.04):
        r = SegmentRules(rules.junction, rules.n_max, rules.seg_t, rules.min_seg_d, min_move_d, rules.flavour)
        _compare(sts, T, beta, r)
    old = seg.KNOT_CHUNK
    seg.KNOT_CHUNK = 97
    try:
        globals()["KNOT_CHUNK"] = 97
        _compare(sts, T, beta, rules)
    finally:
        seg.KNOT_CHUNK = old
        globals()["KNOT_CHUNK"] = old


def test_law_knots_same_as_1927d34_with_blocks():
    sts, T, beta, rules = _laws(*CASES[2])
    n = np.array([segment_count(t, st.length_d, rules.n_max, rules.seg_t, rules.min_seg_d)
                  for st, t in zip(sts, T)], dtype=int)
    ok = np.flatnonzero(n >= 2)[:3000]
    sub = [sts[i] for i in ok]
    got, want = seg.law_knots(sub, T[ok], beta[ok], n[ok]), law_knots(sub, T[ok], beta[ok], n[ok])
    assert len(got) == len(want) and isinstance(got, list)
    for (s, v), (s0, v0) in zip(got, want):
        for x, y in ((s, s0), (v, v0)):
            assert type(x) is type(y) and x.dtype == y.dtype and x.shape == y.shape
            assert np.array_equal(x.view(np.int64), y.view(np.int64))
    rows = 0
    for g, Sb, Vb in got.blocks:             # each block row is that stroke's knots
        for q, i in enumerate(g.tolist()):
            assert np.shares_memory(got[i][0], Sb) and np.array_equal(got[i][0], Sb[q])
            assert np.array_equal(got[i][1], Vb[q])
            rows += 1
    assert rows > 100
    assert seg.law_knots([], [], [], []) == []


def test_segment_counts_same_as_segment_count():
    rng = np.random.default_rng(5)

    class St:
        def __init__(self, L):
            self.length_d = L
    Ls = list(rng.uniform(-1.0, 30.0, 400)) + [0.0, -0.0, 0.3, 0.6, 0.9, 1e300, 5e-324, 3]
    Ts = list(rng.uniform(-0.1, 2.0, 400)) + [0.0, 0.004, 0.012, 1e-9, 1e200, -1e200, 0.5, 2]
    sts = [St(L) for L in Ls]
    for rules in (SegmentRules("jerk", 20, 0.004, 0.3), SegmentRules("jerk", 2 ** 40, 0.004, 0.3),
                  SegmentRules("jerk", 0, 0.004, 0.3), SegmentRules("jerk", 20, 0.0, 0.3),
                  SegmentRules("jerk", 20, 1, 0.3), SegmentRules("jerk", 20, 0.01, 1.0)):
        with np.errstate(all="ignore"):
            want = np.array([segment_count(t, st.length_d, rules.n_max, rules.seg_t, rules.min_seg_d)
                             for st, t in zip(sts, Ts)], dtype=int)
        got = seg._segment_counts(sts, np.array(Ts), rules)
        assert got.dtype == want.dtype and np.array_equal(got, want)
        assert np.array_equal(seg._segment_counts(sts, Ts, rules), want)
    # what int() or the division refuses raises as before (the same error)
    r3 = SegmentRules("jerk", 20, 0.004, 0.3)
    for sts_, Ts_, r in ((sts[:3] + [St(1.0)], Ts[:3] + [math.inf], r3), (sts[:3] + [St(1.0)], Ts[:3] + [math.nan], r3),
                         (sts[:3] + [St(math.inf)], Ts[:4], r3), (sts[:3], Ts[:3], SegmentRules("jerk", 20, 0.004, 0.0)),
                         ([St(1.0), St(2.0)], [0.1, 0.2], SegmentRules("jerk", 20, 0.004, 0.0))):
        with pytest.raises(Exception) as old, np.errstate(all="ignore"):
            [segment_count(t, st.length_d, r.n_max, r.seg_t, r.min_seg_d) for st, t in zip(sts_, Ts_)]
        with pytest.raises(old.type):
            with np.errstate(all="ignore"):
                seg._segment_counts(sts_, np.array(Ts_), r)


def test_jerk_steps_same_as_jerk_step_v():
    rng = np.random.default_rng(8)

    class Lim:
        def __init__(self, jx, jy):
            self.jerk_x, self.jerk_y = jx, jy

    class St:
        def __init__(self, ux, uy, jx, jy):
            self.ux, self.uy, self.lim = ux, uy, Lim(jx, jy)
    odd = [0.0, -0.0, 1.0, -1.0, 0.5, math.nan, math.inf, 1e-300, 8, 10]
    sts = [St(*rng.choice(odd, 4)) for _ in range(600)] + [St(*rng.uniform(-1, 1, 2), 8, 10) for _ in range(200)]
    sts = [st for st in sts if max(abs(st.ux), abs(st.uy)) != 0.0]
    sts.append(St(-0.0, 1.0, 8, 8))
    sts.append(St(1.0, math.nan, -0.0, 0.0))
    with np.errstate(all="ignore"):
        got = seg._jerk_steps(sts)
        want = np.array([jerk_step_v(st) for st in sts], float)
    assert np.array_equal(got.view(np.int64), want.view(np.int64))
    with pytest.raises(ZeroDivisionError):
        seg._jerk_steps(sts[:5] + [St(0.0, -0.0, 8, 10)])


@pytest.fixture(autouse=True)
def _no_jerk_corners(monkeypatch):
    """The plans pinned here are those of the code before segments' classic-jerk corner step
    (session 29, segments.JERK_CORNERS): off here.  tests/test_speed29_jerkentry_corners.py
    checks that step, and that plan_segments with it is these plans with their ends cut."""
    monkeypatch.setattr(seg, "JERK_CORNERS", False)
