"""Command line: `gcode-opt process|simulate|profiles ...`  (`gcode-opt -h` teaches)."""
from __future__ import annotations

import math
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


class UserError(Exception):
    """A mistake in the command line or its files: exit 2, one line, no traceback."""


def _parser_type():
    """Parser: argparse with the program's one error form, `gcode-opt: message` (exit 2).
    Made where a parser is built: a plain process command line needs neither argparse's
    import (~8 M instructions) nor a parser (_plain_process)."""
    import argparse

    class Parser(argparse.ArgumentParser):
        def error(self, message):
            self.print_usage(sys.stderr)
            if message.startswith("argument "):        # "argument --x: why" -> "--x: why"
                message = message[len("argument "):]
            self.exit(2, f"gcode-opt: {message}\n")
    return Parser


def _refused(message):
    """The error an option's type function raises: argparse shows message as the option's."""
    import argparse
    return argparse.ArgumentTypeError(message)


def _number(text, what):
    try:
        v = float(text)
    except ValueError:
        raise _refused(f"{text!r} is not a number ({what})") from None
    if not math.isfinite(v):
        raise _refused(f"{text!r}: must be a finite number ({what})")
    return v


def _typed(name):
    def deco(fn):
        fn.__name__ = name      # argparse names the type in its messages: no Python names leak
        return fn
    return deco


@_typed("alpha")
def _alpha(text):
    if text == "auto":
        return "auto"
    v = _number(text, "expected 'auto' or a number in s^2/kg")
    if v <= 0:
        raise _refused(f"{text}: alpha must be > 0 (s^2/kg)")
    return v


@_typed("features")
def _features(text):
    try:
        return feat.parse_feature_list(text)
    except ValueError as e:
        raise _refused(str(e))


@_typed("fraction")
def _corners(text):
    return "auto" if text.strip().lower() == "auto" else _fraction(text)


def _fraction(text):
    """0.25 or 25%; a bare number above 1 is refused (3 would mean +300 %)."""
    pct = text.strip().endswith("%")
    v = _number(text.strip().rstrip("%").strip(), "a fraction such as 0.03, or a percentage such as 3%")
    if pct:
        v /= 100.0
    if v < 0:
        raise _refused(f"{text}: must be >= 0")
    if v > 1:
        hint = f"; did you mean {text.strip()}%?" if not pct else ""
        raise _refused(f"{text}: a fraction above 1 means more than +100 %{hint} "
                       "(give 0.03 or 3%)")
    return v


@_typed("count")
def _segments(text):
    try:
        v = int(text)
    except ValueError:
        raise _refused(f"{text!r}: expected a whole number >= 1") from None
    if v < 1:
        raise _refused(f"{text}: must be >= 1")
    return v


@_typed("angle")
def _max_turn(text):
    v = _number(text, "degrees")
    if not 0 <= v < 90:
        raise _refused(f"{text}: must be in [0, 90) degrees")
    return v


@_typed("length")
def _length(text):
    v = _number(text, "mm")
    if v < 0:
        raise _refused(f"{text}: must be >= 0 mm")
    return v


# process's options but its input: (option strings, add_argument's keywords), the one list
# the parser is built from and _plain_process reads
PROCESS_OPTIONS = (
    (("-o", "--output"), dict(metavar="OUT.gcode", help="write here (default: rewrite IN in place)")),
    (("--profile",), dict(default="auto",
         help="printer profile name (see `gcode-opt profiles`) or a .toml file. 'auto' (default) "
              "reads the slicer's printer_model / flavour comments and falls back to generic-klipper")),
    (("--alpha",), dict(type=_alpha, default="auto",
         help="weight of the inertia term, s^2/kg (beta = alpha*m is a time^2: the law's boundary "
              "layers are sqrt(beta) long). 'auto' (default) picks per stroke the law with the "
              "least int|a|^2 dt that fits the limits and the time budget")),
    (("--features",), dict(type=_features, default=None,
         help="comma-separated features to re-time (default: sparse_infill,solid_infill; in a file "
              "without feature comments every extruding move, 'other'; 'all'; "
              f"choices: {', '.join(feat.ALL)})")),
    (("--overshoot",), dict(type=_fraction, default=0.25,
         help="how far the law's peak speed may exceed the slicer's F, e.g. 0.25 or 25%% "
              "(never above the machine's max speed or the hotend's flow limit; default %(default)s)")),
    (("--max-slowdown",), dict(type=_fraction, default=0.03,
         help="print-time budget the auto law may spend, as a fraction of the whole file's "
              "print time (default %(default)s = 3%%)")),
    (("--corners",), dict(type=_corners, default=0.0, metavar="R",
         help="slower corners, less ringing (ghosting): the share of the --max-slowdown budget spent "
              "lowering speeds at sharp corners (e.g. 0.7 or 70%%), or 'auto' (the corners' share of the "
              "original's ringing; the usual choice). Written as a junction command the firmware applies "
              "to that corner only (M205 X Y on Prusa/Marlin classic jerk, SET_VELOCITY_LIMIT "
              "SQUARE_CORNER_VELOCITY on Klipper), else a short lead-in. Costs part of the int|a|^2 gain; "
              "default 0 = off. See README, Ringing")),
    (("--segments",), dict(type=_segments, default=10,
         help="most segments per re-timed stroke (also capped by the firmware's segment rate, "
              "minimum segment time and planner buffer; default %(default)s)")),
    (("--max-turn",), dict(type=_max_turn, default=30.0, metavar="DEG",
         help="a run of G1 lines whose every vertex turns by at most DEG degrees is one smooth curve, "
              "re-timed as a whole (gyroid, concentric infill); 0 re-times straight runs only "
              "(default %(default)s)")),
    (("--min-length",), dict(type=_length, default=0.2,
         help="shortest stroke to re-time, mm (default %(default)s: a stroke too short for two segments "
              "is played as one move with its own feed and acceleration)")),
    (("--json",), dict(metavar="SUMMARY.json", help="write the summary (figures from the firmware model) here")),
    (("--report",), dict(metavar="REPORT.html",
         help="write a self-contained HTML report: before/after figures, plots of the re-timed moves")),
    (("--no-ringing",), dict(action="store_true",
         help="skip the ringing figures (the frame's resonance driven by the original and the written "
              "file, per axis, before/after: the summary's 'ringing', one summary line, the report's "
              "ringing section); they ride on the firmware model's passes over both files")),
    (("-q", "--quiet"), dict(action="store_true", help="no progress bar, no summary on stderr")),
    (("--profile-time",), dict(action="store_true",
         help="after the summary, print the CPU seconds each phase took (analyse, plan, rewrite, measure)")),
)


def build_parser(only_process=False):
    """The command line's parser; only_process: with the process command alone (main's
    parser for a command line that starts with it: the other commands' parsers, and the
    report package's import, are ~15 M instructions of a small file's run).  Its parsing of
    such a command line, and every message and exit, is the whole parser's: the process
    parser is the same, and the top-level one shows COMMAND, not the commands' names.  Its
    parser is a ProcessLine: the plain command lines it parses without argparse."""
    if only_process:
        return ProcessLine()
    return _argparser(only_process)


def _argparser(only_process):
    """build_parser's argparse parser (only_process: with the process command alone)."""
    import argparse
    ap = _parser_type()(prog="gcode-opt", description="Re-time the moves of sliced FDM G-code with the "
                                 "energy/inertia-optimal law of motion, checked on a model of the printer's firmware.",
                                 epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--version", action="version", version=f"gcode-opt {__version__}")
    ap.add_argument("--debug", action="store_true",
                    help="show a Python traceback on errors (may also be given after the command)")
    sub = ap.add_subparsers(dest="cmd", metavar="COMMAND")

    p = sub.add_parser("process", help="re-time a G-code file", description=PROCESS_HELP,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("input", metavar="IN.gcode")
    for flags, kw in PROCESS_OPTIONS:
        p.add_argument(*flags, **kw)
    if only_process:
        return ap

    s = sub.add_parser("simulate", help="play a file through the firmware model",
                       description="Plan a whole file the way a constant-acceleration lookahead firmware does "
                                   "and report print time, int|a|^2 dt, peak speed and acceleration, full stops, "
                                   "and the ringing the frame's resonance gives (the profile's [resonance] table).")
    s.add_argument("input", metavar="FILE.gcode")
    s.add_argument("--no-ringing", action="store_true", help="skip the ringing figures")
    s.add_argument("--profile", default="auto", help="as for process (default: auto)")
    s.add_argument("--json", action="store_true", help="print JSON instead of text")

    sub.add_parser("profiles", help="list the bundled printer profiles")
    from .report.commands import register        # report, law, figures
    register(sub)
    return ap


class ProcessLine:
    """build_parser(only_process=True)'s parser: parse_args gives the namespace the process
    parser gives, read without argparse where the command line is plain (_plain_process);
    any other command line (an abbreviation, a refused value, -h ...) the argparse parser
    parses, with its messages and exits."""

    def parse_args(self, argv):
        a = _plain_process(argv)
        return a if a is not None else _argparser(True).parse_args(argv)

    def print_help(self, file=None):
        _argparser(True).print_help(file)


def _plain_process(argv):
    """The process parser's namespace (its attributes, in a SimpleNamespace) for a plain
    command line -- `process`, one input, each option spelled in full with its value as
    the next word (not one starting with '-') that the option's type takes -- read without
    argparse: its import, the parser's build and parse were ~17 M instructions of each run.
    None for anything else (abbreviations, --opt=value, -h, --version, '--', a refused or
    missing value, no input or a second one): argparse parses those."""
    if argv[:1] != ["process"]:
        return None
    ns = {"debug": False, "cmd": "process"}
    options = {}
    for flags, kw in PROCESS_OPTIONS:
        dest = next(f for f in flags if f.startswith("--"))[2:].replace("-", "_")
        conv = True if kw.get("action") == "store_true" else kw.get("type")
        default = False if conv is True else kw.get("default")
        ns[dest] = conv(default) if isinstance(default, str) and callable(conv) else default   # (as argparse)
        options.update((f, (dest, conv)) for f in flags)
    inputs = []
    words = iter(argv[1:])
    for w in words:
        if not w.startswith("-"):
            inputs.append(w)
            continue
        if w not in options:
            return None
        dest, conv = options[w]
        if conv is True:
            ns[dest] = True
            continue
        v = next(words, None)
        if v is None or v.startswith("-"):
            return None
        try:
            ns[dest] = conv(v) if conv is not None else v
        except Exception:           # noqa: BLE001 - argparse reports it (ArgumentTypeError, ValueError)
            return None
    if len(inputs) != 1:
        return None
    from types import SimpleNamespace
    return SimpleNamespace(input=inputs[0], **ns)


def _load_profile(name, path=None, quiet=False, metadata=None):
    """auto: limits from the slicer's settings (file, SLIC3R_* variables) on the closest bundled
    profile, each value's source on stderr.  A named profile wins; where the file's limits differ
    from it, one warning line each (also under -q: the user chose against the file).  metadata:
    settings read from the file elsewhere (a .bgcode's slicer-metadata block)."""
    from .profile import load_profile
    if name == "auto":
        from .detect import auto_profile
        auto = auto_profile(path, metadata=metadata)
        if not quiet:
            sys.stderr.write(auto.describe() + "\n")
            sys.stderr.flush()
        return auto.profile
    prof = load_profile(name)
    if path:
        from .detect import conflicts
        try:
            warnings = conflicts(prof, path, metadata=metadata)
        except OSError:                  # unreadable input: check_input reports it
            warnings = []
        if warnings:
            sys.stderr.write("\n".join(warnings) + "\n")
    return prof


def check_outputs(pairs):
    """(path, what) for each output; folder exists and is writable, path is not a folder."""
    from .outfile import OutputError, check_writable
    seen = {}
    for path, what in pairs:
        if not path:
            continue
        try:
            check_writable(path, what)
        except OutputError as e:
            raise UserError(str(e)) from None
        real = os.path.realpath(path)
        if real in seen:
            raise UserError(f"{path}: named both as the {seen[real]} and the {what}")
        seen[real] = what


def _binary_input(path):
    """The BinaryJob of a Prusa binary G-code input (decoded to a temporary text), or None for
    text.  Checks the input either way (UserError / InputRefused 'PATH: why')."""
    from .inputcheck import check_input
    if check_input(path, binary_gcode=True) == "text":   # missing, folder, empty, binary: refused here
        return None
    from .bgcode_job import BinaryJob
    return BinaryJob(path, path)


_START_PAUSE = []        # main's pause of the garbage collector, not yet ended (see _gc_pause)


def _gc_pause():
    """The collector off for main's start (the parser, the profile, output and reader
    modules, numpy through them: the program's objects, none of them garbage; the
    collections on the way walked them again and again), where the caller left it on and
    nothing is frozen.  _modules_frozen ends the pause with those objects frozen along
    with the pipeline's; _gc_resume ends it otherwise (another command, an exit)."""
    import gc
    if gc.isenabled() and not gc.get_freeze_count():
        gc.disable()
        _START_PAUSE.append(True)


def _gc_resume():
    """The collector back on where main's pause is still on; else nothing."""
    import gc
    if _START_PAUSE:
        _START_PAUSE.clear()
        gc.enable()


def _modules_frozen(name):
    """Imports module `name` (the pipeline: numpy's modules and ours, ~10^5 objects, none of
    them garbage) with the garbage collector off, then moves every object alive out of its
    view (gc.freeze): the collections on the way walked them again and again (~13 M
    instructions of a small file's run).  Returns thaw(), to call before the pipeline
    starts (it freezes its own objects, pipeline._strokes_frozen, only where nothing is
    frozen yet); a second call does nothing."""
    import gc
    from importlib import import_module
    paused = bool(_START_PAUSE)                         # (main's pause: ended here, its objects frozen too)
    _START_PAUSE.clear()
    if not paused and (gc.get_freeze_count() or not gc.isenabled()):     # (a caller's own settings: left alone)
        import_module(name)
        return lambda: None
    gc.disable()
    try:
        import_module(name)
        gc.freeze()
    finally:
        gc.enable()
    frozen = [True]

    def thaw():
        if frozen:
            frozen.clear()
            gc.unfreeze()
    return thaw


def cmd_process(a):
    thaw = _modules_frozen(__package__ + ".pipeline")
    _gc_resume()                                      # (a stand-in for _modules_frozen: main's pause ended)
    try:
        from .pipeline import Options, Progress, process
        out = a.output or a.input
        job = _binary_input(a.input)                  # .bgcode: decoded, every checksum verified
        try:
            return _process(a, out, job, Options, Progress, process, thaw)
        finally:
            if job is not None:
                job.close()
    finally:
        thaw()                                        # (however it ends: a refused input too)


def _process(a, out, job, Options, Progress, process, thaw=lambda: None):
    check_outputs([(out, "output" if a.output else "output (the input, rewritten in place)"),
                   (a.report, "report"), (a.json, "summary")])
    src, dst, metadata = a.input, out, None
    if a.output and not a.quiet and (job is not None) != a.output.lower().endswith(".bgcode"):
        kind = "binary G-code" if job is not None else "text G-code"
        sys.stderr.write(f"gcode-opt: {a.output}: written as {kind}, the input's kind, whatever its name\n")
    if job is not None:                               # the pipeline works on the decoded text
        job.out_path = out
        src, dst, metadata = job.src, job.dst, job.settings
    prof = _load_profile(a.profile, src, a.quiet, metadata=metadata)
    prog = None if a.quiet else Progress(os.path.getsize(src))
    features, features_why = (a.features, None) if a.features is not None else feat.default_selection(src)
    opts = Options(alpha=a.alpha, features=features, overshoot_r=a.overshoot, max_slowdown_r=a.max_slowdown,
                   max_segments=a.segments, min_length_d=a.min_length, progress=prog,
                   corner_budget_r=a.corners)
    opts.max_turn_deg = a.max_turn
    opts.ringing = not a.no_ringing                   # the pipeline's passes feed ringing collectors
    # the ringing's ramp / corner / turn parts only where something reads them: the JSON, the
    # report, --corners auto (corners.corner_share); the text summary shows the whole ringing
    opts.ringing_parts = bool(a.json or a.report or a.corners == "auto")
    opts.summary_rows = "table" if a.json or a.report else False   # likewise the summary's per-stroke rows (made as written)
    report_error = []
    pending = []

    def write_report(orig, new, summary):
        try:                                          # a failed report never costs the G-code output
            from .report.html import write_report
            write_report(orig, new, prof, summary, a.report, ringing=opts.ringing)
        except Exception as e:                        # noqa: BLE001 - reported after the output is in place
            if a.debug:
                import traceback
                traceback.print_exc()
            why = e.strerror if isinstance(e, OSError) and e.strerror else e
            report_error.append(f"{a.report}: report not written: {why}")

    def write_report_hook(orig, new, summary):        # runs while both files exist
        if opts.ringing and "ringing" not in summary:
            add_ringing(summary, orig, new, prof, a.debug)
        if not a.report:
            return
        if job is None:
            write_report(orig, new, summary)
        else:                                         # the .bgcode is written after the pipeline
            pending.append((orig, new, summary))
    hook = write_report_hook if a.report or opts.ringing else None
    thaw()
    if job is None:
        summary = process(a.input, out, prof, opts, before_replace=hook)
    else:
        summary = job.run(lambda: process(src, dst, prof, opts, before_replace=hook))
        summary = job.finish(summary)                 # encoded, read back, put in place atomically
        if not a.quiet:
            for w in job.warnings:
                sys.stderr.write(f"gcode-opt: {w}\n")
        for orig, _tmp, summ in pending:           # the pipeline's temporary text is job.dst now
            write_report(orig, job.dst, summ)
    rc = 0
    fi = summary.get("features")
    if isinstance(fi, dict) and features_why:         # the no-comments default was applied: say why
        fi["why"] = features_why
        if not a.quiet:                               # (a file with no move to re-time: nothing to say)
            sys.stderr.write(f"gcode-opt: {a.input}: {features_why}\n")
    if a.json:
        from .summary import dump_json
        try:
            with open(a.json, "w") as fh:
                dump_json(summary, fh)
        except OSError as e:
            report_error.append(f"{a.json}: summary not written: {e.strerror or e}")
    if summary.get("unchanged"):
        where = a.input if out == a.input else f"{a.input} copied unchanged to {out}"
        sys.stderr.write(f"gcode-opt: {summary['unchanged']}; {where}"
                         + ("" if out != a.input else " left unchanged") + "\n")
        if a.report:
            sys.stderr.write(f"gcode-opt: {a.report}: no report written: nothing to compare\n")
    elif not a.quiet:
        _print_warnings(a.input, summary)
        fi = summary.get("features") or {}
        if fi.get("note"):                            # a file without feature comments: say what that selects
            sys.stderr.write(f"gcode-opt: {a.input}: features {','.join(fi['selected'])}: {fi['note']}\n")
        sys.stderr.write(format_summary(summary) + "\n")
        faults = summary["strokes"].get("faults", 0)
        if faults:
            sys.stderr.write(f"  kept as sliced     {faults} stroke(s) after a fault in planning, segments or the "
                             "output check (reasons in --json: strokes.not_retimed)\n")
    if a.profile_time and summary.get("timing_s"):
        sys.stderr.write(format_timing(summary, opts.peak_rss_mb) + "\n")
        b = summary.get("bgcode")
        if b:
            sys.stderr.write(f"  binary G-code      {b['bytes_before']} -> {b['bytes_after']} bytes "
                             f"({b['gcode_encoding']}, {b['gcode_compression']}; "
                             f"{b['blocks_kept']} metadata/thumbnail blocks kept byte for byte)\n")
    for msg in report_error:
        sys.stderr.write(f"gcode-opt: {msg}; {out} was written\n")
        rc = 1
    return rc


def add_ringing(summary, orig, new, prof, debug=False):
    """summary["ringing"] from one firmware-model pass over each file, where the pipeline
    did not already give it; a failure here never costs the output (a note instead).  A
    written file that is the original byte for byte is played once: no change."""
    try:
        from .pipeline import same_bytes
        from .ringing import figures, summary_of
        before = figures(orig, prof)
        after = before if same_bytes(orig, new) else figures(new, prof)
        summary["ringing"] = summary_of(before, after)
        if "per_stroke" in summary:                   # (kept last: the long list)
            summary["per_stroke"] = summary.pop("per_stroke")
    except Exception as e:                            # noqa: BLE001 - the G-code output comes first
        if debug:
            import traceback
            traceback.print_exc()
        summary["ringing_error"] = f"{type(e).__name__}: {e}"


MAX_SHOWN_WARNINGS = 10


def _print_warnings(path, summary):
    """The reader's warnings, each naming its line (the first few; all are counted)."""
    w = summary.get("warnings") or {}
    for item in w.get("first", [])[:MAX_SHOWN_WARNINGS]:
        sys.stderr.write(f"gcode-opt: {path}:{item['line']}: warning: {item['text']}\n")
    more = w.get("count", 0) - min(len(w.get("first", [])), MAX_SHOWN_WARNINGS)
    if more > 0:
        sys.stderr.write(f"gcode-opt: {path}: {more} more warning(s) (--json lists the first 100)\n")


def format_timing(s, peak_mb=None):
    """The --profile-time line(s): CPU seconds per phase; with peak_mb ({phase: MB}, the
    process's peak RSS at the end of each phase), a second line of those peaks."""
    t = s["timing_s"]
    phases = ", ".join(f"{k} {v:.2f}" for k, v in t.items() if k != "total")
    lines = s.get("file", {}).get("lines_before")
    rate = f" = {lines / t['total'] / 1000:.1f} k lines/s" if lines and t.get("total") else ""
    out = (f"  CPU time (s)       {phases} ({s.get('rewrite_passes', 1)} rewrite pass(es)); "
           f"total {t.get('total', 0.0):.2f}{rate}; cores: firmware model {s.get('firmware_core', '?')}, "
           f"reader {s.get('reader_core', '?')}, chains {s.get('chain_core', '?')}, "
           f"rewrite {s.get('emit_core', '?')}, curves {s.get('curve_core', '?')}")
    if peak_mb and all(v is not None for v in peak_mb.values()):
        out += "\n  peak RSS (MB)      " + ", ".join(f"{k} {v:.0f}" for k, v in peak_mb.items())
    return out


def format_summary(s):
    rs = s["retimed_strokes"]
    pt = s["print_time_s"]

    def pct(x):
        return "n/a" if x is None else f"{x * 100:+.1f}%"

    lines = [f"gcode-opt: {s['output']} ({s['profile']}, {s['flavour']})"]
    lines += format_coverage(s.get("coverage"), pct)
    lines += [
        f"  strokes re-timed   {s['strokes']['retimed']} of {s['strokes']['candidates']}",
        f"  int|a|^2 dt        {rs['int_a2']['before']:.4g} -> {rs['int_a2']['after']:.4g} mm^2/s^3 on re-timed strokes "
        f"({pct(rs['int_a2']['change'])}); whole file {pct(s['whole_file']['int_a2_change'])}",
        f"  print time         {pt['before']:.1f} s -> {pt['after']:.1f} s ({pct(pt['change'])})",
        f"  firmware vs law    time {pct(rs['firmware_vs_law']['time'])}, int|a|^2 {pct(rs['firmware_vs_law']['int_a2'])}",
        f"  full stops         {s['whole_file']['before']['full_stops']} -> {s['whole_file']['after']['full_stops']}",
    ]
    if s.get("ringing"):
        from .ringing import headline_text
        lines.append(f"  ringing            {headline_text(s['ringing'])}")
    elif s.get("ringing_error"):
        lines.append(f"  ringing            not computed: {s['ringing_error']}")
    return "\n".join(lines)


MAX_SHOWN_REASONS = 6
MIN_SHOWN_SHARE = 0.005       # reasons below 0.5 % of both int|a|^2 dt and time are summed up


def format_coverage(cov, pct):
    """The headline lines: the whole file's change, the share re-timed, and what was left and why."""
    if not cov:
        return []

    def share(x):
        return "n/a" if x is None else f"{x * 100:.1f}%"
    wf, rt = cov["whole_file"], cov["retimed"]
    out = [f"  whole file         int|a|^2 dt {pct(wf['int_a2_change'])}, print time {pct(wf['time_change'])} "
           "(firmware model)",
           f"  re-timed           {share(rt['int_a2_share'])} of the file's int|a|^2 dt, {share(rt['time_share'])} of "
           f"its print time ({rt['strokes']} strokes)"]
    left = cov.get("left") or {}
    shown, rest_a2, rest_t, n_rest = [], 0.0, 0.0, 0
    for why, g in left.items():
        a2, t = g.get("int_a2_share") or 0.0, g.get("time_share") or 0.0
        if len(shown) < MAX_SHOWN_REASONS and max(a2, t) >= MIN_SHOWN_SHARE:
            shown.append((why, g, a2, t))
        else:
            rest_a2, rest_t, n_rest = rest_a2 + a2, rest_t + t, n_rest + 1
    if shown or n_rest:
        out.append("  left as sliced     share of int|a|^2 dt / of print time, by reason:")
    for why, g, a2, t in shown:
        count = f" ({g['count']} {g['unit']})" if g.get("count") and g.get("unit") else ""
        out.append(f"    {a2 * 100:5.1f}% / {t * 100:5.1f}%  {why}{count}")
    if n_rest:
        out.append(f"    {rest_a2 * 100:5.1f}% / {rest_t * 100:5.1f}%  {n_rest} other reason(s) (--json: coverage.left)")
    return out


def cmd_simulate(a):
    from .firmware.simulate import simulate_file
    job = _binary_input(a.input)                      # .bgcode: its decoded G-code is simulated
    fig = []

    def run(src, prof):
        if a.no_ringing:
            return simulate_file(src, prof)
        from .ringing import Collector, play
        col = Collector(prof)                         # rides on the same firmware-model pass
        res = play(src, prof, col)
        fig.append(col.figures())
        return res
    try:
        src = a.input if job is None else job.src
        if job is None:
            res = run(src, _load_profile(a.profile, src, a.json))
        else:
            res = job.run(lambda: run(src, _load_profile(a.profile, src, a.json, metadata=job.settings)))
    finally:
        if job is not None:
            job.close()
    d = res.as_dict()
    if fig:
        d["ringing"] = fig[0]
    if a.json:
        import json
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
    if fig:
        from .ringing import text_rows
        rows += text_rows(fig[0])
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


EXIT_USER = 2          # user error or refused input
EXIT_FAIL = 1          # the output could not be written (disk full, size limit), or an internal error
SIGNAL_EXIT = {"SIGINT": 130, "SIGTERM": 143, "SIGHUP": 129}


def _dispatch(a):
    if hasattr(a, "func"):
        return a.func(a)
    return {"process": cmd_process, "simulate": cmd_simulate, "profiles": cmd_profiles}[a.cmd](a)


def _left(a):
    """What an interrupted or failed run did to the user's file, for the one-line message."""
    from .outfile import COMMITTED
    src = getattr(a, "input", None)
    if src is None:
        return ""
    out = getattr(a, "output", None) or src
    if os.path.realpath(out) in COMMITTED:
        return f"; {out} was already written"
    return f"; {src} left unchanged" if out == src else f"; {src} left unchanged, {out} not written"


def main(argv=None):
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv                      # accepted anywhere, not only before the command
    argv = [x for x in argv if x != "--debug"]
    _gc_pause()                     # until process freezes these modules with the pipeline's, or the command runs
    to_process = False
    try:
        ap = build_parser(only_process=argv[:1] == ["process"])
        a = ap.parse_args(argv)
        a.debug = debug
        if not a.cmd:
            ap.print_help()
            return EXIT_USER
        from . import blas, malloc_policy
        blas.one_thread_from_start()    # no OpenBLAS thread pool spinning at numpy's import (blas.py)
        malloc_policy.apply()           # freed numpy temporaries reused, not faulted in anew (malloc_policy.py)
        malloc_policy.small_pages()     # no 2 MiB pages under numpy's arrays: a lower peak RSS (malloc_policy.py)
        from .outfile import Interrupted, OutputError, discard_pending, install_signal_handlers, restore_signal_handlers
        from .profile import ProfileError
        from .state import GcodeError
        from .inputcheck import InputRefused
        saved = install_signal_handlers()
        to_process = a.cmd == "process" and not hasattr(a, "func")
    finally:
        if not to_process:
            _gc_resume()

    def fail(code, msg):
        if debug:
            import traceback
            traceback.print_exc()
        sys.stderr.write(f"gcode-opt: {msg}\n")
        return code
    try:
        return _dispatch(a)
    except KeyboardInterrupt:
        return fail(SIGNAL_EXIT["SIGINT"], "interrupted" + _left(a))
    except Interrupted as e:
        import signal
        name = signal.Signals(e.signum).name
        return fail(SIGNAL_EXIT.get(name, 128 + e.signum), f"interrupted by {name}" + _left(a))
    except OutputError as e:                       # raised while writing: disk full, ulimit -f
        return fail(EXIT_FAIL if "cannot write" in str(e) else EXIT_USER, str(e) + _left(a))
    except (UserError, ProfileError, GcodeError, InputRefused) as e:
        return fail(EXIT_USER, str(e))
    except ValueError as e:                        # a refusal raised deeper down, already 'FILE:LINE: why'
        return fail(EXIT_USER, str(e))
    except OSError as e:
        where = e.filename or getattr(a, "input", "")
        return fail(EXIT_FAIL, f"{where}: {e.strerror or e}" + _left(a))
    except Exception as e:                         # noqa: BLE001 - a bug: one line, traceback on --debug
        return fail(EXIT_FAIL, f"internal error: {type(e).__name__}: {e} (run again with --debug for the "
                               "traceback, and please report it)" + _left(a))
    finally:
        _gc_resume()                               # (process ended the pause; else here)
        discard_pending()
        restore_signal_handlers(saved)


def run():
    """The `gcode-opt` program (pyproject's console script): main() on sys.argv, then the
    process ends by exit_process, as `python -m gcode_opt` does (__main__.py).  It does not
    return where the teardown is skipped: call main() to run a command in-process."""
    exit_process(main())


def exit_process(code):
    """sys.exit(code) at the end of `python -m gcode_opt` (__main__.py): where the
    interpreter's teardown has nothing to do for the run -- no atexit callback (coverage's,
    logging's), no other thread, no profiler or tracer, stdout and stderr flushed -- the
    process ends with os._exit instead.  The teardown frees every module and object one by
    one and collects garbage on the way (~44 M instructions after a 2-line file's run);
    every file a run writes is closed by its with block before this, its temporary files
    are gone (main's finally).  Anything else: sys.exit, as before."""
    import atexit
    callbacks = getattr(atexit, "_ncallbacks", None)
    threading = sys.modules.get("threading")
    if (code is None or type(code) is int) and callbacks is not None and callbacks() == 0 \
            and (threading is None or threading.active_count() == 1) \
            and sys.getprofile() is None and sys.gettrace() is None:
        try:
            for stream in (sys.stdout, sys.stderr):
                if stream is not None:
                    stream.flush()
        except Exception:           # noqa: BLE001 - (the usual exit reports it, as before)
            sys.exit(code)
        os._exit(code or 0)
    sys.exit(code)


if __name__ == "__main__":
    # run the imported module's main, not this __main__ copy: one set of exception classes
    from gcode_opt.cli import main as _main
    sys.exit(_main())
