"""Session 31, the measure pass and the summary's line counts, at the same bits.

- Sim.play_buf hands a line of ASCII bytes to the reader's fused loop as bytes
  (ReaderAPI.line_ascii): a str is made only for a line step() reads.  Against the
  list-of-str loop (USE_PLAY_BUF off) and the per-line step (use_fused off), on a file
  whose lines go every way: plain G1s, M204s, non-ASCII comments and moves, marked
  comments, SET_VELOCITY_LIMIT, E-only moves, dwells, CRLF.
- The summary's lines_before / lines_after come from the passes (analyse's reader, the
  last full measure's Blocks) where those lines are summary.count_lines' lines (no "\\r"
  in the file), else from count_lines: the same numbers either way."""
from __future__ import annotations

import json
import os
import types

import pytest

from gcode_opt import pipeline as pl
from gcode_opt import ringing as rg
from gcode_opt import state as st
from gcode_opt.firmware import simulate as fw
from gcode_opt.profile import load_profile
from gcode_opt.summary import count_lines

from test_speed_measure_loop import bits, led_bits, res_bits

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLES = os.path.join(ROOT, "sample_gcode")

compiled = pytest.mark.skipif(fw._core is None or not hasattr(fw._core.Sim, "play_buf") or st._reader is None,
                              reason="the compiled cores are not built here")


def _mixed_file(path, crlf=False):
    """prusa_gyroid's first lines with lines of every kind put between them."""
    extra = [";\u00e9 comment \u00fc\n", "M204 S1500\n", "M204 P800 T1200\n", "G1 X10.5 Y20.25 ; \u00e9\n",
             ";TYPE:External perimeter\n", "SET_VELOCITY_LIMIT ACCEL=2500\n", "G1 E-0.8 F2100\n",
             "G4 P10\n", "\n", "G1 X11 Y21 E0.05\n"]
    out = []
    with open(os.path.join(SAMPLES, "prusa_gyroid.gcode"), encoding="utf-8") as fh:
        for k, line in enumerate(fh):
            if k >= 4000:
                break
            out.append(line)
            if k > 200 and k % 7 == 0:
                out.append(extra[(k // 7) % len(extra)])
    text = "".join(out)
    if crlf:
        text = text.replace("\n", "\r\n")
    with open(path, "w", encoding="utf-8", newline="") as fh:
        fh.write(text)


def _measure(path, profile):
    n = count_lines(path)
    first = list(range(3, n - 8, 29))
    watch = fw.LineRanges(first, [a + 6 for a in first])        # (the re-timed blocks' lines, say)
    out_ranges = [(a, a + 6, i) for i, a in enumerate(first)]
    ring = rg.Collector(profile, parts=True)
    opts = types.SimpleNamespace(progress=None)
    sim, t, a2, v2, led = pl.measure(path, profile, out_ranges, opts, watch, ring)
    return (res_bits(sim), bits([t, a2, v2]), led_bits(led), bits(ring.figures())), opts.lines_out


@compiled
@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
@pytest.mark.parametrize("crlf", [False, True])
def test_play_buf_ascii_lines_same_bits(tmp_path, monkeypatch, prof, crlf):
    path = str(tmp_path / "mixed.gcode")
    _mixed_file(path, crlf)
    profile = load_profile(prof)
    assert fw.use_fused(True)
    new, counted = _measure(path, profile)
    assert counted == (None if crlf else count_lines(path))
    for size in (37, 1 << 16):            # blocks cut everywhere: the lines the same
        monkeypatch.setattr(fw, "BLOCK_BYTES", size)
        assert _measure(path, profile)[0] == new, size
    monkeypatch.setattr(fw, "USE_PLAY_BUF", False)       # the list-of-str loop
    assert _measure(path, profile) == (new, None)
    monkeypatch.setattr(fw, "USE_PLAY_BUF", True)
    try:
        assert not fw.use_fused(False)                   # step() line by line
        assert _measure(path, profile)[0] == new
    finally:
        fw.use_fused(True)


@pytest.mark.parametrize("tail", [b"", b"G1 X6 Y7 E0.1", b"G1 X6 Y7 E0.1\n\n"])
def test_blocks_count_is_count_lines(tmp_path, tail):
    """Blocks' count (the lines play_buf played) is count_lines' where no "\\r" is in the
    file, and unknown (None) where one is."""
    src = os.path.join(SAMPLES, "prusa_gyroid.gcode")
    with open(src, "rb") as fh:
        body = fh.read().rstrip(b"\n") + b"\n"
    for text, known in ((body + tail, True), (body.replace(b"\n", b"\r\n", 3) + tail, False)):
        path = str(tmp_path / "f.gcode")
        with open(path, "wb") as fh:
            fh.write(text)
        got = []
        fw.simulate_file(path, load_profile("prusa-mk3s"), on_count=got.append)
        if fw._core is not None and hasattr(fw._core.Sim, "play_buf"):
            assert got == ([count_lines(path)] if known else [])
        else:
            assert got == []


def _summary_lines(src, tmp_path, monkeypatch, count_calls):
    real = count_lines
    calls = []

    def counting(path):
        calls.append(path)
        return real(path)
    monkeypatch.setattr("gcode_opt.summary.count_lines", counting)
    out = str(tmp_path / "out.gcode")
    s = pl.process(src, out, load_profile("prusa-mk3s"), pl.Options())
    monkeypatch.setattr("gcode_opt.summary.count_lines", real)
    assert len(calls) == count_calls, calls
    return s["file"], real(src), real(out)


@pytest.mark.parametrize("form", ["lf", "no_final_newline", "crlf"])
def test_summary_line_counts(tmp_path, monkeypatch, form):
    with open(os.path.join(SAMPLES, "prusa_absolute_e.gcode"), "rb") as fh:
        text = fh.read()
    if form == "no_final_newline":
        text = text.rstrip(b"\n")
    elif form == "crlf":
        text = text.replace(b"\n", b"\r\n")
    src = str(tmp_path / "in.gcode")
    with open(src, "wb") as fh:
        fh.write(text)
    fast = st._reader is not None and getattr(st._reader, "split_lines", None) is not None \
        and fw._core is not None and hasattr(fw._core.Sim, "play_buf")
    # counted by the passes (no file read again) unless a "\r" is in it, or a core is missing
    want_calls = 2 if (form == "crlf" or not fast) else 0
    got, n_in, n_out = _summary_lines(src, tmp_path, monkeypatch, want_calls)
    assert (got["lines_before"], got["lines_after"]) == (n_in, n_out)
    assert n_out > n_in > 1000


def test_summary_json_same_with_and_without_counts(tmp_path, monkeypatch):
    """The whole summary (figures, file section) the same when the passes' counts are
    thrown away and count_lines reads both files."""
    src = os.path.join(SAMPLES, "prusa_absolute_e.gcode")
    out = str(tmp_path / "out.gcode")
    a = pl.process(src, out, load_profile("prusa-mk3s"), pl.Options())
    orig_measure = pl.measure

    def forget(*args, **kw):
        got = orig_measure(*args, **kw)
        args[3].lines_out = None
        args[3].lines_in = None
        return got
    monkeypatch.setattr(pl, "measure", forget)
    b = pl.process(src, str(tmp_path / "out2.gcode"), load_profile("prusa-mk3s"), pl.Options())
    for s in (a, b):
        for k in ("timing_s", "elapsed_s", "output"):
            s.pop(k, None)
    assert json.dumps(a, sort_keys=True, default=str) == json.dumps(b, sort_keys=True, default=str)


def _n_moves_ref(strokes):
    """summary._n_moves before session 31 (the type test and the fields read in Python)."""
    import numpy as np
    from operator import attrgetter
    from gcode_opt.strokes import Stroke
    n = len(strokes)
    if all(type(s) is Stroke for s in strokes):
        return (np.fromiter(map(attrgetter("last_idx"), strokes), np.int64, n)
                - np.fromiter(map(attrgetter("first_idx"), strokes), np.int64, n) + 1)
    return np.fromiter((s.n_moves for s in strokes), np.int64, n)


def test_n_moves_same(tmp_path):
    from gcode_opt.stroke_columns import n_moves      # (summary._n_moves until session 50)
    from gcode_opt.strokes import Stroke
    strokes, _ = pl.analyse(os.path.join(SAMPLES, "prusa_gyroid.gcode"), load_profile("prusa-mk3s"), pl.Options())
    assert len(strokes) > 500
    got = n_moves(strokes)
    assert got.dtype == _n_moves_ref(strokes).dtype and got.tolist() == _n_moves_ref(strokes).tolist()
    assert n_moves(strokes[::3]).tolist() == _n_moves_ref(strokes[::3]).tolist()
    assert n_moves([]).tolist() == [] and n_moves([]).dtype == _n_moves_ref([]).dtype

    class Other(Stroke):                 # a stroke of another kind counts its own moves
        __slots__ = ()

        @property
        def n_moves(self):
            return 7
    odd = Other.__new__(Other)
    odd.first_idx, odd.last_idx = 10, 11
    mixed = strokes[:5] + [odd]
    assert n_moves(mixed).tolist() == _n_moves_ref(mixed).tolist() == [s.n_moves for s in mixed]
