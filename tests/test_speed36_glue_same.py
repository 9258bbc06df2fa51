"""Issue 8, session 36 (glue): the planning glue's copies made cheaper must give the same
values as the code they replace (kept below verbatim as references): plan._entry_columns
by flat places, plan._chosen_figures by 1-D gathers, chains._at's flat gathers for 2-D
fancy indexes, schedule._run_or_rows' slices for runs of rows, and distinct.value_codes'
masks for the object arrays' compares."""
from __future__ import annotations

import numpy as np
import pytest

from gcode_opt import chains, schedule
from gcode_opt import plan as plan_mod
from gcode_opt.distinct import value_codes


def ref_entry_columns(mask, first, cnt, m):
    """plan._entry_columns at ba46960."""
    col = np.zeros(m, np.int8 if mask.shape[1] <= 127 else np.intp)
    for a in range(0, mask.shape[0], plan_mod.ENTRY_ROWS):
        rr, cc = np.nonzero(mask[a:a + plan_mod.ENTRY_ROWS])
        c = cnt[a:a + plan_mod.ENTRY_ROWS]
        col[np.repeat(first[a:a + plan_mod.ENTRY_ROWS] - (np.cumsum(c) - c), c) + np.arange(rr.size)] = cc
    return col


@pytest.mark.parametrize("k", [1, 23, 130])
def test_entry_columns(k, monkeypatch):
    rng = np.random.default_rng(k)
    monkeypatch.setattr(plan_mod, "ENTRY_ROWS", 37)           # several blocks
    mask = rng.random((300, k)) < 0.3
    cnt = mask.sum(axis=1)
    first = np.cumsum(cnt) - cnt
    m = int(cnt.sum())
    got = plan_mod._entry_columns(mask, first, cnt, m)
    want = ref_entry_columns(mask, first, cnt, m)
    assert got.dtype == want.dtype and np.array_equal(got, want)


class _Cands:
    """What _chosen_figures reads of a Candidates: vals (4, m) and at(rows, cols)."""

    def __init__(self, vals):
        self.vals = vals

    def at(self, rows, cols):
        return self.vals[:, (rows * 7 + cols) % self.vals.shape[1]]


def ref_chosen(cands, use, pos, j, T_orig, I_orig):
    """plan_auto's figures at ba46960."""
    n = use.size
    got = np.zeros((4, n))
    got[2:] = np.nan
    known = pos >= 0
    got[:, known] = cands.vals[:, pos[known]]
    rest = use & ~known
    got[:, rest] = cands.at(np.flatnonzero(rest), j[rest])
    return (np.where(use, got[0], T_orig), np.where(use, got[1], np.inf), np.where(use, got[2], I_orig),
            np.where(use, got[3], np.nan))


def test_chosen_figures():
    rng = np.random.default_rng(3)
    n, m = 500, 900
    vals = rng.random((4, m))
    vals[1, ::5] = np.inf
    vals[3, ::7] = np.nan
    cands = _Cands(vals)
    use = rng.random(n) < 0.6
    pos = np.where(use & (rng.random(n) < 0.8), rng.integers(0, m, n), -1)
    j = rng.integers(0, 5, n)
    T_orig, I_orig = rng.random(n), rng.random(n)
    got = plan_mod._chosen_figures(cands, use, pos, j, T_orig, I_orig)
    want = ref_chosen(cands, use, pos, j, T_orig, I_orig)
    for a, b in zip(got, want):
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("dtype", [float, bool, np.int64])
def test_at_is_fancy_index(dtype):
    rng = np.random.default_rng(5)
    A = (rng.random((6, 50)) * 100).astype(dtype)
    rows, start = rng.integers(0, 6, 40), rng.integers(0, 45, 40)
    cols = start[:, None] + np.arange(5)
    for a in (A, np.asfortranarray(A)):             # (the latter not C-contiguous: numpy's index)
        got = chains._at(a, rows[:, None], cols)
        assert got.dtype == a.dtype and np.array_equal(got, a[rows[:, None], cols])
        assert np.array_equal(chains._at(a, rows, start), a[rows, start])


@pytest.mark.parametrize("r,run", [([3, 4, 5, 6], True), ([7], True), ([0, 2, 3], False), ([5, 4], False),
                                   ([2, 2], False), ([], False)])
def test_run_or_rows(r, run):
    r = np.array(r, np.intp)
    got = schedule._run_or_rows(r)
    assert isinstance(got, slice) == run
    S = np.arange(80.0).reshape(10, 8)
    assert np.array_equal(S[got], S[r])


def test_value_codes_masks_are_compares():
    rng = np.random.default_rng(9)
    words = ["retimed", "", "no law within limits", "error: planning (non-finite)", None]
    values = [words[i] for i in rng.integers(0, len(words), 400)]
    code_of, code = value_codes(values)
    assert list(code_of) == list(dict.fromkeys(values))
    arr = np.array(values, dtype=object)
    for v in words + ["absent"]:
        assert np.array_equal(code == code_of.get(v, -1), arr == v)
