"""Issue 8, session 46 (alloc46): the budget runs' list writes by row (schedule._put_rows,
_put_at, _copy_at, SegmentCache.forget_lines, _keep_plans' put) are Python loops storing
through the list-item opcode, not deque(map(list.__setitem__, ...)) (the method wrapper:
~570 instructions a row against ~190), and the reads by row (SegmentCache.lookup,
_RunMemo) one itemgetter (_items); Plan's reasons are made as _reasons makes them.  The
same lists and arrays: compared with 0b09fc6's code (verbatim copies below)."""
from collections import deque
from itertools import repeat

import numpy as np
import pytest

from gcode_opt import plan as plan_mod
from gcode_opt import schedule
from gcode_opt.schedule import SegmentCache


# ---------------------------------------------------------------- 0b09fc6, verbatim (PUT_ROWS read
# from schedule, where the tests set it)
def _put_rows_0b09fc6(segs, got):
    deque(map(segs.__setitem__, got.keys(), got.values()), maxlen=0)


def _put_at_0b09fc6(segs, rows, plans):
    it = iter(plans)
    for a in range(0, rows.size, schedule.PUT_ROWS):
        deque(map(segs.__setitem__, rows[a:a + schedule.PUT_ROWS].tolist(), it), maxlen=0)      # (map stops at the rows' end)


def _copy_at_0b09fc6(dst, dst_rows, src, src_rows):
    for a in range(0, dst_rows.size, schedule.PUT_ROWS):
        b = a + schedule.PUT_ROWS
        deque(map(dst.__setitem__, dst_rows[a:b].tolist(), map(src.__getitem__, src_rows[a:b].tolist())), maxlen=0)


class SegmentCache0b09fc6(SegmentCache):
    def lookup(self, kind, rows, T, beta):
        if schedule.KINDS[kind].batch:
            key, segs, bad = self.batch.get(kind, (None, {}, {}))
            return (segs, bad) if key == self._key(rows, T, beta) else ({}, {})
        got, bad = {}, {}
        if not rows.size:
            return got, bad
        self._grow(int(rows.max()) + 1)
        hit = (self.line_T[rows] == T[rows]) & (self.line_beta[rows] == beta[rows])
        hit_l = rows[hit].tolist()
        seg = self.line_seg
        if not self.line_why:                 # no failure kept (the common case): the hits' plans
            return dict(zip(hit_l, map(seg.__getitem__, hit_l))), bad
        for i in hit_l:
            why = self.line_why.get(i)
            if why:
                bad[i] = why
            else:
                got[i] = seg[i]
        return got, bad

    def forget_lines(self, rows):
        n = len(self.line_seg)
        rows = np.asarray(rows)
        if rows.size and rows.max() >= n:
            rows = rows[rows < n]
        if not rows.size:
            return
        self.line_T[rows] = self.line_beta[rows] = np.nan
        rows_l = rows.tolist()
        deque(map(self.line_seg.__setitem__, rows_l, repeat(None)), maxlen=0)          # seg[i] = None
        if self.line_why:
            for i in rows_l:
                self.line_why.pop(i, None)


def _ids(xs):
    return [id(x) for x in xs]


@pytest.mark.parametrize("seed", range(5))
def test_puts_are_the_old_ones(seed, monkeypatch):
    monkeypatch.setattr(schedule, "PUT_ROWS", 7)
    rng = np.random.default_rng(seed)
    objs = [object() for _ in range(300)]
    base = [objs[int(i)] for i in rng.integers(0, 300, 120)]
    for _ in range(30):
        rows = rng.integers(0, 120, int(rng.integers(0, 60))).astype(np.intp)     # repeats: the last write wins
        vals = [objs[int(i)] for i in rng.integers(0, 300, rows.size + int(rng.integers(0, 3)))]
        a, b = list(base), list(base)
        schedule._put_at(a, rows, iter(vals))
        _put_at_0b09fc6(b, rows, iter(vals))
        assert _ids(a) == _ids(b)
        got = dict(zip(rows.tolist(), vals))
        a, b = list(base), list(base)
        schedule._put_rows(a, got)
        _put_rows_0b09fc6(b, got)
        assert _ids(a) == _ids(b)
        src = rng.integers(0, 120, rows.size).astype(np.intp)
        a, b = list(base), list(base)
        schedule._copy_at(a, rows, a, src)                  # (dst the src itself: row by row in turn)
        _copy_at_0b09fc6(b, rows, b, src)
        assert _ids(a) == _ids(b)


def test_items():
    seq = [object() for _ in range(9)]
    for at in ([], [2], [2, 2], [8, 0, 3]):
        got = schedule._items(seq, at)
        assert type(got) is list and _ids(got) == _ids([seq[i] for i in at])


@pytest.mark.parametrize("seed", range(3))
def test_segment_cache_lookup_and_forget_are_the_old_ones(seed):
    rng = np.random.default_rng(seed)
    n = 80
    caches = SegmentCache(), SegmentCache0b09fc6()
    plans = [object() for _ in range(n)]
    hits = 0
    T, beta = rng.choice([1.0, 2.0], n), rng.choice([0.5, np.inf], n)
    for _ in range(12):
        rows = np.unique(rng.integers(0, n, int(rng.integers(1, 30))))
        T, beta = T.copy(), beta.copy()
        T[rng.integers(0, n, 8)] = 3.0                   # (some laws change, the others are hits)
        segs = [plans[int(i)] if rng.random() < 0.8 else None for i in rng.integers(0, n, n)]
        bad = {int(i): "error: segments" for i in rows[rng.random(rows.size) < 0.1]}
        gone = rng.integers(0, n, 5)
        out = []
        for c in caches:
            look = c.lookup("line", rows, T, beta)
            out.append(({k: id(v) for k, v in look[0].items()}, dict(look[1])))
            c.store("line", rows, T, beta, segs, bad)
            c.forget_lines(gone)
            out.append((_ids(c.line_seg), c.line_T.tobytes(), dict(c.line_why)))
        assert out[0] == out[2] and out[1] == out[3]
        hits += len(out[0][0])
    assert hits > 20


def test_run_memo_segs_are_the_rows_plans():
    class P:
        pass
    p = P()
    n = 50
    p.T, p.beta = np.arange(n, dtype=float), np.ones(n)
    p.retime, p.reason = np.ones(n, bool), np.full(n, "retimed", dtype=object)
    p.segs = [object() for _ in range(n)]
    p.t_pred, p.a2_pred = np.zeros(n), np.zeros(n)
    rows = np.array([1, 4, 9, 30], np.intp)
    m = schedule._RunMemo(p, rows)
    assert _ids(m.segs) == _ids([p.segs[i] for i in rows.tolist()]) and type(m.segs) is list


def test_plan_reasons_are_the_old_array():
    for n in (0, 1, 1000):
        got, want = plan_mod.Plan(n).reason, np.full(n, "", dtype=object)
        assert got.dtype == want.dtype and got.shape == want.shape and got.tolist() == want.tolist()
        assert len({id(x) for x in got.tolist()}) <= 1    # (one str object, as before)
