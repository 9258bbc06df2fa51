"""Session 58 (common): a ringing stream's joined events solved in one call of the core.

_Stream.add_joined (a stream without a shaper) took its steps in numpy -- the new times +
0.0, the order check, np.searchsorted for the events before the horizon, then _solve and
Oscillator.solve's Python around the core's ring_solve (~20 us a call, 286 calls on the
rectilinear plate's two ringing passes).  Oscillator.join takes them in one call of the
core (ring_join) and declines where add_joined's own steps must run (times out of order, a
number not finite, no core).

Checked bit for bit against add_joined's own steps (resonance.USE_JOIN off, the reference):
stream by stream on random events (waiting events, a carried time or none, horizons
before, among, on and after the events, inf and NaN, -0.0 times, times out of order, a
number not finite), and whole Collectors' figures on sample files cut into small chunks."""
import os

import numpy as np
import pytest

from gcode_opt import ringing as rg
from gcode_opt.firmware import resonance as res
from gcode_opt.firmware import simulate as fw
from gcode_opt.profile import load_profile
# (a Collector's figures played in chunks, and as bits: the joined events' own tests')
from test_speed39_ringc_joined import _bits, _figures

SAMPLES = os.path.join(os.path.dirname(__file__), "..", "sample_gcode")
CORE = fw._core
need_core = pytest.mark.skipif(CORE is None or not hasattr(CORE, "ring_join"),
                               reason="the compiled firmware core is not built here")
MODEL = {"freq_x_hz": 47.0, "freq_y_hz": 53.0, "damping_r": 0.1, "shaper": "none", "shaper_freq_x_hz": 47.0,
         "shaper_freq_y_hz": 53.0, "shaper_damping_r": 0.1}


def _stream(rng, t0):
    """A stream of MODEL's X oscillator with a carried time (or none) and waiting events
    (as a chunk before left it)."""
    osc = res.Oscillator(MODEL["freq_x_hz"], MODEL["damping_r"])
    st = rg._Stream(osc, rg._pulses(MODEL, "none")[0])
    assert st.plain
    if rng.uniform() < 0.7:
        st.t_last = t0 - float(rng.uniform(0.0, 0.01))
        st.c_last = complex(rng.normal(), rng.normal()) * 1e-3
        st.peak = float(rng.uniform(0.0, 2e-3))
        st.int_r2 = float(rng.uniform(0.0, 1e-6))
    nw = int(rng.integers(0, 4))
    st.t = np.sort(t0 + rng.uniform(0.0, 0.01, nw))
    st.dr, st.drp = rng.normal(size=nw) * 1e-4, rng.normal(size=nw) * 1e-2
    return st


def _joined(rng, st, n):
    """add_joined's arrays (as _events writes them): the carried time and the waiting events
    in front of n new ones -- times with repeats (pieces of length 0) and -0.0 among them."""
    new_t = np.cumsum(rng.choice([0.0, 0.0, 1e-3, 2.5e-3], n) * (rng.uniform(size=n) < 0.9))
    new_t += (st.t[-1] if len(st.t) else (st.t_last if st.t_last is not None else 0.0))
    if n and st.t_last is None and not len(st.t) and rng.uniform() < 0.5:
        new_t[:int(rng.integers(1, n + 1))] = -0.0
    front = ([st.t_last] if st.t_last is not None else []) + list(st.t)
    t1 = np.concatenate([np.array(front, float), new_t])
    dr1 = np.concatenate([st.dr, rng.normal(size=n) * 1e-4])
    drp1 = np.concatenate([st.drp, rng.normal(size=n) * 1e-2])
    return t1, dr1, drp1


def _state(st):
    def b(x):
        return None if x is None else np.asarray(x, complex if isinstance(x, complex) else float).tobytes()
    return (b(st.t_last), b(st.c_last), b(st.int_r2), b(st.peak), st.t.tobytes(), st.dr.tobytes(),
            st.drp.tobytes())


def _copy(st):
    c = rg._Stream(st.osc, (st.a_p, st.t_p))
    c.t, c.dr, c.drp = st.t.copy(), st.dr.copy(), st.drp.copy()
    c.t_last, c.c_last, c.int_r2, c.peak = st.t_last, st.c_last, st.int_r2, st.peak
    return c


def _join_spy(took):
    """Oscillator.join that appends to took whether the core's join took the steps."""
    real = res.Oscillator.join

    def spy(self, *a):
        got = real(self, *a)
        took.append(got is not None)
        return got
    return spy


def _both(monkeypatch, st, t1, dr1, drp1, horizon_t):
    """(the stream after add_joined with the core's join, after add_joined's own steps,
    whether the join took them)"""
    took = []
    real = res.Oscillator.join
    spy = _join_spy(took)
    a, b = _copy(st), _copy(st)
    monkeypatch.setattr(res.Oscillator, "join", spy)
    a.add_joined(t1.copy(), dr1.copy(), drp1.copy(), horizon_t)
    monkeypatch.setattr(res.Oscillator, "join", real)
    monkeypatch.setattr(res, "USE_JOIN", False)
    b.add_joined(t1.copy(), dr1.copy(), drp1.copy(), horizon_t)
    monkeypatch.setattr(res, "USE_JOIN", True)
    return a, b, took == [True]


@need_core
@pytest.mark.parametrize("seed", range(8))
def test_join_is_add_joineds_steps(monkeypatch, seed):
    rng = np.random.default_rng(seed)
    joined = 0
    for n in (0, 1, 2, 5, 40, 300):
        st = _stream(rng, float(rng.uniform(0.0, 5.0)))
        t1, dr1, drp1 = _joined(rng, st, n)
        t_all = t1[st.t_last is not None:]
        picks = [np.inf, np.nan, -np.inf, float(t_all[0]) - 1.0 if len(t_all) else 0.0]
        if len(t_all):
            picks += [float(t_all[len(t_all) // 2]), float(t_all[-1]), float(t_all[-1]) + 1e-3,
                      float(rng.uniform(t_all[0], t_all[-1]))]
        for horizon_t in picks:
            a, b, took = _both(monkeypatch, st, t1, dr1, drp1, horizon_t)
            assert _state(a) == _state(b), (seed, n, horizon_t)
            joined += took
    assert joined > 20                     # (the join ran, not only add_joined's own steps)


@need_core
@pytest.mark.filterwarnings("ignore::RuntimeWarning")      # (numpy's steps on inf: NaN, as add_joined's own)
def test_join_declines_times_out_of_order_and_numbers_not_finite(monkeypatch):
    rng = np.random.default_rng(58)
    st = _stream(rng, 1.0)
    st.t_last = None
    t1, dr1, drp1 = _joined(rng, st, 50)
    bad = t1.copy()
    bad[10], bad[11] = bad[11] + 1e-3, bad[10]                # out of order: add sorts them
    a, b, took = _both(monkeypatch, st, bad, dr1, drp1, np.inf)
    assert not took and _state(a) == _state(b)
    nan_t = t1.copy()
    nan_t[5] = np.nan
    a, b, took = _both(monkeypatch, st, nan_t, dr1, drp1, np.inf)
    assert not took and _state(a) == _state(b)
    inf_dr = dr1.copy()
    inf_dr[7] = np.inf                                        # solve declines: numpy's steps
    a, b, took = _both(monkeypatch, st, t1, inf_dr, drp1, np.inf)
    assert not took and _state(a) == _state(b)


@need_core
def test_ring_join_checks_its_arguments():
    osc = res.Oscillator(50.0, 0.1)
    args = (osc.s, osc.wd) + res._int_r2_args(osc.s, osc.lam)
    t1, dr = np.arange(4.0), np.zeros(4)
    assert CORE.ring_join(t1, dr, dr, 0, 0, np.inf, None, 0.0, *args)[0] == 4
    assert CORE.ring_join(np.arange(5.0), dr, dr, 1, 0, 2.5, 0j, 0.0, *args)[0] == 2
    with pytest.raises(ValueError):
        CORE.ring_join(t1, dr, dr, 1, 0, np.inf, 0j, 0.0, *args)           # no room for the carried time
    with pytest.raises(ValueError):
        CORE.ring_join(np.arange(5.0), dr, dr, 1, 0, np.inf, None, 0.0, *args)   # carried time, no amplitude
    with pytest.raises(ValueError):
        CORE.ring_join(t1, dr, dr[:3], 0, 0, np.inf, None, 0.0, *args)
    with pytest.raises(ValueError):
        CORE.ring_join(t1, dr, dr, 0, 5, np.inf, None, 0.0, *args)
    # not contiguous arrays of doubles (t1 writable): declined, nothing written (the caller's steps)
    neg = np.full(4, -0.0)
    for t, d in ((np.arange(8.0)[::2], dr), (t1.astype(np.float32), dr), (t1, dr.astype(np.float32)),
                 (np.frombuffer(t1.tobytes()), dr), (t1, np.zeros(8)[::2]), (list(t1), dr)):
        assert CORE.ring_join(t, d, dr, 0, 0, np.inf, None, 0.0, *args) is None
    assert CORE.ring_join(neg, dr, dr, 0, 0, np.inf, None, 0.0, *args)[0] == 4
    assert np.signbit(neg).sum() == 0                       # (the new times + 0.0: -0.0 made 0.0)


@pytest.mark.parametrize("name,prof,chunk", [("prusa_gyroid.gcode", "prusa-mk3s", 300),
                                              ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 97),
                                              ("prusa_klipper.gcode", "voron24", 500)])
def test_figures_equal_add_joineds_own_steps(monkeypatch, name, prof, chunk):
    path = os.path.join(SAMPLES, name)
    profile = load_profile(prof)
    took = []
    spy = _join_spy(took)
    for parts in (True, False):
        took.clear()
        monkeypatch.setattr(res.Oscillator, "join", spy)
        got, chunks = _figures(path, profile, chunk, parts)
        if CORE is not None and hasattr(CORE, "ring_join"):
            assert sum(took) >= 2 * chunks > 4          # (the join took the streams' steps, chunk after chunk)
        monkeypatch.setattr(res, "USE_JOIN", False)
        want, _ = _figures(path, profile, chunk, parts)
        monkeypatch.setattr(res, "USE_JOIN", True)
        assert _bits(got) == _bits(want)
