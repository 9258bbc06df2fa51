"""Issue 10's table: ringing of the bundled samples, original vs processed, with and without
Klipper's MZV input shaper, from the exact resonance model (gcode_opt/ringing.py).

    python benchmarks/ringing_table.py [--freq 50] [--damping 0.1] [--keep DIR]

Each sample is processed with `python -m gcode_opt process IN -o OUT --profile P` (default
options and `--features all`, the README's profile for the sample); every file (original and
outputs) is played by the firmware model and run through a damped oscillator per axis at
--freq Hz (both axes), damping ratio --damping.  Figures: RMS of the XY ringing vector (um),
its ramp / corner / gentle-turn parts, the larger axis' peak, the print time, and for the
shaped rows the shaper's path smoothing (RMS / max um).  "MZV 20 % low" is tuned at 0.8 f.

    python benchmarks/ringing_table.py --corners 0.7 --slowdown 0.05 [--corner-features all]

adds rows "corners": the pipeline run in this process with slower corners
(Options.corner_budget_r, the CLI's --corners: that share of the --max-slowdown budget may
go to lower end speeds of line strokes at sharp corners, gcode_opt/corners.py).  What the
firmware model then plays is measured.
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
           ("prusa_klipper", "voron24"), ("cura_box", "ender3"), ("prusa_gyroid_fullspeed_klipper", "voron24"))
MODES = (("original", None), ("default", []), ("--features all", ["--features", "all"]))


def process_here(src, out, prof_name, slowdown_r, features_all, corner_budget_r):
    """The pipeline in this process with slower corners (Options.corner_budget_r; the
    option is set as an attribute so that an Options without the keyword works too)."""
    from gcode_opt import features as feat
    from gcode_opt.pipeline import Options, process as run
    sel = feat.parse_feature_list("all") if features_all else feat.default_selection(src)[0]
    opts = Options(max_slowdown_r=slowdown_r, features=sel)
    opts.corner_budget_r = corner_budget_r
    return run(src, out, load_profile(prof_name), opts)


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
                    help="also rows with slower corners: this share of the --slowdown budget "
                         "(Options.corner_budget_r); 'auto': the corners' share of the original's "
                         "ringing energy (corners.corner_share)")
    ap.add_argument("--slowdown", type=float, default=0.03,
                    help="the corner rows' print-time budget (Options.max_slowdown_r; default 0.03)")
    ap.add_argument("--only", help="one sample (name without .gcode)")
    ap.add_argument("--corner-features", choices=("default", "all"), default="default",
                    help="features the corner rows re-time")
    a = ap.parse_args(argv)
    modes = MODES
    if a.corners != "0":
        same = ["--max-slowdown", repr(a.slowdown)] + (["--features", "all"] if a.corner_features == "all" else [])
        modes = MODES + ((f"no corners, budget {a.slowdown:g}, {a.corner_features}", same),
                         (f"corners {a.corners}, budget {a.slowdown:g}, {a.corner_features}", "corners"))
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
                    r = a.corners
                    if r == "auto":
                        from gcode_opt.corners import corner_share
                        tr0 = ringing.trace(src, prof)
                        r = corner_share(ringing.figures_of_trace(tr0, ringing.model_of(prof), "none"))
                    path = os.path.join(out_dir, f"{name}.corners.gcode")
                    process_here(src, path, prof_name, a.slowdown, a.corner_features == "all", float(r))
                elif extra is not None:
                    path = os.path.join(out_dir, f"{name}.{len(extra)}.gcode")
                    process(src, path, prof_name, extra)
                figs = measure(path, prof)
                if base is None:
                    base = figs["none"]
                for shaper, label in (("none", "none"), ("mzv", "MZV at f"), ("mzv_low", "MZV at 0.8 f")):
                    print(fmt_row(name, mode, label, figs[shaper], base), flush=True)


if __name__ == "__main__":
    main()
