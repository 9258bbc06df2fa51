"""resonance.PROBE_AFTER: a run's first events go by numpy (no probe of the compiled
core: ~130 M instructions a small file paid), the core from there on.  The ringing figures
are the same bits either way, and the gate opens once the events are seen."""
import json

import numpy as np
import pytest

from gcode_opt import ringing
from gcode_opt.firmware import resonance, simulate
from gcode_opt.profile import load_profile

pytestmark = pytest.mark.skipif(simulate._core is None or not hasattr(simulate._core, "ring_solve"),
                                reason="the compiled firmware core is not built here")

VERDICTS = ("_KERNEL_OK", "_AMPS_MODE", "_JUMPS_OK", "_INT_R2_OK", "_SOLVE_OK")


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


@pytest.mark.parametrize("name, shaper", [("prusa_klipper.gcode", None), ("prusa_gyroid.gcode", "mzv"),
                                          ("cura_box.gcode", "ei")])
def test_figures_same_bits_with_and_without_the_core(tmp_path, fresh, name, shaper):
    path = "sample_gcode/" + name
    # (a short copy too: its events stay under the gate's default from start to end)
    short = tmp_path / "short.gcode"
    with open(path) as fh:
        short.write_text("".join(fh.readlines()[:400]))
    for src in (str(short), path):
        for name_ in VERDICTS:
            getattr(resonance, name_).clear()
        resonance._EVENTS_SEEN[0] = 0
        resonance.PROBE_AFTER = float("inf")
        try:
            numpy_only = ringing.figures(src, load_profile("prusa-mk3s"), shaper)
        finally:
            resonance.PROBE_AFTER = 0
        assert not _probed()                         # numpy all along: no probe ran
        resonance._EVENTS_SEEN[0] = 0
        with_core = ringing.figures(src, load_profile("prusa-mk3s"), shaper)
        assert resonance._SOLVE_OK                   # the core was probed and used
        assert json.dumps(numpy_only, sort_keys=True).encode() == json.dumps(with_core, sort_keys=True).encode()
        assert all(np.float64(v).tobytes() == np.float64(with_core[ax][k]).tobytes()
                   for ax in ("x", "y", "xy") for k, v in numpy_only[ax].items())
        if src == path:
            # the gate opening mid-run (numpy's steps for the first calls, the core's after)
            for name_ in VERDICTS:
                getattr(resonance, name_).clear()
            resonance._EVENTS_SEEN[0] = 0
            resonance.PROBE_AFTER = 40000
            try:
                mixed = ringing.figures(src, load_profile("prusa-mk3s"), shaper)
            finally:
                resonance.PROBE_AFTER = 0
            assert resonance._SOLVE_OK
            assert json.dumps(mixed, sort_keys=True).encode() == json.dumps(with_core, sort_keys=True).encode()


def test_small_run_does_not_probe_and_a_large_one_does(fresh):
    path = "sample_gcode/prusa_klipper.gcode"
    resonance.PROBE_AFTER = 20000
    try:
        resonance._EVENTS_SEEN[0] = 0
        osc = resonance.Oscillator(50.0, 0.1)
        t = np.cumsum(np.full(100, 1e-3))
        dr = np.linspace(-1.0, 1.0, 100)
        assert osc.solve(t, dr, dr, None) is None and not _probed()   # 100 events: numpy's steps
        ringing.figures(path, load_profile("prusa-mk3s"))
        assert resonance._EVENTS_SEEN[0] >= 20000
        assert resonance._SOLVE_OK                                    # past the gate: probed
        assert osc.solve(t, dr, dr, None) is not None                # and the core's steps
    finally:
        resonance.PROBE_AFTER = 0
