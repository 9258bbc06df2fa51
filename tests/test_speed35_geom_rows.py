"""Issue 8, session 35 (geom): what the curve geometry and the curves' segment plans hold
through planning.

* curves._finish_rows makes each curve's SegmentPlan as a RowPlan, row k of the four
  blocks it computes for the strokes of one knot count (knots, speeds, accelerations,
  feeds), not a SegmentPlan of two arrays and two views of its own (~0.45 kB of numpy
  objects a plan).  The numbers are the rows of those blocks (tests/test_speed_plan3_finish.py
  pins them to the per-stroke loop); here: the plans share the blocks, each row is its
  stroke's knots, and the verdict kept is seg_fault's.
* CurveGeom keeps four slots: the vertices are read from its block (every block keeps
  its rows' vertices; build_geoms' keep no directions u), on both paths.
"""
import sys

import numpy as np

from gcode_opt import curves
from gcode_opt import schedule as sc
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.segments import RowPlan, SegmentRules
from gcode_opt.strokes import K_CURVE, Points

S = "sample_gcode/"


def _curve_plans(name, profile):
    """(strokes, their knots, finish_curves' plans) of the curves of a sample, at each
    one's first candidate law that meets its limits."""
    prof = load_profile(profile)
    opts = Options()
    strokes, _ = analyse(S + name, prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    rows = np.array([i for i in sc._rows_by_kind(strokes)[K_CURVE] if not pin.fault[i]], int)
    T, beta, _, _ = curves.candidates_curve(pin, rows, strokes, prof)
    sts, Ts, bs = [], [], []
    for i, t, b in zip(rows.tolist(), T, beta):
        ok = np.flatnonzero(np.isfinite(t))
        if ok.size:
            sts.append(strokes[i])
            Ts.append(t[ok[0]])
            bs.append(b[ok[0]])
    assert len(sts) > 30
    knots = curves.curve_knots(sts, Ts, bs, prof)
    rules = SegmentRules.for_profile(prof, opts.max_segments)
    return sts, knots, curves.finish_curves(sts, knots, rules, prof)


def test_curve_plans_are_rows_of_shared_blocks():
    sts, knots, plans = _curve_plans("prusa_gyroid.gcode", "prusa-mk3s")
    blocks = {}                 # knot count -> the four blocks' ids
    rowed = 0
    for (sk, vk), plan in zip(knots, plans):
        if sk.size < 3:         # one segment: finish_curve's own plan
            continue
        assert type(plan) is RowPlan
        rowed += 1
        ids = (id(plan._s), id(plan._v), id(plan._accel), id(plan._feed))
        assert blocks.setdefault(sk.size, ids) == ids       # one set of blocks a knot count
        assert plan.s.tobytes() == sk.tobytes() and plan.v.tobytes() == vk.tobytes()
        assert plan.accel.shape == plan.feed.shape == (sk.size - 1,)
        # the verdict kept on the blocks is the one seg_fault finds on the plan's own rows
        assert plan.fault in (None, "") and (plan.fault == "") == (sc.seg_fault(plan) == "")
    assert rowed > 30 and len(blocks) < rowed


def test_curve_geom_reads_vertices_from_its_block():
    prof = load_profile("prusa-mk3s")
    strokes, _ = analyse(S + "prusa_gyroid.gcode", prof, Options())
    sts = [st for st in strokes if st.kind == K_CURVE][:200]
    curves.build_geoms(sts, prof)
    assert any(st.curv._b in curves._BLOCKS for st in sts)
    for st in sts:
        g = st.curv
        assert g._b._pts[g._k] is st.pts            # the stroke's own Points, not a copy
        assert g.pts.tobytes() == np.asarray(st.pts, float).tobytes()
        assert not hasattr(g, "_pts") and not hasattr(g, "__dict__")
    # CurveGeom's own path: a block of one row that keeps u and the stroke's vertices
    st = sts[0]
    st.curv = None
    g = st.curv = curves.CurveGeom(st, prof)
    assert g._b._u is not None and g._b._pts == [st.pts] and g.pts.tobytes() == np.asarray(st.pts, float).tobytes()
    # four slots: pymalloc's 64-byte class (a fifth took 80 bytes a geometry)
    assert len(curves.CurveGeom.__slots__) == 4 and sys.getsizeof(g) <= 64
    # stack_du gathers the rows' vertices from their blocks: the same bits as row by row
    gs = [s.curv for s in sts if s.curv.d.size == sts[1].curv.d.size]
    D, U = curves.stack_du(gs)
    assert D.tobytes() == np.array([x.d for x in gs], float).tobytes()
    assert U.tobytes() == np.array([x.u for x in gs], float).tobytes()
    for s in sts:
        s.curv = None
    assert isinstance(sts[0].pts, Points)
