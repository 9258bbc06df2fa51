"""_rewrite_bytes' inline copy of the untouched lines and take of a stroke's lines (the
common case of _ByteLines.copy_take, both line runs inside the chunk read; else
copy_take itself) against the reference rewrite kept verbatim in
tests/test_speed20_rewrite_core.py (ref_rewrite, the text loop of ede93db):

  * real files, chunk sizes from a few bytes (nearly every stroke falls back to
    copy_take) to the default (nearly none does): the same bytes, output ranges, digests,
    reasons and plans;
  * the inline path is taken (copy_take is called for few strokes with the default chunk);
  * a file cut right after a re-timed stroke's last line, with and without its line end
    (the end of the file: skip_lines' final is the fallback's business)."""
from __future__ import annotations

import numpy as np
import pytest

from gcode_opt import pipeline
from gcode_opt.strokes import K_ARC

from test_speed20_rewrite_core import CORE, SAMPLES, _planned, _run, ref_rewrite

pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "stroke_block"),
                                reason="no compiled emit core")

CASES = [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24"),
         ("edge/crlf_line_endings.gcode", "prusa-mk3s")]


@pytest.mark.parametrize("name,prof_name", CASES)
def test_chunks_are_the_reference(name, prof_name, tmp_path, monkeypatch):
    prof, opts, strokes, plan = _planned(name, prof_name)
    path = SAMPLES + name
    ref = _run(ref_rewrite, path, strokes, plan, prof, opts, tmp_path / "ref.gcode")
    for chunk in (1 << 20, 4096, 997, 101, 37, 3):
        with monkeypatch.context() as m:
            m.setattr(pipeline, "_CHUNK", chunk)
            got = _run(pipeline.rewrite, path, strokes, plan, prof, opts, tmp_path / f"c{chunk}.gcode")
        assert got[0] == ref[0], chunk
        assert got[1:] == ref[1:], chunk


def test_inline_path_is_taken(tmp_path, monkeypatch):
    prof, opts, strokes, plan = _planned("prusa_gyroid.gcode", "prusa-mk3s")
    calls = []
    orig = pipeline._ByteLines.copy_take

    def counted(self, *a):
        calls.append(a)
        return orig(self, *a)

    ref = _run(ref_rewrite, SAMPLES + "prusa_gyroid.gcode", strokes, plan, prof, opts, tmp_path / "ref.gcode")
    with monkeypatch.context() as m:
        m.setattr(pipeline._ByteLines, "copy_take", counted)
        got = _run(pipeline.rewrite, SAMPLES + "prusa_gyroid.gcode", strokes, plan, prof, opts, tmp_path / "n.gcode")
    assert got == ref
    n = int(np.count_nonzero(plan.retime))
    assert n > 100 and len(calls) <= 2, (n, len(calls))      # the file is one chunk
    calls.clear()
    with monkeypatch.context() as m:
        m.setattr(pipeline._ByteLines, "copy_take", counted)
        m.setattr(pipeline, "_CHUNK", 4096)
        got = _run(pipeline.rewrite, SAMPLES + "prusa_gyroid.gcode", strokes, plan, prof, opts, tmp_path / "c.gcode")
    assert got == ref
    assert 0 < len(calls) < n / 2, (n, len(calls))           # some strokes span chunks


@pytest.mark.parametrize("line_end", [b"\n", b""])
@pytest.mark.parametrize("chunk", [1 << 20, 64])
def test_file_cut_after_a_stroke(line_end, chunk, tmp_path, monkeypatch):
    prof, opts, strokes, plan = _planned("prusa_gyroid.gcode", "prusa-mk3s")
    raw = open(SAMPLES + "prusa_gyroid.gcode", "rb").read()
    lines = raw.split(b"\n")
    order = sorted(np.flatnonzero(plan.retime), key=lambda i: strokes[i].first_idx)
    s = strokes[order[len(order) // 2]]
    last = s.first_idx + s.n_moves - 1
    path = tmp_path / "cut.gcode"
    path.write_bytes(b"\n".join(lines[:last + 1]) + line_end)
    ref = _run(ref_rewrite, str(path), strokes, plan, prof, opts, tmp_path / "ref.gcode")
    with monkeypatch.context() as m:
        m.setattr(pipeline, "_CHUNK", chunk)
        got = _run(pipeline.rewrite, str(path), strokes, plan, prof, opts, tmp_path / "got.gcode")
    assert got[0] == ref[0]
    assert got[1:] == ref[1:]


def test_stroke_without_start_state(tmp_path):
    """A re-timed stroke without a recorded start state (start_state None, read from the
    slots by _rewrite_bytes): the Python path's failure, as the reference has it."""
    import copy as _copy
    prof, opts, strokes, plan = _planned("prusa_gyroid.gcode", "prusa-mk3s")
    strokes = _copy.deepcopy(strokes)
    order = sorted(np.flatnonzero(plan.retime), key=lambda i: strokes[i].first_idx)
    for k in (0, len(order) // 3, len(order) - 1):
        strokes[order[k]].start_state = None
    path = SAMPLES + "prusa_gyroid.gcode"
    ref = _run(ref_rewrite, path, strokes, plan, prof, opts, tmp_path / "ref.gcode")
    got = _run(pipeline.rewrite, path, strokes, plan, prof, opts, tmp_path / "got.gcode")
    assert got == ref
    assert sum(r is not None and r.startswith("error: emission") for r in ref[3]) >= 3


def test_one_move_strokes(tmp_path, monkeypatch):
    """Strokes of one move (no ends_d kept: _rewrite_bytes hands the core [length_d], not
    ends_d's array): the core writes their blocks, the reference's bytes; a length_d that
    is not a float (a numpy float) makes the core decline: still the reference's bytes."""
    import copy as _copy
    from test_speed20_rewrite_core import _Core
    from gcode_opt import emit
    prof, opts, strokes, plan = _planned("prusa_gyroid.gcode", "prusa-mk3s")
    path = SAMPLES + "prusa_gyroid.gcode"
    one = [i for i in np.flatnonzero(plan.retime) if strokes[i]._ends is None and strokes[i].kind != K_ARC]
    assert len(one) > 20
    ref = _run(ref_rewrite, path, strokes, plan, prof, opts, tmp_path / "ref.gcode")
    seen = []

    class Seen(_Core):
        def stroke_block(self, *args):
            got = super().stroke_block(*args)
            if isinstance(args[16], list):
                seen.append(got is not None)
            return got

    with monkeypatch.context() as m:
        m.setattr(emit, "CORE_MOD", Seen())
        got = _run(pipeline.rewrite, path, strokes, plan, prof, opts, tmp_path / "got.gcode")
    assert got == ref
    assert len(seen) == len(one) and sum(seen) >= 0.9 * len(one), (len(seen), sum(seen), len(one))
    strokes2 = _copy.deepcopy(strokes)
    for i in one[::3]:
        strokes2[i].length_d = np.float64(strokes2[i].length_d)
    ref2 = _run(ref_rewrite, path, strokes2, plan, prof, opts, tmp_path / "ref2.gcode")
    got2 = _run(pipeline.rewrite, path, strokes2, plan, prof, opts, tmp_path / "got2.gcode")
    assert got2 == ref2
