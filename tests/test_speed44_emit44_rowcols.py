"""Session 44: stroke_run's rows straight into out_ranges' three array('q') columns (one
frombytes a column a call, no tuple a row) and order's int64s read in place, against the
same call with a list out_ranges and order as a list (the tuple rows and order[k] objects
of before): every call of real rewrites (four flavours, CRLF, arcs; digests on and off)
is made both ways, and the rows, the returned (k, pos, line, out_line), the bytes written
and the digests must be the same.  And a write that raises at the run's flush: the rows
taken before it are in the columns all the same (as they were in the list)."""
from __future__ import annotations

import array
import copy
import types

import pytest

from gcode_opt import emit, pipeline

from test_speed20_rewrite_core import CASES, SAMPLES, _planned, _run, ref_rewrite

CORE = emit.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "stroke_run"),
                                reason=f"no compiled emit core with stroke_run: {emit.CORE_WHY}")


def _cols_rows(cols, since):
    return list(zip(*(c[n:] for c, n in zip(cols, since))))


class _Twin(types.ModuleType):
    """The compiled core; each stroke_run call made first the old way (a list of rows,
    order as a list of ints, its own dict of digests and its own writes), then as the
    pipeline makes it, and the two compared."""

    def __init__(self):
        super().__init__("_gcode_opt_emit_twin")
        self.calls = self.rows = 0

    def __getattr__(self, name):
        return getattr(CORE, name)

    def stroke_run(self, *args):
        args = list(args)
        cols = args[6]
        assert type(cols) is tuple and all(type(c) is array.array and c.typecode == "q" for c in cols)
        old = list(args)
        old_rows, old_out = [], []
        old[3] = [int(i) for i in args[3]]
        old[6] = old_rows
        old[20] = None if args[20] is None else {}
        old[22] = lambda mv: old_out.append(bytes(mv))
        want = CORE.stroke_run(*old)
        since = [len(c) for c in cols]
        new_out = []
        write = args[22]

        def both(mv):
            new_out.append(bytes(mv))
            write(mv)
        args[22] = both
        digests_before = None if args[20] is None else dict(args[20])
        got = CORE.stroke_run(*args)
        assert got == want
        assert _cols_rows(cols, since) == old_rows
        assert b"".join(new_out) == b"".join(old_out)
        if args[20] is not None:
            new = {k: v for k, v in args[20].items() if k not in digests_before}
            assert new == old[20]
        self.calls += 1
        self.rows += len(old_rows)
        return got


def _rewrite(core, path, strokes, plan, prof, opts, out, digests, monkeypatch):
    with monkeypatch.context() as m:
        m.setattr(emit, "CORE_MOD", core)
        m.setattr(pipeline, "_STROKE_RUN", True)
        with open(out, "w", encoding="utf-8", errors="surrogateescape", newline="") as fh:
            ranges = pipeline.rewrite(path, fh, strokes, copy.deepcopy(plan), prof, opts, digests)
    return open(out, "rb").read(), ranges


@pytest.mark.parametrize("name,prof_name", CASES)
@pytest.mark.parametrize("with_digests", [True, False])
def test_columns_are_the_list_rows(name, prof_name, with_digests, tmp_path, monkeypatch):
    prof, opts, strokes, plan = _planned(name, prof_name)
    path = SAMPLES + name
    core = _Twin()
    digests = {} if with_digests else None
    got, ranges = _rewrite(core, path, strokes, plan, prof, opts, tmp_path / "run.gcode", digests, monkeypatch)
    assert core.calls >= 1 and (core.rows > 20 or "crlf" in name)      # (CRLF lines: the run takes none)
    ref = _run(ref_rewrite, path, strokes, plan, prof, opts, tmp_path / "ref.gcode")
    assert got == ref[0] and ranges == ref[1]
    if with_digests:
        assert digests == ref[2]


class _Raising(types.ModuleType):
    """The compiled core whose stroke_run's write raises; as_list: the call made with a
    list out_ranges (its rows then put in the columns, as OutRanges.take did)."""

    def __init__(self, as_list):
        super().__init__("_gcode_opt_emit_raising")
        self.as_list, self.rows = as_list, None

    def __getattr__(self, name):
        return getattr(CORE, name)

    def stroke_run(self, *args):
        args = list(args)
        cols = args[6]
        if self.as_list:
            args[6] = []

        def write(mv):
            raise _Stop
        args[22] = write
        try:
            return CORE.stroke_run(*args)
        finally:
            for row in (args[6] if self.as_list else ()):
                for c, v in zip(cols, row):
                    c.append(int(v))
            self.rows = [c.tolist() for c in cols]


class _Stop(Exception):
    pass


def test_rows_kept_when_the_write_raises(tmp_path, monkeypatch):
    """A write that raises (the run's last flush): the exception comes out of the rewrite,
    and the rows of the blocks the call took are in the columns, as in the list."""
    prof, opts, strokes, plan = _planned("prusa_gyroid.gcode", "prusa-mk3s")
    got = []
    for as_list in (True, False):
        core = _Raising(as_list)
        with pytest.raises(_Stop):
            _rewrite(core, SAMPLES + "prusa_gyroid.gcode", strokes, plan, prof, opts, tmp_path / "x.gcode", None,
                     monkeypatch)
        got.append(core.rows)
    assert got[0] == got[1] and len(got[1][0]) > 20
