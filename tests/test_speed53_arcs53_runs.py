"""Arcs and curves row-own in the budget runs (issue 8, arcs53): a circle law, its knots and
its peak speed are each arc's own, whatever else is in its batch, so schedule._by_windows
segments arcs and curves a window at a time without the one-batch fallback, Newton or not:
- circle._newton_cheb: each arc's steps its own (_mm_ordered and row sums, not a BLAS
  product that rounds with the batch's size);
- arcs.arc_knots: each arc evaluated at its own n + 1 instants (not a grid padded to the
  batch's largest n: a BLAS product's element rounds with the number of columns).
(The short arcs' peak speed, CircleBatch.peak_speed on the batch's largest panel levels, is
polished by Newton to the same bits on any levels: 1200 random arcs at levels 3..10 and the
samples' arcs, benchmarks/arcs53.md.)
Run compiled and with GCODE_OPT_PURE_PYTHON=1."""
import numpy as np
import pytest

from gcode_opt import arcs
from gcode_opt import schedule as sc
from gcode_opt.laws import circle
from gcode_opt.strokes import K_ARC, K_CURVE

from test_speed33_mem_circle import _arcs
from test_speed52_runs52_rowown import _partitions, _rows, _segments
from test_speed52_runs52_windows import plan_bits, runs

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


def _arc_strokes():
    """A few of concentric_arcs' arc strokes, (T, beta) from its runs' laws."""
    from test_speed52_runs52_rowown import _fresh, _laws
    T, beta, idx = _laws("prusa_concentric_arcs.gcode", "prusa-mk3s")
    strokes, pin = _fresh("prusa_concentric_arcs.gcode", "prusa-mk3s")[:2]
    rows = np.array([i for i in idx.tolist() if strokes[i].kind == K_ARC and np.isfinite(beta[i])])
    return [strokes[i] for i in rows.tolist()], T[rows], beta[rows]


def test_arc_knots_are_each_arcs_own():
    """arc_knots of arcs with n from 2 to 9 in one batch and each alone: the same knots."""
    sts, T, beta = _arc_strokes()
    n = 2 + np.arange(len(sts)) % 8
    whole = arcs.arc_knots(sts, T, beta, n)
    for i in range(len(sts)):
        s, v = arcs.arc_knots([sts[i]], T[i:i + 1], beta[i:i + 1], n[i:i + 1])[0]
        assert s.tobytes() == whole[i][0].tobytes() and v.tobytes() == whole[i][1].tobytes()


@pytest.mark.parametrize("kind,name,prof_name", [
    (K_ARC, "prusa_concentric_arcs.gcode", "prusa-mk3s"),
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


@pytest.mark.parametrize("window", [pytest.param(1, marks=pytest.mark.slow), 37])
def test_windowed_runs_are_the_one_call_plan(window, monkeypatch):
    """concentric_arcs (arcs that go to Newton): the stored runs at windows of 1 and 37
    strokes (candidates and segments by windows) give the plan of one call over the list,
    and no circle kind went to one batch."""
    monkeypatch.setattr(sc, "WINDOW_KINDS", (K_ARC, K_CURVE) + tuple(sc.WINDOW_KINDS))
    ref = plan_bits(runs("prusa_concentric_arcs.gcode", "prusa-mk3s", 10 ** 9, stored=False))
    b0, n0 = sc.WHOLE_BATCHES[0], circle.NEWTON_ARCS[0]
    got = plan_bits(runs("prusa_concentric_arcs.gcode", "prusa-mk3s", window))
    assert circle.NEWTON_ARCS[0] > n0 and sc.WHOLE_BATCHES[0] == b0
    assert got == ref


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
