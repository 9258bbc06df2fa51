"""ring_solve's optional buffer tuples (amps_memo, amps_out, pieces_memo, pieces_out) are read
by one helper (ring_opt_bufs): a good tuple gives the same answer as none, and each way of
getting one wrong raises (no crash, no buffer left held)."""
import importlib

import numpy as np
import pytest

from gcode_opt import native
from gcode_opt.firmware import resonance

core = None if native.pure_python_asked() else importlib.util.find_spec("_gcode_opt_fwcore")
pytestmark = pytest.mark.skipif(core is None, reason="the compiled firmware core is not there")


def _call(**kw):
    fw = importlib.import_module("_gcode_opt_fwcore")
    t = np.array([0.0, 0.01, 0.02, 0.05])
    dr, drp = np.array([1.0, -2.0, 0.5, 0.1]), np.zeros(4)
    s, wd = 0.1 * 2 * np.pi * 50, 2 * np.pi * 50 * np.sqrt(1 - 0.01)
    opt = dict(am=None, ao=None, pm=None, po=None)
    opt.update(kw)
    return fw.ring_solve(t, dr, drp, None, s, wd, 1.0, 100, False, *resonance._int_r2_args(s, complex(-s, wd)),
                         opt["am"], opt["ao"], opt["pm"], opt["po"])


def test_outs_given_same_answer_and_filled():
    base = _call()
    ao, po = (np.zeros(4), np.zeros(16)), (np.zeros(3), np.zeros(9))
    assert _call(ao=ao, po=po) == base
    assert np.array_equal(po[0], np.diff([0.0, 0.01, 0.02, 0.05]))
    assert np.any(ao[1] != 0.0)


@pytest.mark.parametrize("kw, err", [
    (dict(ao=[np.zeros(4), np.zeros(16)]), TypeError),          # not a tuple
    (dict(ao=(np.zeros(4), np.zeros(5))), ValueError),          # wrong length
    (dict(po=(np.zeros(3),)), TypeError),                       # too few
    (dict(am=(np.zeros(2), None, np.zeros(8))), TypeError),     # a None inside
    (dict(po=(np.zeros(3), np.zeros(3))), ValueError),
    (dict(am=(np.zeros(2), np.zeros(3), np.zeros(8))), ValueError),   # memo lengths differ
    (dict(pm=(np.zeros(2), np.zeros(2), np.zeros(5))), ValueError),
])
def test_bad_tuples_raise(kw, err):
    with pytest.raises(err):
        _call(**kw)
    assert _call() is not None          # still usable after the failure
