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
differ on the probe, a long restart or a number that is not finite leave the old steps."""
import math
import os
import subprocess
import sys

import numpy as np
import pytest

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


def _bits(d):
    if isinstance(d, dict):
        return {k: _bits(v) for k, v in d.items()}
    if isinstance(d, float):
        return np.float64(d).tobytes()
    return d


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
    assert _bits(got) == _bits(ref)
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
    assert _bits(got) == _bits(ref)


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
    _figures(os.path.join(SAMPLES, name), profile, col)
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
    return [None if x is None else np.complex128(x).tobytes() for x in a] == \
        [None if x is None else np.complex128(x).tobytes() for x in b]


@need_solve
def test_ring_solve_is_the_steps_on_real_events():
    """Every call of a real file: sum, peak and last amplitude bit for bit, alone and with
    memos (an X stream's kept, read by a Y stream; a src read by a lead that keeps)."""
    calls = _real_events()
    osc = Oscillator(50.0, 0.1)
    assert len(calls) > 50
    for t1, dr, drp, first in calls:
        want = _steps(osc, t1, dr, drp, first)
        got = osc.solve(t1, dr, drp, first)
        assert got is not None and _same(got, want)
        a, b = res.RingMemo(), res.RingMemo()
        assert _same(osc.solve(t1, dr, drp, first, a, True), want)      # keeps
        assert _same(osc.solve(t1, dr, drp, first, a, False), want)     # reads a
        assert _same(osc.solve(t1, dr, drp, first, b, True, a), want)   # reads a, keeps in b
        assert _same(osc.solve(t1, dr, drp, first, a, False), want)
        if len(t1) > 1:
            assert b.amps is not None and b.pieces is not None
            assert np.array_equal(b.pieces[1].view(np.int64), np.diff(t1).view(np.int64))


@need_solve
@pytest.mark.parametrize("seed", range(3))
def test_ring_solve_random_events(seed):
    """Random streams (events at one time, zero jumps of both signs, long pauses, other
    oscillators): the steps' bits, or None where the steps differ from the core's path (a
    restart of 16384 events or more, a number that is not finite)."""
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
    t = np.linspace(0.0, 1.0, 20000)              # one restart of 20000 events: numpy's
    dr = np.full(20000, 1e-5)
    assert osc.solve(t, dr, dr, None) is None
    t = np.array([0.0, 0.1, np.inf])
    assert osc.solve(t, np.ones(3), np.ones(3), None) is None
    assert osc.solve(np.array([0.0, 0.1]), np.array([1.0, np.nan]), np.ones(2), None) is None


@need_solve
def test_the_old_steps_where_ring_solve_declines(monkeypatch):
    """Chunks the core declines (a long restart: all events in one 16384-event window, or
    infinite pieces) give the old steps' figures."""
    profile = load_profile("prusa-mk3s")
    monkeypatch.setattr(res, "ELIDE_BYTES", 16 * 50)           # restarts of 50+ events: numpy's
    seen = _count_solves(monkeypatch)
    path = os.path.join(SAMPLES, "prusa_gyroid.gcode")
    got = _figures(path, profile, rg.Collector(profile, None, chunk_blocks=300))
    assert seen["n"] and seen["done"] < seen["n"]
    monkeypatch.setattr(res, "USE_SOLVE", False)
    ref = _figures(path, profile, RefCollector(profile, None, chunk_blocks=300))
    assert _bits(got) == _bits(ref)


@need_solve
def test_a_probe_that_fails_leaves_the_steps(monkeypatch):
    """A core whose ring_peak is one ulp off (or whose real exp is not numpy's) leaves that
    step to numpy (round 23: ring_solve takes numpy's decay2 / hands back the pieces for
    numpy's peak_abs_r); one whose |c| is not np.abs's is not used for the solve: the
    figures stay the steps'."""
    real = fw._core

    class Off:
        def __getattr__(self, name):
            return getattr(real, name)

        def ring_peak(self, *a):
            ok = real.ring_peak(*a)
            a[6].view(np.int64)[5] += 1
            return ok

    class OffExp(Off):
        def ring_peak(self, *a):
            return real.ring_peak(*a)

        def ring_exp(self, t, a, b, out):
            ok = real.ring_exp(t, a, b, out)
            if b == 0.0:
                out.view(np.int64)[::2][7] += 1
            return ok

    class OffAbs(Off):
        def ring_peak(self, *a):
            ok = real.ring_peak(*a)
            a[7].view(np.int64)[5] += 1
            return ok
    path, profile = os.path.join(SAMPLES, "prusa_klipper.gcode"), load_profile("voron24")
    monkeypatch.setattr(res, "USE_SOLVE", False)
    ref = _figures(path, profile, rg.Collector(profile, None, chunk_blocks=500))
    monkeypatch.setattr(res, "USE_SOLVE", True)
    for core, want in ((Off(), "peak"), (OffExp(), "decay"), (OffAbs(), None)):
        monkeypatch.setattr(fw, "_core", core)
        monkeypatch.setattr(res, "_SOLVE_OK", {})
        seen = _count_solves(monkeypatch)
        got = _figures(path, profile, rg.Collector(profile, None, chunk_blocks=500))
        assert _bits(got) == _bits(ref)
        assert res._SOLVE_OK
        if want is None:
            assert seen["n"] and seen["done"] == 0
            assert not any(res._SOLVE_OK.values())
        else:
            assert seen["n"] and seen["done"] == seen["n"]
            assert all(m[want == "peak"] for m in res._SOLVE_OK.values())


@need_solve
def test_ring_peak_is_peak_abs_r():
    rng = np.random.default_rng(5)
    for f, z in ((50.0, 0.1), (37.0, 0.03), (80.0, 0.4)):
        osc = Oscillator(f, z)
        n = 5000
        c = (rng.normal(size=n) + 1j * rng.normal(size=n)) * np.exp(rng.normal(size=n) * 3)
        c[:50] = 0.0
        c.real[50:100] = -0.0
        dur = rng.exponential(2.0 / osc.wd, n)
        dur[100:150] = 0.0
        out, out_abs = np.empty(n), np.empty(n)
        assert fw._core.ring_peak(c, dur, -osc.s, osc.wd, osc.wd, True, out, out_abs)
        assert np.array_equal(out_abs.view(np.int64), np.abs(c).view(np.int64))
        if res._peak_ok(fw._core, osc.s, osc.wd, True) == "numpy":
            continue        # numpy's arctan2 / exp are its AVX-512 loops, not libm's: numpy solves the peak
        assert np.array_equal(out.view(np.int64), _ref_peak_abs_r(osc, c, dur).view(np.int64))
        assert osc.peak_abs_r(c, dur).tobytes() == out.tobytes()
    dur[3] = np.inf
    assert not fw._core.ring_peak(c, dur, -osc.s, osc.wd, osc.wd, True, out, out_abs)


@need_solve
def test_x_parts_read_alls_memo(monkeypatch):
    """X's ramp stream takes most of its numbers from "all"'s memo: it is there (not yet
    cleared) when ramp's X stream solves, and cleared after the chunk."""
    profile = load_profile("prusa-mk3s")
    col = rg.Collector(profile, None, chunk_blocks=400)
    assert col.streams["x", "ramp"].src is col.streams["x", "all"].memo
    assert col.streams["y", "ramp"].src is None and col.streams["x", "all"].src is None
    memo = col.streams["x", "all"].memo
    seen = []
    orig = Oscillator.solve

    def spy(self, t, dr, drp, first, memo=None, keep=False, src=None, *more):
        if src is not None:
            seen.append(src.amps is not None and src.pieces is not None)
        return orig(self, t, dr, drp, first, memo, keep, src, *more)
    monkeypatch.setattr(Oscillator, "solve", spy)
    _figures(os.path.join(SAMPLES, "prusa_gyroid.gcode"), profile, col)
    assert seen and sum(seen) > 0.9 * len(seen)
    assert memo.amps is None and memo.pieces is None


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
    assert out == repr(got)
