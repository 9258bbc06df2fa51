"""Arcs and curves row-own in the budget runs (issue 8, arcs53): a circle law, its knots and
its peak speed are each arc's own, whatever else is in its batch, so schedule._by_windows
segments arcs and curves a window at a time without the one-batch fallback, Newton or not:
- circle._newton_cheb: each arc's steps its own (_mm_ordered and row sums, not a BLAS
  product that rounds with the batch's size);
Run compiled and with GCODE_OPT_PURE_PYTHON=1."""
import numpy as np
import pytest

from gcode_opt import schedule as sc
from gcode_opt.laws import circle
from gcode_opt.strokes import K_CURVE

from test_speed33_mem_circle import _arcs
from test_speed52_runs52_rowown import _partitions, _rows, _segments

pytestmark = pytest.mark.skipif(not circle.rows_invariant(),
                                reason="this BLAS does not give rows their own bits: one batch (_by_windows)")


def _parts(nb, size, seed):
    """Every arc of nb once: in windows of size, in a shuffled order."""
    order = np.random.default_rng(seed).permutation(nb)
    return [np.sort(order[a:a + size]) for a in range(0, nb, size)]


def test_newton_is_each_arcs_own():
    """Steep arcs by Newton (from the constant start) in one batch, alone and in shuffled
    windows of 7: the same nodes, C and flags, bit for bit."""
    phi, gam2, u0, u1, _ = _arcs(3, 120, steep=True)
    n = 32
    w0 = np.repeat(phi[:, None], n + 1, axis=1)
    w, cc, ok = circle._newton_cheb(n, phi, gam2, u0, u1, w0)
    assert ok.sum() > 100
    for size in (1, 7):
        for r in _parts(phi.size, size, size):
            wr, ccr, okr = circle._newton_cheb(n, phi[r], gam2[r], u0[r], u1[r], w0[r])
            assert wr.tobytes() == w[r].tobytes() and ccr.tobytes() == cc[r].tobytes()
            assert np.array_equal(okr, ok[r])


@pytest.mark.parametrize("kind,name,prof_name", [
    pytest.param(K_CURVE, "prusa_benchy_like.gcode", "voron24", marks=pytest.mark.slow)])
def test_rows_are_their_own_with_newton(kind, name, prof_name):
    """The kind's re-timed rows segmented whole, in windows of 1, 5 and 64 rows and shuffled
    windows of 7: each row's plan the same bits, where Newton took part."""
    rows = _rows(kind, name, prof_name)
    ref, newton = _segments(kind, name, prof_name, [rows])
    assert newton > 0
    for how, parts in _partitions(rows):
        got, _ = _segments(kind, name, prof_name, parts)
        assert got == ref, how


def test_circle_kinds_in_one_batch_where_rows_are_not_their_own(monkeypatch):
    """_by_windows of a circle kind: windows, Newton or not; one batch where the BLAS does
    not give rows their own bits (circle.rows_invariant)."""
    calls = []

    def fn(r):
        calls.append(r.tolist())
        if 9 in r.tolist():
            circle.NEWTON_ARCS[0] += 1
        return r.tolist()
    rows = np.array([1, 2, 9, 10])
    assert sc._by_windows(fn, 1, True)(rows) == [1, 2, 9, 10] and calls == [[1], [2], [9], [10]]
    calls.clear()
    monkeypatch.setattr(circle, "rows_invariant", lambda: False)
    b0 = sc.WHOLE_BATCHES[0]
    assert sc._by_windows(fn, 1, True)(rows) == [1, 2, 9, 10] and calls == [[1, 2, 9, 10]]
    assert sc.WHOLE_BATCHES[0] == b0 + 1
    calls.clear()
    assert sc._by_windows(fn, 1, False)(rows) == [1, 2, 9, 10] and calls == [[1], [2], [9], [10]]
