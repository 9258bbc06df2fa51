"""Moves the firmware would drop.

Marlin 2 (planner.cpp `if (block->step_event_count < MIN_STEPS_PER_SEGMENT) return false;`,
default 6) and Prusa-Firmware 3.x (`if (block->step_event_count.wide <= dropsegments)`,
dropsegments 5) drop a move of fewer than 6 steps and join its distance with the next
move: a lead-in there does not slow its corner, a lead-out moves the next move's start.
Checked by counting steps the way those planners do (positions rounded to whole steps,
the count = the largest axis' step difference), with the steps/mm from the firmware
sources, not from the profile under test."""
from __future__ import annotations

import dataclasses
import os

import pytest

from gcode_opt import features as feat
from gcode_opt.pipeline import Options, process
from gcode_opt.profile import ProfileError, load_profile, profile_from_dict
from gcode_opt.validate import BlockInvalid, Geometry, validate_block

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLES = os.path.join(ROOT, "sample_gcode")
FIRMWARE_MIN_STEPS = 6
# steps/mm from the firmware sources: Prusa-Firmware variants/MK3S.h {100,100,400,280};
# Creality's Marlin 2 Ender-3 {80,80,400,93}
STEPS = {"prusa-mk3s": (100.0, 280.0), "ender3": (80.0, 93.0)}


def _moves(path):
    """[(inside a gcode-opt block, (x0, y0, e0), (x1, y1, e1))] for every G0/G1/G2/G3 with X or Y."""
    out, x, y, e, rel, inside = [], 0.0, 0.0, 0.0, False, False
    with open(path, encoding="utf-8", errors="replace") as fh:
        for raw in fh:
            if raw.startswith("; gcode-opt begin"):
                inside = True
            elif raw.startswith("; gcode-opt end"):
                inside = False
            code = raw.split(";", 1)[0].split()
            if not code:
                continue
            if code[0] in ("M82", "M83"):
                rel = code[0] == "M83"
                continue
            if code[0] == "G92":
                for w in code[1:]:
                    if w[0] == "E":
                        e = float(w[1:])
                continue
            if code[0] not in ("G0", "G1", "G2", "G3"):
                continue
            w = {t[0]: float(t[1:]) for t in code[1:] if t[0] in "XYE"}
            nx, ny = w.get("X", x), w.get("Y", y)
            ne = e + w["E"] if (rel and "E" in w) else w.get("E", e)
            if "X" in w or "Y" in w:
                out.append((inside, (x, y, e), (nx, ny, ne)))
            x, y, e = nx, ny, ne
    return out


def _steps(a, b, spm_xy, spm_e):
    return max(abs(round(b[0] * spm_xy) - round(a[0] * spm_xy)), abs(round(b[1] * spm_xy) - round(a[1] * spm_xy)),
               abs(round(b[2] * spm_e) - round(a[2] * spm_e)))


def _dropped_in_blocks(src, out, spm_xy, spm_e):
    """Moves inside gcode-opt blocks the firmware would drop, not counting a move the
    original has itself (same end points: the firmware treats both files alike)."""
    own = {(round(a[0], 3), round(a[1], 3), round(b[0], 3), round(b[1], 3)) for _, a, b in _moves(src)}
    bad = []
    for inside, a, b in _moves(out):
        if inside and _steps(a, b, spm_xy, spm_e) < FIRMWARE_MIN_STEPS:
            if (round(a[0], 3), round(a[1], 3), round(b[0], 3), round(b[1], 3)) not in own:
                bad.append((a, b))
    return bad


def test_min_move_d_by_flavour_and_override():
    mk3s, voron = load_profile("prusa-mk3s"), load_profile("voron24")
    assert mk3s.min_move_d == pytest.approx(7 / 100.0)      # 6 steps + 1 of margin at 100 steps/mm
    assert voron.min_move_d == 0.0                            # Klipper queues any move
    marlin = dataclasses.replace(voron, flavour="marlin2", min_move_steps=-1)   # -1: the flavour's rule
    assert marlin.min_move_d == pytest.approx(7 / marlin.steps_per_mm_xy)
    assert dataclasses.replace(marlin, min_move_steps=0).min_move_d == 0.0


def test_profile_schema_rejects_bad_steps():
    base = {"name": "x", "firmware": {"flavour": "marlin2", "junction": "jd", "junction_deviation_d": 0.02,
                                      "steps_per_mm_xy": -5.0},
            "limits": {"max_velocity_v": 200.0, "max_accel_a": 1000.0}}
    with pytest.raises(ProfileError, match="steps_per_mm_xy"):
        profile_from_dict(base, "x")


def test_validator_rejects_a_move_the_firmware_drops():
    geom = Geometry([(0.0, 0.0), (10.0, 0.0)])
    block = ("; gcode-opt begin: replaces 1 lines, kind=line, 3 segments\n"
             "G1 X0.05 Y0 E0.002 F300\nG1 X9.95 Y0 E0.4 F3000\nG1 X10 Y0 E0.002 F300\n; gcode-opt end")
    validate_block(block, "marlin2", 1000.0, geom)                    # no rule: accepted
    validate_block(block, "marlin2", 1000.0, geom, min_move_d=0.04)   # 0.05 mm is enough
    with pytest.raises(BlockInvalid, match="shorter than the firmware keeps"):
        validate_block(block, "marlin2", 1000.0, geom, min_move_d=0.0875)


def test_validator_lets_the_originals_own_short_move_pass():
    geom = Geometry([(0.0, 0.0), (0.03, 0.0), (5.0, 0.0)])           # the original has a 0.03 mm move
    block = ("; gcode-opt begin: replaces 2 lines, kind=curve, 2 segments\n"
             "G1 X0.03 Y0 E0.001 F300\nG1 X5 Y0 E0.2 F3000\n; gcode-opt end")
    validate_block(block, "marlin2", 1000.0, geom, min_move_d=0.0875)


@pytest.mark.parametrize("sample,profile,extra", [
    ("cura_box", "ender3", {}),                                        # Marlin 2 JD: corner lead-ins
    ("prusa_mk3s_rectilinear", "prusa-mk3s", {"corner_budget_r": 1.0}),  # slower corners, M205
    ("prusa_gyroid", "ender3", {"corner_budget_r": 0.5}),   # laws ramping into stops, JD lead-ins
])
def test_no_written_move_is_dropped_by_the_firmware(tmp_path, sample, profile, extra):
    src = os.path.join(SAMPLES, sample + ".gcode")
    out = str(tmp_path / "out.gcode")
    prof = load_profile(profile)
    opts = Options(max_slowdown_r=0.05, features=feat.parse_feature_list("all"))
    for k, v in extra.items():
        setattr(opts, k, v)
    summary = process(src, out, prof, opts)
    assert sum(k["retimed"] for k in summary["retimed_strokes"]["by_kind"].values()) > 100
    spm_xy, spm_e = STEPS[profile]
    bad = _dropped_in_blocks(src, out, spm_xy, spm_e)
    assert not bad, f"{len(bad)} written moves under {FIRMWARE_MIN_STEPS} steps, e.g. {bad[:3]}"
