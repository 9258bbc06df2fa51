"""group_lines sums a curve's lengths, points and E per mm as it reads the moves (issue 8):
Stroke._curve gets them instead of of_curve's second loop over the run.  Pinned bit for bit
against of_curve as it was (commit 9bb98a8, copied below, not imported) and, on random event
streams, group_strokes against the c8abe7b grouping (test_speed_analyse's reference)."""
from __future__ import annotations

import math
from array import array

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as hs

from gcode_opt import curves, vertex_filter
from gcode_opt import features as feat
from gcode_opt.profile import load_profile
from gcode_opt.state import LINE, Barrier, Limits, Move
from gcode_opt.strokes import K_CURVE, Points, Stroke, group_strokes
from test_speed_analyse import _ref_group_strokes, _stroke_bits


def _ref_of_curve(moves, ds=None):
    """Stroke.of_curve at 9bb98a8, verbatim but for cls -> Stroke."""
    st = Stroke(moves[0])
    st.kind = K_CURVE
    xy = [moves[0].x0, moves[0].y0]
    if ds is None:
        ds = [math.hypot(m.x1 - m.x0, m.y1 - m.y0) for m in moves]
    length_d, e_per_mm = 0.0, st.e_per_mm
    ends = []
    for m, d in zip(moves, ds):
        length_d += d
        ends.append(length_d)
        q = m.e / d
        if q > e_per_mm:          # max(e_per_mm, q)
            e_per_mm = q
        xy += (m.x1, m.y1)
    st.length_d, st.e_per_mm = length_d, e_per_mm
    st.pts, st.ends_d = Points(xy), array("d", ends)
    st.last_idx = moves[-1].idx
    return st


LIM = Limits(300.0, 1000.0, 1000.0, 5.0, 0.5, 0.013, 8.0, 8.0)
LIM2 = Limits(300.0, 1000.0, 1000.0, 5.0, 0.5, 0.013, 0.0, 8.0)     # no X jerk: every vertex splits
FEATS = [feat.SPARSE_INFILL, feat.SOLID_INFILL, feat.PERIMETER, feat.TRAVEL]

_step = hs.tuples(
    hs.sampled_from(["move"] * 12 + ["none", "barrier", "feed", "feature", "z", "lim", "gap", "accel"]),
    hs.one_of(hs.floats(-40.0, 40.0), hs.sampled_from([0.0, 0.01, 0.06, 29.9, 30.0, 31.0, 90.0, 180.0])),
    hs.one_of(hs.floats(1e-4, 3.0), hs.sampled_from([1e-7, 1e-6, 0.2, 2.0, 2.0000001, 2.5])),
    hs.one_of(hs.floats(-0.05, 0.2), hs.sampled_from([0.0, 1e-300, 0.05])))


def _stream(steps):
    """(idx, raw, event) triples: moves from the origin turning by the drawn angles."""
    x = y = 0.0
    z, v, accel, feature, lim, heading = 0.2, 80.0, 1000.0, FEATS[0], LIM, 0.3
    idx, out = 0, []
    for kind, turn_deg, d, e in steps:
        if kind == "none":
            out.append((idx, ";", None))
        elif kind == "barrier":
            out.append((idx, "G4", Barrier(idx, 0.0, "G4")))
        elif kind == "gap":
            idx += 1            # a line the stream skips: moves either side are not adjacent
            continue
        else:
            if kind == "feed":
                v = 20.0 if v == 80.0 else 80.0
            elif kind == "feature":
                feature = FEATS[(FEATS.index(feature) + 1) % len(FEATS)]
            elif kind == "z":
                z += 0.2
            elif kind == "lim":
                lim = LIM2 if lim is LIM else LIM
            elif kind == "accel":       # 5e-324: every cap 0 under jd and scv, nothing proven
                accel = 5e-324 if accel == 1000.0 else 1000.0
            heading += math.radians(turn_deg)
            x1, y1 = x + d * math.cos(heading), y + d * math.sin(heading)
            e_mv = 0.0 if feature == feat.TRAVEL and e < 0.02 else e
            out.append((idx, "G1", Move(idx, LINE, x, y, z, x1, y1, z, e_mv, v, accel, feature, 0, lim)))
            x, y = x1, y1
        idx += 1
    return out


def _tagged(fn, stream, selected, min_d, turn, split):
    out = []
    for item in fn(iter(stream), selected, min_d, turn, split, lambda: (0.5, 1000.0, 1500.0, 0.5)):
        out.append(("line", item[1]) if item[0] == "line" else ("stroke", _stroke_bits(item[1])))
    return out


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(steps=hs.lists(_step, min_size=1, max_size=60), prof=hs.sampled_from(["prusa-mk3s", "voron24", "ender3"]),
       min_d=hs.sampled_from([0.0, 0.2, 2.0]), turn=hs.sampled_from([0.0, 10.0, 30.0, 90.0]),
       selected=hs.sampled_from([feat.DEFAULT_SELECTED, feat.ALL]))
def test_group_strokes_on_random_streams_is_the_reference(steps, prof, min_d, turn, selected):
    profile = load_profile(prof)
    stream = _stream(steps)
    ref = _tagged(_ref_group_strokes, stream, selected, min_d, turn, curves.vertex_splitter(profile) if turn else None)
    assert _tagged(group_strokes, stream, selected, min_d, turn,
                   vertex_filter.splitter(profile) if turn else None) == ref
    assert _tagged(group_strokes, stream, selected, min_d, turn,
                   curves.vertex_splitter(profile) if turn else None) == ref


@settings(max_examples=300, deadline=None)
@given(steps=hs.lists(_step, min_size=1, max_size=40), given_ds=hs.booleans())
def test_of_curve_is_the_reference(steps, given_ds):
    """Stroke.of_curve (test_speed_analyse's reference calls it) against its 9bb98a8 copy."""
    moves = [ev for _, _, ev in _stream([("move",) + s[1:] for s in steps])]
    ds = [math.hypot(m.x1 - m.x0, m.y1 - m.y0) for m in moves] if given_ds else None
    assert _stroke_bits(Stroke.of_curve(moves, ds)) == _stroke_bits(_ref_of_curve(moves, ds))


def _moves(points, accels=None, lim=LIM):
    """(idx, raw, Move) triples along the points, one per segment, printing sparse infill."""
    out = []
    for k, ((x0, y0), (x1, y1)) in enumerate(zip(points[:-1], points[1:])):
        a = accels[k] if accels else 1000.0
        out.append((k, "G1", Move(k, LINE, x0, y0, 0.2, x1, y1, 0.2, 0.05, 80.0, a, FEATS[0], 0, lim)))
    return out


def _zigzag(n, x=0.0):
    pts = [(x, 0.0)]
    for k in range(n):
        pts.append((pts[-1][0] + 0.5, 0.1 if k % 2 == 0 else 0.0))
    return pts


def test_group_strokes_where_the_acceleration_changes_is_the_reference():
    """A run at 1000 mm/s^2 then one at 5e-324 (every jd cap 0: each vertex splits) under the
    same limits: the filter's bounds of the first run must not serve the second."""
    pts = _zigzag(8)
    stream = _moves(pts, accels=[1000.0] * 4 + [5e-324] * 4)
    profile = load_profile("ender3")
    ref = _tagged(_ref_group_strokes, stream, feat.DEFAULT_SELECTED, 0.0, 30.0, curves.vertex_splitter(profile))
    assert _tagged(group_strokes, stream, feat.DEFAULT_SELECTED, 0.0, 30.0, vertex_filter.splitter(profile)) == ref
    assert sum(1 for item in ref if item[0] == "stroke") >= 4


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_group_strokes_at_the_collinear_tolerance_is_the_reference(sign):
    """A vertex whose cross product is exactly +-COLLINEAR_SIN: collinear (|cross| <= it)."""
    dy = sign * 0.0010000005000003751
    u = (1.0 / math.hypot(1.0, dy), dy / math.hypot(1.0, dy))
    assert 1.0 * u[1] - 0.0 * u[0] == sign * 1e-3
    stream = _moves([(0.0, 0.0), (1.0, 0.0), (2.0, dy), (3.0, 2 * dy), (4.0, 3 * dy)])
    profile = load_profile("prusa-mk3s")
    for split in (None, vertex_filter.splitter(profile)):
        ref = _tagged(_ref_group_strokes, stream, feat.DEFAULT_SELECTED, 0.0, 30.0, split)
        assert _tagged(group_strokes, stream, feat.DEFAULT_SELECTED, 0.0, 30.0, split) == ref
