"""Sim.play_buf: the measure pass reads the written file as bytes blocks (Blocks) and
the core splits and decodes the lines itself (no list of str a chunk).  Against the
references: the lines read_lines gives (LF, CRLF, a lone CR, also at a block's edge, no
final newline, bytes that are not UTF-8, a BOM, a line longer than a block), the
per-line loop of 9bb98a8 (test_speed_measure_loop._ref_play) on samples x profiles with
and without a ledger, the list-of-str loop (USE_PLAY_BUF off) on the measure pass of a
re-timed corpus file with its ringing, and the pure-Python core."""
from __future__ import annotations

import math
import os
import types

import pytest

from gcode_opt import pipeline as pl
from gcode_opt import ringing as rg
from gcode_opt import state as st
from gcode_opt.firmware import simulate as fw
from gcode_opt.profile import load_profile

from test_speed_measure_fused import PROFILES, _Taps
from test_speed_measure_loop import _ref_play, bits, led_bits, res_bits

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLES = os.path.join(ROOT, "sample_gcode")
CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus")

pytestmark = pytest.mark.skipif(fw._core is None or not hasattr(fw._core.Sim, "play_buf"),
                                reason="the compiled firmware core is not built here")

MIXED = (b"\xef\xbb\xbfG1 X1\nG1 X2\r\nG1 X3\rG1 X4\n\n;\xff comment \xe2\x82\n;\xc3\xa9\r\n\r\r\n"
         + b"; a long line " + b"x" * 300 + b"\n") * 40 + b"G1 X5\r"


def _blocks_lines(path):
    """(idx, raw) of every line play_buf reads, through a Python step (called for every line)."""
    got = []

    def step(idx, raw):
        got.append((idx, raw))

    sim = fw.new_sim(load_profile("prusa-mk3s"), None, None)
    idx = 0
    for buf, cr in fw.Blocks(path).blocks():
        pos = 0
        while pos < len(buf):
            pos, idx, stopped = sim.play_buf(buf, pos, idx, cr, step, -2, False, None)
            assert not stopped
    return got


@pytest.mark.parametrize("tail", [b"", b"G1 X6", b"G1 X6\r", b"G1 X6\r\n", b"\r"])
def test_blocks_split_as_read_lines(tmp_path, tail, monkeypatch):
    path = str(tmp_path / "mixed.gcode")
    with open(path, "wb") as fh:
        fh.write(MIXED + tail)
    ref = list(st.read_lines(path))
    for size in (1, 2, 3, 7, 64, 1 << 16):
        monkeypatch.setattr(fw, "BLOCK_BYTES", size)
        assert _blocks_lines(path) == ref, size
        # the blocks are the file, each but the last ends a line, none inside a "\r\n"
        blocks = [(bytes(buf), cr) for buf, cr in fw.Blocks(path).blocks()]
        assert b"".join(b for b, _ in blocks) == MIXED + tail
        assert all(b.endswith((b"\n", b"\r")) for b, _ in blocks[:-1])
        assert all(cr == (b"\r" in b) for b, cr in blocks)
        assert not any(a.endswith(b"\r") and b.startswith(b"\n") for (a, _), (b, _) in zip(blocks, blocks[1:]))


def test_empty_file(tmp_path):
    path = str(tmp_path / "empty.gcode")
    open(path, "wb").close()
    assert _blocks_lines(path) == []
    assert list(fw.Blocks(path)) == []


def _run(path, profile, size, ref, watch=None, monkeypatch=None):
    lines = list(st.read_lines(path))
    taps = _Taps(len(lines), 5)
    state = st.MachineState(profile, path)
    state.warnings = []
    sim = fw.new_sim(profile, taps.sums, taps.sink)
    led = None
    if watch is not None:
        sim.max_stop_lines = math.inf
        led = fw.Ledger()
    if ref:
        _ref_play(iter(lines), state, sim, watch, led)
    else:
        monkeypatch.setattr(fw, "BLOCK_BYTES", size)
        fw._play_chunks(fw.Blocks(path), state, sim, watch, led)
    if watch is None:
        sim.stop()
    else:
        led.stop_lines = sim.res.stop_lines
        led.res = sim.res
    rows, sums = taps.result()
    return rows, sums, res_bits(sim.res), led and led_bits(led), bits([state.snapshot(), state.warnings])


FILES = ["edge/crlf_line_endings", "edge/m204_variants", "edge/klipper_macros", "edge/firmware_retraction",
         "prusa_gyroid", "prusa_klipper", "prusa_gyroid_arcs"]


@pytest.mark.parametrize("name", FILES)
@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_play_buf_same_as_per_line_loop(name, prof, monkeypatch):
    path = os.path.join(SAMPLES, name + ".gcode")
    profile = PROFILES[prof]()
    n = sum(1 for _ in st.read_lines(path))
    watch = [(a, min(a + 7, n - 1)) for a in range(3, n, 29)]
    for w in (None, watch):
        for first in (True, False):
            monkeypatch.setattr(fw, "USE_PLAY_FIRSTS", first)
            ref = _run(path, profile, 0, True, w)
            for size in (50, 1 << 16):
                assert _run(path, profile, size, False, w, monkeypatch) == ref, (w is None, first, size)


def _measure(path, profile, out_ranges, watch):
    ring = rg.Collector(profile, parts=True)
    sim, t, a2, v2, led = pl.measure(path, profile, out_ranges, types.SimpleNamespace(progress=None), watch, ring)
    return res_bits(sim), bits([t, a2, v2]), led_bits(led), bits(ring.figures())


def test_measure_pass_same_bits(tmp_path, monkeypatch):
    """pipeline.measure with its ledger and ringing on a re-timed file: play_buf against
    the list-of-str loop, and the pure-Python core against both (a smaller file)."""
    src = os.path.join(CORPUS, "bridges.gcode")
    if not os.path.exists(src):
        src = os.path.join(SAMPLES, "prusa_gyroid.gcode")
    profile = load_profile("prusa-mk3s")
    out = str(tmp_path / "out.gcode")
    got = {}
    orig = pl.measure

    def spy(path, prof, out_ranges, opts, watch=None, ring=None):
        got.setdefault("args", (out_ranges, watch))
        with open(path, "rb") as fh:
            got.setdefault("bytes", fh.read())
        return orig(path, prof, out_ranges, opts, watch, ring)

    monkeypatch.setattr(pl, "measure", spy)
    pl.process(src, out, profile, pl.Options())
    monkeypatch.setattr(pl, "measure", orig)
    written = str(tmp_path / "written.gcode")
    with open(written, "wb") as fh:
        fh.write(got["bytes"])
    out_ranges, watch = got["args"]
    assert watch is not None and len(watch) > 100
    new = _measure(written, profile, out_ranges, watch)
    monkeypatch.setattr(fw, "USE_PLAY_BUF", False)
    assert _measure(written, profile, out_ranges, watch) == new
    monkeypatch.setattr(fw, "USE_PLAY_BUF", True)
    # the pure-Python core (reads lines, plays them in Python) on a sample's first lines
    small = str(tmp_path / "small.gcode")
    with open(written, "rb") as fh:
        head = b"".join(fh.readline() for _ in range(6000))
    with open(small, "wb") as fh:
        fh.write(head)
    lines = [(a, z, i) for a, z, i in out_ranges if z < 6000]
    w = fw.LineRanges([a for a, _, _ in lines], [z for _, z, _ in lines])
    c = _measure(small, profile, lines, w)
    old = fw.use_core("python")
    try:
        assert _measure(small, profile, lines, w) == c
    finally:
        fw.use_core(old)
