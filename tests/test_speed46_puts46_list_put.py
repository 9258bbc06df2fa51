"""objfields.put_at / fill_at (the curve core's list_put) against the Python loops they
replaced in schedule.py's row writes: the same items, and on a row out of range the same
IndexError after the same rows written."""
import numpy as np
import pytest

from gcode_opt import objfields, schedule

pytestmark = pytest.mark.skipif(objfields._LIST_PUT is None, reason="curve core not built")


def _loop_put(dst, rows, src, at=None):
    """The replaced loop: dst[i] = src[j] row by row (at None: src in order)."""
    at = range(len(rows)) if at is None else at.tolist()
    for i, j in zip(rows.tolist(), at):
        dst[i] = src[j]


def _both(fn_new, fn_ref, n_dst):
    """(list, error) after each way on fresh lists of distinct objects."""
    out = []
    for fn in (fn_new, fn_ref):
        dst = [("old", k) for k in range(n_dst)]
        err = None
        try:
            fn(dst)
        except IndexError as e:
            err = (type(e), str(e))
        out.append((dst, err))
    return out


@pytest.mark.parametrize("seed", range(20))
def test_put_at_same_as_loop(seed):
    rng = np.random.default_rng(seed)
    n_dst, n = int(rng.integers(1, 60)), int(rng.integers(0, 80))
    lo, hi = (-n_dst, n_dst) if seed % 3 else (-n_dst - 3, n_dst + 3)    # some out of range
    rows = rng.integers(lo, hi, n).astype(np.intp)                     # repeats and negatives
    src = [("new", k) for k in range(n)]
    (a, ea), (b, eb) = _both(lambda d: objfields.put_at(d, rows, src), lambda d: _loop_put(d, rows, src), n_dst)
    assert ea == eb and a == b


@pytest.mark.parametrize("seed", range(20))
def test_put_at_from_rows_same_as_loop(seed):
    rng = np.random.default_rng(100 + seed)
    n_dst, n_src, n = int(rng.integers(1, 50)), int(rng.integers(1, 50)), int(rng.integers(0, 80))
    pad = 0 if seed % 3 else 2
    rows = rng.integers(-n_dst - pad, n_dst + pad, n).astype(np.intp)
    at = rng.integers(-n_src - pad, n_src + pad, n).astype(np.intp)
    src = [("src", k) for k in range(n_src)]
    (a, ea), (b, eb) = _both(lambda d: objfields.put_at(d, rows, src, at),
                             lambda d: _loop_put(d, rows, src, at), n_dst)
    assert ea == eb and a == b


def test_put_at_into_itself():
    rows, at = np.array([0, 1, 2], np.intp), np.array([2, 0, 1], np.intp)
    a, b = list("xyz"), list("xyz")
    objfields.put_at(a, rows, a, at)
    _loop_put(b, rows, b, at)
    assert a == b


def test_fill_at_same_as_loop():
    rows = np.array([3, -1, 3, 0, 9], np.intp)
    (a, ea), (b, eb) = _both(lambda d: objfields.fill_at(d, rows, None),
                             lambda d: [d.__setitem__(i, None) for i in rows.tolist()], 6)
    assert ea == eb and a == b and ea is not None


def test_not_taken_where_types_differ():
    dst = [0] * 4
    assert not objfields.put_at(dst, np.array([1, 2], np.int32), [5, 6])       # not intp
    assert not objfields.put_at(dst, np.array([1, 2]), [5, 6, 7])              # not as long
    assert not objfields.put_at(dst, np.array([1, 2]), (5, 6))                 # not a list
    assert not objfields.put_at(dst, np.array([3, 2, 1])[::2], [5, 6])         # not contiguous
    assert dst == [0] * 4


def test_schedule_helpers_same_as_loops():
    rng = np.random.default_rng(7)
    rows = rng.integers(0, 30, 50).astype(np.intp)
    src = [("p", k) for k in range(50)]
    a, b = [None] * 30, [None] * 30
    schedule._put_at(a, rows, src)
    _loop_put(b, rows, src)
    assert a == b
    got = {int(i): ("g", int(i)) for i in rng.integers(0, 30, 12)}
    schedule._put_rows(a, got)
    for i, v in got.items():
        b[i] = v
    assert a == b
    at = rng.integers(0, 50, 50).astype(np.intp)
    schedule._copy_at(a, rows, src, at)
    _loop_put(b, rows, src, at)
    assert a == b
    schedule._clear_at(a, rows[:10])
    for i in rows[:10].tolist():
        b[i] = None
    assert a == b


def _loop_take(src, rows):
    """The replaced _items: the items at rows, one by one."""
    return [src[i] for i in rows.tolist()]


@pytest.mark.parametrize("seed", range(12))
def test_take_same_as_loop(seed):
    rng = np.random.default_rng(200 + seed)
    n_src, n = int(rng.integers(1, 50)), int(rng.integers(0, 80))
    pad = 0 if seed % 3 else 2
    rows = rng.integers(-n_src - pad, n_src + pad, n).astype(np.intp)
    src = [("s", k) for k in range(n_src)]
    got = []
    for fn in (objfields.take, _loop_take, lambda s, r: schedule._take(s, r)):
        try:
            got.append(fn(src, rows))
        except IndexError as e:
            got.append((type(e), str(e)))
    assert got[0] == got[1] == got[2]
    assert objfields.take(src, rows.astype(np.int32)) is None
