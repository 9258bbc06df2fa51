"""_emit.c's stroke_run takes its output buffer's room (a flush's worth and the block that
passes it) at once instead of growing it from nothing by doubling on every call.  Against
the loop it stands for (_STROKE_RUN off: stroke_block per stroke): the same bytes, output
ranges, digests and plan on a corpus file whose rewrite flushes the buffer several times
in one run, each flush but a run's last one at least RUN_FLUSH (1 MiB) bytes."""
from __future__ import annotations

import os

import pytest

from gcode_opt import emit, pipeline

from test_speed25_rewritec_run import CORE, _Counted, _counted_run

CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus/bridges.gcode")
RUN_FLUSH = 1 << 20

pytestmark = [pytest.mark.skipif(CORE is None or not hasattr(CORE, "stroke_run"),
                                 reason=f"no compiled emit core with stroke_run: {emit.CORE_WHY}"),
              pytest.mark.skipif(not os.path.exists(CORPUS), reason="no corpus file")]


class _Writes(_Counted):
    """The core with each stroke_run's writes (their sizes) recorded."""

    def __init__(self):
        super().__init__()
        self.writes = []

    def stroke_run(self, *args):
        sizes = []
        self.writes.append(sizes)
        write = args[-1]

        def rec(mv):
            sizes.append(len(mv))
            return write(mv)
        return super().stroke_run(*args[:-1], rec)


def test_run_flushes_are_the_loop(tmp_path, monkeypatch):
    from gcode_opt.profile import load_profile
    from gcode_opt.schedule import plan_inputs, plan_strokes
    prof = load_profile("prusa-mk3s")
    opts = pipeline.Options()
    strokes, sim0 = pipeline.analyse(CORPUS, prof, opts)
    plan = plan_strokes(strokes, plan_inputs(strokes, prof, opts), prof, opts, opts.max_slowdown_r * sim0.time_t)
    core = _Writes()
    monkeypatch.setattr("test_speed25_rewritec_run._Counted", lambda: core)
    got, _ = _counted_run(monkeypatch, CORPUS, strokes, plan, prof, opts, tmp_path / "run.gcode")
    loop, _ = _counted_run(monkeypatch, CORPUS, strokes, plan, prof, opts, tmp_path / "loop.gcode", run_on=False)
    assert got == loop
    sizes = [w for run in core.writes for w in run[:-1]]
    assert len(sizes) >= 3 and all(w >= RUN_FLUSH for w in sizes), core.writes
    assert sum(map(sum, core.writes)) > 0.8 * len(got[0])      # the run wrote nearly all of it
