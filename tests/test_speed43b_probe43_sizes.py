"""The ringing probes at their smaller sizes (session 43b: resonance.PROBE_GRID, PROBE_DRAWS,
JUMPS_PROBE_N, INT_R2_SIZES) against the sizes they replace: the same verdict on the real
core, and a core 1 ulp off on any one path the probes cover is still turned down.  (Since
session 46 the probes gate the steps' kernels only -- Oscillator.amplitudes', jump_amplitude's,
integral_r2_fin's, which take a chunk the core's ring_solve declines: ring_solve itself, its
recursion not numpy's bits, is not probed; nor is ring_peak, gone with the peak's probe.)"""
import numpy as np
import pytest

from gcode_opt.firmware import resonance as R
from gcode_opt.firmware import simulate

CORE = simulate._core
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "ring_solve"),
                                reason="needs the compiled firmware core")

OLD_SIZES = {"PROBE_GRID": 1601, "PROBE_DRAWS": 2000, "JUMPS_PROBE_N": 20000,
             "INT_R2_SIZES": (1, 7, 8, 9, 100, 127, 128, 129, 200, 255, 256, 257, 1000) * 3
             + (4097, 5003, 20011)}
# the sample files' oscillator (the profiles' default 50 Hz, 0.1) and others
OSCS = [(50.0, 0.1), (37.5, 0.05), (81.0, 0.3), (12.0, 0.6), (120.0, 0.02)]


def _fresh(monkeypatch):
    """Every probe's verdict forgotten, and the times' cache."""
    for name in ("_KERNEL_OK", "_AMPS_MODE", "_JUMPS_OK", "_INT_R2_OK"):
        monkeypatch.setattr(R, name, {})
    monkeypatch.setattr(R, "_PROBE", [None, None])
    monkeypatch.setattr(R, "_EVENTS_SEEN", [10 ** 9])


def _steps_core(osc):
    """The core's amplitudes' product mode where every kernel of the steps passed its probe
    (the pair's exponentials, the jumps, integral_r2's sum, the amplitudes'), else None."""
    span = R.CHUNK_DECAY / osc.s
    core = R._core()
    if core is None or R._kernel_for(("pair", osc.s, osc.wd), span) is None \
            or R._jumps_core(osc.s, osc.wd) is None or R._int_r2_core(osc.s, osc.wd) is None:
        return None
    return R._amps_mode(core, osc.s, osc.wd, span)


def _verdict(osc):
    """The steps' kernels' verdict and the single probes' (amplitudes' and integral_r2's on
    their own)."""
    span = R.CHUNK_DECAY / osc.s
    return (_steps_core(osc),
            R._kernel_for(("pair", osc.s, osc.wd), span) is not None,
            R._kernel_for(("one", -osc.s, osc.wd), 1e4) is not None,
            R._jumps_core(osc.s, osc.wd) is not None, R._int_r2_core(osc.s, osc.wd) is not None)


@pytest.mark.parametrize("freq_hz,damping_r", OSCS)
def test_smaller_probes_give_the_old_verdict(monkeypatch, freq_hz, damping_r):
    osc = R.Oscillator(freq_hz, damping_r)
    _fresh(monkeypatch)
    new = _verdict(osc)
    for name, size in OLD_SIZES.items():
        monkeypatch.setattr(R, name, size)
    _fresh(monkeypatch)
    assert new == _verdict(osc)
    assert new[0] is not None          # the real core passes: the breaks below are what turn it


def _up(a, where):
    """a (float or complex array) 1 ulp up where `where` (each part), in place; how many."""
    k = np.flatnonzero(where)
    if a.dtype == complex:
        a.real[k] = np.nextafter(a.real[k], np.inf)
        a.imag[k] = np.nextafter(a.imag[k], np.inf)
    else:
        a[k] = np.nextafter(a[k], np.inf)
    return len(k)


class _Broken:
    """The compiled core with one path's numbers 1 ulp off (the path picked by `path`)."""

    def __init__(self, path):
        self.path, self.hits = path, 0

    def __getattr__(self, name):
        return getattr(CORE, name)

    def ring_exps(self, t, s, wd, e_dn, e_up):
        ok = CORE.ring_exps(t, s, wd, e_dn, e_up)
        if self.path == "exps_zero_t":
            self.hits += _up(e_dn, t == 0.0)
        elif self.path == "exps_subnormal_t":
            self.hits += _up(e_up, (t > 0.0) & (t < 1e-300))
        elif self.path == "exps_far_t":
            self.hits += _up(e_up, t >= 0.999 * t.max())
        return ok

    def ring_exp(self, t, a, b, out):
        ok = CORE.ring_exp(t, a, b, out)
        if self.path == "exp_tiny_t":
            self.hits += _up(out, (t > 0.0) & (t < 1e-15))
        return ok

    def ring_jumps(self, dr, drp, s, wd, out):
        ok = CORE.ring_jumps(dr, drp, s, wd, out)
        if self.path == "jumps_zeros":
            self.hits += _up(out, (dr == 0.0) & np.signbit(dr) & (drp != 0.0))
        elif self.path == "jumps_cancel":
            self.hits += _up(out, (drp + s * dr == 0.0) & (dr != 0.0))
        return ok

    def ring_amps(self, t_ev, dc, s, wd, span, short, start, carry, t_carry, c, fused, *extra):
        end = CORE.ring_amps(t_ev, dc, s, wd, span, short, start, carry, t_carry, c, fused, *extra)
        if self.path == "amps_restart":
            # the first event after a pause longer than a restart's span
            gap = np.diff(t_ev, prepend=t_ev[0])
            self.hits += _up(c, (gap > span) & (np.arange(len(c)) < end))
        elif self.path == "amps_zero_dc":
            self.hits += _up(c, (dc == 0.0) & (np.arange(len(c)) < end))
        return end

    def ring_int_r2(self, c, dur, decay2, *rest):
        got = CORE.ring_int_r2(c, dur, decay2, *rest)
        work = rest[6]
        if self.path == "int_r2_zero_dur":
            self.hits += _up(work, dur == 0.0)
        elif self.path == "int_r2_zero_imag":
            self.hits += _up(work, (c.imag == 0.0) & (c.real != 0.0) & (dur > 0.0))
        elif self.path == "int_r2_sum_block" and len(dur) == 129:
            self.hits += 1
            return np.nextafter(got, np.inf)
        elif self.path == "int_r2_sum_deep" and len(dur) > 4096:
            self.hits += 1
            return np.nextafter(got, np.inf)
        return got


PATHS = ["exps_zero_t", "exps_subnormal_t", "exps_far_t", "exp_tiny_t", "jumps_zeros", "jumps_cancel",
         "amps_restart", "amps_zero_dc", "int_r2_zero_dur", "int_r2_zero_imag", "int_r2_sum_block",
         "int_r2_sum_deep"]


@pytest.mark.parametrize("path", PATHS)
@pytest.mark.parametrize("freq_hz,damping_r", OSCS[:2])
def test_a_core_one_ulp_off_on_one_path_is_turned_down(monkeypatch, path, freq_hz, damping_r):
    osc = R.Oscillator(freq_hz, damping_r)
    _fresh(monkeypatch)
    broken = _Broken(path)
    monkeypatch.setattr(simulate, "_core", broken)
    assert _steps_core(osc) is None
    assert broken.hits > 0           # the probe took that path
