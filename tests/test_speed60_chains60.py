"""chains._remember_runs laying a merged kept base's finishing groups out together
(benchmarks/chains60.md): every chain's memo rows and the base's T, beta and predicted times
are those the definition gives (each run's good rows, each chain's newest first, after the
rows it had), whatever the runs' tables; the windowed command writes the list path's bytes."""
import os
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import chains

from windowed_run import run_command

SAMPLES = Path(__file__).resolve().parent.parent / "sample_gcode"


class _St:
    __slots__ = ("chain_T",)

    def __init__(self):
        self.chain_T = chains.ChainMemo()


def _runs(rng, nruns, shared):
    """Runs (sts, j, c, t, good, T, beta, a) of finishing groups: chains with 2-5 rows each
    (j ascending), some rows not good, a run's last chain index the next run's first; the
    runs' tables one pair (a chunk's groups: shared) or each run's own."""
    k = 5
    T0 = rng.uniform(0.1, 2.0, (40, k))
    b0 = rng.uniform(1.0, 9.0, (40, k))     # (chains 3..~33: each run's first its last's)
    runs, last = [], 3
    for w in range(nruns):
        sts = [_St() for _ in range(40)]
        for st in sts[::7]:                         # chains with rows from before
            st.chain_T.put(0.5 + w, 0.25, 0.125, "old", 7.0)
        chains_ = np.unique(np.r_[last, rng.choice(np.arange(last + 1, last + 6), rng.integers(1, 5), replace=False)])
        j = np.repeat(chains_, rng.integers(2, 6, chains_.size))
        c = rng.integers(0, k, j.size)
        t = rng.uniform(0.1, 3.0, j.size)
        good = rng.random(j.size) > 0.3
        if w == 0:
            good[j == chains_[-1]] = False          # a chain with no good row
        T, beta = (T0, b0) if shared else (T0 * (1 + w), b0 + w)
        runs.append((sts, j, c, t, good, T, beta, 10 * w))
        last = int(chains_[-1])
    return runs


def _want(runs):
    """{(run, chain): its memo rows} by the definition, and {batch row: (T, beta, t)}."""
    rows, base, R = {}, {}, 0
    for w, (sts, j, c, t, good, T, beta, _) in enumerate(runs):
        for jj in np.unique(j).tolist():
            own = [i for i in np.flatnonzero(j == jj).tolist()[::-1] if good[i]]
            old = [tuple(r[:4]) for r in sts[jj].chain_T.rows()]
            rows[w, jj] = [(t[i], T[jj, c[i]], beta[jj, c[i]], float(R + i)) for i in own] + old
            base.update({R + i: (T[jj, c[i]], beta[jj, c[i]], t[i]) for i in own})
        R += j.size
    return rows, base


@pytest.mark.parametrize("nruns,shared", [(1, True), (4, True), (4, False), (6, False)])
def test_remember_runs_rows_by_definition(nruns, shared):
    rng = np.random.default_rng(60 + nruns)
    runs = _runs(rng, nruns, shared)
    want, want_base = _want(runs)
    R = sum(r[1].size for r in runs)
    kept = chains._KeptLaws(("key",), (None, None, None, None, None, None, None, None), 0, R)
    chains._remember_runs(runs, kept)
    got = {(w, jj): [tuple(r[:4]) for r in runs[w][0][jj].chain_T.rows()]
           for w, jj in want}
    assert got == want
    for (w, jj), rows in want.items():
        memo = runs[w][0][jj].chain_T
        new = len(rows) - (1 if jj % 7 == 0 else 0)
        assert [memo._kept(q) for q in range(memo.n)] == [kept] * new + ["old"] * (memo.n - new)
    q = np.array(sorted(want_base), np.int64)
    T, beta, t = (kept.base[3][q], kept.base[4][q], kept.base[5][q])
    assert [tuple(x) for x in np.stack([T, beta, t], axis=1).tolist()] == [want_base[i] for i in q.tolist()]


@pytest.mark.parametrize("name", ["prusa_gyroid.gcode", "prusa_gyroid_fullspeed.gcode"])
def test_windowed_command_same_bits(monkeypatch, tmp_path, name):
    """The windowed command (window 64: chain calls of several windows, merged kept bases)
    writes the list path's bytes and summary."""
    src = os.path.join(SAMPLES, name)
    want = run_command(monkeypatch, src, tmp_path / "list.gcode", False, 64)
    got = run_command(monkeypatch, src, tmp_path / "win.gcode", True, 64)
    assert got[0] == want[0] and got[1] == want[1]
