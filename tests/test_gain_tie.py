"""A stroke is rewritten only when its segments beat the original's int a^2 by more than
rounding (schedule.beats): a constant-speed stroke whose segments equal the original
used to be rewritten or not by where the last bit fell."""
import math
import os

import numpy as np

from gcode_opt import pipeline as pl
from gcode_opt import schedule as sc
from gcode_opt.detect import auto_profile

HERE = os.path.dirname(os.path.abspath(__file__))


def test_ties_and_last_bits_do_not_count_as_a_gain():
    a2 = 1.2345678e7
    assert not sc.beats(a2, a2)
    assert not sc.beats(math.nextafter(a2, 0.0), a2)          # one ulp below
    assert not sc.beats(a2 * (1.0 - 1e-12), a2)
    assert sc.beats(a2 * 0.999, a2)
    assert not sc.beats(float("nan"), a2)
    assert not sc.beats(0.0, 0.0)


def test_every_rewritten_stroke_gains_beyond_rounding():
    path = os.path.join(HERE, "..", "sample_gcode", "prusa_benchy_like.gcode")
    prof = auto_profile(path).profile        # the file's own limits: it holds a tie there
    opts = pl.Options()
    strokes, sim0 = pl.analyse(path, prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    plan = sc.plan_strokes(strokes, pin, prof, opts, opts.max_slowdown_r * sim0.time_t)
    idx = np.flatnonzero(plan.retime)
    assert len(idx) > 100
    for i in idx:
        if plan.segs[i] is not None and math.isfinite(plan.beta[i]):   # slowed corners keep their own move
            assert plan.segs[i].int_a2 < strokes[i].int_a2 * (1.0 - sc.GAIN_TOL_R)
