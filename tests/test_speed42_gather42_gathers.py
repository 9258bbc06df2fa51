"""Session 42 (gather42): gathers and scatters made with fewer steps give the values of the
indexing they replace, bit for bit: distinct._row_hashes without its zeroed start,
Candidates.piece's entries by one flatnonzero and in-place takes (not a compress a table),
chains._Table.put's flat scatters, _Spread's takes and chains._at."""
import numpy as np
import pytest

from gcode_opt import chains, distinct
from gcode_opt.plan import T_RATIOS, Candidates


def _row_hashes_ref(cols):
    """distinct._row_hashes as it was: a zeroed hash mixed with every column."""
    m, w = cols[0].shape[0], len(cols)
    mult = (np.arange(1, w + 1, dtype=np.uint64) * np.uint64(0x9E3779B97F4A7C15)) | np.uint64(1)
    h = np.zeros(m, np.uint64)
    for j, c in enumerate(cols):
        x = c.view(np.uint64) * mult[j]
        h ^= x ^ (x >> np.uint64(29))
        h *= np.uint64(0xBF58476D1CE4E5B9)
    return h


@pytest.mark.parametrize("w", [1, 2, 5])
@pytest.mark.parametrize("m", [0, 1, 7, 1000])
def test_row_hashes_as_from_zero(w, m):
    rng = np.random.default_rng(m * 10 + w)
    B = rng.integers(-(1 << 62), 1 << 62, (m, w + 1))
    cols = [B[:, j] for j in range(w)]                  # strided columns, as segments.py hands them
    cols[0] = np.ascontiguousarray(cols[0])
    got = distinct._row_hashes(cols)
    assert got.dtype == np.uint64 and got.shape == (m,)
    np.testing.assert_array_equal(got, _row_hashes_ref(cols))
    # the classes follow from the hashes: the same as before
    if m:
        np.testing.assert_array_equal(distinct.column_classes(cols),
                                      distinct.column_classes([c.copy() for c in cols]))


def _piece_ref(sub, tables, T_orig):
    """Candidates.piece's vals as the compress of each table had them (t[mask] row-major)."""
    _, mask, _, _, _ = Candidates.piece(sub, tables, T_orig)
    return np.stack([np.asarray(x, float)[mask] for x in tables]), mask


@pytest.mark.parametrize("seed", range(6))
def test_piece_vals_are_the_masked_entries(seed):
    rng = np.random.default_rng(seed)
    n, k = int(rng.integers(0, 60)), T_RATIOS.size
    T_orig = rng.random(n + 5) + 0.1
    sub = np.sort(rng.choice(n + 5, n, replace=False))
    t = T_orig[sub, None] * T_RATIOS[None, :]
    b = rng.random((n, k))
    i = np.where(rng.random((n, k)) < 0.5, rng.random((n, k)), np.inf)
    ke = rng.random((n, k))
    # the odd ones: a non-finite T (bad row), a NaN beta, a finite I with a NaN KE, -0.0
    if n > 3:
        t[0, 3] = np.inf
        b[1, 2] = np.nan
        ke[2, 5] = np.nan
        i[3, 4] = -0.0
    tabs = (t, b, i, ke)
    if seed % 2:
        tabs = tuple(np.asfortranarray(x) for x in tabs)   # (not C-contiguous: ravel copies)
    got = Candidates.piece(sub, tabs, T_orig)
    ref, mask = _piece_ref(sub, tabs, T_orig)
    assert got[2].shape == ref.shape
    np.testing.assert_array_equal(got[2].view(np.int64), ref.view(np.int64))
    np.testing.assert_array_equal(got[1], mask)


@pytest.mark.parametrize("seed", range(4))
def test_table_put_as_2d_fancy_assignments(seed):
    rng = np.random.default_rng(seed)
    n, k = int(rng.integers(1, 50)), 5
    T = rng.random((n, k))
    if seed % 2:
        T = np.asfortranarray(T)               # (the table's tp is C order whatever T's)
    tab, ref = chains._Table(n, k, T), chains._Table(n, k, T)
    for _ in range(3):
        q = rng.choice(n * k, int(rng.integers(0, n * k)), replace=False)
        J, C = q // k, q % k
        tp, ia, iv = rng.random(q.size), rng.random(q.size), rng.random(q.size)
        tab.put(J, C, tp, ia, iv)
        ref.ok[J, C], ref.tp[J, C], ref.ia[J, C], ref.iv[J, C] = True, tp, ia, iv
    for f in ("ok", "tp", "ia", "iv"):
        a, b = getattr(tab, f), getattr(ref, f)
        np.testing.assert_array_equal(a.view(np.uint8), b.view(np.uint8))


def test_at_is_the_2d_fancy_index():
    rng = np.random.default_rng(3)
    A = rng.random((7, 40))
    rows, cols = rng.integers(0, 7, (30, 1)), rng.integers(0, 40, (30, 6))
    np.testing.assert_array_equal(chains._at(A, rows, cols), A[rows, cols])
    np.testing.assert_array_equal(chains._at(A.T.copy().T, rows, cols), A[rows, cols])
    B = rng.random((5, 5)) < 0.5
    r, c = rng.integers(0, 5, 9), rng.integers(0, 5, 9)
    np.testing.assert_array_equal(chains._at(B, r, c), B[r, c])


class _Laws:
    """What _Spread reads of a FlatLaws."""

    def __init__(self, rng, m):
        self.conv = rng.random(m) < 0.5
        self.iv, self.peak_v, self.min_v = rng.random(m), rng.random(m), rng.random(m)
        self.piece_off = np.concatenate([[0], np.cumsum(rng.integers(1, 5, m))]).astype(np.int64)
        self.piece_T = rng.random(int(self.piece_off[-1]))


def test_spread_fields_are_the_gathers():
    rng = np.random.default_rng(5)
    r = _Laws(rng, 30)
    pos = np.sort(rng.integers(0, 30, 50))
    sp = chains._Spread(r, None, pos, None)
    for f in ("conv", "iv", "peak_v", "min_v"):
        a = getattr(sp, f)
        assert a.dtype == getattr(r, f).dtype
        np.testing.assert_array_equal(a, getattr(r, f)[pos])
    np.testing.assert_array_equal(sp.piece_at, r.piece_off[pos])
    np.testing.assert_array_equal(sp.piece_n, r.piece_off[pos + 1] - r.piece_off[pos])
    assert sp.piece_T is r.piece_T


@pytest.mark.parametrize("w", [0, 1, 2, 5, 8, 9, 13])
@pytest.mark.parametrize("many", [False, True])
def test_row_ranges_and_plus_rows_as_broadcasts(w, many):
    # (many: at least ROW_RANGE_ROWS rows, the column-by-column path; s62)
    rng = np.random.default_rng(w)
    start = rng.integers(-(1 << 40), 1 << 40, int(rng.integers(0, 50)) + (chains.ROW_RANGE_ROWS if many else 0))
    got = chains._row_ranges(start, w)
    want = start[:, None] + np.arange(w)
    assert got.dtype == want.dtype and got.shape == want.shape
    np.testing.assert_array_equal(got, want)
    x = rng.integers(-(1 << 40), 1 << 40, (start.size, w))
    want = x + start[:, None]
    got = chains._plus_rows(x.copy(), start)
    assert got.dtype == want.dtype and got.shape == want.shape
    np.testing.assert_array_equal(got, want)
    # not int64: the broadcasts themselves
    np.testing.assert_array_equal(chains._row_ranges(start.astype(np.int32), w),
                                  start.astype(np.int32)[:, None] + np.arange(w))
