"""Firmware model on cases worked out by hand.

Every expected number is derived in the comment next to it from the constant-acceleration
trapezoid (d_acc = (v1^2 - v0^2) / 2a, t_acc = (v1 - v0) / a) and the firmware's junction
law; none is copied from the code's output.
"""
import math
import random

import pytest

from gcode_opt.profile import Profile
from gcode_opt.firmware import simulate as simmod
from gcode_opt.firmware.simulate import simulate_file

REL = 1e-6


def klipper(**kw):
    base = dict(flavour="klipper", junction="scv", max_velocity_v=1000.0, max_accel_a=1e6,
                default_accel_a=1000.0, travel_accel_a=1000.0, retract_accel_a=1500.0,
                square_corner_velocity_v=5.0, minimum_cruise_ratio_r=0.0, block_buffer=0)
    base.update(kw)
    return Profile("test-klipper", **base)


def marlin(**kw):
    base = dict(flavour="marlin2", junction="jd", max_velocity_v=1000.0, max_accel_a=1e6,
                default_accel_a=1000.0, travel_accel_a=1000.0, retract_accel_a=1500.0,
                junction_deviation_d=0.013, block_buffer=16)
    base.update(kw)
    return Profile("test-marlin", **base)


def run(tmp_path, text, prof):
    p = tmp_path / "t.gcode"
    p.write_text(text)
    recs = []
    res = simulate_file(str(p), prof, recs.append)
    return res, recs


def approx(x, rel=REL, abs=1e-9):
    return pytest.approx(x, rel=rel, abs=abs)


def test_single_move_trapezoid(tmp_path):
    # 100 mm at v=100 mm/s, a=1000: accelerates over v^2/2a = 5 mm in v/a = 0.1 s, same to
    # stop; cruise 90 mm in 0.9 s.  time = d/v + v/a = 1.1 s.
    # int a^2 = a^2 (0.1 + 0.1) = 2 a v = 200000.
    # int v^2 = 2 * a^2 t^3 / 3 (t = 0.1) + 100^2 * 0.9 = 666.667 + 9000.
    res, recs = run(tmp_path, "G1 X100 F6000\n", klipper())
    assert res.time_t == approx(1.1)
    assert res.int_a2 == approx(200000.0)
    assert res.int_a2_t == approx(200000.0)
    assert res.int_v2 == approx(2 * 1e6 * 0.1 ** 3 / 3 + 9000.0)
    assert res.peak_v == approx(100.0)
    assert res.peak_a == approx(1000.0)
    assert len(recs) == 1 and recs[0].idx == 0
    assert recs[0].start_v == 0.0 and recs[0].end_v == approx(0.0)


def test_single_move_triangle(tmp_path):
    # 10 mm asking 200 mm/s at a=1000: 200^2/2a = 20 mm > d/2, so a triangle: peak^2 = a d
    # -> 100 mm/s; time = 2 sqrt(d/a) = 0.2 s; int a^2 = a^2 * 0.2 = 200000.
    res, recs = run(tmp_path, "G1 X10 F12000\n", klipper())
    assert res.peak_v == approx(100.0)
    assert res.time_t == approx(0.2)
    assert res.int_a2 == approx(200000.0)


def test_collinear_different_speeds(tmp_path):
    # X0->50 at 100 mm/s then X50->100 at 50 mm/s, a=1000, straight: junction = 50.
    # move 1: 0->100: 5 mm, 0.1 s; 100->50: (100^2-50^2)/2000 = 3.75 mm, 0.05 s;
    #         cruise 41.25 mm / 100 = 0.4125 s -> 0.5625 s
    # move 2: cruise 48.75 mm / 50 = 0.975 s; 50->0: 1.25 mm, 0.05 s -> 1.025 s
    res, recs = run(tmp_path, "G1 X50 F6000\nG1 X100 F3000\n", klipper())
    assert recs[0].end_v == approx(50.0) and recs[1].start_v == approx(50.0)
    assert recs[0].time_t == approx(0.5625)
    assert recs[1].time_t == approx(1.025)
    assert res.time_t == approx(1.5875)
    assert res.int_a2 == res.int_a2_t          # no direction change
    assert res.full_stops == 0


def test_square_corner_klipper(tmp_path):
    # 90 deg corner: cos(theta) = 0, sin(theta/2) = 1/sqrt2, R_jd = sin/(1-sin) = 1+sqrt2;
    # jd = scv^2 (sqrt2-1)/a so v^2 = R_jd * jd * a = scv^2 (sqrt2+1)(sqrt2-1) = 25 -> 5 mm/s.
    # centripetal caps: 0.25 * tan(45) * 2 d a = 5000 (>25), not binding.
    # each 10 mm move at 100 mm/s: 0->100 5 mm 0.1 s; 100->5: (10000-25)/2000 = 4.9875 mm,
    # 0.095 s; cruise 0.0125 mm, 0.000125 s -> 0.195125 s.
    # a 90 deg turn is a corner: dv = 2*5*sin(45) -> dv^2 = 50, reported apart from int a^2.
    res, recs = run(tmp_path, "G1 X10 F6000\nG1 Y10\n", klipper())
    assert recs[0].end_v == approx(5.0)
    assert recs[0].time_t == approx(0.195125) and recs[1].time_t == approx(0.195125)
    assert recs[0].int_a2_j == 0.0 and recs[1].int_a2_j == 0.0
    assert res.corners == 1 and res.corner_dv2 == approx(50.0)
    assert res.int_a2_t == approx(2 * 1e6 * 0.195)
    assert res.int_a2 == approx(2 * 1e6 * 0.195)
    assert sum(r.int_a2 + r.int_a2_j for r in recs) == approx(res.int_a2)


def test_gentle_turn_is_spread_as_normal_acceleration(tmp_path):
    # a 10 deg turn (<= 30 deg: a curve, not a corner) at Klipper scv=5, a=1000, F=100 mm/s:
    # cos(theta) = -cos(10deg); sin(theta/2) = cos(5deg) = 0.996195; R_jd = 261.8;
    # v^2 = R_jd * jd * a = R_jd * scv^2 (sqrt2 - 1) = 2711 (jd term) vs centripetal
    # 0.25*tan(85deg)*2*10*1000 = 57150 -> v = 52.07 mm/s; dv^2 = 2 v^2 (1 - cos 10deg),
    # spread over t_j.
    import math
    c, s_ = math.cos(math.radians(10)), math.sin(math.radians(10))
    res, recs = run(tmp_path, f"G1 X10 F6000\nG1 X{10 + 10 * c:.6f} Y{10 * s_:.6f}\n", klipper())
    sin_d2 = math.cos(math.radians(5))
    v = math.sqrt(sin_d2 / (1 - sin_d2) * 25.0 * (math.sqrt(2) - 1))
    assert recs[0].end_v == approx(v, rel=1e-5)
    dv2 = 2 * v * v * (1 - c)
    tj = 0.5 * (recs[0].time_t + recs[1].time_t)
    assert res.corners == 0
    assert recs[0].int_a2_j + recs[1].int_a2_j == approx(dv2 / tj, rel=1e-5)


def test_reversal_stops(tmp_path):
    # X0->10->0: exact reversal, R_jd = 0 -> junction 0.  Each leg rest-to-rest, 10 mm at
    # 100 mm/s, a=1000: v^2 = a d exactly, so t = 2 v / a = 0.2 s each.
    res, recs = run(tmp_path, "G1 X10 F6000\nG1 X0\n", klipper())
    assert recs[0].end_v == approx(0.0)
    assert res.time_t == approx(0.4)
    assert res.full_stops == 1 and res.stop_lines == [2]
    assert res.int_a2 == res.int_a2_t          # v = 0 at the turn: no normal term


def test_minimum_cruise_ratio_single_move(tmp_path):
    # 10 mm asking 200 mm/s, a=1000.
    # mcr=0: triangle, peak 100 mm/s, 0.2 s.
    # mcr=0.5: pseudo accel 500 -> mcr_delta_v2 = 2*10*500 = 10000; the backward pass gives
    # peak_cruise_v2 = (0 + 10000)/2 = 5000 -> cruise 70.7107 mm/s; accel and decel
    # 5000/2000 = 2.5 mm each in 0.0707107 s; cruise 5 mm / 70.7107 = 0.0707107 s
    # -> 3 * 0.0707107 = 0.212132 s.
    r0, _ = run(tmp_path, "G1 X10 F12000\n", klipper(minimum_cruise_ratio_r=0.0))
    r5, _ = run(tmp_path, "G1 X10 F12000\n", klipper(minimum_cruise_ratio_r=0.5))
    assert r0.peak_v == approx(100.0) and r0.time_t == approx(0.2)
    assert r5.peak_v == approx(math.sqrt(5000.0))
    assert r5.time_t == approx(3 * math.sqrt(5000.0) / 1000.0)


def _chain(n=10, d=1.0, dv=10.0):
    """Up: segment i (1..n) from v_{i-1} to v_i = dv*i at a_i = (v_i^2 - v_{i-1}^2)/2d with
    F = v_i; then the mirror image down to rest."""
    lines, x = [], 0.0
    v = [dv * i for i in range(n + 1)]
    for i in range(1, n + 1):
        a = (v[i] ** 2 - v[i - 1] ** 2) / (2 * d)
        x += d
        lines += [f"M204 S{a:.6f}", f"G1 X{x:.6f} F{v[i] * 60:.6f}"]
    for i in range(n, 0, -1):
        a = (v[i] ** 2 - v[i - 1] ** 2) / (2 * d)
        x += d
        lines += [f"M204 S{a:.6f}", f"G1 X{x:.6f} F{v[i] * 60:.6f}"]
    return "\n".join(lines) + "\n", v


def test_accel_chain_followed_exactly(tmp_path):
    # mcr=0: each segment's max start is min(F_{i-1}^2, F_i^2, reachable) = v_{i-1}^2 and
    # its delta_v2 = 2 d a_i = v_i^2 - v_{i-1}^2, so the plan is: segment i accelerates
    # from v_{i-1} to v_i over its whole length, t_i = 2d/(v_{i-1}+v_i) = 0.2/(2i-1) s;
    # the mirror segments decelerate the same way.  peak 100 mm/s at the middle junction.
    text, v = _chain()
    res, recs = run(tmp_path, text, klipper(minimum_cruise_ratio_r=0.0))
    assert len(recs) == 20
    for i in range(1, 11):
        assert recs[i - 1].start_v == approx(v[i - 1], abs=1e-6)
        assert recs[i - 1].end_v == approx(v[i])
        assert recs[20 - i].start_v == approx(v[i])
        assert recs[20 - i].end_v == approx(v[i - 1], abs=1e-6)
    t = 2 * sum(0.2 / (2 * i - 1) for i in range(1, 11))
    assert res.time_t == approx(t)
    # int a^2 = sum a_i^2 t_i, a_i = 50 (2i - 1): 2 * sum 2500 (2i-1)^2 * 0.2/(2i-1)
    assert res.int_a2 == approx(2 * sum(500.0 * (2 * i - 1) for i in range(1, 11)))
    assert res.peak_v == approx(100.0)
    assert res.full_stops == 0


def test_accel_chain_capped_by_mcr(tmp_path):
    # mcr=0.5: the mcr pass uses half of every delta_v2.  Forward, the smoothed start of up
    # segment i is v_{i-1}^2/2; backward from the end the smoothed starts of the down
    # segments are v_k^2/2, so none of them can "accelerate" and they wait (cruise None).
    # The last up segment then has mcr_start = v_9^2/2 and reach = v_10^2/2 + (v_10^2 -
    # v_9^2)/2, and is a peak (full-accel move before full-decel moves):
    # peak_cruise_v2 = (v_9^2/2 + v_10^2 - v_9^2/2)/2 = v_10^2/2 -> peak = 100/sqrt2.
    text, v = _chain()
    res, recs = run(tmp_path, text, klipper(minimum_cruise_ratio_r=0.5))
    assert res.peak_v == approx(100.0 / math.sqrt(2.0))
    # below the cap (v_i^2 <= 5000, i.e. i <= 7) the chain is still followed exactly
    for i in range(1, 8):
        assert recs[i - 1].end_v == approx(v[i])
    r0, _ = run(tmp_path, text, klipper(minimum_cruise_ratio_r=0.0))
    assert res.time_t > r0.time_t


def _tiny_segments(accel, n=40, d=0.5):
    lines = [f"M204 S{accel}", "G1 F6000"]
    lines += [f"G1 X{d * i:.3f}" for i in range(1, n + 1)]
    return "\n".join(lines) + "\n"


def test_marlin_buffer_throttles_tiny_segments(tmp_path):
    # 40 collinear 0.5 mm segments at 100 mm/s, B=16 -> 15 blocks in the buffer.  When a
    # block starts, its exit must allow a stop (0.05 mm/s) at the end of the 14 blocks
    # after it: v^2 <= 0.05^2 + 2 a (14 * 0.5) = 0.0025 + 14 a.
    # a=500: junction speeds^2 settle at 7000.0025 -> 83.666 mm/s.  The JD small-segment
    # cap d a / 0.0328436 (Marlin's fast acos of a straight line) = 7611.8 does not bind.
    # Blocks 1..14 accelerate 0 -> sqrt(7000) over 7 mm (t = sqrt(7000)/500 = 0.167332 s).
    # Blocks 15..26 enter and leave at ~sqrt(7000) but each one, being a trapezoid of its
    # own, accelerates over its first half and brakes over the second:
    # peak^2 = (e + x + 2 a d)/2 = 7000.0025 + 250 -> 85.147 mm/s (the sawtooth of a short
    # buffer), t = 2 (sqrt(7250) - sqrt(7000))/500 = 0.0059237 s each.  Blocks 27..40
    # decelerate to Marlin's final MINIMUM_PLANNER_SPEED 0.05 mm/s in
    # (sqrt(7000) - 0.05)/500 = 0.167232 s.  Total 0.167332 + 0.071085 + 0.167232 = 0.405649 s.
    res, recs = run(tmp_path, _tiny_segments(500), marlin())
    assert res.peak_v == approx(math.sqrt(7250.0025), rel=1e-6)
    assert max(r.end_v for r in recs) == approx(math.sqrt(7000.0025), rel=1e-6)
    v, vp = math.sqrt(7000.0), math.sqrt(7250.0)
    assert res.time_t == approx(v / 500 + 12 * 2 * (vp - v) / 500 + (v - 0.05) / 500, rel=1e-5)
    # a=20000: 14 a = 280000 >> 100^2, so the buffer does not bind: peak 100.
    res2, _ = run(tmp_path, _tiny_segments(20000), marlin())
    assert res2.peak_v == approx(100.0)
    # Klipper, full lookahead, a=500: v^2 = a * 20 mm = 10000 -> reaches 100 at the middle
    # and the whole 20 mm is a triangle: t = 2 sqrt(20/500) = 0.4 s.
    rk, _ = run(tmp_path, _tiny_segments(500), klipper())
    assert rk.peak_v == approx(100.0)
    assert rk.time_t == approx(0.4)
    assert res.time_t > rk.time_t


def test_marlin_min_segment_time_counts(tmp_path):
    # 0.5 mm at 100 mm/s = 5 ms nominal < 20 ms: all 40 blocks are short; counted, not slowed
    res, _ = run(tmp_path, _tiny_segments(20000), marlin(min_segment_time_t=0.02))
    assert res.short_segments == 40
    res0, _ = run(tmp_path, _tiny_segments(20000), marlin(min_segment_time_t=0.0))
    assert res0.time_t == approx(res.time_t)


def jerk_profile(**kw):
    return marlin(flavour="marlin-legacy", junction="jerk", jerk_xy_v=8.0, **kw)


def test_classic_jerk_corner(tmp_path):
    # Marlin 1.1 jerk, 90 deg X then Y at 100 mm/s, jerk 8: X exit 100 vs entry 0 -> jerk
    # 100 > 8, factor 0.08; Y then changes by 100*0.08 = 8 <= 8.  v_junction = 100*0.08 = 8;
    # both safe speeds are 8 (> 0.99*8): Marlin uses safe_speed = 8 anyway.
    res, recs = run(tmp_path, "G1 X10 F6000\nG1 Y10\n", jerk_profile())
    assert recs[0].end_v == approx(8.0)
    # classic jerk starts from rest at the safe speed (X axis jumps 0 -> 8)
    assert recs[0].start_v == approx(8.0)
    # 45 deg turn: X changes by 100(1 - 1/sqrt2) = 29.29 -> factor 8/29.29; then Y changes by
    # 70.71 * that = 19.31 > 8 -> factor *= 8/19.31: overall 8/70.71 -> v = 8 sqrt2 = 11.3137;
    # safe speeds 8 < 0.99 * 11.31, so the jerk value stands.
    res, recs = run(tmp_path, "G1 X10 F6000\nG1 X20 Y10\n", jerk_profile())
    assert recs[0].end_v == approx(8.0 * math.sqrt(2.0))
    # collinear, 100 then 50 mm/s: min of the nominal speeds, no axis jerk -> 50
    res, recs = run(tmp_path, "G1 X50 F6000\nG1 X100 F3000\n", jerk_profile())
    assert recs[0].end_v == approx(50.0)


def test_arc_full_circle_chords(tmp_path):
    # G2 full circle R=10 from (0,0) around (10,0) at 50 mm/s: length 20 pi = 62.83 mm,
    # arc_segment_d=1 -> n = floor(62.83) = 62 chords of d = 2R sin(pi/62), turning by
    # alpha = 2 pi/62 at each of the 61 internal junctions.  Klipper limits at those
    # junctions: R_jd jd a = 25 cos(a/2)/(1-cos(a/2)) ~ 8066 and 0.25 cot(a/2) 2 d a >> 2500,
    # so with a = 1e6 (accel distance 1.25 um) the speed is 50 everywhere.
    # time = 62 d / v + v / a (the accel/decel halves cost v/2a each).
    # normal term per junction = (2 v sin(alpha/2))^2 / (d/v) = (v d/R)^2 v/d = v^3 d/R^2
    # = centripetal (v^2/R)^2 * (d/v): total 61 v^3 d / R^2 (the first/last chords are
    # 1e-3 longer in time, hence rel 2e-3).
    prof = klipper(default_accel_a=1e6, arc_segment_d=1.0)
    res, recs = run(tmp_path, "G1 F3000\nG2 X0 Y0 I10 J0\n", prof)
    R, v, n = 10.0, 50.0, 62
    d = 2 * R * math.sin(math.pi / n)
    assert len(recs) == 1 and recs[0].idx == 1
    assert res.n_blocks == n
    assert res.time_t == approx(n * d / v + v / 1e6, rel=1e-6)
    normal = res.int_a2 - res.int_a2_t
    assert normal == approx((n - 1) * (v * v / R) ** 2 * d / v, rel=2e-3)
    # internal junctions: the whole normal part is in the line's own int_a2
    assert recs[0].int_a2_j == 0.0
    assert recs[0].int_a2 == approx(res.int_a2)
    assert recs[0].peak_a == approx(1e6)       # the tangential accel phases dominate


def test_g4_dwell_adds_time(tmp_path):
    # two 10 mm rest-to-rest moves at 100 mm/s, a=1000: 0.2 s each; G4 P500 = 0.5 s
    res, recs = run(tmp_path, "G1 X10 F6000\nG4 P500\nG1 X20\n", klipper())
    assert res.time_t == approx(0.9)
    assert res.barrier_dwell_t == approx(0.5)
    assert res.full_stops == 0                # forced by the barrier, not counted
    assert recs[0].end_v == approx(0.0)


def test_eonly_move_stops(tmp_path):
    # collinear moves with a retraction between: the planner must stop (no "full stop"
    # counted, it is forced).  Retract 1 mm at 35 mm/s, retract accel 1500:
    # 35^2 = 1225 <= a d = 1500 -> t = d/v + v/a = 1/35 + 35/1500 = 0.0519048 s.
    res, recs = run(tmp_path, "G1 X10 F6000\nG1 E-1 F2100\nG1 X20 F6000\n", klipper())
    assert [r.idx for r in recs] == [0, 1, 2]
    assert recs[0].end_v == approx(0.0) and recs[2].start_v == 0.0
    assert recs[1].time_t == approx(1 / 35 + 35 / 1500)
    assert recs[1].int_a2 == 0.0
    assert res.time_t == approx(0.4 + 1 / 35 + 35 / 1500)
    assert res.full_stops == 0


def test_full_stop_count(tmp_path):
    # X0->10 (line 1), back to 0 (line 2, reversal: stop), corner to Y10 (line 3, 5 mm/s),
    # back to 0,0 (line 4, reversal: stop) -> 2 planned full stops at lines 2 and 4.
    text = "G1 X10 F6000\nG1 X0\nG1 Y10\nG1 Y0\n"
    res, _ = run(tmp_path, text, klipper())
    assert res.full_stops == 2 and res.stop_lines == [2, 4]


def test_klipper_lazy_flush_matches_full_queue(tmp_path, monkeypatch):
    # committing in chunks (Klipper's lazy flush) must give the same plan as one big queue
    rnd = random.Random(7)
    lines, x, y = [], 0.0, 0.0
    for i in range(600):
        if i % 37 == 0:
            lines.append(f"M204 S{rnd.choice([500, 1500, 4000])}")
        x += rnd.uniform(-3, 3) if rnd.random() < 0.7 else rnd.uniform(-40, 40)
        y += rnd.uniform(-3, 3)
        lines.append(f"G1 X{x:.3f} Y{y:.3f} F{rnd.choice([1800, 6000, 12000])}")
    text = "\n".join(lines) + "\n"
    for mcr in (0.0, 0.5):
        prof = klipper(minimum_cruise_ratio_r=mcr)
        monkeypatch.setattr(simmod, "KLIPPER_CHUNK", 10 ** 9)
        big, rb = run(tmp_path, text, prof)
        monkeypatch.setattr(simmod, "KLIPPER_CHUNK", 3)
        small, rs = run(tmp_path, text, prof)
        assert small.time_t == approx(big.time_t, rel=1e-12)
        for a, b in zip(rb, rs):
            assert (a.start_v, a.end_v, a.peak_v) == (b.start_v, b.end_v, b.peak_v)
        # continuity: each line starts at the speed the previous one ended
        for a, b in zip(rs, rs[1:]):
            assert b.start_v == approx(a.end_v, abs=1e-9)


def test_line_records_add_up(tmp_path):
    text = "G1 X10 F6000\nG1 X20 Y5\nG2 X30 Y5 I5 J0\nG1 E-1\nG1 X0 Y0\nG4 S1\nG1 X5\n"
    res, recs = run(tmp_path, text, klipper(minimum_cruise_ratio_r=0.5))
    assert sum(r.time_t for r in recs) + res.barrier_dwell_t == approx(res.time_t)
    assert sum(r.int_a2 + r.int_a2_j for r in recs) == approx(res.int_a2)
    assert sum(r.int_v2 for r in recs) == approx(res.int_v2)
    assert [r.idx for r in recs] == sorted(r.idx for r in recs)
    assert res.as_dict()["n_moves"] == 6


def test_klipper_m204_is_not_capped_by_max_accel(tmp_path):
    # Klipper's M204 S sets the toolhead's max_accel itself: 6000 on a 3000 printer is 6000.
    # 100 mm at 100 mm/s rest to rest: t = d/v + v/a = 1 + 100/6000.
    # Marlin caps the accel in force by the per-axis maximum (M201 / max_accel_a): a = 3000,
    # and brakes to its MINIMUM_PLANNER_SPEED 0.05 mm/s: accel 100/3000 s over 10000/6000 mm,
    # decel 99.95/3000 s over (10000 - 0.0025)/6000 mm, the rest cruised at 100 mm/s.
    text = "M204 S6000\nG1 X100 F6000\n"
    res, _ = run(tmp_path, text, klipper(max_accel_a=3000.0))
    assert res.time_t == approx(1.0 + 100.0 / 6000.0)
    res, _ = run(tmp_path, text, marlin(max_accel_a=3000.0))
    cruise_d = 100.0 - 10000.0 / 6000.0 - (10000.0 - 0.0025) / 6000.0
    assert res.time_t == approx(100.0 / 3000.0 + cruise_d / 100.0 + 99.95 / 3000.0)


def test_klipper_z_scales_accel_and_speed(tmp_path):
    # cartesian check_move: a move with Z gets accel <= max_z_accel * d/|dz| and speed <=
    # max_z_velocity * d/|dz|.  X30 Z40: d = 50, d/|dz| = 1.25.  max_z_accel 100 -> 125;
    # asked 10 mm/s (max_z_velocity 1000 does not bind): t = 50/10 + 10/125 = 5.08 s.
    prof = klipper(max_z_accel_a=100.0, max_z_velocity_v=1000.0)
    res, _ = run(tmp_path, "G1 X30 Z40 F600\n", prof)
    assert res.time_t == approx(5.08)
    # max_z_velocity 4 -> speed cap 5 mm/s: t = 50/5 + 5/125 = 10.04 s
    res, _ = run(tmp_path, "G1 X30 Z40 F600\n", klipper(max_z_accel_a=100.0, max_z_velocity_v=4.0))
    assert res.time_t == approx(10.04)


def test_arc_chord_count_is_bounded():
    # firmware rule floor(length / segment), at least 1 ...
    assert simmod.arc_chords(20 * math.pi, 2 * math.pi, 1.0) == 62
    assert simmod.arc_chords(0.4, 0.1, 1.0) == 1
    # ... but never more than ceil(|sweep| / 1 mrad): 6284 a turn, 1571 a quarter
    assert simmod.arc_chords(2 * math.pi * 1e5, 2 * math.pi, 1.0) == 6284
    assert simmod.arc_chords(2 * math.pi * 1e5, -math.pi / 2, 1.0) == 1571
    assert simmod.arc_chords(20 * math.pi, 2 * math.pi, 1e-9) == 6284
    assert simmod.arc_chords(float("nan"), float("nan"), 1.0) == 6284
    assert simmod.arc_chords(float("inf"), 2 * math.pi, 1.0) == 6284


def test_huge_arc_is_played_in_bounded_time(tmp_path):
    # A full circle of radius 1e5 mm (the largest the reader takes) at 100 mm/s, a = 1e6:
    # a firmware would cut 628 318 chords; the model cuts 6284, each turning by 1 mrad:
    # Klipper's corner limit there is ~1.8 scv / 1e-3 = 9100 mm/s and the centripetal one
    # sqrt(r a) >> 100, so the speed is 100 throughout: t = n 2 r sin(pi/n) / v + v/a.
    n, r, v = 6284, 1e5, 100.0
    res, _ = run(tmp_path, "G1 F6000\nG2 X0 Y0 I100000 J0\n", klipper(default_accel_a=1e6))
    assert res.n_blocks == n
    assert res.time_t == approx(n * 2 * r * math.sin(math.pi / n) / v + v / 1e6, rel=1e-9)


def test_bounded_arc_cut_agrees_with_firmware_cut(tmp_path, monkeypatch):
    # Quarter arc of radius 2000 mm at 150 mm/s, a = 3000, then a line: the firmware's
    # 3141 chords of 1 mm against the model's 1571 of 2 mm.  Same time and int a^2 to
    # (chord turn)^2 / 24 ~ 4e-8 (the chords' length), so within 1e-6.
    text = "G1 X0 Y0 F9000\nG2 X2000 Y2000 I2000 J0\nG1 X2100 Y2000\n"
    prof = klipper(default_accel_a=3000.0, minimum_cruise_ratio_r=0.5)
    res, _ = run(tmp_path, text, prof)
    assert res.n_blocks == 1571 + 1
    monkeypatch.setattr(simmod, "ARC_MIN_TURN", 1e-12)
    fw, _ = run(tmp_path, text, prof)
    assert fw.n_blocks == 3141 + 1
    assert res.time_t == approx(fw.time_t, rel=1e-6)
    assert res.int_a2_t == approx(fw.int_a2_t, rel=1e-6)
