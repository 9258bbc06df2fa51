"""Round 53 (rep53): `process --report` in bounded memory, same bytes.
(1) the processed file's ringing rows streamed through a StretchSink: the stretch's samples
    as stretch_rows over the whole file's RowTable, its Collector's figures as add_rows over
    all the rows (chunks small enough that rows are dropped and many chunks placed);
(2) the processed file played as a FenceTrace: each fence's block figures, the kinetic terms,
    the kept spans' blocks and a layer's blocks as the whole trace's;
(3) LayerPick never drops the layer _map_layer's min() takes (random gains, ties, NaN);
(5) the original's ringing streamed: BusiestSink's start as busiest_stretch_rows', the
    report's ringing section as ringing_data_rows over both files' whole rows; its kinetic
    terms without block columns as with them;
(4) the HTML and JSON the code of 182bdeb (git archive) writes for `report` and `process --report`."""
import math
import os
import shutil
import subprocess
import sys
from collections import defaultdict

import numpy as np
import pytest
from base_tree import command as base_tree_command
from base_tree import unpack as base_tree_unpack

from gcode_opt import ringing as rg
from gcode_opt.profile import load_profile
from gcode_opt.report import data as dm
from gcode_opt.report.fences import parse_fences
from gcode_opt.report.ringing import BusiestSink, RingingRows, StretchSink, ringing_data_rows
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
    subprocess.run([sys.executable] + base_tree_command(tree) + args, env=dict(os.environ, PYTHONPATH=tree), cwd=cwd,
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


# ----------------------------------------------------------------- (5) the original's ringing, kinetic terms
@pytest.mark.parametrize("name,length_d,chunk_rows", [(SAMPLES[0], 40.0, 300), (SAMPLES[1], 20.0, 1000),
                                                      (SAMPLES[0], 40.0, 16384), (SAMPLES[2], 1e6, 300)])
def test_busiest_sink_as_the_whole_rows(name, length_d, chunk_rows, processed, monkeypatch):
    src, _dst = processed[name]
    prof = load_profile(PROFILE)
    model = rg.model_of(prof)
    monkeypatch.setattr(rg, "STRETCH_ROWS", chunk_rows)
    rows = rg.Rows.padded()
    rg.play(src, prof, rows)
    rows.close_padded()
    rt = rg.RowTable(rows.items, model, padded=True)
    ref = rg.busiest_stretch_rows(rt, length_d, chunk_rows)
    ref_bins = np.zeros(rg.stretch_bins(float(rt.s[-1]), length_d))      # its energies by bin
    for r0 in range(0, len(rt), chunk_rows):
        r1 = min(r0 + chunk_rows, len(rt))
        for bins, per in rg.stretch_energy(rt, r0, r1, r1 == len(rt), 0.5 * length_d):
            np.add.at(ref_bins, bins, per)
    sink = BusiestSink(model, length_d)
    sink.limit = rg.ROW * 256
    rg.play(src, prof, sink)
    sink.close()
    assert sink.n == len(rt) and len(sink.parts) <= 2 + (chunk_rows + 600) // 256
    k = min(len(ref_bins), len(sink.per_bin))
    assert sink.per_bin[:k].tobytes() == ref_bins[:k].tobytes() and not sink.per_bin[k:].any()
    assert _bits(sink.busiest()) == _bits(ref)
    if length_d < 1e5:
        assert ref > 0.0


@pytest.mark.parametrize("given", [False, True])
def test_ringing_section_streamed_as_the_whole_rows(given, processed):
    src, dst = processed[SAMPLES[1]]
    prof = load_profile(PROFILE)
    whole = []
    for path in (src, dst):
        rows = rg.Rows.padded()
        rg.play(path, prof, rows)
        rows.close_padded()
        whole.append(rows.items)
    ref = ringing_data_rows(whole, prof)
    figures = {"model": ref["model"], "before": ref["before"], "after": ref["after"]} if given else None
    rr = RingingRows(prof, figures=figures)
    for path, make, tag in ((src, rr.busiest_sink, None), (dst, rr.sink, "after"), (src, rr.stretch_sink, "before")):
        sink = make()
        assert (sink.col is None) == (given or tag == "before")
        rg.play(path, prof, sink)
        rr.add_sink(sink, tag) if tag else rr.add_sink(sink)
    assert rr.data() == ref and list(rr.data()["stretch"]) == ["from_mm", "length_mm", "before", "after"]


@pytest.mark.parametrize("name", SAMPLES)
def test_kinetic_terms_without_block_columns(name, processed):
    src, _dst = processed[name]
    prof = load_profile(PROFILE)
    full = trace_file(src, prof)
    lean = trace_file(src, prof, mass_xy=(prof.moving_mass_x_kg, prof.moving_mass_y_kg))
    assert lean.blocks is None and len(lean.kinetic) == len(full.blocks["d"]) > 0
    assert _bits(dm._kinetic_whole(lean, prof)) == _bits(dm._kinetic_whole(full, prof))


@pytest.mark.parametrize("chunk_rows,limit_rows", [(300, 64), (300, 256), (1000, 128)])
def test_busiest_sink_keeps_what_each_window_reads(chunk_rows, limit_rows, processed, monkeypatch):
    """Whenever the sink solves a chunk, the rows kept reach from the row before its window's
    first row (history) to the row after its last one's (lookahead), as the whole RowTable has them."""
    src, _dst = processed[SAMPLES[1]]
    prof = load_profile(PROFILE)
    model = rg.model_of(prof)
    monkeypatch.setattr(rg, "STRETCH_ROWS", chunk_rows)
    rows = rg.Rows.padded()
    rg.play(src, prof, rows)
    rows.close_padded()
    rt = rg.RowTable(rows.items, model, padded=True)
    sink = BusiestSink(model, 20.0)
    sink.limit = rg.ROW * limit_rows
    seen = []
    real = rg.stretch_energy

    def spy(part, r0, r1, last, bin_d):
        first, kept = sink.parts[0][0], sum(len(p[1]) for p in sink.parts)
        g0, g1 = first + r0, first + r1
        w0 = max(int(np.searchsorted(rt.t, rt.t[g0] - rt.history_t, side="right")) - 1, 0)
        w1 = min(int(np.searchsorted(rt.t, rt.t[min(g1, len(rt) - 1)] + rt.span_t, side="right")) + 2, len(rt))
        assert first <= max(w0 - 1, 0) and first + kept >= w1
        assert np.array_equal(part.t, rt.t[first:first + kept]) and np.array_equal(part.m, rt.m[first:first + kept])
        seen.append((g0, g1, last))
        return real(part, r0, r1, last, bin_d)
    monkeypatch.setattr(rg, "stretch_energy", spy)
    rg.play(src, prof, sink)
    sink.close()
    assert seen == [(r0, min(r0 + chunk_rows, len(rt)), r0 + chunk_rows >= len(rt)) for r0 in range(0, len(rt), chunk_rows)]
    assert max(len(p[1]) for p in sink.parts) <= limit_rows + 2
