"""OpenBLAS's thread count, set for a block of work (blas_one_thread).

The job makes many small LAPACK/BLAS calls (the circle law's Newton solves thousands of
32 x 32 systems, np.linalg.solve each): there a second OpenBLAS thread only adds
synchronisation, ~2x the CPU time, and takes the core a slicer may need.  The same
routines run, so the results are the same bits with 1 and 2 threads
(tests/test_speed_plan2_circle.py).  Found through /proc/self/maps (Linux); with another
BLAS or elsewhere nothing is changed.
"""
from __future__ import annotations

import contextlib
import ctypes
import os

# OpenBLAS's own thread-count knobs, in the order it reads them
_THREAD_ENV = ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")

_OPENBLAS_FNS = (("scipy_openblas_get_num_threads64_", "scipy_openblas_set_num_threads64_"),
                 ("scipy_openblas_get_num_threads", "scipy_openblas_set_num_threads"),
                 ("openblas_get_num_threads64_", "openblas_set_num_threads64_"),
                 ("openblas_get_num_threads", "openblas_set_num_threads"))
_blas_threads_fns: list = []       # [(get, set)] once looked up; [None] if not found


def _openblas_thread_fns():
    """(get, set) of the number of threads of the OpenBLAS numpy has loaded (Linux: found
    in /proc/self/maps), or None (another BLAS or platform: then nothing is changed)."""
    if not _blas_threads_fns:
        found = None
        try:
            with open("/proc/self/maps") as fh:
                paths = {ln.split(None, 5)[5].strip() for ln in fh
                         if "openblas" in ln.lower() and len(ln.split(None, 5)) == 6}
            for path in sorted(paths):
                lib = ctypes.CDLL(path)
                for get_name, set_name in _OPENBLAS_FNS:
                    if hasattr(lib, get_name) and hasattr(lib, set_name):
                        get_fn, set_fn = getattr(lib, get_name), getattr(lib, set_name)
                        get_fn.restype, get_fn.argtypes = ctypes.c_int, []
                        set_fn.restype, set_fn.argtypes = None, [ctypes.c_int]
                        found = (get_fn, set_fn)
                        break
                if found:
                    break
        except (OSError, IndexError, ValueError):
            found = None
        _blas_threads_fns.append(found)
    return _blas_threads_fns[0]


@contextlib.contextmanager
def blas_one_thread():
    """OpenBLAS on one thread inside the block, its count restored after.  The Newton
    batches solve thousands of 32 x 32 systems (np.linalg.solve, one LAPACK call each):
    OpenBLAS's threads only add synchronisation there, ~2x the CPU time (and more wall
    time when the other core is busy).  The same LAPACK routines run, and their results
    were the same bits with 1 and 2 threads (tests/test_speed_plan2_circle.py)."""
    fns = _openblas_thread_fns()
    if fns is None:
        yield
        return
    get_fn, set_fn = fns
    before = get_fn()
    set_fn(1)
    try:
        yield
    finally:
        set_fn(before)


def one_thread_from_start(environ=None) -> bool:
    """OPENBLAS_NUM_THREADS=1 for this process, before numpy is imported (the command line
    calls it first; True if set).  When loaded, OpenBLAS starts its thread pool and each
    thread spins ~0.1 s before it sleeps: ~0.07-0.1 s of CPU in every run, ~20 % of a
    7 k-line file's (measured: prusa_gyroid 0.49 -> 0.39 s median of 7), though the job
    then runs on one thread anyway (blas_one_thread).  With the variable set at load, no
    pool is started.  Not set when the user set one of OpenBLAS's knobs, or when numpy is
    already loaded (too late to matter; blas_one_thread still holds for the job)."""
    import sys
    env = os.environ if environ is None else environ
    if "numpy" in sys.modules or any(k in env for k in _THREAD_ENV):
        return False
    env["OPENBLAS_NUM_THREADS"] = "1"
    return True
