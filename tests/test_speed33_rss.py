"""rss.peak_rss_mb is the process's own peak: a child forked from a large process does not
report the parent's (Linux's ru_maxrss does: it keeps the fork's resident set through exec)."""
import os
import subprocess
import sys

import pytest

from gcode_opt.rss import peak_rss_mb

CHILD = "from gcode_opt.rss import peak_rss_mb; print(peak_rss_mb())"


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="VmHWM is Linux's")
def test_child_of_a_large_process_reports_its_own_peak():
    ballast = bytearray(300 << 20)            # 300 MB resident in this (the parent) process
    ballast[::4096] = b"\x01" * len(ballast[::4096])
    assert peak_rss_mb() > 300
    # fork + exec (not posix_spawn/vfork: those skip the copy whose peak ru_maxrss keeps)
    env = dict(os.environ, PYTHONPATH=os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    out = subprocess.run([sys.executable, "-c", CHILD], capture_output=True, text=True, check=True, env=env,
                         preexec_fn=lambda: None).stdout
    child_mb = float(out)
    assert 1.0 < child_mb < 150.0, child_mb
    del ballast
