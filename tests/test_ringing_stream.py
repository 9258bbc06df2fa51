"""ringing.Collector: the streaming, bounded-memory ringing figures equal the whole-trace
computation (ringing.figures_of_trace over ringing.trace) on real files, across many chunk
boundaries, with and without an input shaper."""
import os

import pytest

from gcode_opt import ringing as rg
from gcode_opt.firmware.simulate import simulate_file
from gcode_opt.profile import load_profile

SAMPLES = os.path.join(os.path.dirname(__file__), "..", "sample_gcode")
CASES = [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24"),
         ("cura_box.gcode", "ender3"), ("prusa_gyroid.gcode", "prusa-mk3s")]
REL = 1e-9


def _flat(d, pre=""):
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(_flat(v, pre + k + "."))
        elif isinstance(v, (int, float)) and not isinstance(v, bool):
            out[pre + k] = float(v)
        else:
            out[pre + k] = v
    return out


def _assert_same(got, ref):
    g, r = _flat(got), _flat(ref)
    assert g.keys() == r.keys()
    for k, v in r.items():
        if isinstance(v, float):
            assert g[k] == pytest.approx(v, rel=REL, abs=1e-12), k
        else:
            assert g[k] == v, k


@pytest.fixture(scope="module", params=CASES, ids=[c[0] for c in CASES])
def case(request):
    name, prof = request.param
    path, p = os.path.join(SAMPLES, name), load_profile(prof)
    return path, p, rg.trace(path, p)


@pytest.mark.parametrize("shaper", ["none", "mzv"])
@pytest.mark.parametrize("chunk", [20, 400, pytest.param(1, marks=pytest.mark.slow)])
def test_collector_equals_whole_trace(case, shaper, chunk):
    path, p, tr = case
    ref = rg.figures_of_trace(tr, rg.model_of(p), shaper)
    col = rg.Collector(p, shaper, chunk_blocks=chunk)
    rg.play(path, p, col)
    got = col.figures()
    assert col.chunks >= min(20, len(tr) // (3 * chunk))      # many chunk boundaries were crossed
    _assert_same(got, ref)
    assert ref["xy"]["rms_um"] > 0.5                            # the samples do ring: not a 0 == 0 check
    if shaper != "none":
        assert ref["smoothing"]["rms_um"] > 0.5


def test_figures_stream_and_default_chunk(case):
    path, p, tr = case
    _assert_same(rg.figures(path, p), rg.figures_of_trace(tr, rg.model_of(p)))


def test_collector_rides_on_the_pass():
    """play() gives the firmware model's own SimResult: the collector changes nothing."""
    path, p = os.path.join(SAMPLES, "prusa_klipper.gcode"), load_profile("voron24")
    col = rg.Collector(p, chunk_blocks=50)
    seen = []
    res = rg.play(path, p, col, on_line=seen.append)
    ref_lines = []
    ref = simulate_file(path, p, on_line=ref_lines.append)
    assert res.as_dict() == ref.as_dict()
    assert [r.idx for r in seen] == [r.idx for r in ref_lines]
    assert col.figures()["time_s"] == pytest.approx(ref.time_t, rel=1e-12)


def test_hooks_feed_a_pass_with_its_own_on_line():
    """The few lines a pipeline pass needs: hooks() + wrap_events() beside its own on_line."""
    from gcode_opt import state as st
    from gcode_opt.firmware.simulate import simulate_events
    path, p = os.path.join(SAMPLES, "prusa_mk3s_rectilinear.gcode"), load_profile("prusa-mk3s")
    col = rg.Collector(p, chunk_blocks=64)
    ring_line, on_block, on_dwell = rg.hooks(col)
    mine = []

    def on_line(rec):
        mine.append(rec.idx)
        ring_line(rec)
    simulate_events(rg.wrap_events(st.events(path, p), on_dwell), p, on_line, on_block)
    _assert_same(col.figures(), rg.figures(path, p))
    assert mine


def test_figures_twice_is_the_same():
    path, p = os.path.join(SAMPLES, "cura_box.gcode"), load_profile("ender3")
    col = rg.Collector(p, "zv", chunk_blocks=10)
    rg.play(path, p, col)
    assert col.figures() is col.figures()


@pytest.mark.parametrize("shaper", ["none", "mzv"])
def test_stretch_from_kept_rows_equals_whole_trace(case, shaper):
    """The report's bounded-memory stretch: the busiest window found window by window and
    the ringing sampled over only the stretch's window equal the whole-trace functions."""
    import numpy as np
    path, p, tr = case
    rows = rg.Rows()
    rg.play(path, p, rows)
    model = dict(rg.model_of(p), shaper=shaper)
    rt = rg.RowTable(rows.items, model)
    s_ref = rg.busiest_stretch(tr, model, 40.0)
    for chunk in (37, 5000):
        assert rg.busiest_stretch_rows(rt, 40.0, chunk) == s_ref
    s_a, x_a, y_a = rg.stretch(tr, model, s_ref, 40.0, 400)
    s_b, x_b, y_b = rg.stretch_rows(rt, s_ref, 40.0, 400)
    assert np.max(np.abs(x_a)) > 1.0                      # the stretch does ring
    assert np.allclose(s_b, s_a, rtol=0, atol=1e-8)
    assert np.allclose(x_b, x_a, rtol=0, atol=1e-5 * np.max(np.abs(x_a)))
    assert np.allclose(y_b, y_a, rtol=0, atol=1e-5 * np.max(np.abs(x_a)))
    col = rg.Collector(model=model, chunk_blocks=100)
    col.add_rows(rows.items)
    _assert_same(col.figures(), rg.figures_of_trace(tr, rg.model_of(p), shaper))


def test_collector_on_the_analyse_pass(tmp_path):
    """pipeline.analyse plays the original once and the ringing rides on that pass
    (opts.ringing_before): exactly the figures ringing.figures gets from a pass of its
    own, on a file with dwells (barriers) and E-only moves (rests)."""
    from gcode_opt import pipeline
    from gcode_opt.state import read_lines
    src, p = os.path.join(SAMPLES, "prusa_mk3s_rectilinear.gcode"), load_profile("prusa-mk3s")
    path = str(tmp_path / "dwell.gcode")
    n = 0
    with open(path, "w", newline="") as fo:
        for _, raw in read_lines(src):
            if raw.startswith("G1 "):
                n += 1
                if n % 53 == 0:
                    fo.write("G4 P150\n")
                if n % 41 == 0:
                    fo.write("G1 E-0.5 F2400\nG1 E0.5 F2400\n")
            fo.write(raw)
    opts = pipeline.Options()
    strokes, sim = pipeline.analyse(path, p, opts)
    assert strokes and sim.barrier_dwell_t > 1.0
    assert opts.ringing_before == rg.figures(path, p)
    assert opts.ringing_before["xy"]["rms_um"] > 0.5