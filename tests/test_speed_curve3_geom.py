"""curves.build_geoms computes the curve geometry (segments, turns, κ(s) at the vertices,
κ_eff) for all strokes of one vertex count at once (curves._batch_parts); every field must
be the same bits as CurveGeom's own per-stroke path (laws/curve.curvature_from_polyline
and np.interp, unbatched), and a stroke the batch does not take (duplicate point,
non-finite coordinates, too few or too many vertices) must behave as before, raising
where it raised."""
import dataclasses
import math

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.state import Limits
from gcode_opt.strokes import Points

S = "sample_gcode/"
FIELDS = ("d", "u", "cos_turn", "s_v", "kappa_v", "caps", "caps_jerk1")


class _St:
    """The stroke fields CurveGeom reads."""
    def __init__(self, pts, lim, accel, prev_u=None, next_u=None, as_points=True):
        self.pts = Points([c for p in pts for c in p]) if as_points else [tuple(p) for p in pts]
        self.lim, self.accel, self.prev_u, self.next_u, self.curv = lim, accel, prev_u, next_u, None


def _reference(st, prof):
    """CurveGeom stroke by stroke on its own path (no batch parts, no batched caps)."""
    g = curves.CurveGeom(st, prof)
    return g


def _same(a, b):
    for f in FIELDS:
        x, y = getattr(a, f), getattr(b, f)
        if x is None or y is None:
            assert x is None and y is None, f
            continue
        x, y = np.asarray(x), np.asarray(y)
        assert x.shape == y.shape and x.dtype == y.dtype, f
        assert x.tobytes() == y.tobytes(), (f, np.flatnonzero(x.ravel() != y.ravel())[:5])
    assert a.kappa_eff == b.kappa_eff and float(a.kappa_eff).hex() == float(b.kappa_eff).hex()
    assert a.cap == b.cap or (math.isnan(a.cap) and math.isnan(b.cap))
    assert a.cos_end == b.cos_end


def _random_curve(rng, n):
    """A slicer-like gentle curve: turns of a few degrees, short segments, coordinates
    rounded to 0.001 mm (sometimes unrounded, sometimes with a long segment)."""
    turn = rng.normal(0.0, 0.12, n) + rng.choice([0.0, 0.05, -0.2], n)
    head = rng.uniform(-math.pi, math.pi) + np.cumsum(turn)
    d = rng.uniform(0.2, 1.5, n) * rng.choice([1.0, 1.0, 1.0, 6.0], n)
    xy = np.cumsum(np.c_[np.cos(head), np.sin(head)] * d[:, None], axis=0)
    xy = np.vstack([[0.0, 0.0], xy]) + rng.uniform(-100, 100, 2)
    return np.round(xy, 3) if rng.random() < 0.8 else xy


@pytest.mark.parametrize("junction", ["jerk", "jd", "scv"])
def test_batched_geometry_bitwise_equal_to_per_stroke(junction):
    rng = np.random.default_rng(7)
    prof = dataclasses.replace(load_profile("generic-marlin"), junction=junction)
    lim = Limits(300.0, 4000.0, 2500.0, 5.0, 0.5, 0.02, 8.0, 10.0)
    pts = [_random_curve(rng, int(n)) for n in rng.choice([2, 3, 4, 5, 9, 13, 40, 130], size=300)]
    sts = [_St(p, lim, rng.choice([0.0, 800.0, 3000.0]), (1.0, 0.0) if k % 3 else None,
               (0.0, 1.0) if k % 2 else None, as_points=k % 5 != 0) for k, p in enumerate(pts)]
    curves.build_geoms(sts, prof, jerk1=True)
    parts = curves._batch_parts([_St(p, lim, 0.0) for p in pts])
    assert sum(p is not None for p in parts) == len(pts)      # all of these take the batch
    for st in sts:
        ref = _St(np.asarray(st.pts, float), lim, st.accel, st.prev_u, st.next_u)
        g = _reference(ref, prof)
        if junction == "jerk":          # what build_geoms(jerk1=True) adds
            g.caps_jerk1 = curves.vertex_caps(prof, lim, st.accel, g.u, g.d, jerk_r=1.0)
        _same(st.curv, g)


def test_batched_geometry_on_a_real_file_equal_to_per_stroke():
    prof = load_profile("prusa-mk3s")
    strokes, _ = analyse(S + "prusa_gyroid.gcode", prof, Options())
    sts = [st for st in strokes if st.kind == "curve"]
    assert len(sts) > 50
    curves.build_geoms(sts, prof)
    for st in sts:
        g = curves.CurveGeom(st, prof)
        _same(st.curv, g)


def test_strokes_the_batch_does_not_take_follow_their_own_path():
    """A duplicate point (curvature drops it), a curve of more vertices than one smoothing
    window, a NaN coordinate (raises, as geom() does): the strokes before the one that
    raises keep their geometry, the same as per stroke."""
    rng = np.random.default_rng(3)
    prof = load_profile("prusa-mk3s")
    lim = Limits(300.0, 4000.0, 2500.0, 5.0, 0.5, 0.02, 8.0, 10.0)
    dup = _random_curve(rng, 12)
    dup = np.vstack([dup[:5], dup[4:]])
    long = _random_curve(rng, 600)
    good = _random_curve(rng, 12)
    bad = _random_curve(rng, 12)
    bad[6, 0] = np.nan
    sts = [_St(p, lim, 1000.0) for p in (dup, long, good, bad, _random_curve(rng, 12))]
    parts = curves._batch_parts(sts)
    assert parts[0] is None and parts[1] is None and parts[2] is not None and parts[3] is None
    with np.errstate(all="ignore"), pytest.raises(Exception) as e_batch:
        curves.build_geoms(sts, prof)
    with np.errstate(all="ignore"), pytest.raises(Exception) as e_one:
        curves.CurveGeom(_St(bad, lim, 1000.0), prof)
    assert type(e_batch.value) is type(e_one.value)
    for st, p in zip(sts[:3], (dup, long, good)):
        with np.errstate(all="ignore"):
            ref = _reference(_St(p, lim, 1000.0), prof)
        _same(st.curv, ref)
    assert sts[4].curv is None


def test_mass_ratio_rows_equal_per_stroke():
    """adjust_plan_inputs' direction masses, summed by blocks of one segment count, are
    the per-stroke float(np.sum(w * u_x²)) bit for bit."""
    rng = np.random.default_rng(11)
    prof = load_profile("prusa-mk3s")
    lim = Limits(300.0, 4000.0, 2500.0, 5.0, 0.5, 0.02, 8.0, 10.0)
    sts = [_St(_random_curve(rng, int(n)), lim, 1000.0) for n in rng.choice([2, 3, 9, 17, 60], size=80)]
    curves.build_geoms(sts, prof)
    gs = [st.curv for st in sts]
    want = [float(np.sum((g.d / g.d.sum()) * g.u[:, 0] ** 2)) for g in gs]
    got = curves._ux2_rows(gs)
    assert [x.hex() for x in got] == [x.hex() for x in want]
