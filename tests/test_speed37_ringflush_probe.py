"""The ring_int_r2 probe made for all its sizes at once (resonance._int_r2_probe, ProbeRng.randoms)
against the size-by-size loop it replaces: the same numbers, bit for bit, and the same verdict."""
import numpy as np
import pytest

from gcode_opt.firmware import resonance as R
from gcode_opt.firmware import simulate
from gcode_opt.probe_rng import ProbeRng


def _loop_draws(seed, sizes, kinds):
    """The draws as a loop takes them: for each size, each kind in turn."""
    rng = ProbeRng(seed)
    out = [[] for _ in kinds]
    for n in sizes:
        for j, kind in enumerate(kinds):
            out[j].append(kind(rng, n))
    return [np.concatenate(x) if x else np.zeros(0) for x in out], rng


KINDS = {
    "random": (lambda rng, n: rng.random(n), lambda u: u),
    "normal": (lambda rng, n: rng.normal(size=n), ProbeRng.normal_of),
    "normal2": (lambda rng, n: rng.normal(1.5, 3.0, size=n), lambda u: ProbeRng.normal_of(u, 1.5, 3.0)),
    "uniform": (lambda rng, n: rng.uniform(size=n), ProbeRng.uniform_of),
    "uniform2": (lambda rng, n: rng.uniform(-2.0, 7.0, n), lambda u: ProbeRng.uniform_of(u, -2.0, 7.0)),
    "exponential": (lambda rng, n: rng.exponential(0.3, n), lambda u: ProbeRng.exponential_of(u, 0.3)),
}


@pytest.mark.parametrize("sizes", [(1,), (2,), (7, 8, 9), (1, 1, 1, 2, 3), (0, 5, 0, 4), (1000, 3, 4097),
                                   R.INT_R2_SIZES])
@pytest.mark.parametrize("names", [("random",), ("normal", "uniform"),
                                   ("normal", "normal2", "uniform2", "exponential", "uniform", "random")])
def test_randoms_are_the_loops_draws(sizes, names):
    kinds = [KINDS[k] for k in names]
    want, rng_loop = _loop_draws(5, sizes, [k[0] for k in kinds])
    rng = ProbeRng(5)
    u = rng.randoms(sizes, len(kinds))
    got = [k[1](x) for k, x in zip(kinds, u)]
    for g, w in zip(got, want):
        assert g.dtype == w.dtype and g.tobytes() == w.tobytes()
    # and the generator goes on from the same place
    assert rng.random(9).tobytes() == rng_loop.random(9).tobytes()


def _loop_probe(s):
    """_int_r2_core's probe as the loop made it (before _int_r2_probe): its c and dur of each size."""
    rng = ProbeRng(13)
    got = []
    for n in R.INT_R2_SIZES:
        c = rng.normal(size=n) * np.exp(rng.normal(size=n) * 4.0) \
            + 1j * rng.normal(size=n) * np.exp(rng.normal(size=n) * 4.0)
        c[rng.uniform(size=n) < 0.05] = 0.0
        c.imag[rng.uniform(size=n) < 0.05] = 0.0
        dur = rng.exponential(0.5 / s, n) * (rng.uniform(size=n) < 0.95)
        got.append((c, dur))
    return got


def _osc(freq_hz, damping_r):
    return R.Oscillator(freq_hz, damping_r)


@pytest.mark.parametrize("freq_hz,damping_r", [(50.0, 0.1), (37.5, 0.05), (81.0, 0.3)])
def test_int_r2_probe_numbers_and_integrals_are_the_loops(freq_hz, damping_r):
    osc = _osc(freq_hz, damping_r)
    c, dur, sizes = R._int_r2_probe(osc.s)
    assert sizes == R.INT_R2_SIZES and len(c) == len(dur) == sum(sizes)
    want_all = osc.integral_r2_fin(c, dur)         # all sizes at once (the new probe's)
    a = 0
    for (c1, d1), n in zip(_loop_probe(osc.s), sizes):
        b = a + n
        assert c[a:b].tobytes() == c1.tobytes() and dur[a:b].tobytes() == d1.tobytes()
        w1 = osc.integral_r2_fin(c1, d1)           # size by size (the loop's)
        assert want_all[a:b].tobytes() == w1.tobytes()
        assert np.float64(want_all[a:b].copy().sum()).tobytes() == np.float64(w1.sum()).tobytes()
        a = b


class _Core:
    """The compiled core with ring_int_r2 changed for one probe size (its n): the verdict must turn."""

    def __init__(self, core, n, how):
        self._core, self.n, self.how = core, n, how

    def __getattr__(self, name):
        return getattr(self._core, name)

    def ring_int_r2(self, c, dur, decay2, *rest):
        got = self._core.ring_int_r2(c, dur, decay2, *rest)
        if len(dur) == self.n and self.how == "sum":
            return np.nextafter(got, np.inf)
        if len(dur) == self.n and self.how == "work":
            rest[-1][len(dur) // 2] = np.nextafter(rest[-1][len(dur) // 2], np.inf)
        if len(dur) == self.n and self.how == "none":
            return None
        return got


@pytest.mark.skipif(simulate._core is None or not hasattr(simulate._core, "ring_int_r2"),
                    reason="needs the compiled firmware core")
@pytest.mark.parametrize("n,how", [(None, None), (1, "sum"), (257, "work"), (5003, "work"), (4097, "none"),
                                   (9, "sum")])
def test_int_r2_core_verdict(monkeypatch, n, how):
    osc = _osc(50.0, 0.1)
    monkeypatch.setattr(R, "_INT_R2_OK", {})
    monkeypatch.setattr(R, "_KERNEL_OK", {})
    real = simulate._core
    if n is not None:
        monkeypatch.setattr(simulate, "_core", _Core(real, n, how))
    got = R._int_r2_core(osc.s, osc.wd)
    # the loop's verdict, with the same core
    core = simulate._core
    want = True
    pieces = _loop_probe(osc.s)
    # (and the large sizes of the drawn pieces over again: resonance.INT_R2_DEEP)
    c_all, d_all = (np.concatenate(x) for x in zip(*pieces))
    pieces += [(np.resize(c_all, m), np.resize(d_all, m)) for m in R.INT_R2_DEEP]
    for c1, d1 in pieces:
        w1 = osc.integral_r2_fin(c1, d1)
        work = np.empty(len(d1))
        r = core.ring_int_r2(c1, d1, np.exp(-2.0 * osc.s * d1), *R._int_r2_args(osc.s, osc.lam), work)
        if r is None or work.tobytes() != w1.tobytes() \
                or np.float64(r).tobytes() != np.float64(float(w1.sum())).tobytes():
            want = False
            break
    assert want is (n is None)
    assert (got is not None) is want


def _probe_fresh(span):
    """resonance._probe's times as it made them before it kept the last span's."""
    t = np.concatenate([[0.0, 5e-324, 1e-310, 1e-300, 1e-20, 1e-9, span],
                        np.geomspace(1e-12, span, 400), np.linspace(0.0, span, R.PROBE_GRID)])
    return np.concatenate([t, t * (1.0 + 2.0 ** -52), ProbeRng(7).uniform(0.0, span, R.PROBE_DRAWS)])


def test_probe_times_kept_for_the_last_span_are_the_fresh_ones(monkeypatch):
    monkeypatch.setattr(R, "_PROBE", [None, None])
    spans = [1e4, 1e4, 31.41592653589793, 1e4, 1e4, np.nextafter(1e4, 0.0), 1e4, 2.5, 2.5, 31.41592653589793]
    for span in spans:
        got = R._probe(span)
        assert got.tobytes() == _probe_fresh(span).tobytes()
        assert not got.flags.writeable          # (kept: no caller may write it)
    assert R._probe(1e4) is R._probe(1e4)
