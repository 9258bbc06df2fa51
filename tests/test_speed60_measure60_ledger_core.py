"""The measure pass's whole ledger written in C (session 60, simulate._LedgerWriter.ledger_core:
a LedgerCore as play_buf's on_quiet records every stop and every watched range's start where
play_loop meets them; play_buf returns at a block's end only) against the Python writer it
replaces (USE_LEDGER_CORE and USE_QUIET_CORE off: play_buf returns at each stop with a range
pending, range_starts / stopped in Python): every ledger field, the result, the barriers'
callbacks, on the samples with sparse, dense and odd watches (ranges holding a stop, ranges
past the file's end, none) and, where the corpus is here, on the rectilinear plate; the
core is used (not a fallback); errors propagate."""
from __future__ import annotations

import pytest
from test_speed50_boot50_quiet_stops import _watch
from test_speed51_meas51_quiet_core import FILES as QUIET_FILES, RECT, SAMPLES, _fields, _profile

from gcode_opt import state as st
from gcode_opt.firmware import simulate as fwsim
from gcode_opt.profile import load_profile

FILES = QUIET_FILES + ["edge/klipper_macros.gcode"]     # (the quiet core's samples and Klipper's macros)

pytestmark = pytest.mark.skipif(fwsim.CORE != "c" or not hasattr(fwsim._core, "ledger_new"),
                                reason="compiled core")


def _run(path, profile, watch, core, monkeypatch):
    """simulate_ledger with the LedgerCore (core) or the Python writer; how many LedgerCores
    were made and how many stops the Python writer recorded"""
    barriers, made, py_stops = [], [0], [0]
    real_new, real_stopped = fwsim._core.ledger_new, fwsim._LedgerWriter.stopped

    def ledger_new(*a):
        made[0] += 1
        return real_new(*a)

    def stopped(w, idx):
        py_stops[0] += 1
        return real_stopped(w, idx)
    with monkeypatch.context() as m:
        m.setattr(fwsim, "USE_LEDGER_CORE", core)
        m.setattr(fwsim, "USE_QUIET_CORE", core)
        m.setattr(fwsim._core, "ledger_new", ledger_new)
        m.setattr(fwsim._LedgerWriter, "stopped", stopped)
        r, led = fwsim.simulate_ledger(str(path), profile, watch, on_barrier=barriers.append)
    return (r, led, barriers), made[0], py_stops[0]


def _same(path, profile, watch, monkeypatch):
    (a, made, py_stops), (b, made0, py_stops0) = (_run(path, profile, watch, c, monkeypatch) for c in (True, False))
    assert made == 1 and py_stops == 0 and made0 == 0
    assert _fields(a[1]) == _fields(b[1])
    assert repr(a[0].as_dict()) == repr(b[0].as_dict()) and repr(a[2]) == repr(b[2])
    return b[1], py_stops0


@pytest.mark.parametrize("name", FILES)
@pytest.mark.parametrize("step", [0, 3, 40, 400])
def test_ledger_core_same_ledger(name, step, monkeypatch):
    path = SAMPLES / name
    n = sum(1 for _ in open(path, "rb"))
    _same(path, _profile(name), _watch(n, step, step + len(name)), monkeypatch)


@pytest.mark.parametrize("name", FILES[:4])
def test_ledger_core_odd_watches(name, monkeypatch):
    """no range; a range over every line (each stop inside one: ok False); one range past
    the file's end"""
    path = SAMPLES / name
    n = sum(1 for _ in open(path, "rb"))
    led, stops = _same(path, _profile(name), [], monkeypatch)
    assert stops > 10 and len(led.line) == 1
    led, _ = _same(path, _profile(name), [(k, k) for k in range(n)], monkeypatch)
    assert not led.ok and len(led.lo) == n
    led, _ = _same(path, _profile(name), [(0, n // 2), (n + 3, n + 9)], monkeypatch)
    assert not led.ok


@pytest.mark.skipif(not RECT.exists(), reason="corpus plate not here")
def test_ledger_core_rect_plate(monkeypatch):
    """a real plate: sparse ranges (the measure's shape: most stops quiet, ~1.2 k not)"""
    n = sum(1 for _ in open(RECT, "rb"))
    led, stops = _same(RECT, load_profile("prusa-mk3s"), _watch(n, 600, 51), monkeypatch)
    assert stops > 1000 and len(led.hi) > 100


def test_ledger_core_snapshot_error_propagates(monkeypatch):
    """a snapshot that fails at the fifth stop: the pass raises it (the session closed)"""
    calls = [0]
    real = st._modal_of

    def failing(state):
        calls[0] += 1
        if calls[0] == 6:                  # (the writer's first snapshot, then five stops)
            raise RuntimeError("snapshot failed")
        return real(state)
    monkeypatch.setattr(st, "_modal_of", failing)
    path = SAMPLES / "prusa_gyroid.gcode"
    with pytest.raises(RuntimeError, match="snapshot failed"):
        fwsim.simulate_ledger(str(path), load_profile("prusa-mk3s"), _watch(10 ** 5, 40, 7))
    assert calls[0] == 6


def test_ledger_core_argument_errors():
    sim = fwsim.new_sim(load_profile("prusa-mk3s"), None, None)
    state = st.MachineState(load_profile("prusa-mk3s"), "x.gcode")
    from array import array
    args = (sim.res, st._modal_of, state, array("q", [3]), fwsim.Ledger(), state.snapshot())
    with pytest.raises(ValueError, match="eleven doubles"):
        fwsim._core.ledger_new(*args, bytes(80))
    with pytest.raises(TypeError):
        fwsim._core.ledger_new(object(), *args[1:], bytes(88))
    lc = fwsim._core.ledger_new(*args, bytes(88))
    assert fwsim._core.ledger_done(lc)[3:] == (-1, 0.0, 0.0, 0, True)
    with pytest.raises(TypeError):
        fwsim._core.ledger_done(state)
    with pytest.raises(TypeError):
        fwsim._core.ledger_flush(state)
    with pytest.raises(TypeError, match="not a list"):
        fwsim._core.ledger_new(*args[:4], type("L", (), {"state": ()})(), *args[5:], bytes(88))
