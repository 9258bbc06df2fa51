"""Round 42 (rep56): the report's coverage section made on the line table's chunks as arrays
(report.data._line_shares), not a loop over Python floats with a set of every fenced line
(gyroid plate `--report`: ~18 MB of heap).  Checked against that loop, kept here verbatim from
bf05c3e (ref_coverage), bit for bit, on real samples and their processed files, with the
table's chunks made small (many chunks, groups that start in a later chunk), with fences that
overlap, reach past the file and are empty, and on a file of no moving line."""
import os
import subprocess
import sys

import numpy as np
import pytest

from gcode_opt import state as st
from gcode_opt.profile import load_profile
from gcode_opt.report import data as rd
from gcode_opt.report import trace as tm
from gcode_opt.report.fences import parse_fences
from gcode_opt.report.trace import trace_file

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLES = ["prusa_mk3s_rectilinear.gcode", "prusa_gyroid_arcs.gcode", "cura_box.gcode",
           "edge/tool_changes.gcode"]
PROFILE = "prusa-mk3s"


def ref_coverage(tr0, tr1, fences, summary):
    """report.data._coverage as of bf05c3e, verbatim but for its loop, which is ref_shares."""
    total_a2, total_t = tr0.res.int_a2, tr0.res.time_t
    (a2_in, t_in), rest = ref_shares(tr0, fences)
    selected = set(((summary or {}).get("options") or {}).get("features") or ())
    left = [{"feature": f, "moves": n, "selected": (f in selected) if selected else None,
             "int_a2_share": rd.ratio_share(a2, total_a2), "time_share": rd.ratio_share(t, total_t)}
            for f, (n, a2, t) in rest.items()]
    left.sort(key=lambda g: -(g["int_a2_share"] or 0.0))
    cov = (summary or {}).get("coverage") or {}
    return {
        "whole_file": {"int_a2_change": rd.ratio(tr1.res.int_a2, total_a2),
                       "time_change": rd.ratio(tr1.res.time_t, total_t)},
        "retimed": {"strokes": len(fences), "int_a2_share": rd.ratio_share(a2_in, total_a2),
                    "time_share": rd.ratio_share(t_in, total_t)},
        "left_by_feature": left,
        "left_by_reason": cov.get("left"),
        "features": (summary or {}).get("features"),
    }


def _bits(x):
    """A JSON-like value with every float as its bytes (0.0 and -0.0, NaNs told apart)."""
    if isinstance(x, float):
        return ("f", np.float64(x).tobytes())
    if isinstance(x, dict):
        return {k: _bits(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_bits(v) for v in x]
    return x


class _F:
    """A fence's span only (what the coverage reads)."""
    def __init__(self, first, last):
        self.orig_first, self.orig_last = first, last


@pytest.fixture(scope="module")
def traces(tmp_path_factory):
    d = tmp_path_factory.mktemp("cov56")
    prof = load_profile(PROFILE)
    out = {}
    for name in SAMPLES:
        src = os.path.join(ROOT, "sample_gcode", name)
        dst = str(d / (name.replace("/", "_") + ".out.gcode"))
        subprocess.run([sys.executable, "-m", "gcode_opt", "process", src, "-o", dst, "-q", "--profile", PROFILE],
                       env=dict(os.environ, PYTHONPATH=ROOT), cwd=str(d), check=True, capture_output=True)
        fences, _n = parse_fences(dst)
        out[name] = (trace_file(src, prof), trace_file(dst, prof, processed=True), fences)
    return out


SUMMARY = {"options": {"features": ["infill", "solid infill"]}, "coverage": {"left": {"x": 1}},
           "features": {"infill": 1}}


@pytest.mark.parametrize("name", SAMPLES)
@pytest.mark.parametrize("chunk", [tm._Rows.CHUNK, 3])
def test_coverage_as_the_loop(name, chunk, traces, monkeypatch):
    tr0, tr1, fences = traces[name]
    assert fences, "the sample should have re-timed strokes"
    if chunk != tm._Rows.CHUNK:       # the original's tables made again in small chunks
        monkeypatch.setattr(tm._Rows, "CHUNK", chunk)
        tr0 = trace_file(os.path.join(ROOT, "sample_gcode", name), load_profile(PROFILE))
        assert len(tr0.lines._chunks) > 3 or len(tr0.lines) < 12
    for summary in (None, SUMMARY):
        assert _bits(rd._coverage(tr0, tr1, fences, summary)) == _bits(ref_coverage(tr0, tr1, fences, summary))


def test_coverage_odd_fences(traces):
    tr0, tr1, _fences = traces["prusa_mk3s_rectilinear.gcode"]
    n = tr0.n_lines
    for fences in ([], [_F(100, 400), _F(300, 900)], [_F(n - 5, n + 50)], [_F(0, n - 1)],
                   [_F(50, 49), _F(7, 7)]):
        assert _bits(rd._coverage(tr0, tr1, fences, None)) == _bits(ref_coverage(tr0, tr1, fences, None))


def test_coverage_of_no_move(tmp_path):
    src = tmp_path / "none.gcode"
    src.write_text("; nothing moves\nM104 S200\nG4 P10\n")
    tr = trace_file(str(src), load_profile(PROFILE))
    assert _bits(rd._coverage(tr, tr, [_F(0, 1)], None)) == _bits(ref_coverage(tr, tr, [_F(0, 1)], None))


def ref_shares(tr0, fences):
    """_coverage's loop as of bf05c3e, verbatim: ((a2_in, t_in), rest), rest's groups in its order."""
    inside = set()
    for f in fences:
        inside.update(range(f.orig_first, f.orig_last + 1))
    a2_in = t_in = 0.0
    rest = {}
    ln = tr0.lines
    for idx, a2, a2_j, t in zip(ln.idx, ln.column("int_a2"), ln.column("int_a2_j"), ln.column("time_t")):
        a2 = a2 + a2_j
        if idx in inside:
            a2_in += a2
            t_in += t
            continue
        g = rest.setdefault(tr0.moves.group_of(idx), [0, 0.0, 0.0])
        g[0] += 1
        g[1] += a2
        g[2] += t
    return (a2_in, t_in), rest


@pytest.mark.parametrize("name", SAMPLES)
def test_groups_in_the_loops_order(name, traces, monkeypatch):
    """The groups' order (which left_by_feature's sort keeps among equal shares) is the loop's,
    also when a group first shows in a later chunk."""
    monkeypatch.setattr(tm._Rows, "CHUNK", 3)
    tr0 = trace_file(os.path.join(ROOT, "sample_gcode", name), load_profile(PROFILE))
    fences = traces[name][2]
    got, want = rd._line_shares(tr0.lines, tr0.moves, fences), ref_shares(tr0, fences)
    assert _bits(got[0]) == _bits(want[0])
    assert [(k, _bits(v)) for k, v in got[1].items()] == [(k, _bits(v)) for k, v in want[1].items()]
    assert len(want[1]) >= 2


@pytest.mark.parametrize("name", ["prusa_gyroid_arcs.gcode", "edge/arcs.gcode"])
def test_move_rows_as_the_views(name, monkeypatch):
    """MoveTable.length_at / xyz_at / rows_of (StrokeHeads' lengths and the stroke rows'
    masses read them) give what the MoveViews gave, arcs included, across chunks."""
    monkeypatch.setattr(tm._Rows, "CHUNK", 5)
    mv = trace_file(os.path.join(ROOT, "sample_gcode", name), load_profile(PROFILE)).moves
    assert any(mv._view(k).kind == st.ARC for k in range(len(mv.idx)))
    for k in range(len(mv.idx)):
        v = mv._view(k)
        assert _bits(mv.length_at(k)) == _bits(v.length_d)
        assert [_bits(x) for x in mv.xyz_at(k)] == [_bits(getattr(v, f)) for f in ("x0", "y0", "z0", "x1", "y1", "z1")]
    idx = list(mv.idx)
    for a, b in ((0, 0), (idx[1], idx[len(idx) // 2]), (idx[-1] + 1, idx[-1] + 9), (-5, idx[-1] + 5)):
        assert [idx[k] for k in mv.rows_of(a, b)] == [i for i in range(a, b + 1) if i in mv]
