"""Command line: `gcode-opt process|simulate|profiles ...`  (`gcode-opt -h` teaches)."""
from __future__ import annotations

import argparse
import json
import os
import sys

from . import __version__
from . import features as feat

EPILOG = """\
examples:
  gcode-opt process part.gcode -o part.opt.gcode --profile prusa-mk3s
  gcode-opt process part.gcode --profile voron24 --json summary.json      (rewrites part.gcode in place)
  gcode-opt simulate part.gcode --profile prusa-mk3s
  gcode-opt profiles

as a slicer post-processing script (PrusaSlicer, SuperSlicer, OrcaSlicer, Bambu Studio:
Print Settings > Output options > Post-processing scripts), one line:
  /path/to/gcode-opt process --profile prusa-mk3s
the slicer appends the file's path and expects the file changed in place.
"""

PROCESS_HELP = """\
Re-time the straight infill strokes of a sliced file with the law of motion that
minimises J = m/2 int|v|^2 dt + alpha m^2/2 int|a|^2 dt, written as short segments that
carry their own feedrate and acceleration so the firmware follows the law.  Toolpath,
filament and every other line are unchanged.  Without -o the file is rewritten in place
(atomically: on any error the input is left untouched)."""


def _alpha(text):
    if text == "auto":
        return "auto"
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError("expected 'auto' or a number in s^2/kg")
    if v <= 0:
        raise argparse.ArgumentTypeError("alpha must be > 0 (s^2/kg)")
    return v


def _features(text):
    try:
        return feat.parse_feature_list(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e))


def _fraction(text):
    v = float(text.rstrip("%")) / (100.0 if text.endswith("%") else 1.0)
    if v < 0:
        raise argparse.ArgumentTypeError("must be >= 0")
    return v


def build_parser():
    ap = argparse.ArgumentParser(prog="gcode-opt", description="Re-time the moves of sliced FDM G-code with the "
                                 "energy/inertia-optimal law of motion, checked on a model of the printer's firmware.",
                                 epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--version", action="version", version=f"gcode-opt {__version__}")
    sub = ap.add_subparsers(dest="cmd", metavar="COMMAND")

    p = sub.add_parser("process", help="re-time a G-code file", description=PROCESS_HELP,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("input", metavar="IN.gcode")
    p.add_argument("-o", "--output", metavar="OUT.gcode", help="write here (default: rewrite IN in place)")
    p.add_argument("--profile", default="auto",
                   help="printer profile name (see `gcode-opt profiles`) or a .toml file. 'auto' (default) "
                        "reads the slicer's printer_model / flavour comments and falls back to generic-klipper")
    p.add_argument("--alpha", type=_alpha, default="auto",
                   help="weight of the inertia term, s^2/kg (beta = alpha*m is a time^2: the law's boundary "
                        "layers are sqrt(beta) long). 'auto' (default) picks per stroke the law with the "
                        "least int|a|^2 dt that fits the limits and the time budget")
    p.add_argument("--features", type=_features, default=feat.DEFAULT_SELECTED,
                   help="comma-separated features to re-time (default: sparse_infill,solid_infill; 'all'; "
                        f"choices: {', '.join(feat.ALL)})")
    p.add_argument("--overshoot", type=_fraction, default=0.25,
                   help="how far the law's peak speed may exceed the slicer's F, e.g. 0.25 or 25%% "
                        "(never above the machine's max speed or the hotend's flow limit; default %(default)s)")
    p.add_argument("--max-slowdown", type=_fraction, default=0.03,
                   help="print-time budget the auto law may spend, as a fraction of the whole file's "
                        "print time (default %(default)s = 3%%)")
    p.add_argument("--segments", type=int, default=10,
                   help="most segments per re-timed stroke (also capped by the firmware's segment rate, "
                        "minimum segment time and planner buffer; default %(default)s)")
    p.add_argument("--max-turn", type=float, default=30.0, metavar="DEG",
                   help="a run of G1 lines whose every vertex turns by at most DEG degrees is one smooth curve, "
                        "re-timed as a whole (gyroid, concentric infill); 0 re-times straight runs only "
                        "(default %(default)s)")
    p.add_argument("--min-length", type=float, default=2.0, help="shortest stroke to re-time, mm (default %(default)s)")
    p.add_argument("--json", metavar="SUMMARY.json", help="write the summary (figures from the firmware model) here")
    p.add_argument("--report", metavar="REPORT.html",
                   help="write a self-contained HTML report: before/after figures, plots of the re-timed moves")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar, no summary on stderr")

    s = sub.add_parser("simulate", help="play a file through the firmware model",
                       description="Plan a whole file the way a constant-acceleration lookahead firmware does "
                                   "and report print time, int|a|^2 dt, peak speed and acceleration, full stops.")
    s.add_argument("input", metavar="FILE.gcode")
    s.add_argument("--profile", default="auto", help="as for process (default: auto)")
    s.add_argument("--json", action="store_true", help="print JSON instead of text")

    sub.add_parser("profiles", help="list the bundled printer profiles")
    from .report.commands import register        # report, law, figures
    register(sub)
    return ap


def _load_profile(name, path=None, quiet=False):
    from .profile import load_profile
    if name == "auto":
        from .detect import detect_profile
        name, why = detect_profile(path)
        if not quiet:
            sys.stderr.write(f"gcode-opt: profile {name} ({why}; choose another with --profile)\n")
    return load_profile(name)


def cmd_process(a):
    from .pipeline import Options, Progress, process
    if not os.path.isfile(a.input):
        raise SystemExit(f"gcode-opt: {a.input}: no such file")
    prof = _load_profile(a.profile, a.input, a.quiet)
    out = a.output or a.input
    prog = None if a.quiet else Progress(os.path.getsize(a.input))
    opts = Options(alpha=a.alpha, features=a.features, overshoot_r=a.overshoot, max_slowdown_r=a.max_slowdown,
                   max_segments=a.segments, min_length_d=a.min_length, progress=prog)
    opts.max_turn_deg = a.max_turn

    def write_report_hook(orig, new, summary):        # runs while both files exist
        from .report.html import write_report
        write_report(orig, new, prof, summary, a.report)
    summary = process(a.input, out, prof, opts, before_replace=write_report_hook if a.report else None)
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(summary, fh, indent=1)
    if not a.quiet:
        sys.stderr.write(format_summary(summary) + "\n")
    return 0


def format_summary(s):
    rs = s["retimed_strokes"]
    pt = s["print_time_s"]

    def pct(x):
        return "n/a" if x is None else f"{x * 100:+.1f}%"

    lines = [
        f"gcode-opt: {s['output']} ({s['profile']}, {s['flavour']})",
        f"  strokes re-timed   {s['strokes']['retimed']} of {s['strokes']['candidates']}",
        f"  int|a|^2 dt        {rs['int_a2']['before']:.4g} -> {rs['int_a2']['after']:.4g} mm^2/s^3 on re-timed strokes "
        f"({pct(rs['int_a2']['change'])}); whole file {pct(s['whole_file']['int_a2_change'])}",
        f"  print time         {pt['before']:.1f} s -> {pt['after']:.1f} s ({pct(pt['change'])})",
        f"  firmware vs law    time {pct(rs['firmware_vs_law']['time'])}, int|a|^2 {pct(rs['firmware_vs_law']['int_a2'])}",
        f"  full stops         {s['whole_file']['before']['full_stops']} -> {s['whole_file']['after']['full_stops']}",
    ]
    return "\n".join(lines)


def cmd_simulate(a):
    from .firmware.simulate import simulate_file
    if not os.path.isfile(a.input):
        raise SystemExit(f"gcode-opt: {a.input}: no such file")
    res = simulate_file(a.input, _load_profile(a.profile, a.input, a.json))
    d = res.as_dict()
    if a.json:
        print(json.dumps(d, indent=1))
        return 0
    stops = ", ".join(str(x) for x in d["stop_lines"][:12]) + (" ..." if len(d["stop_lines"]) > 12 else "")
    rows = [("print time", f"{d['time_t']:.1f} s ({d['time_t'] / 60:.1f} min, of which dwell {d['barrier_dwell_t']:.1f} s)"),
            ("int |a|^2 dt", f"{d['int_a2']:.4g} mm^2/s^3 (tangential {d['int_a2_t']:.4g})"),
            ("int |v|^2 dt", f"{d['int_v2']:.4g} mm^2/s"),
            ("peak speed", f"{d['peak_v']:.1f} mm/s"),
            ("peak acceleration", f"{d['peak_a']:.0f} mm/s^2"),
            ("moves / blocks", f"{d['n_moves']} / {d['n_blocks']}"),
            ("corners (> 30 deg)", f"{d['corners']}, sum dv^2 {d['corner_dv2']:.4g} mm^2/s^2"),
            ("full stops", f"{d['full_stops']}" + (f" (lines {stops})" if stops else "")),
            ("short segments", f"{d['short_segments']} (shorter than the firmware's minimum segment time)")]
    for k, v in rows:
        print(f"{k:<20} {v}")
    return 0


def cmd_profiles(a):
    from .profile import load_profile, profile_names
    for n in profile_names():
        p = load_profile(n)
        print(f"{n:<18} {p.flavour:<14} {p.junction:<5} v_max {p.max_velocity_v:g} mm/s, a_max {p.max_accel_a:g} mm/s^2, "
              f"masses {p.moving_mass_x_kg:g}/{p.moving_mass_y_kg:g} kg")
    return 0


def main(argv=None):
    ap = build_parser()
    a = ap.parse_args(argv)
    if not a.cmd:
        ap.print_help()
        return 2
    from .state import GcodeError
    try:
        return a.func(a) if hasattr(a, "func") else {"process": cmd_process, "simulate": cmd_simulate,
                                                      "profiles": cmd_profiles}[a.cmd](a)
    except GcodeError as e:
        sys.stderr.write(f"gcode-opt: {e}\n")
        return 2
    except ValueError as e:
        sys.stderr.write(f"gcode-opt: {e}\n")
        return 2


if __name__ == "__main__":
    sys.exit(main())
