"""Ringing figures in fewer passes, the same bits (issue 8, stop 18): the jumps' complex
amplitudes (Oscillator.jump_amplitude: ring_jumps) and the restarts of
Oscillator.amplitudes run in the firmware core (ring_amps: the exponentials, the products,
the running sum and the carried amplitude of each restart in one loop), and the sum of
integral_r2_fin over a chunk is one core pass (ring_int_r2: exponential, products,
absolute value, quotient, numpy's pairwise sum), numpy's SIMD real exponential left to
numpy.  Each is used only after a probe gave numpy's bits for the oscillator.

Reference: 9bb98a8's Oscillator.jump_amplitude, amplitudes, integral_r2_fin and _real_quotient, copied
verbatim below (the products and sums by numpy).  The core's results must equal them bit
for bit (tobytes), called directly (so a changed core fails here even where the probe
would then leave it unused) and through the gated methods; the figures of whole files
with and without the new paths must be equal."""
import math
import os
import platform

import numpy as np
import pytest

from gcode_opt import ringing as rg
from gcode_opt.firmware import resonance as res
from gcode_opt.firmware import simulate as fw
from gcode_opt.firmware.resonance import Oscillator, _kernel_for
from gcode_opt.profile import load_profile

SAMPLES = os.path.join(os.path.dirname(__file__), "..", "sample_gcode")
CORE = fw._core
HAS_AMPS = CORE is not None and hasattr(CORE, "ring_amps")
need_core = pytest.mark.skipif(not HAS_AMPS, reason="the compiled firmware core is not built here")


# ---------------------------------------------------------------- 9bb98a8, verbatim
def _ref_jump_amplitude(self, dr, drp):
    return dr - 1j * (drp + self.s * dr) / self.wd


def _ref_amplitudes(self, t_ev, dc):
    n = len(t_ev)
    c = np.empty(n, complex)
    if n == 0:
        return c
    lam = self.lam
    span = res.CHUNK_DECAY / self.s
    core = _kernel_for(("pair", self.s, self.wd), span)
    short = res.ELIDE_BYTES // 16             # restarts numpy works out of place
    start = 0
    carry, t_carry = 0j, float(t_ev[0])
    while start < n:
        t0 = float(t_ev[start])
        stop = int(np.searchsorted(t_ev, t0 + span, side="right"))
        if stop <= start:
            stop = start + 1
        tt = t_ev[start:stop] - t0
        if core is not None and stop - start < short:
            # np.exp(-lam tt), np.exp(lam tt) by the core; the products as numpy's
            e_dn, e_up = np.empty(stop - start, complex), np.empty(stop - start, complex)
            if core.ring_exps(tt, self.s, self.wd, e_dn, e_up):
                g = np.cumsum(dc[start:stop] * e_dn)
                c0 = carry * np.exp(lam * (t0 - t_carry))
                c[start:stop] = (c0 + g) * e_up
                carry, t_carry = c[stop - 1], float(t_ev[stop - 1])
                start = stop
                continue
        g = np.cumsum(dc[start:stop] * np.exp(-lam * tt))
        c0 = carry * np.exp(lam * (t0 - t_carry))
        c[start:stop] = (c0 + g) * np.exp(lam * tt)
        carry, t_carry = c[stop - 1], float(t_ev[stop - 1])
        start = stop
    return c


def _ref_integral_r2_fin(self, c, dur):
    s, lam = self.s, self.lam
    decay2 = np.exp(-2.0 * s * dur)
    q = 2.0 * lam
    core = _kernel_for(("one", q.real, q.imag), 1e4)
    osc2 = None
    if core is not None:
        osc2 = np.empty(len(dur), complex)
        if not core.ring_exp(np.ascontiguousarray(dur), q.real, q.imag, osc2):
            osc2 = None
    if osc2 is None:
        osc2 = np.exp(q * dur)
    y = c * c * (osc2 - 1.0)
    return np.abs(c) ** 2 * (1.0 - decay2) / (4.0 * s) + _ref_real_quotient(y, 4.0 * lam)


def _ref_real_quotient(y, q: complex):
    qr, qi = q.real, q.imag
    if abs(qr) >= abs(qi):
        rat = qi / qr
        scl = 1.0 / (qr + qi * rat)
        return (y.real + y.imag * rat) * scl
    rat = qr / qi
    scl = 1.0 / (qi + qr * rat)
    return (y.real * rat + y.imag) * scl


def _ref_sum(osc, c, dur):
    return float(_ref_integral_r2_fin(osc, c, dur).sum())


def _bits(x):
    return np.float64(x).tobytes()


def _oscillators(rng, k):
    yield Oscillator(50.0, 0.1)
    for _ in range(k):
        yield Oscillator(float(rng.uniform(10.0, 150.0)), float(rng.uniform(0.01, 0.6)))


def _events(rng, span, n, long_pause=0.01):
    """Sorted event times: dense bursts, equal times, long pauses (restarts apart)."""
    gaps = rng.exponential(span / rng.uniform(50.0, 3000.0), n) * (rng.uniform(size=n) < 0.9)
    gaps[rng.uniform(size=n) < long_pause] *= 500.0
    t = np.cumsum(gaps) + rng.uniform(-5.0, 5.0)
    dc = rng.standard_normal(n) * 1e-3 + 1j * rng.standard_normal(n) * 1e-3
    dc[rng.uniform(size=n) < 0.1] = 0.0
    dc.real[rng.uniform(size=n) < 0.05] = -0.0
    return t, dc


# ---------------------------------------------------------------- ring_jumps
def _dr_drp(rng, n, s):
    dr = rng.normal(size=n) * np.exp(rng.normal(size=n) * 6.0) * 1e-4
    drp = rng.normal(size=n) * np.exp(rng.normal(size=n) * 6.0)
    for a in (dr, drp):
        a[rng.uniform(size=n) < 0.2] = 0.0
        a[rng.uniform(size=n) < 0.1] = -0.0
    drp[:20] = -s * dr[:20]
    return dr, drp


@need_core
@pytest.mark.parametrize("seed", range(3))
def test_ring_jumps_is_numpys(seed):
    rng = np.random.default_rng(400 + seed)
    for osc in _oscillators(rng, 5):
        for n in (0, 1, 17, 5000):
            dr, drp = _dr_drp(rng, n, osc.s)
            got = np.empty(n, complex)
            assert CORE.ring_jumps(dr, drp, osc.s, osc.wd, got)
            assert got.tobytes() == _ref_jump_amplitude(osc, dr, drp).tobytes(), (osc.s, n)
    for bad in (np.nan, np.inf, -np.inf):         # not finite: left to numpy
        assert not CORE.ring_jumps(np.array([1.0, bad]), np.zeros(2), 3.0, 30.0, np.empty(2, complex))
        assert not CORE.ring_jumps(np.zeros(2), np.array([bad, 1.0]), 3.0, 30.0, np.empty(2, complex))
    with pytest.raises(ValueError):
        CORE.ring_jumps(np.zeros(3), np.zeros(2), 1.0, 2.0, np.empty(3, complex))


def test_jump_amplitude_same_bits(monkeypatch):
    """Through the gate (core or numpy), and for views, scalars and a failed probe."""
    rng = np.random.default_rng(7)
    for osc in _oscillators(rng, 2):
        dr, drp = _dr_drp(rng, 3000, osc.s)
        want = _ref_jump_amplitude(osc, dr, drp)
        assert osc.jump_amplitude(dr, drp).tobytes() == want.tobytes()
        assert osc.jump_amplitude(dr[::2], drp[::2]).tobytes() == want[::2].tobytes()
        assert complex(osc.jump_amplitude(0.25, -3.0)) == complex(_ref_jump_amplitude(osc, 0.25, -3.0))
        dr[7], drp[9] = np.nan, np.inf
        with np.errstate(invalid="ignore"):
            assert osc.jump_amplitude(dr, drp).tobytes() == _ref_jump_amplitude(osc, dr, drp).tobytes()
    osc = Oscillator(61.0, 0.07)
    monkeypatch.setattr(res, "_JUMPS_OK", {(osc.s, osc.wd): False})
    dr, drp = _dr_drp(rng, 100, osc.s)
    assert osc.jump_amplitude(dr, drp).tobytes() == _ref_jump_amplitude(osc, dr, drp).tobytes()


# ---------------------------------------------------------------- ring_amps
@need_core
@pytest.mark.parametrize("seed", range(3))
def test_ring_amps_is_the_numpy_restart_loop(seed):
    """The core's loop (numpy's fused complex product) against the verbatim 9bb98a8
    amplitudes, called directly on every event: restarts, pauses, equal times, carries."""
    rng = np.random.default_rng(seed)
    for osc in _oscillators(rng, 4):
        span = res.CHUNK_DECAY / osc.s
        if _kernel_for(("pair", osc.s, osc.wd), span) is None:
            continue
        for n in (1, 2, 50, 3000):
            t, dc = _events(rng, span, n)
            want = _ref_amplitudes(osc, t, dc)
            got = np.empty(n, complex)
            end = CORE.ring_amps(t, dc, osc.s, osc.wd, span, 1 << 30, 0, 0j, float(t[0]), got, True)
            assert end == n
            assert got.tobytes() == want.tobytes(), (osc.s, n)


@need_core
def test_ring_amps_events_at_one_time():
    """Runs of events at one time (blocks without cruise) reuse the previous event's
    exponentials: the same bits as computing them, next to times that differ by one ulp
    or only in the sign of zero."""
    rng = np.random.default_rng(21)
    for osc in _oscillators(rng, 3):
        span = res.CHUNK_DECAY / osc.s
        base = np.cumsum(rng.exponential(span / 500.0, 700))
        t = np.repeat(base, rng.integers(1, 5, len(base)))
        t[5:9] = np.nextafter(t[5], np.inf)
        t = np.sort(np.concatenate([[-0.0, 0.0, 0.0, -0.0], t]))
        dc = rng.standard_normal(len(t)) + 1j * rng.standard_normal(len(t))
        want = _ref_amplitudes(osc, t, dc)
        got = np.empty(len(t), complex)
        assert CORE.ring_amps(t, dc, osc.s, osc.wd, span, 1 << 30, 0, 0j, float(t[0]), got, True) == len(t)
        assert got.tobytes() == want.tobytes()


@need_core
def test_ring_amps_stops_at_long_and_non_finite_restarts():
    """It hands back the start of a restart of short_n events or more and of one with a
    time that is not finite, having written only the restarts before it."""
    osc = Oscillator(50.0, 0.1)
    span = res.CHUNK_DECAY / osc.s
    t = np.concatenate([np.linspace(0.0, 0.5, 10), span * 2.0 + np.linspace(0.0, 0.5, 40),
                        [span * 5.0]])
    dc = np.ones(len(t), complex)
    got = np.full(len(t), 7.0 + 7.0j)
    assert CORE.ring_amps(t, dc, osc.s, osc.wd, span, 40, 0, 0j, 0.0, got, True) == 10
    assert (got[10:] == 7.0 + 7.0j).all() and (got[:10] != 7.0 + 7.0j).all()
    t2 = t.copy()
    t2[-1] = np.inf
    got = np.empty(len(t), complex)
    assert CORE.ring_amps(t2, dc, osc.s, osc.wd, span, 1000, 0, 0j, 0.0, got, True) == 50
    dc2 = dc.copy()
    dc2[12] = complex(1.0, np.nan)
    assert CORE.ring_amps(t, dc2, osc.s, osc.wd, span, 1000, 0, 0j, 0.0, got, True) == 10
    with pytest.raises(ValueError):
        CORE.ring_amps(t, dc[:-1], osc.s, osc.wd, span, 10, 0, 0j, 0.0, got, True)


@pytest.mark.parametrize("seed", range(2))
def test_amplitudes_same_bits(seed):
    """Oscillator.amplitudes (core restarts, numpy for long ones) is the 9bb98a8 code, with
    restarts short and long (16384 events or more: numpy's in-place expressions), and past
    a time that is not finite."""
    rng = np.random.default_rng(100 + seed)
    for osc in _oscillators(rng, 2):
        span = res.CHUNK_DECAY / osc.s
        for n_per in (1, 3, 200, 16383, 16384, 20000):
            n = 3 * n_per
            t = np.sort(np.concatenate([k * span * 1.0001 + rng.uniform(0.0, span, n_per)
                                        for k in range(3)]))
            dc = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) * 1e-3
            assert osc.amplitudes(t, dc).tobytes() == _ref_amplitudes(osc, t, dc).tobytes(), n_per
        t, dc = _events(rng, span, 5000)
        assert osc.amplitudes(t, dc).tobytes() == _ref_amplitudes(osc, t, dc).tobytes()
        dc[30] = complex(np.inf, 0.0)
        with np.errstate(invalid="ignore", over="ignore"):
            assert osc.amplitudes(t, dc).tobytes() == _ref_amplitudes(osc, t, dc).tobytes()
        t[-3:] = [np.inf, np.inf, np.nan]
        with np.errstate(invalid="ignore", over="ignore"):
            assert osc.amplitudes(t, dc).tobytes() == _ref_amplitudes(osc, t, dc).tobytes()


@need_core
def test_the_core_restarts_are_used_here():
    """On this machine the probe finds the mode that gives numpy's bits (else the speed-up
    is silently gone)."""
    osc = Oscillator(50.0, 0.1)
    span = res.CHUNK_DECAY / osc.s
    if platform.machine() not in ("x86_64", "AMD64"):
        pytest.skip("numpy's complex product loop is known here only for x86-64")
    assert res._amps_mode(CORE, osc.s, osc.wd, span) is not None
    assert res._int_r2_core(osc.s, osc.wd) is CORE
    assert res._jumps_core(osc.s, osc.wd) is CORE


def test_a_failed_probe_leaves_numpy(monkeypatch):
    """With the probes failed, amplitudes and the integral's sum are numpy's (same bits)."""
    rng = np.random.default_rng(9)
    osc = Oscillator(47.0, 0.12)
    span = res.CHUNK_DECAY / osc.s
    monkeypatch.setattr(res, "_AMPS_MODE", {(osc.s, osc.wd, span): None})
    monkeypatch.setattr(res, "_INT_R2_OK", {(osc.s, osc.wd): False})
    t, dc = _events(rng, span, 4000)
    c = osc.amplitudes(t, dc)
    assert c.tobytes() == _ref_amplitudes(osc, t, dc).tobytes()
    dur = np.diff(t)
    assert _bits(osc.integral_r2_fin_sum(c[:-1], dur)) == _bits(_ref_sum(osc, c[:-1], dur))


# ---------------------------------------------------------------- ring_int_r2
def _c_dur(rng, s, n):
    c = rng.normal(size=n) * np.exp(rng.normal(size=n) * 3.0) * 1e-3 \
        + 1j * rng.normal(size=n) * np.exp(rng.normal(size=n) * 3.0) * 1e-3
    c[rng.uniform(size=n) < 0.03] = 0.0
    c.real[rng.uniform(size=n) < 0.03] = 0.0
    c.imag[rng.uniform(size=n) < 0.03] = -0.0
    dur = rng.exponential(rng.uniform(0.01, 3.0) / s, n) * (rng.uniform(size=n) < 0.95)
    return c, dur


@need_core
@pytest.mark.parametrize("seed", range(3))
def test_ring_int_r2_is_the_numpy_sum(seed):
    """The core's one pass against the verbatim 9bb98a8 integral_r2_fin summed by numpy,
    called directly, on lengths around numpy's pairwise blocks (8, 128, halves)."""
    rng = np.random.default_rng(200 + seed)
    for osc in _oscillators(rng, 4):
        q = 2.0 * osc.lam
        if _kernel_for(("one", q.real, q.imag), 1e4) is None:
            continue
        for n in (1, 2, 7, 8, 9, 16, 127, 128, 129, 136, 255, 256, 257, 1000, 4097, 33333):
            c, dur = _c_dur(rng, osc.s, n)
            decay2 = np.exp(-2.0 * osc.s * dur)
            got = CORE.ring_int_r2(c, dur, decay2, *res._int_r2_args(osc.s, osc.lam), np.empty(n))
            assert _bits(got) == _bits(_ref_sum(osc, c, dur)), (osc.s, n)


@need_core
def test_ring_int_r2_pieces_of_one_length():
    """Zero-length pieces and runs of one length reuse exp and sincos: the same bits as
    computing them, next to -0.0 and lengths one ulp apart."""
    rng = np.random.default_rng(23)
    for osc in _oscillators(rng, 3):
        n = 3000
        c, _ = _c_dur(rng, osc.s, n)
        pool = np.array([0.0, -0.0, 1e-3, np.nextafter(1e-3, 1.0), 0.25 / osc.s, 5e-324])
        dur = np.where(rng.uniform(size=n) < 0.7, pool[rng.integers(0, len(pool), n)],
                       rng.exponential(0.5 / osc.s, n))
        dur[:6] = [0.0, 0.0, -0.0, 0.0, 1e-3, 1e-3]
        decay2 = np.exp(-2.0 * osc.s * dur)
        work = np.empty(n)
        got = CORE.ring_int_r2(c, dur, decay2, *res._int_r2_args(osc.s, osc.lam), work)
        want = _ref_integral_r2_fin(osc, c, dur)
        assert work.tobytes() == want.tobytes()
        assert _bits(got) == _bits(float(want.sum()))


@need_core
def test_ring_int_r2_leaves_non_finite_to_numpy():
    osc = Oscillator(50.0, 0.1)
    c = np.array([1e-3 + 1e-3j, 2e-3 + 0j, 1e-4j])
    args = res._int_r2_args(osc.s, osc.lam)
    for bad_c, bad_d in ((np.inf, 0.1), (np.nan, 0.1), (1e-3, np.inf), (1e-3, np.nan)):
        cc, dd = c.copy(), np.array([0.01, 0.02, 0.03])
        cc[1], dd[2] = bad_c, bad_d if bad_d != 0.1 else dd[2]
        with np.errstate(invalid="ignore", over="ignore"):
            decay2 = np.exp(-2.0 * osc.s * dd)
        assert CORE.ring_int_r2(cc, dd, decay2, *args, np.empty(3)) is None
    with pytest.raises(ValueError):
        CORE.ring_int_r2(c, np.zeros(2), np.zeros(2), *args, np.empty(2))


@pytest.mark.parametrize("seed", range(2))
def test_integral_r2_fin_sum_same_bits(seed):
    rng = np.random.default_rng(300 + seed)
    for osc in _oscillators(rng, 3):
        for n in (0, 1, 9, 130, 20000):
            c, dur = _c_dur(rng, osc.s, n)
            assert _bits(osc.integral_r2_fin_sum(c, dur)) == _bits(_ref_sum(osc, c, dur))


# ---------------------------------------------------------------- whole files
def _figure_bits(d):
    if isinstance(d, dict):
        return {k: _figure_bits(v) for k, v in d.items()}
    return _bits(d) if isinstance(d, float) else d


@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "prusa-mk3s"),
                                       ("prusa_mk3s_rectilinear.gcode", "voron24")])
@pytest.mark.parametrize("shaper", [None, "zv", "mzv", "ei"])
def test_figures_with_and_without_the_new_paths(monkeypatch, name, prof, shaper):
    """Collector figures (chunks forced small: many carries) equal with the core's paths
    and with numpy's, every float bit for bit."""
    path = os.path.join(SAMPLES, name)
    if not os.path.exists(path):
        pytest.skip(f"{name} not in sample_gcode")
    profile = load_profile(prof)
    got = {}
    monkeypatch.setattr(res, "USE_SOLVE", False)     # (these kernels' paths: not ring_solve's recursion)
    for use in (True, False):
        monkeypatch.setattr(res, "USE_AMPS", use)
        monkeypatch.setattr(res, "USE_INT_R2", use)
        monkeypatch.setattr(res, "USE_JUMPS", use)
        col = rg.Collector(profile, shaper, chunk_blocks=700)
        rg.play(path, profile, col)
        got[use] = _figure_bits(col.figures())
        assert math.isfinite(col.figures()["time_s"])
    assert got[True] == got[False]
