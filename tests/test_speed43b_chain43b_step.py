"""Session 43b (chain43b): the chain core's active_step in fewer passes -- the binding masks
gathered from hist[-1] while each chain's binding vertices are counted, the scale's |a0| and
|a1| maxima in one loop, and the released vertices' masks made again only in a chain that
releases (rel) -- must give what the former loop (REFERENCE below, its C transliterated:
the same float operations) gives, every output bit for bit: on every active_step call of
real chains (cold and warm solves, pieces True and False) and on made-up steps (negative
multipliers with and without violations, cycling, nan accelerations, multipliers given)."""
import math

import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.laws import chain as lc

from test_speed_chains import _chain_problems  # noqa: E402

CORE = lc.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "active_step"), reason="no chain core")


# ------------------------------------------------------------------ REFERENCE (int c42fbc2's C loop)
def _np_max(a, b):
    return a if (a >= b or a != a) else b


def ref_active_step(vi, roff, bv, vv, cv, a0, a1, koff, mug, hist, cap_f, mu_tol, last, nw, done, cyc, bound,
                    vt, vert_t, warm, act, res_v=None, res_t=None):
    if bv is None:
        bv = (hist[-1][vi] != 0).astype(np.uint8)
    H = len(hist)
    for r in range(roff.size - 1):
        q0, q1 = int(roff[r]), int(roff[r + 1])
        p0, p1 = int(koff[r]) - r, int(koff[r + 1]) - r - 1
        scale = 0.0
        for p in range(p0, p1):
            scale = _np_max(scale, math.fabs(a0[p]))
        for p in range(p0, p1):
            scale = _np_max(scale, math.fabs(a1[p]))
        scale = _np_max(scale, 1e-9)
        any_viol = any_neg = 0
        mu_min, worst, p = 0.0, -1, p0
        for q in range(q0, q1):
            if bv[q]:
                if mug is not None:
                    m = float(mug[p - r])
                else:
                    m = (float(a0[p + 1]) - float(a1[p])) / scale
                    m = m if m < -mu_tol else 0.0
                p += 1
                if m < 0:
                    any_neg = 1
                if worst < 0 or m < mu_min:
                    mu_min, worst = m, q
                nw[q] = 2 | (m < 0)
            else:
                viol = int(float(vv[q]) > float(cv[vi[q]]) * cap_f + 1e-12)
                any_viol |= viol
                nw[q] = viol
        rel = (not any_viol) and any_neg
        for q in range(q0, q1):
            nw[q] = int(not (rel and (nw[q] & 1))) if (nw[q] & 2) else nw[q]
        moving = any_viol or any_neg

        def seen_now():
            return any(all((h[vi[q]] != 0) == (nw[q] != 0) for q in range(q0, q1)) for h in hist[:H])
        seen = seen_now() if (rel or moving) else False
        if rel and seen:
            for q in range(q0, q1):
                nw[q] = int(bv[q] != 0)
            nw[worst] = 0
            seen = seen_now()
        cy = moving and seen
        dn = (not moving) or cy
        if last:
            cy, dn = cy or moving, 1
        cyc[r], done[r] = cy, dn
        if not dn:
            for q in range(q0, q1):
                bound[vi[q]] = nw[q]
                vt[vi[q]] = vert_t[q]
            warm[act[r]] = 1
        elif res_v is not None:
            for q in range(q0, q1):
                res_v[vi[q]] = vv[q]
                res_t[vi[q]] = vert_t[q]
# ------------------------------------------------------------------ end of REFERENCE

_OUT = (13, 14, 15, 16, 17, 19)          # new, done, cyc, bound, vt, warm (args' places)


def _both(args, nres=None):
    """active_step and the reference on copies of args: every output the same bits."""
    a = [x.copy() if isinstance(x, np.ndarray) else x for x in args]
    b = [x.copy() if isinstance(x, np.ndarray) else x for x in args]
    CORE.active_step(*a)
    hist = [np.asarray(h) for h in b[9]]
    ref_active_step(*b[:9], hist, *b[10:])
    for i in _OUT + tuple(range(21, len(args))):
        x, y = np.asarray(a[i]), np.asarray(b[i])
        if i == 13:        # new: the released and unreleased binding vertices as 0 / 1 both
            x, y = x != 0, y != 0
        assert x.tobytes() == y.tobytes(), i


def _calls(monkeypatch):
    calls = []
    orig = CORE.active_step

    class Rec:
        def __getattr__(self, name):
            return getattr(CORE, name)

        def active_step(self, *a):
            calls.append([x.copy() if isinstance(x, np.ndarray) else
                          ([h.copy() for h in x] if isinstance(x, list) else x) for x in a])
            return orig(*a)
    monkeypatch.setattr(lc, "CORE_MOD", Rec())
    for prof in ("prusa-mk3s", "voron24"):
        sts, T0, profile = _chain_problems(prof)
        for ratio in (1.0, 1.1):
            T = T0 * ratio
            fl = lc._Flat(chains._problems(sts, T, (T / chains.GAMMA_MIN) ** 2, profile))
            for pieces in (True, False):
                res = lc.solve_flat(fl, lc.cold_binding(fl), np.zeros(fl.sv.size), np.zeros(fl.S.size, bool),
                                    pieces)
            T2 = T * 1.02
            fl2 = fl.with_T(T2, (T2 / chains.GAMMA_MIN) ** 2)
            lc.solve_flat(fl2, res.bound.copy(), res.vert_t * 1.02, np.ones(fl.S.size, bool), False)
    monkeypatch.undo()
    return calls


def test_real_calls(monkeypatch):
    calls = _calls(monkeypatch)
    assert len(calls) >= 8
    for a in calls:
        _both(a)
        # the same step with its masks given (bv), with its multipliers given, and as the last
        bv = (a[9][-1][a[0]] != 0).astype(np.uint8)
        _both(a[:2] + [bv] + a[3:])
        _both(a[:12] + [1] + a[13:])


def _made_up(rng, na, H, with_mu, nan):
    npc = rng.integers(1, 6, na)                     # pieces a chain
    nb = npc - 1                                     # its binding vertices
    nf = rng.integers(0, 4, na)                      # and free ones
    nvc = nb + nf
    NV = int(nvc.sum()) + 3
    vi = np.sort(rng.choice(NV, int(nvc.sum()), replace=False)).astype(np.int64)
    roff = np.concatenate([[0], np.cumsum(nvc)]).astype(np.int64)
    koff = np.concatenate([[0], np.cumsum(npc + 1)]).astype(np.int64)
    cur = np.zeros(NV, np.uint8)
    for r in range(na):
        q = np.arange(roff[r], roff[r + 1])
        cur[vi[rng.choice(q, int(nb[r]), replace=False)]] = 1
    P = int(npc.sum())
    a0, a1 = rng.normal(0, 1000, P), rng.normal(0, 1000, P)
    # jumps near -mu_tol x scale and exactly zero
    k = rng.random(P) < 0.3
    a0[k] = a1[np.maximum(np.flatnonzero(k) - 1, 0)]
    # a chain's scale from an a1 far above the rest, its jumps at a multiple of -mu_tol x scale
    # (the scale decides their sign: made from a0 alone, those at 0.5 would be negative)
    for r in range(na):
        p0, p1 = koff[r] - r, koff[r + 1] - r - 1
        if p1 - p0 >= 2 and rng.random() < 0.5:
            a0[p0:p1] = rng.normal(0, 1, p1 - p0)
            a1[p0:p1] = rng.normal(0, 1, p1 - p0)
            big = int(rng.integers(p0, p1))
            a1[big] = 1e4
            for p in range(p0, p1 - 1):
                if p != big:
                    a0[p + 1] = a1[p] - rng.choice([0.5, 1.0, 2.0]) * lc.MU_TOL_R * 1e4
    if nan:
        a0[rng.integers(0, P)] = np.nan
    cv = rng.uniform(50, 150, NV)
    vv = cv[vi] * rng.choice([0.5, 1.0, 1.0 + 2e-7], vi.size)
    hist = [rng.integers(0, 2, NV).astype(np.uint8) for _ in range(H - 1)] + [cur]
    # a mask a release would make, in hist: cycling
    if H > 1:
        hist[0] = cur.copy()
        hist[0][vi[rng.integers(0, vi.size)]] ^= 1 if vi.size else 0
    mug = rng.choice([0.0, -1.0, -1e-3], int(nb.sum())) if with_mu else None
    act = rng.permutation(na + 2)[:na].astype(np.int64)
    return [vi, roff, None, vv, cv, a0, a1, koff, mug, hist, 1 + lc.CAP_TOL_R, lc.MU_TOL_R, 0,
            np.zeros(vi.size, np.uint8), np.zeros(na, np.uint8), np.zeros(na, np.uint8), cur.copy(),
            rng.normal(size=NV), rng.normal(size=vi.size), np.zeros(na + 2, np.uint8), act,
            np.zeros(NV), np.zeros(NV)]


@pytest.mark.parametrize("seed", range(60))
def test_made_up_steps(seed):
    rng = np.random.default_rng(seed)
    a = _made_up(rng, int(rng.integers(1, 8)), int(rng.integers(1, 4)), seed % 3 == 0, seed % 5 == 0)
    _both(a)
    _both(a[:12] + [1] + a[13:])
