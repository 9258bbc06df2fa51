"""measure's per-stroke sums (pipeline._per_stroke) kept in floats while the pass is in a
stroke: the same bits as the c8abe7b code (kept below verbatim, renamed) that added every
record into the numpy arrays."""
from __future__ import annotations

import random
import struct

import numpy as np
import pytest

from gcode_opt import pipeline as pl
from gcode_opt.firmware.simulate import simulate_events
from gcode_opt.profile import load_profile
from gcode_opt.state import events


def _ref_per_stroke(out_ranges, t, a2, v2):
    """on_line for the firmware model on a re-timed file: each line's record added to the
    re-timed stroke (out_ranges, in file order) whose block holds the line."""
    n = len(out_ranges)
    pos = [0]

    def on_line(r):
        k = pos[0]
        while k < n and r.idx > out_ranges[k][1]:
            k += 1
        pos[0] = k
        if k < n and out_ranges[k][0] <= r.idx:
            t[k] += r.time_t
            a2[k] += r.int_a2 + r.int_a2_j
            v2[k] += r.int_v2
    return on_line


class _Rec:
    __slots__ = ("idx", "time_t", "int_a2", "int_a2_j", "int_v2")

    def __init__(self, idx, rng):
        self.idx = idx
        self.time_t, self.int_a2, self.int_a2_j, self.int_v2 = (rng.uniform(-1, 1) * 10 ** rng.randint(-12, 6)
                                                                for _ in range(4))


def _bits(a):
    return [struct.pack("<d", x) for x in np.asarray(a, float).tolist()]


def _both(out_ranges, recs):
    n = len(out_ranges)
    ref, new = [np.zeros(n) for _ in range(3)], [np.zeros(n) for _ in range(3)]
    f_ref, f_new = _ref_per_stroke(out_ranges, *ref), pl._per_stroke(out_ranges, *new)
    for r in recs:
        f_ref(r)
        f_new(r)
    f_new.flush()
    for a, b in zip(ref, new):
        assert _bits(a) == _bits(b)
    return ref


@pytest.mark.parametrize("seed", range(40))
def test_per_stroke_sums_are_the_reference(seed):
    """Random ranges (touching, gaps, one line, empty of records), random records in file
    order with gaps, signed values over 18 decades (so the order of additions shows)."""
    rng = random.Random(seed)
    out_ranges, line = [], rng.randint(0, 3)
    for j in range(rng.randint(0, 12)):
        lo = line + rng.choice((0, 0, 1, 5))
        hi = lo + rng.choice((0, 1, 3, 20))
        out_ranges.append((lo, hi, j))
        line = hi + 1
    recs = [_Rec(i, rng) for i in range(line + 5) if rng.random() < 0.8]
    _both(out_ranges, recs)


def test_per_stroke_on_a_real_pass():
    """The model's own records of a written file, out_ranges from its rewrite."""
    path = "sample_gcode/prusa_gyroid.gcode"
    profile = load_profile("prusa-mk3s")
    import tempfile, os
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "o.gcode")
        opts = pl.Options()
        pl.process(path, out, profile, opts)
        recs = []
        simulate_events(events(out, profile), profile, on_line=recs.append)
        # the written file's blocks: the fenced line ranges
        out_ranges, lo = [], None
        with open(out) as fh:
            for i, line in enumerate(fh):
                if line.startswith("; gcode-opt begin"):
                    lo = i
                elif line.startswith("; gcode-opt end") and lo is not None:
                    out_ranges.append((lo, i, len(out_ranges)))
                    lo = None
    assert len(out_ranges) > 10
    ref = _both(out_ranges, recs)
    assert (ref[0] > 0).sum() > 10
