"""Session 34, the ringing's CPU (helper "ring"); ring_solve's recursion since session 46:

- ring_solve tests no number for being finite on its way (jumps, amplitudes, pieces): one
  that is not makes an amplitude that is not finite from its event on (the recursion carries
  it), so the last amplitude, and ring_solve tests the integrals' sum and the last amplitude
  once at the end.  It must decline (None: the caller's steps) wherever a per-number test
  would: any NaN (of any bits, RING_DUR_NONE's among them) or infinity in t, dr, drp or
  first, at any event;
- max_abs_r's pieces (those whose |c| (1 + 1e-9) is not below max(floor, lo)) are picked
  while the integrals are made, against the running lo, and sifted by the final lo after:
  the caller's max (its floor and the peak returned) is max_abs_r's of every piece, to
  rounding (the amplitudes are the recursion's, numpy's steps' to ~1e-14), for floors
  below, at and above the amplitudes.
"""
import math

import numpy as np
import pytest

from ring_close import random_events
from gcode_opt.firmware import resonance as res
from gcode_opt.firmware import simulate as fw
from gcode_opt.firmware.resonance import Oscillator

CORE = fw._core
need_solve = pytest.mark.skipif(CORE is None or not hasattr(CORE, "ring_solve"),
                                reason="the compiled firmware core is not built here")

NOT_FINITE = (np.nan, -np.nan, np.inf, -np.inf,
              np.array([-1], np.int64).view(np.float64)[0],           # all bits set: RING_DUR_NONE's
              np.array([0x7FF0000000000001], np.int64).view(np.float64)[0])   # a signalling NaN


def _solve(osc, t, dr, drp, first, floor=0.0):
    return CORE.ring_solve(t, dr, drp, first, osc.s, osc.wd, *res._int_r2_args(osc.s, osc.lam), floor)


@need_solve
@pytest.mark.parametrize("seed", range(4))
def test_a_number_not_finite_anywhere_declines(seed):
    rng = np.random.default_rng(3400 + seed)
    osc = Oscillator(float(rng.uniform(20.0, 120.0)), float(rng.uniform(0.02, 0.5)))
    for trial in range(60):
        n = int(rng.integers(1, 400))
        t, dr, drp = random_events(rng, n)
        first = complex(rng.normal(), rng.normal()) * 1e-3 if rng.uniform() < 0.6 else None
        if first is not None:
            t = np.concatenate([[t[0] - rng.exponential(0.01)], t])
        off = first is not None
        bad = NOT_FINITE[trial % len(NOT_FINITE)]
        where = ["t", "dr", "drp"] + (["first"] if off else [])
        what = where[int(rng.integers(len(where)))]
        t2, dr2, drp2 = t.copy(), dr.copy(), drp.copy()
        f2 = first
        # the first, the last or any event
        if what == "first":
            f2 = complex(bad, 0.0) if rng.uniform() < 0.5 else complex(0.0, bad)
        else:
            arr = {"t": t2, "dr": dr2, "drp": drp2}[what]
            k = int(rng.choice([0, len(arr) - 1, int(rng.integers(len(arr)))]))
            arr[k] = bad
        assert _solve(osc, t2, dr2, drp2, f2) is None, (what, bad, n)
        # the same events all finite: solved (the test above is not vacuous)
        assert _solve(osc, t, dr, drp, first) is not None


@need_solve
def test_an_infinite_amplitude_with_finite_inputs_declines():
    """A finite jump large enough that the amplitude overflows: declined (as the per-piece
    test declined it), not a sum of inf."""
    osc = Oscillator(50.0, 0.1)
    t = np.array([0.0, 0.01, 0.02, 0.03])
    dr = np.array([1e308, 1e308, 0.0, 0.0])
    assert _solve(osc, t, dr, np.zeros(4), None) is None


def _amplitudes(osc, t, dr, drp, first):
    """The amplitudes ring_solve makes (the steps': numpy's jumps and restarts)."""
    keep, res.USE_KERNEL = res.USE_KERNEL, False
    try:
        dc = osc.jump_amplitude(dr, drp)
        if first is not None:
            dc = np.concatenate([[first], dc])
        return osc.amplitudes(t, dc)
    finally:
        res.USE_KERNEL = keep


@need_solve
@pytest.mark.parametrize("seed", range(3))
def test_max_abs_r_pieces_and_peak(seed):
    rng = np.random.default_rng(3410 + seed)
    osc = Oscillator(50.0, 0.1)
    for trial in range(40):
        n = int(rng.integers(2, 3000))
        t, dr, drp = random_events(rng, n)
        if trial % 4 == 1:            # amplitudes that grow: many pieces stay above the running lo
            dr *= np.geomspace(1e-6, 1.0, n)
            drp *= np.geomspace(1e-6, 1.0, n)
        c = _amplitudes(osc, t, dr, drp, None)
        dur = np.diff(t)
        cp = c[:-1]
        lo = np.abs(cp.real).max()
        mags = np.abs(cp)
        floor = [0.0, 0.5 * lo, lo, 2.0 * lo, float(rng.choice(mags)),
                 float(rng.choice(mags)) * (1.0 + 1e-9), float(mags.max()) * 1.1][trial % 7]
        got = _solve(osc, t, dr, drp, None, floor=floor)
        assert got is not None and math.isfinite(got[0])
        # the caller's max: max(floor, peak) is max_abs_r's over every piece (to rounding: the
        # amplitudes are the recursion's); the peak itself is at least lo, and is max_abs_r's
        # where the floor rules nothing out
        want_pk = float(osc.peak_abs_r(cp, dur).max())
        assert max(floor, got[1]) == pytest.approx(max(floor, want_pk), rel=1e-12)
        assert got[1] >= lo * (1.0 - 1e-12)
        if floor == 0.0:
            assert got[1] == pytest.approx(want_pk, rel=1e-12)


@need_solve
def test_ring_jumps_is_numpys_to_the_zeros_sign():
    """ring_jumps (ring_solve's jumps) against numpy's jump_amplitude bit for bit on zeros of
    both signs, x = drp + s dr exactly 0 either way, subnormals and numbers near overflow;
    declined at a jump that is not finite."""
    rng = np.random.default_rng(3420)
    n = 200000
    special = np.array([0.0, -0.0, 5e-324, -5e-324, 2.2e-308, 1e-300, 1e300, -1e300, 1.7e308, -1.7e308])
    for wd_scale in (1.0, 1e-3, 1e3):
        osc = Oscillator(float(rng.uniform(20.0, 120.0)) * wd_scale, float(rng.uniform(0.02, 0.5)))
        dr = rng.normal(size=n) * np.exp(rng.normal(size=n) * 40.0)
        drp = rng.normal(size=n) * np.exp(rng.normal(size=n) * 40.0)
        for a in (dr, drp):
            k = rng.uniform(size=n) < 0.2
            a[k] = rng.choice(special, int(k.sum()))
        k = rng.uniform(size=n) < 0.05
        with np.errstate(all="ignore"):
            drp[k] = -osc.s * dr[k]                  # x exactly 0 (of either sign)
            ok = np.isfinite(drp + osc.s * dr)       # (where it overflows numpy's NaN is its own)
            want = dr[ok] - 1j * (drp[ok] + osc.s * dr[ok]) / osc.wd
        got = np.empty(int(ok.sum()), complex)
        assert CORE.ring_jumps(dr[ok], drp[ok], osc.s, osc.wd, got)
        assert got.tobytes() == want.tobytes()
        for bad in (np.nan, np.inf, -np.inf):
            d2 = dr[ok].copy()
            d2[len(d2) // 2] = bad
            assert not CORE.ring_jumps(d2, drp[ok], osc.s, osc.wd, got)
            assert not CORE.ring_jumps(drp[ok], d2, osc.s, osc.wd, got)


@need_solve
def test_the_events_room_is_kept_and_the_figures_stay(monkeypatch):
    """A Collector's _events write every chunk into one Room (views of one array); the
    figures are those of fresh arrays a chunk."""
    import os

    from gcode_opt import ringing as rg
    from gcode_opt.profile import load_profile
    path = os.path.join(os.path.dirname(__file__), "..", "sample_gcode", "prusa_gyroid.gcode")
    profile = load_profile("prusa-mk3s")
    arrays = []
    orig = rg._events

    def spy(m, c, model, parts=True, room=None, *lead):
        got = orig(m, c, model, parts, room, *lead)
        arrays.append(room.arr)
        return got
    monkeypatch.setattr(rg, "_events", spy)
    col = rg.Collector(profile, chunk_blocks=300)
    rg.play(path, profile, col)
    kept = col.figures()
    assert len(arrays) > 5 and all(a is arrays[0] for a in arrays)
    monkeypatch.setattr(rg, "_events", orig)
    monkeypatch.setattr(res.Room, "grab", lambda self, need: np.full(need, np.nan))
    col = rg.Collector(profile, chunk_blocks=300)
    rg.play(path, profile, col)
    assert repr(col.figures()) == repr(kept)
