"""Issue 8 (s31, the chains' candidates): chains whose every solve input is the same bit
for bit as an earlier chain's are solved once (chains._same_chains, _solve_cols, _Spread).
These tests hold:
  - _same_rows to a grouping of the rows by their bytes, on tables with equal rows and
    rows whose hashes collide;
  - _same_chains to a grouping of real chains by the bytes of every solve input, and that
    it keeps apart chains one ulp apart in one vertex cap or one vertex position;
  - _figures' tables (feasible, predicted time and ∫|a|², ∫ṡ²) with the merging to those
    without it, bit for bit, on real chains with repeated rows, under classic jerk, Klipper
    SCV and junction deviation (no grouped finishing);
and that the comparison catches one table entry one ulp off."""
import numpy as np
import pytest

from gcode_opt import chains

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
        elif count is not None:
            real_c = chains._same_chains

            def spy_c(base, T, beta):
                got = real_c(base, T, beta)
                count["chains"] += 0 if got is None else base.S.size - got[0].size
                return got
            mp.setattr(chains, "_same_chains", spy_c)
        return chains._figures(strokes, rows, pin, T, beta, prof, rules), rows.size


@pytest.mark.parametrize("path,prof_name", CASES)
def test_figures_merged_are_the_tables_unmerged(path, prof_name, monkeypatch):
    count = {"chains": 0}
    got, n = _tables(path, prof_name, True, monkeypatch, count)
    want, _ = _tables(path, prof_name, False, monkeypatch)
    for g, w in zip(got, want, strict=True):
        assert g.dtype == w.dtype and g.shape == w.shape and float_bits(g) == float_bits(w)
    assert np.isfinite(got[2]).sum() > 3 * n
    assert count["chains"] > n // 10                    # the repeats in a repeated chain's chunk not solved


def test_figures_comparison_catches_an_ulp(monkeypatch):
    got, _ = _tables(*CASES[0], True, monkeypatch)
    tp = got[1].copy()
    q = np.flatnonzero(got[0].ravel())[7]
    tp.ravel()[q] = np.nextafter(tp.ravel()[q], np.inf)
    assert float_bits(tp) != float_bits(got[1])
