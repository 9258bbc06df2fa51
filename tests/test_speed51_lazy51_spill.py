"""analyse spilling its finished strokes to a StrokeStore window by window (pipeline.analyse's
store, GCODE_OPT_SPILL_ANALYSE: issue 8, lazy51) must give the strokes the list path gives,
every field bit for bit, with windows from one record (a flush every chunk of ~20 lines) to
the default; and the whole command the same bytes with the switch on (compiled and pure)."""
import os
import struct
import subprocess
import sys
from array import array

import pytest

from gcode_opt import features as feat
from gcode_opt import pipeline as pl
from gcode_opt import strokes as stm
from gcode_opt.firmware import simulate as fwsim
from gcode_opt.profile import load_profile
from gcode_opt.state import Arc
from gcode_opt.stroke_store import ARC_NAMES, StrokeStore

SAMPLES = "sample_gcode/"
_UNSET = object()


def _value(v):
    """a field's value as comparable bits (floats by their bytes; arrays, points, arcs by content)"""
    t = type(v)
    if t is float:
        return ("f", struct.pack("<d", v))
    if t is array:
        return ("a", v.typecode, v.tobytes())
    if t is stm.Points:
        return ("p", v.xy.tobytes())
    if t is Arc:
        return ("arc",) + tuple(_value(getattr(v, k)) for k in ARC_NAMES)
    if t in (str, int, bool) or v is None or v is _UNSET:
        return (t.__name__, v)
    return ("obj", type(v).__name__) + tuple(_value(getattr(v, k)) for k in v.__slots__)    # (Limits)


def _sharing(sts, name):
    """for each stroke, the first stroke holding the same object in field name (shared Limits
    and features stay shared)"""
    first = {}
    return [first.setdefault(id(getattr(st, name)), k) for k, st in enumerate(sts)]


def _fields(st):
    return tuple((n, _value(getattr(st, n, _UNSET))) for n in stm.FIELDS)


def _analyse(path, prof, store, **kw):
    o = pl.Options(**kw)
    got, res = pl.analyse(path, load_profile(prof), o, store)
    return got, res, o


def _spills(monkeypatch):
    """how many strokes each spill moved to the store"""
    seen = []
    saved = pl._spill_finished

    def spill(store, strokes, sums):
        n = len(store)
        saved(store, strokes, sums)
        seen.append(len(store) - n)
    monkeypatch.setattr(pl, "_spill_finished", spill)
    return seen


@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24"),
                                       ("cura_box.gcode", "ender3"), ("prusa_gyroid_arcs.gcode", "voron24"),
                                       ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"),
                                       ("edge/no_feature_comments.gcode", "prusa-mk3s")])
@pytest.mark.parametrize("flush_rows,chunk", [(1, 700), (37, 3000), (None, None)])
@pytest.mark.parametrize("kw", [{}, dict(features=feat.ALL, min_length_d=0.0)])
def test_spilled_strokes_are_the_list_path(name, prof, flush_rows, chunk, kw, monkeypatch):
    ref, r0, o0 = _analyse(SAMPLES + name, prof, None, **kw)
    if chunk is not None:       # small chunks: a flush (a window spilled) every ~20-90 lines
        monkeypatch.setattr(fwsim, "CHUNK_HINT", chunk)
    if flush_rows is not None:
        monkeypatch.setattr(pl, "LOG_FLUSH_ROWS", flush_rows)
    seen = _spills(monkeypatch)
    with StrokeStore() as store:
        got, r1, o1 = _analyse(SAMPLES + name, prof, store, **kw)
        assert got is store
        back = store.load(0, len(store))
    assert len(back) == len(ref)
    for k, (a, b) in enumerate(zip(back, ref)):
        assert _fields(a) == _fields(b), k
    for name in ("lim", "feature"):
        assert _sharing(back, name) == _sharing(ref, name)
    assert list(o1.by_feature.items()) == list(o0.by_feature.items())
    assert (r1.time_t, r1.int_a2, r1.int_v2, r1.n_moves) == (r0.time_t, r0.int_a2, r0.int_v2, r0.n_moves)
    if chunk is not None and len(ref) > 50 and fwsim.CORE == "c" and hasattr(fwsim._core, "RecordLog"):
        # windows were spilled during the pass, not all at its end
        assert sum(seen) > 0 and sum(1 for n in seen if n) >= 2


def _run(inp, out, env_extra):
    env = dict(os.environ, PYTHONPATH=os.getcwd(), **env_extra)
    subprocess.run([sys.executable, "-m", "gcode_opt", "process", inp, "-o", str(out), "-q"], env=env,
                   check=True, capture_output=True)
    return out.read_bytes()


@pytest.mark.parametrize("name", ["prusa_gyroid.gcode", "prusa_mk3s_rectilinear.gcode"])
def test_process_same_bytes_with_the_switch(name, tmp_path):
    plain = _run(SAMPLES + name, tmp_path / "a.gcode", {"GCODE_OPT_SPILL_ANALYSE": "0"})
    assert _run(SAMPLES + name, tmp_path / "b.gcode", {"GCODE_OPT_SPILL_ANALYSE": "1"}) == plain
    pure = _run(SAMPLES + name, tmp_path / "c.gcode", {"GCODE_OPT_SPILL_ANALYSE": "1", "GCODE_OPT_PURE_PYTHON": "1"})
    assert pure == plain
