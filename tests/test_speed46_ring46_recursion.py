"""Session 46, the ringing's CPU (helper "ring46"): the core's ring_solve makes a chunk's
amplitudes by their recursion, c_k = c_(k-1) exp(lam d) + dc_k over each piece of length d,
with each length's numbers (exp(lam d) and the piece's r^2 integral's two scalars) made once
in a table kept from call to call -- not by numpy's restarts of a cumulative sum, whose
exponentials (exp(+-lam tt) of every event's time in its restart, libm's exp twice and sincos)
were most of its cost, nor with the memo of X's exponentials that Y's stream read.  Not the
same bits: the figures move by ~4e-14 relative on the plates, towards the exact ones.

Reference (independent of both codes): the exact piecewise solution of the oscillator in
long double (numpy's 80-bit extended precision, 64-bit significand): the jumps' amplitudes,
the amplitudes by a cumulative sum of dc exp(-lam (t - t_w)) in windows of WINDOW_T (the
exponentials' arguments small: exact to ~1e-18), each piece's integral of r^2 in closed form
with expm1 (no cancellation for short pieces) and its peak at the start, the end and the first
extremum.  Tolerances: the recursion's figures within TOL = 1e-14 relative of it (measured
~2e-16: a few ulps; the numpy steps' own error was 1.3e-14 to 3.3e-14 on these files), on
real files solved in one chunk (the same event times as the whole trace: chunk cuts round
the times otherwise, ~1e-11, tests/test_ringing_stream.py), and on random event streams
(events at one time, long pauses, a carried amplitude, both branches of the division by
4 lam); the figures of numpy's steps within ring_close.REL (1e-12) of the new ones, on the
samples and the corpus plates (the pure-Python path's: test_speed20_ring_solve.py)."""
import math
import os

import numpy as np
import pytest

from ring_close import assert_figures_close, random_events
from gcode_opt import ringing as rg
from gcode_opt.firmware import resonance as res
from gcode_opt.firmware import simulate as fw
from gcode_opt.firmware.resonance import Oscillator
from gcode_opt.profile import load_profile

CORE = fw._core
need_solve = pytest.mark.skipif(CORE is None or not hasattr(CORE, "ring_solve"),
                                reason="the compiled firmware core is not built here")
SAMPLES = os.path.join(os.path.dirname(__file__), "..", "sample_gcode")
CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus")
TOL = 1e-14
WINDOW_T = 0.25           # the reference's windows: exp(s 0.25) <= e^26 for the plates' oscillators

LD, CLD = np.longdouble, np.clongdouble
I_LD = np.array([1j], CLD)[0]
PI_LD = np.arccos(LD(-1))


def _osc_ld(freq_hz, damping_r):
    """(s, wd, lam) in long double."""
    w = 2 * PI_LD * LD(freq_hz)
    z = LD(damping_r)
    s, wd = z * w, w * np.sqrt(1 - z * z)
    return s, wd, -s + I_LD * wd


def _ref_stream(t, dr, drp, freq_hz, damping_r, first=None, tail=True):
    """(int r^2 dt, peak |r|, last amplitude) of the events at t (sorted) with jumps dr, drp,
    exactly to long double rounding: after `first` (an amplitude at t[0], then dr, drp are
    the later events') or from rest; tail: the last amplitude rings down to rest (a
    stream's finish), else its piece is not counted (a ring_solve call's)."""
    s, wd, lam = _osc_ld(freq_hz, damping_r)
    t = np.asarray(t).astype(LD)
    dr, drp = np.asarray(dr).astype(LD), np.asarray(drp).astype(LD)
    dc = dr.astype(CLD) - I_LD * ((drp + s * dr) / wd).astype(CLD)
    if first is not None:
        dc = np.concatenate([np.array([first], CLD), dc])
    c = np.empty(len(t), CLD)
    start, carry, t_carry = 0, CLD(0), t[0]
    while start < len(t):
        t0 = t[start]
        stop = max(int(np.searchsorted(t, t0 + LD(WINDOW_T), side="right")), start + 1)
        tt = (t[start:stop] - t0).astype(CLD)
        c0 = carry * np.exp(lam * CLD(t0 - t_carry))
        c[start:stop] = (c0 + np.cumsum(dc[start:stop] * np.exp(-lam * tt))) * np.exp(lam * tt)
        carry, t_carry, start = c[stop - 1], t[stop - 1], stop
    d = np.append(np.diff(t), LD(np.inf))
    cc = c if tail else c[:-1]
    d = d if tail else d[:-1]
    fin = np.isfinite(d)
    dd = np.where(fin, d, 0)
    one_m = np.where(fin, -np.expm1(-2 * s * dd), 1)                  # 1 - exp(-2 s d)
    a, b = -2 * s * dd, 2 * wd * dd                                     # exp(2 lam d) - 1:
    em1 = (np.expm1(a) * np.cos(b) - 2 * np.sin(b / 2) ** 2) + I_LD * (np.exp(a) * np.sin(b))
    em1 = np.where(fin, em1, CLD(-1))
    i_r2 = (np.abs(cc) ** 2 * one_m / (4 * s) + np.real(cc * cc * em1 / (4 * lam))).sum()
    best = np.abs(cc.real)
    end = np.where(fin, np.abs(np.real(cc * np.exp(lam * dd.astype(CLD)))), 0)
    tau = np.mod(PI_LD / 2 - np.angle(lam * cc), PI_LD) / wd
    ext = np.where((tau < d) | ~fin, np.abs(np.real(cc * np.exp(lam * tau.astype(CLD)))), 0)
    peak = np.maximum(best, np.maximum(end, ext)).max() if len(cc) else LD(0)
    return i_r2, peak, c[-1]


def _ref_figures(tr, model):
    """{'x.rms_um', ...}: the per-axis figures of a whole trace, by _ref_stream."""
    out = {}
    for ax, name in enumerate("xy"):
        for part in ("all",) + rg.PARTS:
            dr, drp = rg._jumps(tr, model, name, ax, part)             # the jumps as the code takes them
            dr = np.zeros(len(tr)) if dr is None else dr
            drp = np.zeros(len(tr)) if drp is None else drp
            keep = (dr != 0.0) | (drp != 0.0)
            i_r2, peak, _c = _ref_stream(tr.t0[keep], dr[keep], drp[keep], model[f"freq_{name}_hz"],
                                         model["damping_r"])
            key = "" if part == "all" else "_" + part
            out[f"{name}.rms{key}_um"] = float(np.sqrt(i_r2 / LD(tr.total_t)) * 1000)
            out[f"{name}.peak{key}_um"] = float(peak * 1000)
    return out


def _collector_figures(path, profile, chunk=10 ** 7):
    col = rg.Collector(profile, "none", chunk_blocks=chunk)
    rg.play(path, profile, col)
    return col.figures()


FILES = [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24"),
         ("cura_box.gcode", "ender3"), ("prusa_gyroid.gcode", "prusa-mk3s")]


@need_solve
@pytest.mark.parametrize("name,prof", FILES, ids=[f[0] for f in FILES])
def test_figures_of_real_files_against_the_exact_solution(name, prof, monkeypatch):
    monkeypatch.setattr(res, "PROBE_AFTER", 0)
    path, profile = os.path.join(SAMPLES, name), load_profile(prof)
    tr = rg.trace(path, profile)
    want = _ref_figures(tr, rg.model_of(profile))
    calls = []
    solve = Oscillator.solve

    def spy(self, *a, **k):
        got = solve(self, *a, **k)
        calls.append(got is not None)
        return got
    monkeypatch.setattr(Oscillator, "solve", spy)
    monkeypatch.setattr(res, "USE_JOIN", False)     # (Oscillator.solve's own calls: Oscillator.join takes the streams' steps otherwise, test_speed58_ring_join)
    got = _collector_figures(path, profile)                   # one chunk: the trace's event times
    assert calls and all(calls)                               # the core solved every call
    flat = {f"{a}.{k}": v for a in "xy" for k, v in got[a].items()}
    assert flat.keys() == want.keys()
    for k, v in want.items():
        assert flat[k] == pytest.approx(v, rel=TOL, abs=1e-300), k
    assert want["x.rms_um"] > 0.5 and want["y.peak_corner_um"] > 0.5     # they ring: not 0 == 0


@need_solve
@pytest.mark.parametrize("damping", [0.1, 0.03, 0.8])      # 0.8: the division's other branch
def test_ring_solve_against_the_exact_solution(damping):
    rng = np.random.default_rng(4600 + int(damping * 100))
    freq = 50.0
    osc = Oscillator(freq, damping)
    assert res._int_r2_args(osc.s, osc.lam)[5] == (damping > 0.5 ** 0.5)
    for trial in range(30):
        n = int(rng.integers(2, 3000))
        t, dr, drp = random_events(rng, n)
        first = None
        if trial % 2:                                           # a carried amplitude at t[0]
            first = complex(rng.normal(), rng.normal()) * 1e-3
            dr, drp = dr[1:], drp[1:]
        got = CORE.ring_solve(t, dr, drp, first, osc.s, osc.wd, *res._int_r2_args(osc.s, osc.lam))
        i_r2, peak, c_last = _ref_stream(t, dr, drp, freq, damping, first, tail=False)
        assert got[0] == pytest.approx(float(i_r2), rel=TOL), trial
        assert got[1] == pytest.approx(float(peak), rel=TOL), trial
        # the last amplitude: to TOL of the amplitudes' scale (it may be a small remainder)
        assert abs(got[2] - complex(c_last)) <= TOL * 10 * float(np.abs(c_last)) + 1e-300 or \
            abs(got[2] - complex(c_last)) <= 1e-13 * float(peak), trial


@need_solve
def test_the_table_serves_any_order_of_oscillators():
    """Lengths met again after other oscillators took the table's room (X and Y at other
    frequencies alternate; a third evicts one): the same numbers as a fresh table."""
    rng = np.random.default_rng(4610)
    t, dr, drp = random_events(rng, 2000)
    t = np.round(t, 3)                                # few lengths, met over and over
    oscs = [Oscillator(f, 0.1) for f in (40.0, 55.0, 70.0)]
    fresh = {}
    for o in oscs:
        CORE.ring_release()
        fresh[o.s] = CORE.ring_solve(t, dr, drp, None, o.s, o.wd, *res._int_r2_args(o.s, o.lam))
    CORE.ring_release()
    for k in (0, 1, 0, 1, 2, 0, 2, 1, 1):
        o = oscs[k]
        assert CORE.ring_solve(t, dr, drp, None, o.s, o.wd, *res._int_r2_args(o.s, o.lam)) == fresh[o.s]


def _numpy_steps_figures(path, profile, monkeypatch, shaper="none"):
    """The figures by numpy's steps (the core's solve off: the old code's numbers)."""
    with monkeypatch.context() as m:
        m.setattr(res, "USE_SOLVE", False)
        col = rg.Collector(profile, shaper)
        rg.play(path, profile, col)
        return col.figures()


@need_solve
@pytest.mark.parametrize("shaper", ["none", "mzv"])
@pytest.mark.parametrize("name,prof", FILES, ids=[f[0] for f in FILES])
def test_figures_are_numpys_steps_to_rounding(name, prof, shaper, monkeypatch):
    monkeypatch.setattr(res, "PROBE_AFTER", 0)
    path, profile = os.path.join(SAMPLES, name), load_profile(prof)
    ref = _numpy_steps_figures(path, profile, monkeypatch, shaper)
    col = rg.Collector(profile, shaper)
    rg.play(path, profile, col)
    got = col.figures()
    assert_figures_close(got, ref)
    assert got["xy"]["rms_um"] > 0.5


@need_solve
@pytest.mark.parametrize("plate", ["plate_rectilinear.gcode", "plate_gyroid.gcode"])
def test_plate_figures_are_numpys_steps_to_rounding(plate, monkeypatch):
    path = os.path.join(CORPUS, plate)
    if not os.path.exists(path):
        pytest.skip(f"{plate} not in the corpus")
    profile = load_profile("prusa-mk3s")
    ref = _numpy_steps_figures(path, profile, monkeypatch)
    got = rg.figures(path, profile)
    assert_figures_close(got, ref)


@need_solve
def test_ring_solve_gives_back_none_for_one_event_and_checks_lengths():
    osc = Oscillator(50.0, 0.1)
    args = res._int_r2_args(osc.s, osc.lam)
    one = CORE.ring_solve(np.array([1.0]), np.array([1e-4]), np.array([0.0]), None, osc.s, osc.wd, *args)
    assert one[0] is None and one[1] is None and one[2] == osc.jump_amplitude(np.array([1e-4]), np.zeros(1))[0]
    assert CORE.ring_solve(np.zeros(0), np.zeros(0), np.zeros(0), None, osc.s, osc.wd, *args) is None
    with pytest.raises(ValueError):
        CORE.ring_solve(np.zeros(3), np.zeros(2), np.zeros(3), None, osc.s, osc.wd, *args)
    with pytest.raises(ValueError):
        CORE.ring_solve(np.zeros(3), np.zeros(3), np.zeros(3), 1j, osc.s, osc.wd, *args)
    assert math.isfinite(CORE.ring_solve(np.arange(3.0), np.ones(3) * 1e-4, np.zeros(3), None, osc.s, osc.wd,
                                         *args)[0])
