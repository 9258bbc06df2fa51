"""Issue 8 (chains, round 3): the chain candidate table kept as flat arrays (laws/chain.
solve_flat -> FlatLaws, chains._figures/_finish_table, ChainMemo.put_rows) gives bit for bit
the table and the chains' memories of the per-chain form it replaced: the reference below
is chains._figures as it stood at commit fcf532c (one ChainLaw per chain and duration,
finish_groups on lists of laws, one ChainMemo.put per row), run on real chains of the
bundled full-speed gyroid under classic jerk, Klipper's square-corner velocity and Marlin's
junction deviation (the per-chain finishing path).  Also: solve_flat's active-set
bookkeeping (vectorised) cut short by MAX_ACTIVE_ITERS gives each chain the law it gets
alone, flagged not converged."""
import dataclasses
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.laws import chain as chain_law
from gcode_opt.pipeline import Options, analyse
from gcode_opt.plan import SPEED_TOL_R
from gcode_opt.profile import load_profile
from gcode_opt.schedule import plan_inputs
from gcode_opt.segments import SegmentRules
from gcode_opt.strokes import K_CHAIN

from chain_cases import synthetic_chains

SAMPLES = Path(__file__).resolve().parent.parent / "sample_gcode"


# ---------------------------------------------------------------- the reference (commit fcf532c)
def _usable(law, pin, i, T):
    return (law.converged and law.min_v >= -1e-9 * (1 + pin.v_cap[i])
            and law.peak_v <= pin.v_cap[i] * (1 + SPEED_TOL_R) and T >= pin.t_seg_min[i])


def ref_figures(strokes, rows, pin, T, beta, profile, rules, chunk=256):
    n, k = T.shape
    ok = np.zeros((n, k), bool)
    tp = np.array(T, float)
    ia = np.full((n, k), np.inf)
    iv = np.full((n, k), np.nan)
    mid = int(np.argmin(np.abs(T[0] / pin.T_orig[rows[0]] - 1.0))) if n else 0
    order = [mid] + list(range(mid + 1, k)) + list(range(mid - 1, -1, -1))
    prev = {c: (c - 1 if c > mid else c + 1) for c in order[1:]}
    for a in range(0, n, chunk):
        sl = slice(a, min(a + chunk, n))
        sts = [strokes[i] for i in rows[sl]]
        laws = {}
        for c in order:
            init_B = init_t = None
            if c in prev:
                src, scale = laws[prev[c]], T[sl, c] / T[sl, prev[c]]
                init_B = [lw.binding for lw in src]
                init_t = [lw.vert_t * r for lw, r in zip(src, scale)]
            laws[c] = chain_law.solve_chains(chains._problems(sts, T[sl, c], beta[sl, c], profile), init_B, init_t)
        todo = []
        for j, st in enumerate(sts, start=a):
            cols = [c for c in range(k) if _usable(laws[c][j - a], pin, rows[j], T[j, c])]
            if cols:
                todo.append((j, st, cols))
        done = chains.finish_groups([(st, [laws[c][j - a] for c in cols]) for j, st, cols in todo], rules, profile)
        for (j, st, cols), (kept, _) in zip(todo, done):
            for r, c in enumerate(cols):
                time_t, int_a2 = float(kept.t_pred[r]), float(kept.a2_pred[r])
                if not (np.isfinite(int_a2) and np.isfinite(time_t) and time_t > 0):
                    continue
                ok[j, c], tp[j, c], ia[j, c], iv[j, c] = True, time_t, int_a2, laws[c][j - a].iv
                st.chain_T.put(time_t, float(T[j, c]), float(beta[j, c]), kept, r)
    return ok, tp, ia, iv


# ---------------------------------------------------------------- the checks
_CACHE = {}


def _chains(prof_name):
    if prof_name not in _CACHE:
        prof = load_profile(prof_name)
        opts = Options()
        opts.ringing = False
        strokes, _ = analyse(str(SAMPLES / "prusa_gyroid_fullspeed.gcode"), prof, opts)
        pin = plan_inputs(strokes, prof, opts)
        rows = np.array([i for i, s in enumerate(strokes) if chains.plan_kind(s) == K_CHAIN][:300], int)
        _CACHE[prof_name] = (strokes, pin, rows, prof)
    return _CACHE[prof_name]


def _memo_rows(strokes, rows, rules, prof):
    """Every chain's memory as plain data: its rows and, per row, the plan its kept plans
    give (a _KeptPlans holds it; a _KeptLaws makes it again from the row's law)."""
    out = []
    for i in rows.tolist():
        st = strokes[i]
        m = st.chain_T
        if m.figs is None:
            out.append(None)
            continue
        rows = []
        for t, T, b, r, kp in m.rows():
            p = kp.plan(int(r), st, rules, prof) if isinstance(kp, chains._KeptLaws) else kp.plan(int(r))
            # (r: the row's place in its kept plans, a handle, not compared: s34's kept laws
            # are one a finishing batch, r the batch's row; the plan it gives is compared)
            rows.append((t, T, b, kp.key[:4], p.s.tobytes(), p.v.tobytes(), p.accel.tobytes(),
                         p.feed.tobytes(), p.time_t, p.int_a2))
        out.append(rows)
    return out


def _run(figures, strokes, rows, pin, prof, rules, Tc, bc):
    for i in rows.tolist():
        strokes[i].chain_T = chains.ChainMemo()
    tab = figures(strokes, rows, pin, Tc, bc, prof, rules)
    return tab, _memo_rows(strokes, rows, rules, prof)


@pytest.mark.parametrize("prof_name,junction,grouped", [("prusa-mk3s", None, True), ("voron24", None, True),
                                                         ("prusa-mk3s", "jd", True), ("prusa-mk3s", "jd", False)])
def test_flat_candidate_table_equals_the_per_chain_one(prof_name, junction, grouped, monkeypatch):
    strokes, pin, rows, prof = _chains(prof_name)
    assert rows.size >= 200
    if junction is not None:          # Marlin junction deviation
        prof = dataclasses.replace(prof, junction=junction)
    if not grouped:                   # a junction law finished chain by chain
        monkeypatch.setattr(chains, "GROUP_JUNCTIONS", ("jerk", "scv"))
    rules = SegmentRules.for_profile(prof, 10)
    assert (rules.junction in chains.GROUP_JUNCTIONS) == grouped
    Tc = pin.T_orig[rows, None] * np.array(chains.CHAIN_T_RATIOS)[None, :]
    bc = (Tc / chains.GAMMA_MIN) ** 2
    monkeypatch.setattr(chains, "SOLVE_CHUNK", 128)        # several chunks
    got, got_memo = _run(chains._figures, strokes, rows, pin, prof, rules, Tc, bc)
    want, want_memo = _run(ref_figures, strokes, rows, pin, prof, rules, Tc, bc)
    assert got[0].sum() > 3 * rows.size                  # most candidates usable
    for a, b in zip(got, want, strict=True):
        assert np.array_equal(a, b, equal_nan=True)
    assert got_memo == want_memo


def _synthetic_chains(m, seed):
    return synthetic_chains(m, seed, min_vertices=8, min_cap=15.0)


@pytest.mark.parametrize("iters", [1, 2, 3])
def test_active_set_cut_short_is_each_chains_own(iters, monkeypatch):
    probs = _synthetic_chains(40, seed=3)
    full = chain_law.solve_chains(probs)
    need = np.array([lw.binding.size for lw in full])
    assert need.max() > 3
    monkeypatch.setattr(chain_law, "MAX_ACTIVE_ITERS", iters)
    together = chain_law.solve_chains(probs)
    n_unconv = 0
    for pr, lw in zip(probs, together):
        alone = chain_law.solve_chains([pr])[0]
        n_unconv += not lw.converged
        for f in ("binding", "vert_v", "vert_t", "knot_t", "converged", "iv", "ia", "peak_v", "min_v", "peak_a"):
            assert np.array_equal(np.asarray(getattr(lw, f)), np.asarray(getattr(alone, f))), f
    assert n_unconv > 0                  # some chains were cut short ...
    if iters == 1:                       # ... and a law cut short is the first step's: cold binding set
        for pr, lw in zip(probs, together):
            assert np.array_equal(lw.binding, np.flatnonzero(pr.c_v < chain_law.COLD_BIND_R * pr.S / pr.T))


def test_forced_release_and_cycling_follow_the_per_chain_rules(monkeypatch):
    """Every binding vertex is made to want release (a negative multiplier growing with its
    position), so the active set releases, re-adds the violators and cycles: the vectorised
    bookkeeping (release, 'seen before', release only the worst, give up unconverged)
    must give each chain the per-chain reference's law (tests/test_speed_chains.py)."""
    import test_speed_chains as ref

    def forced(self):
        inner = np.ones(self.ks.size, bool)
        inner[self.koff[:-1]] = inner[self.koff[1:] - 1] = False
        return -(1.0 + self.ks[inner])

    monkeypatch.setattr(chain_law._Step, "multipliers", forced)
    monkeypatch.setattr(ref, "_multipliers", lambda law, Bc: -(1.0 + law.knot_s[1:-1]))
    probs = _synthetic_chains(30, seed=5)
    got, want = chain_law.solve_chains(probs), ref.ref_solve_chains(probs)
    assert sum(not lw.converged for lw in want) >= 10       # the rules gave up on many
    ref._all_close(got, want)      # np.sinh there, prims.sinh here: see test_speed_chains._close
