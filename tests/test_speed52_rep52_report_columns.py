"""Round 38 (rep52): `--report` in less memory, same bytes.
(1) the processed file's line figures kept only as the fences' sums and maxima (SpanFigures)
    against the whole LineTable's line_sum / line_max;
(2) the per-stroke rows as columns (StrokeTable): the rows made again equal the appended ones,
    value, type and key order, and json writes them as it wrote the list;
(3) the ringing rows read in place (RowTable(padded=True)) against the copy with the idle rows
    added, and the block columns against the old all-at-once copy;
(4) the HTML and JSON the code of 872f8f0 (git archive) writes for `report` and for
    `process --report`, byte for byte."""
import io
import json
import math
import os
import shutil
import subprocess
import sys
from array import array

import numpy as np
import pytest
from base_tree import command as base_tree_command
from base_tree import unpack as base_tree_unpack

from gcode_opt import ringing as rg
from gcode_opt.profile import load_profile
from gcode_opt.report import trace as tm
from gcode_opt.report.fences import parse_fences
from gcode_opt.report.html import write_json
from gcode_opt.report.stroke_table import StrokeTable
from gcode_opt.report.trace import BLOCK_FIELDS, SPAN_MAXES, SPAN_SUMS, disjoint_spans, trace_file

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLES = ["prusa_mk3s_rectilinear.gcode", "prusa_gyroid_arcs.gcode", "edge/arcs.gcode",
           "edge/tool_changes.gcode"]
BASE = "872f8f0"
PROFILE = "prusa-mk3s"


def _bits(x):
    return (type(x), np.float64(x).tobytes())


@pytest.fixture(scope="module")
def processed(tmp_path_factory):
    """Each sample and its processed file (this tree's process; its G-code is not ours to change)."""
    d = tmp_path_factory.mktemp("proc")
    out = {}
    for name in SAMPLES:
        src = os.path.join(ROOT, "sample_gcode", name)
        dst = str(d / (name.replace("/", "_") + ".out.gcode"))
        subprocess.run([sys.executable, "-m", "gcode_opt", "process", src, "-o", dst, "-q", "--profile", PROFILE],
                       env=dict(os.environ, PYTHONPATH=ROOT), cwd=str(d), check=True, capture_output=True)
        out[name] = (src, dst)
    return out


# ----------------------------------------------------------------- (1) span figures
@pytest.mark.parametrize("name", SAMPLES)
def test_span_figures_as_the_line_table(name, processed):
    _src, dst = processed[name]
    prof = load_profile(PROFILE)
    fences, _n = parse_fences(dst)
    spans = [(f.out_first, f.out_last) for f in fences]
    assert spans and disjoint_spans(spans)
    full = trace_file(dst, prof, processed=True)
    lean = trace_file(dst, prof, processed=True, spans=spans)
    assert isinstance(lean.lines, tm.SpanFigures)
    for a, b in spans:
        for k in SPAN_SUMS:
            assert _bits(lean.line_sum(a, b, k)) == _bits(full.line_sum(a, b, k)), (a, b, k)
        for k in SPAN_MAXES:
            assert _bits(lean.line_max(a, b, k)) == _bits(full.line_max(a, b, k)), (a, b, k)
    with pytest.raises(KeyError):                       # a span not kept is not answered
        lean.line_sum(spans[0][0], spans[0][1] + 1, "time_t")


def test_span_figures_rules():
    assert disjoint_spans([(0, 3), (4, 4), (9, 12)]) and disjoint_spans([])
    assert not disjoint_spans([(0, 3), (3, 5)]) and not disjoint_spans([(5, 4)]) \
        and not disjoint_spans([(4, 6), (0, 2)])

    class R:
        def __init__(self, idx, v):
            self.idx = idx
            self.time_t = self.int_a2 = self.int_a2_j = self.int_v2 = v
            self.peak_v = self.peak_a = v

    sf = tm.SpanFigures([(2, 4), (6, 6), (8, 9)])
    for i, v in ((0, 5.0), (2, -1.0), (3, -3.0), (4, float("nan")), (5, 7.0), (9, 0.1), (9, 0.2)):
        sf.add(R(i, v))
    ref = {(2, 4): [-1.0, -3.0, float("nan")], (6, 6): [], (8, 9): [0.1, 0.2]}
    for (a, b), vals in ref.items():
        want_sum, got_sum = float(sum(vals)), sf.span_sum(a, b, "time_t")
        assert (want_sum == got_sum) or (math.isnan(want_sum) and math.isnan(got_sum))
        assert sf.span_max(a, b, "peak_v") == (float(max(vals)) if vals else 0.0)     # max() keeps -1.0 past nan


# ----------------------------------------------------------------- (2) stroke table
def _same_row(a, b):
    assert list(a) == list(b)
    for k in a:
        if isinstance(a[k], dict):
            _same_row(a[k], b[k])
        else:
            assert type(a[k]) is type(b[k]) and (a[k] == b[k] or (a[k] != a[k] and b[k] != b[k])), (k, a[k], b[k])


def test_stroke_table_gives_the_rows_back():
    rows = [
        {"line": 3, "kind": "line", "length_mm": 0, "beta_s2": None, "time_s": {"before": 1.5, "after": 1.25},
         "overshoot": None, "flag": True},
        {"line": 9, "kind": "arc", "length_mm": 2.5, "beta_s2": 1e-3, "time_s": {"before": 0.5, "after": 0.75,
                                                                                  "law": 0.7},
         "overshoot": 0.01, "flag": False},
        {"line": 12, "kind": "curve", "length_mm": float("nan"), "beta_s2": np.float64(2.0),
         "time_s": {"before": -0.0, "after": float("inf")}, "overshoot": 1, "flag": True},
        {"line": 13, "extra": "x", "kind": "line", "length_mm": 1.0, "beta_s2": 3.0,
         "time_s": {"before": 1.0, "after": 2.0}, "overshoot": 0.5, "flag": True},
    ]
    t = StrokeTable()
    for r in rows:
        t.append(r)
    assert len(t) == 4
    for a, b in zip(t, rows):
        _same_row(a, b)
    _same_row(t[-1], rows[-1])
    assert t.col("kind") == ["line", "arc", "curve", "line"]
    assert [type(v) for v in t.col("length_mm")] == [int, float, float, float]
    assert t.col("time_s", "after")[1] == 0.75 and not t.has("time_s", "law")
    assert t.col("line") == [3, 9, 12, 13] and [type(v) for v in t.col("line")] == [int] * 4


@pytest.mark.parametrize("name", SAMPLES[:2])
def test_report_rows_json_as_the_list(name, processed, tmp_path):
    from gcode_opt.report.data import build_report
    src, dst = processed[name]
    data, _ctx = build_report(src, dst, load_profile(PROFILE), ringing=False)
    table = data["per_stroke"]
    assert isinstance(table, StrokeTable) and len(table) > 0
    as_list = {**data, "per_stroke": list(table)}
    a, b = tmp_path / "t.json", tmp_path / "l.json"
    write_json(data, str(a))
    write_json(as_list, str(b))
    assert a.read_bytes() == b.read_bytes()
    buf = io.StringIO()
    json.dump(as_list, buf, indent=1, allow_nan=False)
    assert a.read_text() == buf.getvalue()


# ----------------------------------------------------------------- (3) ringing rows, block columns
def test_ringing_rows_in_place(processed):
    src, _dst = processed[SAMPLES[0]]
    prof = load_profile(PROFILE)
    model = rg.model_of(prof)
    tr = trace_file(src, prof, ringing=True)
    items = tr.ring_rows
    assert list(items[:rg.ROW]) == list(rg.IDLE) and list(items[-rg.ROW:]) == list(rg.IDLE)
    inner = array("d", items[rg.ROW:len(items) - rg.ROW])
    old, new = rg.RowTable(inner, model), rg.RowTable(items, model, padded=True)
    assert np.array_equal(old.m, new.m) and np.shares_memory(new.m, np.frombuffer(items))
    assert np.array_equal(old.t, new.t) and np.array_equal(old.s, new.s)
    assert rg.busiest_stretch_rows(old, 20.0) == rg.busiest_stretch_rows(new, 20.0)


def test_block_arrays_as_the_copy():
    rnd = np.random.default_rng(52)
    for n in (0, 1, 1000):
        cols = {k: array("d", rnd.random(n) * 100) for k in BLOCK_FIELDS}
        cols["idx"] = array("d", np.arange(n, dtype=float))
        old = {k: np.frombuffer(v, dtype=float).copy() if len(v) else np.zeros(0) for k, v in cols.items()}
        old["idx"] = old["idx"].astype(int)
        new = tm._block_arrays(cols)
        assert not cols and list(new) == list(BLOCK_FIELDS)
        for k in BLOCK_FIELDS:
            assert new[k].dtype == old[k].dtype and np.array_equal(new[k], old[k])
            assert new[k].flags.owndata and new[k].flags.writeable


# ----------------------------------------------------------------- (4) bytes against 872f8f0
@pytest.fixture(scope="module")
def base_tree(tmp_path_factory):
    """The Python code of BASE with this tree's compiled cores and their C sources (base_tree.unpack)."""
    d = tmp_path_factory.mktemp("base")
    if not base_tree_unpack(BASE, d):
        pytest.skip(f"commit {BASE} not available")
    return str(d)


def _run(tree, args, cwd):
    subprocess.run([sys.executable] + base_tree_command(tree) + args, env=dict(os.environ, PYTHONPATH=tree), cwd=cwd,
                   check=True, capture_output=True)


@pytest.mark.parametrize("name", SAMPLES + ["edge/checksums.gcode"])      # (the last: no stroke re-timed)
def test_report_bytes_as_base(name, base_tree, tmp_path):
    src = os.path.join(ROOT, "sample_gcode", name)
    shutil.copy(src, tmp_path / "in.gcode")
    _run(ROOT, ["process", "in.gcode", "-o", "out.gcode", "-q", "--profile", PROFILE], str(tmp_path))
    outs = []
    for side, tree in (("base", base_tree), ("new", ROOT)):
        d = tmp_path / side
        d.mkdir()
        _run(tree, ["report", "../in.gcode", "../out.gcode", "--profile", PROFILE, "-o", "r.html", "--json", "r.json"],
             str(d))
        _run(tree, ["process", "../in.gcode", "-o", "../p.gcode", "-q", "--profile", PROFILE, "--report", "p.html"],
             str(d))
        outs.append([(d / f).read_bytes() for f in ("r.json", "r.html", "p.html")])
    assert outs[0][0] == outs[1][0]          # report's JSON
    assert outs[0][1] == outs[1][1]          # report's HTML (pictures embedded)
    assert outs[0][2] == outs[1][2]          # process --report's HTML (figures from the summary)


def test_stroke_table_compares_and_shows_as_its_rows():
    rows = [{"line": 1, "t": {"before": 1.0, "after": None}}, {"line": 2, "t": {"before": 0, "after": 2.0}}]
    t = StrokeTable()
    for r in rows:
        t.append(r)
    assert t == rows and rows == t and repr(t) == repr(rows)
    u = StrokeTable()
    u.append(rows[0])
    assert t != u and t != rows[:1] and t != "x"
