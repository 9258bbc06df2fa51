"""build_summary hands _per_stroke_rows its columns as arrays (issue 8, s33): the by-kind sums
take a float64 array as it is and the rows take its tolist(), where before every column was
made a list and _by_kind_rows made arrays of the lists again.  Arrays and lists of the same
values must give the same rows and by-kind sums, bit for bit (odd values, short and long
columns, a column that is not float64)."""
import math
import random
import struct

import numpy as np
import pytest

from gcode_opt import summary as sm
from gcode_opt.strokes import Stroke


def _bits(x):
    if isinstance(x, float):
        return struct.pack("<d", x)
    if isinstance(x, dict):
        return {k: _bits(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_bits(v) for v in x]
    return x


def _stroke(rng, kind):
    s = Stroke.__new__(Stroke)
    if kind is not None:              # (none: _kind_of's "line")
        s.kind = kind
    s.length_d, s.v0, s.v1, s.v_feed = (rng.uniform(0.1, 90.0) for _ in range(4))
    s.layer, s.feature = rng.randrange(5), rng.choice(("sparse_infill", "perimeter"))
    s.first_idx = s.last_idx = rng.randrange(10 ** 5)
    return s


def _both(n, seed, dtype=np.float64):
    rng = random.Random(seed)
    odd = [math.nan, math.inf, -math.inf, -0.0, 0.0, 5e-324, 1e308]
    ss = [_stroke(rng, rng.choice(("line", "curve", "arc", None))) for _ in range(n)]
    cols = [np.array([rng.choice(odd) if rng.random() < 0.03 else rng.uniform(-1, 1) * 10 ** rng.randrange(-8, 4)
                      for _ in range(n)], dtype) for _ in range(7)]
    idx = list(range(n))
    out_first = np.arange(n, dtype=np.int64) * 3
    got = {}           # (arrays given, rows asked for) -> (rows, by_kind) as bits
    for as_arrays in (True, False):
        for rows in ([], None):
            c = cols if as_arrays else [x.tolist() for x in cols]
            of = out_first if as_arrays else out_first.tolist()
            by_kind = {}
            sm._per_stroke_rows(idx, of, *c, ss, rows, by_kind)
            got[as_arrays, rows is not None] = (_bits(rows), _bits(by_kind))
    return got


@pytest.mark.parametrize("n", [3, 64, 65, 700])
@pytest.mark.parametrize("seed", range(2))
def test_arrays_give_the_lists_rows_and_sums(n, seed):
    got = _both(n, seed)
    for rows in (True, False):
        assert got[True, rows] == got[False, rows]
    rows, by_kind = got[True, True]
    assert len(rows) == n and got[True, False][0] is None     # rows made where asked, none where not
    assert got[True, False][1] == by_kind
    assert sum(g["retimed"] for g in by_kind.values()) == n


def test_a_column_not_float64():
    """float32 columns: the values their tolist() gives, by either way."""
    got = _both(200, 5, np.float32)
    for rows in (True, False):
        assert got[True, rows] == got[False, rows]
