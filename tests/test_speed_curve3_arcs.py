"""arcs.arc_trapezoid takes the planned law's peak as the trapezoid's top speed; the law
starts and ends at the stroke's end speeds, so a law whose peak is at an end has peak =
that end speed, and rounding (any change of the circle solver's last bits) can put it one
ulp below.  The trapezoid must not depend on that ulp (before: no trapezoid at all, so the
arc's fate hung on rounding; found when the solver changed its last bits)."""
import numpy as np

from gcode_opt import arcs
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.schedule import SegmentRules


def test_trapezoid_does_not_hang_on_the_peaks_last_ulp():
    prof = load_profile("voron24")
    strokes, _ = analyse("sample_gcode/prusa_gyroid_arcs.gcode", prof, Options())
    rules = SegmentRules.for_profile(prof, Options().max_segments)
    sts = [st for st in strokes if st.kind == "arc" and max(st.v0, st.v1) >= 5.0][:60]
    assert len(sts) >= 20
    planned = 0
    for st in sts:
        top = max(st.v0, st.v1)
        for r in (1.02, 1.1, 1.3):
            T = r * st.time_t
            at = arcs.arc_trapezoid(st, T, top, rules, prof)
            below = arcs.arc_trapezoid(st, T, float(np.nextafter(top, 0.0)), rules, prof)
            assert (at is None) == (below is None)
            if at is not None:
                planned += 1
                assert below.int_a2 == at.int_a2 and np.array_equal(below.feed, at.feed)
    assert planned >= 10
