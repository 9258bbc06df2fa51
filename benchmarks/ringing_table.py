"""Issue 10's table: ringing of the bundled samples, original vs processed, with and without
Klipper's MZV input shaper, from the exact resonance model (gcode_opt/ringing.py).

    python benchmarks/ringing_table.py [--freq 50] [--damping 0.1] [--keep DIR]

Each sample is processed with `python -m gcode_opt process IN -o OUT --profile P` (default
options and `--features all`, the README's profile for the sample); every file (original and
outputs) is played by the firmware model and run through a damped oscillator per axis at
--freq Hz (both axes), damping ratio --damping.  Figures: RMS of the XY ringing vector (um),
its ramp / corner / gentle-turn parts, the larger axis' peak, the print time, and for the
shaped rows the shaper's path smoothing (RMS / max um).  "MZV 20 % low" is tuned at 0.8 f.

    python benchmarks/ringing_table.py --corners 0.02 [--only prusa_mk3s_rectilinear]

adds rows "corners": the pipeline run in this process with gcode_opt/corners.py wired in
as a PROTOTYPE (monkeypatched here, not in the package): after plan_inputs the strokes' end
speeds are lowered at sharp corners (budget: that fraction of the strokes' time), and a
slowed end gets a lead-in / lead-out segment whose feed is the corner speed (otherwise the
firmware keeps its own junction speed).  What the firmware model then plays is measured.
"""
from __future__ import annotations

import argparse
import dataclasses
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from gcode_opt import ringing  # noqa: E402
from gcode_opt.profile import load_profile  # noqa: E402

SAMPLES = (("prusa_mk3s_rectilinear", "prusa-mk3s"), ("prusa_gyroid", "prusa-mk3s"),
           ("prusa_klipper", "voron24"), ("cura_box", "ender3"))
MODES = (("original", None), ("default", []), ("--features all", ["--features", "all"]))
_FW_ENDS = {}            # id(stroke) -> the firmware's own (v0, v1), for the prototype


def corner_prototype(budget_r, budget_t=None):
    """(plan_inputs, finish): the pipeline's plan_inputs and segments._finish with
    corners.end_speeds wired in (see the module docstring); install with
    _install_corner_prototype or a test's monkeypatch."""
    import numpy as np

    from gcode_opt import corners, schedule, segments as sg
    from gcode_opt.plan import input_faults

    plain_inputs = schedule.plan_inputs
    plain_finish = sg._finish

    def plan_inputs(strokes, profile, opts):
        pin = plain_inputs(strokes, profile, opts)
        bt = budget_t if budget_t is not None else budget_r * float(np.nansum(pin.T_orig))
        v0n, v1n = corners.end_speeds(strokes, pin, profile, opts, budget_t=bt)
        for st, a, b in zip(strokes, v0n, v1n):
            _FW_ENDS[id(st)] = (st.v0, st.v1)
            st.v0, st.v1 = float(a), float(b)
        pin.v0, pin.v1 = v0n, v1n
        fault = input_faults(pin)
        pin.fault = np.where(pin.fault != "", pin.fault, fault).astype(object)
        return pin

    def finish(stroke, sk, vk, rules):
        fw0, fw1 = _FW_ENDS.get(id(stroke), (stroke.v0, stroke.v1))
        slow0, slow1 = stroke.v0 < fw0 - 1e-6, stroke.v1 < fw1 - 1e-6
        if not (slow0 or slow1):
            return plain_finish(stroke, sk, vk, rules)
        # a lead-in / lead-out at the corner speed, its feed that speed: the firmware's
        # junction may not exceed the nominal speed of the block on either side
        e0 = min(sg.EDGE_D, max(stroke.v0 * sg.EDGE_T, 0.05)) if slow0 else 0.0
        e1 = min(sg.EDGE_D, max(stroke.v1 * sg.EDGE_T, 0.05)) if slow1 else 0.0
        e0 = e0 if sk[1] > 2.5 * e0 else 0.0
        e1 = e1 if sk[-1] - sk[-2] > 2.5 * e1 else 0.0
        sk, vk = sg.with_edges(sk, vk, e0, e1)
        plan = plain_finish(stroke, sk, vk, rules)
        if plan is None:
            return None
        feed = plan.feed.copy()
        if e0:
            feed[0] = max(stroke.v0, sg.MIN_FEED_V)
        if e1:
            feed[-1] = max(stroke.v1, sg.MIN_FEED_V)
        return sg.SegmentPlan(plan.s, plan.v, plan.accel, feed, plan.time_t, plan.int_a2, plan.shape)

    return plan_inputs, finish


def _install_corner_prototype(budget_r, budget_t=None):
    from gcode_opt import pipeline, segments as sg
    pipeline.plan_inputs, sg._finish = corner_prototype(budget_r, budget_t)


def process_here(src, out, prof_name, slowdown_r, features_all):
    """The pipeline in this process (the corner prototype installed)."""
    from gcode_opt import features as feat
    from gcode_opt.pipeline import Options, process as run
    sel = feat.parse_feature_list("all") if features_all else feat.default_selection(src)[0]
    return run(src, out, load_profile(prof_name), Options(max_slowdown_r=slowdown_r, features=sel))


def process(src, out, prof, extra):
    subprocess.run([sys.executable, "-m", "gcode_opt", "process", src, "-o", out, "--profile", prof,
                    "-q", *extra], cwd=ROOT, check=True, stderr=subprocess.DEVNULL)


def measure(path, profile):
    """{row: figures} for one file: no shaper, MZV at f, MZV at 0.8 f."""
    tr = ringing.trace(path, profile)
    model = ringing.model_of(profile)
    low = dict(model, shaper_freq_x_hz=0.8 * model["freq_x_hz"], shaper_freq_y_hz=0.8 * model["freq_y_hz"])
    return {"none": ringing.figures_of_trace(tr, model, "none"),
            "mzv": ringing.figures_of_trace(tr, model, "mzv"),
            "mzv_low": ringing.figures_of_trace(tr, low, "mzv")}


def fmt_row(sample, mode, shaper, f, base):
    xy = f["xy"]
    ratio = xy["rms_um"] / base["xy"]["rms_um"]
    pk = xy["peak_um"] / base["xy"]["peak_um"]
    sm = f.get("smoothing")
    smt = f"{sm['rms_um']:.1f} / {sm['max_um']:.0f}" if sm else "0"
    return (f"| {sample} | {mode} | {shaper} | {xy['rms_um']:.2f} ({ratio:.2f}) | "
            f"{xy['rms_ramp_um']:.2f} / {xy['rms_corner_um']:.2f} / {xy['rms_turn_um']:.2f} | "
            f"{xy['peak_um']:.1f} ({pk:.2f}) | {f['time_s']:.0f} | {smt} |")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--freq", type=float, default=50.0, help="resonance of both axes, Hz")
    ap.add_argument("--damping", type=float, default=0.1, help="damping ratio")
    ap.add_argument("--keep", help="write the processed files here (default: a temporary folder)")
    ap.add_argument("--corners", default="0",
                    help="also the corner prototype, spending this fraction of the strokes' time; "
                         "'auto': the corners' share of the original's ringing energy times the "
                         "--slowdown budget (corners.corner_share)")
    ap.add_argument("--slowdown", type=float, default=0.03,
                    help="the corner rows' print-time budget (Options.max_slowdown_r; default 0.03)")
    ap.add_argument("--only", help="one sample (name without .gcode)")
    ap.add_argument("--corner-features", choices=("default", "all"), default="default",
                    help="features the corner rows re-time")
    a = ap.parse_args(argv)
    modes = MODES
    if a.corners != "0":
        modes = MODES + ((f"corners {a.corners}, budget {a.slowdown:g}, {a.corner_features}", "corners"),)
    print(f"Resonance {a.freq:g} Hz both axes, damping {a.damping:g}. Ratios in brackets are to the "
          "original without shaper.\n")
    print("| sample | file | shaper | RMS ringing um (/ original) | ramp / corner / turn um | "
          "peak um (/ original) | time s | smoothing RMS / max um |")
    print("|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        out_dir = a.keep or tmp
        for name, prof_name in SAMPLES:
            if a.only and name != a.only:
                continue
            prof = dataclasses.replace(load_profile(prof_name), freq_x_hz=a.freq, freq_y_hz=a.freq,
                                       damping_r=a.damping, shaper_freq_x_hz=a.freq,
                                       shaper_freq_y_hz=a.freq)
            src = os.path.join(ROOT, "sample_gcode", name + ".gcode")
            base = None
            for mode, extra in modes:
                path = src
                if extra == "corners":
                    if a.corners == "auto":
                        from gcode_opt.corners import corner_share
                        tr0 = ringing.trace(src, prof)
                        share = corner_share(ringing.figures_of_trace(tr0, ringing.model_of(prof), "none"))
                        _install_corner_prototype(0.0, share * a.slowdown * tr0.sim.time_t)
                    else:
                        _install_corner_prototype(float(a.corners))
                    path = os.path.join(out_dir, f"{name}.corners.gcode")
                    process_here(src, path, prof_name, a.slowdown, a.corner_features == "all")
                elif extra is not None:
                    path = os.path.join(out_dir, f"{name}.{'all' if extra else 'def'}.gcode")
                    process(src, path, prof_name, extra)
                figs = measure(path, prof)
                if base is None:
                    base = figs["none"]
                for shaper, label in (("none", "none"), ("mzv", "MZV at f"), ("mzv_low", "MZV at 0.8 f")):
                    print(fmt_row(name, mode, label, figs[shaper], base), flush=True)


if __name__ == "__main__":
    main()
