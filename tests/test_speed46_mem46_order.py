"""The strokes' first-line order (pipeline._first_line_order), which only measure reads, is
made once the first plan is written, not before planning: it is not held through the
plan's peak (0.42 MB on the rectilinear plate).  The same order as the expression it
replaces, and the same written file."""

import numpy as np

from gcode_opt import pipeline
from gcode_opt.pipeline import Options, analyse, line_spans, process
from gcode_opt.profile import load_profile
from strokes_kept import _strokes_kept

SAMPLE = "sample_gcode/prusa_gyroid.gcode"


def ref_order(strokes):
    """pipeline._process's order at 0b09fc6 (verbatim), made before the first plan."""
    from array import array
    return array("q", np.argsort(line_spans(strokes)[0], kind="stable").astype(np.int64).tobytes())


def test_first_line_order_is_the_old_order():
    prof = load_profile("prusa-mk3s")
    strokes, _ = analyse(SAMPLE, prof, Options())
    got, want = pipeline._first_line_order(strokes), ref_order(strokes)
    assert got.typecode == want.typecode == "q"
    assert got == want
    # shuffled strokes: a real reordering, ties (the same first line) kept in stroke order
    rng = np.random.default_rng(46)
    mixed = [strokes[i] for i in rng.permutation(len(strokes)).tolist()]
    mixed = mixed + mixed[:5]
    assert pipeline._first_line_order(mixed) == ref_order(mixed)


def test_order_made_after_planning_and_the_same_file(tmp_path, monkeypatch):
    prof = load_profile("prusa-mk3s")
    seen = []
    plan_strokes, first_line_order = pipeline.plan_strokes, pipeline._first_line_order

    def planned(*a, **k):
        seen.append("plan")
        return plan_strokes(*a, **k)

    def ordered(strokes):
        seen.append("order")
        return first_line_order(strokes)
    monkeypatch.setattr(pipeline, "plan_strokes", planned)
    monkeypatch.setattr(pipeline, "_first_line_order", ordered)
    out = tmp_path / "new.gcode"
    process(SAMPLE, str(out), prof, Options())
    assert seen.count("order") == 1 and seen.index("order") > seen.index("plan")
    monkeypatch.undo()

    # the old order (of the strokes: the run hands _first_line_order their StrokeColumns),
    # handed in where the new one is made: the same bytes
    with _strokes_kept() as strokes:
        monkeypatch.setattr(pipeline, "_first_line_order", lambda cols: ref_order(strokes[0]))
        ref = tmp_path / "ref.gcode"
        process(SAMPLE, str(ref), prof, Options())
    assert out.read_bytes() == ref.read_bytes()
