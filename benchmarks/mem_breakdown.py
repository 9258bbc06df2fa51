"""What holds the memory of `gcode-opt process`, phase by phase: traced Python memory
(tracemalloc) by the source file that allocated it, the process's RSS beside it, and the
strokes' own share by slot -- the figures a memory change starts from.

    python benchmarks/mem_breakdown.py FILE [--profile NAME] [--top N] [--ringing]

tracemalloc makes the run ~10x slower and only sees allocations made through Python's
allocators (numpy's data buffers are among them; the C cores' own buffers are not).  The
RSS column is /proc/self/statm's resident set at the same moment and ru_maxrss the peak so
far, both with tracemalloc's own bookkeeping in them (on the gyroid plate ~3x the traced
memory): compare them between phases of one run only.  The command's real peak RSS per
phase is `gcode-opt process --profile-time`'s.  Run from /tmp or
the tree whose gcode_opt you mean to measure (the current directory shadows PYTHONPATH).
"""
from __future__ import annotations

import argparse
import collections
import os
import resource
import sys
import tempfile
import tracemalloc

# the phase boundaries: (module, function) wrapped in this order of the job
PHASES = (("pipeline", "analyse"), ("pipeline", "plan_inputs"), ("schedule", "_candidates"),
          ("pipeline", "plan_strokes"), ("pipeline", "rewrite"), ("pipeline", "measure"))


def rss_mb() -> float:
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6


def peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def by_file(snapshot, top):
    """[(file name, MB)] of the snapshot's traced blocks, grouped by allocating file."""
    sizes = collections.Counter()
    for st in snapshot.statistics("filename"):
        sizes[os.path.basename(st.traceback[0].filename)] += st.size
    return [(name, size / 1e6) for name, size in sizes.most_common(top)]


def stroke_slots(strokes):
    """{slot or part: MB} of the strokes: the Stroke objects, and each slot's objects not
    counted before (a float shared by two strokes counts once), numpy/array data included."""
    import types
    from gcode_opt.strokes import Stroke
    seen, sizes = set(), collections.Counter()
    # fields the compiled StrokeBase stores in the stroke itself (doubles, ints): a read makes
    # an object the stroke does not hold, so they are in "Stroke objects" and not counted again
    base = Stroke.__mro__[1] if len(Stroke.__mro__) > 2 else None
    inline = {f for f in Stroke.__slots__
              if base is not None and isinstance(base.__dict__.get(f), types.GetSetDescriptorType)}

    def count(tag, o):
        if o is None or isinstance(o, bool) or id(o) in seen:
            return
        seen.add(id(o))
        sizes[tag] += sys.getsizeof(o)

    for s in strokes:
        count("Stroke objects", s)
        for slot in Stroke.__slots__:
            if slot in inline:
                continue
            v = getattr(s, slot, None)
            count(f"{slot} ({type(v).__name__})", v)
            xy = getattr(v, "xy", None)           # strokes.Points: its array of vertices
            if xy is not None:
                count(f"{slot}.xy ({type(xy).__name__})", xy)
    return {k: v / 1e6 for k, v in sizes.most_common()}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("file")
    ap.add_argument("--profile", default="prusa-mk3s")
    ap.add_argument("--top", type=int, default=8, help="files listed per phase")
    ap.add_argument("--ringing", action="store_true", help="leave the ringing figures on (default: off)")
    a = ap.parse_args(argv)

    was_tracing = tracemalloc.is_tracing()
    if not was_tracing:
        tracemalloc.start(1)
    import gcode_opt.pipeline as pl
    import gcode_opt.schedule as sch
    mods = {"pipeline": pl, "schedule": sch}
    rows, held, saved = [], {}, []

    def wrap(mod, name):
        fn = getattr(mod, name)
        saved.append((mod, name, fn))

        def wrapped(*args, **kw):
            out = fn(*args, **kw)
            if name == "analyse":
                held["strokes"] = out[0]
            if name not in {r[0] for r in rows}:      # (the first call: a second pass re-plans)
                cur, peak = tracemalloc.get_traced_memory()
                rows.append((name, cur / 1e6, peak / 1e6, rss_mb(), peak_mb(),
                             by_file(tracemalloc.take_snapshot(), a.top)))
            return out
        setattr(mod, name, wrapped)

    from gcode_opt.cli import main as cli_main
    try:
        for mod, name in PHASES:
            wrap(mods[mod], name)
        with tempfile.TemporaryDirectory() as tmp:
            cmd = ["process", a.file, "-o", os.path.join(tmp, "out.gcode"), "--profile", a.profile, "-q"]
            if not a.ringing:
                cmd.append("--no-ringing")
            try:
                cli_main(cmd)
            except SystemExit as e:
                if e.code not in (0, None):
                    raise
    finally:                  # (called in a process that goes on, e.g. a test: leave it as it was)
        for mod, name, fn in reversed(saved):
            setattr(mod, name, fn)
        if not was_tracing:
            tracemalloc.stop()
    print(f"{a.file} ({a.profile}): traced MB after each phase (peak: since the start), RSS MB")
    for name, cur, peak, rss, maxrss, files in rows:
        print(f"  {name:14s} traced {cur:7.1f} (peak {peak:7.1f})  RSS {rss:7.1f} (peak {maxrss:7.1f})")
        print("      " + ", ".join(f"{f} {mb:.1f}" for f, mb in files))
    strokes = held.get("strokes")
    if strokes:
        parts = stroke_slots(strokes)
        total = sum(parts.values())
        print(f"  strokes: {len(strokes)}, {total:.1f} MB ({1e6 * total / len(strokes):.0f} bytes each)")
        print("      " + ", ".join(f"{k} {mb:.2f}" for k, mb in parts.items() if mb >= 0.05))
    return rows


if __name__ == "__main__":
    main()
