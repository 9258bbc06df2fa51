"""pipeline.trim_heap against the command line's malloc policy (issue 8, memory, s49 heap49).

With malloc_policy's thresholds (mmap above 32 MiB, heap top kept up to 64 MiB) a freed
block of a few MiB stays resident: glibc keeps it for the next allocation.  trim_heap is
what gives such pages back at the pipeline's phase points (after the candidates, between
the passes); the peaks of rewrite and measure rest on it.  Checked in a fresh interpreter
on the [heap] mappings' resident size (rss.heap_rss_mb), relative to the block's own size
only (no machine's RSS figure)."""
import os
import subprocess
import sys

import pytest

from gcode_opt import malloc_policy

_GLIBC = sys.platform.startswith("linux") and "glibc" in " ".join(__import__("platform").libc_ver())

_SCRIPT = """
from gcode_opt import malloc_policy
from gcode_opt.pipeline import trim_heap
from gcode_opt.rss import heap_rss_mb
import numpy as np

on = malloc_policy.apply()
block = np.ones(3 << 20)             # 24 MiB, touched: below the policy's mmap threshold, on the heap
guard = np.ones(1 << 10)             # (above it: the block is not the heap's top)
before = heap_rss_mb()
del block
kept = heap_rss_mb()
trim_heap()
after = heap_rss_mb()
print(on, before, kept, after)
"""


def _run():
    env = {k: v for k, v in os.environ.items() if k not in malloc_policy._USER_KNOBS and k != "GCODE_OPT_MALLOC"}
    env["PYTHONPATH"] = os.getcwd()
    out = subprocess.run([sys.executable, "-c", _SCRIPT], env=env, capture_output=True, text=True, check=True)
    on, before, kept, after = out.stdout.split()
    return on == "True", float(before), float(kept), float(after)


@pytest.mark.skipif(not _GLIBC, reason="glibc only")
def test_freed_block_kept_by_policy_given_back_by_trim():
    on, before, kept, after = _run()
    block_mb = 24.0
    assert on
    assert before >= block_mb                      # the block was on the heap, resident
    assert kept > before - block_mb / 4            # the policy keeps the freed pages (no trim on free)
    assert after < kept - block_mb * 3 / 4         # trim_heap gives (nearly) all of them back


def test_trim_heap_is_safe_anywhere():
    from gcode_opt.pipeline import trim_heap
    assert trim_heap() is None                     # (a no-op without glibc's malloc_trim)
