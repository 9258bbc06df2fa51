"""Line segments under Klipper "scv" and Marlin "jd" in rows (s29, segrows): plan_segments'
_finish_corner_rows / _corner_rows (was _finish + _finish_feeds_and_figures stroke by stroke)
and line_trapezoids' _line_trapezoid_rows (was _edges_prep / _edges_finish stroke by stroke).
The plans must be the same bits (knots, speeds, accelerations, feeds, figures, shape,
verdict) as the per-stroke forms, which stay in segments.py and are the references here:
  * plan_segments with both rows paths turned off (every stroke through _finish, the
    one-move trapezoids through _edges_prep / _edges_finish);
  * line_trapezoids against _line_trapezoid per stroke (the scalar least_a2_trapezoid);
  * accel_to_pass_junction_rows against accel_to_pass_junction on odd junctions.
On bundled samples (and corpus files when present) under voron24 / generic-klipper (scv)
and ender3 / generic-marlin (jd, its < 1 mm rule, Marlin's dropped short moves), with
slowed ends and junction commands (--corners), lead-ins and lead-outs, and the jerk
profile too (line_trapezoids' rows serve it)."""
import math
import os

import numpy as np
import pytest

from gcode_opt import plan as plan_mod
from gcode_opt import schedule as sc
from gcode_opt import segments as seg
from gcode_opt.firmware.junction import accel_to_pass_junction, accel_to_pass_junction_rows
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_LINE

S = "sample_gcode/"
CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus/")


def _line_laws(path, profile, corners=0.0, every=3):
    """Line strokes and several candidate laws each (T, beta), as the planner asks them."""
    prof = load_profile(profile)
    opts = Options()
    opts.corner_budget_r = corners
    strokes, _ = analyse(path, prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    rows = np.array([i for i in sc._rows_by_kind(strokes)[K_LINE] if not pin.fault[i]], int)
    T, beta, I, _ = plan_mod.candidates_auto(pin.take(rows))
    sts, Ts, bs = [], [], []
    for col in range(0, T.shape[1], every):
        ok = np.isfinite(I[:, col])
        sts += [strokes[i] for i in rows[ok]]
        Ts.append(T[ok, col])
        bs.append(beta[ok, col])
    return sts, np.concatenate(Ts), np.concatenate(bs), seg.SegmentRules.for_profile(prof, opts.max_segments)


def _per_stroke(monkeypatch):
    """plan_segments / line_trapezoids with the rows paths off: the per-stroke references."""
    monkeypatch.setattr(seg, "_finish_corner_rows", lambda sts, knots, rules: [None] * len(sts))
    monkeypatch.setattr(seg, "_line_trapezoid_rows", lambda sts, T, peaks, rules, out: list(range(len(sts))))


def _bits(x):
    x = np.asarray(x)
    return x.dtype.str, x.shape, x.tobytes()


def _same(g, w):
    if (g is None) != (w is None):
        return False
    if w is None:
        return True
    return (all(_bits(getattr(g, f)) == _bits(getattr(w, f)) for f in ("s", "v", "accel", "feed"))
            and float(g.time_t).hex() == float(w.time_t).hex() and float(g.int_a2).hex() == float(w.int_a2).hex()
            and type(g.time_t) is type(w.time_t) and type(g.int_a2) is type(w.int_a2)
            and g.shape == w.shape and g.first_cmds == w.first_cmds and g.fault == w.fault
            and sc.seg_fault(g) == sc.seg_fault(w))


CASES = [
    (S + "prusa_klipper.gcode", "voron24", 0.0),
    (S + "prusa_klipper.gcode", "generic-klipper", 0.3),         # slowed ends, junction commands
    (S + "prusa_mk3s_rectilinear.gcode", "voron24", 0.0),
    (S + "cura_box.gcode", "ender3", 0.0),                        # Marlin JD, dropped short moves
    (S + "cura_box.gcode", "generic-marlin", 0.3),
    (S + "prusa_gyroid.gcode", "ender3", 0.05),
    (S + "prusa_mk3s_rectilinear.gcode", "prusa-mk3s", 0.0),     # classic jerk: line_trapezoids' rows
]


@pytest.mark.parametrize("path,profile,corners", CASES)
def test_plan_segments_rows_same_bits_as_per_stroke(path, profile, corners, monkeypatch):
    sts, T, beta, rules = _line_laws(path, profile, corners)
    assert len(sts) > 200
    # the rows' paths' reach: they must take most strokes here (else this tests nothing)
    taken = {"corner": 0, "trap": 0}
    fcr, ltr = seg._finish_corner_rows, seg._line_trapezoid_rows

    def count_corner(s, k, r):
        got = fcr(s, k, r)
        taken["corner"] += sum(p is not None for p in got)
        return got

    def count_trap(s, t, p, r, out):
        rest = ltr(s, t, p, r, out)
        taken["trap"] += len(s) - len(rest)
        return rest

    monkeypatch.setattr(seg, "_finish_corner_rows", count_corner)
    monkeypatch.setattr(seg, "_line_trapezoid_rows", count_trap)
    got = seg.plan_segments(sts, T, beta, rules)
    _per_stroke(monkeypatch)
    want = seg.plan_segments(sts, T, beta, rules)
    assert len(got) == len(want)
    bad = [i for i, (g, w) in enumerate(zip(got, want)) if not _same(g, w)]
    assert not bad, (len(bad), bad[:5])
    if rules.junction != "jerk":
        assert taken["corner"] > 100
        assert taken["trap"] > (50 if not corners else 0)
        assert sum(type(p) is seg.RowPlan and p.shape == "law" for p in got) > 100
    if corners:
        assert any(any(seg.slowed_ends(st)) or st.corner_cmd0 or st.corner_cmd1 for st in sts)


TRAP_CASES = CASES[:6] + [(S + "prusa_gyroid.gcode", "prusa-mk3s", 0.0), (S + "prusa_gyroid.gcode", "voron24", 0.05)]


@pytest.mark.parametrize("path,profile,corners", TRAP_CASES)
def test_line_trapezoids_rows_same_bits_as_line_trapezoid(path, profile, corners):
    """Every stroke's one-move trapezoid, rows against _line_trapezoid (per stroke, the
    scalar least_a2_trapezoid), on short and long strokes alike."""
    sts, T, beta, rules = _line_laws(path, profile, corners, every=5)
    sts, T, beta = sts[::2], T[::2], beta[::2]
    peaks = seg.law_peak_speeds(sts, T, beta)
    got = seg.line_trapezoids(sts, T, beta, rules)
    want = [seg._line_trapezoid(st, float(t), float(p), rules) for st, t, p in zip(sts, T, peaks)]
    bad = [i for i, (g, w) in enumerate(zip(got, want)) if not _same(g, w)]
    assert not bad, (len(bad), bad[:5])
    assert sum(p is not None for p in got) > 100


@pytest.mark.parametrize("path,profile,corners", TRAP_CASES)
@pytest.mark.parametrize("edges", [True, False])
def test_line_trapezoid_rows_each_variant(path, profile, corners, edges):
    """Each variant alone (lead-in / lead-out at the corner speeds, or none), rows against
    _line_trapezoid_edges per stroke: the lead-in variant rarely wins the min, so it is
    checked here on its own (its knots 0, e0, L - e1, L; feeds at the corner speeds)."""
    sts, T, beta, rules = _line_laws(path, profile, corners, every=5)
    sts, T, beta = sts[1::2], T[1::2], beta[1::2]
    peaks = seg.law_peak_speeds(sts, T, beta)
    got = [None] * len(sts)
    rest = seg._line_trapezoid_rows(sts, T, peaks, rules, got, variants=(edges,))
    assert len(sts) - len(rest) >= 100                   # taken by the rows (slowed ends are not)
    assert corners or not rest
    rest = set(rest)
    for i, (st, t, p) in enumerate(zip(sts, T, peaks)):
        if i not in rest:
            assert _same(got[i], seg._line_trapezoid_edges(st, float(t), float(p), rules, edges)), i
    made = sum(p is not None for p in got)
    edged = sum(p is not None and p.s.size > 2 for p in got)
    if not edges or rules.junction == "jerk":             # no corner needs a lead-in under jerk
        assert edged == 0 and made > 100
    elif rules.junction == "jd":                         # every lead-in is < 1 mm: Marlin's rule, no plan
        assert made == 0
    else:
        assert edged > 50


@pytest.mark.skipif(not os.path.exists(CORPUS + "bridges_klipper.gcode"), reason="corpus not downloaded")
@pytest.mark.parametrize("profile,corners", [("voron24", 0.0), ("ender3", 0.3)])
def test_corpus_slice_same_bits(profile, corners, monkeypatch):
    sts, T, beta, rules = _line_laws(CORPUS + "bridges_klipper.gcode", profile, corners, every=7)
    sts, T, beta = sts[:6000], T[:6000], beta[:6000]
    got = seg.plan_segments(sts, T, beta, rules)
    _per_stroke(monkeypatch)
    want = seg.plan_segments(sts, T, beta, rules)
    bad = [i for i, (g, w) in enumerate(zip(got, want)) if not _same(g, w)]
    assert not bad, (len(bad), bad[:5])
    assert sum(p is not None for p in got) > 3000


def _junction_cases():
    rng = np.random.default_rng(29)
    ang = rng.uniform(0, 2 * np.pi, 400)
    turn = np.concatenate([rng.uniform(-np.pi, np.pi, 300), [0.0, 1e-9, -1e-9, np.pi, -np.pi, 1e-4,
                                                                np.pi - 1e-9, np.pi / 4, 3 * np.pi / 4, 2.0] * 10])
    out = []
    for k in range(400):
        ux, uy = math.cos(ang[k]), math.sin(ang[k])
        t = turn[k]
        pux, puy = math.cos(ang[k] - t), math.sin(ang[k] - t)
        pu = None if k % 17 == 0 else (pux, puy)
        v = [0.0, -1.0, 0.3, 25.0, 180.0, float("nan")][k % 6]
        d = [0.0, 1e-320, 0.05, 0.7, 0.999, 1.0, 4.0][k % 7]
        jd = [0.013, 0.08, 0.0][k % 3]
        out.append((v, pu, (ux, uy), d, jd))
    out.append((10.0, (1.0, 0.0), (1.0, 0.0), 0.5, 0.013))          # straight on, < 1 mm
    out.append((10.0, (1.0, 0.0), (-1.0, 0.0), 0.5, 0.013))         # reversal
    return out


@pytest.mark.parametrize("junction", ["scv", "jd"])
def test_junction_rows_as_per_junction(junction):
    cases = _junction_cases()
    v = np.array([c[0] for c in cases])
    has = np.array([c[1] is not None for c in cases])
    pux = np.array([c[1][0] if c[1] else 0.0 for c in cases])
    puy = np.array([c[1][1] if c[1] else 0.0 for c in cases])
    ux = np.array([c[2][0] for c in cases])
    uy = np.array([c[2][1] for c in cases])
    d = np.array([c[3] for c in cases])
    jd = np.array([c[4] for c in cases])
    need, odd = accel_to_pass_junction_rows(junction, v, pux, puy, has, ux, uy, d, jd)
    n_odd = 0
    for k, (vk, pu, u, dk, jdk) in enumerate(cases):
        try:
            want = accel_to_pass_junction(junction, vk, pu, u, dk, jdk)
        except ZeroDivisionError:
            assert odd[k], k                 # the rows' caller takes it stroke by stroke
            n_odd += 1
            continue
        assert not odd[k], k
        assert float(need[k]).hex() == float(want).hex(), (k, need[k], want)
    assert n_odd > 0 and n_odd < len(cases) // 4


@pytest.mark.parametrize("path,profile,junction", [(S + "cura_box.gcode", "ender3", "jd"),
                                                   (S + "prusa_klipper.gcode", "voron24", "scv")])
def test_odd_rules_same_bits(path, profile, junction, monkeypatch):
    """Rules the profiles do not have, to reach the rows' other branches: Marlin JD with
    short segments allowed (min_seg_d 0.05 mm: knots _merge_short merges, lead-ins JD's
    < 1 mm rule no longer refuses, so the straight junctions of a lead-in's trapezoid are
    checked) and Klipper with Marlin's dropped short moves (min_move_d)."""
    sts, T, beta, rules = _line_laws(path, profile, 0.0, every=4)
    rules = seg.SegmentRules(junction, 12, rules.seg_t / 4, 0.05, 0.0875, rules.flavour)
    T = T * 2.5                           # slower laws: knots crowd where they are slow
    got = seg.plan_segments(sts, T, beta, rules)
    peaks = seg.law_peak_speeds(sts, T, beta)
    var = [None] * len(sts)
    rest = set(seg._line_trapezoid_rows(sts, T, peaks, rules, var, variants=(True,)))
    _per_stroke(monkeypatch)
    want = seg.plan_segments(sts, T, beta, rules)
    bad = [i for i, (g, w) in enumerate(zip(got, want)) if not _same(g, w)]
    assert not bad, (len(bad), bad[:5])
    assert sum(type(p) is seg.RowPlan and p.shape == "law" for p in got) > 100
    assert sum(type(p) is seg.SegmentPlan for p in got) > 10          # _merge_short's strokes: per stroke
    n = 0
    for i, (st, t, p) in enumerate(zip(sts, T, peaks)):
        if i not in rest:
            w = seg._line_trapezoid_edges(st, float(t), float(p), rules, True)
            assert _same(var[i], w), i
            n += w is not None and w.s.size > 2
    assert n > 50


@pytest.mark.parametrize("junction", ["jd", "scv"])
def test_edges_finish_rows_as_edges_finish(junction):
    """_edges_finish_rows against _edges_finish on made-up trapezoids of real strokes: lead-in
    and lead-out shorter than 1 mm and gentle ramps, so that Marlin JD's check of the
    straight junctions (a raised ramp would not be the trapezoid: no plan) refuses some."""
    sts, _, _, rules = _line_laws(S + "cura_box.gcode", "ender3", 0.0, every=6)
    rules = seg.SegmentRules(junction, rules.n_max, rules.seg_t, rules.min_seg_d, rules.min_move_d, rules.flavour)
    sts = [st for st in sts if st.n_moves == 1 and st.length_d > 1.2][:600]
    n = len(sts)
    rng = np.random.default_rng(8)
    L = np.array([st.length_d for st in sts])
    e0 = np.where(rng.random(n) < 0.7, 0.3, 0.0)
    e1 = np.where(rng.random(n) < 0.7, 0.25, 0.0)
    v0 = rng.choice([0.0, 3.0, 20.0, 60.0], n)
    v1 = rng.choice([0.0, 5.0, 40.0], n)
    vp = np.maximum(np.maximum(v0, v1), 10.0) * rng.uniform(1.0, 2.0, n)
    a = rng.choice([0.5, 20.0, 400.0, 5000.0], n)
    need0 = rng.choice([0.0, 300.0, 9000.0], n)
    need1 = rng.choice([0.0, 150.0], n)
    Lm = L - e0 - e1
    ux = np.array([st.ux for st in sts])
    uy = np.array([st.uy for st in sts])
    jd = np.array([st.lim.jd for st in sts])
    accel = np.array([st.accel for st in sts])
    ks, plans, a2 = seg._edges_finish_rows(np.arange(n), vp, a, e0, e1, need0, need1, L, Lm, v0, v1, ux, uy, jd,
                                           accel, junction)
    assert a2.tolist() == [p.int_a2 for p in plans]
    got = dict(zip(ks.tolist(), plans))
    refused = 0
    for k, st in enumerate(sts):
        state = (st, rules, (st.ux, st.uy), float(v0[k]), float(v1[k]), float(L[k]), st.lim.jd, float(e0[k]),
                 float(e1[k]), float(Lm[k]), float(need0[k]), float(need1[k]))
        with np.errstate(all="ignore"):
            want = seg._edges_finish(state, float(vp[k]), float(a[k]))
        assert _same(got.get(k), want), k
        refused += want is None
    assert (refused > 20) if junction == "jd" else refused == 0


@pytest.mark.parametrize("path,profile,junction", [(S + "cura_box.gcode", "ender3", "jd"),
                                                   (S + "prusa_klipper.gcode", "voron24", "scv")])
def test_line_trapezoids_edges_longer_than_a_quarter(path, profile, junction):
    """A long shortest kept move (min_move_d 1.2 mm): the lead-ins of short strokes are cut
    to a quarter of the stroke, below min_edge_d, so the edges' variant has none while its
    needs were asked at the cut edge's length: not the other variant's trapezoid (the
    rows solve that one too), against _line_trapezoid per stroke."""
    sts, T, beta, rules = _line_laws(path, profile, 0.0, every=4)
    sts, T, beta = sts[::2], T[::2], beta[::2]
    rules = seg.SegmentRules(junction, 12, rules.seg_t, 0.05, 1.2, rules.flavour)
    peaks = seg.law_peak_speeds(sts, T, beta)
    got = seg.line_trapezoids(sts, T, beta, rules)
    want = [seg._line_trapezoid(st, float(t), float(p), rules) for st, t, p in zip(sts, T, peaks)]
    bad = [i for i, (g, w) in enumerate(zip(got, want)) if not _same(g, w)]
    assert not bad, (len(bad), bad[:5])
    assert sum(p is not None for p in got) > 1000
