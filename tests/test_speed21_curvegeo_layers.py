"""Round 21 (curvegeo): laws/circle._solve_layers_batch takes its two residuals per step
(the bracket's ends; w_c and w_c + h) in one _layers_totals call, which with the compiled
core (_curvecore.c lay_pre / lay_mid / lay_post) does _layers_total's arithmetic in three
compiled passes around one np.exp and one np.arcsinh (numpy's own).  The start commit's
(d3559db) _solve_layers_batch and _layers_total are kept here verbatim as the reference;
the new ones must give the same bits (a NaN's sign aside, see _bits), with and without
the core, on the circle solves
the pipeline makes on the bundled gyroid and concentric files, and on random and
degenerate values (zero, negative, huge, NaN, inf).  Round 46: the reference takes the
secant steps (after the first, a forward difference) the solver now takes."""
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt.laws import circle
from gcode_opt.pipeline import Options, process
from gcode_opt.profile import load_profile

S = Path(__file__).resolve().parent.parent / "sample_gcode"
HAVE_CORE = circle.CORE_MOD is not None


# ---------------------------------------------------------------- references (d3559db, verbatim)
def _asinh_diff_ref(a, b):
    """asinh(a) - asinh(b) without cancellation when a ≈ b."""
    sa, sb = np.sqrt(1.0 + a * a), np.sqrt(1.0 + b * b)
    same = a * b > 0
    denom = np.where(same, a * sb + b * sa, 1.0)
    arg = np.where(same, (a - b) * (a + b) / denom, a * sb - b * sa)
    return np.arcsinh(arg)


def _layers_total_ref(wc, phi, gam2, u0, u1):
    dl0, dr0 = u0 - wc, u1 - wc
    c = gam2 + 6.0 * wc * wc
    lam = np.sqrt(c)
    c_sq = c * c
    g2w = gam2 + 2.0 * wc * wc
    w2, w4 = 2.0 * wc, 4.0 * wc
    e = np.exp(-lam * 1.0)
    k = np.sqrt(g2w)
    tot = wc
    for d0 in (dl0, dr0):
        # _layer_coeffs(d0, wc, gam2)
        rho = w2 * d0 / c
        q = np.sqrt(np.maximum(d0 * d0 + w4 * d0 + c, 0.0)) / lam
        s1 = 1.0 + rho
        num = d0 * d0 * g2w / c_sq
        a_inf = np.where(s1 >= 0, (s1 + q) / 2.0, num / (2.0 * np.where(s1 >= 0, 1.0, q - s1)))
        b_inf = np.where(s1 <= 0, (s1 - q) / 2.0, -num / (2.0 * np.where(s1 <= 0, 1.0, q + s1)))
        # _layer_d(1.0, d0, wc, gam2), then _layer_int(d0, d1, wc, gam2)
        d1 = d0 * e / (-rho * e + a_inf + b_inf * e * e)
        tot = tot + _asinh_diff_ref((d0 + w2) / k, (d1 + w2) / k)
    return tot - phi


def _solve_layers_batch_ref(phi, gam2, u0, u1):
    """Cruise value w_c (safeguarded Newton/bisection; the residual is increasing in w_c)."""
    _layers_total = _layers_total_ref
    span = np.abs(phi) + np.abs(u0) + np.abs(u1) + 1.0
    lo, hi = np.minimum.reduce([phi, u0, u1]) - span, np.maximum.reduce([phi, u0, u1]) + span
    for _ in range(60):             # make sure the bracket holds (the layer integrals are O(log))
        glo, ghi = _layers_total(lo, phi, gam2, u0, u1), _layers_total(hi, phi, gam2, u0, u1)
        bad_lo, bad_hi = glo > 0, ghi < 0
        if not (bad_lo.any() or bad_hi.any()):
            break
        lo = np.where(bad_lo, lo - 2.0 * span, lo)
        hi = np.where(bad_hi, hi + 2.0 * span, hi)
        span = np.where(bad_lo | bad_hi, 2.0 * span, span)
    wc = phi.astype(float).copy()
    wc = np.clip(wc, lo, hi)
    act = np.arange(wc.size)        # an arc leaves the iteration once its step is below tolerance
    xp, gp = np.empty(wc.size), np.empty(wc.size)      # (round 46: secant steps after the first)
    for it in range(100):
        x, p_, g2, a0, a1, sp = wc[act], phi[act], gam2[act], u0[act], u1[act], span[act]
        g = _layers_total(x, p_, g2, a0, a1)
        lo[act] = lo_a = np.where(g < 0, x, lo[act])
        hi[act] = hi_a = np.where(g > 0, x, hi[act])
        if it == 0:
            h = 1e-7 * (np.abs(x) + 1e-3 * sp)
            dg = (_layers_total(x + h, p_, g2, a0, a1) - g) / h
        else:
            dg = (g - gp[act]) / (x - xp[act])
        xp[act], gp[act] = x, g
        new = x - g / np.where(dg > 0, dg, np.inf)
        outside = ~((new > lo_a) & (new < hi_a)) | ~np.isfinite(new)
        new = np.where(outside, 0.5 * (lo_a + hi_a), new)
        done = np.abs(new - x) <= 1e-15 * sp
        wc[act] = new
        act = act[~done]
        if act.size == 0:
            break
    return wc


# ---------------------------------------------------------------- helpers
def _bits(a, b):
    """The same doubles bit for bit, but for a NaN's sign: a NaN made of two NaN operands
    (inf - inf times a NaN input...) takes the sign of the one the C compiler puts first,
    which C does not fix (the operands of * and + commute); a NaN's sign is never read
    (NaN rows leave the layer regime; no output prints or compares it)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.shape != b.shape:
        return False
    na, nb = np.isnan(a), np.isnan(b)
    return np.array_equal(na, nb) and np.array_equal(a[~na].view(np.int64), b[~nb].view(np.int64))


@pytest.fixture(params=["core", "numpy"])
def mode(request, monkeypatch):
    if request.param == "core":
        if not HAVE_CORE:
            pytest.skip("curve core not built")
    else:
        monkeypatch.setattr(circle, "CORE_MOD", None)
    return request.param


@pytest.fixture(scope="module")
def solves(tmp_path_factory):
    """(phi, gam2, u0, u1) of every solve_circles call of the curve planner on the bundled
    gyroid (two profiles) and concentric files (and, round 48, of its rough solves: every
    candidate is screened on one first)."""
    got = []
    f, f_rough = curves.solve_circles, circle.solve_circles_rough
    mp = pytest.MonkeyPatch()

    def put(args):
        phi, T, beta, w0, w1, R = (np.array(a, float) for a in args)
        got.append((phi, T * T / beta, w0 * T, w1 * T))

    def rec(*args, **kw):
        put(args)
        return f(*args, **kw)

    def rec_rough(*args):
        put(args)
        return f_rough(*args)
    try:
        mp.setattr(curves, "solve_circles", rec)
        mp.setattr(circle, "solve_circles_rough", rec_rough)
        d = tmp_path_factory.mktemp("layers21")
        for name, prof in (("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_gyroid.gcode", "voron24"),
                           ("prusa_concentric.gcode", "prusa-mk3s")):
            process(str(S / name), str(d / (name + prof)), load_profile(prof), Options())
    finally:
        mp.undo()
    assert sum(a[0].size for a in got) > 1000
    return got


def _random(seed, n=4000):
    rng = np.random.default_rng(seed)
    phi = rng.uniform(-2.0, 8.0, n) * rng.choice([1.0, 1e-6, 50.0], n)
    gam2 = rng.uniform(0.0, 30.0, n) * rng.choice([1.0, 1e4, 1e-8], n)
    u0 = rng.uniform(-1.0, 5.0, n) * rng.choice([1.0, 0.0, 20.0], n)
    u1 = rng.uniform(-1.0, 5.0, n) * rng.choice([1.0, 0.0, 20.0], n)
    wc = phi + rng.normal(0.0, 1.0, n) * rng.choice([0.0, 1.0, 1e-9, 100.0], n)
    wc[:10] = [0.0, -0.0, np.nan, np.inf, -np.inf, 1e300, -1e300, 1e-300, 5e-324, -3.0]
    gam2[10:14] = [0.0, np.inf, np.nan, 1e308]
    u0[14:18] = [-0.0, np.nan, 1e-310, -1e200]
    return wc, phi, gam2, u0, u1


# ---------------------------------------------------------------- tests
def test_solve_layers_batch_bitwise_on_the_pipelines_solves(solves, mode):
    for phi, gam2, u0, u1 in solves:
        new = circle._solve_layers_batch(phi, gam2, u0, u1)
        old = _solve_layers_batch_ref(phi, gam2, u0, u1)
        assert _bits(new, old)
        for wc in (new, new * (1 + 1e-3), new - 1.0, phi):
            with np.errstate(all="ignore"):
                got = circle._layers_totals((wc, wc + 1e-7), phi, gam2, u0, u1)
                assert _bits(got[0], _layers_total_ref(wc, phi, gam2, u0, u1))
                assert _bits(got[1], _layers_total_ref(wc + 1e-7, phi, gam2, u0, u1))


@pytest.mark.parametrize("seed", [1, 8, 21])
def test_layers_bitwise_on_random_and_degenerate_values(seed, mode):
    wc, phi, gam2, u0, u1 = _random(seed)
    with np.errstate(all="ignore"):
        got = circle._layers_totals((wc, -wc, wc * 3.0), phi, gam2, u0, u1)
        for x, g in zip((wc, -wc, wc * 3.0), got):
            assert _bits(g, _layers_total_ref(x, phi, gam2, u0, u1))
        assert _bits(circle._layers_total(wc, phi, gam2, u0, u1), _layers_total_ref(wc, phi, gam2, u0, u1))
        # the solver on the finite rows (its bracket needs finite numbers)
        r = slice(18, None)
        assert _bits(circle._solve_layers_batch(phi[r], gam2[r], u0[r], u1[r]),
                     _solve_layers_batch_ref(phi[r], gam2[r], u0[r], u1[r]))


def test_layers_totals_takes_strided_and_empty_inputs(mode):
    wc, phi, gam2, u0, u1 = _random(3, 200)
    with np.errstate(all="ignore"):
        got = circle._layers_totals((wc[::2],), phi[::2], gam2[::2], u0[::2], u1[::2])
        assert _bits(got[0], _layers_total_ref(wc[::2], phi[::2], gam2[::2], u0[::2], u1[::2]))
    e = np.empty(0)
    assert circle._layers_totals((e, e), e, e, e, e)[1].size == 0
