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
import random
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
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
