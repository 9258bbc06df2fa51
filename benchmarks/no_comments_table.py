"""The README's "Files without feature comments" table: what each default would do to a file
with no feature comments, against the same file with its comments (default infill selection).

    python benchmarks/no_comments_table.py [--corpus DIR]

Columns: the corpus's no_type_comments.gcode (make_corpus.sh: bridges.gcode with its ;TYPE:
lines removed; MK3S) and the bundled prusa_klipper_no_comments.gcode (the boat, Klipper;
its commented twin prusa_klipper.gcode).  Each cell: the firmware model's whole-file
int |a|^2 dt change at its print-time change (the command's JSON summary, --profile auto,
ringing off).  The classify row labels classify.py's open runs as solid infill and its loops
as perimeters (comments written into a copy of the file), then takes the default selection.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, ROOT)


def run(path, *args):
    with tempfile.TemporaryDirectory() as d:
        out, js = os.path.join(d, "out.gcode"), os.path.join(d, "s.json")
        subprocess.run([sys.executable, "-m", "gcode_opt", "process", path, "-o", out, "--json", js, "-q",
                        "--no-ringing", *args], check=True, cwd=ROOT)
        s = json.load(open(js))
    n = s["strokes"]["retimed"]
    return (f"{100 * s['whole_file']['int_a2_change']:+.1f} % at {100 * s['print_time_s']['change']:+.1f} % time"
            f" ({n} strokes, {s['profile']})")


def classified_copy(path, dest):
    """path with ';TYPE:Solid infill' before each open run and ';TYPE:Perimeter' before each loop
    (classify.py's labels), ';TYPE:Custom' after, so the default selection takes the open runs."""
    from gcode_opt.classify import LOOP, run_label, runs
    from gcode_opt.profile import load_profile
    from gcode_opt.state import MachineState, Move, read_lines

    def moves():
        st = MachineState(load_profile("generic-marlin"), path)
        for idx, raw in read_lines(path):
            ev = st.step(idx, raw)
            for m in (ev if isinstance(ev, list) else [ev]):
                if isinstance(m, Move):
                    yield m
    marks = {}
    for r in runs(moves()):
        marks[r[0].idx] = ";TYPE:Perimeter\n" if run_label(r) == LOOP else ";TYPE:Solid infill\n"
        marks[r[-1].idx + 1] = marks.get(r[-1].idx + 1, "") or ";TYPE:Custom\n"
    with open(path, encoding="utf-8", errors="surrogateescape", newline="") as fh, \
            open(dest, "w", encoding="utf-8", errors="surrogateescape", newline="") as out:
        for i, line in enumerate(fh):
            if i in marks:
                out.write(marks[i])
            out.write(line)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--corpus", default=os.path.expanduser("~/.cache/gcode-opt-corpus"))
    a = ap.parse_args(argv)
    files = [(os.path.join(a.corpus, "no_type_comments.gcode"), os.path.join(a.corpus, "bridges.gcode")),
             (os.path.join(ROOT, "sample_gcode", "prusa_klipper_no_comments.gcode"),
              os.path.join(ROOT, "sample_gcode", "prusa_klipper.gcode"))]
    rows = [("every extruding move (`other`) — the default", lambda f, ref: run(f)),
            ("every extruding move at zero overshoot", lambda f, ref: run(f, "--overshoot", "0")),
            ("everything, travel included (`--features all`)", lambda f, ref: run(f, "--features", "all")),
            ("classify.py's open runs as infill (loops = perimeters left)", None),
            ("reference: the file with its `;TYPE:` comments, default selection", lambda f, ref: run(ref))]
    print("| default for a file without comments | " + " | ".join(os.path.basename(f) for f, _ in files) + " |")
    print("|---|" + "---|" * len(files))
    for name, fn in rows:
        cells = []
        for f, ref in files:
            if fn is None:
                with tempfile.TemporaryDirectory() as d:
                    c = os.path.join(d, "classified.gcode")
                    classified_copy(f, c)
                    cells.append(run(c))
            else:
                cells.append(fn(f, ref))
        print(f"| {name} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
