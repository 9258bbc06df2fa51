"""The README's table "What it measured on the bundled samples", measured anew.

    python benchmarks/samples_table.py [--profile auto]

Each bundled sample is processed with default options and the profile the README names for
it (or every sample with the one given); one Markdown row per sample, every figure from the
pipeline's summary (the firmware model playing the original and the written file).
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from gcode_opt.pipeline import Options, process  # noqa: E402
from gcode_opt.profile import load_profile  # noqa: E402

SAMPLES = (("prusa_mk3s_rectilinear", "prusa-mk3s"), ("prusa_absolute_e", "prusa-mk3s"),
           ("prusa_gyroid", "prusa-mk3s"), ("prusa_concentric", "prusa-mk3s"),
           ("prusa_concentric_arcs", "prusa-mk3s"), ("prusa_gyroid_arcs", "voron24"),
           ("prusa_klipper", "voron24"), ("cura_box", "ender3"))


def pct(x):
    return "n/a" if x is None else f"{x * 100:+.0f}%"


def pct1(x):
    return "n/a" if x is None else f"{x * 100:+.1f}%"


def row(name, prof_name):
    src = os.path.join(ROOT, "sample_gcode", name + ".gcode")
    with tempfile.TemporaryDirectory() as tmp:
        s = process(src, os.path.join(tmp, "out.gcode"), load_profile(prof_name), Options())
    rs, pt, wf = s["retimed_strokes"], s["print_time_s"], s["whole_file"]
    kinds = ", ".join(f"{k} {g['retimed']} ({pct(g['int_a2']['change'])})" for k, g in rs["by_kind"].items())
    a2 = rs["int_a2"]
    return (f"| {name} | {prof_name} | {kinds or 'none'} of {s['strokes']['candidates']} | "
            f"{a2['before']:.3g} → {a2['after']:.3g} ({pct(a2['change'])}) | {pct(wf['int_a2_change'])} | "
            f"{pt['before']:.0f} → {pt['after']:.0f} s ({pct1(pt['change'])}) | "
            f"{pct1(rs['firmware_vs_law']['time'])} / {pct1(rs['firmware_vs_law']['int_a2'])} | "
            f"{wf['before']['full_stops']} → {wf['after']['full_stops']} |")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--profile", help="one profile for every sample (default: the README's per sample)")
    a = ap.parse_args(argv)
    print("| sample | profile | strokes re-timed (their ∫\\|a\\|² change) of candidates | ∫\\|a\\|²dt on re-timed "
          "strokes (mm²/s³) | whole file | print time | firmware vs law (time / ∫\\|a\\|²) | full stops |")
    print("|---|---|---|---|---|---|---|---|")
    for name, prof in SAMPLES:
        print(row(name, a.profile or prof), flush=True)


if __name__ == "__main__":
    main()
