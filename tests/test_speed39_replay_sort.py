"""Issue 8 (s39, replay): plan_chain_segments' sorting of ask_all's answers (a chain's last
plan, or its candidate row by kind: dropped, kept as its law, kept as a plan; or none) in
one pass of the chain core (sort_asks) instead of chains._sort_asks.  The same lists (todo,
items, lazy, again, cold) of the same objects, the same plans into out, the kept plans'
plan(row) called in the same order; keys equal but not the same object, or unequal."""

import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.laws import chain as chain_law

pytestmark = pytest.mark.skipif(chain_law.CORE_MOD is None, reason="chain core not built")


class _Plans:
    """A kept plan of another kind (as _KeptPlans): plan(row) recorded."""
    calls = []

    def __init__(self, key):
        self.key = key

    def plan(self, r):
        self.calls.append((self, r))
        return ("plan", id(self), r)


def _case(m, seed):
    rng = np.random.default_rng(seed)
    key = ("jerk", 10, 0.01, 0.1, 99)
    src = chains._Source(None, None, [0], {}, ("jerk", 10, 0.01, 0.1, 99))     # (an equal key, not key)
    other = chains._Source(None, None, [0], {}, ("scv", 10, 0.01, 0.1, 99))
    strokes = [object() for _ in range(m)]
    segs, kept, rows = [None] * m, [None] * m, [None] * m
    for k in range(m):
        r = rng.random()
        if r < 0.15:
            segs[k] = object()
            continue
        if r < 0.25:
            continue                            # no candidate row: cold
        row = int(rng.integers(0, 9))
        kind = rng.random()
        if kind < 0.2:
            kept[k] = src.again if rng.random() < 0.7 else chains._Again(other)
        elif kind < 0.8:
            kept[k] = chains._KeptLaws(key if rng.random() < 0.5 else src.key if rng.random() < 0.8 else other.key,
                                       None, 0, 0)
        else:
            kept[k] = _Plans(key if rng.random() < 0.8 else other.key)
        rows[k] = row
    return strokes, segs, kept, rows, key


def _run(fn, case):
    strokes, segs, kept, rows, key = case
    out = [None] * len(strokes)
    _Plans.calls = []
    got = fn(strokes, segs, kept, rows, key, chains._Again, chains._KeptLaws, out)
    return got, out, list(_Plans.calls)


def _ids(x):
    """Lists of ints, tuples of objects and plans compared by identity (plans by value)."""
    if isinstance(x, list):
        return [_ids(e) for e in x]
    if isinstance(x, tuple) and x and x[0] == "plan":
        return x
    if isinstance(x, tuple):
        return tuple(_ids(e) for e in x)
    return x if isinstance(x, int) else id(x)


def test_sort_asks_is_the_loop():
    for seed in range(8):
        case = _case(400, seed)
        got = _run(chain_law.CORE_MOD.sort_asks, case)
        want = _run(chains._sort_asks, case)
        assert _ids(got) == _ids(want)
        todo, items, lazy, again, cold = want[0]
        assert len(items) > 50 and len(again) > 5 and len(cold) > 20 and len(want[2]) > 10
        assert len(todo) == len(lazy) + len(again) + len(cold) + len(want[2])
        assert all(type(k) is int for k in todo + lazy + cold)


def test_sort_asks_raises_as_the_loop():
    """A kept plan whose plan(row) raises: the loop's exception."""
    class Bad(_Plans):
        def plan(self, r):
            raise ZeroDivisionError(r)
    key = ("k",)
    for fn in (chain_law.CORE_MOD.sort_asks, chains._sort_asks):
        with pytest.raises(ZeroDivisionError):
            fn([object()] * 2, [None, None], [_Plans(key), Bad(key)], [1, 2], key, chains._Again, chains._KeptLaws,
               [None, None])
