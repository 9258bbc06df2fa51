"""The reader's session write-back (sess_flush) leaves x y z e v in the dict where the
session ends with the bits it loaded: the state the measure pass's ledger snapshots at
each stop, with the compiled reader's sessions (play_buf), is the Python reader's (every
line through step()), floats compared by repr (0.0 is not -0.0): zeros of both signs
across stops, and the samples."""
from __future__ import annotations

from pathlib import Path

import pytest

from gcode_opt import state as st
from gcode_opt.firmware import simulate as fwsim
from gcode_opt.profile import load_profile

ROOT = Path(__file__).resolve().parent.parent
SAMPLES = ROOT / "sample_gcode"

pytestmark = pytest.mark.skipif(fwsim.CORE != "c" or st._C_STEP is None, reason="compiled core and reader")

# each move one session, a stop (M400: a barrier, read by step()) after it; the zeros'
# signs flip between sessions, and some values stay (z, v: left in the dict)
SIGNED_ZEROS = """G21
G90
M83
G1 X-0 Y-0 Z-0 E0.1 F600
M400
G1 X0 Y0 Z0 E0.1
M400
G1 X-0 Y-0 Z-0 E0.1
M400
G1 X5 Y-0 Z-0 E0.1 F1200
M400
G1 X5 Y5 Z-0 E0.1
M400
G1 X-0 Y5 Z0 E0.1 F-0
M400
G1 X10 Y10 Z0.2 E-0 F1200
M400
G1 E0.5
M400
G92 E-0
G1 X10 Y10 E-0
M400
G1 X0 Y0 Z0 E0.1 F600
G1 X1 Y0 E0.1
M400
"""


def _ledger(path, profile, watch, reader):
    old = st.use_reader(reader)
    try:
        return fwsim.simulate_ledger(str(path), profile, watch)
    finally:
        st.use_reader(old)


def _floats(snap):
    return tuple(repr(v) if type(v) is float else v for v in snap)


def _same_states(path, profile, watch):
    (r1, c), (r0, p) = _ledger(path, profile, watch, "c"), _ledger(path, profile, watch, "python")
    assert len(c.state) == len(p.state) > 0
    assert [_floats(s) for s in c.state] == [_floats(s) for s in p.state]
    assert c.line.tobytes() == p.line.tobytes() and c.sums.tobytes() == p.sums.tobytes()
    assert repr(r1.as_dict()) == repr(r0.as_dict())
    return c


def test_signed_zeros_across_stops(tmp_path):
    path = tmp_path / "zeros.gcode"
    path.write_text(SIGNED_ZEROS)
    lines = SIGNED_ZEROS.splitlines()
    watch = [(i, i) for i, ln in enumerate(lines) if ln.startswith("G1")]
    led = _same_states(path, load_profile("prusa-mk3s"), watch)
    zs = {repr(s[st.MachineState.MODAL.index("z")]) for s in led.state}
    assert {"0.0", "-0.0"} <= zs          # (both signs were there to keep apart)


@pytest.mark.parametrize("name", ["prusa_gyroid.gcode", "prusa_mk3s_rectilinear.gcode", "prusa_klipper.gcode",
                                  "edge/relative_g91.gcode", "edge/firmware_retraction.gcode"])
def test_samples_states(name):
    path = SAMPLES / name
    n = sum(1 for _ in open(path, "rb"))
    watch = [(k, k + 2) for k in range(5, n, 97)]
    _same_states(path, load_profile("voron24" if "klipper" in name else "prusa-mk3s"), watch)
