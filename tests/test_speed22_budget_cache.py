"""schedule.SegmentCache's line rows with less per-row glue (budget, s22): lookup takes the
hits' plans in one pass when no failure is kept, store touches the failures only when
there are some, and plan_strokes' rows still to segment come from one isin
(schedule._not_in).  Compared with 479aedb's lookup/store (line part) and list
comprehension, kept verbatim below, on random stores and look-ups with and without
failures: the same dicts (the same plan objects), the same rows in the same order."""
import numpy as np

from gcode_opt import schedule


class RefCache(schedule.SegmentCache):
    """479aedb's line lookup and store, verbatim (batch kinds are not used here)."""

    def lookup(self, kind, rows, T, beta):
        got, bad = {}, {}
        rows_l = rows.tolist()
        if not rows_l:
            return got, bad
        self._grow(max(rows_l) + 1)
        hit = (self.line_T[rows] == T[rows]) & (self.line_beta[rows] == beta[rows])
        for i, h in zip(rows_l, hit.tolist()):
            if h:
                why = self.line_why.get(i)
                if why:
                    bad[i] = why
                else:
                    got[i] = self.line_seg[i]
        return got, bad

    def store(self, kind, rows, T, beta, segs, bad, own=False):
        rows_l = rows.tolist()
        if not rows_l:
            return
        self._grow(max(rows_l) + 1)
        self.line_T[rows] = T[rows]
        self.line_beta[rows] = beta[rows]
        for i in rows_l:
            self.line_seg[i] = segs.get(i)
            why = bad.get(i, "")
            if why:
                self.line_why[i] = why
            else:
                self.line_why.pop(i, None)


def _todo_ref(ii, got, bad):
    return np.array([i for i in ii.tolist() if i not in got and i not in bad], int)


def test_line_cache_same_as_479aedb():
    for seed, p_fail in ((0, 0.0), (1, 0.2), (2, 0.02)):
        rng = np.random.default_rng(seed)
        new, ref = schedule.SegmentCache(), RefCache()
        n = 60
        vals = np.array([0.5, 1.0, 1.5, np.inf, np.nan])
        for step in range(150):
            rows = np.sort(rng.choice(n, size=rng.integers(0, 30), replace=False))
            T = rng.choice(vals[:3], size=n)
            beta = rng.choice(vals, size=n)
            got, bad = new.lookup("line", rows, T, beta)
            g2, b2 = ref.lookup("line", rows, T, beta)
            assert list(got) == list(g2) and all(got[i] is g2[i] for i in got) and bad == b2
            todo = schedule._not_in(rows, got, bad)
            want = _todo_ref(rows, got, bad)
            assert todo.dtype == want.dtype and todo.shape == want.shape and np.array_equal(todo, want)
            segs = {i: (object() if rng.random() < 0.9 else None) for i in todo.tolist() if rng.random() < 0.8}
            fails = {i: "error: segments (x)" for i in todo.tolist() if i not in segs and rng.random() < p_fail}
            if rng.random() < 0.1:
                fails.update({i: "" for i in todo.tolist()[:2]})          # an empty reason: none
            new.store("line", todo, T, beta, list(map(segs.get, range(n))), fails)     # (a list by row, as a run's)
            ref.store("line", todo, T, beta, segs, fails)
            assert new.line_why == ref.line_why
            assert all(a is b for a, b in zip(new.line_seg, ref.line_seg)) and len(new.line_seg) == len(ref.line_seg)
            assert np.array_equal(new.line_T, ref.line_T, equal_nan=True)
            if rng.random() < 0.05:
                gone = int(rng.integers(n))
                for c in (new, ref):
                    c.forget_line(gone)


def test_not_in_odd_cases():
    e = np.zeros(0, np.int64)
    for ii, got, bad in ((e, {}, {}), (e, {1: None}, {}), (np.array([3, 1, 2]), {}, {}),
                         (np.array([3, 1, 2]), {1: 0, 7: 0}, {2: "x"}), (np.array([5]), {5: None}, {})):
        a, b = schedule._not_in(ii, got, bad), _todo_ref(ii, got, bad)
        assert a.dtype == b.dtype and np.array_equal(a, b)
