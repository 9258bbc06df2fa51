"""Line segments (s24, lineplan): plan_segments asks law_knots for no row views of its
blocks (law_knots(views=False); _Knots.at gives a stroke's (s, v) where the rows' path
did not plan it), and _finish_jerk_rows visits only the strokes no block took.  The plans
must be the same bits, types and verdicts as d8e21e6's plan_segments / law_knots /
_finish_jerk_rows, copied below (they call the live _law_knot_blocks, _jerk_rows, _finish,
_finish_feeds_and_figures and line_trapezoids, which this change leaves alone): classic
jerk (the rows' path), slowed ends and junction commands, Klipper and Marlin JD (every
stroke through _finish, its knots from _Knots.at), strokes of several moves."""
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
PLATE = os.path.expanduser("~/.cache/gcode-opt-corpus/plate_rectilinear.gcode")


# ---------------------------------------------------------------- d8e21e6, verbatim
def law_knots_ref(strokes, T, beta, n):
    m = len(strokes)
    if m == 0:
        return []
    multi, blocks = seg._law_knot_blocks(strokes, T, beta, n)
    out = seg._Knots([None]) * m
    for g, s, v in blocks:              # each stroke's s and v: its rows of the blocks
        for i, sr, vr in zip(g.tolist(), s, v):
            out[i] = (sr, vr)
    for i, sv in multi.items():
        out[i] = sv
    out.blocks = blocks
    return out


def finish_jerk_rows_ref(strokes, knots, rules):
    out = [None] * len(strokes)
    if rules.junction != "jerk":
        return out
    blocks = getattr(knots, "blocks", None) if type(knots) is seg._Knots else None
    done = set()
    for g, S_, V in blocks or ():       # law_knots' blocks: its rows' knots as they are
        if (type(S_) is type(V) is np.ndarray and S_.ndim == V.ndim == 2 and S_.shape[1] >= 3
                and S_.shape == V.shape and S_.dtype == V.dtype == seg._F64):
            qs = g.tolist()
            done.update(qs)
            got = seg._jerk_rows(S_, V, [strokes[q] for q in qs], rules)
            if got is not None:
                for k, plan in zip(*got):
                    out[qs[k]] = plan
    by_k = {}
    for q, (st, (sk, _)) in enumerate(zip(strokes, knots)):
        if type(sk) is np.ndarray and sk.ndim == 1 and sk.size >= 3 and sk.dtype == seg._F64 and q not in done:
            by_k.setdefault(sk.size, []).append(q)
    for qs in by_k.values():
        S_ = np.stack([knots[q][0] for q in qs])
        V = np.stack([np.asarray(knots[q][1], float) for q in qs])
        got = seg._jerk_rows(S_, V, [strokes[q] for q in qs], rules, [knots[q] for q in qs])
        if got is not None:
            for k, plan in zip(*got):
                out[qs[k]] = plan
    return out


def plan_segments_ref(strokes, T, beta, rules):
    n = seg._segment_counts(strokes, T, rules)
    ok = np.flatnonzero(n >= 2)
    plans = [None] * len(strokes)
    T, beta = np.asarray(T), np.asarray(beta)
    for a in range(0, ok.size, seg.KNOT_CHUNK):       # bounded memory; every step is per stroke
        rows = ok[a:a + seg.KNOT_CHUNK]
        sts = [strokes[i] for i in rows]
        knots = law_knots_ref(sts, T[rows], beta[rows], n[rows])
        fast = finish_jerk_rows_ref(sts, knots, rules)
        if rules.junction in ("scv", "jd"):    # s29 segrows: the live rows' path of scv / jd (RowPlans),
            fast = seg._finish_corner_rows(sts, knots, rules)   # checked against _finish in test_speed29_segrows_lines
        pending = []
        for i, st, (sk, vk), got in zip(rows.tolist(), sts, knots, fast):
            if got is not None:                   # made by the rows' path
                plans[i] = got
                continue
            got = seg._finish(st, sk, vk, rules, defer=True)
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


# ---------------------------------------------------------------- comparison
def _arr_same(x, y):
    if not isinstance(y, np.ndarray):
        return type(x) is type(y) and x == y
    return (type(x) is type(y) and x.dtype == y.dtype and x.shape == y.shape and x.strides == y.strides
            and x.tobytes() == y.tobytes())


def _same_plans(got, want):
    assert len(got) == len(want)
    made = 0
    for g, w in zip(got, want):
        assert (g is None) == (w is None)
        if w is None:
            continue
        made += 1
        assert type(g) is type(w)
        for f in ("s", "v", "accel", "feed"):
            assert _arr_same(getattr(g, f), getattr(w, f)), f
        for f in ("time_t", "int_a2"):
            assert type(getattr(g, f)) is type(getattr(w, f)) and float(getattr(g, f)).hex() == float(getattr(w, f)).hex()
        assert g.shape == w.shape and g.first_cmds == w.first_cmds
        assert g.fault == w.fault
        assert sc.seg_fault(g) == sc.seg_fault(w)
    return made


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
    (S + "prusa_gyroid.gcode", "bambu-x1c", 0.05),
    (S + "prusa_mk3s_rectilinear.gcode", "voron24", 0.0),        # Klipper: every stroke per stroke
    (S + "prusa_gyroid.gcode", "ender3", 0.0),                   # Marlin JD: likewise
]


@pytest.mark.parametrize("path,profile,corners", CASES)
def test_plan_segments_same_as_d8e21e6(path, profile, corners):
    sts, T, beta, rules = _line_laws(path, profile, corners)
    assert len(sts) > 200
    assert _same_plans(seg.plan_segments(sts, T, beta, rules), plan_segments_ref(sts, T, beta, rules)) > 100


@pytest.mark.skipif(not os.path.exists(PLATE), reason="corpus not downloaded")
def test_plate_slice_same_as_d8e21e6():
    sts, T, beta, rules = _line_laws(PLATE, "prusa-mk3s", every=11)
    sts, T, beta = sts[:5000], T[:5000], beta[:5000]
    assert _same_plans(seg.plan_segments(sts, T, beta, rules), plan_segments_ref(sts, T, beta, rules)) > 3000


class _Line:
    """What law_knots reads of a stroke; n_moves > 1: collinear moves (interior vertices)."""
    def __init__(self, L, v0, v1, ends):
        self.length_d, self.v0, self.v1, self.ends_d = L, v0, v1, list(ends)
        self.n_moves = len(self.ends_d)


def test_knots_at_gives_the_views_law_knots_gives():
    rng = np.random.default_rng(4)
    sts, T, beta, n = [], [], [], []
    for k in range(600):
        L = float(rng.uniform(0.5, 60.0))
        cuts = np.sort(rng.uniform(0.0, L, k % 3))
        sts.append(_Line(L, float(rng.choice([0.0, 10.0, 35.0])), float(rng.choice([0.0, 20.0])), list(cuts) + [L]))
        T.append(L / rng.uniform(20.0, 80.0))
        beta.append(float(rng.choice([1e-6, 1e-4, 1e-2, np.inf])))
        n.append(int(rng.choice([2, 3, 5, 8, 13])))
    T, beta, n = np.array(T), np.array(beta), np.array(n)
    with np.errstate(all="ignore"):
        want = seg.law_knots(sts, T, beta, n)
        got = seg.law_knots(sts, T, beta, n, views=False)
    assert sum(x is None for x in got) > 150 and sum(x is not None for x in got) > 150   # both kinds
    for q, (s0, v0) in enumerate(want):
        s, v = got.at(q)
        for x, y in ((s, s0), (v, v0)):
            assert type(x) is type(y) and x.shape == y.shape and x.strides == y.strides
            assert x.tobytes() == y.tobytes()
        if got[q] is None:                            # a row view of its block, as law_knots' own
            assert any(s.base is S_ and v.base is V for _, S_, V in got.blocks)
