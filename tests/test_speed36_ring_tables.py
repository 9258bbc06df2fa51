"""Session 36, the ringing's CPU (helper "ring"), the same bits as before: _core.c's tables
of the pieces' exponentials by length (ring_int_r2_run) have 16 k slots (4 k lost lengths
seen before to others: ~25 M instructions of libm's exp and sincos on plate_rectilinear's
two ringing passes), and the last two oscillators keep a table each (X's and Y's, whose
streams alternate call by call where their frequencies differ: one table was cleared at
every call).  A hit is what libm gives (the same argument): ring_int_r2's sums against
numpy's integral_r2_fin with the tables cold, alternating, evicted by a third oscillator,
and the figures of X and Y at other frequencies against the Python steps (numpy's sums)."""
import os
from array import array

import numpy as np
import pytest

from ring_close import assert_figures_close

from gcode_opt import ringing as rg
from gcode_opt.firmware import resonance as res
from gcode_opt.firmware import simulate as fw
from gcode_opt.profile import load_profile

SAMPLES = os.path.join(os.path.dirname(__file__), "..", "sample_gcode")
CORE = fw._core
need_core = pytest.mark.skipif(CORE is None or not hasattr(CORE, "ring_int_r2"),
                               reason="the compiled firmware core is not built here")
TABLE_B = 32 << 14        # a table's bytes: 16 k slots of (key, ex, cs, sn)


def _pieces(rng, n):
    """Amplitudes and lengths as the plates': few lengths, repeated out of order, zeros."""
    lengths = rng.exponential(0.02, 300)
    dur = rng.choice(lengths, n) * (rng.uniform(size=n) < 0.9)
    c = (rng.normal(size=n) + 1j * rng.normal(size=n)) * 1e-3
    return c, dur


def _core_sum(osc, c, dur):
    return CORE.ring_int_r2(c, dur, np.exp(-2.0 * osc.s * dur), *res._int_r2_args(osc.s, osc.lam),
                            np.empty(len(dur)))


def _numpy_sum(osc, c, dur, monkeypatch):
    with monkeypatch.context() as mp:
        mp.setattr(res, "USE_KERNEL", False)       # numpy's own exponentials, no table
        return float(osc.integral_r2_fin(c, dur).sum())


@need_core
def test_two_oscillators_keep_a_table_each_and_a_third_evicts(monkeypatch):
    x, y, z = res.Oscillator(50.0, 0.1), res.Oscillator(37.7, 0.07), res.Oscillator(63.0, 0.12)
    for osc in (x, y, z):
        q = 2.0 * osc.lam
        if res._kernel_for(("one", q.real, q.imag), 1e4) is None:
            pytest.skip("numpy's complex exp is not libm's here (its own SIMD loops)")
    rng = np.random.default_rng(36)
    c, dur = _pieces(rng, 5000)
    CORE.ring_release()                                  # cold
    assert np.float64(_core_sum(x, c, dur)).tobytes() == np.float64(_numpy_sum(x, c, dur, monkeypatch)).tobytes()
    assert CORE.ring_release() == TABLE_B                # one table, given back
    for osc in (x, y, x, y, y, x, z, x, z, y):           # alternating; z evicts the older
        k = rng.permutation(len(dur))
        want = _numpy_sum(osc, c[k], dur[k], monkeypatch)
        assert np.float64(_core_sum(osc, c[k], dur[k])).tobytes() == np.float64(want).tobytes()
    assert CORE.ring_release() == 2 * TABLE_B            # two tables at most, both given back
    assert CORE.ring_release() == 0


@need_core
@pytest.mark.parametrize("freqs", [(41.3, 63.0), (50.0, 50.0)])
def test_figures_of_axes_apart_against_the_steps(freqs, monkeypatch):
    profile = load_profile("prusa-mk3s")
    model = dict(rg.model_of(profile), freq_x_hz=freqs[0], freq_y_hz=freqs[1])
    rows = rg.Rows()
    rg.play(os.path.join(SAMPLES, "prusa_gyroid.gcode"), profile, rows)

    def figs(core):
        with monkeypatch.context() as mp:
            # (the reference: the Python steps with numpy's sums, no table)
            mp.setattr(res, "USE_SOLVE", core)
            mp.setattr(res, "USE_INT_R2", core)
            col = rg.Collector(model=model, chunk_blocks=500)
            col.add_rows(array("d", rows.items))
            return col.figures()
    want, got = figs(False), figs(True)
    assert_figures_close(got, want)           # (the core's solve: its recursion since session 46)
    assert got["xy"]["rms_um"] > 0.0
