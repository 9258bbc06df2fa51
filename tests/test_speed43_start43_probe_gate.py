"""resonance.PROBE_AFTER: a run's first events go by numpy (no probe of the compiled
core: ~130 M instructions a small file paid), the core from there on.  The ringing figures
are the same bits either way, and the gate opens once the events are seen.

Since session 46 the gate and the probes are the steps' only (the chunks the core's
ring_solve declines, or all of them with it off: USE_SOLVE): ring_solve itself is not
probed and solves from a run's first event, the same figures whatever the gate."""
import json

import numpy as np
import pytest

from ring_close import assert_figures_close
from gcode_opt import ringing
from gcode_opt.firmware import resonance, simulate
from gcode_opt.profile import load_profile

pytestmark = pytest.mark.skipif(simulate._core is None or not hasattr(simulate._core, "ring_solve"),
                                reason="the compiled firmware core is not built here")

VERDICTS = ("_KERNEL_OK", "_AMPS_MODE", "_JUMPS_OK", "_INT_R2_OK")


@pytest.fixture
def fresh(monkeypatch):
    """No probe verdicts, no events seen: as a new process starts (restored after)."""
    for name in VERDICTS:
        monkeypatch.setattr(resonance, name, {})
    monkeypatch.setattr(resonance, "_EVENTS_SEEN", [0])
    monkeypatch.setattr(resonance, "_PROBE", [None, None])
    yield


def _probed():
    return any(getattr(resonance, name) for name in VERDICTS)


def _figures_of(src, shaper, probe_after):
    """The figures with the gate at probe_after, from a fresh start."""
    for name_ in VERDICTS:
        getattr(resonance, name_).clear()
    resonance._EVENTS_SEEN[0] = 0
    resonance.PROBE_AFTER = probe_after
    try:
        return ringing.figures(src, load_profile("prusa-mk3s"), shaper)
    finally:
        resonance.PROBE_AFTER = 0


def _same_bits(a, b):
    assert json.dumps(a, sort_keys=True).encode() == json.dumps(b, sort_keys=True).encode()
    assert all(np.float64(v).tobytes() == np.float64(b[ax][k]).tobytes() for ax in ("x", "y", "xy")
               for k, v in a[ax].items())


@pytest.mark.parametrize("name, shaper", [("prusa_klipper.gcode", None), ("prusa_gyroid.gcode", "mzv"),
                                          ("cura_box.gcode", "ei")])
@pytest.mark.parametrize("solve", [False, True])
def test_figures_same_bits_with_and_without_the_core(tmp_path, fresh, monkeypatch, name, shaper, solve):
    monkeypatch.setattr(resonance, "USE_SOLVE", solve)
    path = "sample_gcode/" + name
    # (a short copy too: its events stay under the gate's default from start to end)
    short = tmp_path / "short.gcode"
    with open(path) as fh:
        short.write_text("".join(fh.readlines()[:400]))
    for src in (str(short), path):
        numpy_only = _figures_of(src, shaper, float("inf"))
        assert not _probed()                         # numpy all along: no probe ran
        with_core = _figures_of(src, shaper, 0)
        assert _probed() != solve                    # the steps' kernels probed and used (not the solve's)
        _same_bits(numpy_only, with_core)
        if src == path:
            # the gate opening mid-run (numpy's steps for the first calls, the core's after)
            _same_bits(_figures_of(src, shaper, 40000), with_core)
        if solve:
            monkeypatch.setattr(resonance, "USE_SOLVE", False)
            assert_figures_close(with_core, _figures_of(src, shaper, 0))
            monkeypatch.setattr(resonance, "USE_SOLVE", True)


def test_small_run_does_not_probe_and_a_large_one_does(fresh, monkeypatch):
    path = "sample_gcode/prusa_klipper.gcode"
    resonance.PROBE_AFTER = 20000
    try:
        resonance._EVENTS_SEEN[0] = 0
        osc = resonance.Oscillator(50.0, 0.1)
        t = np.cumsum(np.full(100, 1e-3))
        dr = np.linspace(-1.0, 1.0, 100)
        assert osc.solve(t, dr, dr, None) is not None and not _probed()   # the core's solve: no probe
        monkeypatch.setattr(resonance, "USE_SOLVE", False)
        ringing.figures(path, load_profile("prusa-mk3s"))
        assert resonance._EVENTS_SEEN[0] >= 20000
        assert resonance._AMPS_MODE and resonance._INT_R2_OK                # past the gate: probed
    finally:
        resonance.PROBE_AFTER = 0
