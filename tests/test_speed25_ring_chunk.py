"""The ringing Collector's chunk (ringing.CHUNK_BLOCKS 16384 -> 4096 blocks): less memory
held at once, the same figures up to the order of the sums (its chunks cut the sums at
other rows), on a real sample played by the firmware model."""
from __future__ import annotations

import os
import tracemalloc

import pytest

from gcode_opt import ringing as rg
from gcode_opt.profile import load_profile

SAMPLES = os.path.join(os.path.dirname(__file__), "..", "sample_gcode")


def _flat(d, pre=""):
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(_flat(v, pre + k + "."))
        else:
            out[pre + k] = v
    return out


def _played(path, profile, chunk):
    tracemalloc.start()
    try:
        col = rg.Collector(profile, chunk_blocks=chunk)
        rg.play(path, profile, col)
        got = col.figures()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    return got, peak, col.chunks


def test_default_chunk_holds_less_and_figures_the_same():
    path = os.path.join(SAMPLES, "prusa_gyroid.gcode")
    profile = load_profile("prusa-mk3s")
    assert rg.CHUNK_BLOCKS == 4096
    new, peak_new, n_new = _played(path, profile, rg.CHUNK_BLOCKS)
    old, peak_old, n_old = _played(path, profile, 16384)
    assert n_new > n_old >= 1                 # the file spans several of the new chunks
    assert peak_new < peak_old - 2e6, (peak_old, peak_new)
    a, b = _flat(old), _flat(new)
    assert a.keys() == b.keys()
    for k, v in a.items():
        if isinstance(v, float):
            assert b[k] == pytest.approx(v, rel=1e-10, abs=1e-12), k
        else:
            assert b[k] == v, k
    assert a["xy.rms_um"] > 0.5               # it rings: not a 0 == 0 check
