"""Session 38, the ringing's CPU (helper "ringc"): ring_int_r2_run's pieces of length +0.

About half a file's pieces last 0 (a block without cruise: two events at one time).  Such a
piece, once its exp(q 0) is 1 + 0i and its decay2 is 1, has v = +0 exactly for |c| below
RING_ZERO_BIG (1e150), and is a max_abs_r candidate as before (its |c| made only where a
bound does not rule it out).  Held here to the code it replaces, bit for bit:

- ring_int_r2's per-piece values (its work array) against the same pieces each in a call
  of its own (the first zero-length piece of a call takes the general steps): zeros of
  both signs in c and dur, |c| on both sides of 1e150, infinities, a decay2 that is not 1
  at a zero-length piece, with and without the memo's out part;
- ring_solve against numpy's steps: the sum, the peak, the last amplitude, the pieces it
  hands back to numpy (max_abs_r's, zero-length ones among them, for floors at their |c|),
  and the pieces' exponentials it keeps for the next stream.
"""
import math

import numpy as np
import pytest

from gcode_opt.firmware import resonance as res
from gcode_opt.firmware import simulate as fw
from gcode_opt.firmware.resonance import Oscillator

CORE = fw._core
need_core = pytest.mark.skipif(CORE is None or not hasattr(CORE, "ring_solve"),
                               reason="the compiled firmware core is not built here")


def _amps(rng, n, zero_share):
    """n complex amplitudes of varied sizes and both zeros; n durations, zero_share of them +0."""
    c = (rng.normal(size=n) + 1j * rng.normal(size=n)) * np.exp(rng.normal(size=n) * 8.0)
    k = rng.uniform(size=n)
    c[k < 0.03] = complex(0.0, 0.0)
    c[(k >= 0.03) & (k < 0.06)] = complex(-0.0, -0.0)
    c.real[(k >= 0.06) & (k < 0.09)] = -0.0
    c.imag[(k >= 0.09) & (k < 0.12)] = 0.0
    big = (k >= 0.12) & (k < 0.2)        # about RING_ZERO_BIG: both sides
    c[big] = (rng.choice([1.0, -1.0], big.sum()) * 1e150 * rng.choice([0.999999, 1.0, 1.000001, 1e5], big.sum())
              + 1j * rng.normal(size=big.sum()))
    swap = big & (rng.uniform(size=n) < 0.5)
    c[swap] = 1j * c[swap]
    dur = rng.exponential(0.01, n)
    dur[rng.uniform(size=n) < zero_share] = 0.0
    dur[rng.uniform(size=n) < 0.02] = -0.0
    return c, dur


@need_core
@pytest.mark.parametrize("seed", range(4))
def test_int_r2_values_are_the_general_steps(seed):
    rng = np.random.default_rng(3800 + seed)
    osc = Oscillator(float(rng.uniform(20.0, 120.0)), float(rng.uniform(0.02, 0.5)))
    args = res._int_r2_args(osc.s, osc.lam)
    for trial in range(12):
        n = int(rng.integers(2, 800))
        c, dur = _amps(rng, n, (0.5, 0.9, 0.1)[trial % 3])
        decay2 = np.exp(-2.0 * osc.s * dur)
        if trial % 4 == 3:              # a decay2 not 1 at some zero-length pieces: no shortcut there
            odd = (dur == 0.0) & (rng.uniform(size=n) < 0.3)
            decay2[odd] = rng.choice([0.5, 1.0 - 2.0 ** -52, 1.0 + 2.0 ** -52], odd.sum())
        if trial % 6 == 5:              # an infinite |c| at a zero-length piece (checks: None)
            c[int(np.flatnonzero(dur == 0.0)[-1])] = complex(np.inf, 1.0)
        ts = np.cumsum(rng.exponential(0.01, n)) if trial % 2 else None
        extra = (ts, None, None, None, np.empty(3 * n)) if ts is not None else ()
        work = np.empty(n)
        got = CORE.ring_int_r2(c, dur, decay2, *args, work, *extra)
        # the reference: each piece alone (its own call: the general steps for every piece)
        want = np.empty(n)
        want_ov = np.empty(3 * n)
        want_ok = True
        for i in range(n):
            one = np.empty(1)
            e1 = (ts[i:i + 1], None, None, None, want_ov[3 * i:3 * i + 3]) if ts is not None else ()
            r = CORE.ring_int_r2(c[i:i + 1], dur[i:i + 1], decay2[i:i + 1], *args, one, *e1)
            if r is None:
                want_ok = False
                break
            want[i] = one[0]
        if not want_ok:
            assert got is None
            continue
        assert got is not None
        assert work.tobytes() == want.tobytes()
        if ts is not None:
            assert extra[4].tobytes() == want_ov.tobytes()
        assert (dur == 0.0).sum() > 1 and (want == 0.0).any()       # (zero-length pieces were there)


def _events(rng, n):
    gaps = rng.exponential(0.01, n) * (rng.uniform(size=n) < 0.5)
    gaps[rng.uniform(size=n) < 0.01] *= 1e3
    t = np.cumsum(gaps) + rng.uniform(-5, 5)
    dr = rng.normal(size=n) * 1e-4 * (rng.uniform(size=n) < 0.8)
    drp = rng.normal(size=n) * 10.0 * (rng.uniform(size=n) < 0.5)
    return t, dr, drp


def _numpy_amplitudes(osc, t, dr, drp):
    keep, res.USE_KERNEL = res.USE_KERNEL, False
    try:
        return osc.amplitudes(t, osc.jump_amplitude(dr, drp))
    finally:
        res.USE_KERNEL = keep


@need_core
@pytest.mark.parametrize("seed", range(3))
def test_solve_against_numpy_with_many_zero_length_pieces(seed):
    osc = Oscillator((50.0, 37.0, 80.0)[seed], (0.1, 0.03, 0.4)[seed])
    got = res._solve_core(osc.s, osc.wd)
    if got is None:
        pytest.skip("the core's solve is not checked for this oscillator here")
    rng = np.random.default_rng(3810 + seed)
    s, wd = osc.s, osc.wd
    span = res.CHUNK_DECAY / s
    for trial in range(16):
        n = int(rng.integers(2, 2500))
        t, dr, drp = _events(rng, n)
        c = _numpy_amplitudes(osc, t, dr, drp)
        cp, dur = c[:-1], np.diff(t)
        zero = dur == 0.0
        mags = np.abs(cp)
        lo = np.abs(cp.real).max()
        # floors at zero-length pieces' |c| (and just above): the candidate test's edge
        zm = mags[zero] if zero.any() else mags
        floor = [0.0, float(rng.choice(zm)), float(rng.choice(zm)) * (1.0 + 1e-9),
                 float(rng.choice(zm)) * (1.0 - 1e-12), 0.5 * lo][trial % 5]
        keep = ~(mags * (1.0 + 1e-9) < max(floor, lo))
        decay2 = np.exp(-2.0 * s * dur)
        p_out = (np.empty(n - 1), np.empty(3 * (n - 1)))
        ret = CORE.ring_solve(t, dr, drp, None, s, wd, span, res.ELIDE_BYTES // 16, True,
                              *res._int_r2_args(s, osc.lam), None, None, None, p_out, decay2, True, floor)
        assert ret is not None and len(ret) == 5
        i_r2, lo_got, c_last, kc, kd = ret
        keep_k, res.USE_KERNEL = res.USE_KERNEL, False
        try:
            want_sum = float(osc.integral_r2_fin(cp, dur).sum())
        finally:
            res.USE_KERNEL = keep_k
        assert np.float64(i_r2).tobytes() == np.float64(want_sum).tobytes()
        assert complex(c_last) == complex(c[-1])
        assert np.float64(lo_got).tobytes() == lo.tobytes()
        assert kc == cp[keep].tobytes() and kd == dur[keep].tobytes()
        # the exponentials kept for the next stream: a zero-length piece's are exp(0), cos 0, sin 0
        qr, qi = res._int_r2_args(s, osc.lam)[:2]
        z = np.flatnonzero(zero)
        want_z = np.array([math.exp(qr * 0.0 - qi * 0.0), math.cos(qr * 0.0 + qi * 0.0),
                           math.sin(qr * 0.0 + qi * 0.0)])
        pv = p_out[1].reshape(-1, 3)
        assert pv[z].tobytes() == np.tile(want_z, (len(z), 1)).tobytes()
        assert p_out[0].tobytes() == dur.tobytes()
        # and the core's own peak (not numpy's): max_abs_r's
        ret2 = CORE.ring_solve(t, dr, drp, None, s, wd, span, res.ELIDE_BYTES // 16, True,
                               *res._int_r2_args(s, osc.lam), None, None, None, None, None, False, floor)
        out, out_abs = np.empty(int(keep.sum())), np.empty(int(keep.sum()))
        assert CORE.ring_peak(cp[keep], dur[keep], -s, wd, wd, True, out, out_abs)
        want_pk = float(np.maximum(lo, out.max())) if keep.any() else float(lo)
        assert np.float64(ret2[1]).tobytes() == np.float64(want_pk).tobytes()


@need_core
def test_zero_length_candidates_at_the_threshold():
    """Zero-length pieces whose |c| (1 + 1e-9) sits at the threshold (the floor) are handed
    back exactly as max_abs_r keeps them: the bound that spares |c| must not rule one out."""
    osc = Oscillator(50.0, 0.1)
    if res._solve_core(osc.s, osc.wd) is None:
        pytest.skip("the core's solve is not checked for this oscillator here")
    s, wd = osc.s, osc.wd
    rng = np.random.default_rng(3820)
    hits = 0
    for trial in range(30):
        n = 400
        t, dr, drp = _events(rng, n)
        c = _numpy_amplitudes(osc, t, dr, drp)
        cp, dur = c[:-1], np.diff(t)
        zero = np.flatnonzero(dur == 0.0)
        mags = np.abs(cp)
        lo = np.abs(cp.real).max()
        # (zero-length pieces above lo: the floor decides for them)
        for j in zero[mags[zero] * (1.0 + 1e-9) >= lo][:5]:
            for floor in (float(mags[j]) * (1.0 + 1e-9), float(np.nextafter(mags[j] * (1.0 + 1e-9), np.inf)),
                          float(mags[j])):
                keep = ~(mags * (1.0 + 1e-9) < max(floor, lo))
                ret = CORE.ring_solve(t, dr, drp, None, s, wd, res.CHUNK_DECAY / s, res.ELIDE_BYTES // 16, True,
                                      *res._int_r2_args(s, osc.lam), None, None, None, None,
                                      np.exp(-2.0 * s * dur), True, floor)
                assert ret[3] == cp[keep].tobytes() and ret[4] == dur[keep].tobytes()
                hits += bool(keep[j])
    assert hits > 100, hits


@need_core
@pytest.mark.parametrize("first", [1e-3, -2.5e-7, 0.125, 3e-200])
def test_a_real_amplitude_on_a_zero_length_piece_at_the_floor(first):
    """A zero-length piece (not its call's first) whose c is real, |c| (1 + 1e-9) exactly the
    floor: |c| is |Re c| there, so the bound on |c| is tight; the piece is handed back."""
    osc = Oscillator(50.0, 0.1)
    if res._solve_core(osc.s, osc.wd) is None:
        pytest.skip("the core's solve is not checked for this oscillator here")
    s, wd = osc.s, osc.wd
    # events at 0, 0, 0 (the carried amplitude, then two jumps of 0), then one more
    t = np.array([0.0, 0.0, 0.0, 0.01])
    dr, drp = np.array([0.0, 0.0, 1e-4]), np.array([0.0, 0.0, 1.0])
    for floor in (abs(first) * (1.0 + 1e-9), float(np.nextafter(abs(first) * (1.0 + 1e-9), np.inf))):
        ret = CORE.ring_solve(t, dr, drp, complex(first, 0.0), s, wd, res.CHUNK_DECAY / s, res.ELIDE_BYTES // 16,
                              True, *res._int_r2_args(s, osc.lam), None, None, None, None,
                              np.exp(-2.0 * s * np.diff(t)), True, floor)
        c = np.frombuffer(ret[3], complex)
        d = np.frombuffer(ret[4], float)
        at = floor == abs(first) * (1.0 + 1e-9)
        # pieces 0 and 1: c = first, length 0 (piece 0 takes the general steps, piece 1 the shortcut)
        assert list(c[:2]) == ([complex(first, 0.0)] * 2 if at else [])
        assert list(d[:2]) == ([0.0, 0.0] if at else [])
