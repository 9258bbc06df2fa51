"""Issue 8 (s34, planrect: the rectilinear plate's planning memory).

Lines whose candidate inputs repeat share their entries (plan.SharedPiece): Candidates
holds the distinct inputs' entries once, each row pointing at them by (first, cnt),
instead of a copy a row (the rectilinear plate: ~12 MB of entries, and as much again
while they were spread and merged).  Checked against the candidates made of every row
(plan.candidate_pieces: each row's own entries, the reference):
- the dense tables, bit for bit, and the fewer entries held;
- plan_auto's plans at several budgets, bit for bit, by the compiled allocation (its
  rows_view on shared entries, also for groups that leave out rows whose entries other
  rows share) and by numpy's (USE_CORE off: allocation_tables' positions);
- Candidates.at, and a mix of own pieces (curves, chains) and a shared one, with bad rows.
distinct.column_classes (line_classes' classes, made column by column where the columns
are) against row_classes as it was (e1bafc4: on one table, its rows compared at once), and
plan._same_inputs by it against its np.unique of the rows' bytes (e1bafc4).
"""
import os

import numpy as np
import pytest

from gcode_opt import plan as plan_mod
from gcode_opt import schedule as sc
from gcode_opt import segments as sg
from gcode_opt.distinct import column_classes
from gcode_opt.pipeline import Options, analyse
from gcode_opt.plan import Candidates, SharedPiece
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_LINE

S = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "sample_gcode")


def _lines(name, profile="prusa-mk3s", repeat=3):
    """The PlanInput of a sample's lines, each row repeated (the samples' lines repeat
    too little to share), and its originals' figures."""
    prof = load_profile(profile)
    opts = Options()
    strokes, _ = analyse(os.path.join(S, name), prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    rows = np.array([i for i in sc._rows_by_kind(strokes)[K_LINE] if not pin.fault[i]], int)
    p = pin.take(np.repeat(rows, repeat))
    return p


def _both(p):
    """(shared, own): the Candidates of p's rows with repeated inputs shared, and made
    row by row."""
    rows = np.arange(len(p.L))
    shared = plan_mod.pieces_once(plan_mod.candidate_pieces, p, rows, p.T_orig)
    assert [type(pc) for pc in shared] == [SharedPiece]
    own = plan_mod.candidate_pieces(p, rows, p.T_orig)
    a, bad_a = Candidates.of_pieces(len(rows), shared, p.T_orig)
    b, bad_b = Candidates.of_pieces(len(rows), own, p.T_orig)
    assert np.array_equal(bad_a, bad_b)
    return a, b


def _bits(x):
    return np.ascontiguousarray(x, float).view(np.int64)


@pytest.fixture(scope="module")
def rect():
    return _lines("prusa_mk3s_rectilinear.gcode")


def test_shared_entries_same_tables_fewer_entries(rect):
    a, b = _both(rect)
    for x, y in zip(a, b):
        assert np.array_equal(_bits(x), _bits(y))
    assert np.array_equal(a.mask, b.mask) and np.array_equal(a.t_pos, b.t_pos) and np.array_equal(a.cnt, b.cnt)
    first, _ = plan_mod._same_inputs(rect)
    assert a.vals.shape[1] == int(b.cnt[first].sum()) < b.vals.shape[1] // 2
    rows = np.flatnonzero(a.cnt > 0)[::7]
    cols = np.array([np.flatnonzero(a.mask[r])[-1] for r in rows])
    assert np.array_equal(_bits(a.at(rows, cols)), _bits(b.at(rows, cols)))


def _plans_equal(x, y):
    assert np.float64(x.lam).tobytes() == np.float64(y.lam).tobytes()
    assert np.array_equal(x.retime, y.retime) and list(x.reason) == list(y.reason)
    for f in ("T", "beta", "I_law", "KE_law"):
        assert np.array_equal(_bits(getattr(x, f)), _bits(getattr(y, f))), f


@pytest.mark.parametrize("use_core", [True, False])
def test_shared_entries_same_plans(rect, use_core, monkeypatch):
    monkeypatch.setattr(plan_mod, "USE_CORE", use_core)
    a, b = _both(rect)
    n = len(rect.L)
    every = np.arange(n)
    # a group without the first row of each repeated set (its entries are still held for
    # the others: rows_view's check takes the entries the rows point at, not every one)
    first, inv = plan_mod._same_inputs(rect)
    out = np.zeros(n, bool)
    out[first[::2]] = True
    out[np.arange(5, n, 11)] = True
    partial = [every[~out], every[out]]
    total_t = float(rect.T_orig.sum())
    for groups in ([every], partial):
        for r in (0.0, 0.01, 0.05, 0.2):
            _plans_equal(plan_mod.plan_auto(rect, r * total_t, a, groups),
                         plan_mod.plan_auto(rect, r * total_t, b, groups))
    if use_core:
        rv = a.rows_view(every[~out], rect.T_orig[~out], rect.I_orig[~out])
        assert rv is not None and np.array_equal(rv.cnt, b.cnt[~out])


def test_shared_and_own_pieces_together(rect):
    """A table of own pieces (as curves' and chains' are) beside a shared one, with a row
    whose candidates are not finite in each: the dense tables and bad rows of every row
    made on its own."""
    n = len(rect.L)
    lines = np.arange(0, n - 40)
    others = np.arange(n - 40, n)
    p = rect.take(lines)
    made = plan_mod.pieces_once(plan_mod.candidate_pieces, p, lines, rect.T_orig)
    T, beta, I, KE = plan_mod.candidates_auto(rect.take(others))
    I = I.copy()
    I[3, np.flatnonzero(np.isfinite(I[3]))[:1]] = np.nan        # its row is bad
    own_piece = Candidates.piece(others, (T, beta, I, KE), rect.T_orig)
    sh = made[0]
    bad_u = sh.bad.copy()
    bad_u[sh.inv[10]] = True                                     # a shared set is bad: all its rows
    sh = sh._replace(bad=bad_u)
    a, bad_a = Candidates.of_pieces(n, [sh, own_piece], rect.T_orig)
    ref = plan_mod.candidate_pieces(p, lines, rect.T_orig)
    b, bad_b = Candidates.of_pieces(n, ref + [own_piece], rect.T_orig)
    assert bad_a.tolist() == sorted(set(bad_b.tolist()) | set(lines[sh.inv == sh.inv[10]].tolist()))
    for x, y in zip(a, b):
        assert np.array_equal(_bits(x), _bits(y))


def _row_classes_e1bafc4(B):
    m, w = B.shape
    mult = (np.arange(1, w + 1, dtype=np.uint64) * np.uint64(0x9E3779B97F4A7C15)) | np.uint64(1)
    U = B.view(np.uint64)
    h = np.zeros(m, np.uint64)
    for j in range(w):
        x = U[:, j] * mult[j]
        h ^= x ^ (x >> np.uint64(29))
        h *= np.uint64(0xBF58476D1CE4E5B9)
    _, first, inv = np.unique(h, return_index=True, return_inverse=True)
    inv = inv.ravel()
    out = inv.astype(np.int64)
    odd = np.flatnonzero((B != B[first[inv]]).any(axis=1))
    out[odd] = first.size + np.arange(odd.size)
    return out


@pytest.mark.parametrize("seed", range(4))
def test_column_classes_as_row_classes_was(seed):
    rng = np.random.default_rng(seed)
    m, w = 3000, 1 + seed * 5
    base = rng.integers(-5, 5, (40, w)).astype(np.int64)
    B = base[rng.integers(0, 40, m)]
    B[rng.integers(0, m, 50), rng.integers(0, w, 50)] = rng.integers(-2 ** 62, 2 ** 62, 50)
    want = _row_classes_e1bafc4(B)
    assert np.array_equal(sg.row_classes(B), want)
    F = np.asfortranarray(B)                   # columns of other strides
    assert np.array_equal(column_classes([F[:, j] for j in range(w)]), want)
    assert np.unique(want).size < m            # (classes of several rows)


def test_column_classes_collision_is_a_class_of_its_own(monkeypatch):
    """Rows whose hashes collide but differ are apart (the hash made constant)."""
    B = np.array([[1, 2], [1, 2], [3, 4], [1, 2], [3, 5]], np.int64)
    from gcode_opt import distinct              # every row the first's hash (session 37: the
    monkeypatch.setattr(distinct, "_row_hashes", lambda cols: np.zeros(cols[0].shape[0], np.uint64))
    got = column_classes([B[:, 0], B[:, 1]])     # hashes apart from np.unique, which no longer sorts them)
    assert got[0] == got[1] == got[3]
    assert len({got[0], got[2], got[4]}) == 3


def _same_inputs_e1bafc4(p):
    n = len(p.L)
    cols = (p.L, p.v0, p.v1, p.v_cap, p.a_cap, p.T_orig, p.t_seg_min)
    X = np.empty((n, len(cols)))
    for j, c in enumerate(cols):
        X[:, j] = c
    _, first, inv = np.unique(X.view(np.dtype((np.void, X.itemsize * len(cols)))).ravel(),
                              return_index=True, return_inverse=True)
    if first.size > plan_mod.SAME_MAX_R * n:
        return None
    order = np.argsort(first)
    place = np.empty_like(order)
    place[order] = np.arange(order.size)
    return first[order], place[inv.ravel()]


def test_same_inputs_as_by_np_unique(rect):
    p = rect.take(np.random.default_rng(1).permutation(len(rect.L)))
    got, want = plan_mod._same_inputs(p), _same_inputs_e1bafc4(p)
    assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
    # -0.0 and 0.0 apart (by their bytes), a last bit apart
    q = p.take(np.arange(len(p.L)))
    q.v0[:50] = np.where(q.v0[:50] == 0.0, -0.0, np.nextafter(q.v0[:50], np.inf))
    got, want = plan_mod._same_inputs(q), _same_inputs_e1bafc4(q)
    assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
    assert got[0].size > plan_mod._same_inputs(p)[0].size
    # too few repeats: none
    u = rect.take(plan_mod._same_inputs(rect)[0])
    assert plan_mod._same_inputs(u) is None and _same_inputs_e1bafc4(u) is None
