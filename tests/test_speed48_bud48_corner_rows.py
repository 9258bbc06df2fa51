"""segments._keep_corner_rows (session 48): jerk_keep_corner of the rows whose one end fires,
in arrays.  The reference is the loop it replaced in _jerk_corner_rows (verbatim below):
jerk_keep_corner stroke by stroke.  Same bits: every plan's four arrays and figures, and
the same rows cut (None where jerk_keep_corner cuts nothing)."""
import math
import random

import numpy as np
import pytest

from gcode_opt import segments


class _St:
    """The fields of a line stroke the cut reads (v_feed, direction, accel, lim)."""

    def __init__(self, ux, uy, v_feed, accel, ax_max, ay_max):
        self.ux, self.uy, self.v_feed, self.accel = ux, uy, v_feed, accel

        class _L:
            pass
        self.lim = _L()
        self.lim.ax_max, self.lim.ay_max = ax_max, ay_max


def _old_rows(sts, S, V, A, F, fire0, fire1, step_v, rules):
    """The loop of _jerk_corner_rows before session 48 (verbatim, fires given)."""
    out = {}
    for k in np.flatnonzero(fire0 | fire1).tolist():
        got = segments.jerk_keep_corner(sts[k], S[k], V[k], A[k], F[k], fire0[k], fire1[k], step_v[k], rules)
        if got is not None:
            out[k] = got
    return out


def _case(rng, m, K):
    """m strokes of K knots: ramps whose ends cross the slicer's feed or not, short and long
    end segments, lifted end F near and beyond a jerk step, an accel top that refuses some
    steeper ramps, a NaN here and there."""
    sts, S, V = [], np.empty((m, K)), np.empty((m, K))
    for q in range(m):
        a = rng.uniform(-math.pi, math.pi)
        ux, uy = math.cos(a), math.sin(a)
        if rng.random() < 0.1:
            ux, uy = 1.0, 0.0
        vf = rng.choice([20.0, 35.0, 60.0])
        sts.append(_St(ux, uy, vf, rng.choice([800.0, 1250.0]), rng.choice([1000.0, 4000.0, 100.0]),
                       rng.choice([1000.0, 4000.0])))
        d = np.array([rng.choice([rng.uniform(0.01, 0.2), rng.uniform(0.2, 3.0)]) for _ in range(K - 1)])
        S[q, 0] = 0.0
        S[q, 1:] = np.cumsum(d)
        V[q] = [rng.uniform(0.5, 1.6) * vf for _ in range(K)]
        for end in (0, -1):
            r = rng.random()
            if r < 0.15:
                V[q, end] = vf                 # the corner at the slicer's F: the short branch
            elif r < 0.3:
                V[q, end] = rng.uniform(0.3, 0.99) * vf
        if rng.random() < 0.03:
            V[q, rng.randrange(K)] = np.nan
    v2 = V * V
    with np.errstate(all="ignore"):
        A = np.abs(v2[:, 1:] - v2[:, :-1]) / (2.0 * (S[:, 1:] - S[:, :-1]))
    vfa = np.array([st.v_feed for st in sts])
    F = np.maximum(np.maximum(V[:, :-1], V[:, 1:]), vfa[:, None]) * np.array(
        [rng.choice([1.0, 1.01, 1.2]) for _ in range(m)])[:, None]
    step_v = np.array([rng.choice([4.0, 8.0, np.inf]) for _ in range(m)])
    return sts, S, V, A, F, vfa, step_v


@pytest.mark.parametrize("min_move_d", [0.0, 0.06])
@pytest.mark.parametrize("K", [2, 3, 4, 11])
def test_rows_are_the_strokes_own_cuts(K, min_move_d):
    rng = random.Random(48 + K)
    rules = segments.SegmentRules("jerk", 20, 0.004, 0.3, min_move_d)
    sts, S, V, A, F, vf, step_v = _case(rng, 400, K)
    ux = np.array([st.ux for st in sts])
    uy = np.array([st.uy for st in sts])
    fires = np.array([rng.random() < 0.5 for _ in sts]), np.array([rng.random() < 0.5 for _ in sts])
    cut = 0
    for end in (0, 1):
        k = np.flatnonzero(fires[end])
        f0, f1 = np.zeros(len(sts), bool), np.zeros(len(sts), bool)
        (f0 if end == 0 else f1)[k] = True
        with np.errstate(all="ignore"):
            want = _old_rows(sts, S, V, A, F, f0, f1, step_v, rules)
            got = segments._keep_corner_rows([sts[q] for q in k.tolist()], k, end, S[k], V[k], A[k], F[k],
                                             vf[k], step_v[k], ux[k], uy[k], rules)
        assert sorted(got) == sorted(want)
        for r, w in want.items():
            g = got[r]
            assert type(g) is segments.SegmentPlan
            for f in ("s", "v", "accel", "feed"):
                a, b = np.asarray(getattr(g, f)), np.asarray(getattr(w, f))
                assert a.shape == b.shape and a.tobytes() == b.tobytes(), (r, f)
            assert (type(g.time_t), type(g.int_a2)) == (type(w.time_t), type(w.int_a2))
            assert np.float64(g.time_t).tobytes() == np.float64(w.time_t).tobytes()
            assert np.float64(g.int_a2).tobytes() == np.float64(w.int_a2).tobytes()
        cut += len(want)
    assert cut >= 20                  # the case cuts (and refuses: fewer than the rows fired)


def test_both_ends_stroke_by_stroke():
    """_jerk_corner_rows: rows whose two ends fire go through jerk_keep_corner (both cuts)."""
    rng = random.Random(7)
    rules = segments.SegmentRules("jerk", 20, 0.004, 0.3, 0.06)
    sts, S, V, A, F, vf, step_v = _case(rng, 300, 6)
    ux = np.array([st.ux for st in sts])
    uy = np.array([st.uy for st in sts])
    fire0 = np.array([rng.random() < 0.6 for _ in sts])
    fire1 = np.array([rng.random() < 0.6 for _ in sts])
    fires = segments.jerk_corner_fires
    try:
        segments.jerk_corner_fires = lambda *a: (fire0, fire1)
        with np.errstate(all="ignore"):
            got = segments._jerk_corner_rows(sts, S, V, A, F, vf, step_v, ux, uy, rules)
            want = _old_rows(sts, S, V, A, F, fire0, fire1, step_v, rules)
    finally:
        segments.jerk_corner_fires = fires
    assert sorted(got) == sorted(want) and any(fire0[r] and fire1[r] for r in want)
    for r, w in want.items():
        for f in ("s", "v", "accel", "feed"):
            assert np.asarray(getattr(got[r], f)).tobytes() == np.asarray(getattr(w, f)).tobytes()
        for f in ("time_t", "int_a2"):
            assert np.float64(getattr(got[r], f)).tobytes() == np.float64(getattr(w, f)).tobytes()
