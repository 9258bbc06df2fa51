"""What holds the memory of `gcode-opt process`, phase by phase: traced Python memory
(tracemalloc) by the source file that allocated it, the process's RSS beside it, and the
strokes' own share by slot -- the figures a memory change starts from.

    python benchmarks/mem_breakdown.py FILE [--profile NAME] [--top N] [--ringing]
    python benchmarks/mem_breakdown.py FILE --rises [--profile NAME] [--ringing]
    python benchmarks/mem_breakdown.py FILE --steps [--profile NAME] [--ringing]

tracemalloc makes the run ~10x slower and only sees allocations made through Python's
allocators (numpy's data buffers are among them; the C cores' own buffers are not).  The
RSS column is /proc/self/statm's resident set at the same moment and peak_mb() the peak so
far, both with tracemalloc's own bookkeeping in them (on the gyroid plate ~3x the traced
memory): compare them between phases of one run only.  The command's real peak RSS per
phase is `gcode-opt process --profile-time`'s.  Measure a tree with PYTHONPATH=TREE: a
script's own folder, not the current one, is first on sys.path, so without it the
gcode_opt installed in the environment is the one measured.

--rises: where the peak RSS is reached, without tracemalloc (whose bookkeeping would be in
it): every rise of the peak (peak_mb), put on the innermost of the STEPS running when it
was seen (read at each step's start and end), with glibc's heap in use and free beside
it.  Several steps rising to about the same height is the common picture: bounding one
step's temporaries then moves the peak only to the next.

--steps: the same steps' RSS, peak and heap at each one's start and end, indented: whether
a step's rise was a transient the next step reused (the heap's free part grew), or kept.
"""
from __future__ import annotations

import argparse
import collections
import os
import sys
import tempfile
import tracemalloc

# the phase boundaries: (module, function) wrapped in this order of the job
PHASES = (("pipeline", "analyse"), ("pipeline", "plan_inputs"), ("schedule", "_candidates"),
          ("pipeline", "plan_strokes"), ("pipeline", "rewrite"), ("pipeline", "measure"))


# the steps --rises watches: (module, attribute); plan_inputs and plan_strokes as pipeline
# calls them, and each kind's candidates and segments through schedule.KINDS (bound there)
STEPS = (("pipeline", "analyse"), ("pipeline", "plan_inputs"), ("pipeline", "plan_strokes"),
         ("schedule", "_candidates"), ("schedule", "_line_candidates"), ("schedule", "line_classes"),
         ("plan", "Candidates.of_pieces"), ("schedule", "_fit_budget"), ("schedule", "plan_auto"),
         ("schedule", "_keep_plans"), ("laws.circle", "_layer_regime"), ("laws.circle", "_solve_cheb_batch"),
         ("curves", "surely_over"), ("curves", "true_figures"), ("chains", "_figures_sorted"),
         ("pipeline", "rewrite"), ("pipeline", "measure"), ("pipeline", "trim_heap"))


def rss_mb() -> float:
    """The resident set now, in peak_mb()'s unit (VmHWM's kB / 1024: MiB; this read
    1e6-byte MB, ~5 % more than the peak beside it)."""
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / (1 << 20)


def peak_mb() -> float:
    """The process's peak resident set so far, MB (pipeline.peak_rss_mb: VmHWM, not the
    ru_maxrss a child inherits from its parent)."""
    from gcode_opt.rss import peak_rss_mb
    return peak_rss_mb()


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


def heap_mb():
    """(in use, free) MB of glibc's main heap (mallinfo2), or None off glibc >= 2.33."""
    import ctypes

    class Mallinfo2(ctypes.Structure):
        _fields_ = [(f, ctypes.c_size_t) for f in ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks",
                                                   "fsmblks", "uordblks", "fordblks", "keepcost")]
    try:
        fn = ctypes.CDLL(None).mallinfo2
    except (OSError, AttributeError):
        return None
    fn.restype = Mallinfo2
    m = fn()
    return m.uordblks / 1e6, m.fordblks / 1e6


def _run(a):
    """The command on a.file, its output in a temporary folder."""
    from gcode_opt.cli import main as cli_main
    with tempfile.TemporaryDirectory() as tmp:
        cmd = ["process", a.file, "-o", os.path.join(tmp, "out.gcode"), "--profile", a.profile, "-q"]
        if not a.ringing:
            cmd.append("--no-ringing")
        try:
            cli_main(cmd)
        except SystemExit as e:
            if e.code not in (0, None):
                raise


def _watching(a, enter, leave):
    """Run the command with every STEPS step and each kind's candidates and segments
    wrapped: enter(name) before it runs, leave(name) after (it raised or not); the steps
    put back as they were after."""
    import importlib
    import gcode_opt.schedule as sch

    def watched(fn, name):
        def step(*args, **kw):
            enter(name)
            try:
                return fn(*args, **kw)
            finally:
                leave(name)
        return step

    saved = []              # (owner, attribute, what owner.__dict__ held): put back after
    for mod, path in STEPS:
        owner = importlib.import_module("gcode_opt." + mod)
        *outer, name = path.split(".")
        for part in outer:
            owner = getattr(owner, part)
        saved.append((owner, name, owner.__dict__[name]))
        setattr(owner, name, watched(getattr(owner, name), path))
    for k, kind in sch.KINDS.items():
        for name in ("candidates", "segments"):
            saved.append((kind, name, kind.__dict__[name]))
            setattr(kind, name, watched(getattr(kind, name), f"{name}[{k}]"))
    try:
        _run(a)
    finally:
        for owner, name, was in reversed(saved):
            setattr(owner, name, was)


def rises(a):
    """[(step path, MB risen, peak MB after, heap_mb())]: each rise of peak_mb() during the
    command, put on the innermost STEPS running (the last three of them named); printed."""
    stack, seen, out = [], [peak_mb()], []

    def note():
        p = peak_mb()
        if p > seen[0]:
            out.append(("/".join(stack[-3:]) or "(between steps)", p - seen[0], p, heap_mb()))
            seen[0] = p

    def enter(name):
        note()
        stack.append(name)

    def leave(name):
        note()
        stack.pop()

    _watching(a, enter, leave)
    note()
    print(f"{a.file} ({a.profile}): each rise of the peak RSS, in the step it was seen in")
    for path, up, peak, heap in out:
        tail = "" if heap is None else f"   [heap in use {heap[0]:.1f}, free {heap[1]:.1f} MB]"
        print(f"  +{up:6.1f} MB -> {peak:6.1f} MB  {path}{tail}")
    return out


def steps(a):
    """[(depth, '>' or '<', step, RSS MB, peak MB, heap_mb())] at each watched step's start
    (>) and end (<), printed indented by depth: what a step holds after it (RSS, heap in
    use) and what it left free, beside the peak -- the rises alone do not say whether a
    step's memory was a transient, reused by the next, or kept."""
    out, depth = [], [0]

    def row(mark, name):
        out.append((depth[0], mark, name, rss_mb(), peak_mb(), heap_mb()))

    def enter(name):
        row(">", name)
        depth[0] += 1

    def leave(name):
        depth[0] -= 1
        row("<", name)

    _watching(a, enter, leave)
    print(f"{a.file} ({a.profile}): RSS (statm), peak RSS and glibc's heap at each step's start (>) and end (<), MB")
    for d, mark, name, rss, peak, heap in out:
        tail = "" if heap is None else f"   heap in use {heap[0]:5.1f}, free {heap[1]:5.1f}"
        print(f"  {'  ' * d}{mark} {name:{44 - 2 * d}s} RSS {rss:6.1f}  peak {peak:6.1f}{tail}")
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("file")
    ap.add_argument("--profile", default="prusa-mk3s")
    ap.add_argument("--top", type=int, default=8, help="files listed per phase")
    ap.add_argument("--ringing", action="store_true", help="leave the ringing figures on (default: off)")
    ap.add_argument("--rises", action="store_true", help="where the peak RSS rises (no tracemalloc)")
    ap.add_argument("--steps", action="store_true", help="RSS and heap at every step's start and end (no tracemalloc)")
    a = ap.parse_args(argv)
    if a.rises:
        return rises(a)
    if a.steps:
        return steps(a)

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

    try:
        for mod, name in PHASES:
            wrap(mods[mod], name)
        _run(a)
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
