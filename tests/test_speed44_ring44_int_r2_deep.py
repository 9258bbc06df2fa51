"""resonance._int_r2_core's large sizes (INT_R2_DEEP) made of the drawn pieces over again
(session 44) instead of drawn and solved by numpy: the same verdict as the drawn ones on the
real core; a core 1 ulp off in a large size's sum or in one of its pieces is still turned
down; and the premise -- numpy's integral of a piece is its own c's and dur's alone, so the
repeated pieces' integrals are the drawn ones' repeated -- holds bit for bit."""
import numpy as np
import pytest

from gcode_opt.firmware import resonance as R
from gcode_opt.firmware import simulate

CORE = simulate._core
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "ring_int_r2"),
                                reason="needs the compiled firmware core")
OSCS = [(50.0, 0.1), (37.5, 0.05), (81.0, 0.3), (12.0, 0.6), (120.0, 0.02)]
SMALL = (1, 7, 8, 9, 100, 127, 128, 129, 200, 255, 256, 257, 1000) * 3


def _fresh(monkeypatch):
    for name in ("_KERNEL_OK", "_INT_R2_OK"):
        monkeypatch.setattr(R, name, {})
    monkeypatch.setattr(R, "_PROBE", [None, None])
    monkeypatch.setattr(R, "_EVENTS_SEEN", [10 ** 9])


@pytest.mark.parametrize("freq_hz,damping_r", OSCS)
def test_repeated_large_sizes_give_the_drawn_ones_verdict(monkeypatch, freq_hz, damping_r):
    osc = R.Oscillator(freq_hz, damping_r)
    _fresh(monkeypatch)
    new = R._int_r2_core(osc.s, osc.wd) is not None
    # before: the large sizes drawn (and solved by numpy) like the small ones
    monkeypatch.setattr(R, "INT_R2_SIZES", SMALL + (4097, 5003))
    monkeypatch.setattr(R, "INT_R2_DEEP", ())
    _fresh(monkeypatch)
    assert new == (R._int_r2_core(osc.s, osc.wd) is not None)
    assert new                      # the real core passes: the breaks below are what turn it


class _Off:
    """The core with ring_int_r2 1 ulp off for calls of n pieces: its sum ("sum") or one
    piece's integral ("work", the piece at `at`)."""

    def __init__(self, n, how, at=0):
        self.n, self.how, self.at, self.hits = n, how, at, 0

    def __getattr__(self, name):
        return getattr(CORE, name)

    def ring_int_r2(self, c, dur, decay2, *rest):
        got = CORE.ring_int_r2(c, dur, decay2, *rest)
        if len(dur) != self.n:
            return got
        self.hits += 1
        if self.how == "sum":
            return float(np.nextafter(got, np.inf))
        work = rest[6]
        work[self.at] = np.nextafter(work[self.at], np.inf)
        return got


@pytest.mark.parametrize("n,how,at", [(4097, "sum", 0), (5003, "sum", 0), (4097, "work", 4096),
                                      (5003, "work", 2500), (5003, "work", 0)])
@pytest.mark.parametrize("freq_hz,damping_r", OSCS[:2])
def test_a_large_size_one_ulp_off_is_turned_down(monkeypatch, n, how, at, freq_hz, damping_r):
    osc = R.Oscillator(freq_hz, damping_r)
    _fresh(monkeypatch)
    off = _Off(n, how, at)
    monkeypatch.setattr(simulate, "_core", off)
    assert R._int_r2_core(osc.s, osc.wd) is None
    assert off.hits == 1


@pytest.mark.parametrize("freq_hz,damping_r", OSCS)
def test_numpys_integrals_of_the_repeated_pieces_are_the_drawn_ones_repeated(freq_hz, damping_r):
    osc = R.Oscillator(freq_hz, damping_r)
    c, dur, sizes = R._int_r2_probe(osc.s)
    want = osc.integral_r2_fin(c, dur)
    for n in R.INT_R2_DEEP:
        c_n, d_n = np.resize(c, n), np.resize(dur, n)
        # numpy on the repeated pieces themselves, as the drawn large sizes were solved
        assert osc.integral_r2_fin(c_n, d_n).tobytes() == np.resize(want, n).tobytes()
        assert c_n.tobytes() == np.concatenate([c] * (n // len(c) + 1))[:n].tobytes()
