"""Session 48 (play48): play_fused's planar body (firmware/_core.c CFG_MARLIN_JERK_XY).

On the Marlin jerk law a block with dz == 0 (+0 or -0) is built without its Z terms: no dz * dz
in its length, no Z cap on its acceleration or speed, no Z jerk on its safe speed, and no Z
term in its junction when the block before it had uz == 0 too; only where the Z jerk is not
< 0.  Each of those terms is a test that is false there (0 or NaN times a number is not above a
cap that is not < 0), so the blocks must be the same bits as the general body's.

Reference: the same pass through the compiled Sim's move() line by line (the 9bb98a8 loop,
test_speed_measure_loop._ref_play: Sim_move_body, the general CFG_ANY body, not play_fused),
whose bits test_speed43_sim43_block pins to the pure-Python model.  The files mix planar
moves, Z moves at speed (a Z jerk that limits), planar moves right after them, moves between
Z0 and Z-0 (dz of -0, +0), diagonal XYZ moves, E-only moves and travel; the profiles vary the
Z jerk (> 0, 0, < 0, NaN) and the Z caps (0, < 0, NaN)."""
from __future__ import annotations

import math
import os
import random

import pytest

from gcode_opt import state as st
from gcode_opt.firmware import simulate as fw
from gcode_opt.profile import Profile, load_profile

from test_speed28_measure_buf import _run

pytestmark = pytest.mark.skipif(fw._core is None or not hasattr(fw._core.Sim, "play_buf"),
                                reason="the compiled firmware core is not built here")

NAN = float("nan")


def _file(tmp_path, seed):
    rng = random.Random(4800 + seed)
    out = ["G21", "G90", "M83", ";TYPE:Perimeter", "G1 Z0.2 F600"]
    x, y, z = 100.0, 100.0, 0.2
    for _ in range(400):
        r = rng.random()
        f = rng.choice([600, 1200, 3000, 9000, 18000])
        if r < 0.55:                                  # planar, extruding or not
            x, y = x + rng.uniform(-15, 15), y + rng.uniform(-15, 15)
            e = f" E{rng.uniform(0.01, 0.5):.5f}" if rng.random() < 0.8 else ""
            out.append(f"G1 X{x:.3f} Y{y:.3f}{e} F{f}")
        elif r < 0.65:                                # a Z move at speed, then planar ones
            z += rng.choice([0.2, -0.2, 1.0, 0.05])
            out.append(f"G1 Z{z:.3f} F{rng.choice([600, 1200, 6000])}")
        elif r < 0.72:                                # diagonal XYZ
            x, y, z = x + rng.uniform(-5, 5), y + rng.uniform(-5, 5), z + rng.uniform(-0.3, 0.3)
            out.append(f"G1 X{x:.3f} Y{y:.3f} Z{z:.3f} E0.05 F{f}")
        elif r < 0.80:                                # Z0 / Z-0: dz of +0 and -0 on planar moves
            zz = rng.choice(["0", "-0", "0.0", "-0.0"])
            z = float(zz)
            out.append(f"G1 Z{zz} F{f}")
            x += rng.uniform(-3, 3)
            out.append(f"G1 X{x:.3f} Z{rng.choice(['0', '-0'])} E0.02")
        elif r < 0.88:                                # retract / unretract (the model stops)
            out.append(f"G1 E{rng.choice(['-0.8', '0.8'])} F2100")
        elif r < 0.94:                                # tiny and zero-length moves
            x += rng.choice([0.0, 1e-10, 1e-4])
            out.append(f"G1 X{x:.10f} Y{y:.3f} E0.001")
        else:
            out.append(rng.choice(["M204 S800", "M204 S1500", "G4 P10", ";TYPE:Infill"]))
    path = str(tmp_path / f"xy{seed}.gcode")
    with open(path, "w") as fh:
        fh.write("\n".join(out) + "\n")
    return path


def _profile(jerk_z, max_z_v=12.0, max_z_a=1000.0):
    """prusa-mk3s with these Z limits; the Z jerk (no Profile field: the models read
    jerk_z_v if there is one, else 0.4) as a subclass's attribute."""
    prof = load_profile("prusa-mk3s")
    cls = type("ProfileJerkZ", (Profile,), {"jerk_z_v": jerk_z})
    return cls(**{**prof.__dict__, "max_z_velocity_v": max_z_v, "max_z_accel_a": max_z_a})


def _pass(path, profile, ref, monkeypatch):
    n = sum(1 for _ in st.read_lines(path))
    watch = [(a, min(a + 5, n - 1)) for a in range(4, n, 23)]
    try:
        return _run(path, profile, 0 if ref else 1 << 16, ref, watch, None if ref else monkeypatch)
    except Exception as exc:                          # the same error on both paths
        return type(exc).__name__, str(exc)


def test_the_plates_profile_takes_the_planar_body():
    """The plates' profile (prusa-mk3s): Marlin's planner, the jerk law, the Z jerk 0.4."""
    prof = load_profile("prusa-mk3s")
    assert prof.flavour.startswith("marlin") and prof.junction == "jerk"
    assert getattr(prof, "jerk_z_v", 0.4) == 0.4


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("jerk_z", [0.4, 0.0, -0.0, -1.0, NAN, 50.0])
def test_planar_blocks_same_bits(tmp_path, seed, jerk_z, monkeypatch):
    path = _file(tmp_path, seed)
    profile = _profile(jerk_z)
    ref = _pass(path, profile, True, monkeypatch)
    assert _pass(path, profile, False, monkeypatch) == ref


@pytest.mark.parametrize("max_z_v,max_z_a", [(0.0, 1000.0), (-1.0, 1000.0), (NAN, 1000.0), (12.0, 0.0),
                                             (12.0, -5.0), (12.0, NAN), (math.inf, math.inf)])
def test_planar_blocks_same_bits_under_z_caps(tmp_path, max_z_v, max_z_a, monkeypatch):
    path = _file(tmp_path, 7)
    profile = _profile(0.4, max_z_v, max_z_a)
    ref = _pass(path, profile, True, monkeypatch)
    assert _pass(path, profile, False, monkeypatch) == ref


def test_a_z_jerk_limits_here(tmp_path, monkeypatch):
    """The files reach the Z terms: a Z jerk of 0.4 and one of 1e9 give other blocks (a
    planar body that dropped them where they count would differ from the reference)."""
    path = _file(tmp_path, 0)
    a = _pass(path, _profile(0.4), True, monkeypatch)
    b = _pass(path, _profile(1e9), True, monkeypatch)
    assert a[0] != b[0]
    assert os.path.getsize(path) > 0
