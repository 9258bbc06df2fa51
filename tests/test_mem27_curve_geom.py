"""Round 27 (memcurve): what the curve geometry blocks hold through planning.

* curves._Blk keeps no directions u (~5 MB on the gyroid plate at planning's peak): a
  block of build_geoms holds its rows' vertices (the strokes' own pts) and makes u from
  them and the kept lengths d when read (_Blk.u_rows / u_row, CurveGeom.u, cos_turn,
  stack_du; _curvecore.c u_rows, or numpy's subtract and divide without the core);
* under classic jerk, chains.classify's drop_jerk1 lets go of the blocks' vertex caps too
  (~2.4 MB; classify is their one reader there): _Blk.caps makes them again when read;
* candidates_curve, κ(s)'s one reader in a run, lets go of κ at the vertices of every
  block alive (drop_kappa, ~2.7 MB): _Blk.kappa_v makes it again by _parts_block.

The reference is each stroke's geometry on CurveGeom's own path (its own _segments, its
own vertex_caps, its u kept as made), independent of the blocks; every field must be the
same bits, with and without the compiled cores, on the bundled curve files under a jerk,
a square-corner-velocity and a junction-deviation profile."""
import os

import numpy as np
import pytest

from gcode_opt import chains, curves
from gcode_opt.curves import CurveGeom
from gcode_opt.laws import circle
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_CURVE

S = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "sample_gcode")
HAVE_CORE = circle.CORE_MOD is not None
CASES = [(os.path.join(S, "prusa_gyroid.gcode"), "prusa-mk3s"), (os.path.join(S, "prusa_gyroid.gcode"), "voron24"),
         (os.path.join(S, "prusa_concentric.gcode"), "ender3"),
         (os.path.join(S, "prusa_gyroid_fullspeed.gcode"), "prusa-mk4")]


def _bits(a):
    return None if a is None else (np.asarray(a).dtype.str, np.shape(a), np.asarray(a, float).tobytes())


def _fields(g, jerk1):
    out = [_bits(g.d), _bits(g.u), _bits(g.cos_turn), _bits(g.s_v), _bits(g.kappa_v), _bits(g.caps),
           repr(g.cap), repr(g.kappa_eff), repr(g.cos_end)]
    if jerk1:
        out.append(_bits(g.caps_jerk1))
    return out


def _curves(path, profile):
    prof = load_profile(profile)
    strokes, _ = analyse(path, prof, Options())
    sts = [st for st in strokes if st.kind == K_CURVE]
    assert len(sts) > 30
    return prof, sts


def _own(sts, prof, jerk1):
    """Each stroke's geometry on CurveGeom's own path (one stroke at a time)."""
    j1 = jerk1 and prof.junction == "jerk"
    out = []
    for st in sts:
        st.curv = None
        g = CurveGeom(st, prof, caps_jerk1=curves._own_jerk1(st, prof) if j1 else None)
        out.append(_fields(g, j1))
        st.curv = None
    return out


@pytest.mark.parametrize("path,profile", CASES)
@pytest.mark.parametrize("core", [True, False])
def test_blocks_without_u_same_bits(path, profile, core, monkeypatch):
    if core and not HAVE_CORE:
        pytest.skip("curve core not built")
    if not core:
        monkeypatch.setattr(curves, "_CURVE_CORE", None)
        monkeypatch.setattr(curves, "_JERK_CAPS", None)
        monkeypatch.setattr(curves, "_U_ROWS", None)
    prof, sts = _curves(path, profile)
    for jerk1 in (False, True):
        want = _own(sts, prof, jerk1)
        curves.build_geoms(sts, prof, jerk1=jerk1)
        blks = {id(st.curv._b): st.curv._b for st in sts}
        batched = [b for b in blks.values() if b in curves._BLOCKS]
        assert batched and all(b._u is None for b in batched)       # no directions kept
        j1 = jerk1 and prof.junction == "jerk"
        assert [_fields(st.curv, j1) for st in sts] == want
        # stack_du's rows (runs of one block, fancy-indexed) against the own path's u and d
        pick = [st.curv for st in sts if st.curv.d.size == sts[0].curv.d.size]
        D, U = curves.stack_du(pick)
        assert _bits(U) == _bits(np.array([g.u for g in pick], float))
        assert _bits(D) == _bits(np.array([g.d for g in pick], float))
        for b in batched:                   # the whole block's u: its rows', rows in any order
            assert _bits(b.u) == _bits(np.stack([b.u_row(k) for k in range(b.d.shape[0])]))
            ks = list(range(b.d.shape[0]))[::-2]
            assert _bits(b.u_rows(ks)) == _bits(b.u[ks])
        curves.drop_kappa()                 # κ at the vertices let go: made again when read
        assert all(b._kv is None for b in batched)
        assert [_fields(st.curv, j1) for st in sts] == want
        assert all(b._kv is not None for b in batched)
        for st in sts:
            st.curv = None


@pytest.mark.parametrize("path,profile", CASES)
def test_classify_lets_caps_go_under_jerk(path, profile):
    """chains.classify as plan_inputs runs it: under classic jerk the blocks hold no caps
    after it (and no caps at the whole jerk); reading them makes them again, the same bits
    as the own path's; the chains it marks are the own path's."""
    prof, sts = _curves(path, profile)
    want = _own(sts, prof, False)
    want_chain = []
    for st in sts:                          # the own path's classification
        g = CurveGeom(st, prof)
        want_chain.append(bool(g.caps.size and curves.CAP_MARGIN * float(np.min(g.caps)) < st.v_feed))
        st.curv = None
    chains.classify(sts, range(len(sts)), prof)
    assert [st.chain_T is not None for st in sts] == want_chain
    blks = {id(st.curv._b): st.curv._b for st in sts}
    batched = [b for b in blks.values() if b._lim is not None]
    assert batched
    jerk = prof.junction == "jerk"
    assert all((b._caps is None) == jerk and b.caps_jerk1 is None for b in batched)
    assert [_fields(st.curv, False) for st in sts] == want      # the caps made again
    assert all(b._caps is not None for b in batched)
    for st in sts:
        st.curv = None
        st.chain_T = None


def test_blocks_hold_less(monkeypatch):
    """What the blocks of a gyroid sample hold after classify under classic jerk: d,
    kappa_v and each row's few numbers, well under what they held with u and the caps
    (8 + 8 + 16 + 8 bytes a segment: d, kappa_v, u, caps)."""
    prof, sts = _curves(os.path.join(S, "prusa_gyroid.gcode"), "prusa-mk3s")
    chains.classify(sts, range(len(sts)), prof)
    blks = {id(st.curv._b): st.curv._b for st in sts if st.curv._b._u is None}.values()
    seg = sum(b.d.size for b in blks)
    held = sum(x.nbytes for b in blks for x in (b.d, b.kappa_v, b._u, b._caps, b.caps_jerk1)
               if isinstance(x, np.ndarray))
    assert seg > 1000 and held < 18 * seg
    for st in sts:
        st.curv = None
        st.chain_T = None


def test_candidates_let_kappa_go():
    """plan_inputs then the curves' candidates, as planning runs them: afterwards no block
    holds κ at the vertices, and the candidate table is the same whether the blocks held
    it or made it again (a second call reads the made-again κ)."""
    from gcode_opt.schedule import plan_inputs
    prof = load_profile("prusa-mk3s")
    strokes, _ = analyse(os.path.join(S, "prusa_gyroid.gcode"), prof, Options())
    pin = plan_inputs(strokes, prof, Options())
    rows = [i for i, st in enumerate(strokes) if chains.plan_kind(st) == K_CURVE and not pin.fault[i]]
    assert len(rows) > 10
    first = curves.candidates_curve(pin, rows, strokes, prof)
    blks = {id(st.curv._b): st.curv._b for st in strokes if st.curv is not None and st.curv._b._u is None}
    assert blks and all(b._kv is None for b in blks.values())
    again = curves.candidates_curve(pin, rows, strokes, prof)
    assert [_bits(x) for x in first] == [_bits(x) for x in again]


@pytest.mark.skipif(not HAVE_CORE or curves._U_ROWS is None, reason="curve core not built")
def test_core_u_rows_same_bits_as_numpy(monkeypatch):
    """_curvecore.c u_rows against numpy's path, on sample rows and on random vertices
    (rows in any order, one row, rows whose vertices are lists: numpy's path)."""
    prof, sts = _curves(os.path.join(S, "prusa_gyroid.gcode"), "prusa-mk3s")
    curves.build_geoms(sts, prof)
    blks = [b for b in {id(st.curv._b): st.curv._b for st in sts}.values() if b._u is None]
    rng = np.random.default_rng(27)
    from gcode_opt.strokes import Points
    m, n = 40, 7
    xy = rng.normal(scale=30.0, size=(m, n + 1, 2))
    d = np.hypot(*np.moveaxis(np.diff(xy, axis=1), -1, 0))
    pts = [Points(r.ravel().tolist()) if k % 3 else [tuple(v) for v in r.tolist()] for k, r in enumerate(xy)]
    blks.append(curves._Blk(d, None, None, None, None, None, None, None, False, pts=pts))
    for b in blks:
        ks = rng.permutation(b.d.shape[0]).tolist()
        got = [b.u_rows(ks), b.u_rows(ks[:1]), b.u_row(ks[0])]
        with monkeypatch.context() as mp:
            mp.setattr(curves, "_U_ROWS", None)
            want = [b.u_rows(ks), b.u_rows(ks[:1]), b.u_row(ks[0])]
        assert [_bits(x) for x in got] == [_bits(x) for x in want]
    for st in sts:
        st.curv = None
