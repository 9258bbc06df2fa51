"""Instructions of candidates_in_windows (K>0) or _candidates (K=0) only: callgrind client requests."""
import ctypes, sys
import numpy as np
from gcode_opt import schedule
from gcode_opt import features as feat
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
lib = ctypes.CDLL(__import__("os").environ.get("CGMARK", "/tmp/chainw51/libcgmark.so"))
path, K = sys.argv[1], int(sys.argv[2])
prof = load_profile("prusa-mk3s")
opts = Options(features=feat.default_selection(path)[0])
strokes, _ = analyse(path, prof, opts)
pin = schedule.plan_inputs(strokes, prof, opts)
rows = schedule._rows_by_kind(strokes, schedule._plan_kind_codes_of(strokes, pin))
failed = schedule._faults_of(pin.fault)
import gc, os as _os
if not _os.environ.get("NOFREEZE"): gc.freeze()
bounds = np.linspace(0, len(strokes), max(K, 1) + 1).astype(int)
import os
only = os.environ.get("ONLY")
if only:
    from gcode_opt import chains
    orig = chains.candidates_chain
    def wrapped(*a, **k):
        lib.cg_on()
        try:
            return orig(*a, **k)
        finally:
            lib.cg_off()
    schedule.KINDS[schedule.K_CHAIN].candidates = wrapped
    lib.cg_on(); lib.cg_zero(); lib.cg_off()
else:
    lib.cg_start()
if K == 0:
    got = schedule._candidates(strokes, pin, prof, opts, rows, failed)
else:
    got = schedule.candidates_in_windows(strokes, pin, prof, opts, rows, failed, bounds, None, False)
if only:
    lib.cg_on(); lib.cg_dump(); lib.cg_off()
else:
    lib.cg_stop()
