"""The first pass's measure holds the strokes' output lines once (issue 8, memory, s54
tail54): as the watch (LineRanges, in file order) the firmware model reads, not also as
stroke_lines' two arrays by stroke; these are made again from the watch after the pass
(pipeline.lines_by_stroke) for a second pass's remeasure.  Checked: the same int64 arrays as
stroke_lines gave, on a real run's strokes and on random permutations; and the second pass
on a real sample re-measures from them (remeasure lines up, and equals a full measure:
test_speed_paths.test_second_pass_measures_only_what_changed)."""
import os
from array import array

import numpy as np
import pytest

from gcode_opt import pipeline
from gcode_opt.firmware.simulate import LineRanges
from gcode_opt.profile import load_profile

SAMPLES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "sample_gcode")


def _round_trip(lines, order, n):
    o = np.asarray(order, np.int64)
    watch = LineRanges.of_rows(lines[0][o], lines[1][o])
    return pipeline.lines_by_stroke(watch, order, n)


@pytest.mark.parametrize("n,seed", [(1, 0), (2, 1), (97, 2), (5000, 3)])
def test_lines_made_again_from_the_watch(n, seed):
    rng = np.random.default_rng(seed)
    first = rng.integers(0, 1 << 40, n)
    lines = (first, first + rng.integers(0, 50, n))
    order = rng.permutation(n)
    for o in (order, array("q", order.astype(np.int64).tobytes())):
        got = _round_trip(lines, o, n)
        assert all(g.dtype == np.int64 and np.array_equal(g, w) for g, w in zip(got, lines))


def test_a_real_runs_lines(tmp_path, monkeypatch):
    seen = []
    real = pipeline.stroke_lines

    def spy(strokes, order, out_ranges):
        got = real(strokes, order, out_ranges)
        seen.append((got, order, len(strokes)))
        return got
    monkeypatch.setattr(pipeline, "stroke_lines", spy)
    pipeline.process(os.path.join(SAMPLES, "prusa_gyroid.gcode"), str(tmp_path / "o.gcode"),
                     load_profile("prusa-mk3s"), pipeline.Options())
    (lines, order, n), = seen
    assert n > 1000 and type(order) is array
    got = _round_trip(lines, order, n)
    assert all(g.dtype == np.int64 and np.array_equal(g, w) for g, w in zip(got, lines))
