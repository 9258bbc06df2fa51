"""Issue 8, stop 19 (D9): segments.law_knots makes the knots of the strokes of one move
for all of one knot count at once (rows of two blocks), and segments.plan_segments makes
the plans of the plainest strokes (classic jerk, no slowed end, no knot merged, no edge)
for all of one knot count at once (_finish_jerk_rows, then _block_plans on its blocks)
instead of one _finish(defer=True) call per stroke.  The plans must be the same bits and
types as ddecd40's plan_segments and law_knots, copied below (it calls the live _finish
and _finish_feeds_and_figures, which tests/test_speed_plan3_lines.py pins to their
earlier forms); _finish_jerk_rows is compared with _finish(defer=True) and
_finish_feeds_and_figures on random and degenerate knots."""
import math
import os

import numpy as np
import pytest

from gcode_opt import plan as plan_mod
from gcode_opt import schedule as sc
from gcode_opt import segments as seg
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_LINE

S = "sample_gcode/"
CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus/")


# ---------------------------------------------------------------- ddecd40's forms
def _old_law_knots(strokes, T, beta, n):
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
    law = seg.line_law(L[:, None], T[:, None], beta[:, None], v0[:, None], v1[:, None])
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
        vl = seg.line_law(L[owner_a], T[owner_a], beta[owner_a], v0[owner_a], v1[owner_a])
        _, v_vert, _ = vl.eval(np.asarray(seg.time_of_distance(vl, verts_a), float), "v")
        for k, i in enumerate(owner):
            vv.setdefault(i, []).append((verts_a[k], float(v_vert[k])))
    out = []
    for i in range(m):
        s, v = s_all[i, :n[i] + 1].copy(), v_all[i, :n[i] + 1].copy()
        if i in vv:
            vs = np.array([p[0] for p in vv[i]])
            min_gap = min(seg.MIN_SEG_D, L[i] / (4 * n[i]))
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
        out.append((s, v))
    return out


def _old_plan_segments(strokes, T, beta, rules):
    n = np.array([seg.segment_count(t, st.length_d, rules.n_max, rules.seg_t, rules.min_seg_d)
                  for st, t in zip(strokes, T)], dtype=int)
    ok = np.flatnonzero(n >= 2)
    plans = [None] * len(strokes)
    T, beta = np.asarray(T), np.asarray(beta)
    for a in range(0, ok.size, seg.KNOT_CHUNK):       # bounded memory; every step is per stroke
        rows = ok[a:a + seg.KNOT_CHUNK]
        knots = _old_law_knots([strokes[i] for i in rows], T[rows], beta[rows], n[rows])
        pending = []
        for i, (sk, vk) in zip(rows.tolist(), knots):
            got = seg._finish(strokes[i], sk, vk, rules, defer=True)
            if got is not None:
                pending.append((i, got))
        for (i, _), plan in zip(pending, seg._finish_feeds_and_figures([g for _, g in pending])):
            plans[i] = plan
    short = [i for i, p in enumerate(plans) if p is None or not p.int_a2 < strokes[i].int_a2]
    if short:
        rows = np.array(short, int)
        for i, p in zip(short, seg.line_trapezoids([strokes[i] for i in short], T[rows], beta[rows], rules)):
            if p is not None and p.int_a2 < strokes[i].int_a2 and (plans[i] is None or p.int_a2 < plans[i].int_a2):
                plans[i] = p
    return plans


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


def _same_deferred(a, b):
    if a is None or b is None:
        assert a is None and b is None
        return
    assert a[0] is b[0]
    for x, y in zip(a[1:4], b[1:4]):
        assert type(x) is type(y) and x.dtype == y.dtype and x.shape == y.shape
        assert x.tobytes() == y.tobytes(), (x, y)
    assert type(a[4]) is type(b[4]) and np.float64(a[4]).tobytes() == np.float64(b[4]).tobytes()
    assert a[5:] == b[5:] and type(a[5]) is type(b[5]) and type(a[6]) is type(b[6])


def _line_laws(path, profile, corners=0.0, every=3):
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
    return sts, np.concatenate(Ts), np.concatenate(bs), seg.SegmentRules.for_profile(prof, opts.max_segments)


CASES = [
    (S + "prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 0.0),    # classic jerk: the rows' path
    (S + "prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 0.3),    # slowed ends and commands: per stroke
    (S + "prusa_benchy_like.gcode", "prusa-mk4", 0.0),
    (S + "prusa_gyroid.gcode", "bambu-x1c", 0.05),
    (S + "prusa_mk3s_rectilinear.gcode", "voron24", 0.0),        # Klipper: every stroke per stroke
    (S + "prusa_gyroid.gcode", "ender3", 0.0),                   # Marlin JD: likewise
    (CORPUS + "bridges.gcode", "prusa-mk3s", 0.0),
]


@pytest.mark.parametrize("path,profile,corners", CASES)
def test_plan_segments_same_plans(path, profile, corners):
    if not os.path.exists(path):
        pytest.skip("corpus file not present")
    sts, T, beta, rules = _line_laws(path, profile, corners)
    assert len(sts) > 200
    calls = []
    real = seg._finish_jerk_rows

    def spy(strokes, knots, rules_):
        out = real(strokes, knots, rules_)
        calls.append(sum(x is not None for x in out))
        return out
    seg._finish_jerk_rows = spy
    try:
        got = seg.plan_segments(sts, T, beta, rules)
    finally:
        seg._finish_jerk_rows = real
    want = _old_plan_segments(sts, T, beta, rules)
    assert len(got) == len(want)
    assert sum(p is not None and p.shape == "law" for p in got) > 100
    if rules.junction == "jerk":
        assert sum(calls) > 100               # the rows' path ran
    else:
        assert sum(calls) == 0
    for a, b in zip(got, want):
        _same_plan(a, b)


class _Lim:
    def __init__(self, jx, jy):
        self.jerk_x, self.jerk_y, self.jd = jx, jy, 0.0


class _St:
    """What _finish reads of a stroke."""
    def __init__(self, rng, k):
        ang = rng.uniform(0, 2 * math.pi)
        self.ux, self.uy = math.cos(ang), math.sin(ang)
        if k % 13 == 0:
            self.ux, self.uy = 1.0, 0.0
        if k % 17 == 0:
            self.ux, self.uy = 0.0, -1.0
        self.v0, self.v1 = (float(x) for x in rng.choice([0.0, 0.004, 5.0, 40.0], 2))
        self.accel = float(rng.choice([1000.0, 2500.0, -5.0, 0.0, -0.0, math.nan]) if k % 7 == 0 else 1250.0)
        self.lim = _Lim(*(float(x) for x in rng.choice([8.0, 10.0, 0.5], 2)))
        self.prev_u = None if k % 3 else (1.0, 0.0)
        self.next_u = None if k % 5 else (0.0, 1.0)
        self.corner_cmd0 = self.corner_cmd1 = False
        self.v0_fw = self.v1_fw = None
        if k % 11 == 0:                        # a slowed end: per stroke
            self.v0_fw = self.v0 + 1.0
        if k % 19 == 0:
            self.v1_fw, self.corner_cmd1 = self.v1 + 1.0, True
        self.v_feed = 60.0
        self.ends_d = [1.0]


def _random_knots(rng, k, K):
    L = float(rng.choice([0.5, 3.0, 40.0]))
    kind = k % 9
    if kind == 0:                              # crowded knots: merged by _merge_short
        s = np.sort(np.concatenate([[0.0, L], rng.uniform(0, L, K - 2)]))
        s[1] = s[0] + 1e-4
    elif kind == 1:                            # decreasing knots: negative ramp accelerations
        s = np.linspace(L, 0.0, K)
    elif kind == 2:
        s = np.linspace(0.0, L, K)
        s[2] = math.nan
    else:
        s = np.linspace(0.0, L, K)
    v = rng.uniform(0.0, 80.0, K)
    if k % 4 == 0:
        v[:] = 30.0                            # a cruise: ramp accelerations 0
    if k % 23 == 0:
        v[1] = math.nan
    if k % 29 == 0:
        v[-1] = math.inf
    return s, v


@pytest.mark.parametrize("min_move_d", [0.0, 0.05, 1.0])
def test_finish_rows_same_as_finish(min_move_d):
    rng = np.random.default_rng(19)
    rules = seg.SegmentRules("jerk", 20, 0.004, 0.3, min_move_d, "marlin")
    sts, knots = [], []
    for k in range(1200):
        st = _St(rng, k)
        K = int(rng.choice([3, 4, 5, 9, 15]))
        sts.append(st)
        knots.append(_random_knots(rng, k, K))
    knots.append((np.array([0.0, 1.0]), np.array([1.0, 2.0])))     # one segment: per stroke
    sts.append(_St(rng, 1))
    with np.errstate(all="ignore"):
        got = seg._finish_jerk_rows(sts, knots, rules)
    taken = sum(g is not None for g in got)
    assert 200 < taken < len(sts) - 200
    for st, (sk, vk), g in zip(sts, knots, got):
        if g is None:
            continue
        with np.errstate(all="ignore"):
            want = seg._finish(st, sk, vk, rules, defer=True)
            assert want is not None and want[5:] == (False, False)
            ref = seg._finish_feeds_and_figures([want])[0]
        _same_plan(g, ref)
        assert g.fault == ref.fault
    # other junction laws take no stroke
    for junction in ("scv", "jd"):
        r = seg.SegmentRules(junction, 20, 0.004, 0.3, min_move_d, "klipper")
        assert all(g is None for g in seg._finish_jerk_rows(sts, knots, r))


def test_finish_rows_zero_direction_raises_alike():
    """A stroke with ux = uy = 0 raises in _finish's step_v: here too (isolate() drops it)."""
    rng = np.random.default_rng(3)
    st = _St(rng, 1)
    st.ux = st.uy = 0.0
    rules = seg.SegmentRules("jerk", 20, 0.004, 0.3, 0.0, "marlin")
    knots = [(np.linspace(0.0, 2.0, 5), np.full(5, 20.0))]
    with pytest.raises(ZeroDivisionError):
        seg._finish(st, *knots[0], rules, defer=True)
    with pytest.raises(ZeroDivisionError):
        seg._finish_jerk_rows([st], knots, rules)


def _same_knots(got, want):
    assert len(got) == len(want)
    for (s, v), (s0, v0) in zip(got, want):
        for x, y in ((s, s0), (v, v0)):
            assert type(x) is type(y) and x.dtype == y.dtype and x.shape == y.shape and x.ndim == 1
            assert x.flags.c_contiguous
            assert x.tobytes() == y.tobytes(), (x, y)


@pytest.mark.parametrize("path,profile,corners", CASES[:4])
def test_law_knots_same_as_ddecd40(path, profile, corners):
    sts, T, beta, rules = _line_laws(path, profile, corners, every=5)
    n = np.array([seg.segment_count(t, st.length_d, rules.n_max, rules.seg_t, rules.min_seg_d)
                  for st, t in zip(sts, T)], dtype=int)
    ok = np.flatnonzero(n >= 2)
    for a in range(0, ok.size, 700):
        rows = ok[a:a + 700]
        sub = [sts[i] for i in rows]
        _same_knots(seg.law_knots(sub, T[rows], beta[rows], n[rows]),
                    _old_law_knots(sub, T[rows], beta[rows], n[rows]))
    # segment counts of 0 and 1, slow laws (speeds through 0), near-cubic and flat laws
    rows = ok[:300]
    sub = [sts[i] for i in rows]
    nn = n[rows].copy()
    nn[::7] = 1
    nn[::11] = 0
    TT = T[rows].copy()
    TT[::13] *= 3.0                                          # slow laws: speeds through 0
    bb = beta[rows].copy()
    bb[::17] = np.inf
    bb[::19] = 1e-9
    with np.errstate(all="ignore"):
        _same_knots(seg.law_knots(sub, TT, bb, nn), _old_law_knots(sub, TT, bb, nn))


class _Line:
    """What law_knots reads of a stroke; n_moves > 1: collinear moves (interior vertices)."""
    def __init__(self, L, v0, v1, ends):
        self.length_d, self.v0, self.v1, self.ends_d = L, v0, v1, list(ends)
        self.n_moves = len(self.ends_d)


def test_law_knots_interior_vertices():
    rng = np.random.default_rng(4)
    sts, T, beta, n = [], [], [], []
    for k in range(900):
        L = float(rng.uniform(0.5, 60.0))
        cuts = np.sort(rng.uniform(0.0, L, k % 4))
        if k % 9 == 0 and cuts.size:
            cuts[0] = L / 2.0                                 # a vertex on a law knot
        sts.append(_Line(L, float(rng.choice([0.0, 10.0, 35.0])), float(rng.choice([0.0, 20.0])),
                         list(cuts) + [L]))
        T.append(L / rng.uniform(20.0, 80.0) if k % 5 else L / 2.0)    # slow: speeds through 0 (clipped)
        beta.append(float(rng.choice([1e-6, 1e-4, 1e-2, np.inf])))
        n.append(int(rng.choice([2, 3, 5, 8, 13])))
    assert sum(st.n_moves > 1 for st in sts) > 500
    T, beta, n = np.array(T), np.array(beta), np.array(n)
    with np.errstate(all="ignore"):
        got = seg.law_knots(sts, T, beta, n)
        _same_knots(got, _old_law_knots(sts, T, beta, n))
    assert sum(float(np.min(v)) == 0.0 for s, v in got if v.size > 2) > 50      # clipped speeds seen


# ddecd40's _tent_by_step (every step value its own group), verbatim
def _old_tent_by_step(out, need, vf, step, live, ar, max_cells):
    n = need.shape[1]
    steps = step[live]
    if (steps == steps[0]).all():
        groups = [(live, steps[0])]
    else:
        uniq, inv = np.unique(steps, return_inverse=True)
        groups = [(live[inv == q], uniq[q]) for q in range(uniq.size)]
    per = max(1, max_cells // max(n * (n + 2), 1))
    block = np.empty((min(per, live.size), n, n + 2))
    for rows, st in groups:
        dist = st * ar
        for a in range(0, rows.size, per):
            r = rows[a:a + per]
            side = (vf[r] + step[r])[:, None]
            pad = np.concatenate([side, need[r], side], axis=1)
            b = block[:r.size]
            np.subtract(pad[:, None, :], dist[None, :, :], out=b)
            out[r] = np.max(b, axis=2)


@pytest.mark.parametrize("seed", range(4))
def test_tent_small_groups_same_as_ddecd40(seed):
    """Lines under classic jerk: a step per direction, few rows each (each row's own
    products into the block); a few large groups still share theirs."""
    rng = np.random.default_rng(seed)
    for k, n, distinct, cells in ((400, 9, 300, 1 << 19), (2000, 4, 1500, 5000), (300, 30, 12, 1 << 19),
                                  (64, 1, 64, 1 << 19), (700, 15, 400, 3000)):
        need = rng.uniform(0.1, 250.0, (k, n))
        need[::13] = np.round(need[::13], 1)
        steps = rng.uniform(0.3, 12.0, distinct)
        steps[::5] = 9.0                             # ties between groups' rows
        step = rng.choice(steps, k)
        vf = rng.uniform(10.0, 150.0, k)
        live = np.flatnonzero(step > 1.0)              # some rows left out (an infinite step)
        ar = seg._tent_dist(n)
        got, want = np.array(need), np.array(need)
        seg._tent_by_step(got, need, vf, step, live, ar, cells)
        _old_tent_by_step(want, need, vf, step, live, ar, cells)
        assert got.tobytes() == want.tobytes()


@pytest.mark.parametrize("min_move_d", [0.0, 0.004, 0.05, 1.0])
def test_min_edge_d_rows_same_as_min_edge_d(min_move_d):
    rng = np.random.default_rng(7)
    rules = seg.SegmentRules("jerk", 20, 0.004, 0.3, min_move_d, "marlin")

    class D:
        def __init__(self, ux, uy):
            self.ux, self.uy = ux, uy
    vals = [0.0, -0.0, 1.0, -1.0, 1e-13, -1e-300, 0.7071067811865476, math.nan, math.inf, -math.inf]
    sts = [D(float(a), float(b)) for a in vals for b in vals]
    ang = rng.uniform(0, 2 * math.pi, 500)
    sts += [D(math.cos(a), math.sin(a)) for a in ang]
    got = seg._min_edge_d_rows(rules, sts)
    for st, g in zip(sts, got.tolist()):
        want = rules.min_edge_d(st.ux, st.uy)
        assert np.float64(g).tobytes() == np.float64(want).tobytes() or (math.isnan(g) and math.isnan(want))


@pytest.fixture(autouse=True)
def _no_jerk_corners(monkeypatch):
    """The plans pinned here are those of the code before segments' classic-jerk corner step
    (session 29, segments.JERK_CORNERS): off here.  tests/test_speed29_jerkentry_corners.py
    checks that step, and that plan_segments with it is these plans with their ends cut."""
    monkeypatch.setattr(seg, "JERK_CORNERS", False)
