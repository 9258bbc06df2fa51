"""Real Klipper as a test oracle (a helper module for the tests, not a test file).

`../shared/klipper/klipper_motion.py` (beside the repository; env KLIPPER_ORACLE names
another path) runs Klipper's own host planner in batch mode on a file and prints JSON:
its motion time, the integral of |a|^2 over its trapezoids, full stops and every G-code
error with its line.  `run_oracle(path, profile)` runs it with the profile's limits
(results cached per (file content, options) for the session); `oracle_or_skip()` skips
a test, saying why, only when the oracle is absent.

`model_metrics(path, profile)` gives the firmware model's figures under the oracle's
definitions (sum of the XYZ trapezoids' durations; sum of a^2 (accel_t + decel_t) over
them, XY-projected or not; a full stop = a move ending and the next starting below
1e-6 mm/s), and `oracle_machine(profile)` the profile as the oracle's printer.cfg has
it (its Z limits are fixed there), so that the model plays the same machine.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from gcode_opt.firmware.simulate import simulate_file

REPO = Path(__file__).resolve().parents[1]
DEFAULT_ORACLE = REPO.parent / "shared" / "klipper" / "klipper_motion.py"
ORACLE_Z_VELOCITY_V = 20.0      # shared/klipper/printer.cfg [printer] max_z_velocity (not an option)
ORACLE_Z_ACCEL_A = 500.0        # shared/klipper/printer.cfg [printer] max_z_accel
STOP_V = 1e-6                   # klipper_motion.py: a move ending and the next starting below this

_cache: dict = {}


def oracle_path() -> Path:
    return Path(os.environ.get("KLIPPER_ORACLE") or DEFAULT_ORACLE)


def oracle_or_skip() -> Path:
    p = oracle_path()
    if not p.is_file():
        pytest.skip(f"Klipper oracle absent: no {p} (set KLIPPER_ORACLE to klipper_motion.py)")
    return p


def oracle_options(profile, start=None) -> tuple:
    """klipper_motion.py options for a profile; start = (x, y, z) sets --start."""
    opts = ("--accel", repr(float(profile.default_accel_a)),
            "--scv", repr(float(profile.square_corner_velocity_v)),
            "--max-velocity", repr(float(profile.max_velocity_v)),
            "--mcr", repr(float(profile.minimum_cruise_ratio_r)))
    if start is not None:
        opts += ("--start", ",".join(repr(float(c)) for c in start))
    return opts


def run_oracle(path, profile, start=None) -> dict:
    """The oracle's JSON for this file under the profile's limits (cached)."""
    exe = oracle_or_skip()
    digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()
    opts = oracle_options(profile, start)
    key = (str(exe), digest, opts)
    if key not in _cache:
        proc = subprocess.run([sys.executable, str(exe), str(path), *opts],
                              capture_output=True, text=True, timeout=900)
        if proc.returncode not in (0, 1) or not proc.stdout.strip():
            raise RuntimeError(f"Klipper oracle failed (exit {proc.returncode}) on {path}: "
                               f"{proc.stderr.strip()[-2000:]}")
        _cache[key] = json.loads(proc.stdout)
    return _cache[key]


FULL_STOP_V = 1e-2    # mm/s: below this a junction is a full stop (full_stops)


def full_stops(path, profile, start=None, stop_v=FULL_STOP_V) -> int:
    """The toolhead's internal full stops in Klipper's own plan of the file: a move ending and
    the next starting below stop_v (from the oracle's trapq moves, end speed = cruise -
    accel * decel time, as klipper_motion.py makes it).  Its n_internal_full_stops counts
    below 1e-6 mm/s, where a reversal's junction speed is rounding: an exact 180-degree turn
    gives 0, one whose two directions round apart gives ~3e-4 mm/s (sin(theta/2) ~ 1e-8 in
    Klipper's junction deviation), and both are full stops (no_type_comments.gcode: 107 of
    its processed file's reversals were 0 where the original's were 3e-4 to 0.03 mm/s)."""
    import tempfile

    import numpy as np
    exe = oracle_or_skip()
    digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()
    opts = oracle_options(profile, start)
    key = (str(exe), digest, opts, "full_stops", stop_v)
    if key not in _cache:
        with tempfile.TemporaryDirectory() as tmp:
            csv = os.path.join(tmp, "moves.csv")
            proc = subprocess.run([sys.executable, str(exe), str(path), *opts, "--moves", csv],
                                  capture_output=True, text=True, timeout=900)
            if proc.returncode not in (0, 1) or not os.path.isfile(csv):
                raise RuntimeError(f"Klipper oracle failed (exit {proc.returncode}) on {path}: "
                                   f"{proc.stderr.strip()[-2000:]}")
            m = np.genfromtxt(csv, delimiter=",", names=True)
        m = np.atleast_1d(m)
        end_v = m["cruise_v"] - m["accel"] * m["decel_t"]
        _cache[key] = int(((end_v[:-1] < stop_v) & (m["start_v"][1:] < stop_v)).sum())
    return _cache[key]


def oracle_machine(profile):
    """The profile on the oracle's printer: same XY limits, the oracle's fixed Z limits."""
    return dataclasses.replace(profile, max_z_velocity_v=ORACLE_Z_VELOCITY_V,
                               max_z_accel_a=ORACLE_Z_ACCEL_A)


def model_metrics(path, profile) -> dict:
    """The firmware model's figures with the oracle's definitions (see module doc)."""
    acc = {"motion_time_s": 0.0, "int_a2_xy": 0.0, "int_a2_xyz": 0.0,
           "n_internal_full_stops": 0, "n_trapq_moves": 0}
    last = [None]

    def on_block(b):
        ta = b.accel_t + b.decel_t
        a2 = b.accel * b.accel * ta
        acc["motion_time_s"] += b.accel_t + b.cruise_t + b.decel_t
        acc["int_a2_xyz"] += a2
        acc["int_a2_xy"] += a2 * (b.ux * b.ux + b.uy * b.uy)
        acc["n_trapq_moves"] += 1
        if last[0] is not None and last[0] < STOP_V and b.start_v < STOP_V:
            acc["n_internal_full_stops"] += 1
        last[0] = b.end_v

    res = simulate_file(str(path), profile, on_block=on_block)
    acc["sim"] = res
    return acc


def rel_diff(model: float, oracle: float) -> float:
    return (model - oracle) / oracle if oracle else (0.0 if model == 0 else float("inf"))


def random_klipper_file(seed: int, n: int = 400) -> str:
    """A random G-code file of what Klipper plans: lines from 0.05 to 40 mm (reversals
    included), F changes, M204 S and SET_VELOCITY_LIMIT (ACCEL, VELOCITY,
    SQUARE_CORNER_VELOCITY incl. 0, MINIMUM_CRUISE_RATIO), retract/unretract, G4/M400, Z
    moves, I/J arcs of 0.5..40 mm radius (helical, with and without E); within 200 mm."""
    import math
    import random
    rnd = random.Random(seed)
    out = ["G21", "G90", "M83", "G1 F3000", "G1 X100 Y100 Z0.2"]
    x = y = 100.0
    z = 0.2
    for _ in range(n):
        k = rnd.random()
        if k < 0.04:
            out.append(f"M204 S{rnd.choice([500, 1000, 2500, 4000, 7000])}")
        elif k < 0.07:
            out.append("SET_VELOCITY_LIMIT " + rnd.choice([
                f"ACCEL={rnd.choice([800, 3000, 6000])}", f"VELOCITY={rnd.choice([80, 150, 300, 500])}",
                f"SQUARE_CORNER_VELOCITY={rnd.choice([0, 1, 5, 12])}",
                f"MINIMUM_CRUISE_RATIO={rnd.choice([0, 0.3, 0.5, 0.9])}"]))
        elif k < 0.09:
            d = rnd.choice([0.5, 1.0])
            out += [f"G1 E-{d} F2400", f"G1 E{d}"]
        elif k < 0.10:
            out.append(rnd.choice(["G4 P100", "M400", "G4 P0"]))
        elif k < 0.13:
            z += 0.2
            out.append(f"G1 Z{z:.2f} F{rnd.choice([600, 1200, 6000])}")
        elif k < 0.20:
            rad = rnd.choice([0.5, 2, 5, 15, 40])
            th0 = rnd.uniform(0, 2 * math.pi)
            cx, cy = x - rad * math.cos(th0), y - rad * math.sin(th0)
            sw = rnd.uniform(0.2, 6.0) * rnd.choice([-1, 1])
            ex, ey = cx + rad * math.cos(th0 + sw), cy + rad * math.sin(th0 + sw)
            if not (5 < ex < 195 and 5 < ey < 195):
                continue
            e = f" E{rnd.uniform(0.01, 2):.4f}" if rnd.random() < 0.7 else ""
            zz = ""
            if rnd.random() < 0.1:
                z += 0.1
                zz = f" Z{z:.2f}"
            out.append(f"{'G3' if sw > 0 else 'G2'} X{ex:.4f} Y{ey:.4f} I{cx - x:.4f} J{cy - y:.4f}"
                       f"{zz}{e} F{rnd.choice([1200, 3000, 9000])}")
            x, y = float(f"{ex:.4f}"), float(f"{ey:.4f}")
        else:
            step = rnd.choice([0.05, 0.3, 1, 3, 10, 40])
            nx = min(max(x + rnd.uniform(-step, step), 1), 199)
            ny = min(max(y + rnd.uniform(-step, step), 1), 199)
            e = f" E{rnd.uniform(0.001, 0.1) * step:.5f}" if rnd.random() < 0.7 else ""
            f = f" F{rnd.choice([600, 1800, 3600, 7200, 12000, 30000])}" if rnd.random() < 0.3 else ""
            out.append(f"G1 X{nx:.3f} Y{ny:.3f}{e}{f}")
            x, y = float(f"{nx:.3f}"), float(f"{ny:.3f}")
    return "\n".join(out) + "\n"
