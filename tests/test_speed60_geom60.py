"""Round 60 (geom): the geometry rows' stacks and the geometries put on strokes in one pass.

* curves.stack_du / stack_d stack the geometries' rows by the compiled core in one pass
  (_stacked_core: _curvecore.c stack_rows), not a run of rows a block through
  _stacked_runs and _stack_u: the same lengths and directions bit for bit as that path
  (kept as the fallback and the reference here), on blocks of build_geoms (directions made
  from the vertices), CurveGeom's own blocks (directions kept) and blocks the core does
  not take (then the fallback's, the same arrays).
* curves.put_rows puts a block's row geometries on its strokes in one compiled pass
  (_curvecore.c put_geoms; geom_keep._give_rows and build_geoms' _put_rows): the same
  geometries (block, row, chain caps, caps at the whole jerk from the block) as
  row_geom's loop, where none is held (or on every stroke), with the same count.
* The command's bytes and summary, list path and windowed, are those of the Python paths.
"""
import copy
import os
import random
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt import features as feat
from gcode_opt import geom_keep as gk
from gcode_opt.geom_keep import GeomKeep
from gcode_opt.pipeline import Options, analyse
from gcode_opt.plan_windows import plan_inputs_windowed
from gcode_opt.profile import load_profile
from gcode_opt.schedule import C_CHAIN, C_CURVE
from gcode_opt.stroke_store import StrokeStore
from gcode_opt.strokes import K_CURVE, Points

from windowed_run import run_command

S = Path(__file__).resolve().parent.parent / "sample_gcode"
_CACHE = {}


def _curves(name="prusa_gyroid.gcode", profile="prusa-mk3s"):
    """Fresh copies (no geometry) of the sample's curve strokes; every seventh with a
    vertex doubled (a row _parts_block declines: CurveGeom's own path, its u kept)."""
    key = (profile, name)
    if key not in _CACHE:
        prof = load_profile(profile)
        strokes, _ = analyse(str(S / name), prof, Options())
        _CACHE[key] = prof, [st for st in strokes if st.kind == K_CURVE]
    prof, sts = _CACHE[key]
    out = []
    for k, st in enumerate(sts):
        st = copy.copy(st)
        st.curv = st.chain_T = None
        if k % 7 == 0:
            xy = np.frombuffer(st.pts.xy, float).reshape(-1, 2)
            st.pts = Points(np.vstack([xy[:2], xy[1:]]).ravel().tobytes())
        out.append(st)
    return prof, out


def _runs_path(gs):
    """stack_du as the runs' path makes it (_stacked_runs, _stack_u): the reference."""
    D, runs, ks = curves._stacked_runs(gs)
    return D, curves._stack_u(gs, runs, ks, D)


def _same(a, b):
    return a.shape == b.shape and a.dtype == b.dtype and np.array_equal(a.view(np.int64), b.view(np.int64))


def _geoms_by_n(windows=37):
    """The sample's curve geometries made as a windowed run makes them (build_geoms a window
    of strokes: several blocks of one segment count), by segment count."""
    prof, sts = _curves()
    for a in range(0, len(sts), windows):
        curves.build_geoms(sts[a:a + windows], prof, jerk1=True, kappa=False)
    by_n = {}
    for st in sts:
        by_n.setdefault(st.curv.d.size, []).append(st.curv)
    return by_n


def _orders(gs, rng):
    """gs in file order, shuffled, reversed, every third, and one geometry alone."""
    sh = gs[:]
    rng.shuffle(sh)
    return [gs, sh, gs[::-1], gs[::3], gs[:1]]


def test_core_stacks_are_the_runs_stacks():
    if curves._STACK_ROWS is None:
        pytest.skip("curve core not built")
    rng = random.Random(60)
    by_n = _geoms_by_n()
    own = 0
    for n, gs in by_n.items():
        own += sum(g._b._u is not None for g in gs)
        for order in _orders(gs, rng):
            got = curves._stacked_core(order, True)
            assert got is not None
            ref = _runs_path(order)
            assert _same(got[0], ref[0]) and _same(got[1], ref[1])
            d_only = curves._stacked_core(order, False)
            assert d_only[1] is None and _same(d_only[0], ref[0])
            assert _same(curves.stack_d(order), ref[0])
            du = curves.stack_du(order)
            assert _same(du[0], ref[0]) and _same(du[1], ref[1])
    assert len(by_n) > 3 and own > 0        # (several segment counts; CurveGeom's own blocks met)


def test_stacks_the_core_declines_are_the_fallbacks(monkeypatch):
    by_n = _geoms_by_n()
    n, gs = max(by_n.items(), key=lambda x: len(x[1]))
    gs = gs[:40]
    ref = _runs_path(gs)
    # a block whose lengths are not C-contiguous: the core declines, the runs' path is taken
    b = gs[0]._b
    wide = np.zeros((b.d.shape[0], 2 * b.d.shape[1]))
    wide[:, ::2] = b.d
    monkeypatch.setattr(b, "d", wide[:, ::2])
    assert curves._stacked_core(gs, True) is None
    got = curves.stack_du(gs)
    assert _same(got[0], ref[0]) and _same(got[1], ref[1])
    monkeypatch.undo()
    # geometries of two segment counts, a tuple, none: declined
    other = next(g for m, x in by_n.items() if m != n for g in x)
    assert curves._stacked_core(gs + [other], True) is None
    assert curves._stacked_core(tuple(gs), True) is None
    assert curves._stacked_core([], True) is None
    # without the core: the same stacks
    monkeypatch.setattr(curves, "_STACK_ROWS", None)
    got = curves.stack_du(gs)
    assert _same(got[0], ref[0]) and _same(got[1], ref[1])
    assert _same(curves.stack_d(gs), ref[0])


def _row_geoms_loop(blk, sts, chain, only_none):
    """put_rows as row_geom's loop (the reference)."""
    given = 0
    for k, st in enumerate(sts):
        if not only_none or st.curv is None:
            st.curv = curves.row_geom(blk, k, None if chain is None else chain[k])
            given += 1
    return given


def _fields(sts):
    return [None if st.curv is None else
            (type(st.curv), id(st.curv._b), st.curv._k, st.curv.chain_caps, st.curv._j1 is curves._FROM_BLOCK)
            for st in sts]


@pytest.mark.parametrize("core", [True, False])
def test_put_rows_puts_row_geoms(monkeypatch, core):
    if not core:
        monkeypatch.setattr(curves, "_PUT_GEOMS", None)
    elif curves._PUT_GEOMS is None:
        pytest.skip("curve core not built")
    prof, sts = _curves()
    sts = sts[:300]
    blk = object()
    chain = [None if k % 3 else bytes([k % 251]) * 16 for k in range(len(sts))]
    held = [copy.copy(st) for st in sts]
    for k in range(0, len(sts), 4):         # (every fourth holds a geometry already)
        held[k].curv = sts[k].curv = curves.row_geom(blk, 10_000 + k)
    for only_none in (True, False):
        for ch in (chain, None):
            a, b = [copy.copy(st) for st in held], [copy.copy(st) for st in held]
            want = _row_geoms_loop(blk, a, ch, only_none)
            assert curves.put_rows(blk, b, ch, only_none) == want
            assert _fields(b) == _fields(a)
            assert want == (len(sts) - len(range(0, len(sts), 4)) if only_none else len(sts))


@pytest.mark.parametrize("name", ["prusa_gyroid_fullspeed.gcode", "prusa_gyroid.gcode"])
def test_command_bytes_are_the_python_paths(tmp_path, monkeypatch, name):
    """The list path with this round's two compiled passes off (the runs' stacks and
    row_geom's loop) against the list path and the windowed one with them."""
    with monkeypatch.context() as m:
        m.setattr(curves, "_STACK_ROWS", None)
        m.setattr(curves, "_PUT_GEOMS", None)
        ref = run_command(m, S / name, tmp_path / "ref.gcode", False, None)
    for windowed in (False, True):
        got = run_command(monkeypatch, S / name, tmp_path / "got.gcode", windowed, 37)
        assert got[0] == ref[0]
        assert got[1] == ref[1]


def test_put_geoms_sets_attributes_of_a_type_without_slots():
    """A geometry type whose fields are not object slots: set as attributes, the same."""
    if curves._PUT_GEOMS is None:
        pytest.skip("curve core not built")

    class Plain:
        pass

    class St:
        def __init__(self, curv=None):
            self.curv = curv

    sts = [St(), St(7), St()]
    blk, j1 = object(), object()
    assert curves._PUT_GEOMS(blk, sts, [b"a", b"b", None], Plain, j1, True) == 2
    assert sts[1].curv == 7
    for k in (0, 2):
        g = sts[k].curv
        assert type(g) is Plain and g._b is blk and g._k == k and g._j1 is j1
        assert g.chain_caps == (b"a" if k == 0 else None)


# ---------------------------------------------------------------- GeomKeep.put's columns at once
class _OldPutKeep(GeomKeep):
    """GeomKeep with a20d971's put (a block's columns gathered block by block): the
    reference the columns joined once a put must write bit for bit."""

    def put(self, lo, sts, codes):
        if self.fh is None:
            return
        rows = np.flatnonzero((codes == C_CURVE) | (codes == C_CHAIN))
        if not rows.size:
            return
        gs = [sts[r].curv for r in rows.tolist()]
        try:
            bs, ks = [g._b for g in gs], np.fromiter((g._k for g in gs), np.int64, len(gs))
        except AttributeError:
            return
        cc = [g.chain_caps for g in gs]
        ids = np.fromiter(map(id, bs), np.int64, len(bs))
        _, first, grp = np.unique(ids, return_index=True, return_inverse=True)
        order = np.argsort(first[grp], kind="stable")
        cut = (np.flatnonzero(np.diff(first[grp][order])) + 1).tolist()
        parts, W = {}, self.window
        for a, z in zip([0] + cut, cut + [len(order)]):
            qs = order[a:z]
            b = bs[int(qs[0])]
            got = self._old_block(b, ks[qs], [cc[q] for q in qs.tolist()]) if gk._keepable(b) else None
            if got is None:
                continue
            (n, flags), cols, arrs, chain, kap = got
            rs = rows[qs] + lo
            js = rs // W
            cols[gk.C_ROW] = rs - js * W
            jcut = (np.flatnonzero(np.diff(js)) + 1).tolist()
            for c, e in zip([0] + jcut, jcut + [len(rs)]):
                parts.setdefault(int(js[c]), []).append(
                    ((n, e - c, flags), cols[:, c:e], [x[c:e] for x in arrs], b"".join(filter(None, chain[c:e])),
                     [x[c:e] for x in kap]))
        for j, ps in parts.items():
            self._write(j, ps)

    def _old_block(self, b, ks, cc):
        n, m = b.d.shape[1], len(ks)
        whole = m == b.d.shape[0] and not (ks - np.arange(m)).any()
        take = (lambda x: x) if whole else (lambda x: x[ks])
        _, lims, which, accel = b._lim
        cols = np.empty((gk.N_COLS, m))
        cols[gk.C_CAP], cols[gk.C_ACCEL] = take(b.cap), take(accel)
        cols[gk.C_LIM] = np.array([self._lim_index(x) for x in lims], float)[take(which)]
        cols[gk.C_END0:gk.C_END1 + 1] = gk._end_cols(b.cos_end if whole else [b.cos_end[k] for k in ks.tolist()])
        bits = np.zeros(m, np.int64)
        flags = gk.F_CAP_MIN if b.cap_min else 0
        arrs = [take(b.d)]
        if b._caps is not None:
            flags |= gk.F_CAPS
            arrs.append(take(b._caps))
        has = np.array([c is not None for c in cc], bool)
        if has.any():
            if not {type(c) for c in cc} <= {bytes, type(None)}:
                cc = [c if c is None or type(c) is bytes else np.asarray(c, float).tobytes() for c in cc]
            if {len(c) for c in cc if c} != {8 * (n - 1)}:
                return None
            bits[has] |= gk.R_CHAIN
        cols[gk.C_KE] = np.nan
        if b._ke is not None:
            flags |= gk.F_KE
            cols[gk.C_KE] = take(b._ke)
            if b._ke_miss is not None:
                bits[take(b._ke_miss)] |= gk.R_KE_MISS
        kap = []
        if b._kv is not None:
            flags |= gk.F_KV
            kap.append(take(b._kv))
            if b._kv_miss is not None:
                bits[take(b._kv_miss)] |= gk.R_KV_MISS
        cols[gk.C_BITS] = bits
        return (n, flags), cols, arrs, cc, kap


def _records(data, recs):
    """Each record of the keep's file (data) as its main doubles' bits and its κ rows' bits
    where made (a row whose κ is not made holds what its block's array held: not read)."""
    x = np.frombuffer(data, np.int64)
    out = {}
    for j, rs in recs.items():
        for at, n_main, n_kap in rs:
            main = x[at:at + n_main]
            f = main.view(float)
            P, R = int(f[0]), int(f[1])
            head = f[3:3 + 3 * P].astype(np.int64).reshape(P, 3).tolist()
            bits = f[3 + 3 * P + gk.C_BITS * R:3 + 3 * P + (gk.C_BITS + 1) * R].astype(np.int64)
            kap, y, r0 = [], at + n_main, 0
            for n, m, flags in head:
                if flags & gk.F_KV:
                    rows = x[y:y + m * (n + 1)].reshape(m, n + 1)
                    kap += [rows[k].tobytes() for k in range(m) if not bits[r0 + k] & gk.R_KV_MISS]
                    y += m * (n + 1)
                r0 += m
            assert y == at + n_main + n_kap
            out.setdefault(j, []).append((main.tobytes(), kap))
    return out


def _kept_file(tmp_path, prof_name, keep_type, name, window, pin_rows):
    """(the keep's records (_records), its records' places, its limits' fields) after
    plan_inputs_windowed."""
    tmp_path.mkdir()
    prof = load_profile(prof_name)
    path = str(S / name)
    opts = Options(features=feat.default_selection(path)[0])
    store = StrokeStore(folder=str(tmp_path))
    analyse(path, prof, opts, store)
    keep = keep_type(window, prof, str(tmp_path))
    plan_inputs_windowed(store, prof, opts, pin_rows, keep)
    size = os.fstat(keep.fh.fileno()).st_size
    data = os.pread(keep.fh.fileno(), size, 0)
    lims = [(type(x).__name__, [(a, repr(getattr(x, a))) for a in dir(x)
                                if not a.startswith("_") and not callable(getattr(x, a))]) for x in keep.lims]
    store.close()
    return _records(data, keep.recs), keep.recs, lims


@pytest.mark.parametrize("prof_name", ["prusa-mk3s", "voron24"])     # classic jerk; Klipper's (caps kept)
@pytest.mark.parametrize("name,window,pin_rows", [("prusa_gyroid_fullspeed.gcode", 37, 100),
                                                  ("prusa_gyroid.gcode", 64, 1000)])
def test_put_writes_the_block_by_block_records(tmp_path, prof_name, name, window, pin_rows):
    ref = _kept_file(tmp_path / "a", prof_name, _OldPutKeep, name, window, pin_rows)
    got = _kept_file(tmp_path / "b", prof_name, GeomKeep, name, window, pin_rows)
    assert len(ref[1]) > 3 and any(kap for rs in ref[0].values() for _, kap in rs)
    assert got[0] == ref[0]
    assert got[1] == ref[1]
    assert got[2] == ref[2]


def _old_rows_chain_caps(flat, head, bits, rs):
    """a20d971's geom_keep._rows_chain_caps (the reference)."""
    has = (bits & gk.R_CHAIN) != 0
    if not has[rs].any():
        return [None] * rs.size
    w = np.repeat([8 * (n - 1) for n, _, _ in head], [m for _, m, _ in head])
    z = np.cumsum(np.where(has, w, 0))[rs]
    buf = flat.tobytes()
    return [buf[a:b] if h else None for h, a, b in zip(has[rs].tolist(), (z - w[rs]).tolist(), z.tolist())]


@pytest.mark.parametrize("core", [True, False])
def test_chain_caps_given_are_the_slices(monkeypatch, core):
    if not core:
        monkeypatch.setattr(gk, "_BYTE_RUNS", None)
    elif gk._BYTE_RUNS is None:
        pytest.skip("curve core not built")
    rng = np.random.default_rng(60)
    head = [(1, 3, 0), (4, 5, 0), (2, 6, 0), (7, 2, 0)]        # (n, m, flags) a part; n = 1: empty caps
    R = sum(m for _, m, _ in head)
    bits = np.where(rng.random(R) < 0.6, gk.R_CHAIN, 0) | gk.R_KE_MISS * (rng.random(R) < 0.3)
    ns = np.repeat([n for n, _, _ in head], [m for _, m, _ in head])
    flat = rng.random(int(((ns - 1) * ((bits & gk.R_CHAIN) != 0)).sum()))
    every = np.arange(R)
    for rs in (every, every[::2], every[3:9], every[-1:], every[:0]):
        want = _old_rows_chain_caps(flat, head, bits, rs)
        assert gk._rows_chain_caps(flat, head, bits, rs) == want
        assert [type(x) for x in gk._rows_chain_caps(flat, head, bits, rs)] == [type(x) for x in want]
    assert gk._rows_chain_caps(flat, head, bits) == _old_rows_chain_caps(flat, head, bits, every)
    assert any(x == b"" for x in gk._rows_chain_caps(flat, head, bits))        # (a chain of one segment)
