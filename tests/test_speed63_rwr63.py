"""The windowed rewrite's reads (issue 8, rwr63): each helper that replaced a numpy idiom in
the rewrite's windows (line_spill.LineSpill.take, schedule._PlansAgain, the spills' reads,
HeldRows.hold) gives what the idiom gave, on random and edge-case inputs:
line_spill._places is distinct(at[k]) and its searchsorted; line_spill._rows_at is the 2-D
index gather; schedule._in_codes is np.isin; schedule._ascending and HeldRows' rows are
distinct(rows); schedule._are_none is the is-None test; SpillFile.read_runs reads by preadv
what the join of its preads read; schedule._record_blocks cuts the blocks lexsort's order
cut; and LineSpill.take answers as before when a hash is shared by two keys."""

import numpy as np
import pytest

from gcode_opt import line_spill as ls
from gcode_opt import schedule as sc
from gcode_opt import spill_file as sf
from gcode_opt.distinct import distinct

RNG = np.random.default_rng(63)


@pytest.mark.parametrize("n", [1, 7, 500])
def test_places_is_distinct_and_search(n):
    at = RNG.permutation(10 * n)[:n].astype(np.int64) * 3          # (the records' firsts: distinct)
    k = RNG.integers(0, n, 4 * n)
    u_k, which = ls._places(k, n, at)
    hat = at[k]
    u = distinct(hat)
    assert np.array_equal(at[u_k], u)
    assert np.array_equal(which, np.searchsorted(u, hat))


@pytest.mark.parametrize("width", [1, 3, 46])
def test_rows_at_is_the_gather(width):
    buf = RNG.random(400)
    start = np.sort(RNG.choice(400 - width + 1, 30, replace=False)).astype(np.int64)
    want = buf[start[:, None] + np.arange(width)]
    got = ls._rows_at(buf, start, width)
    assert got.dtype == want.dtype and np.array_equal(got, want)
    got[:] = 0.0                           # (a copy: the buffer is not written)
    assert np.array_equal(buf[start[:, None] + np.arange(width)], want)
    ro = np.frombuffer(buf.tobytes(), float)          # (read-only, as a pread's bytes give it)
    assert np.array_equal(ls._rows_at(ro, start, width), want)
    assert np.array_equal(ls._rows_at(buf[::2], start[start < 200 - width], width),
                          buf[::2][start[start < 200 - width][:, None] + np.arange(width)])


@pytest.mark.parametrize("kind, codes", [
    (np.array([0, 1, 2, 3, 1, 0]), [0, 3]), (np.array([0, 1, 2, 3]), [3, 0]), (np.array([], np.int64), [1]),
    (np.array([5, -1, 2]), [5, 2]), (np.array([1, 2]), []), (np.array([0, 300, 2]), [300, 2]),
    (np.array([1.0, 2.0]), [1])])
def test_in_codes_is_isin(kind, codes):
    assert np.array_equal(sc._in_codes(kind, codes), np.isin(kind, codes))


@pytest.mark.parametrize("rows", [[], [4], [1, 2, 9], [3, 3, 4], [5, 2, 7], [2, 1]])
def test_ascending_is_distinct(rows):
    rows = np.array(rows, np.int64)
    assert np.array_equal(sc._ascending(rows), distinct(rows))


def test_are_none():
    p = object()
    for objs in ([], [None] * 5, [None, p, None], [p, p], [0, None, False, ""]):
        assert np.array_equal(sc._are_none(list(objs)), np.array([o is None for o in objs], bool))


def test_hold_rows_any_order(tmp_path):
    """HeldRows.hold's rows: ascending ones as given, others sorted and made distinct; the
    slots of the rows held before let go, and the held rows not the caller's array."""
    from gcode_opt.stored_strokes import HeldRows

    class Store:
        def __len__(self):
            return 10

        def take(self, rows):
            return [("stroke", int(r)) for r in rows]
    h = HeldRows(Store(), 4)
    rows = np.array([1, 4, 6], np.int64)
    h.hold(rows)
    rows[0] = 9                           # (the caller's array changed after: not the held rows)
    assert [i for i, s in enumerate(h.slots) if s is not None] == [1, 4, 6]
    h.hold(np.array([8, 2, 8], np.int64))
    assert h.slots == [None, None, ("stroke", 2), None, None, None, None, None, ("stroke", 8), None]


def _spill(tmp_path, data):
    fh = open(tmp_path / "spill", "w+b", buffering=0)
    f = sf.SpillFile(fh)
    f.append(np.asarray(data, float), 1 << 40)
    return f


def test_read_runs_by_preadv_is_the_join(tmp_path, monkeypatch):
    data = RNG.random(5000)
    f = _spill(tmp_path, data)
    a = np.array([3, 40, 41 + 2, 900, 4000], np.int64)
    z = a + np.array([10, 2, 30, 7, 1000])
    for cut in (np.array([], np.intp), np.array([2, 3], np.intp), np.arange(1, 5)):
        got = f.read_runs(a, z, cut, "test")
        monkeypatch.setattr(sf, "_PREADV", None)
        want = f.read_runs(a, z, cut, "test")
        monkeypatch.undo()
        assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
        for s, lo, hi in zip(got[1], a, z):
            assert np.array_equal(got[0][s:s + hi - lo], data[lo:hi])
    with pytest.raises(OSError):                    # (past the file's end: cut short, as before)
        f.read_runs(np.array([4990], np.int64), np.array([5010], np.int64), np.array([], np.intp), "test")
    f.close()


def _record_blocks_lexsort(buf, start, ns):
    """_record_blocks as it was (lexsort's order)."""
    o = np.lexsort((start, ns))
    lens = sc._spill_len(ns[o])
    cut = np.flatnonzero((ns[o][1:] != ns[o][:-1]) | (start[o][1:] != start[o][:-1] + lens[:-1])) + 1
    out = []
    for a, z in zip([0] + cut.tolist(), cut.tolist() + [o.size]):
        n, L, s0 = int(ns[o[a]]), int(lens[a]), int(start[o[a]])
        out.append((o[a:z], buf[s0:s0 + (z - a) * L].reshape(z - a, L), n))
    return out


def test_record_blocks_as_lexsort():
    ns = RNG.integers(1, 5, 60).astype(np.int64)
    lens = sc._spill_len(ns)
    gaps = RNG.integers(0, 2, 60) * 3               # (runs of consecutive records, and gaps)
    start = np.cumsum(lens + gaps) - lens - gaps
    perm = RNG.permutation(60)                      # (the rows' order: not the file's)
    buf = RNG.random(int(start[-1] + lens[-1]) + 5)
    got = sc._record_blocks(buf, start[perm], ns[perm])
    want = _record_blocks_lexsort(buf, start[perm], ns[perm])
    assert len(got) == len(want)
    for (g1, b1, n1), (g2, b2, n2) in zip(got, want):
        assert n1 == n2 and np.array_equal(g1, g2) and np.array_equal(b1, b2)


def test_line_take_hash_twin(tmp_path, monkeypatch):
    """Two keys of one hash: the row whose key is the record's gets its plan, the other is
    the caller's (the keys compared bit for bit, column by column)."""
    from gcode_opt.segments import RowPlan
    spill = ls.LineSpill(open(tmp_path / "lines", "w+b", buffering=0))
    monkeypatch.setattr(ls, "_key_hash", lambda cls, T, beta: np.zeros(np.asarray(cls).size, np.uint64))
    S, V = np.array([[0.0, 1.0, 2.0]]), np.array([[0.0, 3.0, 0.0]])
    A, F = np.array([[1.0, -1.0]]), np.array([[60.0, 60.0]])
    p = RowPlan(S, V, A, F, 0, 1.5, 2.0)
    spill.put([p], np.array([7]), np.array([1.0]), np.array([0.5]))
    rows = np.array([2, 3, 5], np.int64)
    got, plans, rest = spill.take(rows, np.array([7, 7, 8]), np.array([1.0, 1.0, 1.0]), np.array([0.5, -0.0, 0.5]))
    assert got.tolist() == [2] and rest.tolist() == [3, 5]
    assert len(plans) == 1 and plans[0].time_t == 1.5 and np.array_equal(plans[0].s, S[0])
    spill.close()


def _record_plans_before(G, n, head, cols, shapes):
    """spill_file.record_plans as it was (each SegmentPlan's rows indexed and copied)."""
    from itertools import compress
    from gcode_opt.segments import RowPlan, SegmentPlan
    c_t, c_a2, c_kind, c_fine, c_shape = cols
    S, V = G[:, head:head + n + 1], G[:, head + n + 1:head + 2 * n + 2]
    A, F = G[:, head + 2 * n + 2:head + 3 * n + 2], G[:, head + 3 * n + 2:]
    t, a2, kind = G[:, c_t].tolist(), G[:, c_a2].tolist(), G[:, c_kind]
    shape = G[:, c_shape]
    sh = [shapes[int(c)] for c in shape.tolist()]
    plans = [RowPlan(S, V, A, F, i, t[i], a2[i], sh[i]) if kind[i] == 0.0
             else SegmentPlan(S[i].copy(), V[i].copy(), A[i].copy(), F[i].copy(), t[i], a2[i], sh[i])
             for i in range(G.shape[0])]
    for p in compress(plans, G[:, c_fine].tolist()):
        p.fault = ""
    return plans


@pytest.mark.parametrize("kinds", [[1, 1, 1], [0, 1, 0, 1, 1], [1], [0, 0]])
def test_record_plans_segment_rows(kinds):
    """SegmentPlans made of row views of one copy: the same type, numbers, figures, shape and
    verdict as the copies a row; their arrays apart from G (G written after: unchanged)."""
    n, head = 3, ls.HEAD
    m = len(kinds)
    G = RNG.random((m, ls.record_len(n)))
    G[:, 5] = kinds                       # (the type: 1.0 a SegmentPlan)
    G[:, 6] = RNG.integers(0, 2, m)       # (the verdict)
    G[:, 7] = [0, 1] * (m // 2) + [0] * (m % 2)    # (the shape)
    cols = (3, 4, 5, 6, 7)
    got = sf.record_plans(G.copy(), n, head, cols, ls._SHAPES)
    want = _record_plans_before(G.copy(), n, head, cols, ls._SHAPES)
    for p, q in zip(got, want):
        assert type(p) is type(q) and (p.time_t, p.int_a2, p.shape, p.fault) == (q.time_t, q.int_a2, q.shape, q.fault)
        for f in ("s", "v", "accel", "feed"):
            x, y = getattr(p, f), getattr(q, f)
            assert x.dtype == y.dtype and x.flags.c_contiguous and x.tobytes() == y.tobytes()
    G2 = G.copy()
    got = sf.record_plans(G2, n, head, cols, ls._SHAPES)
    G2[:] = -1.0
    for p, q in zip(got, want):
        if type(p).__name__ == "SegmentPlan":
            assert p.s.tobytes() == q.s.tobytes() and p.feed.tobytes() == q.feed.tobytes()


def test_line_take_some_rows_unrecorded(tmp_path):
    """Rows whose key has no record are the caller's (the masked path), the others get their
    record's plan; all rows recorded: the rows themselves, none left."""
    from gcode_opt.segments import RowPlan
    spill = ls.LineSpill(open(tmp_path / "lines", "w+b", buffering=0))
    S, V = np.array([[0.0, 1.0, 2.0]]), np.array([[0.0, 3.0, 0.0]])
    A, F = np.array([[1.0, -1.0]]), np.array([[60.0, 60.0]])
    spill.put([RowPlan(S, V, A, F, 0, 1.5, 2.0)], np.array([7]), np.array([1.0]), np.array([0.5]))
    rows = np.array([2, 3, 5], np.int64)
    got, plans, rest = spill.take(rows, np.array([7, 9, 7]), np.array([1.0, 1.0, 1.0]), np.array([0.5, 0.5, 0.5]))
    assert got.tolist() == [2, 5] and rest.tolist() == [3] and plans[0] is plans[1]
    got, plans, rest = spill.take(rows, np.array([7, 7, 7]), np.array([1.0, 1.0, 1.0]), np.array([0.5, 0.5, 0.5]))
    assert got.tolist() == [2, 3, 5] and rest.size == 0 and len(plans) == 3
    assert np.array_equal(plans[2].feed, F[0]) and plans[2].time_t == 1.5
    spill.close()
