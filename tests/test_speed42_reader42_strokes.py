"""The strokes run_lines makes itself (issue 8, session 42; firmware/_core.c run_stroke and
run_parts): a double or int field computed in C (x0, y0, the part's directions, length_d,
e_per_mm, _ss_e, first_idx, last_idx ...) is written straight into the StrokeBase's field
(stroke_new's deferred values), with no float or int object made for it and read back.
Every field must be what the objects gave.  The references: the pure-Python Stroke class
(its fields plain slots: run_lines then makes every field's object, as before), swapped in
as test_mem27_stroke_fields does; and, for the runs run_parts closes, group_lines' own
Python (no RecordLog: no run_lines) with that class.  On files whose runs run_lines closes
in C (one move, curves, straight runs of several moves: run_parts), with and without
curves."""
from __future__ import annotations

import math
import os
import sys

import pytest

from gcode_opt import chains, pipeline, stroke_columns, strokes
from gcode_opt.profile import load_profile

from test_mem27_stroke_fields import BASE, _fields, _python_stroke

pytestmark = pytest.mark.skipif(BASE is None, reason="the compiled core is not built (or pure Python is asked)")

SAMPLES = "sample_gcode/"
_CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus/")


def _analyse(path, prof, curves):
    """curves off: no curve strokes, and no run dropped as short (min_length_d 0)"""
    opts = pipeline.Options()
    if not curves:
        opts.max_turn_deg = 0.0
        opts.min_length_d = 0.0
    return pipeline.analyse(path, load_profile(prof), opts)[0]


def _python_class(monkeypatch):
    cls = _python_stroke()
    for mod in (strokes, pipeline, chains, stroke_columns):
        monkeypatch.setattr(mod, "Stroke", cls)
    monkeypatch.setattr(strokes, "_new", object.__new__)
    return cls


def _arrays(st):
    return [a for a in (st._ends, st.pts.xy if st.pts is not None else None) if a is not None]


def _all(st):
    return (_fields(st), st.prev_u, st.next_u, st.start_state, st.n_moves, st.ends_d.tobytes(),
            [type(a) for a in _arrays(st)])


def _room_at_most(a, b):
    """a's arrays take no more room than b's (run_lines' array_room: exactly their items)"""
    return all(sys.getsizeof(x) <= sys.getsizeof(y) for x, y in zip(_arrays(a), _arrays(b)))


@pytest.mark.parametrize("curves", [True, False])
@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "prusa-mk3s"),
                                       ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"),
                                       ("prusa_klipper.gcode", "voron24"), ("cura_box.gcode", "ender3"),
                                       ("prusa_benchy_like.gcode", "prusa-mk3s"), ("cura_gyroid.gcode", "ender3")])
def test_run_lines_strokes_as_the_python_class(monkeypatch, name, prof, curves):
    path = (_CORPUS if name.startswith("cura_gyroid") else SAMPLES) + name
    if not os.path.exists(path):
        pytest.skip("corpus not built")
    got = _analyse(path, prof, curves)
    cls = _python_class(monkeypatch)
    ref = _analyse(path, prof, curves)
    assert all(isinstance(s, BASE) for s in got) and all(type(s) is cls for s in ref)
    assert len(got) == len(ref) > 50
    for a, b in zip(got, ref):
        assert _all(a) == _all(b), a.first_idx
        assert _room_at_most(a, b), a.first_idx


def _drift_file(path):
    """Runs of many moves, each vertex collinear (|sin| of the turn below COLLINEAR_SIN) but
    drifting off the run's first direction, each run closed by a sharp turn at the same feed
    (run_lines' pre path): straight runs that close into several parts in C (run_parts'
    strokes after the first: their first move, directions and E made there)."""
    with open(SAMPLES + "prusa_mk3s_rectilinear.gcode") as f:
        head = f.readlines()[:63]
    out = head + [";TYPE:Solid infill\n", "G1 X60 Y60 F9000\n", "G1 F1800\n"]
    x, y, a = 60.0, 60.0, 0.0
    for k, turn in enumerate([0.0006, 0.0003, -0.0006, 0.00045, -0.0002, 0.0005, 0.0006, -0.0003]):
        for j in range(30 + 10 * k):
            a += turn
            step = 0.7 + 0.1 * (j % 3)
            x += step * math.cos(a)
            y += step * math.sin(a)
            out.append(f"G1 X{x:.5f} Y{y:.5f} E{0.02 + 0.001 * (j % 5):.5f}\n")
        a += math.pi * (0.8 + 0.02 * k)          # a sharp turn: the next run
    out += ["M107\n"]
    path.write_text("".join(out))


@pytest.mark.parametrize("curves", [True, False])
@pytest.mark.parametrize("name", ["drift", "prusa_gyroid.gcode", "prusa_mk3s_rectilinear.gcode"])
def test_run_lines_strokes_as_group_lines_python(tmp_path, monkeypatch, name, curves):
    """against group_lines' own Python (no RecordLog: no run_lines) and the Python class"""
    path = tmp_path / "drift.gcode"
    if name == "drift":
        _drift_file(path)
    else:
        path = SAMPLES + name
    got = _analyse(str(path), "prusa-mk3s", curves)
    cls = _python_class(monkeypatch)
    monkeypatch.setattr(pipeline, "_record_log", lambda: None)
    ref = _analyse(str(path), "prusa-mk3s", curves)
    assert all(isinstance(s, BASE) for s in got) and all(type(s) is cls for s in ref)
    assert len(got) == len(ref) > 20
    if name == "drift":                 # parts after a run's first: made in C
        assert sum(a.prev_u is not None and a.first_idx > 0 for a in got) > 20
    if name == "prusa_gyroid.gcode" and curves:
        assert sum(a.kind == "curve" for a in got) > 50
    for a, b in zip(got, ref):
        assert _all(a) == _all(b), a.first_idx
        assert _room_at_most(a, b), a.first_idx
