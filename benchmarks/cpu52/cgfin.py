"""Instructions spent inside named functions (callgrind client requests: counting on while
one of them runs, off otherwise; nested calls counted once).

    cgfin.py cand FILE K      the candidate step (as win51_chainw51/cgcand.py: K 0 the one
                              call, K > 0 candidates_in_windows over K even windows)
    cgfin.py whole FILE       the whole command (gcode_opt process FILE -o /dev/null -q)

FNS: comma-separated module.attr or module.Class.attr of gcode_opt (default: the chains'
finishing, chains._finish_stacked_dt + chains._finish_rows_dt); FNS=all: the whole step.
Needs libcgmark.so (win51_chainw51/cgmark.c; CGMARK=its path); run under
valgrind --tool=callgrind --instr-atstart=no (cgfin.sh)."""
import ctypes
import functools
import importlib
import os
import sys

lib = ctypes.CDLL(os.environ.get("CGMARK", "/tmp/chainw51/libcgmark.so"))
FNS = os.environ.get("FNS", "chains._finish_stacked_dt,chains._finish_rows_dt")
_depth = [0]


def _wrap(fn):
    @functools.wraps(fn)
    def w(*a, **k):
        if _depth[0] == 0:
            lib.cg_on()
        _depth[0] += 1
        try:
            return fn(*a, **k)
        finally:
            _depth[0] -= 1
            if _depth[0] == 0:
                lib.cg_off()
    return w


def _patch():
    for name in FNS.split(","):
        parts = name.split(".")
        mod = importlib.import_module("gcode_opt." + parts[0])
        owner = mod
        for p in parts[1:-1]:
            owner = getattr(owner, p)
        setattr(owner, parts[-1], _wrap(getattr(owner, parts[-1])))


def cand(path, K):
    import gc
    import numpy as np
    from gcode_opt import schedule
    from gcode_opt import features as feat
    from gcode_opt.pipeline import Options, analyse
    from gcode_opt.profile import load_profile
    prof = load_profile("prusa-mk3s")
    opts = Options(features=feat.default_selection(path)[0])
    strokes, _ = analyse(path, prof, opts)
    pin = schedule.plan_inputs(strokes, prof, opts)
    rows = schedule._rows_by_kind(strokes, schedule._plan_kind_codes_of(strokes, pin))
    failed = schedule._faults_of(pin.fault)
    gc.freeze()
    bounds = np.linspace(0, len(strokes), max(K, 1) + 1).astype(int)
    if FNS == "all":
        lib.cg_on()
    else:
        _patch()
    lib.cg_zero()
    if K == 0:
        schedule._candidates(strokes, pin, prof, opts, rows, failed)
    else:
        schedule.candidates_in_windows(strokes, pin, prof, opts, rows, failed, bounds, None, False)
    lib.cg_on()
    lib.cg_dump()
    lib.cg_off()


def whole(path):
    _patch()
    lib.cg_on()
    lib.cg_zero()
    lib.cg_off()
    from gcode_opt import cli
    try:
        print("exit", cli.main(["process", path, "-o", os.environ.get("CGOUT", "/tmp/cgfin_out.gcode"), "-q"]))
    finally:
        lib.cg_on()
        lib.cg_dump()
        lib.cg_off()


if __name__ == "__main__":
    if sys.argv[1] == "cand":
        cand(sys.argv[2], int(sys.argv[3]))
    else:
        whole(sys.argv[2])
