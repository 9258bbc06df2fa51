"""Issue 8, stop 18 (D8): curves.build_geoms computes CurveGeom.cap (the least vertex cap x
CAP_MARGIN) and CurveGeom.cos_end (the turns at the two ends) for a chunk of strokes in
arrays (_cap_rows, _ends_rows) instead of per stroke in CurveGeom.__init__ (~12 µs a
stroke, 21 k curve strokes on the gyroid plate).  The same numbers and types as
9bb98a8's per-stroke code, copied below."""
import math

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt.firmware.simulate import CORNER_COS
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_CURVE

S = "sample_gcode/"


def _old_cap(g):
    caps = g.caps
    return curves.CAP_MARGIN * min(caps.tolist()) if caps.size else math.inf


def _old_cos_end(g, st):
    u = g.u
    cos_end = [None, None]
    for j, (a, b) in enumerate(((st.prev_u, tuple(u[0])), (tuple(u[-1]), st.next_u))):
        if a is not None and b is not None:
            c = a[0] * b[0] + a[1] * b[1]
            cos_end[j] = c if c >= CORNER_COS else None
    return curves._NO_ENDS if cos_end == [None, None] else tuple(cos_end)


def _same(x, y):
    if x is None or y is None:
        return x is None and y is None
    if isinstance(x, tuple):
        return isinstance(y, tuple) and len(x) == len(y) and all(_same(a, b) for a, b in zip(x, y))
    return type(x) is type(y) and (x == y or (math.isnan(x) and math.isnan(y))) and \
        np.float64(x).tobytes() == np.float64(y).tobytes()


@pytest.mark.parametrize("name,profile", [("prusa_gyroid.gcode", "prusa-mk3s"),
                                          ("prusa_gyroid_fullspeed_klipper.gcode", "voron24"),
                                          ("prusa_concentric.gcode", "prusa-mk4")])
def test_cap_and_ends_same_as_per_stroke(name, profile):
    prof = load_profile(profile)
    strokes, _ = analyse(S + name, prof, Options())
    todo = [st for st in strokes if st.kind == K_CURVE]
    assert len(todo) > 50
    for st in todo:
        st.curv = None
    curves.build_geoms(todo, prof, jerk1=True)
    n_ends = 0
    for st in todo:
        g = st.curv
        assert _same(g.cap, _old_cap(g)), (g.cap, _old_cap(g))
        assert _same(g.cos_end, _old_cos_end(g, st))
        n_ends += g.cos_end is not curves._NO_ENDS
    assert n_ends > 10                                    # ends that turn gently were compared


class _Lim:
    ax_max = ay_max = 1000.0
    scv, jd, jerk_x, jerk_y = 5.0, 0.02, 8.0, 8.0


class _St:
    def __init__(self, xy, prev_u, next_u):
        self.pts = [tuple(p) for p in xy]
        self.lim, self.accel, self.curv = _Lim(), 1000.0, None
        self.prev_u, self.next_u = prev_u, next_u


def test_random_curves_and_edge_cases():
    rng = np.random.default_rng(7)
    prof = load_profile("prusa-mk3s")
    sts = []
    for i in range(400):
        n = int(rng.integers(2, 20))
        head = rng.uniform(-math.pi, math.pi) + np.cumsum(rng.normal(0.0, 0.15, n))
        xy = np.vstack([[0.0, 0.0], np.cumsum(np.c_[np.cos(head), np.sin(head)] * rng.uniform(0.2, 1.5, n)[:, None], axis=0)])
        u0 = (math.cos(head[0] + rng.normal(0, 0.3)), math.sin(head[0] + rng.normal(0, 0.3)))
        u1 = (np.float64(math.cos(head[-1] + rng.normal(0, 0.3))), np.float64(math.sin(head[-1] + rng.normal(0, 0.3))))
        pick = rng.random()
        sts.append(_St(xy, None if pick < 0.2 else u0, None if 0.1 < pick < 0.3 else u1))
    curves.build_geoms(sts, prof)
    for st in sts:
        assert _same(st.curv.cap, _old_cap(st.curv))
        assert _same(st.curv.cos_end, _old_cos_end(st.curv, st))


@pytest.mark.parametrize("bad", [np.nan, 0.0, -0.0])
def test_cap_rows_declines_nan_and_zero(bad):
    flat = np.array([3.0, 2.0, bad, 5.0, 1.0])
    assert curves._cap_rows(flat, [0, 2, 4], [3, 3, 2]) == [None] * 3
    got = curves._cap_rows(np.array([3.0, 2.0, 7.0, 5.0, 1.0]), [0, 2, 2, 4], [3, 1, 3, 2])
    want = [curves.CAP_MARGIN * 2.0, math.inf, curves.CAP_MARGIN * 5.0, curves.CAP_MARGIN * 1.0]
    assert got == want and all(type(x) is float for x in got)
