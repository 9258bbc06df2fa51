"""benchmarks/mem_breakdown.py --rises: each rise of the peak RSS put on the step it was
seen in, and the process left as it was."""
import os
import re
import subprocess
import sys

import gcode_opt.schedule as sch
from bench_modules import load_bench

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
SAMPLE = os.path.join(ROOT, "sample_gcode", "prusa_gyroid.gcode")


def _load():
    return load_bench("mem_breakdown")


def test_rises_in_a_fresh_process_name_the_phases():
    """A fresh process (a test process's peak may be above anything the sample needs): the
    rises add up to the last peak, planning raises it, and every rise is put on a watched
    step.  (Whether analyse raises it on the 7 k-line sample depends on the heap the imports
    left: +0.2 to +1.4 MB, or none under pytest.)"""
    env = dict(os.environ, PYTHONPATH=os.path.abspath(ROOT))
    out = subprocess.run([sys.executable, os.path.join(ROOT, "benchmarks", "mem_breakdown.py"), SAMPLE, "--rises"],
                         capture_output=True, text=True, check=True, env=env).stdout
    rows = [(float(m[1]), float(m[2]), m[3]) for m in re.finditer(r"\+\s*([\d.]+) MB ->\s*([\d.]+) MB  (\S+)", out)]
    assert rows, out
    peaks = [p for _, p, _ in rows]
    assert peaks == sorted(peaks)
    assert abs(sum(up for up, _, _ in rows[1:]) - (peaks[-1] - peaks[0])) <= 0.05 * len(rows)   # (printed to 0.1)
    steps = {s for _, _, s in rows}
    assert any(s.startswith(("plan_inputs", "plan_strokes")) for s in steps), steps
    watched = {name.split(".")[-1] for _, name in _load().STEPS} | {"candidates", "segments", "(between"}   # (the kinds')
    # (a step is named as STEPS names it, "Candidates.of_pieces" included: its last dotted part)
    assert all(s.split("/")[-1].split("[")[0].split(".")[-1] in watched for s in steps), steps


def test_rises_leave_the_steps_as_they_were():
    mod = _load()
    kinds = {k: (kind.candidates, kind.segments) for k, kind in sch.KINDS.items()}
    fit, of_pieces = sch._fit_budget, vars(sch.Candidates)["of_pieces"]
    mod.main([SAMPLE, "--rises"])
    assert sch._fit_budget is fit and vars(sch.Candidates)["of_pieces"] is of_pieces
    assert all((kind.candidates, kind.segments) == kinds[k] for k, kind in sch.KINDS.items())
