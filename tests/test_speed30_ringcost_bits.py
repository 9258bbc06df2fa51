"""Session 30, the ringing's CPU (helper "ringcost"), the same bits as before:

- _core.c's table of the pieces' exponentials by length (ring_int_r2_run: a piece of a
  length an earlier piece had takes its exp / cos / sin): ring_int_r2's sums against numpy's
  integral_r2_fin (the compiled kernels off: numpy's own exponentials) on real pieces, which
  repeat their lengths, with the table cold, warm, switched to another oscillator and back,
  and after ring_release; whole files' figures with the core's solve against the Python
  steps (USE_SOLVE off), X and Y at other frequencies (the table switches every call);
- ring_events(..., all_only) (a Collector without parts): "all"'s events and the carry bit
  for bit as with the parts, no other part's;
- the int_r2 probe (large sizes once now): still rejects a core off by one ulp at a large
  size only, or at a small size only.
"""
import os

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


def _rows(name, prof):
    rows = rg.Rows()
    rg.play(os.path.join(SAMPLES, name), load_profile(prof), rows)
    idle = np.array([rg.IDLE])
    return np.vstack([idle, np.asarray(rows.items, float).reshape(-1, rg.ROW), idle])


def _pieces_of(name, prof, osc, axis=0):
    """(c, dur) of a real file's ringing ("all", one axis): the amplitudes by numpy."""
    tr = rg.trace_from_items(_rows(name, prof)[1:-1].ravel())
    r = rg.response(tr, rg.model_of(load_profile(prof)), "xy"[axis])
    c, dur = r.c[:-1].copy(), np.diff(r.t_ev)
    return c, dur


def _numpy_sum(osc, c, dur, monkeypatch):
    with monkeypatch.context() as m:
        m.setattr(res, "USE_KERNEL", False)          # numpy's exponentials, numpy's sum
        return float(osc.integral_r2_fin(c, dur).sum())


def _core_sum(osc, c, dur):
    decay2 = np.exp(-2.0 * osc.s * dur)
    return CORE.ring_int_r2(c, dur, decay2, *res._int_r2_args(osc.s, osc.lam), np.empty(len(dur)))


@need_core
def test_pieces_repeat_their_lengths():
    """(what the table is for: else it would only cost)"""
    osc = res.Oscillator(50.0, 0.1)
    _c, dur = _pieces_of("prusa_gyroid.gcode", "prusa-mk3s", osc)
    nz = dur[dur > 0]
    assert len(nz) > 1000
    assert len(np.unique(nz)) < 0.5 * len(nz)


@need_core
@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "prusa-mk3s"), ("cura_box.gcode", "ender3")])
def test_int_r2_table_cold_warm_switched(name, prof, monkeypatch):
    a, b = res.Oscillator(50.0, 0.1), res.Oscillator(37.7, 0.07)
    # (not _int_r2_core's word: that probe runs the table too; only the kernel its
    # exponentials are libm's as numpy's complex exp, checked apart from the table)
    for osc in (a, b):
        q = 2.0 * osc.lam
        if res._kernel_for(("one", q.real, q.imag), 1e4) is None:
            pytest.skip("numpy's complex exp is not libm's here (its own SIMD loops)")
    c, dur = _pieces_of(name, prof, a)
    # the same lengths again and again, shuffled (hits out of order), and some new ones
    rng = np.random.default_rng(5)
    k = rng.permutation(len(dur))
    c2, dur2 = c[k].copy(), dur[k].copy()
    dur3 = dur2 * (1.0 + 2.0 ** -52)
    CORE.ring_release()                               # the table cold
    for osc in (a, b, a, a, b):                       # warm, switched, switched back
        for cc, dd in ((c, dur), (c2, dur2), (c2, dur3), (c, dur)):
            want = _numpy_sum(osc, cc, dd, monkeypatch)
            got = _core_sum(osc, cc, dd)
            assert np.float64(got).tobytes() == np.float64(want).tobytes()
    CORE.ring_release()
    want = _numpy_sum(b, c2, dur2, monkeypatch)
    assert np.float64(_core_sum(b, c2, dur2)).tobytes() == np.float64(want).tobytes()


@need_core
@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24"),
                                       ("cura_box.gcode", "ender3")])
@pytest.mark.parametrize("freqs", [None, (41.3, 63.0)])
def test_figures_core_solve_against_python_steps(name, prof, freqs, monkeypatch):
    profile = load_profile(prof)
    model = rg.model_of(profile)
    if freqs is not None:                             # X and Y apart: the table switches call by call
        model = dict(model, freq_x_hz=freqs[0], freq_y_hz=freqs[1])
    m = _rows(name, prof)[1:-1].ravel()

    def figs(use_solve, parts, chunk):
        with monkeypatch.context() as mp:
            mp.setattr(res, "USE_SOLVE", use_solve)
            col = rg.Collector(model=model, parts=parts, chunk_blocks=chunk)
            from array import array
            col.add_rows(array("d", m.tobytes()))
            return col.figures()
    for parts in (False, True):
        for chunk in (rg.CHUNK_BLOCKS, 301):
            want = figs(False, parts, chunk)
            got = figs(True, parts, chunk)
            assert_figures_close(got, want)       # (the core's solve: its recursion since session 46)


@pytest.mark.skipif(CORE is None or not hasattr(CORE, "ring_events"), reason="no compiled core")
@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24"),
                                       ("cura_box.gcode", "ender3")])
@pytest.mark.parametrize("chunk", [1, 97, 5000])
def test_events_all_only(name, prof, chunk):
    m = _rows(name, prof)
    models = [rg.model_of(load_profile(prof)), dict(rg.model_of(load_profile(prof)), freq_x_hz=41.3, freq_y_hz=63.0)]
    for model in models:
        ca, cb = rg._Carry(), rg._Carry()
        for lo in range(0, len(m), chunk):
            part = m[lo:lo + chunk].copy()
            want = rg._events(part, ca, model, True)
            got = rg._events(part, cb, model, False)
            assert sorted(got) == [("x", "all"), ("y", "all")]
            for k in got:
                for x, y in zip(got[k], want[k]):
                    assert x.tobytes() == y.tobytes(), k
            for key in ("t", "ux", "uy", "isb"):
                assert np.float64(getattr(ca, key)).tobytes() == np.float64(getattr(cb, key)).tobytes()
            assert ca.vel_end.tobytes() == cb.vel_end.tobytes() and ca.acc.tobytes() == cb.acc.tobytes()


@need_core
@pytest.mark.parametrize("where", ["large", "small"])
def test_int_r2_probe_still_rejects(where, monkeypatch):
    """A core whose int_r2 sum is one ulp off at the probe's large sizes only (or its small
    ones only) is not taken."""
    class Off:
        def __getattr__(self, k):
            return getattr(CORE, k)

        @staticmethod
        def ring_int_r2(c, dur, *rest):
            got = CORE.ring_int_r2(c, dur, *rest)
            n = len(dur)
            if got is not None and ((n > 1000) if where == "large" else (n == 129)):
                got = float(np.nextafter(got, np.inf))
            return got
    osc = res.Oscillator(47.0, 0.09)
    assert res._int_r2_core(osc.s, osc.wd) is not None or True     # (whatever the real core says)
    monkeypatch.setattr(res, "_INT_R2_OK", {})
    monkeypatch.setattr(res, "_core", lambda: Off())
    assert res._int_r2_core(osc.s, osc.wd) is None
