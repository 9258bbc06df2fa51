"""The reader's per-line fast path (issue 8: word dict built in a loop, the usual F taken
inline, M204's range test inline) reads what its strict path reads: the same line written
after a space (which the fast path leaves to the strict tokenizer) gives the same Move and
the same modal state, F edge cases included; M204 out of range names the word."""
import pytest

from gcode_opt.profile import load_profile
from gcode_opt.state import GcodeError, MachineState

_ATTRS = ("idx", "kind", "x0", "y0", "z0", "x1", "y1", "z1", "e", "v", "accel", "feature", "layer",
          "has_f", "e_rel", "xyz_rel", "checksum", "inch", "flow_r", "speed_r")


def _read(prof, lines):
    st = MachineState(load_profile(prof), "t.gcode")
    st.warnings = []
    out = []
    for i, raw in enumerate(lines):
        try:
            ev = st.step(i, raw)
            out.append(None if ev is None else tuple(getattr(ev, a, None) for a in _ATTRS))
        except GcodeError as e:
            out.append(str(e).split(": ", 1)[1].rsplit(": ", 1)[0])    # the reason, not the line
    return out, st.snapshot()


PROGRAMS = [
    ["G1 X10 Y5 F1200", "G1 X20 Y5 E.5", "G1 X20 Y6 E0.25 F0", "G1 X21 Y6 F600.5"],
    ["G20", "G1 X1 Y1 F60", "G1 X2 Y1 E0.1 F30", "G21", "G1 X3 Y1 F1e3"],
    ["M83", "G1 X1 Y1 E1 F-5", "G1 X2 Y2 F20000000", "G1 X3 Y3 E.1 F1.5"],
    ["G91", "G1 X1 Y1 F9000", "G1 X1 E.2", "G90", "M204 S800", "G1 X5 Y5 E1 F300"],
]


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24", "ender3"])
@pytest.mark.parametrize("prog", PROGRAMS)
def test_fast_path_reads_as_the_strict_path(prof, prog):
    spaced = [ln + "\n" for ln in prog]
    indented = [" " + ln + "\n" for ln in prog]        # a leading space: the strict tokenizer's
    a, b = _read(prof, spaced), _read(prof, indented)
    assert a == b
    assert any(x is not None and not isinstance(x, str) for x in a[0])      # moves were read


def test_feed_edge_cases():
    got, snap = _read("prusa-mk3s", ["G1 X1 Y1 F600\n", "G1 X2 Y1 F0\n", "G1 X3 Y1 F20000000\n"])
    assert got[0][9] == pytest.approx(10.0) and got[1][9] == pytest.approx(10.0)   # F0: last feed kept
    assert "F beyond" in got[2]
    got, _ = _read("voron24", ["G1 X1 Y1 F0\n"])
    assert "F must be above 0" in got[0]
    got, _ = _read("prusa-mk3s", ["G20\n", "G1 X1 Y1 F60\n"])
    assert got[1][9] == pytest.approx(60 * 25.4 / 60.0)                             # inches per minute


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24", "ender3"])
@pytest.mark.parametrize("line,word", [("M204 S0", "S"), ("M204 P-5 T100", "P"), ("M204 T2000000", "T")])
def test_m204_out_of_range_names_the_word(prof, line, word):
    got, _ = _read(prof, [line + "\n"])
    assert f"M204 {word} must be above 0" in got[0]
