"""process() freezes the objects alive after analyse out of the garbage collector's view
(pipeline._strokes_frozen) and thaws them when the job ends, however it ends; a caller's
own frozen objects are left alone.  The output is the same bytes either way."""
import gc
from pathlib import Path

import pytest

from gcode_opt import pipeline
from gcode_opt.pipeline import Options
from gcode_opt.profile import load_profile

SAMPLE = Path(__file__).resolve().parents[1] / "sample_gcode" / "prusa_gyroid.gcode"


def _run(tmp_path, name):
    out = tmp_path / name
    pipeline.process(str(SAMPLE), str(out), load_profile("prusa-mk3s"), Options())
    return out.read_bytes()


def test_freeze_is_taken_and_undone(tmp_path, monkeypatch):
    seen = []
    real = pipeline.plan_inputs

    def spy(*a, **k):
        seen.append(gc.get_freeze_count())
        return real(*a, **k)
    monkeypatch.setattr(pipeline, "plan_inputs", spy)
    assert gc.get_freeze_count() == 0
    frozen = _run(tmp_path, "a.gcode")
    assert seen and seen[0] > 1000          # the strokes and the modules, frozen during planning
    assert gc.get_freeze_count() == 0
    # the same bytes without the freeze
    monkeypatch.setattr(pipeline, "_strokes_frozen", _no_freeze)
    assert _run(tmp_path, "b.gcode") == frozen


class _NoFreezeCtx:
    def __enter__(self):
        return None

    def __exit__(self, *exc):
        return False


def _no_freeze():
    return _NoFreezeCtx()


def test_thawed_after_a_failure(tmp_path, monkeypatch):
    def boom(*a, **k):
        raise RuntimeError("planning failed")
    monkeypatch.setattr(pipeline, "plan_inputs", boom)
    with pytest.raises(RuntimeError):
        _run(tmp_path, "c.gcode")
    assert gc.get_freeze_count() == 0


def test_a_callers_freeze_is_left_alone(tmp_path):
    keep = [object() for _ in range(10)]
    gc.freeze()
    try:
        n = gc.get_freeze_count()
        _run(tmp_path, "d.gcode")
        # not thawed (0) and not frozen again (it would take the job's objects too); a few
        # frozen objects may be freed by their reference counts meanwhile
        assert 0.99 * n <= gc.get_freeze_count() <= n
    finally:
        gc.unfreeze()
    del keep
