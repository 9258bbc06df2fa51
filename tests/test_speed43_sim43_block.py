"""Session 43 (sim43): the compiled model's per-block path against the Python model, bit for bit.

firmware/_core.c's sim_block_body (inlined into play_fused and sim_block) caps a block's
acceleration and speed per axis with caps_axis() when no cap is < 0 (`x * au > cap`, no
`au > 0.0` test, no zero check on the division), takes its square roots with sqrt_rn()
(sqrtsd, no errno), and leaves a new block's trapezoid fields for set_trapezoid to write.
Here every LineRecord, Block and SimResult field of the compiled core must be the Python
model's bits, on moves made to reach each case: axis-aligned moves (a unit component of 0),
Z moves, caps of 0, < 0, NaN and inf, speeds and accelerations above or at the caps, on the
two Marlin laws (the capped path) and Klipper's."""
from __future__ import annotations

import itertools
import random

import pytest

import fwcore_compare as fc
from gcode_opt import state as st
from gcode_opt.firmware import simulate as sm
from gcode_opt.profile import Profile, load_profile

pytestmark = pytest.mark.skipif(sm._core is None, reason="the compiled firmware-model core is not built")

LAWS = ("prusa-mk3s", "generic-marlin", "voron24")
NAN, INF = float("nan"), float("inf")
CAPS = (3000.0, 0.0, -5.0, NAN, INF, 1000.0, 1e-300)


def _lim(ax, ay, v_max, jerk=8.0):
    return st.Limits(v_max=v_max, ax_max=ax, ay_max=ay, scv=5.0, mcr=0.5, jd=0.02, jerk_x=jerk, jerk_y=jerk)


def _moves(rng: random.Random, lim, n: int, z_step: float = 0.0):
    """n moves from the origin on: axis-aligned, diagonal, Z and random ones, some at the caps."""
    out, x, y, z = [], 0.0, 0.0, 0.0
    steps = [(10.0, 0.0), (0.0, 10.0), (-10.0, 0.0), (0.0, -7.5), (3.0, 4.0), (1e-3, 0.0), (0.0, 0.0)]
    for i in range(n):
        if i % 3 == 0:
            dx, dy = steps[i // 3 % len(steps)]
        else:
            dx, dy = rng.uniform(-20, 20), rng.uniform(-20, 20)
        dz = z_step if i % 5 == 4 else 0.0
        v = rng.choice([100.0, 1000.0, 3000.0, 8.0, rng.uniform(1, 500)])
        accel = rng.choice([1000.0, 3000.0, 1e6, 0.0, rng.uniform(100, 5000)])
        e = rng.choice([0.0, 0.1, rng.uniform(0, 1)])
        out.append(st.Move(i, st.LINE, x, y, z, x + dx, y + dy, z + dz, e, v, accel, "infill", 0, lim))
        x, y, z = x + dx, y + dy, z + dz
    return out


def _run_or_error(moves, prof, core):
    try:
        return fc.run([(mv.idx, "", mv) for mv in moves], prof, core)
    except Exception as exc:            # the same error on both cores
        return type(exc).__name__


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("ax,ay", list(itertools.product(CAPS[:4], CAPS[:4])))
def test_accel_caps_of_any_sign_same_bits(law, ax, ay):
    prof = load_profile(law)
    lim = _lim(ax, ay, 250.0)
    moves = _moves(random.Random(repr((ax, ay))), lim, 60, z_step=0.2)
    py, c = _run_or_error(moves, prof, "python"), _run_or_error(moves, prof, "c")
    if isinstance(py, str) or isinstance(c, str):
        assert py == c
    else:
        assert fc.first_difference(py, c) is None


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("v_max", CAPS)
@pytest.mark.parametrize("max_z_v", [12.0, 0.0, -1.0])
def test_speed_caps_of_any_sign_same_bits(law, v_max, max_z_v):
    prof = load_profile(law)
    prof = Profile(**{**prof.__dict__, "max_z_velocity_v": max_z_v})
    moves = _moves(random.Random(int(max_z_v * 7) + 3), _lim(3000.0, 2500.0, v_max), 60, z_step=0.3)
    py, c = _run_or_error(moves, prof, "python"), _run_or_error(moves, prof, "c")
    if isinstance(py, str) or isinstance(c, str):
        assert py == c
    else:
        assert fc.first_difference(py, c) is None


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("seed", range(4))
def test_limits_changing_between_moves_same_bits(law, seed):
    # the caps are kept per Limits object (set_lim, vlim_read): a new object, new caps and flags
    rng = random.Random(seed)
    prof = load_profile(law)
    moves = []
    for k in range(8):
        lim = _lim(rng.choice(CAPS), rng.choice(CAPS), rng.choice(CAPS), jerk=rng.choice([8.0, 0.0, 20.0]))
        for mv in _moves(rng, lim, 15, z_step=0.1):
            moves.append(st.Move(len(moves), mv.kind, mv.x0 + 50 * k, mv.y0, mv.z0, mv.x1 + 50 * k, mv.y1, mv.z1,
                                 mv.e, mv.v, mv.accel, mv.feature, mv.layer, mv.lim))
    # the moves joined end to start
    joined, x, y, z = [], 0.0, 0.0, 0.0
    for mv in moves:
        dx, dy, dz = mv.x1 - mv.x0, mv.y1 - mv.y0, mv.z1 - mv.z0
        joined.append(st.Move(mv.idx, mv.kind, x, y, z, x + dx, y + dy, z + dz, mv.e, mv.v, mv.accel,
                              mv.feature, mv.layer, mv.lim))
        x, y, z = x + dx, y + dy, z + dz
    py, c = _run_or_error(joined, prof, "python"), _run_or_error(joined, prof, "c")
    if isinstance(py, str) or isinstance(c, str):
        assert py == c
    else:
        assert fc.first_difference(py, c) is None


@pytest.mark.parametrize("law", LAWS)
def test_square_roots_of_tiny_huge_and_exact_squares_same_bits(law):
    # block lengths and corner speeds whose roots are exact, subnormal-near and huge
    prof = load_profile(law)
    lim = _lim(3000.0, 3000.0, 500.0)
    pts = [(0.0, 0.0), (3.0, 4.0), (3.0, 4.0 + 1e-9), (3.0 + 1e-8, 4.0), (1e150, 1e150), (1e150 + 3e134, 1e150),
           (0.0, 0.0), (1e-5, 2e-5), (5.0, -7.0), (5.0 + 2 ** -30, -7.0)]
    moves = [st.Move(i, st.LINE, *a, 0.0, *b, 0.0, 0.1, 200.0, 2000.0, "infill", 0, lim)
             for i, (a, b) in enumerate(zip(pts, pts[1:]))]
    py, c = _run_or_error(moves, prof, "python"), _run_or_error(moves, prof, "c")
    if isinstance(py, str) or isinstance(c, str):
        assert py == c
    else:
        assert fc.first_difference(py, c) is None
