"""The measure pass's quiet stops kept by the compiled core (quiet_record on a QuietStops,
folded into the _LedgerWriter by absorb) against _LedgerWriter.stopped, the Python twin
they replace (USE_QUIET_CORE off): every ledger field, the result, the barriers'
callbacks, on the samples and, where the corpus is here, on the rectilinear plate; two twin
writers stepped stop by stop (every attribute the same after); fallbacks and errors."""
from __future__ import annotations

import os
from pathlib import Path

import pytest
from test_speed50_boot50_quiet_stops import _watch

from gcode_opt import state as st
from gcode_opt.firmware import simulate as fwsim
from gcode_opt.profile import load_profile

ROOT = Path(__file__).resolve().parent.parent
SAMPLES = ROOT / "sample_gcode"
FILES = ["prusa_gyroid.gcode", "prusa_mk3s_rectilinear.gcode", "prusa_klipper.gcode",
         "prusa_concentric_arcs.gcode", "edge/firmware_retraction.gcode", "edge/tool_changes.gcode",
         "edge/crlf_line_endings.gcode", "edge/relative_g91.gcode"]
RECT = Path(os.path.expanduser("~/.cache/gcode-opt-corpus/plate_rectilinear.gcode"))

pytestmark = pytest.mark.skipif(fwsim.CORE != "c" or not hasattr(fwsim._core, "quiet_record"),
                                reason="compiled core")


def _profile(name):
    return load_profile("voron24" if "klipper" in name else "prusa-mk3s")


def _run(path, profile, watch, core, monkeypatch):
    barriers = []
    with monkeypatch.context() as m:
        m.setattr(fwsim, "USE_QUIET_CORE", core)
        m.setattr(fwsim, "USE_LEDGER_CORE", False)   # (the QuietStops path: the LedgerCore's is test_speed60's)
        r, led = fwsim.simulate_ledger(str(path), profile, watch, on_barrier=barriers.append)
    return r, led, barriers


def _floats(snap):
    """a snapshot with its floats as repr (0.0 and -0.0 told apart)"""
    return tuple(repr(v) if type(v) is float else v for v in snap)


def _fields(led):
    """every field of a Ledger, its floats' bits (0.0 and -0.0 told apart)"""
    return ({f: getattr(led, f).tobytes() for f in ("line", "sums", "peak_v", "peak_a", "lo", "hi")},
            [_floats(s) for s in led.state], led.stop_lines, led.n_lines, led.ok)


def _same(a, b):
    """two runs' (result, ledger, barriers) the same"""
    assert _fields(a[1]) == _fields(b[1])
    assert repr(a[0].as_dict()) == repr(b[0].as_dict()) and repr(a[2]) == repr(b[2])


def _quiet_calls(path, profile, watch, monkeypatch):
    """how many stops the Python twin recorded with no range pending (quiet ones)"""
    n = [0]
    real = fwsim._LedgerWriter.stopped

    def stopped(w, idx):
        n[0] += not w.pending
        return real(w, idx)
    with monkeypatch.context() as m:
        m.setattr(fwsim._LedgerWriter, "stopped", stopped)
        _run(path, profile, watch, False, monkeypatch)
    return n[0]


@pytest.mark.parametrize("name", FILES)
@pytest.mark.parametrize("step", [0, 40, 400])
def test_ledger_quiet_same_ledger(name, step, monkeypatch):
    path = SAMPLES / name
    n = sum(1 for _ in open(path, "rb"))
    watch = _watch(n, step, step + len(name))
    _same(_run(path, _profile(name), watch, True, monkeypatch),
          _run(path, _profile(name), watch, False, monkeypatch))


@pytest.mark.parametrize("name", FILES[:4])
def test_ledger_quiet_no_ranges(name, monkeypatch):
    """every stop quiet: the carried peaks and the last stop reach finish()"""
    path = SAMPLES / name
    assert _quiet_calls(path, _profile(name), [], monkeypatch) > 10
    _same(_run(path, _profile(name), [], True, monkeypatch), _run(path, _profile(name), [], False, monkeypatch))


@pytest.mark.skipif(not RECT.exists(), reason="corpus plate not here")
def test_ledger_quiet_rect_plate(monkeypatch):
    """a real plate: sparse ranges (the measure's shape: most stops quiet)"""
    profile = load_profile("prusa-mk3s")
    n = sum(1 for _ in open(RECT, "rb"))
    watch = _watch(n, 600, 51)
    assert _quiet_calls(RECT, profile, watch, monkeypatch) > 1000
    _same(_run(RECT, profile, watch, True, monkeypatch), _run(RECT, profile, watch, False, monkeypatch))


def _twins():
    """two writers in the same state on compiled SimResults, their peaks and sums set"""
    state = st.MachineState(load_profile("prusa-mk3s"), "x.gcode")
    out = []
    for _ in range(2):
        sim = fwsim.new_sim(load_profile("prusa-mk3s"), None, None)
        res = sim.res
        res.time_t, res.n_moves, res.corner_dv2 = 12.5, 7, 0.25
        w = fwsim._LedgerWriter(fwsim.Ledger(), [(3, 5), (9, 12)], state, res)
        out.append(w)
    return state, out


def _attrs(w):
    return (repr(w.carry_v), repr(w.carry_a), w.last[0], _floats(w.last[1]), w.last[2], w.last_j,
            list(w.pending), repr(w.res.peak_v), repr(w.res.peak_a), w.led.line.tobytes(), w.led.hi.tobytes(),
            w.led.ok)


PEAKS = [(0.0, 0.0), (5.0, 1000.0), (150.0, 2.0), (-0.0, float("nan")), (5.0, 1000.0), (float("nan"), 0.0),
         (0.0, -0.0), (400.0, 3.0)]
ZEROS = [(-0.0, 0.0), (0.0, -0.0), (-0.0, -0.0), (0.0, 0.0)]      # (the first of equal values kept)


@pytest.mark.parametrize("carry", [(0.0, 0.0), (100.0, 1500.0), (-0.0, float("nan")), (-1.0, -1.0)])
@pytest.mark.parametrize("peaks", [PEAKS[:1], PEAKS[:2], PEAKS[:5], PEAKS, ZEROS])
def test_quiet_record_twin(carry, peaks):
    """stops recorded by quiet_record, then absorbed, leave the writer as as many calls of
    stopped leave its twin (the carried peaks: the strict > of each stop in turn); the
    SimResult's peaks and sums change between stops as the model's would"""
    state, ws = _twins()
    quiet = ws[0].on_quiet(state)
    assert ws[0].quiet is not None
    for w in ws:
        w.carry_v, w.carry_a = carry
    for j, (pv, pa) in enumerate(peaks):
        for w in ws:
            w.res.peak_v, w.res.peak_a = pv, pa
            w.res.time_t += 1.25 * j
            w.res.n_blocks += j
        quiet(10 + j)
        ws[1].stopped(10 + j)
    ws[0].absorb()
    assert _attrs(ws[0]) == _attrs(ws[1])
    ws[0].absorb()                  # (nothing kept since: the same)
    assert _attrs(ws[0]) == _attrs(ws[1])


def test_quiet_falls_back():
    """the Python twin where the core would not take the stop as stopped does: another
    take (a SimResult subclass's own take_stop), a MachineState subclass's snapshot, the
    switch off"""
    state, ws = _twins()

    class Res(fwsim._core.SimResult):
        def take_stop(self):
            return fwsim._take_stop(self)
    ws[0].res = Res()
    assert ws[0].on_quiet(state) == ws[0].stopped and ws[0].quiet is None

    class State(st.MachineState):
        def snapshot(self):
            return st.MachineState.snapshot(self)
    _, ws = _twins()
    assert ws[0].on_quiet(State(load_profile("prusa-mk3s"), "x.gcode")) == ws[0].stopped
    fwsim.USE_QUIET_CORE = False
    try:
        assert ws[0].on_quiet(state) == ws[0].stopped
    finally:
        fwsim.USE_QUIET_CORE = True


def test_quiet_errors():
    state, ws = _twins()

    def snap(_):
        raise RuntimeError("snapshot failed")
    q = fwsim._core.quiet_new(ws[0].res, snap, state)
    with pytest.raises(RuntimeError, match="snapshot failed"):
        fwsim._core.quiet_record(q, 2)
    assert fwsim._core.quiet_take(q) is None
    with pytest.raises(TypeError):
        fwsim._core.quiet_record(q)
    with pytest.raises(TypeError):
        fwsim._core.quiet_record(state, 2)
    with pytest.raises(TypeError):
        fwsim._core.quiet_take(state)
    with pytest.raises(TypeError):
        fwsim._core.quiet_new(object(), snap, state)
