"""The firmware model (simulate.py and its compiled twin, firmware/_core.c)."""
import os

CORE_SOURCE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "_core.c")


def load_core():
    """(the compiled core, module _gcode_opt_fwcore, "") or (None, why not): native.load,
    which refuses a build made from another _core.c than CORE_SOURCE.  simulate sets the
    core up for the model; strokes takes its StrokeBase."""
    from ..native import load
    return load("_gcode_opt_fwcore", CORE_SOURCE, "core")
