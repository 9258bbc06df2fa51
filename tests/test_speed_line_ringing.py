"""Per-line speed-ups of the ringing figures (issue 8) give the same numbers, exactly:
Oscillator.max_abs_r (only the pieces that can hold the peak solved) against the plain
max of peak_abs_r, and the Collector's blocks turned into rows in bulk against the rows a
Rows sink builds one block at a time (fed back through add_rows, the path that takes
ready rows)."""
import os

import numpy as np
import pytest

from gcode_opt import ringing as rg
from gcode_opt.firmware.resonance import Oscillator
from gcode_opt.firmware.simulate import simulate_file
from gcode_opt.profile import load_profile

SAMPLES = os.path.join(os.path.dirname(__file__), "..", "sample_gcode")


@pytest.mark.parametrize("seed", range(6))
def test_max_abs_r_is_the_max_of_peak_abs_r(seed):
    rng = np.random.default_rng(seed)
    osc = Oscillator(float(rng.uniform(20.0, 90.0)), float(rng.uniform(0.02, 0.3)))
    for _ in range(200):
        n = int(rng.integers(1, 400))
        c = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) * np.exp(rng.uniform(-25.0, 5.0, n))
        dur = rng.exponential(float(rng.choice([1e-4, 1e-3, 1e-2, 0.1])), n)
        if rng.random() < 0.3:
            dur[-1] = np.inf
        if rng.random() < 0.2:
            c[rng.integers(0, n)] = 0j
        assert osc.max_abs_r(c, dur) == float(osc.peak_abs_r(c, dur).max())


def test_max_abs_r_finds_a_peak_inside_a_piece():
    """A piece that starts at r = 0 (pure velocity jump) and rings up inside: its start is
    below every other start, its peak above them all."""
    osc = Oscillator(40.0, 0.1)
    c = np.array([0.5 + 0j, -1j * 3.0, 0.4 + 0.1j])
    dur = np.array([0.01, 0.02, np.inf])
    ref = float(osc.peak_abs_r(c, dur).max())
    assert ref > 2.0                          # the second piece's inside extremum wins
    assert osc.max_abs_r(c, dur) == ref


class _Spy(rg.Collector):
    """A Collector that keeps every chunk's rows as it solves them."""

    def __init__(self, *a, **k):
        super().__init__(*a, **k)
        self.seen = []

    def _flush(self, final):
        self._drain()
        self.seen.append(np.frombuffer(self.rows, float).reshape(-1, rg.ROW).copy())
        super()._flush(final)


class _Both:
    """Feeds one pass to a Collector and a Rows sink at once."""

    def __init__(self, col, rows):
        self.col, self.rows = col, rows

    def on_block(self, b):
        self.col.on_block(b)
        self.rows.on_block(b)

    def rest(self, dt_t):
        self.col.rest(dt_t)
        self.rows.rest(dt_t)


@pytest.mark.parametrize("name,prof,chunk,pend", [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 37, None),
                                                  ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 37, 7),
                                                  ("prusa_klipper.gcode", "voron24", 1, None),
                                                  ("prusa_klipper.gcode", "voron24", 500, 64)])
def test_collector_rows_in_bulk_equal_rows_one_by_one(name, prof, chunk, pend, monkeypatch):
    """The rows the Collector solves, chunk by chunk, are the Rows sink's (_block_row of
    each block, _rest_row of each rest) between the idle second before and after, bit for
    bit; every chunk but the first and the last holds exactly chunk_blocks rows."""
    if pend is not None:                       # fewer pending blocks than a chunk holds
        monkeypatch.setattr(rg, "PEND_BLOCKS", pend)
    path, p = os.path.join(SAMPLES, name), load_profile(prof)
    col, rows = _Spy(p, chunk_blocks=chunk), rg.Rows()
    rg.play(path, p, _Both(col, rows))
    col.figures()
    ref = np.concatenate([rg.IDLE, np.frombuffer(rows.items, float), rg.IDLE]).reshape(-1, rg.ROW)
    got = np.concatenate(col.seen)
    assert len(ref) > 200 and (ref[:, 11] == 0.0).sum() > 2            # blocks and rests
    assert got.tobytes() == ref.tobytes()
    assert len(col.seen) > 3 if chunk < 100 else len(col.seen) >= 1
    # the idle row before the file counts, and a chunk is solved once a row fills it
    assert len(col.seen[0]) == max(chunk, 2)
    assert all(len(m) == chunk for m in col.seen[1:-1])
