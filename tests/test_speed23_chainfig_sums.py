"""Issue 8 (s23, chainfig): the chains' candidate figures and segment plans with less
per-chain Python, the same bits.  Each change is held to the code it replaced (kept here
verbatim from 0d0dc03) on real chains of the sample files, under classic jerk (grouped
finishing, C core), square corner velocity (grouped) and junction deviation (chain by
chain):

  _inner_s         the interior vertices' arc lengths of a chunk of chains in one
                   piece_cumsum call, not g.s_v[1:-1] chain by chain;
  _finish_core     the chains' numbers gathered in one pass (_cf_row), not a list per column;
  _again_plans     one finishing of a re-solved row (its acc and feed from the call that
                   predicts its figures), not that call and then _replay's;
  _replay          the chosen rows gathered base by base, not row() and np.stack;
  plan_chain_segments  a chain asked again for the duration its last plan was made for,
                   its rows unchanged, skips law_T (the law duration is the plan's)."""
import math

import numpy as np
import pytest

from gcode_opt import chains, curves
from gcode_opt.laws import chain as chain_law
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.schedule import plan_inputs
from gcode_opt.segments import SegmentRules
from gcode_opt.strokes import K_CHAIN

FILES = ["sample_gcode/prusa_gyroid_fullspeed.gcode", "sample_gcode/prusa_gyroid_fullspeed_klipper.gcode"]
_CACHE = {}


def _chains(path, prof_name):
    key = (path, prof_name)
    if key not in _CACHE:
        prof = load_profile(prof_name)
        opts = Options()
        opts.ringing = False
        strokes, _ = analyse(path, prof, opts)
        pin = plan_inputs(strokes, prof, opts)
        rows = np.array([i for i, s in enumerate(strokes) if chains.plan_kind(s) == K_CHAIN], int)
        _CACHE[key] = (strokes, pin, rows, prof)
    return _CACHE[key]


def _fresh(path, prof_name):
    strokes, pin, rows, prof = _chains(path, prof_name)
    for i in rows.tolist():
        strokes[i].chain_T = chains.ChainMemo()
        strokes[i].curv = None            # the geometry as planning makes it (its caps read once)
    curves.build_geoms([strokes[i] for i in rows.tolist()], prof, jerk1=True)
    return strokes, pin, rows, prof, SegmentRules.for_profile(prof, 10)


def _bits(x):
    return None if x is None else np.ascontiguousarray(np.asarray(x, float)).view(np.int64).tobytes()


def _same_plan(p, w):
    return all(_bits(getattr(p, f)) == _bits(getattr(w, f)) for f in ("s", "v", "accel", "feed", "time_t", "int_a2"))


# the C paths under test need the chain core (a build without a compiler: the Python paths,
# which these tests compare against, are all that runs)
needs_core = pytest.mark.skipif(chain_law.CORE_MOD is None, reason="chain core not built")


# ---------------------------------------------------------------- _inner_s
def _ref_inner_s(gs):
    return np.concatenate([g.s_v[1:-1] for g in gs])


@needs_core
@pytest.mark.parametrize("path", FILES)
def test_inner_s_is_each_geometrys_s_v(path, monkeypatch):
    strokes, pin, rows, prof = _chains(path, "prusa-mk3s")
    gs = [curves.geom(strokes[i], prof) for i in rows.tolist()]
    assert len(gs) > 100
    want = _ref_inner_s(gs)
    assert chain_law.CORE_MOD is not None          # the C path is the one under test
    assert _bits(chains._inner_s(gs)) == _bits(want)
    for a, b in ((0, 1), (3, 40), (17, len(gs))):  # chunks of any size, any start
        assert _bits(chains._inner_s(gs[a:b])) == _bits(_ref_inner_s(gs[a:b]))
    monkeypatch.setattr(chain_law, "CORE_MOD", None)
    assert _bits(chains._inner_s(gs)) == _bits(want)


class _G:
    """A geometry of segment lengths d (what _inner_s reads: d, and s_v for the reference)."""

    def __init__(self, d):
        self.d = np.asarray(d, float)

    @property
    def s_v(self):
        s = np.empty(self.d.size + 1)
        s[0] = 0.0
        np.cumsum(self.d, out=s[1:])
        return s


def test_inner_s_adds_in_cumsums_order():
    """Lengths over 30 decades: any other order of the additions rounds differently."""
    rng = np.random.default_rng(5)
    gs = [_G(10.0 ** rng.uniform(-15, 15, int(n))) for n in rng.integers(1, 40, 300)]
    assert _bits(chains._inner_s(gs)) == _bits(_ref_inner_s(gs))
    # (the test can tell: one running sum over all chains, each chain's start taken off,
    # is not each chain's own sums)
    d = np.concatenate([g.d for g in gs])
    n = np.array([g.d.size for g in gs])
    run = np.cumsum(d)
    start = np.concatenate([[0.0], run[np.cumsum(n)[:-1] - 1]])
    other = np.concatenate([(run[a:a + k] - s0)[:-1] for a, k, s0 in zip(np.cumsum(n) - n, n, start)])
    assert _bits(other) != _bits(_ref_inner_s(gs))
    gs.append(_G([]))                      # a chain without segments: the reference's way
    assert _bits(chains._inner_s(gs)) == _bits(_ref_inner_s(gs))


# ---------------------------------------------------------------- _finish_core
def ref_finish_core(sts, gs, own, vk, tk, rules, profile, predict, core=None):
    """chains._finish_core at 0d0dc03 (verbatim but for the module names)."""
    GROUP_JUNCTIONS, _CF_NO_W, TRAP_GRID = chains.GROUP_JUNCTIONS, chains._CF_NO_W, chains.TRAP_GRID
    core = chain_law.CORE_MOD if core is None else core
    fn = getattr(core, "chain_finish", None) if core else None
    if fn is None or rules.junction not in GROUP_JUNCTIONS or profile.junction != rules.junction:
        return None
    jerk = rules.junction == "jerk"
    n, m, R = gs[0].d.size, len(sts), vk.shape[0]
    D = np.stack([g.d for g in gs])
    if vk.shape != (R, n + 1) or tk.shape != (R, n) or D.shape != (m, n):
        return None
    U = np.stack([g.u for g in gs])
    C = np.einsum("mij,mij->mi", U[:, :-1], U[:, 1:]) if n > 1 else np.empty((m, 0))
    W, ws = _CF_NO_W, 0
    if profile.block_buffer > 0:
        nb = max(profile.block_buffer - 3, 1)
        ext = np.empty((m, n + nb))
        ext[:, :n] = D
        ext[:, n:] = D[:, n - 1:n]
        W, ws = np.convolve(ext.ravel(), np.ones(nb), "valid"), n + nb
    lims = [st.lim for st in sts]
    nan2 = (math.nan, math.nan)
    pu = np.array([nan2 if w is None else w for w in (st.prev_u for st in sts)], float).reshape(m, 2)
    nu = np.array([nan2 if w is None else w for w in (st.next_u for st in sts)], float).reshape(m, 2)
    P = np.zeros((m, 18))
    P[:, 0] = [min(st.accel, lim.ax_max, lim.ay_max) for st, lim in zip(sts, lims)]    # _a_top
    P[:, 8] = [st.v0 for st in sts]
    P[:, 9] = [st.v1 for st in sts]
    P[:, 10] = pu[:, 0] * U[:, 0, 0] + pu[:, 1] * U[:, 0, 1]
    P[:, 11] = U[:, -1, 0] * nu[:, 0] + U[:, -1, 1] * nu[:, 1]
    if jerk:
        P[:, 1] = [st.v_feed for st in sts]
        P[:, 3] = [lim.jerk_x for lim in lims]
        P[:, 4] = [lim.jerk_y for lim in lims]
        P[:, 2] = curves.JERK_F_STEP_R * np.minimum(P[:, 3], P[:, 4])
    else:
        P[:, 2] = math.inf
        P[:, 5] = [lim.scv for lim in lims]
        P[:, 6] = [lim.ax_max for lim in lims]
        P[:, 7] = [lim.ay_max for lim in lims]
        hp = np.array([st.prev_u is not None for st in sts], bool)
        hn = np.array([st.next_u is not None for st in sts], bool)
        P[hp, 12:14], P[hp, 14] = pu[hp], 1.0
        P[hn, 15:17], P[hn, 17] = nu[hn], 1.0
    acc, feed = np.empty((R, n)), np.empty((R, n))
    t, a2, fits = np.empty(R), np.empty(R), np.empty(R, bool)
    if not fn(0 if jerk else 1, 1 if predict else 0, np.ascontiguousarray(own, np.int64),
              np.ascontiguousarray(vk, float), np.ascontiguousarray(tk, float), D, U, C, W, ws,
              P, TRAP_GRID, chains._cf_consts(profile), acc, feed, t, a2, fits):
        return None
    return (acc, feed, t, a2, fits) if predict else (acc, feed, None, None, fits)


class _Spy:
    """Records what chain_finish is handed (every argument but the outputs, copied)."""

    def __init__(self, core):
        self.core, self.calls = core, []

    def chain_finish(self, *a):
        self.calls.append([np.array(x, copy=True) if isinstance(x, np.ndarray) else x for x in a[:13]])
        return self.core.chain_finish(*a)


@needs_core
@pytest.mark.parametrize("prof_name", ["prusa-mk3s", "voron24"])
def test_finish_core_hands_the_core_what_it_did(prof_name, monkeypatch):
    """The candidate table and the plans of one column made through _finish_core: every call
    gives what the 0d0dc03 code gives (outputs, bit for bit), and hands the core the same
    per-chain arrays P, D, U, COS, W (the spy sees the new code's inputs; the reference's
    made here again from the same call)."""
    strokes, pin, rows, prof, rules = _fresh(FILES[0], prof_name)
    seen = []
    real = chains._finish_core

    def spy(*a, **k):
        got = real(*a, **k)
        du = k.pop("du", None)         # (s32: the caller's curves.stack_du, which the reference makes)
        if du is not None:
            D, U = curves.stack_du(a[1])
            assert _bits(du[0]) == _bits(D) and _bits(du[1]) == _bits(U)
        want = ref_finish_core(*a, **k)
        if got is None or want is None:
            same = got is None and want is None
        else:
            same = all(_bits(x) == _bits(y) for x, y in zip(got, want))
        seen.append((a[0], same))
        return got
    monkeypatch.setattr(chains, "_finish_core", spy)
    # (the plans' replay finished batch by batch, through _finish_core: not by replay55's one
    # ragged call a group)
    ragged = chains._finish_ragged
    monkeypatch.setattr(chains, "_finish_ragged", lambda *a, predict=True, **k: ragged(*a, **k) if predict else None)
    T, beta, I, _ = chains.candidates_chain(pin, rows, strokes, prof, rules)
    c = chains.CHAIN_COLS[1]
    ok = np.isfinite(I[:, c])
    chains.plan_chain_segments([strokes[i] for i in rows[ok]], T[ok, c], beta[ok, c], rules, prof)
    assert len(seen) > 5
    assert all(r is True for _, r in seen), [r for _, r in seen if r is not True][:3]
    # and the arrays themselves, on one call's chains, through a spy on the core
    sub = [strokes[i] for i in rows.tolist() if curves.geom(strokes[i], prof).d.size == 6][:40]
    assert len(sub) > 5
    gs = [curves.geom(st, prof) for st in sub]
    rng = np.random.default_rng(1)
    vk = rng.uniform(5, 60, (len(sub), 7))
    tk = rng.uniform(0.01, 0.2, (len(sub), 6))
    own = np.arange(len(sub))
    a, b = _Spy(chain_law.CORE_MOD), _Spy(chain_law.CORE_MOD)
    keep = [(st.prev_u, st.next_u) for st in sub]
    try:            # neighbours of every kind at both ends (the sample's chains end at stops)
        sub[0].prev_u, sub[0].next_u = None, (0.6, -0.8)
        sub[1].prev_u, sub[1].next_u = (-1.0, 0.0), None
        sub[2].prev_u, sub[2].next_u = None, None
        sub[3].prev_u, sub[3].next_u = (0.0, 1.0), (math.sqrt(0.5), math.sqrt(0.5))
        real(sub, gs, own, vk, tk, rules, prof, True, core=a)
        ref_finish_core(sub, gs, own, vk, tk, rules, prof, True, core=b)
    finally:
        for st, (p, q) in zip(sub, keep):
            st.prev_u, st.next_u = p, q
    assert len(a.calls) == len(b.calls) == 1
    for x, y in zip(a.calls[0], b.calls[0]):
        assert type(x) is type(y)
        if isinstance(x, np.ndarray):
            assert x.shape == y.shape and x.dtype == y.dtype and x.tobytes() == y.tobytes()
        else:
            assert x == y


# ---------------------------------------------------------------- _again_plans
def ref_again_plans(items, rules, profile):
    """chains._again_plans at 0d0dc03 (verbatim but for the module names): the rows'
    figures by one finishing, their acc and feed by _replay's."""
    got = chains._knots_again([(st, ag.src, st.chain_T.src_i if ag.i is None else ag.i, T, b)
                               for st, ag, T, b in items], profile)
    grouped = rules.junction in chains.GROUP_JUNCTIONS and profile.junction == rules.junction
    kept = [None] * len(items)
    if grouped:
        by_n = {}
        for q, (vk, _) in enumerate(got):
            by_n.setdefault(vk.shape[1], []).append(q)
        for qs in by_n.values():
            for a in range(0, len(qs), chains.FINISH_ROWS):
                Q = qs[a:a + chains.FINISH_ROWS]
                sts = [items[q][0] for q in Q]
                vk = np.concatenate([got[q][0] for q in Q])
                dt = np.concatenate([got[q][1] for q in Q])
                _, _, t, a2, _ = chains._finish_stacked_dt(sts, [curves.geom(st, profile) for st in sts],
                                                           np.arange(len(Q)), vk, dt, rules, profile)
                for i, q in enumerate(Q):
                    kept[q] = chains._KeptLaws(items[q][1].key, (vk, dt, t, a2), i, 1)
    else:
        for q, (st, ag, _, _) in enumerate(items):
            vk, dt = got[q]
            _, _, t, a2, _ = chains._finish_rows_dt(st, vk, dt, rules, profile)
            kept[q] = chains._KeptLaws(ag.key, (vk, dt, t, a2), 0, 1)
    return chains._replay([(st, kp, 0) for (st, _, _, _), kp in zip(items, kept)], rules, profile)


@pytest.mark.parametrize("prof_name", ["prusa-mk3s", "voron24", "ender3"])
def test_again_plans_finish_once(prof_name):
    """Every good row of every chain, its knots dropped, made again: the plans of one
    finishing are the 0d0dc03 plans (its finishing, then _replay's), bit for bit; all rows
    at once and one row a chain.  ender3 (junction deviation) finishes chain by chain."""
    strokes, pin, rows, prof, rules = _fresh(FILES[0], prof_name)
    chains.candidates_chain(pin, rows, strokes, prof, rules)
    items = []
    for i in rows.tolist():
        st = strokes[i]
        for t, TL, b, r, kept in st.chain_T.rows():
            items.append((st, TL, b))
        chains._drop(st)
    assert len(items) > 1000
    mk = lambda sel: [(items[q][0], items[q][0].chain_T.kept, items[q][1], items[q][2]) for q in sel]  # noqa: E731
    allq = range(len(items))
    got, want = chains._again_plans(mk(allq), rules, prof), ref_again_plans(mk(allq), rules, prof)
    assert all(_same_plan(p, w) for p, w in zip(got, want))
    firsts = sorted({id(it[0]): q for q, it in reversed(list(enumerate(items)))}.values())
    got, want = chains._again_plans(mk(firsts), rules, prof), ref_again_plans(mk(firsts), rules, prof)
    assert len(firsts) > 100 and all(_same_plan(p, w) for p, w in zip(got, want))


# ---------------------------------------------------------------- plan_chain_segments' last plan
def test_last_plan_taken_without_law_T_while_rows_unchanged(monkeypatch):
    strokes, pin, rows, prof, rules = _fresh(FILES[0], "prusa-mk3s")
    T, beta, I, _ = chains.candidates_chain(pin, rows, strokes, prof, rules)
    c = chains.CHAIN_COLS[2]
    ok = np.isfinite(I[:, c])
    sts = [strokes[i] for i in rows[ok]]
    Tc, bc = T[ok, c], beta[ok, c]
    first = chains.plan_chain_segments(sts, Tc, bc, rules, prof)
    calls = []
    real = chains.law_T
    # (s32: plan_chain_segments asks each memo once, ChainMemo.ask, which reads the rows,
    # as law_T did, unless its last plan was asked for this duration: those asks recorded)
    real_ask = chains.ChainMemo.ask

    def ask(memo, t, b, key):
        if not (memo.seg is not None and memo.seg_tin == t):
            calls.append(next(x for x in sts if x.chain_T is memo))
        return real_ask(memo, t, b, key)
    monkeypatch.setattr(chains.ChainMemo, "ask", ask)
    again = chains.plan_chain_segments(sts, Tc, bc, rules, prof)
    assert calls == [] and all(p is q for p, q in zip(first, again))
    # a chain's rows change (a put: what its predicted duration maps to may change): law_T
    # is asked, and the chain planned for the law duration its rows now give, as before
    st = sts[0]
    new_T = st.chain_T.seg_T * 1.01
    # (kept under another rules key: the chain is solved cold at new_T)
    st.chain_T.put(float(Tc[0]), new_T, float(bc[0]), chains._KeptLaws(None, None, 0, 0), 0)
    assert real(st, float(Tc[0])) == new_T
    third = chains.plan_chain_segments(sts, Tc, bc, rules, prof)
    assert len(calls) == 1 and calls[0] is st
    assert st.chain_T.seg_T == new_T and third[0] is not first[0]
    assert all(p is q for p, q in zip(first[1:], third[1:]))
    # a duration of its last plan's law asked by another predicted duration: the plan is
    # its last one (law_T maps both to it), as before
    st1 = sts[1]
    calls.clear()
    got = chains.plan_chain_segments([st1], [st1.chain_T.seg_T], [float(bc[1])], rules, prof)
    if st1.chain_T.seg_T != float(Tc[1]):
        assert len(calls) == 1 and calls[0] is st1
    assert got[0] is first[1]


# ---------------------------------------------------------------- _replay's rows
def ref_replay(items, rules, profile, drop=False):
    """chains._replay at 0d0dc03 (verbatim but for the module names): row() and np.stack."""
    out = [None] * len(items)
    grouped = rules.junction in chains.GROUP_JUNCTIONS and profile.junction == rules.junction
    gs = [curves.geom(st, profile) for st, _, _ in items]
    sk = lambda st: chains._knots_s(st.ends_d)       # noqa: E731
    assert grouped
    by_n = {}
    for q, g in enumerate(gs):
        by_n.setdefault(g.d.size, []).append(q)
    for qs in by_n.values():
        for a in range(0, len(qs), chains.FINISH_ROWS):
            Q = qs[a:a + chains.FINISH_ROWS]
            rows = [items[q][1].row(items[q][2], items[q][0]) for q in Q]
            vk, dt = np.stack([x[0] for x in rows]), np.stack([x[1] for x in rows])
            sts = [items[q][0] for q in Q]
            acc, feed, _, _, _ = chains._finish_stacked_dt(sts, [gs[q] for q in Q], np.arange(len(Q)), vk, dt,
                                                           rules, profile, predict=False)
            for i, q in enumerate(Q):
                out[q] = chains.SegmentPlan(sk(sts[i]), vk[i], acc[i], feed[i], rows[i][2], rows[i][3])
    return out


@pytest.mark.parametrize("prof_name", ["prusa-mk3s", "voron24"])
def test_replay_gathers_the_rows_row_would_give(prof_name):
    """Every kept row of every chain (rows of many finishing batches in one group), and a
    mixed pick of one row a chain: _replay's plans are the 0d0dc03 replay's, bit for bit,
    their figures Python floats as row() gives them."""
    strokes, pin, rows, prof, rules = _fresh(FILES[0], prof_name)
    chains.candidates_chain(pin, rows, strokes, prof, rules)
    items = [(strokes[i], kept, int(r)) for i in rows.tolist() for _, _, _, r, kept in strokes[i].chain_T.rows()]
    assert len(items) > 1000 and len({id(k.base) for _, k, _ in items}) > 3
    got, want = chains._replay(items, rules, prof), ref_replay(items, rules, prof)
    assert all(_same_plan(p, w) for p, w in zip(got, want))
    assert all(type(p.time_t) is float and type(p.int_a2) is float for p in got)
    rng = np.random.default_rng(11)
    pick = [it for it in items if rng.random() < 0.25]
    got, want = chains._replay(pick, rules, prof), ref_replay(pick, rules, prof)
    assert len(pick) > 200 and all(_same_plan(p, w) for p, w in zip(got, want))
