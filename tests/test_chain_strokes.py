"""Chain strokes end to end (issue 9 item 1): gyroid infill at the slicer's full speed,
where every vertex caps the speed below F, re-timed as whole chains (chains.py).

Physics by the firmware model playing the output (not the planner's own figures),
invariants by verify.py, the emission's segment shapes by hand-computed kinematics."""

from pathlib import Path

import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.detect import auto_profile
from gcode_opt.pipeline import Options, analyse, process
from gcode_opt.schedule import plan_inputs
from gcode_opt.strokes import K_CHAIN
from gcode_opt.verify import verify

SAMPLES = Path(__file__).resolve().parent.parent / "sample_gcode"
MK3S = "prusa_gyroid_fullspeed.gcode"              # 80 mm/s, 1000 mm/s², classic jerk 8
KLIPPER = "prusa_gyroid_fullspeed_klipper.gcode"   # 147 mm/s, 4000 mm/s², scv 5


def _chain_lines(path, prof):
    """First line (1-based) and original figures of every chain stroke of the file."""
    strokes, _ = analyse(str(path), prof, Options())
    plan_inputs(strokes, prof, Options())
    return {s.first_idx + 1: s for s in strokes if chains.plan_kind(s) == K_CHAIN}


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = {}

    def get(name):
        if name not in out:
            src = SAMPLES / name
            prof = auto_profile(str(src)).profile
            dst = tmp_path_factory.mktemp("chains") / name
            out[name] = (src, dst, prof, process(str(src), str(dst), prof, Options()), _chain_lines(src, prof))
        return out[name]
    return get


def test_mk3s_gyroid_chains_lose_a_third_of_their_inertia(run):
    src, dst, prof, s, ch = run(MK3S)
    assert len(ch) >= 250
    # the chains are a small share of the time and a third of the file's ∫|a|²dt
    a2_all = sum(c.int_a2 for c in ch.values())
    assert a2_all > 0.25 * s["whole_file"]["before"]["int_a2"]
    got = [p for p in s["per_stroke"] if p["line"] in ch]
    assert len(got) >= 0.6 * len(ch)
    assert all(p["kind"] == "curve" for p in got)          # a chain is a curve to the file and summary
    drop = sum(p["int_a2"]["before"] - p["int_a2"]["after"] for p in got)
    assert drop >= 0.30 * a2_all                            # measured -34 % at +3.6 % of their time
    assert s["print_time_s"]["change"] <= 0.05
    wf = s["whole_file"]
    assert wf["after"]["full_stops"] <= wf["before"]["full_stops"]
    assert verify(str(src), str(dst), prof)["blocks"] == s["strokes"]["retimed"]


@pytest.mark.parametrize("name", [MK3S, pytest.param(KLIPPER, marks=pytest.mark.slow)])
def test_firmware_model_plays_the_chains_as_predicted(run, name):
    """The figures the planner predicted for each chain's segments (summary 'law') are
    what the firmware model measures on the written file, stroke by stroke."""
    _, _, _, s, ch = run(name)
    got = [p for p in s["per_stroke"] if p["line"] in ch]
    assert got
    for key, tol in (("time_s", 0.02), ("int_a2", 0.05)):
        pred = sum(p[key]["law"] for p in got)
        after = sum(p[key]["after"] for p in got)
        assert abs(after / pred - 1) <= tol, (key, after, pred)


def test_chain_blocks_keep_every_vertex(run):
    _, dst, _, s, ch = run(MK3S)
    lines = Path(dst).read_text().split("\n")
    out_first = {p["out_line"]: p for p in s["per_stroke"] if p["line"] in ch}
    assert out_first
    for ln, p in out_first.items():
        head = lines[ln - 1]
        assert head.startswith("; gcode-opt begin") and "kind=curve" in head
        n_rep = int(head.split("replaces ")[1].split()[0])
        n_seg = int(head.split("kind=curve, ")[1].split()[0])
        assert n_seg == n_rep == p["lines"]


# ------------------------------------------------------------------ segment shapes
def _trapezoid(d, va, vb, a, F):
    """Time and ∫a²dt of a firmware block from va to vb over d with acceleration a and
    feed F (accelerate to min(F, reachable), cruise, brake), computed from kinematics."""
    peak = min(F, np.sqrt((2 * a * d + va * va + vb * vb) / 2))
    up, down = (peak * peak - va * va) / (2 * a), (peak * peak - vb * vb) / (2 * a)
    cruise = d - up - down
    assert cruise >= -1e-9
    return (peak - va) / a + (peak - vb) / a + max(cruise, 0.0) / peak, a * a * ((peak - va) + (peak - vb)) / a


@pytest.mark.parametrize("va,vb", [(20.0, 20.0), (18.0, 24.0), (30.0, 12.0)])
def test_bump_shapes_take_the_laws_time(va, vb):
    d = np.array([0.7])
    t_ramp = 2 * 0.7 / (va + vb)
    for t in (0.95 * t_ramp, 0.8 * t_ramp):
        tri_a, tri_f = chains.shape_segments(d, np.array([t]), np.array([va]), np.array([vb]), trapezoid=False)
        trap_a, trap_f = chains.shape_segments(d, np.array([t]), np.array([va]), np.array([vb]))
        t_tri, i_tri = _trapezoid(0.7, va, vb, tri_a[0], tri_f[0])
        t_trap, i_trap = _trapezoid(0.7, va, vb, trap_a[0], trap_f[0])
        assert t_tri == pytest.approx(t, rel=1e-9)
        assert t_trap == pytest.approx(t, rel=1e-9)
        # the trapezoid is the least ∫a² shape taking t; a small symmetric bump: ~16 % below
        assert i_trap <= i_tri
        if va == vb:
            assert i_trap == pytest.approx(i_tri * 27 / 32, rel=0.03)


def test_monotone_segment_is_a_pure_ramp():
    d, va, vb = np.array([0.7]), np.array([15.0]), np.array([25.0])
    t = np.array([2 * 0.7 / 40.0])              # exactly the ramp's own time
    a, f = chains.shape_segments(d, t, va, vb)
    assert a[0] == pytest.approx((25.0 ** 2 - 15.0 ** 2) / 1.4)
    assert f[0] == 25.0


@pytest.mark.slow
def test_real_klipper_accepts_and_agrees_on_chains(run):
    """Real Klipper's planner (../shared/klipper) on the Klipper full-speed gyroid: no
    error, no new full stop, and the model's whole-file figures within the oracle
    tolerances (1 % time, 3 % ∫|a|²)."""
    import klipper_oracle as ko
    ko.oracle_or_skip()
    src, dst, prof, s, ch = run(KLIPPER)
    assert any(p["line"] in ch for p in s["per_stroke"])
    o0, o1 = ko.run_oracle(src, prof), ko.run_oracle(dst, prof)
    assert o1["errors"] == [], o1["errors"][:3]
    assert o1["n_internal_full_stops"] <= o0["n_internal_full_stops"]
    m1 = ko.model_metrics(dst, ko.oracle_machine(prof))
    assert abs(ko.rel_diff(m1["motion_time_s"], o1["motion_time_s"])) <= 0.01
    assert abs(ko.rel_diff(m1["int_a2_xy"], o1["int_a2_xy"])) <= 0.03
    m0 = ko.model_metrics(src, ko.oracle_machine(prof))
    # the whole-file change as Klipper measures it and as the model does: within 3 points
    d_o = o1["int_a2_xy"] / o0["int_a2_xy"] - 1
    d_m = m1["int_a2_xy"] / m0["int_a2_xy"] - 1
    assert abs(d_o - d_m) <= 0.03, (d_o, d_m)


# ------------------------------------------------------------------ the prediction's vector forms (issue 8)
def test_vector_jerk_junction_is_marlins_scalar_law():
    """chains._jerk_junction_v over arrays against firmware/junction.py's scalar Marlin
    law, junction by junction: gyroid-like turns, reversals, axis-aligned moves, feeds that
    coast (one side slower) and level ones."""
    from gcode_opt.firmware.junction import marlin_jerk_junction_v, marlin_safe_speed
    rng = np.random.default_rng(3)
    n = 4000
    a0 = rng.uniform(0, 2 * np.pi, n)
    turn = np.where(rng.random(n) < 0.7, rng.normal(0, 0.3, n), rng.uniform(-np.pi, np.pi, n))
    a0[:200] = np.round(a0[:200] / (np.pi / 2)) * (np.pi / 2)        # axis-aligned
    turn[:100] = 0.0
    pu = np.c_[np.cos(a0), np.sin(a0)]
    u = np.c_[np.cos(a0 + turn), np.sin(a0 + turn)]
    fp = rng.uniform(1.0, 150.0, n)
    fn = np.where(rng.random(n) < 0.3, fp, rng.uniform(1.0, 150.0, n))
    jx, jy = 8.0, 10.0
    got = chains._jerk_junction_v(pu, u, fp, fn, jx, jy)
    want = np.array([marlin_jerk_junction_v(pu[k, 0], pu[k, 1], 0.0, fp[k],
                                            marlin_safe_speed(pu[k, 0], pu[k, 1], 0.0, fp[k], jx, jy, 1.0),
                                            u[k, 0], u[k, 1], 0.0, fn[k],
                                            marlin_safe_speed(u[k, 0], u[k, 1], 0.0, fn[k], jx, jy, 1.0),
                                            jx, jy, 1.0) for k in range(n)])
    np.testing.assert_allclose(got, want, rtol=1e-14, atol=0)


def test_lookahead_scans_are_the_sequential_passes():
    """chains._lookahead_v2 (prefix minima) against the forward and backward passes written
    as the firmware's loop."""
    rng = np.random.default_rng(5)
    for n in (1, 2, 7, 60):
        v2 = rng.uniform(0, 3000, n + 1)
        v2[rng.random(n + 1) < 0.2] = 0.0
        reach = 2 * rng.uniform(100, 1500, n) * rng.uniform(0.1, 1.5, n)
        want = v2.copy()
        for k in range(1, n + 1):
            want[k] = min(want[k], want[k - 1] + reach[k - 1])
        for k in range(n - 1, -1, -1):
            want[k] = min(want[k], want[k + 1] + reach[k])
        np.testing.assert_allclose(chains._lookahead_v2(v2, reach), want, rtol=1e-12, atol=1e-9)


def test_jerk_junction_accels_shortcut_is_curves_law():
    """Under classic jerk chains._junction_accels skips curves.junction_accels' per-vertex
    loop (the jerk law needs no acceleration): the same accelerations on real chains."""
    from gcode_opt import curves
    from gcode_opt.segments import SegmentRules
    path = SAMPLES / MK3S
    prof = auto_profile(str(path)).profile
    assert prof.junction == "jerk" and prof.block_buffer > 0
    rules = SegmentRules.for_profile(prof, 10)
    rng = np.random.default_rng(2)
    sts = list(_chain_lines(path, prof).values())[:40]
    assert len(sts) == 40
    for st in sts:
        g = curves.geom(st, prof)
        n = g.d.size
        vk = rng.uniform(5.0, 80.0, n + 1)
        acc = rng.uniform(0.0, 1200.0, n)
        feed = np.maximum(vk[:-1], vk[1:]) * rng.uniform(1.0, 1.3, n)
        want = curves.junction_accels(st, g, vk, acc, rules, prof, vmax=feed)
        np.testing.assert_array_equal(chains._junction_accels(st, g, vk, acc, rules, prof, feed), want)


def test_vector_scv_junction_is_the_scalar_law():
    """chains._scv_junction_v (Klipper, arrays) against chains._junction_v, which calls
    firmware/junction.py's klipper_corner_v2 vertex by vertex, on a real chain of the
    Klipper sample with random accelerations (some 0: the default acceleration)."""
    from gcode_opt import curves
    path = SAMPLES / KLIPPER
    prof = auto_profile(str(path)).profile
    assert prof.junction == "scv"
    rng = np.random.default_rng(4)
    for st in list(_chain_lines(path, prof).values())[:10]:
        g = curves.geom(st, prof)
        n = g.d.size
        acc = rng.uniform(0.0, 6000.0, (3, n))
        acc[0, ::4] = 0.0
        got = chains._scv_junction_v(prof, g.u, g.d, acc, st.lim.scv, st.lim.ax_max, st.lim.ay_max)
        for r in range(3):
            want = [chains._junction_v(prof, st.lim, tuple(g.u[j - 1]), tuple(g.u[j]), g.d[j - 1], g.d[j],
                                       acc[r, j - 1], acc[r, j], 1e9, 1e9) for j in range(1, n)]
            np.testing.assert_allclose(got[r], want, rtol=1e-14)
