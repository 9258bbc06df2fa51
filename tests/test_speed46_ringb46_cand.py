"""Session 46, the ringing solve's stores (helper "ringb46"): the core's ring_solve_run keeps
only what mod_ring_solve reads after it -- max_abs_r's candidate pieces (their amplitude and
length, few of a chunk's events) and the last amplitude -- not every event's amplitude and
every piece's length.  The same bits as before.

Reference: ring_solve as main ea254da had it (every amplitude and length stored, the
candidates as indices into them), built from that commit's _core.c in a test build (the
same flags as setup.py's) and loaded beside the tree's core.  Both are called with the same
arguments -- every call a real file's ringing makes (its floors, its carried amplitudes),
and random streams (events at one time, zero jumps, long pauses, a carried amplitude, peaks
the caller has already, a number that is not finite) -- and must return the same bits."""
import importlib.machinery
import importlib.util
import math
import os
import shutil
import subprocess
import sys
import sysconfig

import numpy as np
import pytest

from ring_close import random_events
from gcode_opt import ringing as rg
from gcode_opt.firmware import resonance as res
from gcode_opt.firmware import simulate as fw
from gcode_opt.firmware.resonance import Oscillator
from gcode_opt.profile import load_profile

CORE = fw._core
ROOT = os.path.join(os.path.dirname(__file__), "..")
SAMPLES = os.path.join(ROOT, "sample_gcode")
OLD = "ea254da"             # the commit whose ring_solve stored every amplitude
FLAGS = ["-O2", "-ffp-contract=off", "-fno-fast-math", "-fno-builtin-sin", "-fno-builtin-cos"]

need_solve = pytest.mark.skipif(CORE is None or not hasattr(CORE, "ring_solve"),
                                reason="the compiled firmware core is not built here")


def _old_source():
    try:
        return subprocess.run(["git", "-C", ROOT, "show", OLD + ":gcode_opt/firmware/_core.c"],
                              capture_output=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return None


@pytest.fixture(scope="module")
def old_core(tmp_path_factory):
    """main ea254da's core (its own module object: its own tables and room)"""
    src = _old_source()
    cc = shutil.which("gcc") or shutil.which("cc")
    if src is None or cc is None or sys.platform != "linux":
        pytest.skip("no git history or no C compiler for the reference build")
    d = tmp_path_factory.mktemp("old_core")
    c_path = d / "_core.c"
    c_path.write_bytes(src)
    name = CORE.__name__
    so = d / (name + importlib.machinery.EXTENSION_SUFFIXES[0])
    inc = [sysconfig.get_paths()["include"], np.get_include(), os.path.join(ROOT, "gcode_opt", "firmware")]
    cmd = [cc, "-shared", "-fPIC", *FLAGS, *("-I" + p for p in inc), str(c_path), "-o", str(so), "-lm"]
    if subprocess.run(cmd, capture_output=True).returncode != 0:
        pytest.skip("the reference core does not build here")
    spec = importlib.util.spec_from_file_location(name, so)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _bits(x):
    if x is None:
        return None
    if isinstance(x, tuple):
        return tuple(_bits(v) for v in x)
    if isinstance(x, complex):
        return (_bits(x.real), _bits(x.imag))
    return np.float64(x).view(np.uint64).item()


def _both(old, osc, t, dr, drp, first, floor):
    args = (np.ascontiguousarray(t, np.float64), np.ascontiguousarray(dr, np.float64),
            np.ascontiguousarray(drp, np.float64), first, osc.s, osc.wd,
            *res._int_r2_args(osc.s, osc.lam), floor)
    return CORE.ring_solve(*args), old.ring_solve(*args)


def _real_calls(name, prof, chunk):
    """(oscillator, t, dr, drp, first, floor) of every Oscillator.solve call of a real file"""
    calls = []
    orig = Oscillator.solve

    def spy(self, t, dr, drp, first, floor=0.0):
        calls.append((self, np.array(t), np.array(dr), np.array(drp), first, floor))
        return orig(self, t, dr, drp, first, floor)
    profile = load_profile(prof)
    col = rg.Collector(profile, None, chunk_blocks=chunk)
    Oscillator.solve, join = spy, res.USE_JOIN
    res.USE_JOIN = False      # (Oscillator.solve's own calls: Oscillator.join takes the streams' steps otherwise, test_speed58_ring_join)
    try:
        rg.play(os.path.join(SAMPLES, name), profile, col)
    finally:
        Oscillator.solve, res.USE_JOIN = orig, join
    return calls


@need_solve
@pytest.mark.parametrize("name,prof,chunk", [("prusa_gyroid.gcode", "prusa-mk3s", 300),
                                             ("prusa_mk3s_rectilinear.gcode", "voron24", 400)])
def test_real_calls_are_the_old_bits(old_core, name, prof, chunk):
    calls = _real_calls(name, prof, chunk)
    assert len(calls) > 50
    peaks = 0
    for osc, t, dr, drp, first, floor in calls:
        got, want = _both(old_core, osc, t, dr, drp, first, floor)
        assert _bits(got) == _bits(want)
        peaks += got is not None and got[1] is not None
    assert peaks > 20


@need_solve
@pytest.mark.parametrize("seed", range(4))
def test_random_streams_are_the_old_bits(old_core, seed):
    rng = np.random.default_rng(seed)
    for _ in range(12):
        osc = Oscillator(float(rng.uniform(20.0, 120.0)), float(rng.uniform(0.02, 0.5)))
        n = int(rng.integers(1, 3000))
        t, dr, drp = random_events(rng, n)
        dr[rng.uniform(size=n) < 0.05] = -0.0
        first = complex(rng.normal(), rng.normal()) * 1e-3 if rng.uniform() < 0.7 else None
        if first is not None:
            t = np.concatenate([[t[0] - rng.exponential(0.01)], t])
        # no floor, one below the chunk's peak (some candidates ruled out), one above (all)
        for floor in (0.0, float(rng.exponential(1e-4)), 1.0):
            got, want = _both(old_core, osc, t, dr, drp, first, floor)
            assert _bits(got) == _bits(want)
    osc = Oscillator(50.0, 0.1)
    one = np.ones(3)
    for t in (np.array([0.0, 0.1, np.inf]), np.array([0.0, 0.0, 0.0]), np.array([0.0])):
        got, want = _both(old_core, osc, t[:len(t)], one[:len(t)], one[:len(t)], None, 0.0)
        assert _bits(got) == _bits(want)
    got, want = _both(old_core, osc, np.array([0.0, 0.1]), np.array([1.0, math.nan]), np.ones(2), None, 0.0)
    assert got is None and want is None
