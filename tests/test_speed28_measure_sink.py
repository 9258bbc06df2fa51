"""RowSink.take() hands out the bytearray the rows were written into (no copy) and writes the
next rows into the last bytes it handed out only once nothing else holds them: every
chunk a flush takes reads the rows pushed, in order, whether the taker keeps the bytes
(or an array over them) or drops them; and the Collector's figures on samples are
those of its chunks taken as copies."""
from __future__ import annotations

import os
import struct

import numpy as np
import pytest

from gcode_opt import ringing as rg
from gcode_opt.firmware import simulate as fw
from gcode_opt.profile import load_profile

from test_speed_measure_loop import bits

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLES = os.path.join(ROOT, "sample_gcode")

pytestmark = pytest.mark.skipif(fw._core is None or not hasattr(fw._core, "RowSink"),
                                reason="the compiled firmware core is not built here")


def _rows(b):
    return [struct.unpack_from("12d", b, 96 * i) for i in range(len(b) // 96)]


@pytest.mark.parametrize("keep", ["bytes", "array", "none"])
@pytest.mark.parametrize("cap", [1, 3, 64])
def test_take_hands_out_the_rows(keep, cap):
    held, seen = [], []

    def flush():
        b = sink.take()
        seen.extend(_rows(b))                 # what the taker reads when it takes them
        if keep == "bytes":
            held.append(b)
        elif keep == "array":
            held.append(np.frombuffer(b, float).reshape(-1, 12))

    sink = fw._core.RowSink(cap, flush)
    want = []
    for i in range(500):
        dt = 0.001 * (i + 1)
        sink.rest(dt)
        want.append(rg._rest_row(dt))
        if i % 97 == 5:                       # rows put as a block, as add_rows does
            more = [rg._rest_row(7.0 + j) for j in range(i % 5)]
            sink.put(struct.pack(f"{12 * len(more)}d", *[x for r in more for x in r]))
            want.extend(more)
    seen.extend(_rows(sink.take()))
    assert [tuple(map(float, r)) for r in seen] == [tuple(map(float, r)) for r in want]
    # the chunks kept still read what they read when taken
    if keep == "bytes":
        assert [r for b in held for r in _rows(b)] == seen[:sum(len(b) // 96 for b in held)]
    elif keep == "array":
        got = [tuple(r) for a in held for r in a.tolist()]
        assert got == [tuple(r) for r in seen[:len(got)]]
    assert sink.take() == b"" and sink.rows == 0


class _Copying:
    """A RowSink seen through take(): its rows as a copy (the take() of da0e9ec)."""

    def __init__(self, real):
        self.real = real

    def take(self):
        return bytes(bytearray(self.real.take()))

    def __getattr__(self, name):
        return getattr(self.real, name)


class _CopyCollector(rg.Collector):
    def _flush(self, final):
        real = self.sink
        if real is not None:
            self.sink = _Copying(real)
        try:
            super()._flush(final)
        finally:
            if self.sink is not None:
                self.sink = real


@pytest.mark.parametrize("name,shaper", [("prusa_gyroid", None), ("prusa_gyroid", "zv"),
                                         ("prusa_klipper", "mzv")])
def test_collector_figures_same_as_copies(name, shaper):
    """A Collector's figures (its chunks of 300 blocks taken without a copy, the arrays of a
    shaper's smoothing window kept over them) against the same pass with each chunk copied."""
    path = os.path.join(SAMPLES, name + ".gcode")
    profile = load_profile("prusa-mk3s")
    got = []
    for cls in (rg.Collector, _CopyCollector):
        col = cls(profile, shaper=shaper, chunk_blocks=300)
        assert col.sink is not None
        rg.play(path, profile, col)
        assert col.chunks > 3
        got.append(bits(col.figures()))
    assert got[0] == got[1]
