"""Issue 8 (s24, chainplan): less per-chain Python around the chains' plans, the same bits.
Each change is held to the code it replaced (kept here verbatim from d8e21e6) on real
chains of the sample files, under classic jerk (prusa-mk3s) and square corner velocity
(voron24):

  classify             the cap test and the chains' caps as row operations on each
                       geometry block (its cap, CHAIN_CAP_MARGIN x caps_jerk1 rows), not
                       np.minimum.reduce and a product a stroke;
  curves.stack_du      _finish_core's stacked d and u taken from the blocks by one fancy
                       index a run of rows, not a view and a copy a geometry;
  _knots_rows          _replay's and _again_plans' knots [0, ends_d] as rows of one array
                       (s50: _ends_rows, each plan's knots made of its ends_d when read);
  plan_chain_segments  its loops on Python floats (no numpy scalar a read), a chain
                       _replay dropped not dropped again."""
import numpy as np
import pytest

from gcode_opt import chains, curves
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.schedule import plan_inputs
from gcode_opt.segments import SegmentRules
from gcode_opt.strokes import K_CHAIN, K_CURVE

FILES = ["sample_gcode/prusa_gyroid_fullspeed.gcode", "sample_gcode/prusa_gyroid.gcode"]
PROFILES = ["prusa-mk3s", "voron24"]
_CACHE = {}


def _strokes(path, prof_name):
    key = (path, prof_name)
    if key not in _CACHE:
        prof = load_profile(prof_name)
        opts = Options()
        opts.ringing = False
        strokes, _ = analyse(path, prof, opts)
        pin = plan_inputs(strokes, prof, opts)
        _CACHE[key] = (strokes, pin, prof)
    return _CACHE[key]


def _bits(x):
    return None if x is None else np.ascontiguousarray(np.asarray(x, float)).view(np.int64).tobytes()


def _same_plan(p, w):
    return all(_bits(getattr(p, f)) == _bits(getattr(w, f)) for f in ("s", "v", "accel", "feed", "time_t", "int_a2"))


def _curves_fresh(strokes, prof):
    """The curve strokes (chains included) unmarked, without geometry."""
    sts = [st for st in strokes if st.kind == K_CURVE]
    for st in sts:
        st.curv, st.chain_T = None, None
    return sts


# ---------------------------------------------------------------- classify
def ref_classify(strokes, rows, profile):
    """chains.classify at d8e21e6 (verbatim but for the module names)."""
    sts = [strokes[i] for i in rows if strokes[i].kind == K_CURVE]
    curves.build_geoms(sts, profile, jerk1=True)
    jerk = profile.junction == "jerk"
    for st in sts:
        g = curves.geom(st, profile)
        caps = g.caps
        if caps.size and curves.CAP_MARGIN * float(np.minimum.reduce(caps)) < st.v_feed:
            st.chain_T = chains.ChainMemo()
            if jerk and g.caps_jerk1 is not None:
                chains.vertex_caps(st, profile)
    if jerk:
        curves.drop_jerk1(sts)


def _marks(sts):
    """What classify leaves: each stroke's chain mark, chain caps, caps at the whole jerk."""
    return [(st.chain_T is not None, _bits(chains._caps_array(st.curv.chain_caps)), _bits(st.curv.caps_jerk1))
            for st in sts]     # (chain caps kept as bytes read as their doubles: s45)


@pytest.mark.parametrize("path", FILES)
@pytest.mark.parametrize("prof_name", PROFILES)
def test_classify_as_d8e21e6(path, prof_name):
    strokes, _, prof = _strokes(path, prof_name)
    sts = _curves_fresh(strokes, prof)
    rows = list(range(len(sts)))
    ref_classify(sts, rows, prof)
    want = _marks(sts)
    assert any(m[0] for m in want) and not all(m[0] for m in want)
    _curves_fresh(sts, prof)
    chains.classify(sts, rows, prof)
    assert _marks(sts) == want
    if prof.junction == "jerk":       # the chains' caps were made (the test can tell them apart)
        assert sum(m[1] is not None for m in want) == sum(m[0] for m in want)


@pytest.mark.parametrize("prof_name", PROFILES)
def test_classify_at_the_cap_itself(prof_name):
    """Feeds set to each curve's cap, one ulp below and above it: the strict test of the
    old code, stroke by stroke (a <= or a rounding of the block's cap would tell)."""
    strokes, _, prof = _strokes(FILES[1], prof_name)
    sts = _curves_fresh(strokes, prof)
    rows = list(range(len(sts)))
    feeds = [st.v_feed for st in sts]
    try:
        curves.build_geoms(sts, prof, jerk1=True)
        caps = [curves.geom(st, prof).cap for st in sts]
        for q, (st, c) in enumerate(zip(sts, caps)):
            st.v_feed = (c, float(np.nextafter(c, 0.0)), float(np.nextafter(c, np.inf)))[q % 3]
        _curves_fresh(sts, prof)
        ref_classify(sts, rows, prof)
        want = _marks(sts)
        assert [m[0] for m in want] == [q % 3 == 2 for q in range(len(sts))]
        _curves_fresh(sts, prof)
        chains.classify(sts, rows, prof)
        assert _marks(sts) == want
    finally:
        for st, f in zip(sts, feeds):
            st.v_feed = f
        _curves_fresh(sts, prof)


def test_classify_blocks_it_declines_go_stroke_by_stroke(monkeypatch):
    """A block whose caps are not all > 0 (cap_min False: Python's min there) and strokes
    with their own caps at the whole jerk are classified one by one, as before."""
    strokes, _, prof = _strokes(FILES[0], "prusa-mk3s")
    sts = _curves_fresh(strokes, prof)
    rows = list(range(len(sts)))
    ref_classify(sts, rows, prof)
    want = _marks(sts)
    _curves_fresh(sts, prof)
    real = curves._block_geoms

    def some_declined(sts_b, block, profile, j1, **kw):
        got = real(sts_b, block, profile, j1, **kw)
        if got is not None and len(sts_b) % 2:
            got[0].cap_min = False
        return got
    monkeypatch.setattr(curves, "_block_geoms", some_declined)
    one = []
    real_one = chains._classify_one
    monkeypatch.setattr(chains, "_classify_one", lambda st, p, j: one.append(st) or real_one(st, p, j))
    chains.classify(sts, rows, prof)
    assert one and len(one) < len(sts)
    assert _marks(sts) == want


# ---------------------------------------------------------------- curves.stack_du
@pytest.mark.parametrize("prof_name", PROFILES)
def test_stack_du_is_the_geometries_rows(prof_name):
    strokes, _, prof = _strokes(FILES[0], prof_name)
    sts = [st for st in strokes if st.kind == K_CURVE]
    by_n = {}
    for st in sts:
        by_n.setdefault(curves.geom(st, prof).d.size, []).append(curves.geom(st, prof))
    n, gs = max(by_n.items(), key=lambda kv: len(kv[1]))
    assert len(gs) > 20
    rng = np.random.default_rng(24)
    for sel in (gs, gs[::-1], [gs[i] for i in rng.integers(0, len(gs), 50)], gs[:1]):
        D, U = curves.stack_du(sel)
        assert _bits(D) == _bits(np.array([g.d for g in sel], float))
        assert _bits(U) == _bits(np.array([g.u for g in sel], float))
        assert D.shape == (len(sel), n) and U.shape == (len(sel), n, 2)

    class _Own:                       # a geometry of another make: row by row
        def __init__(self, g):
            self.d, self.u = g.d, g.u
    D, U = curves.stack_du([_Own(g) for g in gs[:5]] + gs[5:9])
    assert _bits(D) == _bits(np.array([g.d for g in gs[:9]], float))
    assert _bits(U) == _bits(np.array([g.u for g in gs[:9]], float))


# ---------------------------------------------------------------- _knots_rows
# (s50 rowplan50: _knots_rows' block gave way to _ends_rows: each RowPlan's knots made of
# its stroke's own ends_d when read; held to _knots_s all the same)
def test_knots_rows_are_knots_s():
    from gcode_opt.segments import RowPlan
    strokes, _, prof = _strokes(FILES[0], "prusa-mk3s")
    sts = [st for st in strokes if chains.plan_kind(st) == K_CHAIN]
    by_n = {}
    for st in sts:
        by_n.setdefault(len(st.ends_d), []).append(st)
    assert len(by_n) > 3
    for n, group in by_n.items():
        ends = chains._ends_rows(group, n)
        assert ends is not None and len(ends) == len(group)
        V = np.ones((len(group), n + 1))
        A = np.ones((len(group), n))
        for i, st in enumerate(group):
            assert ends[i] is st.ends_d
            assert _bits(RowPlan(ends[i], V, A, A, i, 1.0, 1.0).s) == _bits(chains._knots_s(st.ends_d))
    n, group = next(iter(by_n.items()))
    assert chains._ends_rows(group, n + 1) is None           # another length: one by one

    class _S:
        def __init__(self, e):
            self.ends_d = e
    assert chains._ends_rows([_S(list(group[0].ends_d))], n) is None     # not an array of doubles


# ---------------------------------------------------------------- plan_chain_segments
def ref_plan_chain_segments(strokes, T, beta, rules, profile):
    """chains.plan_chain_segments at d8e21e6 (verbatim but for the module names)."""
    law_T, _rules_key, _Again, _KeptLaws = chains.law_T, chains._rules_key, chains._Again, chains._KeptLaws
    T_in = np.asarray(T, float)
    beta = np.asarray(beta, float)
    out = [None] * len(strokes)
    todo = []
    key = _rules_key(rules, profile)
    T = np.empty(len(strokes))
    for k, (st, t, b) in enumerate(zip(strokes, T_in.tolist(), beta.tolist())):
        memo = st.chain_T
        seg = memo.seg
        if seg is not None and memo.seg_tin == t:
            lt = memo.seg_T
        else:
            lt = law_T(st, t)
        T[k] = lt
        if seg is not None and memo.seg_T == lt and memo.seg_beta == b and memo.seg_key == key:
            out[k] = seg
        else:
            todo.append(k)
    cold, lazy, again = [], [], []
    for k in todo:
        st = strokes[k]
        hit = st.chain_T.plan_of(float(T[k]), float(beta[k]))
        if hit is not None and hit[0].key == key:
            if isinstance(hit[0], _Again):
                again.append((k, hit[0]))
            elif isinstance(hit[0], _KeptLaws):
                lazy.append((k, hit))
            else:
                out[k] = hit[0].plan(hit[1])
        else:
            cold.append(k)
    for (k, _), plan in zip(lazy, chains._replay([(strokes[k], kept, r) for k, (kept, r) in lazy], rules, profile,
                                                 drop=True)):
        out[k] = plan
    if again:
        plans = chains._again_plans([(strokes[k], ag, float(T[k]), float(beta[k])) for k, ag in again], rules,
                                    profile)
        for (k, _), plan in zip(again, plans):
            out[k] = plan
    for k, law in zip(cold, chains.solve([strokes[k] for k in cold], T[cold], beta[cold], profile)):
        out[k] = chains.finish_chain(strokes[k], law, rules, profile)[0]
    for k in todo:
        memo = strokes[k].chain_T
        memo.seg_T, memo.seg_beta, memo.seg_key, memo.seg = float(T[k]), float(beta[k]), key, out[k]
        tt, t = getattr(out[k], "time_t", None), float(T_in[k])
        memo.seg_tin = tt if tt == t else t
        chains._drop(strokes[k])
    return out


def _memo_state(sts):
    out = []
    for st in sts:
        m = st.chain_T
        out.append((m.seg_T, m.seg_beta, m.seg_key, m.seg_tin, type(m.kept).__name__, _bits(chains._caps_array(st.curv.chain_caps))
                    if st.curv is not None else None, [r[:4] for r in m.rows()]))
    return out


@pytest.mark.parametrize("prof_name", PROFILES)
def test_plan_chain_segments_as_d8e21e6(prof_name, monkeypatch):
    """Three plans in a row, as the budget asks them: every chain at a candidate (replayed),
    the same again (each its last plan), then a third of them at another candidate (made
    again: _again_plans) and a few at a duration of no candidate (solved cold).  Plans and
    memos as the old code left them, each run from the same fresh candidate table."""
    path = FILES[0]
    strokes, pin, prof = _strokes(path, prof_name)
    rules = SegmentRules.for_profile(prof, 10)
    rows = np.array([i for i, s in enumerate(strokes) if chains.plan_kind(s) == K_CHAIN], int)
    assert rows.size > 100
    res = {}
    seen = {"replay": 0, "again": 0, "cold": 0}
    for name, real in (("replay", chains._replay), ("again", chains._again_plans), ("cold", chains.solve)):
        def counted(items, *a, _real=real, _name=name, **k):
            seen[_name] += len(items)
            return _real(items, *a, **k)
        monkeypatch.setattr(chains, "_replay" if name == "replay" else "_again_plans" if name == "again" else "solve",
                            counted)
    for name, fn in (("ref", ref_plan_chain_segments), ("new", chains.plan_chain_segments)):
        for i in rows.tolist():
            strokes[i].chain_T = chains.ChainMemo()
            strokes[i].curv = None
        curves.build_geoms([strokes[i] for i in rows.tolist()], prof, jerk1=True)
        T, beta, I, _ = chains.candidates_chain(pin, rows, strokes, prof, rules)
        ok = np.isfinite(I)
        good = ok.any(axis=1)
        sts = [strokes[i] for i in rows[good]]
        first = np.argmax(ok[good], axis=1)
        r = np.arange(len(sts))
        Tc, bc = T[good][r, first], beta[good][r, first]
        last = ok.shape[1] - 1 - np.argmax(ok[good][:, ::-1], axis=1)
        T2, b2 = Tc.copy(), bc.copy()
        sel = np.arange(0, len(sts), 3)
        T2[sel], b2[sel] = T[good][sel, last[sel]], beta[good][sel, last[sel]]
        T2[1::50] *= 1.013            # no candidate's duration: solved cold
        got = []
        for t, b in ((Tc, bc), (Tc, bc), (T2, b2)):
            plans = fn(sts, t, b, rules, prof)
            got.append(([p for p in plans], _memo_state(sts)))
        res[name] = got
    for (p_ref, m_ref), (p_new, m_new) in zip(res["ref"], res["new"]):
        assert len(p_ref) == len(p_new) > 100
        assert all(_same_plan(p, w) for p, w in zip(p_new, p_ref))
        assert m_new == m_ref
    # the three kinds of plan were all made (the test can tell them apart)
    assert seen["replay"] and seen["again"] and seen["cold"]
