"""benchmarks/mem_breakdown.py --steps (s34, planrect): the RSS, peak and heap at every
watched step's start and end, nested as the steps ran, and the process left as it was;
its RSS in the peak's unit (MiB, VmHWM's kB / 1024)."""
import os

import gcode_opt.schedule as sch
from bench_modules import load_bench

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
SAMPLE = os.path.join(ROOT, "sample_gcode", "prusa_gyroid.gcode")


def _load():
    return load_bench("mem_breakdown")


def test_steps_nest_and_leave_the_steps_as_they_were():
    mod = _load()
    kinds = {k: (kind.candidates, kind.segments) for k, kind in sch.KINDS.items()}
    fit = sch._fit_budget
    rows = mod.main([SAMPLE, "--steps"])
    assert sch._fit_budget is fit
    assert all((kind.candidates, kind.segments) == kinds[k] for k, kind in sch.KINDS.items())
    # every start has its end, at the same depth, last in first out
    open_ = []
    for depth, mark, name, rss, peak, _ in rows:
        if mark == ">":
            assert depth == len(open_)
            open_.append(name)
        else:
            assert open_.pop() == name and depth == len(open_)
        assert 0 < rss <= peak * 1.02 + 1          # (one unit: RSS now never far above the peak so far)
    assert not open_
    names = [name for _, mark, name, *_ in rows if mark == ">"]
    assert {"analyse", "plan_inputs", "plan_strokes", "_fit_budget", "rewrite"} <= set(names)
    # (not the peaks in order: VmHWM is the kernel's high-water mark or the resident set
    # now, whichever is more, and trim_heap's madvise can lower the second by a little)
    plan = [i for i, r in enumerate(rows) if r[2] == "plan_strokes"]
    assert rows[plan[-1]][4] >= rows[plan[0]][4]
