"""Issue 8, stop 18 (D8): schedule.plan_strokes reads each stroke's plan kind once (from
_rows_by_kind) for all its re-plans, instead of calling chains.plan_kind per re-timed
stroke in each.  That holds because nothing in plan_strokes changes a stroke's kind
(only plan_inputs' chains.classify marks chains): checked here on files with lines, arcs,
curves and chains (the plans themselves are compared with 9bb98a8's outputs by the
reference set of the session's check).""" 
import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt import schedule as sc
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile

S = "sample_gcode/"


def _digest(plan):
    out = [plan.T.tobytes(), plan.beta.tobytes(), plan.retime.tobytes(), plan.t_pred.tobytes(),
           plan.a2_pred.tobytes(), repr(list(plan.reason))]
    for seg in plan.segs:
        out.append(None if seg is None else (seg.s.tobytes(), seg.v.tobytes(), np.asarray(seg.accel).tobytes(),
                                             np.asarray(seg.feed).tobytes(), repr((seg.time_t, seg.int_a2))))
    return out


@pytest.mark.parametrize("name,profile", [("prusa_gyroid.gcode", "prusa-mk3s"),
                                          ("prusa_gyroid_arcs.gcode", "prusa-mk3s"),
                                          ("prusa_gyroid_fullspeed_klipper.gcode", "voron24")])
def test_kinds_stable_during_plan_strokes(name, profile):
    prof = load_profile(profile)
    opts = Options()

    def planned():
        strokes, sim = analyse(S + name, prof, opts)
        pin = sc.plan_inputs(strokes, prof, opts)
        before = [chains.plan_kind(st) for st in strokes]
        plan = sc.plan_strokes(strokes, pin, prof, opts, opts.max_slowdown_r * sim.time_t)
        assert [chains.plan_kind(st) for st in strokes] == before
        return plan, before

    plan, kinds = planned()
    assert {"line", "curve"} <= set(kinds)
    again, _ = planned()
    assert _digest(again) == _digest(plan)
