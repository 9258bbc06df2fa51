"""The README's per-sample table: the whole-file figures on every bundled sample (issue 9).

    python benchmarks/samples_table.py [--profile NAME] [--json OUT.json] [SAMPLE ...]

Each bundled sample (sample_gcode/*.gcode, or the ones named) is processed as the CLI does
with default options: `--profile auto` (the slicer's limits on the closest bundled profile)
and the default feature selection (features.default_selection: the slicer's infill, or
every extruding move in a file without feature comments).  One Markdown row per sample,
every figure from the pipeline's summary (the firmware model playing the original and the
written file), then the medians issue 9's "Done means" asks for: whole-file int|a|^2 dt
reduction and print-time change.
"""
from __future__ import annotations

import argparse
import io
import json
import os
import statistics
import sys
import tempfile
from contextlib import redirect_stderr

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from gcode_opt import features as feat  # noqa: E402
from gcode_opt.pipeline import Options, process  # noqa: E402

SAMPLE_DIR = os.path.join(ROOT, "sample_gcode")


def samples():
    return sorted(f[:-len(".gcode")] for f in os.listdir(SAMPLE_DIR) if f.endswith(".gcode"))


def pct(x, nd=1):
    return "n/a" if x is None else f"{x * 100:+.{nd}f}%"


def share(x):
    return "n/a" if x is None else f"{x * 100:.0f}%"


def _profile(src, name):
    if name and name != "auto":
        from gcode_opt.profile import load_profile
        return load_profile(name)
    from gcode_opt.detect import auto_profile
    return auto_profile(src).profile


def feature_totals(path, prof):
    """{feature: [moves, time_t, int_a2]} of a file as the firmware model plays it (an XY
    move without extrusion is travel): the split of summary["coverage"]["left"] by feature,
    and the per-feature change between the original and the output."""
    from gcode_opt.firmware.simulate import simulate_events
    from gcode_opt.state import Move, events
    feats, tot = {}, {}

    def feed():
        for idx, raw, ev in events(path, prof):
            if type(ev) is Move:
                feats[idx] = ev.feature
            yield idx, raw, ev

    def on_line(r):
        g = tot.setdefault(feats.pop(r.idx, feat.OTHER), [0, 0.0, 0.0])
        g[0] += 1
        g[1] += r.time_t
        g[2] += r.int_a2 + r.int_a2_j
    simulate_events(feed(), prof, on_line=on_line)
    return tot


def run(name, prof_name=None):
    """The summary of one sample processed with default options (as `gcode-opt process`),
    with the part left split by feature, and the sparse infill's whole-file change
    ("feature_change": {feature: int|a|^2 dt after/before - 1})."""
    src = os.path.join(SAMPLE_DIR, name + ".gcode")
    with redirect_stderr(io.StringIO()):
        prof = _profile(src, prof_name)
    features, _why = feat.default_selection(src)
    opts = Options(features=features)
    before = feature_totals(src, prof)
    opts.by_feature = before
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "out.gcode")
        s = process(src, out, prof, opts)
        after = feature_totals(out, prof)
    s["feature_change"] = {f: (after.get(f, [0, 0.0, 0.0])[2] / g[2] - 1.0 if g[2] else None)
                           for f, g in before.items()}
    return s


def gyroid_change(s):
    """Whole-file change of int|a|^2 dt over every sparse-infill move (the gyroid), re-timed or not."""
    return s.get("feature_change", {}).get(feat.SPARSE_INFILL)


def row(name, s):
    cov, wf, pt = s["coverage"], s["whole_file"], s["print_time_s"]
    rt = cov["retimed"]
    left = [(why, g) for why, g in cov["left"].items() if (g.get("int_a2_share") or 0.0) > 0.005]
    # "feature not selected: perimeter" -> "perimeter"; "sparse_infill: moves in no stroke (...)" -> shorter
    top = "; ".join(f"{why.replace('feature not selected: ', '').split(' (')[0]} {share(g['int_a2_share'])}"
                    for why, g in left[:3]) or "–"
    sel = ",".join(s["features"]["selected"]) if s.get("features") else "?"
    return (f"| {name} | {s['profile']} | {sel} | **{pct(wf['int_a2_change'])}** | {pct(pt['change'])} | "
            f"{share(rt['int_a2_share'])} / {share(rt['time_share'])} | "
            f"{pct(s['retimed_strokes']['int_a2']['change'], 0)} | {top} | "
            f"{wf['before']['full_stops']} → {wf['after']['full_stops']} |")


HEADER = ("| sample | profile (auto) | features | whole file ∫\\|a\\|²dt | print time | re-timed share of the "
          "file's ∫\\|a\\|²dt / time | re-timed strokes' ∫\\|a\\|²dt | largest parts left (not selected, or why; "
          "share of the file's ∫\\|a\\|²dt) "
          "| full stops |\n|---|---|---|---|---|---|---|---|---|")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", metavar="SAMPLE", help="sample names (default: every bundled sample)")
    ap.add_argument("--profile", help="one profile for every sample (default: auto, as the CLI)")
    ap.add_argument("--json", help="write {sample: summary without per_stroke} here")
    a = ap.parse_args(argv)
    names = a.names or samples()
    print(HEADER)
    out, a2, t = {}, [], []
    for name in names:
        s = run(name, a.profile)
        print(row(name, s), flush=True)
        a2.append(s["whole_file"]["int_a2_change"])
        t.append(s["print_time_s"]["change"])
        g = gyroid_change(s) if "gyroid" in name else None
        out[name] = {k: v for k, v in s.items() if k != "per_stroke"}
        out[name]["gyroid_strokes_int_a2_change"] = g
    print(f"\nmedian over {len(names)} samples: whole-file ∫|a|²dt {pct(statistics.median(a2))}, "
          f"print time {pct(statistics.median(t))} (worst {pct(max(t))})")
    for name, d in out.items():
        if d["gyroid_strokes_int_a2_change"] is not None:
            print(f"{name}: all gyroid (sparse infill) moves' ∫|a|²dt, re-timed or not: "
                  f"{pct(d['gyroid_strokes_int_a2_change'])}")
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
