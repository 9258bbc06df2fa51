"""The ringing's per-chunk solve in one call of the firmware core (issue 8, round 20):
_Stream._solve's steps -- jump_amplitude, amplitudes, integral_r2_fin_sum (with numpy's
np.exp(-2 s dur) taken as the core's own exp(qr dur), the same argument), max_abs_r -- are
ring_solve's one pass (Oscillator.solve); X's ramp, corner and turn streams take "all"'s
exponentials (RingMemo src), and the memo's out arrays are kept from chunk to chunk.

Reference: the ede93db _Stream._solve (its steps: jump_amplitude, amplitudes,
integral_r2_fin_sum / integral_r2, max_abs_r, still in resonance.py and checked against
numpy by their own tests) and max_abs_r / peak_abs_r (copied below, numpy only), and the
ede93db Collector part loop (each part's memo cleared after its two streams, no src).  The
figures must be equal bit for bit on real files (with and without shapers, chunks forced
small), ring_solve's numbers equal the steps' on real events, and a core whose new steps
differ on the probe, a long restart or a number that is not finite leave the old steps.

Since session 46 ring_solve makes the amplitudes by their recursion (no restarts, no memo,
no probe): the same figures to rounding (ring_close), not the steps' bits; the numbers of
a number that is not finite still leave the old steps."""
import ast
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from ring_close import assert_figures_close, close
from gcode_opt import ringing as rg
from gcode_opt.firmware import resonance as res
from gcode_opt.firmware import simulate as fw
from gcode_opt.firmware.resonance import Oscillator
from gcode_opt.profile import load_profile

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
SAMPLES = os.path.join(ROOT, "sample_gcode")
CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus")
HAS_SOLVE = fw._core is not None and hasattr(fw._core, "ring_solve")
need_solve = pytest.mark.skipif(not HAS_SOLVE, reason="the compiled firmware core is not built here")


# ---------------------------------------------------------------- the ede93db code
def _ref_peak_abs_r(osc, c, dur):
    lam, wd = osc.lam, osc.wd
    fin = np.isfinite(dur)
    d = np.where(fin, dur, 0.0)
    best = np.abs(c.real)
    end = np.abs(np.real(c * np.exp(lam * d)))
    best = np.maximum(best, np.where(fin, end, 0.0))
    phi = np.angle(lam * c)
    tau = np.mod(0.5 * math.pi - phi, math.pi) / wd
    inside = (tau < d) | ~fin
    ext = np.abs(np.real(c * np.exp(lam * tau)))
    return np.maximum(best, np.where(inside, ext, 0.0))


def _ref_max_abs_r(osc, c, dur) -> float:
    lo = np.abs(c.real).max()
    keep = ~(np.abs(c) * (1.0 + 1e-9) < lo)
    return float(np.maximum(lo, _ref_peak_abs_r(osc, c[keep], dur[keep]).max()))


def _ref_solve(self, t, dr, drp):
    """ede93db _Stream._solve (max_abs_r: the copy above)."""
    if len(t) == 0:
        return
    osc = self.osc
    dc = osc.jump_amplitude(dr, drp)
    if self.t_last is not None:        # the carried amplitude starts the cumulative sum
        t = np.concatenate([[self.t_last], t])
        dc = np.concatenate([[self.c_last], dc])
    memo, lead = self.memo, self.lead
    c = osc.amplitudes(t, dc, memo, lead)
    if len(c) > 1:
        dur = np.diff(t)
        if np.isfinite(dur).all():
            self.int_r2 += osc.integral_r2_fin_sum(c[:-1], dur, memo, lead, t[:-1])
        else:
            self.int_r2 += float(osc.integral_r2(c[:-1], dur).sum())
        self.peak = max(self.peak, _ref_max_abs_r(osc, c[:-1], dur))
    self.t_last, self.c_last = float(t[-1]), complex(c[-1])


class _RefStream(rg._Stream):
    _solve = _ref_solve


class RefCollector(rg.Collector):
    """The ede93db Collector's solve: the old _solve on streams without src (the part
    loop's order of clearing the memos, the one other change of rg.Collector._flush,
    matters only to src).  Figured with numpy alone (_numpy_only: every compiled step off)
    it is the reference."""

    def __init__(self, *a, **k):
        super().__init__(*a, **k)
        for key, st in self.streams.items():
            self.streams[key] = _RefStream(st.osc, (st.a_p, st.t_p), st.memo, st.lead)


class _numpy_only:
    """With every compiled ringing step off (resonance.USE_KERNEL: amplitudes, jumps,
    integral_r2 and the solve take numpy's path)."""

    def __enter__(self):
        self.keep, res.USE_KERNEL = res.USE_KERNEL, False

    def __exit__(self, *exc):
        res.USE_KERNEL = self.keep


def _figures(path, profile, col):
    rg.play(path, profile, col)
    return col.figures()


def _count_solves(monkeypatch):
    """{'n': Oscillator.solve calls, 'done': those ring_solve did}"""
    seen = {"n": 0, "done": 0}
    orig = Oscillator.solve

    def spy(self, *a, **k):
        got = orig(self, *a, **k)
        seen["n"] += 1
        seen["done"] += got is not None
        return got
    monkeypatch.setattr(Oscillator, "solve", spy)
    monkeypatch.setattr(res, "USE_JOIN", False)     # (Oscillator.solve's own calls: Oscillator.join takes the streams' steps otherwise, test_speed58_ring_join)
    return seen


CASES = [("prusa_gyroid.gcode", "prusa-mk3s", None, rg.CHUNK_BLOCKS),
         ("prusa_gyroid.gcode", "prusa-mk3s", None, 300),
         ("prusa_klipper.gcode", "voron24", None, 500),
         ("prusa_klipper.gcode", "voron24", "ei", 700),
         ("prusa_mk3s_rectilinear.gcode", "voron24", "zv", rg.CHUNK_BLOCKS),
         ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", "mzv", 400)]


@need_solve
@pytest.mark.parametrize("name,prof,shaper,chunk", CASES)
def test_figures_equal_the_ede93db_solve(monkeypatch, name, prof, shaper, chunk):
    path = os.path.join(SAMPLES, name)
    if not os.path.exists(path):
        pytest.skip(f"{name} not in sample_gcode")
    profile = load_profile(prof)
    with _numpy_only():
        ref = _figures(path, profile, RefCollector(profile, shaper, chunk_blocks=chunk))
    seen = _count_solves(monkeypatch)
    got = _figures(path, profile, rg.Collector(profile, shaper, chunk_blocks=chunk))
    assert_figures_close(got, ref)
    assert seen["n"] and seen["done"] == seen["n"]         # the core did every chunk here
    assert ref["xy"]["rms_um"] > 0.0


@need_solve
def test_plate_gyroid_figures(monkeypatch):
    path = os.path.join(CORPUS, "plate_gyroid.gcode")
    if not os.path.exists(path):
        pytest.skip("plate_gyroid.gcode not in the corpus")
    profile = load_profile("prusa-mk3s")
    ref = _figures(path, profile, RefCollector(profile))      # (the steps with the core's kernels)
    got = _figures(path, profile, rg.Collector(profile))
    assert_figures_close(got, ref)


def _real_events(name="prusa_gyroid.gcode", prof="prusa-mk3s", chunk=400):
    """The (stream key, t with the carried event first, dr, drp, carried amplitude) of every
    _solve call of a real file's Collector (old steps)."""
    profile = load_profile(prof)
    col = RefCollector(profile, None, chunk_blocks=chunk)
    calls = []

    def spy(self, t, dr, drp):
        first = None if self.t_last is None else self.c_last
        t1 = t if self.t_last is None else np.concatenate([[self.t_last], t])
        calls.append((t1.copy(), dr.copy(), drp.copy(), first))
        return _ref_solve(self, t, dr, drp)
    for st in col.streams.values():
        st._solve = spy.__get__(st)
    join, res.USE_JOIN = res.USE_JOIN, False     # (_solve's own calls: Oscillator.join takes the streams' steps otherwise, test_speed58_ring_join)
    try:
        _figures(os.path.join(SAMPLES, name), profile, col)
    finally:
        res.USE_JOIN = join
    return calls


def _steps(osc, t1, dr, drp, first):
    """The old steps' (sum, peak, last amplitude) for the events, by numpy alone."""
    with _numpy_only():
        dc = osc.jump_amplitude(dr, drp)
        if first is not None:
            dc = np.concatenate([[first], dc])
        c = osc.amplitudes(t1, dc)
        if len(c) < 2:
            return None, None, complex(c[-1])
        dur = np.diff(t1)
        return (float(osc.integral_r2(c[:-1], dur).sum()), _ref_max_abs_r(osc, c[:-1], dur), complex(c[-1]))


def _same(a, b):
    """(sum, peak, last amplitude) of the core and of the steps, to rounding (the amplitudes'
    recursion; the last amplitude to its scale: the peak's)"""
    if a[0] is None or b[0] is None:
        return a[0] is b[0] and a[1] is b[1] and a[2] == b[2]
    return close(a[0], b[0]) and close(a[1], b[1]) and abs(a[2] - b[2]) <= 1e-12 * max(abs(b[2]), b[1])


@need_solve
def test_ring_solve_is_the_steps_on_real_events():
    """Every call of a real file: sum, peak and last amplitude to rounding."""
    calls = _real_events()
    osc = Oscillator(50.0, 0.1)
    assert len(calls) > 50
    for t1, dr, drp, first in calls:
        want = _steps(osc, t1, dr, drp, first)
        got = osc.solve(t1, dr, drp, first)
        assert got is not None and _same(got, want)


@need_solve
@pytest.mark.parametrize("seed", range(3))
def test_ring_solve_random_events(seed):
    """Random streams (events at one time, zero jumps of both signs, long pauses, other
    oscillators): the steps' numbers to rounding, or None where a number is not finite."""
    rng = np.random.default_rng(seed)
    for _ in range(8):
        osc = Oscillator(float(rng.uniform(20.0, 120.0)), float(rng.uniform(0.02, 0.5)))
        n = int(rng.integers(1, 3000))
        gaps = rng.exponential(0.01, n) * (rng.uniform(size=n) < 0.7)
        gaps[rng.uniform(size=n) < 0.01] *= 1e4
        t = np.cumsum(gaps) + rng.uniform(-5, 5)
        dr = rng.normal(size=n) * 1e-4 * (rng.uniform(size=n) < 0.8)
        drp = rng.normal(size=n) * 10.0 * (rng.uniform(size=n) < 0.5)
        dr[rng.uniform(size=n) < 0.05] = -0.0
        first = complex(rng.normal(), rng.normal()) * 1e-3 if rng.uniform() < 0.7 else None
        if first is not None:
            t = np.concatenate([[t[0] - rng.exponential(0.01)], t])
        got = osc.solve(t, dr, drp, first)
        assert got is not None and _same(got, _steps(osc, t, dr, drp, first))
    osc = Oscillator(50.0, 0.1)
    t = np.linspace(0.0, 1.0, 20000)              # one restart of 20000 events for the steps
    dr = np.full(20000, 1e-5)
    assert _same(osc.solve(t, dr, dr, None), _steps(osc, t, dr, dr, None))
    t = np.array([0.0, 0.1, np.inf])
    assert osc.solve(t, np.ones(3), np.ones(3), None) is None
    assert osc.solve(np.array([0.0, 0.1]), np.array([1.0, np.nan]), np.ones(2), None) is None


@need_solve
def test_the_old_steps_where_ring_solve_declines(monkeypatch):
    """Chunks the core declines (every other call here) take the old steps, from the
    amplitude the core carried and back: the figures of the steps, to rounding."""
    profile = load_profile("prusa-mk3s")
    orig, calls = Oscillator.solve, []

    def every_other(self, *a, **k):
        calls.append(len(calls) % 2 == 0)
        return orig(self, *a, **k) if calls[-1] else None
    monkeypatch.setattr(Oscillator, "solve", every_other)
    monkeypatch.setattr(res, "USE_JOIN", False)     # (Oscillator.solve's own calls: Oscillator.join takes the streams' steps otherwise, test_speed58_ring_join)
    path = os.path.join(SAMPLES, "prusa_gyroid.gcode")
    got = _figures(path, profile, rg.Collector(profile, None, chunk_blocks=300))
    assert len(calls) > 20
    monkeypatch.setattr(res, "USE_SOLVE", False)
    ref = _figures(path, profile, RefCollector(profile, None, chunk_blocks=300))
    assert_figures_close(got, ref)


PURE = """
import sys
from gcode_opt import ringing as rg
from gcode_opt.firmware import simulate as fw
from gcode_opt.profile import load_profile
assert fw._core is None
p = load_profile(sys.argv[2])
col = rg.Collector(p, None if sys.argv[3] == "-" else sys.argv[3])
rg.play(sys.argv[1], p, col)
print(repr(col.figures()))
"""


@pytest.mark.parametrize("name,prof,shaper", [("prusa_gyroid.gcode", "prusa-mk3s", "-"),
                                              ("prusa_klipper.gcode", "voron24", "ei")])
def test_pure_python_gives_the_same_figures(name, prof, shaper):
    path = os.path.join(SAMPLES, name)
    env = dict(os.environ, GCODE_OPT_PURE_PYTHON="1", PYTHONPATH=ROOT)
    out = subprocess.run([sys.executable, "-c", PURE, path, prof, shaper], env=env, cwd=ROOT,
                         capture_output=True, text=True, check=True).stdout.strip()
    profile = load_profile(prof)
    got = _figures(path, profile, rg.Collector(profile, None if shaper == "-" else shaper))
    assert_figures_close(got, ast.literal_eval(out))
