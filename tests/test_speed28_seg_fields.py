"""Issue 8 (s28, segcpu): the budget runs' line segments and their bookkeeping, the same bits.

  plan_segments / law_knots / _jerk_rows / _jerk_steps / _min_edge_d_rows / _segment_counts
      read the strokes' fields once each in C-level passes (map over attrgetter, np.fromiter)
      and share them (L, v0, v1 from plan_segments; ux, uy for the steps and the edges);
      n_moves of Strokes from their two indices (_move_counts); the strokes left short by
      arrays; RowPlan's fields set by its own __init__;
  settle_faults   RowPlans checked as rows of their blocks (_settle_rows), not as four views
      each concatenated again;
  _keep_plans     settle_faults only on the plans with no verdict yet.

The reference is da0e9ec's code, copied verbatim below (it calls the live helpers this
change leaves alone: _law_sv, _Knots, _finish, the tails, line_trapezoids, _settle,
seg_fault): the plans must be the same bits, types and verdicts, on real sample files and
a slice of the rectilinear plate, with the compiled tail and the numpy one, and the pure-
Python strokes (GCODE_OPT_PURE_PYTHON=1) in a child process."""
import copy
import math
import os
import subprocess
import sys
from collections import deque
from itertools import repeat

import numpy as np
import pytest

from gcode_opt import plan as plan_mod
from gcode_opt import schedule as SC
from gcode_opt import segments as SEG
from gcode_opt.laws.line import line_law, time_of_distance
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt import chains
from gcode_opt.schedule import (_FAULT, _INT_A2, _NOT_BEATING, _TIME_T, AS_SLICED, GAIN_TOL_R, KINDS, SETTLE_CHUNK,
                                _as_sliced, _command_for, _settle, seg_fault)
from gcode_opt.strokes import K_LINE, Stroke
from gcode_opt.segments import (KNOT_CHUNK, MIN_EDGE_D, MIN_SEG_D, ROUND_D, RowPlan, SegmentPlan, SegmentRules, _F64,
                                _finish, _finish_feeds_and_figures, _jerk_tail, _jerk_tail_core, _Knots,
                                _law_sv, _rows_core, jerk_step_v, line_trapezoids, segment_count, settle_rows,
                                slowed_ends, slowed_original)

HERE = os.path.dirname(os.path.abspath(__file__))
S = os.path.join(HERE, "..", "sample_gcode") + "/"
PLATE = os.path.expanduser("~/.cache/gcode-opt-corpus/plate_rectilinear.gcode")


# ---------------------------------------------------------------- da0e9ec, verbatim
def plan_segments(strokes, T, beta, rules: SegmentRules):
    """Segments that make the firmware play each stroke's law (L, T, beta, v0, v1): a
    list with a SegmentPlan, or None where no plan beats the original.

    A stroke too short or quick for two segments, or whose segments would not beat the
    original trapezoid, gets the one-move trapezoid of the same duration with the least
    int a^2 (trapezoid.py) instead, when that beats the original."""
    n = _segment_counts(strokes, T, rules)
    ok = np.flatnonzero(n >= 2)
    plans = [None] * len(strokes)
    T, beta = np.asarray(T), np.asarray(beta)
    for a in range(0, ok.size, KNOT_CHUNK):       # bounded memory; every step is per stroke
        rows = ok[a:a + KNOT_CHUNK]
        sts = [strokes[i] for i in rows]
        knots = law_knots(sts, T[rows], beta[rows], n[rows], views=False)
        fast = _finish_jerk_rows(sts, knots, rules)
        if rules.junction in ("scv", "jd"):    # s29 segrows: the live rows' path of scv / jd (RowPlans),
            fast = SEG._finish_corner_rows(sts, knots, rules)   # checked against _finish in test_speed29_segrows_lines
        pending = []
        for q, (i, got) in enumerate(zip(rows.tolist(), fast)):
            if got is not None:                   # made by the rows' path
                plans[i] = got
                continue
            sk, vk = knots.at(q)
            got = _finish(sts[q], sk, vk, rules, defer=True)
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


def _segment_counts(strokes, T, rules):
    """[segment_count(t, st.length_d, rules.n_max, rules.seg_t, rules.min_seg_d)] as an int
    array: the same truncated quotients and the same least of three (exact on floats that
    hold integers: n_max below 2^53); anything else (a quotient not finite, which int()
    refuses, a step not > 0, an n_max not an int) takes segment_count stroke by stroke."""
    n_max, seg_t, min_d = rules.n_max, rules.seg_t, rules.min_seg_d
    if (len(strokes) and type(n_max) is int and 0 <= n_max < 2 ** 53 and isinstance(seg_t, float)
            and isinstance(min_d, float) and seg_t > 0 and min_d > 0 and np.ndim(T) == 1):
        L = np.array([st.length_d for st in strokes], float)
        Tf = np.asarray(T, float)
        if L.ndim == 1 and Tf.shape == L.shape:
            with np.errstate(all="ignore"):
                q1, q2 = np.trunc(Tf / seg_t), np.trunc(L / min_d)
            if np.isfinite(q1).all() and np.isfinite(q2).all():
                nf = np.minimum(np.minimum(q1, q2), float(n_max))
                return np.maximum(nf, 0.0).astype(int)
    return np.array([segment_count(t, st.length_d, n_max, seg_t, min_d)
                     for st, t in zip(strokes, T)], dtype=int)


def law_knots(strokes, T, beta, n, views=True):
    """Knots of many strokes at once (one vectorised law evaluation): for stroke i, the
    distances s (mm) and speeds v (mm/s) at n_i + 1 instants evenly spaced in time, plus
    every interior original vertex (law knots too close to a vertex dropped), with
    s_0 = 0, s_K = L and the end speeds exact.  Returns a list of (s, v).

    views=False: the strokes of one move (rows of the blocks) are None in the list, and
    _Knots.at(i) gives their (s, v) (plan_segments: ~95 % of a plate's strokes are planned
    from the blocks themselves, whose rows' views, ~1.3 µs a stroke, were not read)."""
    m = len(strokes)
    if m == 0:
        return []
    multi, blocks = _law_knot_blocks(strokes, T, beta, n)
    out = _Knots([None]) * m
    for g, s, v in blocks if views else ():     # each stroke's s and v: its rows of the blocks
        for i, sr, vr in zip(g.tolist(), s, v):
            out[i] = (sr, vr)
    for i, sv in multi.items():
        out[i] = sv
    out.blocks = blocks
    return out


def _law_knot_blocks(strokes, T, beta, n):
    """law_knots' knots as ({i: (s, v)} of the strokes of several moves, [(rows, S, V)]
    blocks of the strokes of one move, by knot count: stroke rows[q]'s s and v are the
    rows S[q], V[q]).  The speeds are evaluated without the accelerations (LineLaw.eval's
    want: the same s and v)."""
    L = np.array([st.length_d for st in strokes])
    v0 = np.array([st.v0 for st in strokes])
    v1 = np.array([st.v1 for st in strokes])
    T, beta, n = np.asarray(T, float), np.asarray(beta, float), np.asarray(n, int)
    j = np.arange(n.max() + 1)
    tau = np.minimum(j[None, :] / n[:, None], 1.0)
    s_all, v_all = _law_sv(L, T, beta, v0, v1, tau * T[:, None])
    # interior vertices of multi-move strokes: one vectorised inversion s -> t
    nm = [st.n_moves for st in strokes]
    owner, verts = [], []
    if max(nm) > 1:
        for i, st in enumerate(strokes):
            if nm[i] > 1:
                owner += [i] * (nm[i] - 1)
                verts += st.ends_d[:-1]
    vv = {}
    if verts:
        owner_a, verts_a = np.array(owner), np.array(verts)
        vl = line_law(L[owner_a], T[owner_a], beta[owner_a], v0[owner_a], v1[owner_a])
        _, v_vert, _ = vl.eval(np.asarray(time_of_distance(vl, verts_a), float), "v")
        for k, i in enumerate(owner):
            vv.setdefault(i, []).append((verts_a[k], float(v_vert[k])))
    # strokes of one move, by knot count: their rows in one go (the same copies, the
    # same elementwise max and the same assignments as stroke by stroke)
    single = np.ones(len(strokes), bool)
    if vv:
        single[list(vv)] = False
    blocks = []
    idx = np.flatnonzero(single)
    if idx.size:
        ks = n[idx]
        for k in np.unique(ks).tolist():
            g = idx[ks == k]
            s = s_all[g, :k + 1]
            s[:, 0] = 0.0
            s[:, -1] = L[g]
            v = np.maximum(v_all[g, :k + 1], 0.0)
            v[:, 0] = v0[g]
            v[:, -1] = v1[g]
            blocks.append((g, s, v))
    multi = {}
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
        multi[i] = (s, v)
    return multi, blocks


def _finish_jerk_rows(strokes, knots, rules):
    """The SegmentPlans _finish(st, sk, vk, rules, defer=True) and _finish_feeds_and_figures
    make of the strokes that take _finish's plainest path, for all of one knot count at
    once (law_knots' own blocks as they are, _Knots.blocks; other rows stacked by knot count:
    _jerk_rows); None for the others (and for
    all of them under a junction law other than classic jerk), which go through _finish.

    The plainest path: classic jerk (accel_to_pass_junction gives 0.0 at both ends), no
    end slowed by corners.py, no knot merged by _merge_short (every segment at least
    min_edge_d long), and ramp accelerations at both ends not below 0 (0.0 > acc would
    add edges).  Then _finish computes ramp_accels (elementwise: the same here in rows),
    acc[0] = max(acc[0], min(0.0, accel)) and the same for acc[-1] (Python's max and min:
    np.where on the same comparisons), and step_v (jerk_step_v: _jerk_steps, the same
    operations), and returns the knots it was given.  ~68 k strokes on the rectilinear
    plate (law_knots, _finish_jerk_rows and the plans: ~20 µs each there, was ~29)."""
    out = [None] * len(strokes)
    if rules.junction != "jerk":
        return out
    blocks = getattr(knots, "blocks", None) if type(knots) is _Knots else None
    done = set()
    for g, S, V in blocks or ():       # law_knots' blocks: its rows' knots as they are
        if (type(S) is type(V) is np.ndarray and S.ndim == V.ndim == 2 and S.shape[1] >= 3
                and S.shape == V.shape and S.dtype == V.dtype == _F64):
            qs = g.tolist()
            done.update(qs)
            got = _jerk_rows(S, V, [strokes[q] for q in qs], rules)
            if got is not None:
                for k, plan in zip(*got):
                    out[qs[k]] = plan
    by_k = {}
    at = knots.at if type(knots) is _Knots else knots.__getitem__
    rest = range(len(strokes))
    if done:                           # the strokes no block took (few): those only
        left = np.ones(len(strokes), bool)
        left[list(done)] = False
        rest = np.flatnonzero(left).tolist()
    for q in rest:
        sk = at(q)[0]
        if type(sk) is np.ndarray and sk.ndim == 1 and sk.size >= 3 and sk.dtype == _F64:
            by_k.setdefault(sk.size, []).append(q)
    for qs in by_k.values():
        kn = [at(q) for q in qs]
        S = np.stack([k[0] for k in kn])
        V = np.stack([np.asarray(k[1], float) for k in kn])
        got = _jerk_rows(S, V, [strokes[q] for q in qs], rules, kn)
        if got is not None:
            for k, plan in zip(*got):
                out[qs[k]] = plan
    return out


def _jerk_rows(S, V, sts, rules, knots=None):
    """_finish_jerk_rows of one knot count's rows S, V (float64 blocks; knots: each row's
    own (sk, vk) for its plan, else the blocks' rows): (rows taken, their SegmentPlans),
    or None where no row is taken.  The strokes' fields are read into arrays once: Python's
    min / max of two floats are np.where on the same comparison (the first one on a tie
    or a NaN), the divisions the same; a stroke whose jerk step divides by 0 goes stroke by
    stroke (jerk_step_v raises as _finish would)."""
    m = len(sts)
    fw = [getattr(st, "v0_fw", None) is None and getattr(st, "v1_fw", None) is None for st in sts]
    if all(fw):
        keep = np.ones(m, bool)
    else:                                          # slowed_ends is (False, False) where both are None
        keep = np.array([f or not any(slowed_ends(st)) for f, st in zip(fw, sts)], bool)
    d = S[:, 1:] - S[:, :-1]
    if rules.min_move_d > 0.0:
        # _merge_short leaves the knots alone where the shortest segment is >= min_d
        min_d = _min_edge_d_rows(rules, sts)
        with np.errstate(invalid="ignore"):
            keep &= d.min(axis=1) >= min_d
    v2 = V * V
    accel = np.array([st.accel for st in sts], float)
    with np.errstate(all="ignore"):
        acc = np.abs(v2[:, 1:] - v2[:, :-1]) / (2.0 * d)
        z = np.where(accel < 0.0, accel, 0.0)      # min(0.0, accel)
        edge = (0.0 > acc[:, 0]) | (0.0 > acc[:, -1])
        acc[:, 0] = np.where(z > acc[:, 0], z, acc[:, 0])
        acc[:, -1] = np.where(z > acc[:, -1], z, acc[:, -1])
    keep &= ~edge
    take = np.flatnonzero(keep)
    if not take.size:
        return None
    if take.size < m:
        S, V, acc, accel = S[take], V[take], acc[take], accel[take]
        sts = [sts[k] for k in take.tolist()]
        if knots is not None:
            knots = [knots[k] for k in take.tolist()]
    step_v = _jerk_steps(sts)
    v_feed = np.array([st.v_feed for st in sts], float)
    core = _rows_core()
    if core is not None:
        A, feeds, t_pred, a2_pred, fine = _jerk_tail_core(core, S, V, acc, accel, step_v, v_feed)
    else:
        A, feeds, t_pred, a2_pred, fine = _jerk_tail(S, V, acc, accel, step_v, v_feed)
    if knots is None:
        m = len(t_pred)
        made = list(map(RowPlan, repeat(S, m), repeat(V, m), repeat(A, m), repeat(feeds, m), range(m), t_pred,
                        a2_pred))
        # settle_rows: the knots and speeds are rows of the float64 blocks S, V
        if type(A) is type(feeds) is np.ndarray and A.ndim == feeds.ndim == 2 and A.dtype is feeds.dtype is _F64:
            for plan, f in zip(made, fine):
                if f:
                    plan.fault = ""
    else:
        made = [SegmentPlan(sk, vk, a, f, t, a2) for (sk, vk), a, f, t, a2 in zip(knots, A, feeds, t_pred, a2_pred)]
        settle_rows(made, fine, A, feeds)
    return take.tolist(), made


def _jerk_steps(sts):
    """[jerk_step_v(st) for st in sts] as an array (the same min, max, product and quotient)."""
    lims = [st.lim for st in sts]
    jx = np.array([lim.jerk_x for lim in lims], float)
    jy = np.array([lim.jerk_y for lim in lims], float)
    ax = np.abs(np.array([st.ux for st in sts], float))
    ay = np.abs(np.array([st.uy for st in sts], float))
    mn = np.where(jy < jx, jy, jx)
    mx = np.where(ay > ax, ay, ax)
    if (mx == 0.0).any():
        return np.array([jerk_step_v(st) for st in sts], float)
    with np.errstate(all="ignore"):
        return 0.9 * mn / mx


def _min_edge_d_rows(rules, sts):
    """[rules.min_edge_d(st.ux, st.uy) for st in sts] as an array: for finite directions
    Python's max and np.maximum give the same float, and the division is the same; a
    stroke with a direction that is not finite takes min_edge_d itself."""
    if rules.min_move_d <= 0.0:
        return np.full(len(sts), MIN_EDGE_D)
    ax = np.abs(np.array([st.ux for st in sts], float))
    ay = np.abs(np.array([st.uy for st in sts], float))
    with np.errstate(all="ignore"):
        out = np.maximum(MIN_EDGE_D, (rules.min_move_d + ROUND_D) / np.maximum(np.maximum(ax, ay), 1e-12))
    odd = ~(np.isfinite(ax) & np.isfinite(ay))
    for k in np.flatnonzero(odd).tolist():
        out[k] = rules.min_edge_d(sts[k].ux, sts[k].uy)
    return out


def settle_faults(segs):
    """seg_fault's verdict "" kept on every SegmentPlan of `segs` (None and plans with a
    verdict skipped) that passes _fine_1d's checks, made on all of them at once in flat
    arrays (~27 k plans on the gyroid plate, ~10 µs each by _fine_1d); the others are
    left for seg_fault, which finds their reason.  The same verdicts: every check is
    elementwise (finite, > 0, >= 0, knots increasing inside each plan), each plan's
    sizes and figures are checked as _fine_1d checks them."""
    todo, ss, vs, as_, fs = [], [], [], [], []
    for seg in segs:
        if (type(seg) is not SegmentPlan and type(seg) is not RowPlan) or seg.fault is not None:
            continue
        s, v, a, f = seg.s, seg.v, seg.accel, seg.feed
        if not (type(s) is type(v) is type(a) is type(f) is np.ndarray and s.ndim == v.ndim == a.ndim == f.ndim == 1
                and s.dtype == _F64 and v.dtype == _F64 and a.dtype == _F64 and f.dtype == _F64):
            continue
        n = s.size
        if not (n >= 2 and a.size == n - 1 and f.size == n - 1 and math.isfinite(seg.time_t)
                and math.isfinite(seg.int_a2)):
            continue
        todo.append(seg)
        ss.append(s)
        vs.append(v)
        as_.append(a)
        fs.append(f)
    for a in range(0, len(todo), SETTLE_CHUNK):     # bounded memory: every check is per plan
        b = a + SETTLE_CHUNK
        _settle(todo[a:b], ss[a:b], vs[a:b], as_[a:b], fs[a:b])


def _keep_plans(plan, strokes, idx, segs, seg_failed):
    """The segment plans segs ({row: plan}) of the rows idx (an int array) put on the plan:
    a row whose segmenting failed (seg_failed: its reason), whose plan has a fault
    (seg_fault), has none, or does not beat its original (beats) is left as sliced with
    its reason; the others are put in plan.segs with their figures in t_pred and a2_pred.

    Row by row, the same as a loop over idx asking each row in turn (tests/
    test_speed26_linec_keep.py keeps that loop), made as a few passes over the rows'
    lists and arrays (~41 k rows a budget run on the rectilinear plate, three runs: the
    loop's ~1 µs a row was ~0.1 s of its planning): the faults in one list, beats on
    arrays (the same product and comparison of doubles), the kept rows put at once."""
    idx_l = idx.tolist()
    seg_l = list(map(segs.get, idx_l))
    settle_faults(seg_l)
    n = len(seg_l)
    why_l = None
    if not seg_failed:
        try:                    # every row a plan with a verdict slot (else AttributeError)
            why_l = list(map(_FAULT, seg_l))
        except AttributeError:
            pass
    if why_l is not None and why_l.count("") == n:
        # the common case: every row has a plan and every plan its verdict "" (settle_faults)
        bad_why = None
        a2 = np.fromiter(map(_INT_A2, seg_l), float, n)
    else:
        # seg_fault(seg): its verdict kept on the plan (settle_faults set it on most), else made
        if seg_failed:
            fail = seg_failed.get
            why_l = [fail(i) or ("" if seg is None else seg_fault(seg)) for i, seg in zip(idx_l, seg_l)]
        else:
            why_l = ["" if seg is None else f if (f := getattr(seg, "fault", None)) is not None else seg_fault(seg)
                     for seg in seg_l]
        # the figures of the fault-free plans only (the others' are not read: they may be anything)
        nan = math.nan
        a2 = np.array([nan if why or seg is None else seg.int_a2 for seg, why in zip(seg_l, why_l)], float)
        bad_why = np.fromiter(map(bool, why_l), bool, n)
    a2_orig = np.fromiter(map(_INT_A2, map(strokes.__getitem__, idx_l)), float, n)
    # beats(a2_plan, a2_orig) elementwise (the same product and comparison of doubles); a
    # plan that is None has a2 = nan: it does not beat
    keep = a2 < a2_orig * (1.0 - GAIN_TOL_R)
    if bad_why is not None:
        keep &= ~bad_why
        if bad_why.any():
            rows = idx[bad_why]
            plan.retime[rows] = False
            reason = plan.reason
            for i, why in zip(rows.tolist(), [why for why in why_l if why]):
                reason[i] = why
        lost = ~bad_why & ~keep
    else:
        lost = ~keep
    if lost.any():
        rows = idx[lost]
        plan.retime[rows] = False
        plan.reason[rows] = _NOT_BEATING
    if keep.all():
        put, put_l, kept, a2_kept = idx, idx_l, seg_l, a2
    else:
        k = np.flatnonzero(keep)
        put = idx[k]
        put_l, kept, a2_kept = put.tolist(), list(map(seg_l.__getitem__, k.tolist())), a2[k]
    if not kept:
        return
    deque(map(plan.segs.__setitem__, put_l, kept), maxlen=0)     # plan.segs[i] = seg, in C
    plan.t_pred[put] = np.fromiter(map(_TIME_T, kept), float, len(kept))
    plan.a2_pred[put] = a2_kept


def _attach_commands(plan, strokes, pin, rules, cmd0=None):   # (cmd0: the current signature; read per stroke here)
    """Every re-timed stroke whose start corners.py slowed by a junction command gets it
    (lines, curves and chains alike); one that cannot is left as sliced.  Only the
    strokes whose start corners.py slowed ask (_command_for: every other one has nothing
    to attach), found in one pass (none without --corners)."""
    segs = plan.segs
    for i in [i for i in np.flatnonzero(plan.retime).tolist() if strokes[i].corner_cmd0]:
        seg = segs[i]
        if seg is not None and not _command_for(seg, strokes[i], rules):
            _as_sliced(plan, pin, i, "no junction command for its slower corner")


def _keep_slowed_corners(plan, strokes, rules, cmd0=None):   # (cmd0: the current signature; read per stroke here)
    """A line stroke the planner leaves as sliced whose start corners.py slowed with a
    junction command keeps that corner: its own move is written behind the command
    (segments.slowed_original).  Its time counts in the budget like a re-timed stroke's;
    what the corner cost was priced in corners.py's share of the budget."""
    for i in np.flatnonzero(~plan.retime).tolist():
        st = strokes[i]
        if not st.corner_cmd0 or plan.reason[i] not in AS_SLICED or chains.plan_kind(st) != K_LINE:
            continue
        try:
            seg = slowed_original(st, rules)
        except Exception:                     # noqa: BLE001 -- the stroke stays as sliced
            seg = None
        if seg is None or seg_fault(seg) or not _command_for(seg, st, rules):
            continue
        plan.retime[i] = True
        plan.reason[i] = "retimed"
        plan.segs[i] = seg
        plan.T[i], plan.beta[i], plan.I_law[i] = seg.time_t, np.inf, seg.int_a2
        plan.t_pred[i], plan.a2_pred[i] = seg.time_t, seg.int_a2


class SegmentCacheOld:
    """Segment plans already made for a stroke at a given (T, beta): each re-plan of the
    budget changes the law of some strokes only, and only those are segmented again.

    Lines are planned one law at a time (every step of plan_segments is per stroke), so a
    line's plan is reused whenever its (T, beta) is the one it was made for.  Arcs and
    curves solve their laws in one batch, whose rounding may depend on the batch (~1e-16):
    their plans are reused only when the whole batch is the same, so that the result is
    always the one a fresh run would give.  Curves (ROW_KINDS) are reused row by row when
    their last batch is known to give each row its own bits (no circle solve went to
    Newton, no failure: laws/circle.NEWTON_ARCS; the BLAS gives rows their own bits:
    circle.rows_invariant); the gyroid plate's second budget run re-solved its ~3.5 k
    curves, all at the (T, beta) of the first.  Kept for the last run only.

    A line's entry is a row of two float arrays (T, beta; NaN: none) and of a list of
    plans, 24 bytes a stroke (a dict of tuples took ~210 on a plate of 48 k lines)."""

    def __init__(self):
        self.line_T = np.zeros(0)       # row -> the T its line plan was made for (NaN: none)
        self.line_beta = np.zeros(0)
        self.line_seg = []              # row -> that segment plan, or None
        self.line_why = {}              # row -> why segmenting it failed (failures only)
        self.batch = {}                 # kind -> (key, {row: seg}, {row: why})
        self.row_tb = {}                # kind -> {row: its (T, beta) bytes} when the batch is rows' own

    @staticmethod
    def _key(rows, T, beta):
        return rows.tobytes() + T[rows].tobytes() + beta[rows].tobytes()

    def _grow(self, n):
        k = len(self.line_seg)
        if n > k:
            self.line_T = np.concatenate([self.line_T, np.full(n - k, np.nan)])
            self.line_beta = np.concatenate([self.line_beta, np.full(n - k, np.nan)])
            self.line_seg += [None] * (n - k)

    def lookup_rows(self, kind, rows, T, beta):
        """{row: plan} of the rows whose plan the last batch of this kind made at their
        (T, beta), when that batch's plans are each row's own (store(own=True))."""
        tb = self.row_tb.get(kind)
        if not tb:
            return {}
        segs = self.batch[kind][1]
        got = {}
        for i in rows.tolist():
            k = tb.get(i)
            if k is not None and k == T[i].tobytes() + beta[i].tobytes() and i in segs:
                got[i] = segs[i]
        return got

    def lookup(self, kind, rows, T, beta):
        if KINDS[kind].batch:
            key, segs, bad = self.batch.get(kind, (None, {}, {}))
            return (segs, bad) if key == self._key(rows, T, beta) else ({}, {})
        got, bad = {}, {}
        rows_l = rows.tolist()
        if not rows_l:
            return got, bad
        self._grow(max(rows_l) + 1)
        hit = (self.line_T[rows] == T[rows]) & (self.line_beta[rows] == beta[rows])
        hit_l = rows[hit].tolist()
        seg = self.line_seg
        if not self.line_why:                 # no failure kept (the common case): the hits' plans
            return dict(zip(hit_l, [seg[i] for i in hit_l])), bad
        for i in hit_l:
            why = self.line_why.get(i)
            if why:
                bad[i] = why
            else:
                got[i] = seg[i]
        return got, bad

    def drop(self, kind):
        """Forget the last batch of a batch kind (its plans are not this run's): it would
        otherwise live beside the batch being made (store replaces it only after).  A
        later batch equal to it is solved again, with the same bits."""
        self.batch.pop(kind, None)
        self.row_tb.pop(kind, None)

    def store(self, kind, rows, T, beta, segs, bad, own=False):
        """own: every plan of this batch is its row's own, whatever the batch (ROW_KINDS: no
        Newton step in the circle solves, no failure, a BLAS whose rows are invariant);
        lookup_rows then reuses them row by row."""
        if KINDS[kind].batch:
            if rows.size:
                self.batch[kind] = (self._key(rows, T, beta), segs, bad)
                self.row_tb[kind] = ({i: T[i].tobytes() + beta[i].tobytes() for i in rows.tolist()}
                                     if own else None)
            return
        rows_l = rows.tolist()
        if not rows_l:
            return
        self._grow(max(rows_l) + 1)
        self.line_T[rows] = T[rows]
        self.line_beta[rows] = beta[rows]
        seg, get = self.line_seg, segs.get
        for i in rows_l:
            seg[i] = get(i)
        if self.line_why or bad:              # failures: a row's reason set, or dropped
            why_of = self.line_why
            for i in rows_l:
                why = bad.get(i, "")
                if why:
                    why_of[i] = why
                else:
                    why_of.pop(i, None)

    def forget_lines(self, rows):
        """The line plans of rows (an int array) about to be made again at another (T, beta),
        freed before the new ones are made: a budget run otherwise held both (rectilinear
        plate's second run: ~30 k plans, ~30 MB, beside their replacements).  A later run back
        at an old (T, beta) makes that plan again, with the same bits (a line's plan is its
        row's own)."""
        n = len(self.line_seg)
        rows_l = [i for i in rows.tolist() if i < n]
        if not rows_l:
            return
        self.line_T[rows_l] = self.line_beta[rows_l] = np.nan
        seg = self.line_seg
        for i in rows_l:
            seg[i] = None
        if self.line_why:
            for i in rows_l:
                self.line_why.pop(i, None)

    def forget_line(self, i):
        """Stroke i's line plan is no longer the one its (T, beta) gives (a lead-out changed)."""
        self.forget_lines(np.array([i]))


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
        assert SC.seg_fault(g) == SC.seg_fault(w)
    return made


def _line_laws(path, profile, corners=0.0, every=3):
    """Line strokes of a file at several of their candidate laws each (T, beta)."""
    prof = load_profile(profile)
    opts = Options()
    opts.corner_budget_r = corners
    strokes, _ = analyse(path, prof, opts)
    pin = SC.plan_inputs(strokes, prof, opts)
    rows = np.array([i for i in SC._rows_by_kind(strokes)[K_LINE] if not pin.fault[i]], int)
    T, beta, _, _ = plan_mod.candidates_auto(pin.take(rows))
    sts, Ts, bs = [], [], []
    for col in range(0, T.shape[1], every):
        ok = np.isfinite(T[:, col])
        sts += [strokes[i] for i in rows[ok]]
        Ts.append(T[ok, col])
        bs.append(beta[ok, col])
    return sts, np.concatenate(Ts), np.concatenate(bs), SegmentRules.for_profile(prof, opts.max_segments)


CASES = [
    (S + "prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 0.0),    # classic jerk: the rows' path
    (S + "prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 0.3),    # slowed ends and commands: per stroke
    (S + "prusa_gyroid.gcode", "bambu-x1c", 0.05),
    (S + "prusa_mk3s_rectilinear.gcode", "voron24", 0.0),        # Klipper: every stroke per stroke
]


@pytest.mark.parametrize("core", [True, False])         # the compiled tail, the numpy one
@pytest.mark.parametrize("path,profile,corners", CASES)
def test_plan_segments_same_as_da0e9ec(path, profile, corners, core, monkeypatch):
    if profile != "prusa-mk3s" and not core:
        pytest.skip("no rows' tail under this junction law")
    monkeypatch.setattr(SEG, "USE_CORE", core)
    sts, T, beta, rules = _line_laws(path, profile, corners, every=3 if profile == "prusa-mk3s" else 7)
    assert len(sts) > 200
    assert _same_plans(SEG.plan_segments(sts, T, beta, rules), plan_segments(sts, T, beta, rules)) > 100


@pytest.mark.skipif(not os.path.exists(PLATE), reason="corpus not downloaded")
def test_plate_slice_same_as_da0e9ec():
    sts, T, beta, rules = _line_laws(PLATE, "prusa-mk3s", every=11)
    sts, T, beta = sts[:6000], T[:6000], beta[:6000]
    assert _same_plans(SEG.plan_segments(sts, T, beta, rules), plan_segments(sts, T, beta, rules)) > 2500


def test_move_counts():
    sts, _, _, _ = _line_laws(S + "prusa_gyroid.gcode", "prusa-mk3s", every=50)
    assert type(sts[0]) is Stroke
    sts = sts[:50]
    for k in range(0, 50, 3):                    # strokes of several moves (copies)
        sts[k] = copy.copy(sts[k])
        sts[k].last_idx = sts[k].first_idx + k % 4
    want = [st.n_moves for st in sts]
    got = SEG._move_counts(sts)
    assert got == want and all(type(x) is int for x in got) and max(got) > 1

    class Odd:                                   # not a Stroke: its own n_moves
        def __init__(self, k):
            self.n_moves, self.first_idx, self.last_idx = k, 0, 99
    assert SEG._move_counts([Odd(3), Odd(1)]) == [3, 1]
    assert SEG._move_counts(sts[:3] + [Odd(7)]) == want[:3] + [7]


class _Line:
    """What law_knots reads of a stroke; n_moves > 1: collinear moves (interior vertices)."""
    def __init__(self, L, v0, v1, ends):
        self.length_d, self.v0, self.v1, self.ends_d = L, v0, v1, list(ends)
        self.n_moves = len(self.ends_d)


def test_law_knots_with_fields_same_as_da0e9ec():
    """law_knots given the strokes' (L, v0, v1) arrays (plan_segments reads them once)."""
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
    fields = tuple(np.array([getattr(st, f) for st in sts], float) for f in ("length_d", "v0", "v1"))
    with np.errstate(all="ignore"):
        want = law_knots(sts, T, beta, n)
        got = SEG.law_knots(sts, T, beta, n, fields=fields)
    assert len(got) == len(want) and sum(st.n_moves > 1 for st in sts) > 300
    for (s, v), (s0, v0) in zip(got, want):
        for x, y in ((s, s0), (v, v0)):
            assert _arr_same(x, y)


# ---------------------------------------------------------------- settle_faults and _keep_plans
def _odd_plans(rng):
    """RowPlans and SegmentPlans of many shapes, some with bad numbers, no verdicts."""
    plans = []
    for m, K in ((40, 6), (25, 2), (30, 11), (3, 1)):
        S_ = np.cumsum(rng.uniform(0.01, 1.0, (m, K)), axis=1)
        V = rng.uniform(0.0, 50.0, (m, K))
        A = rng.uniform(1.0, 3000.0, (m, K - 1)) if K > 1 else np.zeros((m, 0))
        F = rng.uniform(1.0, 80.0, (m, K - 1)) if K > 1 else np.zeros((m, 0))
        for r in range(0, m, 4):                 # bad entries here and there
            k = int(rng.integers(0, K))
            X, bad = [(S_, np.nan), (S_, -1.0), (V, -0.5), (V, np.inf), (A, 0.0), (A, np.nan), (F, -0.0),
                      (F, np.inf), (S_, 0.0)][r % 9]
            X[r, min(k, X.shape[1] - 1)] = bad if X.shape[1] else 0.0
        V[::3, 0] = 0.0                          # stops: fine
        if K > 2:
            S_[5::13, 2] = S_[5::13, 1]          # a knot repeated: not increasing
        t = rng.uniform(0.01, 1.0, m)
        t[5 % m] = np.nan
        for r in range(m):
            row = np.int64(r) if r % 7 == 3 else r          # a numpy row: the per-plan way
            plans.append(RowPlan(S_, V, A, F, row, float(t[r]), float(rng.uniform(0, 9)) if r % 11 else math.inf))
    S3 = rng.uniform(0, 1, (4, 3, 3))                # blocks of other shapes and types: the per-plan way
    plans += [RowPlan(S3, S3, S3, S3, r, 0.1, 0.2) for r in range(4)]
    Si = np.arange(12).reshape(3, 4)
    plans += [RowPlan(Si, Si, Si[:, 1:], Si[:, 1:], r, 0.1, 0.2) for r in range(3)]
    Sf = np.sort(rng.uniform(0, 1, (5, 4)), axis=1)
    plans += [RowPlan(Sf, Sf, Sf[:, 1:], Sf, r, 0.1, 0.2) for r in range(5)]            # F of another shape
    plans += [RowPlan(Sf, Sf + 1, Sf[:, 1:] + 1, Sf[:, 1:] + 1, r, 0.1, 0.2) for r in range(5)]  # all fine
    made = plans[-1]
    made.v = made.v.copy()                            # made its own arrays
    for k in range(30):
        s = np.cumsum(rng.uniform(0.01, 1.0, 5))
        a = rng.uniform(0.0 if k % 5 == 0 else 1.0, 9.0, 4)
        plans.append(SegmentPlan(s, rng.uniform(0, 9, 5), a, rng.uniform(1, 9, 4), 0.1, 0.3))
    plans += [None, "not a plan"]
    return plans


def _verdicts(plans):
    return [None if not isinstance(p, SegmentPlan) else p.fault for p in plans]


def test_settle_faults_same_verdicts_as_da0e9ec(monkeypatch):
    monkeypatch.setattr(SC, "SETTLE_CHUNK", 7)      # several chunks a block
    got_plans, want_plans = _odd_plans(np.random.default_rng(3)), _odd_plans(np.random.default_rng(3))
    SC.settle_faults(got_plans)
    settle_faults(want_plans)
    got, want = _verdicts(got_plans), _verdicts(want_plans)
    assert got == want
    assert got.count("") > 60 and got.count(None) > 40        # both verdicts, many of each
    # the plans left without one get seg_fault's reason, the same
    assert [SC.seg_fault(p) if isinstance(p, SegmentPlan) else None for p in got_plans] == \
        [SC.seg_fault(p) if isinstance(p, SegmentPlan) else None for p in want_plans]


def _plan_of(n, rng):
    p = plan_mod.Plan(n)
    p.retime[:] = True
    p.segs = [None] * n
    p.t_pred, p.a2_pred = rng.uniform(0, 1, n), rng.uniform(0, 1, n)
    return p


class _St:
    def __init__(self, a2):
        self.int_a2 = a2


def test_keep_plans_same_as_da0e9ec():
    for seed in range(4):
        rows = []
        for mk in (_odd_plans, _odd_plans):
            rng = np.random.default_rng(seed)
            plans = mk(rng)
            plans = [p for p in plans if p is None or isinstance(p, SegmentPlan)]
            if seed == 1:
                plans = [p for p in plans if p is not None]
            n = len(plans) + 5
            idx = np.arange(2, 2 + len(plans))
            strokes = [_St(float(x)) for x in rng.uniform(0.0, 12.0, n)]
            segs = {int(i): p for i, p in zip(idx, plans)}
            failed = {int(idx[3]): "error: segments (boom)"} if seed == 2 else {}
            for i in failed:
                segs.pop(i)
            if seed == 3:                          # every plan with a verdict already
                SC.settle_faults(plans)
                for p in plans:
                    if p is not None and p.fault is None:
                        p.fault = SC.seg_fault(p)
            rows.append((_plan_of(n, np.random.default_rng(seed)), strokes, idx, segs, failed))
        (pg, *a), (pw, *b) = rows
        SC._keep_plans(pg, a[0], a[1], list(map(a[2].get, a[1].tolist())), a[3])    # (its plans by idx)
        _keep_plans(pw, *b)
        assert pg.retime.tolist() == pw.retime.tolist() and pg.reason.tolist() == pw.reason.tolist()
        assert pg.t_pred.tobytes() == pw.t_pred.tobytes() and pg.a2_pred.tobytes() == pw.a2_pred.tobytes()
        assert [None if s is None else (s.s.tobytes(), s.fault) for s in pg.segs] == \
            [None if s is None else (s.s.tobytes(), s.fault) for s in pw.segs]
        assert sum(s is not None for s in pg.segs) > 10 and (~pg.retime).sum() > 10


# ---------------------------------------------------------------- the pure-Python strokes
def test_pure_python_same_as_da0e9ec():
    """GCODE_OPT_PURE_PYTHON=1 (plain slotted strokes, no compiled tail) in a child: the
    same plans as da0e9ec's code."""
    code = ("import sys; sys.path.insert(0, %r); import test_speed28_seg_fields as t, gcode_opt.strokes as s\n"
            "assert s._BASE is None and t.SEG._rows_core() is None\n"
            "t.SEG.JERK_CORNERS = False\n"
            "sts, T, b, r = t._line_laws(t.S + 'prusa_mk3s_rectilinear.gcode', 'prusa-mk3s', every=5)\n"
            "assert t._same_plans(t.SEG.plan_segments(sts, T, b, r), t.plan_segments(sts, T, b, r)) > 100\n"
            "print('ok')\n") % HERE
    env = dict(os.environ, GCODE_OPT_PURE_PYTHON="1")
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, cwd=os.path.dirname(HERE))
    assert r.returncode == 0 and r.stdout.strip() == "ok", r.stderr[-3000:]


# ---------------------------------------------------------------- whole budget runs
def test_tb_keys():
    T = np.array([0.0, 1.0, -0.0, 2.5, np.nan, 3.0])
    beta = np.array([0.0, np.inf, 1.0, 0.0, 2.0, -0.0])
    rows = np.array([5, 0, 2, 3, 1, 4])
    assert SC._tb_keys(rows, T, beta) == [T[i].tobytes() + beta[i].tobytes() for i in rows.tolist()]
    assert SC._tb_keys(np.array([], int), T, beta) == []
    Ti = np.arange(6)                                          # not float64: each row's own bytes
    assert SC._tb_keys(rows, Ti, beta) == [Ti[i].tobytes() + beta[i].tobytes() for i in rows.tolist()]


class _SegmentCacheOldOfList(SegmentCacheOld):
    """da0e9ec's SegmentCache stored to as the run stores now (its plans as a list by row)."""

    def store(self, kind, rows, T, beta, segs, bad, own=False):
        made = {i: segs[i] for i in rows.tolist() if i not in bad}
        super().store(kind, rows, T, beta, made, bad, own)


def _keep_plans_of_list(plan, strokes, idx, seg_l, seg_failed, idx_l=None, a2_orig=None, in_place=False):
    """da0e9ec's _keep_plans called as the run calls it now (its plans as a list by idx;
    in_place: they are in plan.segs already, where it put the kept ones on rows of None)."""
    if in_place:
        for i in idx.tolist():
            plan.segs[i] = None
    _keep_plans(plan, strokes, idx, dict(zip(idx.tolist(), seg_l)), seg_failed)


def _plan_figures(p):
    segs = [None if s is None else (type(s).__name__, s.s.tobytes(), s.v.tobytes(), s.accel.tobytes(),
                                    s.feed.tobytes(), s.time_t, s.int_a2, s.first_cmds, SC.seg_fault(s))
            for s in p.segs]
    return (p.retime.tobytes(), p.reason.tolist(), p.T.tobytes(), p.beta.tobytes(), p.t_pred.tobytes(),
            p.a2_pred.tobytes(), segs, hasattr(p, "cmd0"))


def _budget_runs(name, prof, corners, monkeypatch, old, budgets=(1.0, 0.6, 0.61, 1.3, 1.0)):
    monkeypatch.setattr(SEG, "JERK_CORNERS", False)   # (the undo() below takes the fixture's off too)
    if old:
        for k, f in (("_keep_plans", _keep_plans_of_list), ("settle_faults", settle_faults),
                     ("_attach_commands", _attach_commands), ("_keep_slowed_corners", _keep_slowed_corners),
                     ("SegmentCache", _SegmentCacheOldOfList)):
            monkeypatch.setattr(SC, k, f)
        monkeypatch.setattr(SC, "plan_segments", plan_segments)
    profile = load_profile(prof)
    opts = Options(corner_budget_r=corners)
    opts.ringing = False
    strokes, sim0 = analyse(os.path.join(S, name), profile, opts)
    pin = SC.plan_inputs(strokes, profile, opts)
    runs = []

    def fit(run, pin_, budget_t):
        for r in budgets:
            p = run(r * budget_t)
            runs.append(_plan_figures(p))
        return p
    monkeypatch.setattr(SC, "_fit_budget", fit)
    SC.plan_strokes(strokes, pin, profile, opts, opts.max_slowdown_r * sim0.time_t)
    monkeypatch.undo()
    return runs, sum(bool(s.corner_cmd0) for s in strokes)


@pytest.mark.parametrize("name,prof,corners", [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 0.3),
                                               ("prusa_gyroid_fullspeed.gcode", "prusa-mk3s", 0.0),
                                               ("prusa_gyroid_fullspeed_klipper.gcode", "voron24", 0.3)])
def test_budget_runs_same_as_da0e9ec(name, prof, corners, monkeypatch):
    """Budget runs (back and forth: the caches' reuse and forgetting) with da0e9ec's
    plan_segments, settle_faults, _keep_plans, corner passes and SegmentCache, and with
    this version's: the same plans, figures and reasons, run by run."""
    old, n_old = _budget_runs(name, prof, corners, monkeypatch, True)
    new, n_new = _budget_runs(name, prof, corners, monkeypatch, False)
    assert n_new == n_old and (n_new > 0) == (corners > 0)      # the commands' path is taken
    assert len(old) == len(new) == 5
    for a, b in zip(old, new):
        assert a == b
    assert sum(s is not None for s in new[0][6]) > 100


@pytest.fixture(autouse=True)
def _no_jerk_corners(monkeypatch):
    """The plans pinned here are those of the code before segments' classic-jerk corner step
    (session 29, segments.JERK_CORNERS): off here.  tests/test_speed29_jerkentry_corners.py
    checks that step, and that plan_segments with it is these plans with their ends cut."""
    monkeypatch.setattr(SEG, "JERK_CORNERS", False)
