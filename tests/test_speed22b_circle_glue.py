"""Issue 8, s22 (circle): cheaper glue around the curve candidates' circle law.

curves.candidates_curve reads each stroke's κ_eff once (not once per candidate and pass),
and _kappa_rows takes a geometry's knots (s_v, kappa_v) once
per geometry for the probe and the figures of both passes (a memo the caller keeps).

The candidate tables must be the same bits as 7712ddd's, whose code is copied below
(verbatim, module names qualified)."""
import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt import plan as plan_mod
from gcode_opt import schedule as sc
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_CURVE

S = "sample_gcode/"


# ---------------------------------------------------------------- 7712ddd's forms
def _ref_kappa_rows(geos, s):
    out = np.empty_like(s)
    n = len(geos)
    a = 0
    while a < n:
        g = geos[a]
        b = a + 1
        while b < n and geos[b] is g:
            b += 1
        out[a:b] = curves._interp(s[a:b].ravel(), g.s_v, g.kappa_v, None, None).reshape(b - a, -1)
        a = b
    return out


def _ref_true_figures(law, R, geos, idx=None):
    if idx is None:
        out = np.empty((5, len(geos)))
        for sl, tau, wq in law.grid_chunks():
            out[:, sl] = _ref_true_figures_rows(law.rows(sl), R[sl], geos[sl], tau, wq)
        return tuple(out)
    out = np.full((5, len(geos)), np.nan)
    for r, tau, wq in law.grid_chunks(idx):
        out[:, r] = _ref_true_figures_rows(law.take(r), R[r], [geos[i] for i in r.tolist()], tau, wq)
    return tuple(out)


def _ref_surely_over(law, R, geos, v_lim, a_lim):
    over = np.zeros(len(geos), bool)
    for sl in law.row_chunks():
        sub = law.rows(sl)
        phi, w, w1, _ = sub.eval_tau(np.broadcast_to(curves._PROBE_TAU[None, :], (len(sub), curves._PROBE_TAU.size)),
                                     w2=False)
        T = sub.T_t[:, None]
        Rr = R[sl, None]
        v = Rr * w / T
        at = Rr * w1 / T ** 2
        kv2 = _ref_kappa_rows(geos[sl], Rr * phi) * (v * v)
        a2 = at * at + kv2 * kv2
        over[sl] = ((np.max(v, axis=1) > v_lim[sl] * (1.0 + curves.PROBE_MARGIN_R))
                    | (np.sqrt(np.max(a2, axis=1)) > a_lim[sl] * (1.0 + curves.PROBE_MARGIN_R)))
    return over


def _ref_true_figures_rows(law, R, geos, tau, wq):
    m = tau.shape[1]
    tu = np.broadcast_to(curves._UNIFORM_TAU[None, :], (len(geos), curves._UNIFORM_TAU.size))
    phi, w, w1, _ = law.eval_tau(np.concatenate([tau, tu], axis=1), w2=False)
    T = law.T_t[:, None]
    s = R[:, None] * phi
    v = R[:, None] * w / T
    at = R[:, None] * w1 / T ** 2
    kap = _ref_kappa_rows(geos, s)
    v2 = v * v
    kv2 = kap * v2
    a2 = at * at + kv2 * kv2
    iv = law.T_t * np.sum(wq * v2[:, :m], axis=1)
    ia = law.T_t * np.sum(wq * a2[:, :m], axis=1)
    ia = ia + np.array([g.end_terms(a, b) for g, a, b in zip(geos, R * law.w0, R * law.w1)])
    return iv, ia, np.max(v, axis=1), np.sqrt(np.max(a2, axis=1)), np.min(v, axis=1)


def _ref_solve(strokes, rows_geo, S, T, beta, v0, v1):
    R = 1.0 / np.array([g.kappa_eff for g in rows_geo])
    return curves.solve_circles(S / R, T, beta, v0 / R, v1 / R, R), R


def _ref_candidates_curve(pin, rows, strokes, profile):
    rows = np.asarray(rows, int)
    k = len(curves.CURVE_COLS)
    geos = [g for i in rows for g in [curves.geom(strokes[i], profile)] * k]
    S, v0, v1, vc, ac = (np.repeat(x[rows], k) for x in (pin.L, pin.v0, pin.v1, pin.v_cap, pin.a_cap))

    def solve_figures(idx, T, beta):
        gs = [geos[q] for q in idx]
        law, R = _ref_solve(None, gs, S[idx], T, beta, v0[idx], v1[idx])
        v_lim, a_lim = vc[idx] * (1 + plan_mod.SPEED_TOL_R), ac[idx] * (1 + plan_mod.SPEED_TOL_R)
        iv, ia, pv, pa, mv = _ref_true_figures(law, R, gs, np.flatnonzero(~_ref_surely_over(law, R, gs, v_lim, a_lim)))
        ok = (pv <= v_lim) & (pa <= a_lim) & (mv >= -1e-9 * (1 + vc[idx]))
        return iv, ia, ok

    return plan_mod.candidate_table(pin, rows, curves.CURVE_COLS, solve_figures, curves.GAMMA_MIN)


# ---------------------------------------------------------------- real curve strokes
_CACHE = {}


def _curves_of(name, profile):
    key = (name, profile)
    if key not in _CACHE:
        prof = load_profile(profile)
        opts = Options()
        strokes, _ = analyse(S + name, prof, opts)
        pin = sc.plan_inputs(strokes, prof, opts)
        rows = np.array([i for i in sc._rows_by_kind(strokes)[K_CURVE] if not pin.fault[i]], int)
        _CACHE[key] = (strokes, pin, rows, prof)
    return _CACHE[key]


def _bits(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


FILES = [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_gyroid.gcode", "voron24"),
         ("prusa_gyroid_fullspeed.gcode", "prusa-mk3s"), ("prusa_concentric.gcode", "prusa-mk3s")]


@pytest.mark.parametrize("name,profile", FILES)
def test_curve_candidates_same_bits(name, profile):
    strokes, pin, rows, prof = _curves_of(name, profile)
    assert rows.size > 20
    got = curves.candidates_curve(pin, rows, strokes, prof)
    want = _ref_candidates_curve(pin, rows, strokes, prof)
    assert len(got) == len(want)
    for g, w in zip(got, want):
        assert _bits(g, w)


def test_no_curves():
    strokes, pin, rows, prof = _curves_of(*FILES[0])
    got = curves.candidates_curve(pin, rows[:0], strokes, prof)
    want = _ref_candidates_curve(pin, rows[:0], strokes, prof)
    for g, w in zip(got, want):
        assert _bits(g, w)


@pytest.mark.parametrize("name,profile", FILES[:2])
def test_kappa_rows_real_geometries_same_bits(name, profile):
    """On real geometries, runs of rows, with and without a memo shared across calls."""
    strokes, pin, rows, prof = _curves_of(name, profile)
    rng = np.random.default_rng(7)
    gs = [curves.geom(strokes[i], prof) for i in rows.tolist()]
    memo = {}
    for trial in range(3):
        pick = rng.integers(0, len(gs), 60)
        geos = [gs[j] for j in pick.tolist() for _ in range(int(rng.integers(1, 6)))]
        top = np.array([g.s_v[-1] for g in geos])
        s = rng.uniform(-0.1, 1.1, (len(geos), 41)) * top[:, None]
        s[:, 0] = 0.0
        s[:, 1] = top                                  # the knots' ends exactly
        want = _ref_kappa_rows(geos, s)
        assert _bits(curves._kappa_rows(geos, s), want)
        assert _bits(curves._kappa_rows(geos, s, memo), want)
    assert memo


def test_kappa_rows_knots_are_the_properties():
    """The knots _kappa_rows makes are CurveGeom.s_v / kappa_v, bit for bit."""
    strokes, pin, rows, prof = _curves_of(*FILES[0])
    for i in rows.tolist()[:200]:
        g = curves.geom(strokes[i], prof)
        memo = {}
        curves._kappa_rows([g], np.zeros((1, 3)), memo)
        s_v, kv = memo[id(g)]
        assert _bits(s_v, g.s_v) and _bits(kv, g.kappa_v)


# ---------------------------------------------------------------- the compiled interpolation
needs_core = pytest.mark.skipif(curves._INTERP_ROWS is None, reason="curve core not built")


class _FakeGeom:
    """A geometry of given knots (for the rows the core does not take: np.interp)."""
    def __init__(self, s_v, kappa_v):
        self.s_v, self.kappa_v = s_v, kappa_v


def _knots_of(pairs):
    xs = np.concatenate([p[0] for p in pairs])
    ys = np.concatenate([p[1] for p in pairs])
    cnt = np.array([p[0].size for p in pairs], dtype=np.int64)
    off = np.concatenate([[0], np.cumsum(cnt)[:-1]]).astype(np.int64)
    ok = np.array([p[0].size >= 2 and np.isfinite(p[0]).all() and (np.diff(p[0]) > 0).all() for p in pairs])
    return curves._Knots(xs, ys, off, cnt, ok)


@needs_core
def test_interp_rows_is_np_interp_bit_for_bit():
    """Random knots, points below, above, at every knot, between, NaN; values with inf and
    NaN (numpy's fallbacks); rows the core does not take (repeated, NaN knots)."""
    rng = np.random.default_rng(11)
    pairs = []
    for t in range(300):
        n = int(rng.integers(2, 40))
        x = np.cumsum(rng.uniform(1e-9 if t % 7 == 0 else 0.01, 1.0, n)) - rng.uniform(0, 3)
        y = rng.normal(0, 1, n)
        if t % 11 == 0:
            y[int(rng.integers(0, n))] = np.inf
        if t % 13 == 0:
            y[int(rng.integers(0, n))] = np.nan
        if t % 23 == 1 and n > 2:
            y[1] = y[2] = np.inf             # slope NaN both ways: numpy's last fallback
        if t % 17 == 0 and n > 2:
            x[1] = x[2]                      # repeated knot: np.interp's own path
        if t % 19 == 0:
            x[0] = np.nan
        pairs.append((x, y))
    m = 64
    s = np.empty((len(pairs), m))
    for r, (x, _) in enumerate(pairs):
        lo, hi = np.nanmin(x), np.nanmax(x)
        s[r] = rng.uniform(lo - 0.5, hi + 0.5, m)
        s[r, :min(m // 2, x.size)] = x[:min(m // 2, x.size)]          # exactly at knots
        s[r, -1], s[r, -2] = np.nan, hi
        if x.size > 2:
            s[r, -3] = 0.5 * (x[1] + x[2])
    kn = _knots_of(pairs)
    assert not kn.ok.all() and kn.ok.any()
    geos = [_FakeGeom(x, y) for x, y in pairs]
    got = curves._kappa_rows(geos, s, kn)
    want = np.array([np.interp(s[r], x, y) for r, (x, y) in enumerate(pairs)])
    assert _bits(got, want)
    # a row subset (as surely_over's and true_figures' chunks take them)
    sel = np.array([5, 3, 3, 250, 0])
    got = curves._kappa_rows([geos[i] for i in sel], s[sel], kn.sub(sel))
    assert _bits(got, want[sel])


@needs_core
def test_knots_of_real_geometries_same_bits():
    strokes, pin, rows, prof = _curves_of(*FILES[0])
    gs = [curves.geom(strokes[i], prof) for i in rows.tolist()]
    kn = curves._Knots.of(gs)
    assert kn.ok.all()
    rng = np.random.default_rng(3)
    top = np.array([g.s_v[-1] for g in gs])
    s = rng.uniform(-0.1, 1.1, (len(gs), 33)) * top[:, None]
    s[:, 0], s[:, 1] = 0.0, top
    assert _bits(curves._kappa_rows(gs, s, kn), _ref_kappa_rows(gs, s))
    bad = curves._Knots.of([_FakeGeom(None, None)] * 0)        # no geometries
    assert bad.xs.size == 0 and bad.ok.size == 0


def test_without_the_core_same_bits(monkeypatch):
    """The per-run path (no compiled core) gives the same tables."""
    monkeypatch.setattr(curves, "_INTERP_ROWS", None)
    strokes, pin, rows, prof = _curves_of(*FILES[0])
    got = curves.candidates_curve(pin, rows, strokes, prof)
    want = _ref_candidates_curve(pin, rows, strokes, prof)
    for g, w in zip(got, want):
        assert _bits(g, w)
