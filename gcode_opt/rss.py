"""The process's peak resident set, read where it is the process's own.

Linux's ru_maxrss also counts the resident set of the process this one was forked from,
kept through exec: run by a slicer or a test run, it reports their peak, not ours.
/proc/self/status's VmHWM is this process's own high-water mark.  (No imports beyond the
standard library: benchmarks read it before and around the package's own imports.)"""
import sys


def peak_rss_mb():
    """The peak resident set so far, MB: VmHWM where there is one (Linux), else
    ru_maxrss (KiB on Linux, bytes on macOS); None where neither is (Windows)."""
    try:
        with open("/proc/self/status", encoding="ascii", errors="replace") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0
    except (OSError, ValueError, IndexError):
        pass
    try:
        import resource
    except ImportError:
        return None
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / (1 << 20 if sys.platform == "darwin" else 1 << 10)
