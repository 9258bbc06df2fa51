"""ring_solve with numpy's two steps (issue 8, round 23): where numpy's own SIMD loops are
not libm's (AVX-512: its float64 exp and arctan2), the core's one-call solve used to be
turned off whole (its probes failed) and every chunk took the step-by-step path.  Now
Oscillator.solve hands ring_solve numpy's np.exp(-2 s dur) (decay2) and solves, with numpy's
peak_abs_r, the pieces ring_solve hands back (numpy_peak): the rest stays in the core.

Reference: the steps (resonance.USE_SOLVE off), with every compiled ringing step off
(USE_KERNEL off: numpy alone), on sample files with and without shapers, chunks forced
small, and on the corpus' plate; and ring_solve's numbers against the numpy steps on random
events.  resonance.SOLVE_NUMPY forces the numpy steps where the core would match them (an
AVX2 machine) so the path is tested everywhere."""
import math
import os

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
pytestmark = pytest.mark.skipif(not HAS_SOLVE, reason="the compiled firmware core is not built here")


def _bits(d):
    if isinstance(d, dict):
        return {k: _bits(v) for k, v in d.items()}
    if isinstance(d, float):
        return np.float64(d).tobytes()
    return d


def _figures(path, profile, shaper, chunk):
    col = rg.Collector(profile, shaper, chunk_blocks=chunk)
    rg.play(path, profile, col)
    return col.figures()


def _reference(monkeypatch, path, profile, shaper, chunk):
    """The step-by-step solve by numpy alone."""
    with monkeypatch.context() as m:
        m.setattr(res, "USE_SOLVE", False)
        m.setattr(res, "USE_KERNEL", False)
        return _figures(path, profile, shaper, chunk)


def _count_solves(monkeypatch):
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
         ("prusa_klipper.gcode", "voron24", "ei", 700),
         ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", "mzv", 400)]


@pytest.mark.parametrize("forced", [True, False])
@pytest.mark.parametrize("name,prof,shaper,chunk", CASES)
def test_figures_equal_numpys_steps(monkeypatch, name, prof, shaper, chunk, forced):
    path = os.path.join(SAMPLES, name)
    if not os.path.exists(path):
        pytest.skip(f"{name} not in sample_gcode")
    profile = load_profile(prof)
    ref = _reference(monkeypatch, path, profile, shaper, chunk)
    monkeypatch.setattr(res, "SOLVE_NUMPY", forced)
    seen = _count_solves(monkeypatch)
    got = _figures(path, profile, shaper, chunk)
    assert _bits(got) == _bits(ref)
    assert seen["n"] and seen["done"] == seen["n"]         # ring_solve did every chunk
    assert ref["xy"]["rms_um"] > 0.0 and ref["xy"]["peak_um"] > 0.0


def test_plate_figures_equal_numpys_steps(monkeypatch):
    path = os.path.join(CORPUS, "plate_rectilinear.gcode")
    if not os.path.exists(path):
        pytest.skip("plate_rectilinear.gcode not in the corpus")
    profile = load_profile("prusa-mk3s")
    with monkeypatch.context() as m:
        m.setattr(res, "USE_SOLVE", False)           # the steps (compiled where they are checked)
        ref = _figures(path, profile, None, rg.CHUNK_BLOCKS)
    monkeypatch.setattr(res, "SOLVE_NUMPY", True)
    seen = _count_solves(monkeypatch)
    assert _bits(_figures(path, profile, None, rg.CHUNK_BLOCKS)) == _bits(ref)
    assert seen["n"] and seen["done"] == seen["n"]


def _events(rng, n):
    gaps = rng.exponential(0.004, n) * (rng.uniform(size=n) < 0.9)
    gaps[rng.uniform(size=n) < 0.005] *= 300.0
    t = np.cumsum(gaps)
    dr = rng.normal(size=n) * 1e-4 * (rng.uniform(size=n) < 0.7)
    drp = rng.normal(size=n) * 1e-2 * (rng.uniform(size=n) < 0.5)
    return t, dr, drp


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ring_solve_numpy_steps_on_random_events(seed):
    """ring_solve(decay2 = numpy's, numpy_peak) against the steps by numpy: the sum, the
    pieces it hands back (those max_abs_r keeps), the peak numpy makes of them, the last
    amplitude."""
    rng = np.random.default_rng(seed)
    osc = Oscillator((50.0, 37.0, 80.0)[seed], (0.1, 0.03, 0.4)[seed])
    got = res._solve_core(osc.s, osc.wd)
    if got is None:
        pytest.skip("the core's solve is not checked for this oscillator here")
    core, span, fused, _d, _p = got
    t, dr, drp = _events(rng, 3000)
    first = complex(rng.normal(), rng.normal()) * 1e-3
    decay2 = np.exp(-2.0 * osc.s * np.diff(t))
    ret = core.ring_solve(t, dr[1:], drp[1:], first, osc.s, osc.wd, span, res.ELIDE_BYTES // 16, fused,
                          *res._int_r2_args(osc.s, osc.lam), None, None, None, None, decay2, True)
    assert ret is not None and len(ret) == 5
    i_r2, lo, c_last, kc, kd = ret
    # the steps, numpy alone
    keep_kernel, res.USE_KERNEL = res.USE_KERNEL, False
    try:
        dc = np.concatenate([[first], osc.jump_amplitude(dr[1:], drp[1:])])
        c = osc.amplitudes(t, dc)
        dur = np.diff(t)
        want_sum = float(osc.integral_r2_fin(c[:-1], dur).sum())
        want_peak = osc.max_abs_r(c[:-1], dur)
    finally:
        res.USE_KERNEL = keep_kernel
    assert np.float64(i_r2).tobytes() == np.float64(want_sum).tobytes()
    assert complex(c_last) == complex(c[-1])
    cc = c[:-1]
    want_lo = np.abs(cc.real).max()
    keep = ~(np.abs(cc) * (1.0 + 1e-9) < want_lo)
    assert np.float64(lo).tobytes() == want_lo.tobytes()
    assert np.frombuffer(kc, complex).tobytes() == cc[keep].tobytes()
    assert np.frombuffer(kd, float).tobytes() == dur[keep].tobytes()
    assert 0 < keep.sum() < len(keep)
    # and Oscillator.solve puts them together as max_abs_r does
    peak = float(np.maximum(np.float64(lo), osc.peak_abs_r(np.frombuffer(kc, complex),
                                                           np.frombuffer(kd, float)).max()))
    assert np.float64(peak).tobytes() == np.float64(want_peak).tobytes()


def test_solve_numpy_mode_through_oscillator(monkeypatch):
    """Oscillator.solve in the forced numpy mode gives the core mode's and the steps' numbers
    (sum, peak, last amplitude) on events with a carried amplitude."""
    osc = Oscillator(50.0, 0.1)
    if res._solve_core(osc.s, osc.wd) is None:
        pytest.skip("the core's solve is not checked for this oscillator here")
    rng = np.random.default_rng(23)
    t, dr, drp = _events(rng, 5000)
    monkeypatch.setattr(res, "SOLVE_NUMPY", True)
    got = osc.solve(t, dr[1:], drp[1:], 1e-4 + 2e-4j)
    assert got is not None
    monkeypatch.setattr(res, "USE_KERNEL", False)
    dc = np.concatenate([[1e-4 + 2e-4j], osc.jump_amplitude(dr[1:], drp[1:])])
    c = osc.amplitudes(t, dc)
    dur = np.diff(t)
    want = (float(osc.integral_r2_fin(c[:-1], dur).sum()), osc.max_abs_r(c[:-1], dur), complex(c[-1]))
    assert _bits({"s": got[0], "p": got[1]}) == _bits({"s": want[0], "p": want[1]})
    assert got[2] == want[2]
    assert math.isfinite(got[1]) and got[1] > 0.0


def test_bad_decay2_raises_and_nonfinite_declines():
    osc = Oscillator(50.0, 0.1)
    got = res._solve_core(osc.s, osc.wd)
    if got is None:
        pytest.skip("the core's solve is not checked for this oscillator here")
    core, span, fused, _d, _p = got
    t, dr, drp = _events(np.random.default_rng(3), 50)
    args = (t, dr, drp, None, osc.s, osc.wd, span, 100, fused, *res._int_r2_args(osc.s, osc.lam),
            None, None, None, None)
    with pytest.raises(ValueError):
        core.ring_solve(*args, np.ones(3), False)             # not one number a piece
    d2 = np.exp(-2.0 * osc.s * np.diff(t))
    d2[7] = np.nan
    assert core.ring_solve(*args, d2, True) is None          # the caller takes the steps
    assert core.ring_solve(*args, None, False) is not None   # still usable


# ---------------------------------------------------------------- floor and pending pieces
@pytest.mark.parametrize("pend_pieces", [1, 50, 1 << 16])
@pytest.mark.parametrize("name,prof,shaper,chunk", [CASES[1], CASES[3]])
def test_pending_pieces_settled_any_time(monkeypatch, name, prof, shaper, chunk, pend_pieces):
    """The streams' pieces left for numpy's peak (solved every pend_pieces, and at finish)
    give the steps' figures."""
    path = os.path.join(SAMPLES, name)
    if not os.path.exists(path):
        pytest.skip(f"{name} not in sample_gcode")
    profile = load_profile(prof)
    ref = _reference(monkeypatch, path, profile, shaper, chunk)
    monkeypatch.setattr(res, "SOLVE_NUMPY", True)
    monkeypatch.setattr(rg, "PEND_PIECES", pend_pieces)
    settled = []
    orig = Oscillator.pending_peak

    def spy(self, pending):
        settled.append(len(pending))
        return orig(self, pending)
    monkeypatch.setattr(Oscillator, "pending_peak", spy)
    assert _bits(_figures(path, profile, shaper, chunk)) == _bits(ref)
    assert settled and max(settled) > 0
    if pend_pieces == 1:
        assert len(settled) > 8         # mid-run too, not only at the 8 streams' finish


def test_floor_rules_out_pieces_not_the_peak():
    """ring_solve's floor: pieces below a peak the caller has are not handed back (nor
    solved, in the core's peak), and the caller's max is unchanged."""
    osc = Oscillator(50.0, 0.1)
    got = res._solve_core(osc.s, osc.wd)
    if got is None:
        pytest.skip("the core's solve is not checked for this oscillator here")
    core, span, fused, _d, _p = got
    t, dr, drp = _events(np.random.default_rng(29), 4000)
    decay2 = np.exp(-2.0 * osc.s * np.diff(t))
    args = (t, dr, drp, None, osc.s, osc.wd, span, res.ELIDE_BYTES // 16, fused,
            *res._int_r2_args(osc.s, osc.lam), None, None, None, None, decay2)
    i0, lo, c0, kc0, kd0 = core.ring_solve(*args, True)
    assert core.ring_solve(*args, True, 0.0) == (i0, lo, c0, kc0, kd0)
    full = osc.pending_peak([(kc0, kd0)])
    assert full >= lo
    for floor in (0.5 * lo, lo, 0.5 * (lo + full), full, 2.0 * full):
        i1, lo1, c1, kc1, kd1 = core.ring_solve(*args, True, floor)
        assert (i1, lo1, c1) == (i0, lo, c0)
        assert len(kd1) <= len(kd0)
        if floor <= lo:
            assert kd1 == kd0
        if floor > full * (1.0 + 1e-8):
            assert kd1 == b""
        # the caller's max: max(floor-ish earlier peak, lo, the pieces') is the full one's
        assert max(full, lo, osc.pending_peak([(kc1, kd1)])) == max(full, lo)
        assert max(floor, lo, osc.pending_peak([(kc1, kd1)])) == max(floor, full)
        # the core's own peak (its bits where the probe says so) obeys the same
        p_core = core.ring_solve(*args, False, floor)[1]
        p_none = core.ring_solve(*args, False, 0.0)[1]
        assert max(floor, p_core) == max(floor, p_none)
