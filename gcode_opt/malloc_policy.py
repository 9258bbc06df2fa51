"""glibc malloc's thresholds for a gcode-opt run (the command line sets them; the library
leaves the process's allocator alone).

glibc serves a block above its mmap threshold with a fresh mmap and gives it back on
free; the threshold starts at 128 KiB and only rises when such a block is freed, and the
heap's top is trimmed back to the system above 128 KiB free.  The pass's numpy
temporaries (the ringing figures of analyse, the plan's tables) are of a few hundred KiB
to a few MiB, made and dropped thousands of times: each one's pages were faulted in anew
(gyroid plate: ~88 k minor faults, ~0.15 s system CPU in analyse alone, ~0.4-0.6 s over a
run).  With the thresholds fixed at 32 MiB (glibc's largest on 64-bit: larger blocks are
still mmap'd and given back) and 64 MiB, freed blocks are reused: ~17 k faults in
analyse, ~0.2 s system CPU a run; the peak RSS is the same (measured: gyroid ~205 MB).
It changes no computation.  Not set when the user set glibc's own knobs (MALLOC_*_ or
GLIBC_TUNABLES) or GCODE_OPT_MALLOC=default, nor off glibc.

numpy asks the kernel for 2 MiB pages (madvise MADV_HUGEPAGE) under every array of 4 MiB
or more; where transparent huge pages are "madvise" (as on most distributions) such a page
is resident whole, and with the thresholds above those arrays are carved from the heap,
whose advised ranges later hold small objects too.  small_pages() turns numpy's advice off
for the command: peak RSS gyroid plate windowed 68.1-68.9 -> 66.1-67.8 MB, rectilinear plate
83.9 -> 82.0 MB (list), the 8 k-line sample 43.7 -> 43.5 MB (`/usr/bin/time`, 4-6 runs each,
alternated).  It changes no computation either."""
from __future__ import annotations

import os
import sys

M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3     # malloc.h
MMAP_THRESHOLD_B = 32 << 20      # bytes: blocks above are mmap'd (glibc's DEFAULT_MMAP_THRESHOLD_MAX, 64-bit)
TRIM_THRESHOLD_B = 64 << 20      # bytes of free heap top kept before it is given back
_USER_KNOBS = ("MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_", "MALLOC_TOP_PAD_", "GLIBC_TUNABLES")


def apply(environ=None) -> bool:
    """Set the two thresholds; True if both were set."""
    env = os.environ if environ is None else environ
    if not sys.platform.startswith("linux") or env.get("GCODE_OPT_MALLOC", "") == "default":
        return False
    if any(k in env for k in _USER_KNOBS):
        return False
    try:
        import ctypes
        libc = ctypes.CDLL(None)
        libc.gnu_get_libc_version           # glibc only (musl's mallopt does nothing)
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    # the mmap threshold first: a fixed trim threshold alone turns the dynamic mmap
    # threshold off and leaves it at 128 KiB (every such block mmap'd: more faults)
    return bool(mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD_B)) and bool(mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD_B))


def small_pages(environ=None) -> bool:
    """NUMPY_MADVISE_HUGEPAGE=0 for this process, before numpy is imported (the command line
    calls it first; True if set): no 2 MiB pages asked for under numpy's arrays (the
    module's doc).  Not set when the user set it, or GCODE_OPT_MALLOC=default, or numpy is
    already loaded (numpy reads it at its import)."""
    env = os.environ if environ is None else environ
    if "numpy" in sys.modules or "NUMPY_MADVISE_HUGEPAGE" in env or env.get("GCODE_OPT_MALLOC", "") == "default":
        return False
    env["NUMPY_MADVISE_HUGEPAGE"] = "0"
    return True
