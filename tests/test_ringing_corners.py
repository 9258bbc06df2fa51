"""corners.py: slower corners within a time budget, and what the firmware model then plays."""
from __future__ import annotations

import math
import os
import types

import numpy as np
import pytest

from gcode_opt import corners, ringing

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLES = os.path.join(ROOT, "sample_gcode")


def _stroke(u, prev_u, next_u, v_feed=80.0):
    return types.SimpleNamespace(kind="line", ux=u[0], uy=u[1], prev_u=prev_u, next_u=next_u,
                                 v_feed=v_feed, arc=None, pts=None)


def _case():
    """Four strokes: a 135-degree corner at both ends, a 45-degree one, a gentle 10-degree
    turn, and a stroke between two stops."""
    d = math.radians
    u = (1.0, 0.0)
    back = (math.cos(d(135)), math.sin(d(135)))
    mid = (math.cos(d(45)), math.sin(d(45)))
    gentle = (math.cos(d(10)), math.sin(d(10)))
    strokes = [_stroke(u, back, back), _stroke(u, mid, mid), _stroke(u, gentle, gentle),
               _stroke(u, None, None)]
    n = len(strokes)
    pin = types.SimpleNamespace(v0=np.full(n, 8.0), v1=np.full(n, 8.0), v_cap=np.full(n, 100.0),
                                a_cap=np.full(n, 1000.0), T_orig=np.full(n, 0.5))
    return strokes, pin


PROF = types.SimpleNamespace(freq_x_hz=50.0, freq_y_hz=50.0)


def test_weights_are_the_turns_velocity_change():
    strokes, _ = _case()
    k0, k1 = corners.corner_weights(strokes, PROF)
    # |u_to - u_from|^2 = 2 - 2 cos(theta): 135 deg -> 2 + sqrt 2, 45 deg -> 2 - sqrt 2
    assert k0[0] == pytest.approx(2 + math.sqrt(2)) and k1[0] == pytest.approx(2 + math.sqrt(2))
    assert k0[1] == pytest.approx(2 - math.sqrt(2))
    assert k0[2] == 0 and k1[2] == 0            # a curve's vertex, not a corner
    assert k0[3] == 0 and k1[3] == 0            # stops on both sides


def test_end_speeds_bounds_and_budget():
    strokes, pin = _case()
    for budget in (0.0, 0.005, 0.02, 0.1, 10.0):
        v0, v1 = corners.end_speeds(strokes, pin, PROF, None, budget_t=budget)
        assert np.all(v0 <= pin.v0) and np.all(v1 <= pin.v1)         # the firmware's bound
        assert np.all(v0 >= min(corners.MIN_CORNER_V, 8.0)) and np.all(v1 >= corners.MIN_CORNER_V)
        assert v0[2] == 8.0 and v1[2] == 8.0 and v0[3] == 8.0 and v1[3] == 8.0
        spent = sum(float(corners.end_time_cost(np.array(v), 8.0, 80.0, 1000.0))
                    for v in np.concatenate([v0, v1]))
        assert spent <= budget + 1e-9
        if budget == 0.0:
            assert np.all(v0 == pin.v0) and np.all(v1 == pin.v1)
    # more time buys lower corners, the sharpest first
    a = corners.end_speeds(strokes, pin, PROF, None, budget_t=0.01)
    b = corners.end_speeds(strokes, pin, PROF, None, budget_t=0.05)
    assert np.all(b[0] <= a[0] + 1e-12) and b[0][0] < a[0][0]
    assert a[0][0] <= a[0][1]


def test_end_time_cost_matches_integrated_trapezoid():
    """The ramp part: a long stroke's time by integrating ds / v(s) of its trapezoid."""
    L, top, a = 40.0, 80.0, 1000.0

    def trapezoid_t(v0, v1):
        s = np.linspace(0.0, L, 400001)
        v = np.minimum(top, np.minimum(np.sqrt(v0 ** 2 + 2 * a * s), np.sqrt(v1 ** 2 + 2 * a * (L - s))))
        return np.trapezoid(1.0 / v, s) if hasattr(np, "trapezoid") else np.trapz(1.0 / v, s)

    for v in (1.0, 3.0, 6.0):
        ramp = trapezoid_t(8.0, v) - trapezoid_t(8.0, 8.0)
        edge_d = max(corners.EDGE_D, v * corners.EDGE_T)
        model = float(corners.end_time_cost(np.array(v), 8.0, top, a)) - (edge_d / v - edge_d / 8.0)
        assert model == pytest.approx(ramp, rel=2e-3)


def test_lower_corner_speed_rings_less():
    """The ringing model on a hand-made stroke pair: halving the junction speed of a
    90-degree corner halves its corner ringing (linear in the jump)."""
    def rows(v):
        # accelerate 0 -> 60 along +X, cruise, decelerate to v; then along +Y from v
        out = []
        for u, (sv, ev) in (((1.0, 0.0), (0.0, v)), ((0.0, 1.0), (v, 0.0))):
            a = 1000.0
            at, dt = (60 - sv) / a, (60 - ev) / a
            out.append((u[0], u[1], sv, 60.0, ev, a, at, 0.2, dt, 0.0, 1, 1.0))
        return out

    model = dict(freq_x_hz=50.0, freq_y_hz=50.0, damping_r=0.1, shaper="none",
                 shaper_freq_x_hz=50.0, shaper_freq_y_hz=50.0, shaper_damping_r=0.1)
    hi = ringing.figures_of_trace(ringing.trace_from_items(rows(8.0)), model)
    lo = ringing.figures_of_trace(ringing.trace_from_items(rows(4.0)), model)
    ratio = lo["xy"]["rms_corner_um"] / hi["xy"]["rms_corner_um"]
    assert ratio == pytest.approx(0.5, rel=0.05)    # total times differ slightly
    assert lo["xy"]["rms_corner_um"] < hi["xy"]["rms_corner_um"]

# The pipeline with slower corners (the product path, Options.corner_budget_r): test_corners_product.py.
