"""Lines with the same inputs are planned once (s30, lineplan).

plan.pieces_once makes the candidates of each distinct set of a line's inputs once
(plan._same_inputs: L, v0, v1, v_cap, a_cap, T_orig, t_seg_min, by their bytes) and gives
them to every line with those inputs (plan.SharedPiece); the budget runs segment each line
class (segments.line_classes: every stroke field plan_segments reads, by bytes and type)
once per (T, beta) (segments.plan_once), the others taking a copy of the plan.  Checked:

- the candidates against 479aedb's _candidates_auto (kept verbatim in
  test_speed22_budget_candidates.py) and against the path that makes every row
  (plan.candidate_pieces), bit for bit, on bundled samples and the rectilinear plate's lines;
- the plans against plan_segments of every stroke (each stroke its own), field by field
  and bit for bit, with corners.py's slowed corners on (v0_fw, corner_cmd0/1 set), under
  classic jerk, SCV and junction deviation; every stroke holds a plan object of its own;
- line_classes against the fields plan_segments reads: strokes proxied so that every
  attribute read is recorded, and each one must be compared by line_classes; a copy of a
  stroke with any one compared field changed (last bit, -0.0, None, a bool, lim) is of
  another class;
- SegmentCache.alone: a stroke whose field changes is a class of its own.
"""
import copy
import os

import numpy as np
import pytest

from gcode_opt import features as feat
from gcode_opt import plan as plan_mod
from gcode_opt import schedule as sc
from gcode_opt import segments as sg
from gcode_opt.pipeline import Options, analyse
from gcode_opt.plan import T_RATIOS, Candidates
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_LINE

from test_speed22_budget_candidates import _same, candidates_ref  # noqa: E402  (479aedb's, verbatim)

S = "sample_gcode/"
PLATE = os.path.expanduser("~/.cache/gcode-opt-corpus/plate_rectilinear.gcode")


def _setup(path, profile, corners=False):
    prof = load_profile(profile)
    opts = Options(max_slowdown_r=0.05, features=feat.parse_feature_list("all")) if corners else Options()
    if corners:
        opts.corner_budget_r = 1.0
    strokes, _ = analyse(path, prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    rows = np.array([i for i in sc._rows_by_kind(strokes)[K_LINE] if not pin.fault[i]], int)
    return prof, opts, strokes, pin, rows


def _bits(x):
    return np.ascontiguousarray(x, float).view(np.int64)


# ------------------------------------------------------------------ candidates
def _dense(p, pieces):
    cands, bad = Candidates.of_pieces(len(p.L), list(pieces), p.T_orig)
    return tuple(cands), bad


def _same_pieces(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b):
        assert np.array_equal(x[0], y[0]) and np.array_equal(x[1], y[1])
        assert np.array_equal(_bits(x[2]), _bits(y[2]))
        assert np.array_equal(x[3], y[3]) and np.array_equal(x[4], y[4])


def _check_candidates(p, chunk=plan_mod.CANDIDATE_CHUNK):
    rows = np.arange(len(p.L))
    got = plan_mod.pieces_once(lambda q, r, t: plan_mod.candidate_pieces(q, r, t, chunk), p, rows, p.T_orig)
    want = plan_mod.candidate_pieces(p, rows, p.T_orig, chunk)  # every row made
    dense, bad = _dense(p, got)
    assert bad.size == 0
    n = _same(candidates_ref(p, chunk), dense)
    _same_pieces([Candidates.piece(rows, dense, p.T_orig)], [Candidates.piece(rows, _dense(p, want)[0], p.T_orig)])
    return n


@pytest.mark.parametrize("name,profile", [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"),
                                          ("prusa_gyroid.gcode", "prusa-mk3s"),
                                          ("prusa_klipper.gcode", "voron24"),
                                          ("cura_box.gcode", "prusa-mk3s")])
def test_line_candidates_same_bits(name, profile):
    _, _, _, pin, rows = _setup(S + name, profile)
    p = pin.take(rows)
    # the samples' lines repeat: their first of each taken (a few on two lines only)
    ps = p.take(np.repeat(np.arange(len(p.L)), 3))
    assert plan_mod._same_inputs(ps) is not None
    for chunk in (plan_mod.CANDIDATE_CHUNK, 97):
        assert _check_candidates(ps, chunk) > 0
        assert _check_candidates(p, chunk) > 0


def _plain_ref(p):
    """_live_entries' test, on every duration (as it is there)."""
    T = p.T_orig[:, None] * T_RATIOS[None, :]
    with np.errstate(all="ignore"):
        return bool(np.isfinite(T).all() and bool((T > 0).all()) and np.isfinite(p.L).all()
                    and np.isfinite(p.v0).all() and np.isfinite(p.v1).all()
                    and bool(((T / (2.0 * plan_mod.GAMMA_HI)) ** 2 > 0.0).all()))


@pytest.mark.parametrize("t", [0.5, 0.0, -0.0, -1e-3, 1e-300, 6.4e-156, 3.2e-156, 1e-155, 5e-324, 1e-6, 1.1e308, 1.3e308,
                               np.inf, np.nan, -np.inf])
def test_plain_on_two_columns(t):
    """plan._plain (the least and largest ratio) against _live_entries' test on all 23,
    around the underflow of (T / 2e6)^2 and the overflow of T_orig x 1.5."""
    _, _, _, pin, rows = _setup(S + "prusa_mk3s_rectilinear.gcode", "prusa-mk3s")
    p = pin.take(rows[:50])
    assert plan_mod._plain(p) and _plain_ref(p)
    for q in range(0, 50, 7):
        for k in range(-3, 4):              # the neighbours of t, a few ulps either way
            y = p.take(np.arange(50))
            y.T_orig[q] = t if not np.isfinite(t) else np.nextafter(t, np.inf * np.sign(k)) if k else t
            for _ in range(abs(k) - 1):
                y.T_orig[q] = np.nextafter(y.T_orig[q], np.inf * np.sign(k))
            assert plan_mod._plain(y) == _plain_ref(y), (t, k, y.T_orig[q])
    for f in ("L", "v0", "v1"):
        x = p.take(np.arange(50))
        getattr(x, f)[3] = np.nan
        assert not plan_mod._plain(x) and not _plain_ref(x)
    # the boundary of (T_orig 0.7 / 2e6)^2 > 0 itself (T_orig ~4.5e-156), found by bisection
    lo, hi = 0.0, 1e-100
    for _ in range(2000):
        mid = lo + (hi - lo) / 2
        if mid in (lo, hi):
            break
        x = p.take(np.arange(50))
        x.T_orig[0] = mid
        lo, hi = (lo, mid) if _plain_ref(x) else (mid, hi)
    for v in (lo, hi, np.nextafter(hi, 1.0), np.nextafter(lo, 0.0)):
        x = p.take(np.arange(50))
        x.T_orig[0] = v
        assert plan_mod._plain(x) == _plain_ref(x), v


def test_candidates_apart_by_bytes():
    """-0.0 and 0.0 (and every input column) keep strokes apart; a NaN input is not plain."""
    _, _, _, pin, rows = _setup(S + "prusa_mk3s_rectilinear.gcode", "prusa-mk3s")
    p = pin.take(np.repeat(rows[:40], 4))
    first, inv = plan_mod._same_inputs(p)
    cols = ("L", "v0", "v1", "v_cap", "a_cap", "T_orig", "t_seg_min")
    keys = [b"".join(getattr(p, f)[q].tobytes() for f in cols) for q in range(len(p.L))]
    assert first.size == len(set(keys))
    assert all(keys[first[inv[q]]] == keys[q] for q in range(len(p.L)))
    assert np.all(np.diff(first) > 0) and all(keys[i] not in keys[:i] for i in first.tolist())
    for f in ("L", "v0", "v1", "v_cap", "a_cap", "T_orig", "t_seg_min"):
        q = p.take(np.arange(len(p.L)))
        x = getattr(q, f)
        x[1] = np.nextafter(x[1], np.inf)
        got = plan_mod._same_inputs(q)
        assert got is not None and got[1][1] != got[1][0], f
    q = p.take(np.arange(len(p.L)))
    q.v0[:] = 0.0
    q.v0[1] = -0.0
    assert plan_mod._same_inputs(q)[1][1] != plan_mod._same_inputs(q)[1][0]
    q.L[2] = np.nan
    assert plan_mod._same_inputs(q) is None


@pytest.mark.skipif(not os.path.exists(PLATE), reason="corpus not downloaded")
def test_rectilinear_plate_candidates():
    _, _, _, pin, rows = _setup(PLATE, "prusa-mk3s")
    p = pin.take(rows[:sc.CANDIDATE_ROWS])
    first, _ = plan_mod._same_inputs(p)
    assert first.size < 0.4 * len(p.L)
    assert _check_candidates(p) > 10000


# ------------------------------------------------------------------ segments
def _laws(pin, rows, cls):
    """A (T, beta) per line, the same in a class (T_orig x a ratio; beta inf or finite)."""
    k = cls % 7
    T = pin.T_orig[rows] * T_RATIOS[[3, 5, 7, 8, 9, 6, 4]][k]
    beta = np.where(k % 3 == 0, (T / 3.0) ** 2, np.inf)
    return T, beta


def _same_plan(a, b):
    if a is None or b is None:
        return a is None and b is None
    return (type(a) is type(b) and all(np.array_equal(_bits(getattr(a, f)), _bits(getattr(b, f)))
                                       and np.shape(getattr(a, f)) == np.shape(getattr(b, f))
                                       for f in ("s", "v", "accel", "feed"))
            and _bits(a.time_t) == _bits(b.time_t) and _bits(a.int_a2) == _bits(b.int_a2)
            and a.shape == b.shape and a.fault == b.fault and a.first_cmds == b.first_cmds)


@pytest.mark.parametrize("name,profile,corners", [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", True),
                                                  ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s", False),
                                                  ("prusa_gyroid.gcode", "voron24", True),
                                                  ("cura_box.gcode", "ender3", True)])
def test_line_plans_same_bits(name, profile, corners):
    prof, opts, strokes, pin, rows = _setup(S + name, profile, corners)
    rules = sg.SegmentRules.for_profile(prof, opts.max_segments)
    sts = [strokes[i] for i in rows.tolist()]
    cls = sg.line_classes(sts)
    # each stroke three times (a plate's layers): the copies the same strokes
    sts3, cls3 = sts * 3, np.tile(cls, 3)
    T, beta = _laws(pin, np.tile(rows, 3), cls3)
    want = sg.plan_segments(sts3, T, beta, sg.SegmentRules.for_profile(prof, opts.max_segments))
    got = sg.plan_once(lambda s, t, b: sg.plan_segments(s, t, b, rules), sts3, T, beta, cls3)
    assert got is not None
    assert sum(p is not None for p in got) > 50
    assert all(_same_plan(a, b) for a, b in zip(want, got))
    held = [p for p in got if p is not None]
    # a plan object of its own for each stroke that may get a junction command (corners.py
    # slowed its start); the others may share their class's (s31: nothing else is set on it)
    cmd = [p for p, st in zip(got, sts3) if p is not None and st.corner_cmd0]
    assert len({id(p) for p in cmd}) == len(cmd)
    if not corners:
        assert len({id(p) for p in held}) < len(held)
    # a junction command put on one copy stays on it
    a, b = held[0], next(p for p in held[1:] if _same_plan(p, held[0]) or True)
    a.first_cmds = ("M205 X1", "M205 X8")
    assert b.first_cmds is None or b.first_cmds != a.first_cmds or b is a
    # schedule's line kind: plan_once where a class repeats, else plan_segments of all
    seg = sc.KINDS[K_LINE].segments
    got2 = seg(sts3, T, beta, rules, prof, same=cls3)
    assert all(_same_plan(a, b) for a, b in zip(sg.plan_segments(sts3, T, beta, rules), got2))


class _Rec:
    """A stroke whose attribute reads are recorded."""
    def __init__(self, st, seen):
        object.__setattr__(self, "_st", st)
        object.__setattr__(self, "_seen", seen)

    def __getattr__(self, name):
        self._seen.add(name)
        return getattr(self._st, name)


COMPARED = set(sg._LINE_FLOATS + sg._LINE_MAYBE) | {
    "lim",                                  # by its values
    "n_moves", "first_idx", "last_idx",     # one move each (line_spans)
    "ends_d", "_ends",                      # none kept: (length_d,)
    "prev_u", "next_u",                     # (_pux, _puy), (_nux, _nuy)
}


@pytest.mark.parametrize("name,profile", [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"),
                                          ("prusa_gyroid.gcode", "voron24"),
                                          ("cura_box.gcode", "ender3")])
def test_line_classes_compare_what_plan_segments_reads(name, profile):
    prof, opts, strokes, pin, rows = _setup(S + name, profile, corners=True)
    rules = sg.SegmentRules.for_profile(prof, opts.max_segments)
    single = [i for i in rows.tolist() if strokes[i].n_moves == 1]
    seen = set()
    sts = [_Rec(strokes[i], seen) for i in single]
    T, beta = _laws(pin, np.array(single), np.arange(len(single)))
    sg.plan_segments(sts, T, beta, rules)
    assert {"length_d", "v0", "v1", "ux", "uy"} <= seen
    assert seen - {"__class__"} <= COMPARED, seen - COMPARED


def _with(st, name, value):
    c = copy.copy(st)
    setattr(c, name, value)
    return c


def test_line_classes_apart_on_any_field():
    _, _, strokes, _, rows = _setup(S + "prusa_mk3s_rectilinear.gcode", "prusa-mk3s", corners=True)
    st = next(strokes[i] for i in rows.tolist() if strokes[i].n_moves == 1 and strokes[i].next_u is not None)
    twin = copy.copy(st)
    assert sg.line_classes([st, twin]).tolist()[0] == sg.line_classes([st, twin]).tolist()[1]
    for name in sg._LINE_FLOATS + sg._LINE_MAYBE:
        x = getattr(st, name)
        others = ([np.nextafter(x, np.inf), -x if x == 0.0 else x * 2, None] if type(x) is float
                  else [not x, 1.0] if type(x) is bool else [0.0, -0.0, 1.0, False])
        for v in others:
            if v is None and name in sg._LINE_FLOATS:
                continue
            c = sg.line_classes([st, _with(st, name, v)])
            assert c[0] != c[1], (name, x, v)
    z = _with(st, "ux", 0.0)
    c = sg.line_classes([z, _with(st, "ux", -0.0)])
    assert c[0] != c[1]
    for f in sg._LIM_FIELDS:
        lim = copy.copy(st.lim)
        setattr(lim, f, getattr(lim, f) + 1.0)
        c = sg.line_classes([st, _with(st, "lim", lim)])
        assert c[0] != c[1], f
    c = sg.line_classes([st, _with(st, "lim", copy.copy(st.lim))])     # another object, the same values
    assert c[0] == c[1]
    c = sg.line_classes([st, _with(st, "ends_d", np.array([st.length_d]))])
    assert c[0] != c[1]


def test_alone():
    cache = sc.SegmentCache()
    cache.line_class = np.array([5, 5, 7], np.int64)
    cache.alone(1)
    assert cache.line_class[1] not in (5, 7) and cache.line_class[0] == 5


@pytest.mark.skipif(not os.path.exists(PLATE), reason="corpus not downloaded")
def test_rectilinear_plate_lines_repeat():
    _, _, strokes, pin, rows = _setup(PLATE, "prusa-mk3s")
    assert sc._lines_repeat(pin, rows)
    cls = sg.line_classes([strokes[i] for i in rows.tolist()])
    assert np.unique(cls).size < 0.2 * rows.size
