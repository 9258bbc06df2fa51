"""Round 20 (curves): laws/circle._layers_total computes the terms its two boundary layers
share (c, λ, e^{-λ}, c², γ² + 2w_c², k, 2w_c, 4w_c) once instead of once per layer.  The
start commit's (ede93db) _layers_total is kept here verbatim as the reference (it calls
_layer_d and _layer_int, unchanged); the new one must give the same bits on the circle
solves the pipeline makes on the bundled gyroid and concentric files, and on random and
degenerate cruise values (negative and zero offsets, huge γ, NaN, inf)."""
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt.laws import circle
from gcode_opt.laws.circle import _layer_d, _layer_int
from gcode_opt.pipeline import Options, process
from gcode_opt.profile import load_profile

S = Path(__file__).resolve().parent.parent / "sample_gcode"


def _layers_total_ref(wc, phi, gam2, u0, u1):
    """∫₀¹ w dτ - Φ for the composite layer solution with cruise value w_c."""
    dl0, dr0 = u0 - wc, u1 - wc
    dl1 = _layer_d(1.0, dl0, wc, gam2)
    dr1 = _layer_d(1.0, dr0, wc, gam2)
    return wc + _layer_int(dl0, dl1, wc, gam2) + _layer_int(dr0, dr1, wc, gam2) - phi


def _bits(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.fixture(scope="module")
def solves(tmp_path_factory):
    """The (phi, T, beta, w0, w1, R) of every solve_circles call of the curve planner on
    the bundled gyroid (two profiles) and concentric files (and, round 48, of its rough
    solves: every candidate is screened on one first)."""
    got = []
    f, f_rough = curves.solve_circles, circle.solve_circles_rough
    mp = pytest.MonkeyPatch()

    def rec(*args, **kw):
        got.append(tuple(np.array(a, float) for a in args))
        return f(*args, **kw)

    def rec_rough(*args):
        got.append(tuple(np.array(a, float) for a in args))
        return f_rough(*args)
    try:
        mp.setattr(curves, "solve_circles", rec)
        mp.setattr(circle, "solve_circles_rough", rec_rough)
        d = tmp_path_factory.mktemp("layers20")
        for name, prof in (("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_gyroid.gcode", "voron24"),
                           ("prusa_concentric.gcode", "prusa-mk3s")):
            process(str(S / name), str(d / (name + prof)), load_profile(prof), Options())
    finally:
        mp.undo()
    assert sum(a[0].size for a in got) > 1000
    return got


def test_solve_layers_batch_bitwise_on_the_pipelines_solves(solves, monkeypatch):
    for phi, T, beta, w0, w1, R in solves:
        gam2 = T * T / beta
        u0, u1 = w0 * T, w1 * T
        new = circle._solve_layers_batch(phi, gam2, u0, u1)
        with monkeypatch.context() as m:
            m.setattr(circle, "_layers_total", _layers_total_ref)
            old = circle._solve_layers_batch(phi, gam2, u0, u1)
        assert _bits(new, old)
        for wc in (new, new * (1 + 1e-3), new - 1.0, phi):
            with np.errstate(all="ignore"):
                assert _bits(circle._layers_total(wc, phi, gam2, u0, u1), _layers_total_ref(wc, phi, gam2, u0, u1))


def test_layers_total_bitwise_on_random_and_degenerate_values():
    rng = np.random.default_rng(8)
    n = 4000
    phi = rng.uniform(-2.0, 8.0, n) * rng.choice([1.0, 1e-6, 50.0], n)
    gam2 = rng.uniform(0.0, 30.0, n) * rng.choice([1.0, 1e4, 1e-8], n)
    u0 = rng.uniform(-1.0, 5.0, n) * rng.choice([1.0, 0.0, 20.0], n)
    u1 = rng.uniform(-1.0, 5.0, n) * rng.choice([1.0, 0.0, 20.0], n)
    wc = phi + rng.normal(0.0, 1.0, n) * rng.choice([0.0, 1.0, 1e-9, 100.0], n)
    wc[:10] = [0.0, -0.0, np.nan, np.inf, -np.inf, 1e300, -1e300, 1e-300, 5e-324, -3.0]
    gam2[10:14] = [0.0, np.inf, np.nan, 1e308]
    with np.errstate(all="ignore"):
        assert _bits(circle._layers_total(wc, phi, gam2, u0, u1), _layers_total_ref(wc, phi, gam2, u0, u1))
        assert _bits(circle._solve_layers_batch(phi[14:], gam2[14:], u0[14:], u1[14:]),
                     _solve_layers_ref(phi[14:], gam2[14:], u0[14:], u1[14:]))


def _solve_layers_ref(phi, gam2, u0, u1):
    old = circle._layers_total
    circle._layers_total = _layers_total_ref
    try:
        return circle._solve_layers_batch(phi, gam2, u0, u1)
    finally:
        circle._layers_total = old
