"""The measure pass's stops with no watched range pending recorded from inside play_buf's loop
(on_quiet: _LedgerWriter.stopped called from C, no return to Python) against the loop that
returns at every stop (USE_QUIET_STOPS off: the a0c8d7a code): every ledger field, the result,
the reader's final state, the writer's calls in order, the barriers' callbacks."""
from __future__ import annotations

import random
from pathlib import Path

import pytest

from gcode_opt.firmware import simulate as fwsim
from gcode_opt.profile import load_profile

ROOT = Path(__file__).resolve().parent.parent
SAMPLES = ROOT / "sample_gcode"
FILES = ["prusa_gyroid.gcode", "prusa_klipper.gcode", "prusa_concentric_arcs.gcode",
         "edge/firmware_retraction.gcode", "edge/klipper_macros.gcode", "edge/tool_changes.gcode",
         "edge/crlf_line_endings.gcode", "edge/relative_g91.gcode"]

pytestmark = pytest.mark.skipif(fwsim.CORE != "c" or not getattr(fwsim._core, "PLAY_FIRSTS", 0),
                                reason="compiled core")


def _run(path, profile, watch, quiet, monkeypatch, on_line=None):
    calls, barriers = [], []
    real_stopped, real_starts = fwsim._LedgerWriter.stopped, fwsim._LedgerWriter.ranges_start

    def stopped(w, idx):
        calls.append(("stop", idx, len(w.pending)))
        return real_stopped(w, idx)

    def ranges_start(w, k):
        calls.append(("starts", w.wi, k))
        return real_starts(w, k)
    with monkeypatch.context() as m:
        m.setattr(fwsim, "USE_QUIET_STOPS", quiet)
        m.setattr(fwsim, "USE_QUIET_CORE", False)    # (the writer's own stopped, its calls counted)
        m.setattr(fwsim, "USE_LEDGER_CORE", False)   # (the writer's calls: not the LedgerCore's pass)
        m.setattr(fwsim._LedgerWriter, "stopped", stopped)
        m.setattr(fwsim._LedgerWriter, "ranges_start", ranges_start)
        r, led = fwsim.simulate_ledger(path, profile, watch, on_line=on_line, on_barrier=barriers.append)
    return r, led, calls, barriers


def _watch(n, step, seed):
    rng = random.Random(seed)
    watch, k = [], rng.randrange(3)
    while k < n + 5:            # (a range past the end too)
        ln = rng.choice([0, 0, 1, 3, 8, 40])
        watch.append((k, k + ln))
        k += ln + step + rng.randrange(3 * step + 1)
    return watch


def _same(a, b):
    (r1, led1, c1, b1), (r0, led0, c0, b0) = a, b
    for f in ("line", "sums", "peak_v", "peak_a", "lo", "hi"):
        assert getattr(led1, f).tobytes() == getattr(led0, f).tobytes(), f
    assert led1.state == led0.state
    assert led1.stop_lines == led0.stop_lines and led1.n_lines == led0.n_lines and led1.ok == led0.ok
    assert repr(r1.as_dict()) == repr(r0.as_dict())
    assert c1 == c0
    assert repr(b1) == repr(b0)


@pytest.mark.parametrize("name", FILES)
@pytest.mark.parametrize("step", [0, 3, 40, 400])
def test_quiet_stops_same_ledger(name, step, monkeypatch):
    path = str(SAMPLES / name)
    profile = load_profile("voron24" if "klipper" in name else "prusa-mk3s")
    n = sum(1 for _ in open(path, "rb"))
    watch = _watch(n, step, step + len(name))
    new = _run(path, profile, watch, True, monkeypatch)
    ref = _run(path, profile, watch, False, monkeypatch)
    _same(new, ref)
    if step >= 40 and n > 1000:     # (sparse ranges, a sample: quiet stops were there to take)
        assert any(c[0] == "stop" and c[2] == 0 for c in ref[2])


@pytest.mark.parametrize("name", FILES[:3])
def test_quiet_stops_no_ranges_and_python_lines(name, monkeypatch):
    """No watched range (every stop quiet); an on_line in Python (no fused session: each line
    through step())."""
    path = str(SAMPLES / name)
    profile = load_profile("voron24" if "klipper" in name else "prusa-mk3s")
    _same(_run(path, profile, [], True, monkeypatch), _run(path, profile, [], False, monkeypatch))
    got = {}
    for q in (True, False):
        rows = []
        got[q] = _run(path, profile, _watch(5000, 25, 1), q, monkeypatch, on_line=lambda *a: rows.append(repr(a)))
        got[q] = got[q] + (rows,)
    _same(got[True][:4], got[False][:4])
    assert got[True][4] == got[False][4]


def test_quiet_stop_error_propagates(monkeypatch):
    path = str(SAMPLES / "prusa_gyroid.gcode")
    profile = load_profile("prusa-mk3s")
    seen = []
    real = fwsim._LedgerWriter.stopped

    def failing(w, idx):
        seen.append(idx)
        if len(seen) == 5:
            raise RuntimeError("stop recorder failed")
        return real(w, idx)
    monkeypatch.setattr(fwsim._LedgerWriter, "stopped", failing)
    monkeypatch.setattr(fwsim, "USE_QUIET_CORE", False)     # (the writer's own stopped called)
    with pytest.raises(RuntimeError, match="stop recorder failed"):
        fwsim.simulate_ledger(path, profile, [])
    assert len(seen) == 5
