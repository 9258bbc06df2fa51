"""The ringing's exponential memo (resonance.RingMemo; ring_amps' and ring_int_r2's memo
arguments): Y's stream of a part takes the exponentials X's stream of that part made for an
event at the same time in a restart from the same time (the same tt, bit for bit), and for
a piece from the same start of the same length.  Reference: the same calls without a memo
(every exponential from libm, as before): the amplitudes, the sums and whole files'
figures must be the same bits, with memos from other, overlapping event sets (restarts
that start elsewhere, events at one time, NaN restart starts where numpy made a restart)."""
import dataclasses
import os

import numpy as np
import pytest

from gcode_opt import ringing as rg
from gcode_opt.firmware import resonance as res
from gcode_opt.firmware import simulate as fw
from gcode_opt.profile import load_profile

SAMPLES = os.path.join(os.path.dirname(__file__), "..", "sample_gcode")
CORE = fw._core
need_core = pytest.mark.skipif(CORE is None or not hasattr(CORE, "ring_amps"),
                               reason="the compiled firmware core is not built here")


def _events(rng, n, dup=0.3, gap=0.01):
    """Sorted event times with runs at one time (blocks without cruise)."""
    gaps = rng.exponential(gap, n) * (rng.uniform(size=n) > dup)
    gaps[rng.uniform(size=n) < 0.005] *= 2000.0          # long pauses: restarts apart
    return np.cumsum(gaps) + rng.uniform(0.0, 5.0)


def _subset(rng, t, keep_r):
    """Another stream's events: most of t's, some dropped, some added between."""
    keep = rng.uniform(size=len(t)) < keep_r
    extra = rng.choice(t, max(len(t) // 50, 1)) + rng.uniform(0.0, 1e-3, max(len(t) // 50, 1))
    return np.sort(np.concatenate([t[keep], extra]))


def _amps(osc, t, dc, span, short, memo=None, keep=False):
    fused = res._amps_mode(CORE, osc.s, osc.wd, span)
    c = np.empty(len(t), complex)
    extra = ()
    if memo is not None or keep:
        out = (np.full(len(t), np.nan), np.empty(4 * len(t))) if keep else (None, None)
        extra = (memo or (None, None, None)) + out
    end = CORE.ring_amps(t, dc, osc.s, osc.wd, span, short, 0, 0j, float(t[0]), c, fused, *extra)
    return end, c, (t, extra[3], extra[4]) if keep else None


@need_core
@pytest.mark.parametrize("seed", range(8))
def test_ring_amps_with_a_memo_is_without(seed):
    rng = np.random.default_rng(seed)
    osc = res.Oscillator([50.0, 37.0, 80.0, 50.0][seed % 4], [0.1, 0.05, 0.2, 0.1][seed % 4])
    span = res.CHUNK_DECAY / osc.s
    n = 3000 + 500 * seed
    t1 = _events(rng, n)
    short = [1 << 30, 200, 50, 1 << 30][seed % 4]       # restarts the core leaves (NaN in the memo)
    end1, c1, memo = _amps(osc, t1, rng.normal(size=n) + 1j * rng.normal(size=n), span, short, keep=True)
    if end1 < n:
        assert np.isnan(memo[1][end1:]).all()
    assert not np.isnan(memo[1][:end1]).any()
    for keep_r in (1.0, 0.999, 0.9, 0.5):
        t2 = t1.copy() if keep_r == 1.0 else _subset(rng, t1, keep_r)
        if keep_r == 1.0 and seed % 2:
            t2 = t2[5:]                                  # restarts from another event
        dc = rng.normal(size=len(t2)) + 1j * rng.normal(size=len(t2))
        dc[rng.uniform(size=len(t2)) < 0.1] = 0.0
        want = _amps(osc, t2, dc, span, short)
        got = _amps(osc, t2, dc, span, short, memo)
        assert got[0] == want[0]
        assert got[1][:got[0]].tobytes() == want[1][:want[0]].tobytes(), keep_r
        # and a memo of another oscillator's numbers would show: the memo is really read
        if keep_r == 1.0 and not seed % 2 and got[0] > 10:
            bad = (memo[0], memo[1], memo[2] * (1.0 + 2.0 ** -40))
            assert _amps(osc, t2, dc, span, short, bad)[1][:got[0]].tobytes() != want[1][:want[0]].tobytes()


@need_core
@pytest.mark.parametrize("seed", range(6))
def test_ring_int_r2_with_a_memo_is_without(seed):
    rng = np.random.default_rng(100 + seed)
    osc = res.Oscillator(50.0 + seed, 0.1)
    if res._int_r2_core(osc.s, osc.wd) is None:
        pytest.skip("ring_int_r2 does not give numpy's bits here")
    args = res._int_r2_args(osc.s, osc.lam)
    n = 4000
    t1 = _events(rng, n)
    ts1, dur1 = t1[:-1], np.diff(t1)
    c1 = rng.normal(size=n - 1) + 1j * rng.normal(size=n - 1)
    ov = np.empty(3 * (n - 1))
    r1 = CORE.ring_int_r2(c1, dur1, np.exp(-2.0 * osc.s * dur1), *args, np.empty(n - 1), ts1, None, None, None, ov)
    assert r1 == CORE.ring_int_r2(c1, dur1, np.exp(-2.0 * osc.s * dur1), *args, np.empty(n - 1))
    memo = (ts1, dur1, ov)
    for keep_r in (1.0, 0.99, 0.7):
        t2 = t1.copy() if keep_r == 1.0 else _subset(rng, t1, keep_r)
        ts2, dur2 = t2[:-1], np.diff(t2)
        c2 = rng.normal(size=len(dur2)) + 1j * rng.normal(size=len(dur2))
        d2 = np.exp(-2.0 * osc.s * dur2)
        w1, w2 = np.empty(len(dur2)), np.empty(len(dur2))
        want = CORE.ring_int_r2(c2, dur2, d2, *args, w1)
        got = CORE.ring_int_r2(c2, dur2, d2, *args, w2, ts2, *memo, None)
        assert np.float64(got).tobytes() == np.float64(want).tobytes()
        assert w1.tobytes() == w2.tobytes()
        if keep_r == 1.0:        # the memo is read: wrong numbers in it show
            bad = (ts1, dur1, ov * (1.0 + 2.0 ** -40))
            w3 = np.empty(len(dur2))
            CORE.ring_int_r2(c2, dur2, d2, *args, w3, ts2, *bad, None)
            assert w3.tobytes() != w1.tobytes()
        # same starts, other lengths: nothing taken
        got = CORE.ring_int_r2(c2, dur2, d2, *args, w2, ts2, ts1[:len(dur2)], dur1[:len(dur2)] * 1.5 + 1e-3,
                               ov[:3 * len(dur2)] * 0.0, None)
        assert np.float64(got).tobytes() == np.float64(want).tobytes()


def _figures(path, profile, use_memo, monkeypatch, shaper=None, chunk=rg.CHUNK_BLOCKS):
    monkeypatch.setattr(res, "USE_MEMO", use_memo)
    col = rg.Collector(profile, shaper, chunk)
    rg.play(path, profile, col)
    return col.figures()


CASES = [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24"),
         ("cura_box.gcode", "ender3"), ("prusa_gyroid_arcs.gcode", "voron24"),
         ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s")]


@pytest.mark.parametrize("shaper", [None, "mzv"])
@pytest.mark.parametrize("chunk", [rg.CHUNK_BLOCKS, 333])
@pytest.mark.parametrize("name,prof", CASES)
def test_figures_with_and_without_the_memo(monkeypatch, name, prof, chunk, shaper):
    path = os.path.join(SAMPLES, name)
    profile = load_profile(prof)
    want = _figures(path, profile, False, monkeypatch, shaper, chunk)
    got = _figures(path, profile, True, monkeypatch, shaper, chunk)
    assert repr(got) == repr(want)


def test_axes_of_other_frequencies(monkeypatch):
    """X and Y of different resonances: Y takes nothing of X's (another oscillator)."""
    path = os.path.join(SAMPLES, "prusa_klipper.gcode")
    profile = dataclasses.replace(load_profile("voron24"), freq_x_hz=41.0, freq_y_hz=57.0)
    want = _figures(path, profile, False, monkeypatch)
    assert repr(_figures(path, profile, True, monkeypatch)) == repr(want)
