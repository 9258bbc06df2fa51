"""The ringing's events of a chunk in one core pass (ringing._events: _core.c ring_events)
against the ddecd40 code it replaces where no shaper is set, kept here verbatim
(_ref_events: Collector._flush's loop over _pieces' trace without positions, _jumps and the
parts' masks): every stream's times, dr and drp bit for bit, and the carry, on real files'
rows cut into chunks and on random and degenerate rows (zeros of both signs, NaN, inf,
rests, stops, turns either side of the corner threshold); and whole files' figures with and
without it."""
import math
import os

import numpy as np
import pytest

from gcode_opt import ringing as rg
from gcode_opt.firmware import simulate as fw
from gcode_opt.firmware.simulate import CORNER_COS
from gcode_opt.profile import load_profile
from gcode_opt.ringing import CORNER, PARTS, TURN, _Carry, _jumps, _pieces

SAMPLES = os.path.join(os.path.dirname(__file__), "..", "sample_gcode")
CORE = fw._core
need_core = pytest.mark.skipif(CORE is None or not hasattr(CORE, "ring_events"),
                               reason="the compiled firmware core is not built here")


# ---------------------------------------------------------------- ddecd40, verbatim (Collector._flush)
def _ref_events(m, carry, model):
    got = {}
    tr = _pieces(m, carry, False)
    for ax, name in enumerate("xy"):
        # the jumps of _jumps, each made once for the parts that share it: ramp and
        # all take da / w^2, all, corner and turn -dv (where it is not 0, the same
        # values as np.where(cls == ..., -dv, 0))
        dr, drp = _jumps(tr, model, name, ax, "all")
        ramp, jump = dr != 0.0, drp != 0.0
        keeps = {"all": ramp | jump, "ramp": ramp, "corner": jump & (tr.cls == CORNER),
                 "turn": jump & (tr.cls == TURN)}
        for part in ("all",) + PARTS:
            keep = keeps[part]
            zero = np.zeros(int(keep.sum()))
            got[name, part] = (tr.t0[keep], dr[keep] if part in ("all", "ramp") else zero,
                               drp[keep] if part != "ramp" else zero)
    return got


def _same(m, model, c_ref=None, c_new=None):
    c_ref = c_ref or _Carry()
    c_new = c_new or _Carry()
    want = _ref_events(m, c_ref, model)
    got = rg._events(m, c_new, model)
    assert list(got) == list(want)
    for k in want:
        for a, b in zip(got[k], want[k]):
            assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), k
    for key in ("t", "ux", "uy", "isb"):
        assert np.float64(getattr(c_ref, key)).tobytes() == np.float64(getattr(c_new, key)).tobytes(), key
    assert c_ref.vel_end.tobytes() == c_new.vel_end.tobytes() and c_ref.acc.tobytes() == c_new.acc.tobytes()
    return c_ref, c_new


def _rows(name, prof):
    rows = rg.Rows()
    rg.play(os.path.join(SAMPLES, name), load_profile(prof), rows)
    return np.asarray(rows.items, float).reshape(-1, rg.ROW)


MODELS = [rg.model_of(load_profile("prusa-mk3s")),
          dict(rg.model_of(load_profile("voron24")), freq_x_hz=41.3, freq_y_hz=63.0)]


@need_core
@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24"),
                                       ("cura_box.gcode", "ender3"), ("prusa_gyroid_arcs.gcode", "voron24")])
@pytest.mark.parametrize("chunk", [1, 2, 97, 5000])
def test_real_rows_in_chunks(name, prof, chunk):
    m = _rows(name, prof)
    idle = np.array([rg.IDLE])
    m = np.vstack([idle, m, idle])
    for model in MODELS:
        ca = cb = None
        for lo in range(0, len(m), chunk):
            ca, cb = _same(m[lo:lo + chunk].copy(), model, ca, cb)


def _random_rows(rng, n):
    m = np.zeros((n, 12))
    ang = rng.uniform(0, 2 * math.pi, n)
    # turns either side of the corner threshold, axis-parallel moves, pure Z (no XY)
    m[:, 0], m[:, 1] = np.cos(ang), np.sin(ang)
    k = rng.uniform(size=n) < 0.2
    m[k, 0], m[k, 1] = rng.choice([1.0, -1.0, 0.0, -0.0], (k.sum(), 2)).T
    near = rng.uniform(size=n) < 0.1
    base = np.arccos(CORNER_COS)
    ang2 = np.where(near, np.roll(ang, 1) + base * (1 + rng.choice([-1e-15, 0.0, 1e-15], n)), ang)
    m[near, 0], m[near, 1] = np.cos(ang2[near]), np.sin(ang2[near])
    m[:, 2] = rng.uniform(0, 100, n)
    m[:, 3] = m[:, 2] + rng.uniform(0, 50, n)
    m[:, 4] = rng.uniform(0, 100, n)
    m[:, 5] = rng.choice([0.0, -0.0, 500.0, 1234.5678, 1e-300, 3e5], n)
    for j in (6, 7, 8):
        m[:, j] = rng.exponential(0.01, n) * (rng.uniform(size=n) > 0.3)
    m[:, 9] = rng.choice([0.0, 1.0], n, p=[0.8, 0.2])
    m[:, 10] = np.arange(n)
    m[:, 11] = rng.choice([1.0, 0.0], n, p=[0.85, 0.15])
    rest = m[:, 11] == 0.0                       # rests: no direction, no speed
    m[rest, :6] = 0.0
    m[rest, 9] = 1.0
    m[rest, 10] = -1
    for _ in range(max(n // 200, 1)):            # odd numbers anywhere
        m[rng.integers(n), rng.integers(10)] = rng.choice([np.nan, np.inf, -np.inf, -0.0, 5e-324, 1e308])
    return m


@need_core
@pytest.mark.parametrize("seed", range(10))
def test_random_and_degenerate_rows(seed):
    rng = np.random.default_rng(seed)
    m = _random_rows(rng, int(rng.integers(1, 3000)))
    for model in MODELS:
        ca = cb = None
        for lo in range(0, len(m), 701):
            ca, cb = _same(m[lo:lo + 701].copy(), model, ca, cb)


@need_core
def test_carry_from_odd_values():
    """A carry that is not at rest (the chunk before ended moving), and one of NaN."""
    rng = np.random.default_rng(3)
    m = _random_rows(rng, 50)
    for vals in ((1.5, 3.0, -2.0, 700.0, -0.0, 0.6, 0.8, 1.0), (np.nan, np.nan, 0.0, np.inf, 1.0, np.nan, 0.0, 1.0)):
        cs = []
        for _ in range(2):
            c = _Carry()
            c.t, c.vel_end, c.acc = vals[0], np.array(vals[1:3]), np.array(vals[3:5])
            c.ux, c.uy, c.isb = vals[5:]
            cs.append(c)
        _same(m.copy(), MODELS[0], *cs)


def _figures(monkeypatch, use, path, profile, chunk):
    monkeypatch.setattr(rg, "USE_EVENTS", use)
    col = rg.Collector(profile, None, chunk)
    rg.play(path, profile, col)
    return col.figures()


@pytest.mark.parametrize("chunk", [rg.CHUNK_BLOCKS, 50])
@pytest.mark.parametrize("name,prof", [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"),
                                       ("prusa_klipper.gcode", "voron24"), ("cura_box.gcode", "ender3")])
def test_figures_with_and_without(monkeypatch, name, prof, chunk):
    path, profile = os.path.join(SAMPLES, name), load_profile(prof)
    assert repr(_figures(monkeypatch, True, path, profile, chunk)) == \
        repr(_figures(monkeypatch, False, path, profile, chunk))


def test_without_the_core_or_with_a_shaper_none(monkeypatch):
    monkeypatch.setattr(rg, "USE_EVENTS", False)
    assert rg._events(np.zeros((3, 12)), _Carry(), MODELS[0]) is None


@pytest.mark.parametrize("seed", range(4))
def test_plain_stream_skips_shaped_events(seed):
    """Without a shaper a stream takes t + 0.0 and the jumps as they are: the same events
    as shaped_events makes (weight 1.0, time 0.0), the same sums; with a shaper it shapes."""
    from gcode_opt.firmware.resonance import Oscillator, shaper_pulses
    rng = np.random.default_rng(seed)
    osc = Oscillator(50.0, 0.1)
    for shaper in ("none", "zv"):
        pulses = shaper_pulses(shaper, 50.0)
        a, b = rg._Stream(osc, pulses), rg._Stream(osc, pulses)
        assert a.plain == (shaper == "none")
        b.plain = False
        t0 = 0.0
        for _ in range(5):
            n = int(rng.integers(0, 400))
            t = t0 + np.cumsum(rng.exponential(0.01, n) * (rng.uniform(size=n) > 0.3))
            if n:
                t[0] = rng.choice([t[0], -0.0, 0.0]) if t0 == 0.0 else t[0]
            dr = rng.normal(size=n) * (rng.uniform(size=n) > 0.2)
            drp = -(rng.normal(size=n) * (rng.uniform(size=n) > 0.5))
            for s in (a, b):
                s.add(t, dr, drp, (t[-1] if n else t0) - 0.005)
            t0 = t[-1] if n else t0
        got, want = a.finish(), b.finish()
        assert np.float64(got).tobytes() == np.float64(want).tobytes()
