"""Issue 8 (s40, "gather"): row gathers by np.take (chains._figures' permutation and its
way back, _classify_block's chain caps, _settle_rows' and the segment rows' blocks,
curves._stacked_runs) and _remember's table made of its good rows only.

The references are the code as it was (fancy indexes; _figures and _remember kept here
verbatim): planning real sample files with each, every chain's memo (its rows' figures,
caps) and the plan compared bit for bit; and np.take against the fancy index it replaces
on varied rows."""
import os
from array import array

import numpy as np
import pytest

from gcode_opt import chains, pipeline, schedule
from gcode_opt.chains import _at, _figures_sorted, _own_source
from gcode_opt.profile import load_profile
from test_speed52_memo52_figs import _finish_old

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")


def _figures_old(strokes, rows, pin, T, beta, profile, rules):
    """chains._figures as it was (7f6c18e)."""
    from gcode_opt import curves
    n, k = T.shape
    if n == 0:
        return _figures_sorted(strokes, rows, pin, T, beta, profile, rules)
    nseg = np.array(curves.seg_counts([curves.geom(strokes[i], profile) for i in rows.tolist()]), np.int64)
    perm = np.argsort(nseg, kind="stable")
    if np.all(perm[1:] > perm[:-1]):
        return _figures_sorted(strokes, rows, pin, T, beta, profile, rules, nseg)
    got = _figures_sorted(strokes, rows[perm], pin, T[perm], beta[perm], profile, rules, nseg[perm])
    out = []
    for a in got:
        b = np.empty_like(a)
        b[perm] = a
        out.append(b)
    return tuple(out)


def _remember_old(sts, j, c, t, good, T, beta, kept, src=None, a=0):
    """chains._remember as it was (7f6c18e)."""
    R = j.size
    first = np.r_[True, j[1:] != j[:-1]]
    tab = np.stack([t, _at(T, j, c), _at(beta, j, c), np.arange(R, dtype=float)], axis=1)
    q = np.flatnonzero(good)
    q = q[np.lexsort((-q, j[q]))]
    figs = array("d")
    figs.frombytes(np.ascontiguousarray(tab[q]).tobytes())
    cnt = np.bincount(j[q], None, j[-1] + 1 if R else 0).tolist()
    lo = 0
    for jj in j[first].tolist():
        k = cnt[jj]
        if k:
            memo = sts[jj].chain_T
            if memo.figs is None and memo.src is None:
                if src is not None:
                    memo.src, memo.src_i = src, a + jj
                memo.figs, memo.kept, memo.at, memo.n = figs, kept, lo, k
                memo.seg_tin = None
            else:
                if src is not None:
                    _own_source(memo, src, a + jj)
                memo.put_shared(figs, lo, k, kept)
            lo += k


def _classify_block_old(b, sts, jerk, fresh=False, memo=None, unput=False, hit=None):
    """chains._classify_block as it was (7f6c18e), called as classify calls it now (ana64):
    where classify left the block's geometries unput, they are put first, as build_geoms
    then did (memo and hit: a new ChainMemo a chain and the feeds' own test, as then)."""
    from gcode_opt import curves, objfields
    from gcode_opt.chains import CHAIN_CAP_MARGIN, ChainMemo, _V_FEED
    if unput:
        curves.put_rows(b, sts, None, False)
    if not (b.cap_min and isinstance(b.cap, np.ndarray) and b.caps.ndim == 2 and b.caps.shape[1] > 0):
        return False
    if not fresh and jerk and any(st.curv._j1 is not curves._FROM_BLOCK for st in sts):
        return False             # (a geometry's own caps at the whole jerk: one by one)
    if fresh:
        ks, cap = None, b.cap
    else:
        ks = np.array([st.curv._k for st in sts], np.int64)
        cap = b.cap[ks]
    feed = objfields.float_col(sts, "v_feed")          # (one compiled pass)
    feed = curves.floats_of(map(_V_FEED, sts), len(sts)) if feed is None else feed
    hit = np.flatnonzero(cap < feed).tolist()
    if not hit:
        return True
    caps1 = None
    if jerk and b.caps_jerk1 is not None:
        caps1 = CHAIN_CAP_MARGIN * b.caps_jerk1[hit if ks is None else ks[hit]]
    for i, q in enumerate(hit):
        st = sts[q]
        st.chain_T = ChainMemo()         # the mark of a chain (plan_kind)
        g = st.curv
        if caps1 is not None and g.chain_caps is None:     # vertex_caps: its caps now, the
            # whole jerk's read no more; a copy of its own, not a view: _drop frees each
            # chain's as its plan is made (a view would hold the block's whole array while
            # any chain of it, not re-timed, keeps its caps)
            g.chain_caps = caps1[i].copy()
            g.caps_jerk1 = None
    return True



def _planned(name, prof, monkeypatch, old):
    if old:
        monkeypatch.setattr(chains, "_figures", _figures_old)
        monkeypatch.setattr(chains, "_remember", _remember_old)
        monkeypatch.setattr(chains, "_classify_block", _classify_block_old)
        # (s52, memo52: the finishing whose kept laws hold their rows' T, beta and predicted
        # times themselves, as _remember_old's callers' did; the new one leaves them to _remember)
        monkeypatch.setattr(chains._Finisher, "_finish", _finish_old)
        monkeypatch.setattr(chains, "_finish_ragged", lambda *a, **k: None)    # (s52, cpu52: not in the old code)
    block_caps = []
    classify = chains._classify_block

    def rec_caps(b, sts, jerk, fresh=False, **kw):
        got = classify(b, sts, jerk, fresh, **kw)
        block_caps.append([None if st.chain_T is None or st.curv.chain_caps is None
                           else chains._caps_array(st.curv.chain_caps).tobytes() for st in sts])
        return got
    monkeypatch.setattr(chains, "_classify_block", rec_caps)
    figures = []
    real = chains._figures

    def rec(*args):
        got = real(*args)
        figures.append([(a.dtype, a.shape, a.tobytes()) for a in got])
        return got
    monkeypatch.setattr(chains, "_figures", rec)
    profile = load_profile(prof)
    opts = pipeline.Options()
    opts.ringing = False
    strokes, sim0 = pipeline.analyse(os.path.join(SAMPLES, name), profile, opts)
    pin = schedule.plan_inputs(strokes, profile, opts)
    plan = schedule.plan_strokes(strokes, pin, profile, opts, opts.max_slowdown_r * sim0.time_t)
    monkeypatch.undo()
    memos = []
    for st in strokes:
        memo = st.chain_T
        if memo is None:
            continue
        figs = None if memo.figs is None else np.frombuffer(memo.figs, float)[4 * memo.at:4 * (memo.at + memo.n)]
        caps = getattr(st.curv, "chain_caps", None)
        memos.append((None if figs is None else figs.tobytes(), memo.n,
                       None if caps is None else np.asarray(chains._caps_array(caps)).tobytes()))
    return block_caps, figures, memos, (plan.retime.tobytes(), list(plan.reason), plan.t_pred.tobytes(), plan.a2_pred.tobytes(),
                            plan.T.tobytes(), plan.beta.tobytes())


@pytest.mark.parametrize("name,prof", [("prusa_gyroid_fullspeed_klipper.gcode", "voron24"),
                                       ("prusa_gyroid_fullspeed.gcode", "prusa-mk3s"),
                                       ("prusa_gyroid.gcode", "prusa-mk3s")])
def test_chain_figures_and_memos_as_before(name, prof, monkeypatch):
    old = _planned(name, prof, monkeypatch, True)
    new = _planned(name, prof, monkeypatch, False)
    assert new[1] and new[2]                       # chains were planned
    assert any(m[0] is not None for m in new[2])   # with remembered rows
    if prof == "prusa-mk3s":                       # (classic jerk: the chains' caps kept)
        assert any(c is not None for cs in new[0] for c in cs)
    assert new == old


@pytest.mark.parametrize("seed", range(6))
def test_take_rows_as_fancy_index(seed):
    rng = np.random.default_rng(seed)
    shape = (int(rng.integers(1, 400)), int(rng.integers(0, 9)))
    for dtype in (float, bool, np.int64):
        A = (rng.standard_normal(shape) * 1e3).astype(dtype)
        for idx in (rng.integers(0, shape[0], int(rng.integers(0, 2 * shape[0]))),
                    np.flatnonzero(rng.random(shape[0]) < 0.5), rng.permutation(shape[0])):
            for src in (A, np.asfortranarray(A), A[:, ::-1]):
                got, ref = src.take(idx, axis=0), src[idx]
                assert got.dtype == ref.dtype and got.shape == ref.shape and got.tobytes() == ref.tobytes()
            perm = rng.permutation(shape[0])         # _figures' way back: b[perm] = a as a[back]
            b = np.empty_like(A)
            b[perm] = A
            back = np.empty_like(perm)
            back[perm] = np.arange(perm.size)
            assert A.take(back, axis=0).tobytes() == b.tobytes()
