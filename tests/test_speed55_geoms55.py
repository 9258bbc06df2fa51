"""Round 55 (geoms): the windowed path's curve geometry and chain caps with less work a block.

* curves.build_geoms makes its blocks' vertex differences, lengths, directions,
  finiteness, end turns and classic jerk's caps for a chunk of blocks at once
  (_flat_blocks: the vertices of many blocks end to end), each block's own arrays then
  cut from them: every geometry field, every block's rows and every stroke left to
  CurveGeom's own path the same as the per-block path of 1ac1c41 (_part_blocks then
  _block_geoms block by block, kept here as the reference) and as each stroke's own
  CurveGeom; with windows' small calls, chunks cut mid-call, two limits objects, rows
  _parts_block declines, κ made, lazy and wanted, classic jerk and square corner velocity.
* chains._kept_caps makes the chains' caps of a geometry block's rows in one product
  (_block_rows_caps), not vertex_caps a chain: the same doubles, and each chain keeps
  them and lets go of its caps at the whole jerk as vertex_caps leaves it.
"""
import copy
import os

import numpy as np
import pytest

from gcode_opt import chains, curves
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_CURVE, Points

S = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "sample_gcode")
_CACHE = {}


def _curves(profile, name="prusa_gyroid.gcode"):
    key = (profile, name)
    if key not in _CACHE:
        prof = load_profile(profile)
        strokes, _ = analyse(os.path.join(S, name), prof, Options())
        _CACHE[key] = prof, [st for st in strokes if st.kind == K_CURVE]
    prof, sts = _CACHE[key]
    out = []
    for st in sts:
        st = copy.copy(st)
        st.curv = st.chain_T = None
        out.append(st)
    return prof, out


def _varied(sts):
    """Every third stroke on a second limits object, each its own acceleration, every
    fifth without a previous direction, every seventh with a vertex doubled (a row
    _parts_block declines)."""
    lim2 = copy.copy(sts[0].lim)
    for f in ("jerk_x", "jerk_y", "scv", "ax_max", "ay_max"):
        if isinstance(getattr(lim2, f, None), float):
            setattr(lim2, f, getattr(lim2, f) * 0.61)
    for k, st in enumerate(sts):
        st.accel = 400.0 + 37.0 * k
        if k % 3 == 0:
            st.lim = lim2
        if k % 5 == 0:
            st.prev_u = None
        if k % 7 == 0:
            xy = np.frombuffer(st.pts.xy, float).reshape(-1, 2)
            st.pts = Points(np.vstack([xy[:2], xy[1:]]).ravel().tobytes())
    return sts


def _per_block_geoms(strokes, profile, jerk1=False, kappa=True):
    """build_geoms as 1ac1c41 made it: _part_blocks' blocks, then _block_geoms a block
    with its own fields (no pre), then CurveGeom's own path for the rest."""
    todo = [st for st in strokes if st.curv is None]
    j1 = jerk1 and profile.junction == "jerk"
    pts = [st.pts for st in todo]
    want = None if isinstance(kappa, bool) else kappa
    fields = curves._stroke_fields_once(todo)
    rows, made = [None] * len(todo), []
    for idx, block in curves._part_blocks(todo, pts, kappa is True):
        ii = idx.tolist()
        got = curves._block_geoms([todo[i] for i in ii], block, profile, j1, want=want,
                                  fields=None if fields is None else curves._fields_at(fields, idx))
        if got is None:
            continue
        blk, keep, sts = got
        made.append((blk, sts))
        for k, i in enumerate(ii if keep is None else [i for i, g in zip(ii, keep.tolist()) if g]):
            rows[i] = (blk, k)
    for st, r in zip(todo, rows):
        if r is None:
            st.curv = curves.CurveGeom(st, profile, caps_jerk1=curves._own_jerk1(st, profile) if j1 else None)
        else:
            g = curves.CurveGeom.__new__(curves.CurveGeom)
            g._b, g._k = r
            g.chain_caps = None
            g._j1 = curves._FROM_BLOCK
            st.curv = g
    return made


def _bits(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return a.shape == b.shape and a.tobytes() == b.tobytes()


def _fields(st, kappa=True):
    g = st.curv
    c1 = g.caps_jerk1
    out = [g.d, g.u, g.caps, [g.cap], [np.nan if c is None else c for c in g.cos_end], [] if c1 is None else c1]
    if kappa:
        out += [g.kappa_v, [g.kappa_eff]]
    return out


def _assert_same(a_sts, b_sts, kappa=True):
    for a, b in zip(a_sts, b_sts):
        assert type(a.curv._b) is type(b.curv._b)
        assert (a.curv._j1 is curves._FROM_BLOCK) == (b.curv._j1 is curves._FROM_BLOCK)
        for x, y in zip(_fields(a, kappa), _fields(b, kappa)):
            assert _bits(x, y)


def _layout(made):
    """Each block's row count and vertex count, in the order made, and whether κ is kept."""
    return [(len(sts), blk.d.shape, blk._kv is None, None if blk._kv_miss is None else blk._kv_miss.tolist())
            for blk, sts in made]


def _two(sts):
    return sts, [copy.copy(st) for st in sts]


@pytest.mark.parametrize("profile", ["prusa-mk3s", "voron24"])
@pytest.mark.parametrize("kappa", [True, False, "want"])
@pytest.mark.parametrize("case", ["windows", "varied", "chunks"])
def test_flat_blocks_give_the_per_block_geometry(profile, kappa, case, monkeypatch):
    prof, sts = _curves(profile)
    if case == "varied":
        sts = _varied(sts[:500])
    if case == "chunks":            # chunks of a few blocks: cut mid-call
        monkeypatch.setattr(curves, "_FLAT_PTS", 200)
    want = (lambda bsts, cap: np.arange(len(bsts)) % 3 == 0) if kappa == "want" else kappa
    calls = [sts[a:a + 97] for a in range(0, len(sts), 97)] if case == "windows" else [sts]
    n_blocks = 0
    for call in calls:
        new, old = _two(call)
        for st in old:
            st.curv = None
        got = curves.build_geoms(new, prof, jerk1=True, kappa=want)
        ref = _per_block_geoms(old, prof, jerk1=True, kappa=want)
        assert _layout(got) == _layout(ref)
        assert [[new.index(st) for st in b] for _, b in got] == [[old.index(st) for st in b] for _, b in ref]
        _assert_same(new, old, kappa is True)
        n_blocks += len(got)
    assert n_blocks > (40 if case == "windows" else 5)
    if case == "varied":            # declined rows: CurveGeom's own, as the per-block path left them
        assert sum(len(b) for _, b in got) < len(sts)


@pytest.mark.parametrize("profile", ["prusa-mk3s", "voron24"])
def test_flat_blocks_give_each_strokes_own_curve_geometry(profile):
    """The geometry of a call of many blocks, field by field, as CurveGeom's own path
    makes each stroke's alone (its own arithmetic: curvature_from_polyline, vertex_caps)."""
    prof, sts = _curves(profile)
    sts = sts[:300]
    own = [copy.copy(st) for st in sts]
    assert len(curves.build_geoms(sts, prof, jerk1=True)) > 5
    jerk = prof.junction == "jerk"
    for st in own:
        st.curv = curves.CurveGeom(st, prof, caps_jerk1=curves._own_jerk1(st, prof) if jerk else None)
    _assert_same(sts, own)


def _blocks_made(todo, profile, flat):
    """(indices, _block_geoms' (block, kept rows mask, strokes) or None) of every block of
    build_geoms' strokes todo (classic jerk's caps at the whole jerk, κ lazy): by
    _flat_blocks (flat) or by _part_blocks a block with its own fields (1ac1c41)."""
    pts = [st.pts for st in todo]
    fields = curves._stroke_fields_once(todo)
    if flat:
        it = ((idx, block, bf, pre) for idx, block, bf, pre in
              curves._flat_blocks(todo, pts, False, False, profile, True, fields))
    else:
        it = ((idx, block, curves._fields_at(fields, idx), None) for idx, block in
              curves._part_blocks(todo, pts, False))
    return [(idx.tolist(), curves._block_geoms([todo[i] for i in idx.tolist()], block, profile, True,
                                                fields=bf, pre=pre)) for idx, block, bf, pre in it]


def test_flat_blocks_decline_as_the_per_block_path_with_non_finite_vertices():
    """Strokes with an infinite or NaN vertex, a vertex far beyond the others (its
    segments' lengths overflow: directions NaN), or arc lengths that do not rise (a
    segment below the rounding of the one before), among good ones: the same rows kept, the
    blocks declined (CurveGeom's own path) and the same fields."""
    prof, sts = _curves("prusa-mk3s")
    sts = sts[:200]
    for k, bad in ((3, np.inf), (10, np.nan), (17, 1e308), (24, -1e308), (31, 1e308)):
        xy = np.frombuffer(sts[k].pts.xy, float).copy()
        xy[2 + (k > 30)] = bad
        sts[k].pts = Points(xy.tobytes())
    for k in (5, 12):               # a first segment of 1e12 mm, then one of 2e-9 mm: no rise in s_v
        xy = np.frombuffer(sts[k].pts.xy, float).copy()
        xy[0], xy[1] = xy[2] - 1e12, xy[3]
        xy[4], xy[5] = xy[2] + 2e-9, xy[3]
        sts[k].pts = Points(xy.tobytes())
    got = _blocks_made(sts, prof, True)
    ref = _blocks_made(sts, prof, False)
    assert [i for i, _ in got] == [i for i, _ in ref]
    assert [g is None for _, g in got] == [r is None for _, r in ref]
    assert any(g is not None and g[1] is not None for _, g in got)     # rows declined
    for (_, g), (_, r) in zip(got, ref):
        if g is None:
            continue
        assert (g[1] is None) == (r[1] is None) and (g[1] is None or g[1].tolist() == r[1].tolist())
        assert g[2] == r[2]
        a, b = g[0], r[0]
        for f in ("d", "caps", "caps_jerk1", "cap", "cap_min"):
            assert _bits(getattr(a, f), getattr(b, f))
        assert _bits(a.u, b.u)
        assert [[np.nan if c is None else c for c in e] for e in a.cos_end] == \
            [[np.nan if c is None else c for c in e] for e in b.cos_end] or \
            _bits([[np.nan if c is None else c for c in e] for e in a.cos_end],
                  [[np.nan if c is None else c for c in e] for e in b.cos_end])


# ---------------------------------------------------------------- chains' caps
def _chain_geoms(profile, n=400):
    prof, sts = _curves(profile)
    sts = sts[:n]
    curves.build_geoms(sts, prof, jerk1=True, kappa=False)
    return prof, sts


@pytest.mark.parametrize("profile", ["prusa-mk3s", "voron24"])
def test_kept_caps_by_block_rows_are_each_chains_vertex_caps(profile):
    prof, sts = _chain_geoms(profile)
    ref = [copy.copy(st) for st in sts]
    for st, r in zip(sts, ref):         # the same blocks, each geometry its own object
        r.curv = copy.copy(st.curv)
    want = [chains.vertex_caps(st, prof) for st in ref]
    calls = []
    real = chains.vertex_caps
    chains.vertex_caps = lambda st, p: calls.append(st) or real(st, p)
    try:
        got = chains._kept_caps(sts, [st.curv for st in sts], prof)
    finally:
        chains.vertex_caps = real
    assert not calls                    # no call a chain
    for g, w, st, r in zip(got, want, sts, ref):
        assert _bits(chains._caps_array(g), w)
        assert _bits(chains._caps_array(st.curv.chain_caps), w)
        assert st.curv.caps_jerk1 is None and r.curv.caps_jerk1 is None
        assert _bits(chains.vertex_caps(st, prof), w)        # read again: the kept ones
    assert _bits(chains._join_caps(got), np.concatenate(want))


def mixed_chain_geoms(n, made=True):
    """(profile, n chains of the prusa-mk3s sample, the caps vertex_caps gives each, made on
    copies): a fourth of them (k % 4 == 1) with their caps made already (made), a fourth
    whose caps at the whole jerk went, a fourth with CurveGeom's own geometry, the rest
    their block's rows as classify left them."""
    prof, sts = _chain_geoms("prusa-mk3s", n)
    for k, st in enumerate(sts):
        if k % 4 == 1 and made:
            chains.vertex_caps(st, prof)                 # made: kept
        elif k % 4 == 2:
            st.curv.caps_jerk1 = None                    # gone: made again
        elif k % 4 == 3:
            st.curv = curves.CurveGeom(st, prof)         # its own (no caps at the whole jerk)
    ref = [copy.copy(st) for st in sts]
    for st, r in zip(sts, ref):
        r.curv = copy.copy(st.curv)
    return prof, sts, [np.array(chains.vertex_caps(st, prof)) for st in ref]


def test_kept_caps_mixed_with_made_and_own_geometries():
    """Chains whose caps are made already (kept as they are), whose caps at the whole
    jerk went (made again in one batch, not kept), whose geometry is CurveGeom's own:
    the caps vertex_caps gives each."""
    prof, sts, want = mixed_chain_geoms(120)
    got = chains._kept_caps(sts, [st.curv for st in sts], prof)
    for k, (g, w) in enumerate(zip(got, want)):
        assert _bits(chains._caps_array(g), w)
        if k % 4 == 2:
            assert sts[k].curv.chain_caps is None       # the batch of gone caps: not kept
