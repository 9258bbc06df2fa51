"""Round 53 (rep53): `process --report` in bounded memory, same bytes.
(1) the processed file's ringing rows streamed through a StretchSink: the stretch's samples
    as stretch_rows over the whole file's RowTable, its Collector's figures as add_rows over
    all the rows (chunks small enough that rows are dropped and many chunks placed);
(2) the processed file played as a FenceTrace: each fence's block figures, the kinetic terms,
    the kept spans' blocks and a layer's blocks as the whole trace's;
(3) LayerPick never drops the layer _map_layer's min() takes (random gains, ties, NaN);
(4) the HTML and JSON the code of 182bdeb (git archive) writes for `report` and `process --report`."""
import math
import os
import shutil
import subprocess
import sys
from collections import defaultdict

import numpy as np
import pytest
from base_tree import unpack as base_tree_unpack

from gcode_opt import ringing as rg
from gcode_opt.profile import load_profile
from gcode_opt.report import data as dm
from gcode_opt.report.fences import parse_fences
from gcode_opt.report.ringing import StretchSink
from gcode_opt.report.trace import BLOCK_FIELDS, trace_fences, trace_file

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLES = ["prusa_mk3s_rectilinear.gcode", "prusa_gyroid_arcs.gcode", "edge/tool_changes.gcode"]
BASE = "182bdeb"
PROFILE = "prusa-mk3s"


def _bits(x):
    return np.float64(x).tobytes()


@pytest.fixture(scope="module")
def processed(tmp_path_factory):
    d = tmp_path_factory.mktemp("proc")
    out = {}
    for name in SAMPLES:
        src = os.path.join(ROOT, "sample_gcode", name)
        dst = str(d / (name.replace("/", "_") + ".out.gcode"))
        subprocess.run([sys.executable, "-m", "gcode_opt", "process", src, "-o", dst, "-q", "--profile", PROFILE],
                       env=dict(os.environ, PYTHONPATH=ROOT), cwd=str(d), check=True, capture_output=True)
        out[name] = (src, dst)
    return out


# ----------------------------------------------------------------- (1) the stretch from a sink
@pytest.mark.parametrize("chunk_blocks", [64, 700])
def test_stretch_sink_as_the_whole_rows(processed, chunk_blocks):
    _src, dst = processed[SAMPLES[0]]
    prof = load_profile(PROFILE)
    model = rg.model_of(prof)
    rows = rg.Rows.padded()
    rg.play(dst, prof, rows)
    rows.close_padded()
    whole = rg.RowTable(rows.items, model, padded=True)
    total_d = float(whole.s[-1])
    ref_col = rg.Collector(model=model, chunk_blocks=chunk_blocks)
    ref_col.add_rows(memoryview(rows.items)[rg.ROW:len(rows.items) - rg.ROW])
    ref_figs = ref_col.figures()
    for k, s0 in enumerate((0.0, 0.37 * total_d, total_d - 25.0, total_d - 3.0, total_d + 10.0)):
        col = rg.Collector(model=model, chunk_blocks=chunk_blocks) if k == 1 else None
        sink = StretchSink(model, s0, 40.0, col)
        if col is None:
            sink.limit = rg.ROW * chunk_blocks
        rg.play(dst, prof, sink)
        sink.close()
        assert len(sink.parts) < sum(1 for _ in range(0, len(whole), chunk_blocks)) // 2   # rows were dropped
        got = sink.samples(500)
        ref = rg.stretch_rows(whole, s0, 40.0, 500)
        for a, b in zip(got, ref):
            assert a.tobytes() == b.tobytes(), s0
        if col is not None:
            assert col.figures() == ref_figs


# ----------------------------------------------------------------- (2) the processed file's trace
def _heads_and_plan(src, dst, prof):
    fences, _n = parse_fences(dst)
    tr0 = trace_file(src, prof)
    heads = dm.StrokeHeads(tr0, fences, None)
    return fences, tr0, heads, dm._rep_plan(heads.kinds, heads.lengths, tr0)


@pytest.mark.parametrize("name", SAMPLES)
def test_fence_trace_as_the_whole_trace(name, processed):
    src, dst = processed[name]
    prof = load_profile(PROFILE)
    fences, tr0, heads, plan = _heads_and_plan(src, dst, prof)
    spans = [(f.out_first, f.out_last) for f in fences]
    full = trace_file(dst, prof, processed=True)
    keep = [k for k in range(0, len(spans), 7)]
    layers = sorted(set(full.moves.layer))
    pick = dm.LayerPick(layers[len(layers) // 3], heads, tr0)
    lean = trace_fences(dst, prof, spans, keep, pick, (prof.moving_mass_x_kg, prof.moving_mass_y_kg))
    assert lean.n_lines == full.n_lines and lean.res.as_dict() == full.res.as_dict()
    for a, b in spans:
        n, t, below = lean.span_blocks(a, b, prof.min_segment_time_t)
        n1, t1, below1 = full.span_blocks(a, b, prof.min_segment_time_t)
        assert (n, below) == (n1, below1) and (t is None) == (t1 is None) and (t is None or _bits(t) == _bits(t1))
        assert n > 0
    assert _bits(dm._kinetic_whole(lean, prof)) == _bits(dm._kinetic_whole(full, prof))
    for k in keep:
        a, b = spans[k]
        sl0, sl1 = lean.block_range(a, b), full.block_range(a, b)
        assert sl0.stop > sl0.start
        for f in BLOCK_FIELDS:
            assert lean.blocks[f][sl0].tobytes() == full.blocks[f][sl1].tobytes()
    got, ref = lean.layer_blocks(pick.fixed), full.layer_blocks(pick.fixed)
    assert len(ref["d"]) > 0
    for f in BLOCK_FIELDS:
        assert got[f].dtype == ref[f].dtype and got[f].tobytes() == ref[f].tobytes()
    with pytest.raises(KeyError):                          # a layer not wanted was not kept
        lean.layer_blocks(pick.fixed + 1)


def test_fence_trace_keeps_the_chosen_layer(processed):
    src, dst = processed[SAMPLES[0]]
    prof = load_profile(PROFILE)
    fences, tr0, heads, plan = _heads_and_plan(src, dst, prof)
    spans = [(f.out_first, f.out_last) for f in fences]
    pick = dm.LayerPick(None, heads, tr0)
    lean = trace_fences(dst, prof, spans, [], pick, (prof.moving_mass_x_kg, prof.moving_mass_y_kg))
    rows = dm._stroke_rows(tr0, lean, fences, None, prof, heads)
    layer = dm._map_layer(rows, tr0)["layer"]
    assert len(set(heads.layers)) > 3 and len(pick.alive) <= 2 and set(lean.layers) <= pick.alive
    full = trace_file(dst, prof, processed=True)
    got, ref = lean.layer_blocks(layer), full.layer_blocks(layer)
    assert len(ref["d"]) > 0
    for f in BLOCK_FIELDS:
        assert got[f].tobytes() == ref[f].tobytes()


# ----------------------------------------------------------------- (3) LayerPick against min()
class _Heads:
    def __init__(self, layers, before):
        self.layers, self.a2_before = layers, before


@pytest.mark.parametrize("seed", range(40))
def test_layer_pick_never_drops_the_minimum(seed):
    rnd = np.random.default_rng(seed)
    n = int(rnd.integers(1, 60))
    layers = sorted(int(x) for x in rnd.integers(-1, 8, n)) if seed % 2 else [int(x) for x in rnd.integers(0, 5, n)]
    before = [float(x) for x in rnd.choice([0.0, 1.0, 2.0, 3.5], n)]
    after = [float(x) for x in rnd.choice([0.0, 1.0, 2.0, 3.5], n)]
    if seed % 5 == 0:
        after[int(rnd.integers(0, n))] = math.nan
    pick = dm.LayerPick(None, _Heads(layers, before), None)
    gone = []
    for k in range(n):
        gone += pick.closed(k, after[k])
    gain = defaultdict(float)
    for k, b, a in zip(layers, before, after):
        gain[k] += b - a
    chosen = min(gain, key=lambda k: (-gain[k], k))
    assert chosen not in gone and pick.wanted(chosen)
    assert set(gone) | pick.alive == set(layers)
    if not any(math.isnan(g) for g in gain.values()):
        assert pick.alive == {chosen}


def test_layer_pick_fixed():
    heads = _Heads([3, 3, 4], [1.0, 1.0, 1.0])
    pick = dm.LayerPick(4, heads, None)
    assert pick.wanted(4) and not pick.wanted(3) and pick.closed(0, 0.0) == ()


# ----------------------------------------------------------------- (4) bytes against 182bdeb
@pytest.fixture(scope="module")
def base_tree(tmp_path_factory):
    d = tmp_path_factory.mktemp("base")
    if not base_tree_unpack(BASE, d):
        pytest.skip(f"commit {BASE} not available")
    return str(d)


def _run(tree, args, cwd):
    subprocess.run([sys.executable, "-m", "gcode_opt"] + args, env=dict(os.environ, PYTHONPATH=tree), cwd=cwd,
                   check=True, capture_output=True)


@pytest.mark.parametrize("name", ["prusa_gyroid_arcs.gcode", "edge/arcs.gcode"])
def test_report_bytes_as_base(name, base_tree, tmp_path):
    shutil.copy(os.path.join(ROOT, "sample_gcode", name), tmp_path / "in.gcode")
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
    assert outs[0] == outs[1]
