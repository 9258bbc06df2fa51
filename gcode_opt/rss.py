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


def heap_rss_mb():
    """The resident part of the C heap (glibc's brk heap: every [heap] mapping, numpy's
    madvise splits it in several), MB; None where /proc/self/smaps is not (not Linux).
    What the allocator keeps of freed blocks shows here, not in what Python traces."""
    total_kb, in_heap = 0, False
    try:
        with open("/proc/self/smaps", encoding="ascii", errors="replace") as fh:
            for line in fh:
                if line.endswith("[heap]\n"):
                    in_heap = True
                elif in_heap and line.startswith("Rss:"):
                    total_kb += int(line.split()[1])
                    in_heap = False
    except (OSError, ValueError, IndexError):
        return None
    return total_kb / 1024.0
