"""segments.line_classes of a sequence that is not a list (issue 8, runs52: the budget runs
over a StoredStrokes give it the line rows as stored_strokes.StrokeRows) reads the fields
a chunk at a time and keeps only the distinct rows (segments._classes_by_chunks), not the
(17, m) table of every line's fields.  Its classes must be, number for number, the ones
line_classes gives the same strokes as a list (its whole-table reading, itself checked
against e9d4ed5's verbatim reference in test_speed32_line_fields.py): on real lines, with
chunks of 1, a few and many strokes; on lines with fields of other types (where it declines
to line_classes' own reading, the same classes or the same exception); and on rows that
differ only by signs (a hash that sums products of the fields' bits alone gave two sign
changes one hash)."""
import copy
import os
from types import SimpleNamespace

import numpy as np
import pytest

from gcode_opt import segments as sg
from gcode_opt.stored_strokes import StoredStrokes, StrokeRows
from gcode_opt.stroke_store import StrokeStore

import test_speed32_line_fields as t32
from test_speed32_line_fields import _lines, needs_core

S = "sample_gcode/"
PLATE = os.path.expanduser("~/.cache/gcode-opt-corpus/plate_rectilinear.gcode")


def _by_chunks(sts, rows=None):
    return sg.line_classes(StrokeRows(sts, np.arange(len(sts)) if rows is None else rows))


@needs_core
@pytest.mark.parametrize("name,profile,corners", [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", True),
                                                  ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", False),
                                                  ("prusa_gyroid.gcode", "voron24", True),
                                                  ("cura_box.gcode", "ender3", False)])
@pytest.mark.parametrize("chunk", [1, 7, 64, 4096])
def test_chunks_are_the_lists(name, profile, corners, chunk, monkeypatch):
    monkeypatch.setattr(sg, "FIELD_ROWS", chunk)
    sts = _lines(S + name, profile, corners)
    ref = sg.line_classes(sts)
    assert sg._classes_by_chunks(StrokeRows(sts, np.arange(len(sts)))) is not None     # (not declined)
    assert _by_chunks(sts).tolist() == ref.tolist()
    assert np.unique(ref).size < len(sts)


@needs_core
@pytest.mark.skipif(not os.path.exists(PLATE), reason="corpus not downloaded")
def test_chunks_are_the_lists_plate():
    sts = _lines(PLATE, "prusa-mk3s", False)
    assert _by_chunks(sts).tolist() == sg.line_classes(sts).tolist()


@needs_core
def test_stored_rows_are_the_lists():
    """The line rows of a StoredStrokes (the windowed runs' reading): the list's classes."""
    sts = _lines(S + "prusa_mk3s_rectilinear.gcode", "prusa-mk3s", False)
    with StrokeStore() as store:
        store.append(sts)
        rows = np.arange(0, len(sts), 3)
        got = sg.line_classes(StrokeRows(StoredStrokes(store, 100), rows))
    assert got.tolist() == sg.line_classes([sts[i] for i in rows.tolist()]).tolist()


@needs_core
@pytest.mark.parametrize("seed", range(8))
def test_odd_fields_are_the_lists(seed, monkeypatch):
    """Copies of real lines with fields of other types (or deleted), as test_speed32's: the
    same classes, or the same exception, as line_classes of the list (its test run with the
    chunks' reading in place of line_classes, the list's in place of its reference)."""
    monkeypatch.setattr(t32, "ref_line_classes", sg.line_classes)
    monkeypatch.setattr(t32, "sg", SimpleNamespace(line_classes=_by_chunks))
    t32.test_line_classes_odd_fields_are_the_reference(seed)


@needs_core
@pytest.mark.parametrize("fields", [("uy", "_puy"), ("ux", "_nux"), ("ux", "uy", "_pux", "_puy")])
def test_signs_told_apart(fields, monkeypatch):
    """Lines and their copies with the signs of two or four fields changed (mirrored moves):
    apart, as line_classes of the list has them, and not declined."""
    monkeypatch.setattr(sg, "FIELD_ROWS", 64)
    base = _lines(S + "prusa_mk3s_rectilinear.gcode", "prusa-mk3s", False)[:200]
    sts = [copy.copy(s) for s in base] + [copy.copy(s) for s in base]
    for st in sts[200:]:
        for f in fields:
            v = getattr(st, f)
            setattr(st, f, v if v is None else -v)
    ref = sg.line_classes(sts)
    assert sg._classes_by_chunks(StrokeRows(sts, np.arange(len(sts)))) is not None
    assert _by_chunks(sts).tolist() == ref.tolist()
    assert not set(ref[:200].tolist()) & set(ref[200:].tolist())
