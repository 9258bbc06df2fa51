"""Round 26 (curvec): the curves' per-geometry Python made a block of rows at a time.

* curves._window_rows: the finite buffer's window sums of every row by one np.convolve
  over the rows end to end, against the per-row np.convolve it replaces (kept here);
* curves._Knots.of: the knots made a geometry block at a time, against the per-geometry
  s_v / kappa_v concatenation it replaces (kept here), on the bundled gyroid's curves;
* curves._finish_rows' cos_turn from the stacked directions: tests/test_speed_plan3_finish.py
  compares whole plans with finish_curve's (every profile kind), and the gyroid plate's
  curve plans are checked here against finish_curve when the corpus is there."""
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt import schedule as sc
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_CURVE

S = Path(__file__).resolve().parent.parent / "sample_gcode"
PLATE = Path.home() / ".cache/gcode-opt-corpus/plate_gyroid.gcode"


def _bits(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def _window_rows_old(D, nb):
    n = D.shape[1]
    ones = np.ones(nb)
    return np.stack([np.convolve(np.concatenate([d, np.full(nb, d[-1])]), ones, "valid")[:n] for d in D])


def test_window_rows_as_per_row_convolve():
    rng = np.random.default_rng(26)
    for m, n in ((1, 1), (1, 5), (7, 2), (50, 9), (300, 17), (40, 130)):
        for nb in (1, 2, 3, 4, 5, 13, 16, 17, 29, 45):
            D = rng.uniform(1e-3, 3.0, (m, n)) * rng.choice([1.0, 1e-4, 1e3], (m, 1))
            if m > 5:
                D[3, n // 2] = np.nan
                D[4, -1] = np.inf
            with np.errstate(invalid="ignore"):
                got, want = curves._window_rows(D, nb), _window_rows_old(D, nb)
            assert _bits(np.ascontiguousarray(got), want), (m, n, nb)


def _knots_old(gs):
    sv = [g.s_v for g in gs]
    kv = [g.kappa_v for g in gs]
    cnt = np.array([x.size for x in sv], dtype=np.int64)
    off = np.zeros(cnt.size, dtype=np.int64)
    np.cumsum(cnt[:-1], out=off[1:])
    return np.concatenate(sv), np.concatenate(kv), off, cnt


def _curve_geoms(path, profile):
    prof = load_profile(profile)
    strokes, _ = analyse(str(path), prof, Options())
    pin = sc.plan_inputs(strokes, prof, Options())
    rows = [i for i in sc._rows_by_kind(strokes)[K_CURVE] if not pin.fault[i]]
    return [curves.geom(strokes[i], prof) for i in rows]


@pytest.mark.parametrize("name,profile", [("prusa_gyroid.gcode", "prusa-mk3s"),
                                          ("prusa_concentric.gcode", "voron24")])
def test_knots_by_block_as_per_geometry(name, profile):
    gs = _curve_geoms(S / name, profile)
    assert len(gs) > 50 and len({id(g._b) for g in gs}) > 3
    for sel in (gs, gs[::-1], gs[::3] + gs[:5]):          # any order, repeats
        kn = curves._Knots.of(sel)
        xs, ys, off, cnt = _knots_old(sel)
        assert _bits(kn.xs, xs) and _bits(kn.ys, ys) and _bits(kn.off, off) and _bits(kn.cnt, cnt)


def test_knots_without_blocks_take_the_per_geometry_path():
    class G:                                   # a geometry of another make (no _b)
        def __init__(self, d, k):
            self.s_v = np.concatenate([[0.0], np.cumsum(d)])
            self.kappa_v = k
    rng = np.random.default_rng(3)
    gs = [G(rng.uniform(0.1, 1.0, n), rng.uniform(0.0, 2.0, n + 1)) for n in (3, 5, 4)]
    kn = curves._Knots.of(gs)
    xs, ys, off, cnt = _knots_old(gs)
    assert _bits(kn.xs, xs) and _bits(kn.ys, ys) and _bits(kn.off, off) and _bits(kn.cnt, cnt)


@pytest.mark.skipif(not PLATE.exists(), reason="corpus plate not downloaded")
def test_plate_knots_and_windows(tmp_path):
    lines = PLATE.read_text().splitlines(keepends=True)[:40000]
    src = tmp_path / "plate_head.gcode"
    src.write_text("".join(lines))
    gs = _curve_geoms(src, "prusa-mk3s")
    assert len(gs) > 300
    kn = curves._Knots.of(gs)
    xs, ys, off, cnt = _knots_old(gs)
    assert _bits(kn.xs, xs) and _bits(kn.ys, ys) and _bits(kn.off, off)
    by_n = {}
    for g in gs:
        by_n.setdefault(g.d.size, []).append(g)
    for n, grp in by_n.items():
        D = curves.stack_du(grp)[0]
        assert _bits(np.ascontiguousarray(curves._window_rows(D, 13)), _window_rows_old(D, 13)), n


def _adjust_old(pin, strokes, rows, profile, cap_peak=True):
    """curves.adjust_plan_inputs as it was (ad24489): row by row."""
    mx, my = profile.moving_mass_x_kg, profile.moving_mass_y_kg
    gs = [curves.geom(strokes[i], profile) for i in rows]
    for i, g, ux2 in zip(rows, gs, _ux2_old(gs)):
        st = strokes[i]
        uy2 = 1.0 - ux2
        pin.mass_r[i] = (mx * mx * ux2 + my * my * uy2) / (mx * ux2 + my * uy2)
        pin.a_cap[i] = min(st.accel, st.lim.ax_max, st.lim.ay_max)
        if cap_peak:
            pin.v_cap[i] = min(pin.v_cap[i], g.cap)


def _ux2_old(gs):
    out = [0.0] * len(gs)
    by_n = {}
    for k, g in enumerate(gs):
        by_n.setdefault(g.d.size, []).append(k)
    for ks in by_n.values():
        d = np.stack([gs[k].d for k in ks])
        ux = np.stack([gs[k].u[:, 0] for k in ks])
        w = d / d.sum(axis=1, keepdims=True)
        for k, x in zip(ks, np.sum(w * ux ** 2, axis=1).tolist()):
            out[k] = x
    return out


class _Pin:
    def __init__(self, n, rng):
        self.mass_r = rng.uniform(0.5, 2.0, n)
        self.a_cap = rng.uniform(100.0, 5000.0, n)
        self.v_cap = rng.uniform(10.0, 300.0, n)
        self.v_cap[::7] = np.inf


@pytest.mark.parametrize("name,profile", [("prusa_gyroid.gcode", "prusa-mk3s"),
                                          ("prusa_concentric.gcode", "voron24")])
def test_adjust_plan_inputs_as_row_by_row(name, profile):
    prof = load_profile(profile)
    strokes, _ = analyse(str(S / name), prof, Options())
    sc.plan_inputs(strokes, prof, Options())
    rows = [i for i, st in enumerate(strokes) if st.kind == K_CURVE and st.curv is not None]
    assert len(rows) > 50
    for cap_peak in (True, False):
        rng = np.random.default_rng(7)
        a, b = _Pin(len(strokes), rng), None
        b = _Pin(len(strokes), np.random.default_rng(7))
        curves.adjust_plan_inputs(a, strokes, np.array(rows[::2] + rows[1::2]), prof, cap_peak)
        _adjust_old(b, strokes, rows[::2] + rows[1::2], prof, cap_peak)
        for f in ("mass_r", "a_cap", "v_cap"):
            assert _bits(getattr(a, f), getattr(b, f)), f
    assert all(strokes[i].curv.caps_jerk1 is None for i in rows)


def _dot2(a, b):
    """two products and their sum, each rounded (what np.dot of two 2-vectors gave until a
    BLAS with a fused ddot: OpenBLAS 0.3.31)"""
    return float(a[0]) * float(b[0]) + float(a[1]) * float(b[1])


def test_end_cosines_as_plain_dot():
    """curves._end_cosines against a per-stroke plain two-product dot, on the bundled
    gyroid's curves (neighbours present or None) and on random directions."""
    prof = load_profile("prusa-mk3s")
    strokes, _ = analyse(str(S / "prusa_gyroid.gcode"), prof, Options())
    sc.plan_inputs(strokes, prof, Options())
    sts = [st for st in strokes if st.kind == K_CURVE and st.curv is not None]
    by_n = {}
    for st in sts:
        by_n.setdefault(st.curv.d.size, []).append(st)
    n_some = 0
    for grp in by_n.values():
        gs = [st.curv for st in grp]
        c0, c1 = curves._end_cosines(grp, curves.stack_du(gs)[1])
        w0 = [None if st.prev_u is None else _dot2(st.prev_u, g.u[0]) for st, g in zip(grp, gs)]
        w1 = [None if st.next_u is None else _dot2(g.u[-1], st.next_u) for st, g in zip(grp, gs)]
        assert [None if x is None else np.float64(x).tobytes() for x in c0] == \
            [None if x is None else np.float64(x).tobytes() for x in w0]
        assert [None if x is None else np.float64(x).tobytes() for x in c1] == \
            [None if x is None else np.float64(x).tobytes() for x in w1]
        n_some += sum(x is not None for x in c0) + sum(x is None for x in c1)
    assert n_some > 20

    class St:
        def __init__(self, pu, nu):
            self.prev_u, self.next_u = pu, nu
    rng = np.random.default_rng(9)
    U = rng.normal(size=(500, 4, 2)) * rng.choice([1.0, 1e-8, 1e8], (500, 1, 1))
    sts = [St(None if k % 5 == 0 else tuple(rng.normal(size=2)), None if k % 7 == 0 else tuple(rng.normal(size=2)))
           for k in range(500)]
    c0, c1 = curves._end_cosines(sts, U)
    for k, st in enumerate(sts):
        want0 = None if st.prev_u is None else _dot2(st.prev_u, U[k, 0])
        want1 = None if st.next_u is None else _dot2(U[k, -1], st.next_u)
        assert (c0[k] is None) == (want0 is None) and (c0[k] is None or np.float64(c0[k]).tobytes() == np.float64(want0).tobytes())
        assert (c1[k] is None) == (want1 is None) and (c1[k] is None or np.float64(c1[k]).tobytes() == np.float64(want1).tobytes())
