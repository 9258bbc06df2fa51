"""Session 37 (numglue): distinct.unique_first_inverse, np.unique(h, return_index=True,
return_inverse=True)'s (first, inverse) by a sort of packed keys (top 32 bits, index), is
the same arrays as np.unique's, bit for bit and dtype for dtype, on varied keys: random,
repeated, negative int64, ones whose top 32 bits collide (in order and out of order: the
fallback), tiny and empty arrays."""
import numpy as np
import pytest

from gcode_opt import distinct
from gcode_opt.distinct import column_classes, column_classes_first, unique_first_inverse


def _ref(h):
    _, first, inv = np.unique(h, return_index=True, return_inverse=True)
    return first, inv.ravel()


def _check(h):
    got, want = unique_first_inverse(h), _ref(h)
    for g, w in zip(got, want):
        assert g.dtype == w.dtype and g.shape == w.shape and np.array_equal(g, w)


def _keys(rng, m, kind):
    if kind == "random":
        return rng.integers(0, 2 ** 64, m, dtype=np.uint64)
    if kind == "repeats":
        return rng.integers(0, 2 ** 64, max(1, m // 7), dtype=np.uint64)[rng.integers(0, max(1, m // 7), m)]
    if kind == "int64":
        return rng.integers(-2 ** 63, 2 ** 63, max(1, m // 3), dtype=np.int64)[rng.integers(0, max(1, m // 3), m)]
    if kind == "small_int64":
        return rng.integers(-3, 3, m).astype(np.int64)
    top = rng.integers(0, 4, m, dtype=np.uint64) << np.uint64(32)     # few top halves
    low = rng.integers(0, 5, m, dtype=np.uint64)
    if kind == "top_same_low_sorted":       # each top half one low value: in order
        return top | (top >> np.uint64(32))
    return top | low                        # "top_collide": bottoms out of order (fallback)


@pytest.mark.parametrize("kind", ["random", "repeats", "int64", "small_int64", "top_same_low_sorted", "top_collide"])
@pytest.mark.parametrize("m", [0, 1, 2, 3, 17, 1000, 50_000])
def test_unique_first_inverse_is_np_unique(kind, m):
    rng = np.random.default_rng(m * 7 + len(kind))
    h = _keys(rng, m, kind)
    _check(h)
    if m > 3:
        _check(h[::-2])                                      # strided
        _check(np.sort(h))                                   # sorted input
        _check(np.full(m, h[0]))                             # one key


@pytest.mark.parametrize("kind, fallback", [("random", False), ("repeats", False), ("int64", False),
                                            ("top_same_low_sorted", False), ("top_collide", True)])
def test_unique_first_inverse_falls_back_only_out_of_order(monkeypatch, kind, fallback):
    h = _keys(np.random.default_rng(1), 5000, kind)
    want = _ref(h)
    calls = []
    real = np.unique
    monkeypatch.setattr(np, "unique", lambda *a, **kw: calls.append(1) or real(*a, **kw))
    got = unique_first_inverse(h)
    assert bool(calls) == fallback
    assert all(np.array_equal(g, w) for g, w in zip(got, want))


def test_unique_first_inverse_other_dtypes_go_to_np_unique():
    x = np.array([3.0, -1.0, 3.0, 2.0])
    first, inv = unique_first_inverse(x)
    assert np.array_equal(first, [1, 3, 0]) and np.array_equal(inv, [2, 0, 2, 1])
    _check(np.array([[5, 1], [5, 2]], np.int64))             # 2-D: np.unique flattens


def test_column_classes_first_same_as_np_unique_way():
    """column_classes_first as it was (np.unique of the row hashes) on rows with repeats."""
    rng = np.random.default_rng(5)
    base = rng.integers(-4, 4, (60, 5)).astype(np.int64)
    B = base[rng.integers(0, 60, 20_000)]
    cols = [B[:, j] for j in range(B.shape[1])]
    h = distinct._row_hashes(cols)
    first, inv = _ref(h)
    out = inv.astype(np.int64)
    odd = np.flatnonzero((B != B[first[inv]]).any(axis=1))
    out[odd] = first.size + np.arange(odd.size)
    got_out, got_first = column_classes_first(cols)
    assert np.array_equal(got_out, out) and np.array_equal(got_first, np.concatenate([first, odd]))


def test_column_classes_collision_is_a_class_of_its_own_hash_patched(monkeypatch):
    """Rows whose hashes collide but differ are apart (every row's hash made the same)."""
    B = np.array([[1, 2], [1, 2], [3, 4], [1, 2], [3, 5], [3, 4]], np.int64)
    monkeypatch.setattr(distinct, "_row_hashes", lambda cols: np.zeros(cols[0].shape[0], np.uint64))
    got = column_classes([B[:, 0], B[:, 1]])
    assert got[0] == got[1] == got[3]
    assert len({got[0], got[2], got[4], got[5]}) == 4       # each odd row its own class
