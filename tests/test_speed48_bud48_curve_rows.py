"""Session 48 (bud48): curves._finish_rows' per-row Python.

* curves._stacked_runs / _stack_u (stack_du, stack_d) take a block of one row (a curve on
  CurveGeom's own path: every curve of the rectilinear plate) as itself, then stack: the
  same arrays as the take / u_rows a run they replace (kept below verbatim), new arrays
  (no block's own array handed out), on geometries of one-row blocks, of build_geoms'
  blocks and of both mixed;
* curves._predict_rows adds the end terms in arrays: the same figures, and the same
  types (a numpy float64 where an end term was added), as the row loop it replaces (kept
  below verbatim), with ends of no neighbour (None), NaN cosines and NaN times."""
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt import schedule as sc
from gcode_opt.curves import CORNER_COS, segment_times
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_CURVE

S = Path(__file__).resolve().parent.parent / "sample_gcode"
_add = np.add.reduce


def _stacked_runs_old(gs):
    """curves._stacked_runs of dd6ed5b, verbatim."""
    try:
        bs = [g._b for g in gs]
        ks = [g._k for g in gs]
    except AttributeError:
        return None
    if not bs:
        return None
    ds, runs = [], []
    a, m = 0, len(bs)
    while a < m:                    # runs of one block
        b = bs[a]
        z = a + 1
        while z < m and bs[z] is b:
            z += 1
        ds.append(np.asarray(b.d, float).take(ks[a:z], axis=0))     # (np.take: the same rows)
        runs.append((b, a, z))
        a = z
    if not all(x.ndim == 2 and x.shape[1:] == ds[0].shape[1:] for x in ds):
        return None
    return (ds[0] if len(ds) == 1 else np.concatenate(ds)), runs, ks


def _stack_u_tail_old(runs, ks):
    """The run-by-run tail of curves._stack_u of dd6ed5b, verbatim."""
    us = [b.u_rows(ks[a:z]) for b, a, z in runs]
    return us[0] if len(us) == 1 else np.concatenate(us)


def _predict_rows_old(S, V, A, cos_turn, c0, c1):
    """curves._predict_rows of dd6ed5b, verbatim."""
    t, a, dv = segment_times(S, V, A)
    s1 = _add(a * dv, axis=1).tolist()
    vi = V[:, 1:-1]
    dv2 = 2.0 * vi * vi * (1.0 - cos_turn)
    tj = 0.5 * (t[:, :-1] + t[:, 1:])
    s2 = _add(np.where(cos_turn >= CORNER_COS, dv2 / np.maximum(tj, 1e-12), 0.0), axis=1).tolist()
    t_sum = _add(t, axis=1).tolist()
    a2s = []
    for k, (x, y, e0, e1) in enumerate(zip(s1, s2, c0, c1)):
        a2 = x
        a2 += y
        for c, vv, tt in ((e0, V[k, 0], t[k, 0]), (e1, V[k, -1], t[k, -1])):
            if c is not None and c >= CORNER_COS:
                a2 += 0.5 * 2.0 * vv * vv * (1.0 - c) / max(tt, 1e-12)
        a2s.append(a2)
    return t_sum, a2s


def _bits(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


_CURVES = {}


def _curves():
    """The bundled gyroid's curves by vertex count: (strokes, build_geoms' geometries, the
    same strokes' geometries on CurveGeom's own path: blocks of one row)."""
    if not _CURVES:
        prof = load_profile("prusa-mk3s")
        strokes, _ = analyse(str(S / "prusa_gyroid.gcode"), prof, Options())
        sc.plan_inputs(strokes, prof, Options())
        for st in strokes:
            if st.kind == K_CURVE and st.curv is not None:
                _CURVES.setdefault(st.curv.d.size, []).append((st, st.curv, curves.CurveGeom(st, prof)))
    return _CURVES


@pytest.mark.parametrize("mix", ["own", "blocks", "mixed", "one"])
def test_stacked_rows_are_the_runs_takes(mix):
    rng = np.random.default_rng(48)
    n_groups = 0
    for n, rows in _curves().items():
        if mix == "own":
            gs = [own for _, _, own in rows]
        elif mix == "blocks":
            gs = [g for _, g, _ in rows]
        elif mix == "mixed":
            gs = [own if rng.random() < 0.5 else g for _, g, own in rows]
        else:
            gs = [rows[0][2]]
        if mix == "own":
            assert len({id(g._b) for g in gs}) == len(gs)       # a block each
        want = _stacked_runs_old(gs)
        got = curves._stacked_runs(gs)
        assert _bits(got[0], want[0]) and got[1] == want[1] and got[2] == want[2]
        runs, ks = got[1], got[2]
        for b, _, _ in runs:                     # a new array, not a block's own
            assert not np.shares_memory(got[0], b.d)
        U = curves._stack_u(gs, runs, ks, got[0])
        assert _bits(U, _stack_u_tail_old(runs, ks))
        for b, _, _ in runs:
            assert b._u is None or not np.shares_memory(U, b._u)
        D2, U2 = curves.stack_du(gs)
        assert _bits(D2, want[0]) and _bits(U2, U) and _bits(curves.stack_d(gs), want[0])
        n_groups += 1
    assert n_groups >= 3


@pytest.mark.parametrize("seed", range(4))
def test_predict_rows_are_the_row_loop(seed):
    rng = np.random.default_rng(480 + seed)
    m, n = 400, rng.integers(3, 12)
    S_ = np.cumsum(rng.uniform(0.05, 2.0, (m, n)), axis=1)
    S_[:, 0] = 0.0
    V = rng.uniform(0.0, 200.0, (m, n)) * rng.choice([1.0, 1e-9], (m, 1))
    A = rng.uniform(0.0, 5000.0, (m, n - 1)) * rng.choice([1.0, 1e-15, 0.0], (m, 1))
    V[rng.random((m, n)) < 0.01] = np.nan
    cos_turn = rng.uniform(0.6, 1.0, (m, n - 2))

    def ends():
        c = rng.uniform(0.5, 1.0, m).tolist()
        for k in np.flatnonzero(rng.random(m) < 0.2).tolist():
            c[k] = None
        for k in np.flatnonzero(rng.random(m) < 0.02).tolist():
            c[k] = float("nan")
        c[0] = CORNER_COS                         # the test's bound itself
        return c
    c0, c1 = ends(), ends()
    with np.errstate(all="ignore"):
        want = _predict_rows_old(S_, V, A, cos_turn, c0, c1)
        got = curves._predict_rows(S_, V, A, cos_turn, c0, c1)
    assert [type(x) for x in got[1]] == [type(x) for x in want[1]]
    assert {type(x) for x in want[1]} == {float, np.float64}
    assert _bits(np.array(got[0]), np.array(want[0])) and _bits(np.array(got[1]), np.array(want[1]))
    assert [type(x) for x in got[0]] == [type(x) for x in want[0]]
