"""Round 47 (geo47): a curve's κ made only for the rows that read it.

* build_geoms(kappa=False) (chains.classify; _rebuild_geometry's chains) leaves κ at the
  vertices and κ_eff to be made when read (_Blk.make_kappa: the same rows' _kappa_block),
  where _parts_lazy proves it finite (the row's `good` then needs no κ); classify makes
  it for the curves (the chains, 99.5 % of the gyroid plate's kernel entries, never read it).
* Every field read, in any order (a row, some rows, the whole block, after drop_kappa),
  is compared bit for bit with the geometry build_geoms(kappa=True) makes (the code this
  replaced: _parts_block made κ for every row), with and without the compiled core.
* _parts_lazy's finiteness claim is checked against _parts_block's own κ on rows at its
  edges (tiny segments, paths near KAPPA_TAME_D) and past them (eager there).
"""
import os

import numpy as np
import pytest

from gcode_opt import chains, curves
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_CURVE

S = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "sample_gcode")
PLATE = os.path.expanduser("~/.cache/gcode-opt-corpus/plate_gyroid.gcode")


def _curves_of(path, profile="prusa-mk3s"):
    prof = load_profile(profile)
    strokes, _ = analyse(path, prof, Options())
    return prof, [st for st in strokes if st.kind == K_CURVE]


def _bits(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64))


def _build(todo, prof, kappa, jerk1=True):
    for st in todo:
        st.curv = None
    curves.build_geoms(todo, prof, jerk1=jerk1, kappa=kappa)
    return [st.curv for st in todo]


def _eager(todo, prof):
    """Every stroke's (kappa_v, kappa_eff) as build_geoms(kappa=True) makes them."""
    gs = _build(todo, prof, True)
    out = [(g.kappa_v.copy(), g.kappa_eff) for g in gs]
    for st in todo:
        st.curv = None
    return out


@pytest.fixture(params=[True, False], ids=["core", "pure"])
def core(request, monkeypatch):
    if not request.param:
        monkeypatch.setattr(curves, "_CURVE_CORE", None)
    elif curves._CURVE_CORE is None:
        pytest.skip("curve core not built")
    return request.param


def _check_reads(todo, prof, want, order):
    gs = _build(todo, prof, False)
    assert all(b._kv is None and b._ke is None for b in {g._b for g in gs}), "κ made though deferred"
    if order == "rows":                 # every other row by row, then the blocks whole
        for g, (kv, ke) in list(zip(gs, want))[::2]:
            assert _bits(g.kappa_v, kv) and g.kappa_eff == ke and type(g.kappa_eff) is float
    elif order == "knots":              # candidates_curve's knots of every third geometry
        sub = gs[::3]
        kn = curves._Knots.of(sub)
        for q, (g, (kv, _)) in enumerate(zip(sub, want[::3])):
            assert _bits(kn.ys[kn.off[q]:kn.off[q] + kn.cnt[q]], kv)
    elif order == "drop":
        for g in gs[::5]:
            g.kappa_eff                 # some κ_eff made, then κ at the vertices let go
        curves.drop_kappa()
    for g, (kv, ke) in zip(gs, want):
        assert _bits(g.kappa_v, kv) and g.kappa_eff == ke
    for b in {g._b for g in gs}:
        assert b._kv_miss is None and b._ke_miss is None
        assert _bits(b.kappa_v, [want[i][0] for i, g in enumerate(gs) if g._b is b])


@pytest.mark.parametrize("order", ["rows", "knots", "drop", "blocks"])
def test_deferred_kappa_same_bits_as_made_at_once(core, order):
    prof, todo = _curves_of(os.path.join(S, "prusa_gyroid.gcode"))
    assert len(todo) > 20
    _check_reads(todo, prof, _eager(todo, prof), order)


@pytest.mark.skipif(not os.path.exists(PLATE), reason="corpus plate not downloaded")
def test_deferred_kappa_same_bits_on_the_gyroid_plate():
    prof, todo = _curves_of(PLATE)
    todo = todo[::7]
    _check_reads(todo, prof, _eager(todo, prof), "knots")


def test_classify_makes_kappa_for_the_curves_alone_the_same_bits(core):
    prof, todo = _curves_of(os.path.join(S, "prusa_gyroid.gcode"))
    want = _eager(todo, prof)
    for st in todo:
        st.curv, st.chain_T = None, None
    chains.classify(todo, list(range(len(todo))), prof)
    is_chain = [st.chain_T is not None for st in todo]
    assert any(is_chain) and not all(is_chain)
    for st, c, (kv, ke) in zip(todo, is_chain, want):
        b, k = st.curv._b, st.curv._k
        made = b._kv is not None and (b._kv_miss is None or not b._kv_miss[k])
        assert made != c                # a curve's made, a chain's not
        if not c:
            assert _bits(st.curv.kappa_v, kv) and st.curv.kappa_eff == ke
    for st, (kv, ke) in zip(todo, want):       # a chain's, read anyway: made now, the same
        assert _bits(st.curv.kappa_v, kv) and st.curv.kappa_eff == ke


@pytest.mark.parametrize("share", [0.0, 0.3, 1.0])
def test_kappa_made_at_once_for_the_wanted_rows(core, share):
    """build_geoms(kappa=want): κ made with the block for the rows want says (a random
    share of them), the others when read: every one the same bits as made at once."""
    prof, todo = _curves_of(os.path.join(S, "prusa_gyroid.gcode"))
    want_all = _eager(todo, prof)
    rng = np.random.default_rng(471)
    asked = []

    def want(sts, cap):
        assert len(sts) == cap.size
        w = rng.uniform(size=cap.size) < share
        asked.append((list(sts), w))
        return w
    for st in todo:
        st.curv = None
    curves.build_geoms(todo, prof, jerk1=True, kappa=want)
    assert asked
    pos = {id(st): q for q, st in enumerate(todo)}
    for sts, w in asked:                 # made: the wanted rows, and only they
        for st, x in zip(sts, w.tolist()):
            b, k = st.curv._b, st.curv._k
            made = b._kv is not None and (b._kv_miss is None or not b._kv_miss[k])
            assert made == x
            if x:
                kv, ke = want_all[pos[id(st)]]
                assert _bits(b._kv[k], kv) and b._ke[k] == ke
    _check_reads_made(todo, want_all)


def _check_reads_made(todo, want):
    for st, (kv, ke) in zip(todo, want):
        assert _bits(st.curv.kappa_v, kv) and st.curv.kappa_eff == ke


def _rows(n_rows, npt, rng, scale=1.0, tiny=False):
    """Random polylines (n_rows, npt, 2): turning paths, segments >= ~1e-9 where tiny."""
    step = rng.uniform(1e-9 if tiny else 0.05, 2.0, (n_rows, npt - 1)) * scale
    ang = np.cumsum(rng.uniform(-1.5, 1.5, (n_rows, npt - 1)), axis=1)
    seg = np.stack([step * np.cos(ang), step * np.sin(ang)], axis=2)
    pts = np.zeros((n_rows, npt, 2))
    np.cumsum(seg, axis=1, out=pts[:, 1:])
    return pts


def test_lazy_parts_same_fields_and_good_as_parts_block(core):
    """_parts_lazy's fields and good are _parts_block's; κ left out only where finite:
    tiny segments, paths up to KAPPA_TAME_D long (its proof's edges); past it (1e150,
    1e300: overflowing squares, inf - inf) and on NaN or duplicate rows, made at once."""
    rng = np.random.default_rng(47)
    for npt in (3, 4, 7, 20, 61):
        for scale, tiny, want_lazy in ((1.0, False, True), (1.0, True, True), (1e99 / (2.0 * npt), False, True),
                                       (1e150, False, False), (1e300, False, False)):
            pts = _rows(12, npt, rng, scale, tiny)
            pts[3, 1] = pts[3, 0]                   # a duplicate point
            pts[4, -1, 0] = np.nan
            with np.errstate(all="ignore"):
                ref = curves._parts_block(pts)
                got = curves._parts_lazy(pts)
            assert _bits(got[6], ref[6]), (npt, scale)
            assert all(_bits(x, y) for x, y in zip(got[:4], ref[:4]))
            assert (got[4] is None) == want_lazy, (npt, scale)
            if want_lazy:           # the claim: every good row's κ finite
                assert np.isfinite(ref[4][ref[6]]).all() and ref[6][:3].all()
                assert _bits(got[7], pts[:, 1:] - pts[:, :-1])      # the segments, for want
            else:
                assert _bits(got[4], ref[4]) and _bits(got[5], ref[5])
