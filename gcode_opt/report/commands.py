"""Sub-commands `report`, `law`, `figures` (issue 3).  register(sub) adds them to the
CLI; each parser sets `func` to the function that runs it."""
from __future__ import annotations

import argparse
import os
import sys

REPORT_HELP = """\
Compare an original file with its processed version (both already on disk): the firmware
model plays both, every fenced block of the processed file is paired with the original
lines it replaced, and one self-contained HTML page (plots embedded) is written, plus the
same figures as JSON with --json."""

LAW_HELP = """\
Table of the optimal law of motion (minimum J = m/2 int|v|^2 dt + alpha m^2/2 int|a|^2 dt)
along one path: t, x, y, s, speed, tangential/normal/total acceleration -- for a robot
controller to play back.  Give exactly one path.  The weight is beta = alpha*m (s^2):
--beta directly, or --alpha with --mass (default mass 1 kg)."""

LAW_EPILOG = """\
examples:
  gcode-opt law --line 0,1,1,-1 --duration 1 --beta 0.01
  gcode-opt law --circle 0,0,1,0,180 --duration 1 --alpha 0.1 --mass 1 --format json -o semicircle.json
  gcode-opt law --ellipse 1,2 --duration 1 --beta 0.01 --points 201
  gcode-opt law --gcode part.gcode --line-number 1234 --profile prusa-mk3s --beta 0.002"""


def _floats(n_min, n_max=None):
    n_max = n_max or n_min

    def parse(text):
        try:
            vals = [float(x) for x in text.split(",")]
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {n_min} comma-separated numbers")
        if not n_min <= len(vals) <= n_max:
            raise argparse.ArgumentTypeError(f"expected {n_min}" + (f"..{n_max}" if n_max != n_min else "")
                                             + " comma-separated numbers")
        return vals
    return parse


def _positive(text):
    v = float(text)
    if not v > 0:
        raise argparse.ArgumentTypeError("must be > 0")
    return v


def register(sub):
    r = sub.add_parser("report", help="HTML/JSON report comparing an original and a processed file",
                       description=REPORT_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    r.add_argument("original", metavar="ORIGINAL.gcode")
    r.add_argument("processed", metavar="PROCESSED.gcode")
    r.add_argument("--profile", default="auto",
                   help="printer profile, resolved as `process` does: 'auto' (default) reads the original "
                        "file's printer_model / flavour comments and falls back to generic-klipper")
    r.add_argument("-o", "--output", metavar="REPORT.html", help="HTML file (default: PROCESSED.report.html)")
    r.add_argument("--json", metavar="REPORT.json", help="also write the figures as JSON")
    r.add_argument("--summary", metavar="SUMMARY.json",
                   help="the summary `process --json` wrote: adds candidates, skip reasons, the law's figures")
    r.add_argument("--layer", type=int, help="layer to draw from above (default: the one that gained most)")
    r.add_argument("--no-ringing", action="store_true", help="leave out the ringing section")
    r.set_defaults(func=cmd_report)

    g = sub.add_parser("law", help="table of the optimal law of motion along a path (CSV/JSON)",
                       description=LAW_HELP, epilog=LAW_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    path = g.add_mutually_exclusive_group(required=True)
    path.add_argument("--line", type=_floats(4), metavar="X0,Y0,X1,Y1", help="straight line, mm")
    path.add_argument("--circle", type=_floats(5), metavar="CX,CY,R,THETA0,SWEEP",
                      help="circular arc: centre and radius (mm), start angle and signed sweep (deg; + = CCW)")
    path.add_argument("--ellipse", type=_floats(2), metavar="A,B",
                      help="full turn of x = A cos p, y = B sin p from (A, 0), counter-clockwise (mm)")
    path.add_argument("--gcode", metavar="FILE.gcode", help="a stroke of a G-code file (with --line-number)")
    g.add_argument("--line-number", type=int, metavar="N", help="1-based line of the stroke's first move (--gcode)")
    g.add_argument("--profile", default="generic-klipper", help="printer profile for --gcode (default: %(default)s)")
    w = g.add_mutually_exclusive_group()
    w.add_argument("--beta", type=_positive, help="beta = alpha*m, s^2")
    w.add_argument("--alpha", type=_positive, help="alpha, s^2/kg (with --mass)")
    g.add_argument("--mass", type=_positive, help="moving mass, kg (default 1; for --gcode: the profile's along the stroke)")
    g.add_argument("--duration", type=_positive, metavar="T",
                   help="duration, s (default: 1 s; for --gcode: the stroke's time in the firmware model)")
    g.add_argument("--v0", type=float, help="start speed, mm/s (default 0; --gcode: the firmware's)")
    g.add_argument("--v1", type=float, help="end speed, mm/s (default 0; --gcode: the firmware's)")
    g.add_argument("--points", type=int, default=101, help="rows of the table (default %(default)s)")
    g.add_argument("--format", choices=("csv", "json"), default="csv")
    g.add_argument("-o", "--output", metavar="FILE", help="write here (default: stdout)")
    g.set_defaults(func=cmd_law)

    f = sub.add_parser("figures", help="reproduce the paper's Figures 1-7 (PNG) from the verified equations")
    f.add_argument("-o", "--output-dir", default="figures", metavar="DIR", help="folder (default: %(default)s)")
    f.set_defaults(func=cmd_figures)


def cmd_report(a):
    import json

    from ..cli import UserError, _load_profile, check_outputs
    from ..inputcheck import check_input
    from .html import write_report
    for p in (a.original, a.processed):
        check_input(p)
    out = a.output or (os.path.splitext(a.processed)[0] + ".report.html")
    check_outputs([(out, "report"), (a.json, "report JSON")])
    summary = None
    if a.summary:
        check_input(a.summary)
        try:
            with open(a.summary) as fh:
                summary = json.load(fh)
        except (ValueError, UnicodeDecodeError) as e:
            raise UserError(f"{a.summary}: not a summary written by `process --json` ({e})") from None
    prof = _load_profile(a.profile, a.original)       # the same profile `process` chose for this file
    data = write_report(a.original, a.processed, prof, summary, out, a.json, a.layer, not a.no_ringing)
    h = data["headline"]
    sys.stderr.write(f"gcode-opt: report written to {out}"
                     + (f" and {a.json}" if a.json else "")
                     + f" ({h['strokes']['retimed']} re-timed strokes, {len(data['warnings'])} warnings)\n")
    return 0


def cmd_law(a):
    from ..cli import check_outputs
    from ..inputcheck import check_input
    from .law_table import law_table_from_args, write_table
    if a.gcode:
        check_input(a.gcode)
    check_outputs([(a.output, "table")])
    table = law_table_from_args(a)
    write_table(table, a.format, a.output)
    return 0


def cmd_figures(a):
    from .figures import write_figures
    paths = write_figures(a.output_dir)
    for p in paths:
        print(p)
    return 0
