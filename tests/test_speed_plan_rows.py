"""The row-batched forms used by chains._finish_rows give, row by row, the same bits as
the per-row functions they replace (segments.tent_feeds, segments.hold_cruise_accels)."""
import numpy as np
import pytest

from gcode_opt.segments import (CRUISE_A, hold_cruise_accels, hold_cruise_accels_rows, tent_feeds,
                                tent_feeds_rows)


@pytest.mark.parametrize("n", [0, 1, 2, 5, 23])
def test_tent_feeds_rows_equal_per_row(n):
    rng = np.random.default_rng(n)
    need = rng.uniform(5.0, 120.0, (6, n))
    need[1] = 80.0
    for step_v in (0.9, 4.5, np.inf):
        got = tent_feeds_rows(need, 80.0, step_v)
        want = np.array([tent_feeds(r, 80.0, step_v) for r in need]).reshape(need.shape)
        assert got.tobytes() == want.tobytes()
        small = tent_feeds_rows(need, 80.0, step_v, max_cells=1)      # the row-by-row path
        assert small.tobytes() == want.tobytes()


@pytest.mark.parametrize("n", [1, 2, 7, 30])
def test_hold_cruise_accels_rows_equal_per_row(n):
    rng = np.random.default_rng(10 + n)
    acc = rng.uniform(100.0, 3000.0, (8, n))
    acc[rng.random((8, n)) < 0.4] = 0.0                  # cruises, leading and inner
    acc[1] = 0.0                                          # all cruise
    acc[2] = rng.uniform(100.0, 3000.0, n)                # none
    acc[3, 0] = CRUISE_A                                  # at the threshold
    acc[4, -1] = np.nan                                   # a fault stays a fault
    got = hold_cruise_accels_rows(acc, 1234.0)
    want = np.array([hold_cruise_accels(r, 1234.0) for r in acc])
    assert got.tobytes() == want.tobytes()
    none = rng.uniform(100.0, 3000.0, (3, n))
    assert hold_cruise_accels_rows(none, 1.0).tobytes() == none.tobytes()


def test_rows_with_values_per_row():
    """Rows of several chains: feed, jerk step and own acceleration per row."""
    rng = np.random.default_rng(21)
    need = rng.uniform(5.0, 120.0, (9, 11))
    v_feed = rng.uniform(40.0, 90.0, 9)
    step_v = rng.uniform(0.5, 3.0, 9)
    step_v[4] = np.inf                                     # that row stays as it is
    got = tent_feeds_rows(need, v_feed, step_v, max_cells=300)   # a few rows per block
    for r in range(9):
        assert got[r].tobytes() == tent_feeds(need[r], v_feed[r], step_v[r]).tobytes()
    acc = rng.uniform(100.0, 3000.0, (9, 11))
    acc[rng.random((9, 11)) < 0.4] = 0.0
    acc[2] = acc[7] = 0.0
    a_own = rng.uniform(500.0, 4000.0, 9)
    got = hold_cruise_accels_rows(acc, a_own)
    for r in range(9):
        assert got[r].tobytes() == hold_cruise_accels(acc[r], a_own[r]).tobytes()
