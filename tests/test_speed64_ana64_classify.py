"""Analyse's spill planning made cheaper (session 64, benchmarks/ana64.md): chains.classify
marks a fresh block's chains in a few passes (their caps' bytes by the core's byte_runs, the
rows' geometries put once with them: build_geoms put=False), the spilled strokes' chains
marked with one ChainMemo (plan_inputs spilled=True), and a lazy block's segments and arc
lengths made only for the rows κ is wanted for (curves._Rows).  Checked against the paths
they replace, on real files: the same chains, chain caps, κ bits, PlanInput and stored
records."""
import os

import numpy as np
import pytest

from gcode_opt import chains, curves, pipeline, schedule
from gcode_opt.profile import load_profile
from gcode_opt.stroke_store import StrokeStore

from test_speed56_inputs56_pin import _same_pin      # (every field, the arrays bit for bit)

SAMPLES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "sample_gcode")
FILES = [(os.path.join(SAMPLES, "prusa_gyroid.gcode"), "prusa-mk3s"),
         (os.path.join(SAMPLES, "prusa_gyroid_arcs.gcode"), "prusa-mk3s"),
         (os.path.join(SAMPLES, "prusa_klipper.gcode"), "voron24")]


def _strokes(path, prof):
    prof = load_profile(prof)
    opts = pipeline.Options(alpha=0.5)
    return pipeline.analyse(path, prof, opts)[0], prof, opts


def _records(strokes):
    """The store's record bytes of strokes (their fields as stored, chain_T a mark)."""
    store = StrokeStore(in_memory=True)
    store.append(strokes)
    return bytes(store._io.data), store


def _geoms(strokes):
    """Each curve's chain mark, chain caps and caps at the whole jerk, as planning reads them."""
    out = []
    for st in strokes:
        g = st.curv
        if g is None:
            out.append(None)
            continue
        c1 = g.caps_jerk1
        out.append((st.chain_T is not None, g.chain_caps, None if c1 is None else np.asarray(c1).tobytes(),
                    np.asarray(g.caps).tobytes(), g.cap, g.kappa_eff if st.chain_T is None else None))
    return out


@pytest.mark.parametrize("path,prof", FILES)
def test_fresh_chains_are_the_loops(monkeypatch, path, prof):
    """plan_inputs with the fresh blocks' chains marked by byte_runs and put_rows: the
    PlanInput, the stored records, each curve's chain caps, caps at the whole jerk, caps,
    cap and κ_eff of the per-chain loop (the core's byte_runs taken away)."""
    if chains._BYTE_RUNS is None:
        pytest.skip("no compiled byte_runs: the loop is the one path")
    a, profile, opts = _strokes(path, prof)
    b = _strokes(path, prof)[0]
    got = schedule.plan_inputs(a, profile, opts)
    monkeypatch.setattr(chains, "_BYTE_RUNS", None)
    want = schedule.plan_inputs(b, profile, opts)
    _same_pin(got, want)
    assert _geoms(a) == _geoms(b)
    assert _records(a)[0] == _records(b)[0]
    assert sum(st.chain_T is not None for st in a) > 0 or profile.junction != "jerk"    # (Klipper's: no chain)


@pytest.mark.parametrize("path,prof", FILES)
def test_spilled_chains_share_one_memo(path, prof):
    """plan_inputs(spilled=True): the same PlanInput and stored records (a memo is stored
    as a mark), every chain marked with one ChainMemo; without it each chain has its own;
    the strokes loaded back each get a new one."""
    a, profile, opts = _strokes(path, prof)
    b = _strokes(path, prof)[0]
    _same_pin(schedule.plan_inputs(a, profile, opts, spilled=True), schedule.plan_inputs(b, profile, opts))
    got, store = _records(a)
    assert got == _records(b)[0]
    marks = [st.chain_T for st in a if st.chain_T is not None]
    if profile.junction != "jerk":
        return                          # (Klipper's sample: no chain)
    assert len(marks) > 1 and len({id(m) for m in marks}) == 1
    assert len({id(st.chain_T) for st in b if st.chain_T is not None}) == len(marks)
    back = [st.chain_T for st in store.load(0, len(store)) if st.chain_T is not None]
    assert len(back) == len(marks) and len({id(m) for m in back}) == len(marks)


@pytest.mark.parametrize("path,prof", FILES[:2])
def test_wanted_kappa_is_the_whole_blocks(path, prof):
    """build_geoms with κ wanted for some rows (seeded; a lazy block's _Rows: its segments
    and arc lengths taken for those rows alone): those rows' κ at the vertices and κ_eff
    are the bits of build_geoms making κ for every row; the others are left to make."""
    a, profile, _ = _strokes(path, prof)
    b = _strokes(path, prof)[0]
    sa = [st for st in a if st.kind == "curve"]
    sb = [st for st in b if st.kind == "curve"]
    rng = np.random.default_rng(64)
    asked = {}

    def want(sts, cap):
        w = rng.random(len(sts)) < 0.4
        if len(sts) > 2:
            w[0], w[1] = True, False
        asked[id(sts[0])] = w
        return w
    made = curves.build_geoms(sa, profile, kappa=want)
    curves.build_geoms(sb, profile, kappa=True)
    seen = 0
    for blk, bsts in made:
        w = asked[id(bsts[0])]
        for k, st in enumerate(bsts):
            q = sa.index(st)
            if w[k]:
                h = sb[q].curv
                assert blk._kv[k].tobytes() == np.asarray(h.kappa_v).tobytes()
                assert float(blk._ke[k]) == h.kappa_eff or (np.isnan(blk._ke[k]) and np.isnan(h.kappa_eff))
                seen += 1
            elif blk._kv is not None:
                assert blk._kv_miss is not None and blk._kv_miss[k]
    assert seen > 10
