"""A later budget run segments only the lines and chains whose law (T, beta) moved
(schedule._RunMemo): the others take the last run's outcome.  Compared, run by run and
bit for bit, with every run segmenting all its strokes (REUSE_RUNS off: the reference),
on budgets that move strokes away and back; and the written files of whole commands."""
import os

import numpy as np
import pytest

from gcode_opt import chains, pipeline, schedule
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_CHAIN, K_LINE

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")
PROFILES = os.path.join(HERE, "..", "profiles")


def _runs(name, prof, reuse, monkeypatch, budgets):
    """The plans of the budget runs at budgets (shares of the budget), and the rows each
    run's segment stage took (_keep_plans' rows)."""
    monkeypatch.setattr(schedule, "REUSE_RUNS", reuse)
    profile = load_profile(prof)
    opts = pipeline.Options()
    opts.ringing = False
    strokes, sim0 = pipeline.analyse(os.path.join(SAMPLES, name), profile, opts)
    pin = schedule.plan_inputs(strokes, profile, opts)
    runs, staged = [], []
    keep = schedule._keep_made_plans

    def keep_rows(plan, sts, idx, seg_failed, a2_orig):
        staged.append(idx.size)
        return keep(plan, sts, idx, seg_failed, a2_orig)

    def fit(run, pin_, budget_t):
        for r in budgets:
            p = run(r * budget_t)
            # (each run's arrays as they were: the next run must not change them)
            runs.append((p, p.retime.copy(), p.reason.copy(), p.t_pred.copy(), p.a2_pred.copy(), list(p.segs)))
        return runs[-1][0]
    monkeypatch.setattr(schedule, "_keep_made_plans", keep_rows)
    monkeypatch.setattr(schedule, "_fit_budget", fit)
    schedule.plan_strokes(strokes, pin, profile, opts, opts.max_slowdown_r * sim0.time_t)
    monkeypatch.undo()
    kinds = np.array([chains.plan_kind(s) for s in strokes], dtype=object)
    return runs, staged, kinds


def _bits(x):
    return np.asarray(x, float).view(np.int64)


def _same(a, b):
    pa, ra, wa, ta, aa, sa_l = a
    pb, rb, wb, tb, ab, sb_l = b
    assert (ra == rb).all() and (wa == wb).all()
    assert (_bits(pa.T) == _bits(pb.T)).all() and (_bits(pa.beta) == _bits(pb.beta)).all()
    assert (_bits(ta) == _bits(tb)).all() and (_bits(aa) == _bits(ab)).all()
    for sa, sb in zip(sa_l, sb_l):
        assert (sa is None) == (sb is None)
        if sa is not None:
            for f in ("s", "v", "accel", "feed"):
                x, y = np.asarray(getattr(sa, f)), np.asarray(getattr(sb, f))
                assert x.shape == y.shape and (_bits(x) == _bits(y)).all(), f
            assert _bits(sa.time_t) == _bits(sb.time_t) and _bits(sa.int_a2) == _bits(sb.int_a2)
            assert sa.fault == sb.fault


# budgets that keep most strokes (0.7 then 0.69), move many (0.4, 1.3) and come back (1.0)
BUDGETS = (1.0, 0.7, 0.69, 0.4, 1.3, 1.0, 1.0)


@pytest.mark.parametrize("name,prof", [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"),
                                       ("prusa_gyroid_fullspeed.gcode", "prusa-mk3s"),
                                       ("prusa_gyroid_fullspeed_klipper.gcode", "voron24"),
                                       ("prusa_concentric_arcs.gcode", "prusa-mk3s")])
def test_runs_reuse_same_as_every_row(name, prof, monkeypatch):
    prof = os.path.join(PROFILES, prof + ".toml")
    got, staged, kinds = _runs(name, prof, True, monkeypatch, BUDGETS)
    ref, staged_ref, _ = _runs(name, prof, False, monkeypatch, BUDGETS)
    assert len(got) == len(ref) == len(BUDGETS)
    for a, b in zip(got, ref):
        _same(a, b)
    # the reference stages every re-timed stroke; the later runs here fewer (the run at
    # 1.0 again after 1.0: only the kinds segmented as a batch, arcs and curves)
    assert staged[0] == staged_ref[0]
    assert all(a <= b for a, b in zip(staged, staged_ref))
    own = (kinds == K_LINE) | (kinds == K_CHAIN)
    p_in = ref[-1]
    assert staged[-1] <= staged_ref[-1] - int((own & p_in[1]).sum())
    assert staged[-1] < staged_ref[-1]


def test_chains_were_reused(monkeypatch):
    """The gyroid sample's chains are among the strokes kept (else the chains' own path
    was not exercised above)."""
    prof = os.path.join(PROFILES, "prusa-mk3s.toml")
    got, _, kinds = _runs("prusa_gyroid_fullspeed.gcode", prof, True, monkeypatch, (1.0, 1.0))
    assert ((kinds == K_CHAIN) & got[1][1]).sum() > 20


@pytest.mark.parametrize("name,prof", [("prusa_benchy_like.gcode", "prusa-mk3s"),
                                       ("prusa_gyroid_arcs.gcode", "voron24")])
def test_whole_command_same_bytes(name, prof, monkeypatch, tmp_path):
    """Whole commands (several budget runs, and second passes) write the same file."""
    profile = load_profile(os.path.join(PROFILES, prof + ".toml"))
    out = {}
    for reuse in (True, False):
        monkeypatch.setattr(schedule, "REUSE_RUNS", reuse)
        opts = pipeline.Options()
        opts.ringing = False
        path = tmp_path / f"{reuse}.gcode"
        pipeline.process(os.path.join(SAMPLES, name), str(path), profile, opts)
        out[reuse] = path.read_bytes()
    assert out[True] == out[False]


def test_plan_once_copies_for_junction_commands():
    """segments.plan_once gives a stroke that may get a junction command (corner_cmd0) a
    plan object of its own, the others of its class their first's; the same bits as
    plan_segments of every stroke either way."""
    import copy

    from gcode_opt import segments as sg
    prof = load_profile(os.path.join(PROFILES, "prusa-mk3s.toml"))
    opts = pipeline.Options()
    opts.ringing = False
    strokes, _ = pipeline.analyse(os.path.join(SAMPLES, "prusa_mk3s_rectilinear.gcode"), prof, opts)
    pin = schedule.plan_inputs(strokes, prof, opts)
    rows = np.array([i for i, s in enumerate(strokes) if chains.plan_kind(s) == K_LINE and s.n_moves == 1][:300])
    rules = sg.SegmentRules.for_profile(prof, opts.max_segments)
    for cmd in (False, True):
        sts = []
        for i in rows.tolist():
            st = copy.copy(strokes[i])
            st.corner_cmd0 = cmd
            sts.append(st)
        sts3 = sts * 3
        cls3 = np.tile(sg.line_classes(sts), 3)
        T = np.tile(pin.T_orig[rows] * 0.9, 3)
        beta = np.full(T.size, np.inf)
        got = sg.plan_once(lambda s, t, b: sg.plan_segments(s, t, b, rules), sts3, T, beta, cls3)
        want = sg.plan_segments(sts3, T, beta, rules)
        assert got is not None
        held = [p for p in got if p is not None]
        assert len(held) > 100
        for a, b in zip(got, want):
            assert (a is None) == (b is None)
            if a is not None:
                for f in ("s", "v", "accel", "feed"):
                    assert (_bits(getattr(a, f)) == _bits(getattr(b, f))).all()
                assert _bits(a.time_t) == _bits(b.time_t) and _bits(a.int_a2) == _bits(b.int_a2)
        if cmd:
            assert len({id(p) for p in held}) == len(held)
        else:
            assert len({id(p) for p in held}) <= len(held) // 3 + 1


@pytest.mark.parametrize("name,prof", [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"),
                                       ("prusa_gyroid_fullspeed_klipper.gcode", "voron24")])
def test_plan_auto_memo_same_as_fresh(name, prof):
    """plan_auto with its memo kept across budgets (plan._AllocMemo: the rows' view) gives
    each budget the plan a fresh call gives, and the plan of the dense allocation (no
    compiled core: every choice by its column)."""
    from gcode_opt import plan as plan_mod
    profile = load_profile(os.path.join(PROFILES, prof + ".toml"))
    opts = pipeline.Options()
    opts.ringing = False
    strokes, sim0 = pipeline.analyse(os.path.join(SAMPLES, name), profile, opts)
    pin = schedule.plan_inputs(strokes, profile, opts)
    budget = opts.max_slowdown_r * sim0.time_t
    schedule.plan_strokes(strokes, pin, profile, opts, budget)
    cands, _, failed = pin.cached
    ok = np.array([i for i in range(len(strokes)) if i not in failed], int)
    memo = {}
    # (a row of every fourth stroke taken out: they keep their original at every budget)
    few = ok[ok % 4 != 0]
    for r in (1.0, 0.7, 0.69, 0.2, 1.5, 1.0, 0.0, 1.0, 1e-6):
        for g in (ok, few):
            got = plan_mod.plan_auto(pin, r * budget, cands, [g], memo)
            want = plan_mod.plan_auto(pin, r * budget, cands, [g])
            plan_mod.USE_CORE = False
            try:
                dense = plan_mod.plan_auto(pin, r * budget, cands, [g])
            finally:
                plan_mod.USE_CORE = True
            for w in (want, dense):
                for f in ("retime", "T", "beta", "I_law", "KE_law"):
                    a, b = getattr(got, f), getattr(w, f)
                    assert a.dtype == b.dtype and (a.view(np.int64 if a.dtype == float else a.dtype) ==
                                                   b.view(np.int64 if b.dtype == float else b.dtype)).all(), f
                assert (got.reason == w.reason).all() and got.lam == w.lam
    am = [v for k, v in memo.items() if isinstance(k, tuple)]
    assert len(am) == 2 and all(m.rv is not None for m in am)
