"""Round 44 (plan44): laws/circle._solve_layers_batch holds the live arcs' numbers packed
(gathered once, packed again only when arcs leave, each arc's w_c written as it leaves)
instead of eight gathers and three scatters by the live rows every Newton step.  The code
it replaced (ebdd6f9) is kept here as the reference, with its step count a parameter: the
new one must give the same bits on random and degenerate arcs, when the steps run out, and
with arcs that never settle (NaN).  Round 46: the reference takes the secant steps
(after the first, a forward difference) the solver now takes."""
import numpy as np
import pytest

from gcode_opt.laws import circle


def _solve_layers_batch_ref(phi, gam2, u0, u1, steps=100):
    """circle._solve_layers_batch as of ebdd6f9 (steps: its 100 Newton steps at most)."""
    _layers_totals = circle._layers_totals
    span = np.abs(phi) + np.abs(u0) + np.abs(u1) + 1.0
    lo, hi = np.minimum.reduce([phi, u0, u1]) - span, np.maximum.reduce([phi, u0, u1]) + span
    for _ in range(60):
        glo, ghi = _layers_totals((lo, hi), phi, gam2, u0, u1)
        bad_lo, bad_hi = glo > 0, ghi < 0
        if not (bad_lo.any() or bad_hi.any()):
            break
        lo = np.where(bad_lo, lo - 2.0 * span, lo)
        hi = np.where(bad_hi, hi + 2.0 * span, hi)
        span = np.where(bad_lo | bad_hi, 2.0 * span, span)
    wc = phi.astype(float).copy()
    wc = np.clip(wc, lo, hi)
    act = np.arange(wc.size)
    xp, gp = np.empty(wc.size), np.empty(wc.size)      # (round 46: secant steps after the first)
    for it in range(steps):
        x, p_, g2, a0, a1, sp = wc[act], phi[act], gam2[act], u0[act], u1[act], span[act]
        if it == 0:
            h = 1e-7 * (np.abs(x) + 1e-3 * sp)
            g, gh = _layers_totals((x, x + h), p_, g2, a0, a1)
            dg = (gh - g) / h
        else:
            (g,) = _layers_totals((x,), p_, g2, a0, a1)
            dg = (g - gp[act]) / (x - xp[act])
        xp[act], gp[act] = x, g
        lo[act] = lo_a = np.where(g < 0, x, lo[act])
        hi[act] = hi_a = np.where(g > 0, x, hi[act])
        new = x - g / np.where(dg > 0, dg, np.inf)
        outside = ~((new > lo_a) & (new < hi_a)) | ~np.isfinite(new)
        new = np.where(outside, 0.5 * (lo_a + hi_a), new)
        done = np.abs(new - x) <= 1e-15 * sp
        wc[act] = new
        act = act[~done]
        if act.size == 0:
            break
    return wc


def _arcs(seed, n):
    rng = np.random.default_rng(seed)
    phi = rng.uniform(-2.0, 8.0, n) * rng.choice([1.0, 1e-6, 50.0], n)
    gam2 = rng.uniform(0.0, 30.0, n) * rng.choice([1.0, 1e4, 1e-8], n)
    u0 = rng.uniform(-1.0, 5.0, n) * rng.choice([1.0, 0.0, 20.0], n)
    u1 = rng.uniform(-1.0, 5.0, n) * rng.choice([1.0, 0.0, 20.0], n)
    if n > 8:
        gam2[:2] = [0.0, 1e308]
        u0[2:5] = [-0.0, 1e-310, -1e3]
        phi[5:8] = [0.0, -0.0, 1e-300]
    return phi, gam2, u0, u1


def _bits(a, b):
    return a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64))


@pytest.fixture(params=["core", "numpy"])
def mode(request, monkeypatch):
    if request.param == "numpy":
        monkeypatch.setattr(circle, "CORE_MOD", None)
    elif circle.CORE_MOD is None:
        pytest.skip("the curve core is not built")


@pytest.mark.parametrize("seed,n", [(1, 3000), (2, 257), (3, 1), (4, 33)])
def test_same_bits_as_the_gathering_loop(seed, n, mode):
    phi, gam2, u0, u1 = _arcs(seed, n)
    with np.errstate(all="ignore"):
        assert _bits(circle._solve_layers_batch(phi, gam2, u0, u1), _solve_layers_batch_ref(phi, gam2, u0, u1))


@pytest.mark.parametrize("steps", [1, 2, 3, 5, 8])
def test_same_bits_when_the_steps_run_out(steps, mode, monkeypatch):
    # arcs leave at different steps; those left when the steps run out keep their last w_c
    phi, gam2, u0, u1 = _arcs(7, 2000)
    monkeypatch.setattr(circle, "_LAYERS_ITER", steps)
    with np.errstate(all="ignore"):
        new = circle._solve_layers_batch(phi, gam2, u0, u1)
        old = _solve_layers_batch_ref(phi, gam2, u0, u1, steps)
    assert _bits(new, old)


def test_same_bits_with_arcs_that_never_settle(mode):
    # a NaN arc never meets the tolerance: it runs every step beside the others
    phi, gam2, u0, u1 = _arcs(9, 500)
    gam2[[3, 100, 499]] = np.nan
    phi[250] = np.nan
    with np.errstate(all="ignore"):
        assert _bits(circle._solve_layers_batch(phi, gam2, u0, u1), _solve_layers_batch_ref(phi, gam2, u0, u1))


def test_no_arcs(mode):
    e = np.zeros(0)
    assert circle._solve_layers_batch(e, e, e, e).shape == (0,)
