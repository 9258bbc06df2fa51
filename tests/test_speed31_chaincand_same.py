"""Issue 8 (s31, the chains' candidates): chains whose every solve input is the same bit
for bit as an earlier chain's are solved once (chains._same_chains, _solve_cols, _Spread),
and candidate rows whose every finishing input is the same as an earlier row's are
finished once (chains._Finisher._first's guess, checked by _same_finish in _finish_core).  These tests hold:
  - _same_rows to a grouping of the rows by their bytes, on tables with equal rows and
    rows whose hashes collide;
  - _same_chains to a grouping of real chains by the bytes of every solve input, and that
    it keeps apart chains one ulp apart in one vertex cap or one vertex position;
  - _figures' tables (feasible, predicted time and ∫|a|², ∫ṡ²) with the merging to those
    without it, bit for bit, on real chains with repeated rows, under classic jerk, Klipper
    SCV and junction deviation (no grouped finishing);
  - _finish_core's outputs with the merging (a right and a wrong guess of the equal rows)
    to those without it on real batches with repeated rows;
and that the comparison catches one table entry one ulp off."""
import numpy as np
import pytest

from gcode_opt import chains, curves
from gcode_opt.laws import chain as lc

from chain_cases import fresh_chains, float_bits

CASES = [("sample_gcode/prusa_gyroid_fullspeed.gcode", "prusa-mk3s"),
         ("sample_gcode/prusa_gyroid_fullspeed_klipper.gcode", "voron24"),
         ("sample_gcode/prusa_gyroid_fullspeed.gcode", "ender3")]


def _groups_by_bytes(rows):
    """Each row's first row of the same bytes (the reference of _same_rows)."""
    first, out = {}, []
    for i, r in enumerate(rows):
        out.append(first.setdefault(bytes(r), i))
    return np.array(out)


def test_same_rows_is_a_grouping_by_bytes():
    rng = np.random.default_rng(3)
    K = rng.integers(-2 ** 62, 2 ** 62, (300, 7))
    K[rng.integers(0, 300, 120)] = K[rng.integers(0, 300, 120)]        # equal rows
    got = chains._same_rows(K)
    assert got is not None and np.array_equal(got, _groups_by_bytes(K))
    assert chains._same_rows(np.unique(K, axis=0)) is None
    assert chains._same_rows(K[:1]) is None


def test_same_rows_keeps_colliding_rows_apart():
    """A row of the same hash (the wrapping dot with _same_rows' weights) as an earlier row
    but other numbers is its own (and so are its copies: the grouping is by the hash's
    first row; a chain or row left its own is only solved or finished again)."""
    c = 3
    w = np.arange(1, c + 1, dtype=np.int64) * np.int64(-7046029254386353131) | np.int64(1)
    a = np.array([5, 9, 11], np.int64)
    b = a + np.array([w[1], -w[0], 0], np.int64)                 # a @ w == b @ w
    assert a @ w == b @ w and not np.array_equal(a, b)
    K = np.stack([a, b, a, b, b])
    assert np.array_equal(chains._same_rows(K), [0, 1, 0, 3, 4])
    keep, pos = chains._kept(chains._same_rows(K))
    assert np.array_equal(keep, [0, 1, 3, 4]) and np.array_equal(pos, [0, 1, 0, 2, 3])


def _base(path, prof_name, reps):
    """The flat chains of the sample's first chains, rows repeated as reps, and their T, beta."""
    strokes, pin, rows, prof, rules = fresh_chains(path, prof_name)
    rows = rows[:300][reps(300)]
    T = pin.T_orig[rows, None] * chains.T_RATIOS[None, chains.CHAIN_COLS]
    beta = (T / chains.GAMMA_MIN) ** 2
    return chains._flat_chains([strokes[i] for i in rows.tolist()], prof), T, beta


def _chain_keys(base, T, beta):
    """Each chain's every solve input as bytes."""
    out = []
    for j in range(base.S.size):
        a, b = base.voff[j], base.voff[j + 1]
        out.append(float_bits(base.sv[a:b]) + b"|" + float_bits(base.cv[a:b]) + b"|"
                   + float_bits([base.S[j], base.v0[j], base.v1[j]]) + float_bits(T[j]) + float_bits(beta[j]))
    return out


def _reps(n):
    return np.concatenate([np.arange(n), np.arange(0, n, 3), np.arange(n - 1, 0, -7)])


def test_same_chains_is_a_grouping_by_every_solve_input():
    base, T, beta = _base(*CASES[0], _reps)
    keep, pos = chains._same_chains(base, T, beta)
    want = _groups_by_bytes(_chain_keys(base, T, beta))
    assert np.array_equal(keep[pos], want)
    assert keep.size == np.unique(want).size < base.S.size
    # the kept chains' own flat arrays: the same numbers
    sub = base.take(keep)
    for j, q in enumerate(keep.tolist()):
        a, b = base.voff[q], base.voff[q + 1]
        c, d = sub.voff[j], sub.voff[j + 1]
        assert float_bits(sub.sv[c:d]) == float_bits(base.sv[a:b]) and float_bits(sub.cv[c:d]) == float_bits(base.cv[a:b])
    assert float_bits(sub.S) == float_bits(base.S[keep]) and float_bits(sub.v1) == float_bits(base.v1[keep])


@pytest.mark.parametrize("field", ["cv", "sv"])
def test_same_chains_keeps_a_chain_one_ulp_apart(field):
    """A repeated chain with one vertex cap (or position) one ulp off is solved itself."""
    base, T, beta = _base(*CASES[0], lambda n: np.concatenate([np.arange(n), np.arange(n)]))
    m = base.S.size
    j = m // 2 + int(np.argmax(base.nv[m // 2:] > 2))       # a repeat with vertices
    arr = getattr(base, field)
    arr[base.voff[j] + 1] = np.nextafter(arr[base.voff[j] + 1], np.inf)
    keep, pos = chains._same_chains(base, T, beta)
    want = _groups_by_bytes(_chain_keys(base, T, beta))
    assert j in keep.tolist() and want[j] == j and np.array_equal(keep[pos], want)
    assert keep.size == np.unique(want).size < m


def _tables(path, prof_name, merge, monkeypatch, count=None):
    """_figures' tables of the sample's chains with repeated rows (many chunks)."""
    strokes, pin, rows, prof, rules = fresh_chains(path, prof_name)
    rows = rows[_reps(rows.size)]
    T = pin.T_orig[rows, None] * chains.T_RATIOS[None, chains.CHAIN_COLS]
    beta = (T / chains.GAMMA_MIN) ** 2
    with monkeypatch.context() as mp:
        mp.setattr(chains, "SOLVE_CHUNK", 128)
        mp.setattr(chains, "SOLVE_SEGS", 128 * 12)
        if not merge:
            mp.setattr(chains, "_same_chains", lambda *a: None)
            mp.setattr(chains, "_same_finish", lambda *a: None)
        elif count is not None:
            real_c, real_f = chains._same_chains, chains._same_finish

            def spy_c(base, T, beta):
                got = real_c(base, T, beta)
                count["chains"] += 0 if got is None else base.S.size - got[0].size
                return got

            def spy_f(D, U, Q, own, vk, tk, first):
                got = real_f(D, U, Q, own, vk, tk, first)
                count["rows"] += 0 if got is None else own.size - got[0].size
                return got
            mp.setattr(chains, "_same_chains", spy_c)
            mp.setattr(chains, "_same_finish", spy_f)
        return chains._figures(strokes, rows, pin, T, beta, prof, rules), rows.size


@pytest.mark.parametrize("path,prof_name", CASES)
def test_figures_merged_are_the_tables_unmerged(path, prof_name, monkeypatch):
    count = {"chains": 0, "rows": 0}
    got, n = _tables(path, prof_name, True, monkeypatch, count)
    want, _ = _tables(path, prof_name, False, monkeypatch)
    for g, w in zip(got, want, strict=True):
        assert g.dtype == w.dtype and g.shape == w.shape and float_bits(g) == float_bits(w)
    assert np.isfinite(got[2]).sum() > 3 * n
    assert count["chains"] > n // 10                    # the repeats in a repeated chain's chunk not solved
    if chains._chain_law.CORE_MOD is not None and prof_name != "ender3":
        assert count["rows"] > 2 * count["chains"]      # nor their rows finished


def test_figures_comparison_catches_an_ulp(monkeypatch):
    got, _ = _tables(*CASES[0], True, monkeypatch)
    tp = got[1].copy()
    q = np.flatnonzero(got[0].ravel())[7]
    tp.ravel()[q] = np.nextafter(tp.ravel()[q], np.inf)
    assert float_bits(tp) != float_bits(got[1])


def _finish_batches(path, prof_name, monkeypatch, keep=12):
    """The first batches _finish_core gets while the sample's chains' table is made."""
    strokes, pin, rows, prof, rules = fresh_chains(path, prof_name)
    got = []
    real = chains._finish_core

    def spy(sts, gs, own, vk, tk, rules, profile, predict, core=None, first=None):
        if len(got) < keep:
            got.append((list(sts), list(gs), np.array(own), np.array(vk), np.array(tk), rules, profile, predict))
        return real(sts, gs, own, vk, tk, rules, profile, predict, core, first)

    with monkeypatch.context() as mp:
        mp.setattr(chains, "_finish_core", spy)
        chains.candidates_chain(pin, rows, strokes, prof, rules)
    return got


def _guesses(own, vk, tk):
    """Guesses of each row's first equal row: the right one (by the bytes of its chain and
    knots) and a wrong one (the row before, for every other row)."""
    keys = [b"%d|" % o + float_bits(v) + float_bits(t) for o, v, t in zip(own.tolist(), vk, tk)]
    right = _groups_by_bytes(keys)
    wrong = np.arange(own.size)
    wrong[1::2] -= 1
    return right, wrong


@pytest.mark.skipif(lc.CORE_MOD is None or not hasattr(lc.CORE_MOD, "chain_finish"), reason="no chain core")
@pytest.mark.parametrize("path,prof_name", CASES[:2])
@pytest.mark.parametrize("predict", [True, False])
def test_finish_core_merged_rows_are_the_rows_unmerged(path, prof_name, predict, monkeypatch):
    """_finish_core given a guess of each row's first equal row: its outputs those without
    the guess, bit for bit, with the right guess (rows merged) and a wrong one (checked:
    only the rows that are the same merged)."""
    batches = _finish_batches(path, prof_name, monkeypatch)
    assert batches
    merged = 0
    for sts, gs, own, vk, tk, rules, prof, _ in batches:
        R = own.size
        ix = np.concatenate([np.arange(R), np.arange(0, R, 2), np.arange(R - 1, -1, -3)])   # rows repeated
        args = (sts, gs, own[ix], vk[ix], tk[ix], rules, prof, predict)
        want = chains._finish_core(*args)
        assert want is not None
        for first in _guesses(own[ix], vk[ix], tk[ix]):
            got = chains._finish_core(*args, first=first)
            for g, w in zip(got, want, strict=True):
                assert (g is None) == (w is None)
                if g is not None:
                    assert g.dtype == w.dtype and g.shape == w.shape and float_bits(g) == float_bits(w)
        right, wrong = _guesses(own[ix], vk[ix], tk[ix])
        D, U = curves.stack_du(gs)
        Q = chains._cf_rows(sts)
        keep, pos = chains._same_finish(D, U, Q, own[ix], vk[ix], tk[ix], right)
        assert np.array_equal(keep[pos], right)
        merged += ix.size - keep.size
        got = chains._same_finish(D, U, Q, own[ix], vk[ix], tk[ix], wrong)
        if got is not None:
            assert np.array_equal(right[got[0][got[1]]], right)    # only equal rows merged
    assert merged > 0
