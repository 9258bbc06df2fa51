"""summary.StrokeRows reads the strokes' own fields (line, lines, kind, feature, layer, the
four rounded fields) from their StrokeColumns a BLOCK of rows at a time as its rows are
made, instead of copying 9 columns of every row when it is built (issue 8, memory, s54
tail54: ~3 MB at the rectilinear plate's summary peak, windowed).  Checked against the
rows of the code they replaced (test_speed51_json51_rows' verbatim reference): the same
rows bit for bit and the same JSON text, at block and chunk sizes that cut inside and
across each other, on odd columns and on a real run's; and the table built holds no copy
of a row column."""
import os
import tracemalloc

import numpy as np
import pytest

from gcode_opt import pipeline
from gcode_opt import summary as sm
from gcode_opt.profile import load_profile

from test_speed51_json51_rows import _bits, _odd_case, _ref_list, _text, ref_dump_json

SAMPLES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "sample_gcode")
SIZES = [(128, 2048), (64, 100), (7, 3), (1, 5), (300, 1), (128, 512)]      # (CHUNK, BLOCK)


def _same_rows(table, cols, idx, row_cols):
    want = _ref_list(cols, idx, row_cols)
    assert _bits(list(table)) == _bits(want)
    assert _text({"a": 1, "per_stroke": table}, sm.dump_json) == _text({"a": 1, "per_stroke": want}, ref_dump_json)
    for j in sorted({0, len(want) // 2, len(want) - 1}):
        assert _bits(table[j]) == _bits(want[j])
    assert _bits(table[-3:]) == _bits(want[-3:])


@pytest.mark.parametrize("chunk,block", SIZES)
@pytest.mark.parametrize("n,seed,ints", [(300, 2, True), (2100, 3, False)])
def test_rows_read_by_blocks_are_the_old_rows(n, seed, ints, chunk, block, monkeypatch):
    cols, idx, row_cols = _odd_case(n, seed, ints)
    monkeypatch.setattr(sm.StrokeRows, "CHUNK", chunk)
    monkeypatch.setattr(sm.StrokeRows, "BLOCK", block)
    _same_rows(sm.StrokeRows(cols, idx, *row_cols), cols, idx, row_cols)


def test_a_real_runs_rows_by_blocks(tmp_path, monkeypatch):
    seen = []
    real = sm._summary_rows

    def spy(wanted, cols, idx, row_cols):
        seen.append((cols, idx, row_cols))
        return real(wanted, cols, idx, row_cols)
    monkeypatch.setattr(sm, "_summary_rows", spy)
    opts = pipeline.Options()
    opts.summary_rows = "table"
    pipeline.process(os.path.join(SAMPLES, "prusa_gyroid.gcode"), str(tmp_path / "o.gcode"),
                     load_profile("prusa-mk3s"), opts)
    (cols, idx, row_cols), = seen
    assert len(idx) > 500
    for chunk, block in SIZES:
        monkeypatch.setattr(sm.StrokeRows, "CHUNK", chunk)
        monkeypatch.setattr(sm.StrokeRows, "BLOCK", block)
        _same_rows(sm.StrokeRows(cols, idx, *row_cols), cols, idx, row_cols)


def test_the_table_holds_no_copy_of_a_row_column():
    cols, idx, row_cols = _odd_case(4000, 7)
    m = len(idx)
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        table = sm.StrokeRows(cols, idx, *row_cols)
        held = tracemalloc.get_traced_memory()[0] - before
    finally:
        tracemalloc.stop()
    assert len(table) == m
    # (the 9 columns of the rows copied, as before: ~9 x 8 bytes a row)
    assert held < 2 * np.dtype(np.float64).itemsize * m
