"""arcs53: instructions of the candidates phase only (callgrind client requests around it):
schedule._candidates (W 0) or candidates_in_windows at windows of W strokes.

    valgrind --tool=callgrind --instr-atstart=no python benchmarks/arcs53/cg_cand.py FILE PROFILE W
(CGMARK: a shared library whose cg_start / cg_stop are CALLGRIND_ZERO_STATS +
START_INSTRUMENTATION and STOP_INSTRUMENTATION + DUMP_STATS_AT; its 3-line source is in
benchmarks/arcs53.md)"""
import ctypes
import gc
import os
import sys

import numpy as np

from gcode_opt import features as feat
from gcode_opt import schedule
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile

lib = ctypes.CDLL(os.environ["CGMARK"])
path, prof_name, w = sys.argv[1], sys.argv[2], int(sys.argv[3])
prof = load_profile(prof_name)
opts = Options(features=feat.default_selection(path)[0])
strokes, _ = analyse(path, prof, opts)
pin = schedule.plan_inputs(strokes, prof, opts)
rows = schedule._rows_by_kind(strokes, schedule._plan_kind_codes_of(strokes, pin))
failed = schedule._faults_of(pin.fault)
gc.freeze()
lib.cg_start()
if w == 0:
    schedule._candidates(strokes, pin, prof, opts, rows, failed)
else:
    schedule.candidates_in_windows(strokes, pin, prof, opts, rows, failed,
                                   np.unique(np.r_[np.arange(0, len(strokes), w), len(strokes)]))
lib.cg_stop()
