"""Issue 7: one bad stroke never aborts the file.  A stroke whose planning, segmenting or
emission raises, gives a non-finite number or fails the validator keeps its original
lines, counted by reason in the summary; every other stroke is re-timed as before.
Faults are injected by wrapping the real functions so that they fail for ONE stroke."""
import math
import warnings

import numpy as np
import pytest

from gcode_opt import pipeline, schedule
from gcode_opt.emit import accel_command
from gcode_opt.firmware.simulate import simulate_file
from gcode_opt.laws.curve import curvature_from_polyline
from gcode_opt.pipeline import Options, analyse, process
from gcode_opt.profile import load_profile
from gcode_opt.segments import SegmentRules, hold_cruise_accels, plan_segments
from gcode_opt.verify import verify

S = "sample_gcode/"
REG = "tests/regressions/"
SAMPLE = S + "prusa_klipper.gcode"


@pytest.fixture(scope="module")
def baseline(tmp_path_factory):
    dst = tmp_path_factory.mktemp("fi") / "base.gcode"
    s = process(SAMPLE, str(dst), load_profile("voron24"), Options())
    return s


def _unique_lengths(baseline):
    """Lengths of re-timed strokes no other stroke of the sample has (fault targets)."""
    ls = [p["length_mm"] for p in baseline["per_stroke"]]
    return [x for x in ls if sum(_is_victim(y, x) for y in ls) == 1]


def _victim_length(baseline, k=0):
    u = _unique_lengths(baseline)
    return u[(k + 1) * len(u) // 3]


def _is_victim(L, target):
    return abs(L - target) < 5e-5


def _run(tmp_path, prof="voron24", src=SAMPLE, **kw):
    dst = tmp_path / "out.gcode"
    s = process(src, str(dst), load_profile(prof), Options(**kw))
    verify(src, str(dst), load_profile(prof))
    return s, dst


def _check_one_dropped(s, baseline, reason):
    assert s["strokes"]["not_retimed"].get(reason) == 1, s["strokes"]["not_retimed"]
    assert s["strokes"]["faults"] == 1 and baseline["strokes"]["faults"] == 0
    assert s["strokes"]["retimed"] == baseline["strokes"]["retimed"] - 1


def test_planning_exception_drops_only_its_stroke(tmp_path, monkeypatch, baseline):
    target = _victim_length(baseline)
    real = schedule.candidate_pieces

    def flaky(pin, rows, T_orig):
        if any(_is_victim(L, target) for L in pin.L):
            raise FloatingPointError("injected")
        return real(pin, rows, T_orig)

    monkeypatch.setattr(schedule, "candidate_pieces", flaky)
    s, _ = _run(tmp_path)
    _check_one_dropped(s, baseline, "error: planning (FloatingPointError)")


def test_non_finite_candidate_drops_only_its_stroke(tmp_path, monkeypatch, baseline):
    target = _victim_length(baseline)
    from gcode_opt.plan import Candidates, candidates_auto

    def poisoned(pin, rows, T_orig):
        T, beta, I, KE = candidates_auto(pin)
        I = I.copy()
        I[[_is_victim(L, target) for L in pin.L], 3] = np.nan
        return [Candidates.piece(rows, (T, beta, I, KE), T_orig)]

    monkeypatch.setattr(schedule, "candidate_pieces", poisoned)
    s, _ = _run(tmp_path)
    _check_one_dropped(s, baseline, "error: planning (non-finite)")


def test_segment_planner_exception_and_nan_drop_only_their_strokes(tmp_path, monkeypatch, baseline):
    t_raise, t_nan = _victim_length(baseline, 0), _victim_length(baseline, 1)
    real = schedule.plan_segments

    def flaky(sts, T, b, rules):
        if any(_is_victim(st.length_d, t_raise) for st in sts):
            raise ZeroDivisionError("injected")
        out = real(sts, T, b, rules)
        for st, seg in zip(sts, out):
            if seg is not None and _is_victim(st.length_d, t_nan):
                seg.accel = seg.accel.copy()
                seg.accel[1] = np.nan
        return out

    monkeypatch.setattr(schedule, "plan_segments", flaky)
    s, _ = _run(tmp_path)
    nr = s["strokes"]["not_retimed"]
    assert nr.get("error: segments (ZeroDivisionError)") == 1, nr
    assert nr.get("error: segments (non-finite)") == 1, nr
    assert s["strokes"]["retimed"] == baseline["strokes"]["retimed"] - 2
    assert s["strokes"]["faults"] == 2


@pytest.mark.parametrize("bad,reason", [
    ("M204 S0", "validator: M204 value out of range"),
    ("G1 X1e1 Y2", "validator: G1 X not a plain decimal"),
])
def test_block_failing_the_validator_keeps_the_original_lines(tmp_path, monkeypatch, baseline, bad, reason):
    target = _victim_length(baseline)
    real = pipeline._stroke_block

    def corrupt(s, raws, *a):
        text = real(s, raws, *a)
        if _is_victim(s.length_d, target):
            lines = text.split("\n")
            lines.insert(2, bad)
            text = "\n".join(lines)
        return text

    monkeypatch.setattr(pipeline, "_stroke_block", corrupt)
    s, dst = _run(tmp_path)
    _check_one_dropped(s, baseline, reason)
    assert bad not in open(dst).read().split("\n")


def test_emission_exception_keeps_the_original_lines(tmp_path, monkeypatch, baseline):
    target = _victim_length(baseline)
    real = pipeline._stroke_block

    def flaky(s, *a):
        if _is_victim(s.length_d, target):
            raise OverflowError("injected")
        return real(s, *a)

    monkeypatch.setattr(pipeline, "_stroke_block", flaky)
    s, dst = _run(tmp_path)
    _check_one_dropped(s, baseline, "error: emission (OverflowError)")
    # the victim's original text is there, byte for byte, outside any block
    orig = open(SAMPLE).read().split("\n")
    out = open(dst).read()
    assert len(out.split("; gcode-opt begin")) - 1 == s["strokes"]["retimed"]
    victim = [p for p in baseline["per_stroke"] if _is_victim(p["length_mm"], target)]
    assert len(victim) == 1
    first = victim[0]["line"]                    # 1-based, as the summary gives it
    lines = orig[first - 1:first - 1 + victim[0]["lines"]]
    outside = "\n".join(part.split("; gcode-opt end", 1)[-1] for part in out.split("; gcode-opt begin"))
    assert lines and all(line in outside.split("\n") for line in lines)


# ------------------------------------------------------------------ issue 7, root cause 1
def test_kernel_underflow_chain_regression():
    """Reproducer: a 28 mm line then short connectors; the end vertex is > 38 smoothing
    widths from every interior vertex, every raw kernel weight underflowed -> 0/0 -> NaN."""
    pts = [(0, 0), (28, 0), (28.6, 0.2), (29.2, 0.6), (29.8, 1.2)]
    for p in (pts, pts[::-1]):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            pc = curvature_from_polyline(p, smooth_d=0.5)
        assert np.isfinite(pc.kappa_v).all()
        # far from the other vertices, the end takes its nearest vertex's curvature
        assert pc.kappa_v[0] == pytest.approx(pc.kappa_v[1], rel=0.5)
        # turning left (then right when reversed): the sign of the curvature follows
        assert np.sign(pc.kappa_v).tolist() == [np.sign(pc.kappa_v[2])] * len(pc.kappa_v)


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24", "ender3"])
def test_kernel_underflow_file_is_retimed_as_a_curve(tmp_path, prof):
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # no numpy warning reaches the user
        s, _ = _run(tmp_path, prof, REG + "kernel_underflow.gcode")
    assert s["strokes"]["not_retimed"] == {}
    assert [p["kind"] for p in s["per_stroke"]] == ["curve", "line"]


# ------------------------------------------------------------------ issue 7, root cause 2
def test_hold_cruise_accels():
    a = hold_cruise_accels(np.array([0.0, 0.0, 50.0, 0.0, 1e-9, 80.0, 0.0]), 1500.0)
    assert a.tolist() == [50.0, 50.0, 50.0, 50.0, 50.0, 80.0, 80.0]
    assert hold_cruise_accels(np.zeros(3), 1500.0).tolist() == [1500.0] * 3
    assert np.isnan(hold_cruise_accels(np.array([np.nan, 5.0]), 1.0)[0])      # a fault stays a fault


def test_accel_command_refuses_zero_and_non_finite():
    for bad in (0.0, -5.0, math.nan, math.inf):
        with pytest.raises(ValueError):
            accel_command("klipper", bad, True)
    assert accel_command("klipper", 1e-12, True) == "M204 S0.1"      # rounded up, never to 0


def _const_speed_file(tmp_path):
    """A 20 mm infill line between two collinear 20 mm perimeter lines at the same feed:
    it is entered and left at full speed, so its best law is a cruise (every segment's
    ramp acceleration ~ 0)."""
    body = ["G21", "G90", "M83", "M204 S3000", "G1 Z0.2 F720", "G1 X10 Y50 F9000",
            ";TYPE:External perimeter", "G1 X30 Y50 E0.748 F3000",
            ";TYPE:Internal infill", "G1 X50 Y50 E0.748 F3000",
            ";TYPE:External perimeter", "G1 X70 Y50 E0.748 F3000"]
    p = tmp_path / "cruise.gcode"
    p.write_text("\n".join(body) + "\n")
    return str(p)


@pytest.mark.parametrize("prof", ["voron24", "prusa-mk3s", "ender3"])
def test_cruise_segments_carry_a_positive_acceleration_and_follow_the_law(tmp_path, prof):
    """Root cause of `M204 S0`: a constant-speed segment has a_k = |v_k^2 - v_k-1^2|/(2 d) = 0.
    Plan the cruise law of a stroke entered and left at its feed: every written acceleration
    is > 0, and the firmware model playing the block takes the law's time, at no |a|^2."""
    profile = load_profile(prof)
    src = _const_speed_file(tmp_path)
    strokes, _ = analyse(src, profile, Options(min_length_d=0.0))
    st, = strokes
    v = st.v_feed
    assert st.v0 == pytest.approx(v) and st.v1 == pytest.approx(v)     # the firmware model agrees
    T = st.length_d / v
    rules = SegmentRules.for_profile(profile, 10)
    seg, = plan_segments([st], [T], [1e-12], rules)       # beta -> 0: the constant-speed law
    assert seg is not None and len(seg.accel) >= 2
    assert np.all(seg.accel > 0) and np.all(np.isfinite(seg.accel))
    assert schedule.seg_fault(seg) == ""
    lines = open(src).read().split("\n")
    raws = [line + "\n" for line in lines[st.first_idx:st.last_idx + 1]]
    text = pipeline._stroke_block(st, raws, seg, 1e-12, st.x0, st.y0, 0.0, 3000.0, 0.5, profile)
    for line in text.split("\n"):
        if line.startswith("M204"):
            assert float(line.split()[1][1:]) > 0, line
    pipeline._validate(text, st, raws, st.x0, st.y0, 3000.0, profile)
    # the firmware model plays the block between its two cruising neighbours
    out = tmp_path / "played.gcode"
    out.write_text("\n".join(lines[:st.first_idx]) + "\n" + text + "\n".join(lines[st.last_idx + 1:]))
    first, n_block = st.first_idx, text.count("\n")
    t, a2 = [0.0], [0.0]

    def on_line(r):
        if first <= r.idx < first + n_block:
            t[0] += r.time_t
            a2[0] += r.int_a2
    simulate_file(str(out), profile, on_line=on_line)
    assert t[0] == pytest.approx(T, rel=0.01)
    assert a2[0] <= 1e-3 * st.int_a2 + 1e-6      # no ramp inside the block


def _faults(s):
    return {k: v for k, v in s["strokes"]["not_retimed"].items() if k.startswith(("error", "validator"))}


def test_lead_in_never_squeezes_a_ramp_above_the_machine_limit(tmp_path):
    """Reproducer (random arc fuzz): a lead-in at the corner speed shortened the first ramp of
    a 1.4 mm line: 563 mm/s^2 on a 500 mm/s^2 machine (the validator threw the block out)."""
    prof = load_profile("ender3")
    s, dst = _run(tmp_path, "ender3", REG + "leadin_squeezed_ramp.gcode")
    assert _faults(s) == {}
    assert s["strokes"]["retimed"] == 3
    accels = [float(line.split()[1][1:]) for line in open(dst) if line.startswith("M204 ")]
    assert accels and max(accels) <= prof.max_accel_a + 0.1


@pytest.mark.parametrize("prof", ["voron24", "prusa-mk3s", "ender3", "generic-marlin"])
@pytest.mark.parametrize("name", ["kernel_underflow.gcode", "leadin_squeezed_ramp.gcode", "leadin_sliver.gcode",
                                  "firmware_retraction_gyroid.gcode"])
def test_regressions_process_without_faults(tmp_path, prof, name):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s, _ = _run(tmp_path, prof, REG + name)
    assert _faults(s) == {}


def test_fixed_alpha_on_a_real_file_writes_no_m204_s0(tmp_path):
    """Real reproducer: the bundled rectilinear sample, voron24, --alpha 0.001 wrote
    `M204 S0` before the cruise-acceleration fix (real Klipper: "S must be above 0.0")."""
    from klipper_oracle import run_oracle
    prof = load_profile("voron24")
    src = S + "prusa_mk3s_rectilinear.gcode"
    s, dst = _run(tmp_path, "voron24", src, alpha=0.001)
    assert s["strokes"]["retimed"] > 100 and _faults(s) == {}
    accels = [float(line.split()[1][1:]) for line in open(dst) if line.startswith("M204 ")]
    assert min(accels) > 0
    assert run_oracle(str(dst), prof)["errors"] == []


@pytest.mark.parametrize("feats", [("sparse_infill", "solid_infill"), ("all",)])
def test_firmware_retraction_gyroid_real_klipper_accepts(tmp_path, feats):
    """A cut of a real PrusaSlicer gyroid cylinder with firmware retraction (G10/G11):
    re-timed curves, and real Klipper finds no error and no new full stop."""
    from gcode_opt import features as feat
    from klipper_oracle import run_oracle
    prof = load_profile("voron24")
    src = REG + "firmware_retraction_gyroid.gcode"
    s, dst = _run(tmp_path, "voron24", src, features=feat.ALL if feats == ("all",) else feats)
    assert s["retimed_strokes"]["by_kind"]["curve"]["retimed"] >= 5 and _faults(s) == {}
    before, after = run_oracle(src, prof), run_oracle(str(dst), prof)
    assert after["errors"] == []
    assert after["n_internal_full_stops"] <= before["n_internal_full_stops"]


def test_non_finite_stroke_figures_fail_that_stroke_only(tmp_path, monkeypatch, baseline):
    """A NaN in one stroke's original figures (time, |a|^2) must not poison the budget's
    allocation over the whole file."""
    target = _victim_length(baseline)
    real = pipeline.analyse

    def poisoned(path, profile, opts):
        strokes, sim = real(path, profile, opts)
        for st in strokes:
            if _is_victim(st.length_d, target):
                st.time_t = math.nan
        return strokes, sim

    monkeypatch.setattr(pipeline, "analyse", poisoned)
    s, _ = _run(tmp_path)
    _check_one_dropped(s, baseline, "error: non-finite plan input")
    # the time budget (3 %) still holds: a NaN in the allocation had spent +32 %
    assert s["print_time_s"]["change"] <= Options().max_slowdown_r + 0.002
