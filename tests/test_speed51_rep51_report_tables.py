"""Round 37 (rep51): the report's traces hold the LineRecords and Moves as columns by line
(report/trace.py LineTable, MoveTable) instead of dicts of objects.  Checked against
(1) a verbatim copy of the dict-based trace_file on real files: every value, every lookup,
the line sums and maxima; (2) the bytes main's code (c6d899c, unpacked with git archive)
writes for the same report, HTML and JSON."""
import os
import random
import shutil
import subprocess
import sys
from array import array

import numpy as np
import pytest
from base_tree import command as base_tree_command
from base_tree import unpack as base_tree_unpack

from gcode_opt import state as st
from gcode_opt.firmware.simulate import simulate_events
from gcode_opt.profile import load_profile
from gcode_opt.report.trace import (BLOCK_FIELDS, LINE_FIELDS, MOVE_FIELDS, PROCESSED_LINE_FIELDS,
                                    PROCESSED_MOVE_FIELDS, trace_file)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLES = [os.path.join(ROOT, "sample_gcode", p) for p in
           ("prusa_mk3s_rectilinear.gcode", "prusa_gyroid_arcs.gcode", "edge/arcs.gcode",
            "edge/arc_variants.gcode", "edge/tool_changes.gcode", "edge/relative_g91.gcode")]
BASE = "c6d899c"
PROFILE = "prusa-mk3s"


# ----------------------------------------------------------------- verbatim copies (c6d899c)
class _OldTrace:
    def __init__(self, res, lines, moves, blocks, n_lines):
        self.res = res              # SimResult
        self.lines = lines          # idx -> LineRecord
        self.moves = moves          # idx -> state.Move
        self.blocks = blocks        # field -> np.ndarray (BLOCK_FIELDS), in execution order
        self.n_lines = n_lines      # lines in the file

    def line_sum(self, first_idx, last_idx, attr):
        return float(sum(getattr(self.lines[i], attr) for i in range(first_idx, last_idx + 1)
                         if i in self.lines))

    def line_max(self, first_idx, last_idx, attr):
        vals = [getattr(self.lines[i], attr) for i in range(first_idx, last_idx + 1) if i in self.lines]
        return float(max(vals)) if vals else 0.0


def _old_trace_file(path, profile):
    lines = {}
    moves = {}
    cols = {k: array("d") for k in BLOCK_FIELDS}
    cursor = [0.0, 0.0]
    count = [0]

    def feed():
        for idx, raw, ev in st.events(path, profile):
            count[0] = idx + 1
            if ev is not None and type(ev) is st.Move:
                moves[idx] = ev
            yield idx, raw, ev

    def on_line(rec):
        lines[rec.idx] = rec

    def on_block(b):
        if b.first:
            m = moves[b.idx]
            cursor[0], cursor[1] = m.x0, m.y0
        x0, y0 = cursor
        x1, y1 = x0 + b.d * b.ux, y0 + b.d * b.uy
        cursor[0], cursor[1] = x1, y1
        sv, cv, ev = b.start_v, b.cruise_v, b.end_v
        v2 = (b.accel_t * (sv * sv + sv * cv + cv * cv) + b.decel_t * (ev * ev + ev * cv + cv * cv)) / 3.0 \
            + b.cruise_t * cv * cv
        for k, v in zip(BLOCK_FIELDS, (b.idx, x0, y0, x1, y1, b.d, sv, cv, ev, b.accel,
                                       b.accel_t, b.cruise_t, b.decel_t, v2, b.nominal_v)):
            cols[k].append(v)

    res = simulate_events(feed(), profile, on_line=on_line, on_block=on_block)
    blocks = {k: np.frombuffer(v, dtype=float).copy() if len(v) else np.zeros(0) for k, v in cols.items()}
    blocks["idx"] = blocks["idx"].astype(int)
    return _OldTrace(res, lines, moves, blocks, count[0])


# ----------------------------------------------------------------- (1) tables against the dicts
def _same(a, b):
    assert type(a) is type(b) and (a == b or (a != a and b != b)), (a, b)


@pytest.mark.parametrize("chunk", [None, 1, 7])       # rows a table chunk: the tables' own, and tiny (session 55)
@pytest.mark.parametrize("path", SAMPLES, ids=os.path.basename)
def test_tables_hold_what_the_dicts_held(path, chunk, monkeypatch):
    if chunk is not None:
        from gcode_opt.report import trace
        monkeypatch.setattr(trace._Rows, "CHUNK", chunk)
    prof = load_profile(PROFILE)
    old, new = _old_trace_file(path, prof), trace_file(path, prof, ringing=True)
    assert new.n_lines == old.n_lines
    assert list(new.lines.idx) == list(old.lines) and list(new.moves) == list(old.moves)
    for i, rec in old.lines.items():
        assert i in new.lines
        for k in LINE_FIELDS:
            _same(new.lines.value(i, k), getattr(rec, k))
    for i, m in old.moves.items():
        v = new.moves[i]
        assert new.moves.get(i) is not None and i in new.moves
        for k in ("idx", "kind", "feature", "layer") + MOVE_FIELDS:
            _same(getattr(v, k), getattr(m, k))
        assert (v.arc is None) == (m.arc is None)
        if m.arc is not None:               # two parses: equal arcs, not the same object
            for k in ("r", "theta0", "sweep", "length_d"):
                _same(getattr(v.arc, k), getattr(m.arc, k))
        _same(v.length_d, m.length_d)
    assert [m.idx for m in new.moves.values()] == list(old.moves)
    for k in BLOCK_FIELDS:
        assert np.array_equal(new.blocks[k], old.blocks[k]) and new.blocks[k].dtype == old.blocks[k].dtype
    n = old.n_lines
    missing = [i for i in range(-1, n + 2) if i not in old.lines]
    for i in missing:
        assert i not in new.lines and new.lines.value(i, "start_v", 0.0) == 0.0
        with pytest.raises(KeyError):
            new.lines.value(i, "end_v")
    for i in (j for j in range(-1, n + 2) if j not in old.moves):
        assert i not in new.moves and new.moves.get(i) is None
        with pytest.raises(KeyError):
            new.moves[i]
    rnd = random.Random(51)
    spans = [(a, a + rnd.randrange(0, 40)) for a in (rnd.randrange(-2, n + 1) for _ in range(300))]
    for a, b in spans + [(0, n), (n, n + 3)]:
        for k in LINE_FIELDS:
            _same(new.line_sum(a, b, k), old.line_sum(a, b, k))
            _same(new.line_max(a, b, k), old.line_max(a, b, k))
    for k in ("idx", "layer", "kind") + MOVE_FIELDS:
        assert new.moves.np(k).tolist() == [getattr(m, k) for m in old.moves.values()]
    groups = ["other" if i not in old.moves else "travel" if not old.moves[i].e > 0.0 else old.moves[i].feature
              for i in range(-1, n + 2)]
    assert [new.moves.group_of(i) for i in range(-1, n + 2)] == groups
    lean = trace_file(path, prof, processed=True)           # what the report keeps of a processed file
    for k in BLOCK_FIELDS:
        assert np.array_equal(lean.blocks[k], old.blocks[k])
    for a, b in spans:
        for k in PROCESSED_LINE_FIELDS:
            _same(lean.line_sum(a, b, k), old.line_sum(a, b, k))
            _same(lean.line_max(a, b, k), old.line_max(a, b, k))
    for k in ("idx", "layer") + PROCESSED_MOVE_FIELDS:
        assert lean.moves.np(k).tolist() == [getattr(m, k) for m in old.moves.values()]


# ----------------------------------------------------------------- (2) report bytes against main
@pytest.fixture(scope="module")
def base_tree(tmp_path_factory):
    """The Python code of BASE with this tree's compiled cores and their C sources (base_tree.unpack)."""
    d = tmp_path_factory.mktemp("base")
    if not base_tree_unpack(BASE, d):
        pytest.skip(f"commit {BASE} not available")
    return str(d)


def _report(tree, orig, new, out_dir):
    env = dict(os.environ, PYTHONPATH=tree)
    html, js = os.path.join(out_dir, "r.html"), os.path.join(out_dir, "r.json")
    subprocess.run([sys.executable] + base_tree_command(tree) + ["report", orig, new, "--profile", PROFILE,
                    "-o", html, "--json", js], env=env, cwd=out_dir, check=True, capture_output=True)
    with open(html, "rb") as fh, open(js, "rb") as fj:
        return fh.read(), fj.read()


@pytest.mark.parametrize("name", ["prusa_mk3s_rectilinear.gcode", "prusa_gyroid_arcs.gcode", "edge/arcs.gcode"])
def test_report_bytes_as_main(name, base_tree, tmp_path):
    src = os.path.join(ROOT, "sample_gcode", name)
    orig = str(tmp_path / "in.gcode")
    shutil.copy(src, orig)
    subprocess.run([sys.executable, "-m", "gcode_opt", "process", orig, "-o", str(tmp_path / "out.gcode"),
                    "-q", "--profile", PROFILE], env=dict(os.environ, PYTHONPATH=ROOT), check=True,
                   capture_output=True)
    outs = []
    for side, tree in (("base", base_tree), ("new", ROOT)):
        d = tmp_path / side
        d.mkdir()
        outs.append(_report(tree, "../in.gcode", "../out.gcode", str(d)))
    assert outs[0][1] == outs[1][1]          # JSON
    assert outs[0][0] == outs[1][0]          # HTML (pictures embedded)
