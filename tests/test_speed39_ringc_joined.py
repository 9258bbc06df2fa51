"""Session 39 (ringc): the ringing streams' events without concatenations.

Collector._flush has ring_events leave room (its `front`) before each output, writes each
stream's carried time and waiting events there (_events' lead) and hands the joined
arrays to _Stream.add_joined, which does add's and _solve's steps on views of them
instead of np.concatenate-ing (~8 instructions a number each).

Checked bit for bit against the code it replaces: _events with a lead gives, per stream,
[t_last] + waiting + the new events (the new events the same as without a lead), on
random rows with varied waiting events; whole Collectors' figures equal those of add()
(the 8a00d23 path: _events without a lead, add) on sample files cut into small chunks
(many flushes, waiting events), with and without the parts."""
import os

import numpy as np
import pytest

from gcode_opt import ringing as rg
from gcode_opt.firmware import simulate as fw
from gcode_opt.profile import load_profile
from gcode_opt.ringing import _Carry

SAMPLES = os.path.join(os.path.dirname(__file__), "..", "sample_gcode")
CORE = fw._core
need_core = pytest.mark.skipif(CORE is None or not hasattr(CORE, "ring_events"),
                               reason="the compiled firmware core is not built here")
MODEL = {"freq_x_hz": 47.0, "freq_y_hz": 53.0, "damping_r": 0.1, "shaper": "none"}


def _rows(rng, n):
    m = np.zeros((n, rg.ROW))
    ang = rng.uniform(0.0, 2.0 * np.pi, n)
    m[:, 0], m[:, 1] = np.cos(ang), np.sin(ang)
    m[:, 2:5] = rng.uniform(0.0, 100.0, (n, 3))
    m[:, 5] = rng.uniform(0.0, 3000.0, n)
    m[:, 6:9] = rng.uniform(0.0, 0.05, (n, 3)) * (rng.uniform(size=(n, 3)) < 0.8)
    m[:, 9] = rng.uniform(size=n) < 0.1
    m[:, 10] = np.arange(n)
    m[:, 11] = rng.uniform(size=n) < 0.9
    rest = m[:, 11] == 0.0
    m[rest, :7] = 0.0
    m[rest, 8] = 0.0
    return m


class _Lead:
    """What _events reads of a stream: its carried time and waiting events."""

    def __init__(self, t_last, t, dr, drp):
        self.t_last, self.t, self.dr, self.drp = t_last, t, dr, drp

    def front(self):
        return (self.t_last is not None) + len(self.t)


@need_core
@pytest.mark.parametrize("seed", range(6))
def test_events_with_a_lead_are_the_joined_arrays(seed):
    rng = np.random.default_rng(seed)
    for n in (1, 2, 7, 300):
        m = _rows(rng, n)
        for parts in (True, False):
            want = rg._events(m, _Carry(), MODEL, parts)
            lead = {}
            for key in want:
                nw = int(rng.integers(0, 5))
                t_last = None if rng.uniform() < 0.3 else float(rng.uniform(-2.0, 0.0))
                # (a part's waiting dr or drp where it has none: zeros, as its stream's)
                dr = rng.normal(size=nw) if key[1] in ("all", "ramp") else np.zeros(nw)
                drp = rng.normal(size=nw) if key[1] != "ramp" else np.zeros(nw)
                lead[key] = _Lead(t_last, rng.uniform(-1.0, 0.0, nw), dr, drp)
            room = rg.Room()
            room.grab(1)                         # (a room too small: grown)
            got = rg._events(m, _Carry(), MODEL, parts, room, lead)
            assert list(got) == list(want)
            for (name, part), arrs in want.items():
                st = lead[name, part]
                t_front = ([st.t_last] if st.t_last is not None else []) + list(st.t)
                w_t = np.concatenate([np.array(t_front, float), arrs[0]])
                w_dr = np.concatenate([st.dr, arrs[1]])
                w_drp = np.concatenate([st.drp, arrs[2]])
                for a, b in zip(got[name, part], (w_t, w_dr, w_drp)):
                    assert a.tobytes() == b.tobytes(), (name, part, seed, n)


@need_core
def test_ring_events_front_checks_the_lengths():
    m = np.zeros((3, rg.ROW))
    args = (m, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.5)
    n, f = 3, 2
    CORE.ring_events(*args, np.empty(16 * n + 8 * f), np.empty(12 * n + 4 * f), np.empty(10 * n + 6 * f), False, f)
    with pytest.raises(ValueError):
        CORE.ring_events(*args, np.empty(16 * n), np.empty(12 * n), np.empty(10 * n), True, f)
    with pytest.raises(ValueError):
        CORE.ring_events(*args, np.empty(16 * n), np.empty(12 * n), np.empty(10 * n), True, -1)


def _events_alone(m, c, model, parts=True, room=None, lead=None):
    """8a00d23's _events: no lead (each stream's new events only)."""
    return _EVENTS(m, c, model, parts, room)


def _add(self, t, dr, drp, horizon_t):
    """8a00d23's path: the new events through add() (its concatenations)."""
    self.add(t, dr, drp, horizon_t)


_EVENTS = rg._events


def _figures(path, prof, chunk, parts):
    col = rg.Collector(prof, chunk_blocks=chunk, parts=parts)
    rg.play(path, prof, col)
    return col.figures(), col.chunks


def _bits(d):
    return {k: _bits(v) if isinstance(v, dict) else (float(v).hex() if isinstance(v, float) else v)
            for k, v in d.items()}


@need_core
@pytest.mark.parametrize("name,prof,chunk", [("prusa_gyroid.gcode", "prusa-mk3s", 300),
                                              ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 97),
                                              ("prusa_klipper.gcode", "voron24", 500)])
def test_figures_equal_the_add_path(monkeypatch, name, prof, chunk):
    path = os.path.join(SAMPLES, name)
    profile = load_profile(prof)
    calls = {"n": 0}
    real = rg._Stream.add_joined

    def spy(self, *a):
        calls["n"] += 1
        return real(self, *a)
    for parts in (True, False):
        monkeypatch.setattr(rg._Stream, "add_joined", spy)
        got, chunks = _figures(path, profile, chunk, parts)
        assert calls["n"] >= 2 * chunks > 4      # (the joined path ran, chunk after chunk)
        monkeypatch.setattr(rg._Stream, "add_joined", _add)
        monkeypatch.setattr(rg, "_events", _events_alone)
        want, _ = _figures(path, profile, chunk, parts)
        monkeypatch.setattr(rg, "_events", _EVENTS)
        assert _bits(got) == _bits(want)
