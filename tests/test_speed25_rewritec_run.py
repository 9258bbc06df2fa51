"""_rewrite_bytes' one-call run (_emit.c's stroke_run: the loop's strokes taken in C, one
buffer, out_ranges and digests made there) and stroke_block reading a plan's float64
arrays in place (set_types' probe), against independent references:

  * real files (four flavours, CRLF, arcs): the reference rewrite kept verbatim in
    test_speed20_rewrite_core (ede93db's Python code) -- the same bytes, output ranges,
    digests, reasons and plans -- with the run taking nearly every line stroke (counted),
    and the same again with the run off (_STROKE_RUN: the loop's stroke_block per stroke);
  * strokes the run does not take in the middle of it (a non-ASCII comment: the Python
    path; tiny chunks: lines past the chunk read): the run stops there and goes on after;
  * the rectilinear corpus plate (41 k re-timed strokes): the run against the loop;
  * stroke_block on an ndarray, its list, a strided view, an array.array and a
    big-endian copy: the same block (or None where the old tobytes() reading declined),
    and with the in-place reading switched off (a probe that fails) the same bytes."""
from __future__ import annotations

import array
import os
import types

import numpy as np
import pytest

from gcode_opt import emit, pipeline
from gcode_opt.strokes import K_ARC

from test_speed20_rewrite_core import CASES, SAMPLES, _planned, _run, ref_rewrite

CORE = emit.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "stroke_run"),
                                reason=f"no compiled emit core with stroke_run: {emit.CORE_WHY}")
PLATE = os.path.expanduser("~/.cache/gcode-opt-corpus/plate_rectilinear.gcode")


class _Counted(types.ModuleType):
    """The compiled core as a module (the run is taken through modules only) with its
    stroke_run and stroke_block calls counted."""

    def __init__(self):
        super().__init__("_gcode_opt_emit_counted")
        self.runs = self.blocks = 0

    def __getattr__(self, name):
        return getattr(CORE, name)

    def stroke_run(self, *args):
        self.runs += 1
        return CORE.stroke_run(*args)

    def stroke_block(self, *args):
        self.blocks += 1
        return CORE.stroke_block(*args)


def _counted_run(monkeypatch, *args, run_on=True):
    core = _Counted()
    with monkeypatch.context() as m:
        m.setattr(emit, "CORE_MOD", core)
        m.setattr(pipeline, "_STROKE_RUN", run_on)
        got = _run(pipeline.rewrite, *args)
    return got, core


@pytest.mark.parametrize("name,prof_name", CASES)
def test_run_is_the_reference(name, prof_name, tmp_path, monkeypatch):
    prof, opts, strokes, plan = _planned(name, prof_name)
    path = SAMPLES + name
    ref = _run(ref_rewrite, path, strokes, plan, prof, opts, tmp_path / "ref.gcode")
    got, core = _counted_run(monkeypatch, path, strokes, plan, prof, opts, tmp_path / "run.gcode")
    assert got == ref
    line_strokes = sum(1 for i, r in enumerate(ref[4]) if r and strokes[i].kind != K_ARC)
    assert core.runs >= 1
    if "crlf" not in name and "arcs" not in name:
        # the run took the line strokes: the loop's stroke_block saw hardly any
        assert line_strokes > 20 and core.blocks <= 0.1 * line_strokes, (core.blocks, line_strokes)
    got, core = _counted_run(monkeypatch, path, strokes, plan, prof, opts, tmp_path / "loop.gcode", run_on=False)
    assert got == ref and core.runs == 0 and core.blocks > 0


def test_run_stops_and_goes_on(tmp_path, monkeypatch):
    """Non-ASCII comments on a few re-timed strokes' lines (the core declines them: the
    Python path) and chunks of a few hundred bytes: the run stops at each, the loop takes
    it, the run goes on; the same as the reference."""
    prof, opts, strokes, plan = _planned("prusa_klipper.gcode", "voron24")
    lines = open(SAMPLES + "prusa_klipper.gcode", "rb").read().split(b"\n")
    order = sorted(np.flatnonzero(plan.retime), key=lambda i: strokes[i].first_idx)
    victims = [strokes[order[k]] for k in range(3, len(order), max(1, len(order) // 7))]
    for v in victims:
        lines[v.first_idx] += b" ; caf\xc3\xa9"
    path = tmp_path / "odd.gcode"
    path.write_bytes(b"\n".join(lines))
    ref = _run(ref_rewrite, str(path), strokes, plan, prof, opts, tmp_path / "ref.gcode")
    assert b"caf\xc3\xa9" in ref[0]
    for chunk in (1 << 20, 300):
        with monkeypatch.context() as m:
            m.setattr(pipeline, "_CHUNK", chunk)
            got, core = _counted_run(monkeypatch, str(path), strokes, plan, prof, opts, tmp_path / "run.gcode")
        assert got == ref, chunk
        assert core.runs > len(victims) and core.blocks >= len(victims), (chunk, core.runs, core.blocks)


@pytest.mark.skipif(not os.path.exists(PLATE), reason="no corpus plate")
def test_run_on_the_rectilinear_plate(tmp_path, monkeypatch):
    from gcode_opt.profile import load_profile
    from gcode_opt.schedule import plan_inputs, plan_strokes
    prof = load_profile("prusa-mk3s")
    opts = pipeline.Options()
    strokes, sim0 = pipeline.analyse(PLATE, prof, opts)
    plan = plan_strokes(strokes, plan_inputs(strokes, prof, opts), prof, opts, opts.max_slowdown_r * sim0.time_t)
    got, core = _counted_run(monkeypatch, PLATE, strokes, plan, prof, opts, tmp_path / "run.gcode")
    loop, _ = _counted_run(monkeypatch, PLATE, strokes, plan, prof, opts, tmp_path / "loop.gcode", run_on=False)
    assert got == loop
    assert len(got[1]) > 30000 and core.blocks < 100 and core.runs < 100, (len(got[1]), core.blocks, core.runs)


def _block_args(monkeypatch, tmp_path):
    """Every stroke_block call's arguments of a rewrite of a sample (run off)."""
    prof, opts, strokes, plan = _planned("prusa_gyroid.gcode", "prusa-mk3s")
    calls = []

    class Rec(_Counted):
        def stroke_block(self, *args):
            calls.append(args)
            return CORE.stroke_block(*args)

    with monkeypatch.context() as m:
        m.setattr(emit, "CORE_MOD", Rec())
        m.setattr(pipeline, "_STROKE_RUN", False)
        _run(pipeline.rewrite, SAMPLES + "prusa_gyroid.gcode", strokes, plan, prof, opts, tmp_path / "x.gcode")
    return calls


def test_arrays_read_in_place(tmp_path, monkeypatch):
    calls = _block_args(monkeypatch, tmp_path)
    n_nd = 0
    for args in calls[:400]:
        want = CORE.stroke_block(*args)
        for k in (13, 14, 15):
            a = args[k]
            if not isinstance(a, np.ndarray):
                continue
            n_nd += 1
            as_list = a.tolist()
            strided = np.repeat(a, 2)[::2]
            assert strided.strides[0] == 16
            for other in (as_list, strided, array.array("d", as_list), a.copy()):
                changed = list(args)
                changed[k] = other
                assert CORE.stroke_block(*changed) == want
            big = list(args)
            big[k] = a.astype(">f8")          # not the native float64 dtype: declined, as before
            assert CORE.stroke_block(*big) is None
    assert n_nd > 300 and any(CORE.stroke_block(*a) is not None for a in calls[:400])


def test_in_place_reading_off_gives_the_same_bytes(tmp_path, monkeypatch):
    prof, opts, strokes, plan = _planned("prusa_gyroid.gcode", "prusa-mk3s")
    path = SAMPLES + "prusa_gyroid.gcode"
    want = _run(pipeline.rewrite, path, strokes, plan, prof, opts, tmp_path / "on.gcode")
    probe = np.array([0.5, 1.5, 2.5])
    try:
        # a probe whose address is not its data's: the core reads arrays through tobytes()
        assert CORE.set_types(np.ndarray, np.dtype(np.float64), array.array, probe, probe.ctypes.data + 8) is False
        got = _run(pipeline.rewrite, path, strokes, plan, prof, opts, tmp_path / "off.gcode")
    finally:
        assert CORE.set_types(np.ndarray, np.dtype(np.float64), array.array, probe, probe.ctypes.data) is True
    assert got == want
    ref = _run(ref_rewrite, path, strokes, plan, prof, opts, tmp_path / "ref.gcode")
    assert got == ref
