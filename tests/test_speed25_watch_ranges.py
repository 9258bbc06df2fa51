"""The measure pass's watched ranges held as LineRanges (two array("q"), not a list of
~52 k (first, last) tuples): the same Ledger, records and SimResult, bit for bit, as the
per-line reference loop kept in test_speed_measure_loop (given the list of tuples), in
chunks and line by line; and LineRanges reads as that list."""
from __future__ import annotations

import random
import sys
import tracemalloc

import numpy as np
import pytest

from gcode_opt.firmware import simulate as fw
from gcode_opt.profile import load_profile

from test_speed_measure_loop import (_n_lines, _ref_simulate_ledger, _watch, led_bits, rec_bits, res_bits,  # noqa: F401
                                     written)


def test_line_ranges_read_as_the_list():
    rng = random.Random(3)
    pairs, line = [], 0
    for _ in range(500):
        line += rng.randint(1, 40)
        last = line + rng.randint(0, 9)
        pairs.append((line, last))
        line = last + 1
    first = np.array([a for a, _ in pairs], np.int64)
    last = np.array([z for _, z in pairs], np.int64)
    r = fw.LineRanges.of_rows(first, last)
    assert len(r) == len(pairs)
    assert list(r) == pairs
    assert [r[i] for i in range(len(pairs))] == pairs and r[-1] == pairs[-1]
    assert all(type(x) is int for x in r[7])
    assert fw.LineRanges([a for a, _ in pairs], [z for _, z in pairs]).first == r.first
    with pytest.raises(ValueError):
        fw.LineRanges([1, 2], [3])
    with pytest.raises(IndexError):
        r[len(pairs)]


def test_line_ranges_hold_less():
    """The point of it: the rectilinear plate's ~52 k ranges were ~6.5 MB as tuples."""
    n = 50_000
    first = np.arange(1000, 1000 + 4 * n, 4, dtype=np.int64)
    tracemalloc.start()
    try:
        a0 = tracemalloc.get_traced_memory()[0]
        as_list = list(zip(first.tolist(), (first + 2).tolist()))
        a1 = tracemalloc.get_traced_memory()[0]
        as_ranges = fw.LineRanges.of_rows(first, first + 2)
        a2 = tracemalloc.get_traced_memory()[0]
    finally:
        tracemalloc.stop()
    assert len(as_list) == len(as_ranges)
    assert (a2 - a1) < 0.25 * (a1 - a0), (a1 - a0, a2 - a1)
    assert sys.getsizeof(as_ranges.first) < 20 * n


@pytest.mark.skipif(fw._core is None or not hasattr(fw._core, "StrokeSums"), reason="no compiled model")
@pytest.mark.parametrize("hint", [1, 333, 1 << 16])
@pytest.mark.parametrize("name", ["prusa_gyroid", "prusa_klipper"])
def test_ledger_of_line_ranges_is_the_reference(written, name, hint, monkeypatch):  # noqa: F811
    path, prof, blocks = written[name]
    profile = load_profile(prof)
    watch = _watch(_n_lines(path), blocks, random.Random(hint))
    ranges = fw.LineRanges.of_rows(np.array([a for a, _ in watch], np.int64), np.array([z for _, z in watch], np.int64))
    recs_ref, recs_new = [], []
    res_ref, led_ref = _ref_simulate_ledger(path, profile, watch, on_line=recs_ref.append)
    monkeypatch.setattr(fw, "CHUNK_HINT", hint)
    for firsts in (True, False):          # the C loop over the ranges' first lines, and a call a range
        monkeypatch.setattr(fw, "USE_PLAY_FIRSTS", firsts)
        recs_new.clear()
        res_new, led_new = fw.simulate_ledger(path, profile, ranges, on_line=recs_new.append)
        assert len(recs_ref) > 1000
        assert [rec_bits(r) for r in recs_ref] == [rec_bits(r) for r in recs_new]
        assert res_bits(res_ref) == res_bits(res_new)
        assert led_bits(led_ref) == led_bits(led_new)
