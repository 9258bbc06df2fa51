"""Coverage study (issue 9, items 2 and 3): what a run re-times of a file's motion, why the
rest is left, and what re-timing perimeters buys and costs.

    python benchmarks/coverage_study.py FILE.gcode [...] [--features LIST] [--profile P]
                                        [--overshoot R] [--by-feature] [--policy] [--min-length D]
                                        [--json OUT.json]

Per file: the firmware model's whole-file ∫|a|²dt and print time before/after (pipeline.
process, the written file measured), the strokes re-timed, the reasons left, each with its
count and its share of the ORIGINAL file's ∫|a|²dt and time (gcode_opt.coverage), and per
feature the highest planned speed above the slicer's F, as a ratio (a law's knot speeds; a
one-move trapezoid's F).
--by-feature splits the motion outside every candidate by feature (one more model pass);
--policy caps each feature's speed by coverage.feature_overshoot_r (patched in after
schedule.plan_inputs, as the lead will wire it there).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from collections import defaultdict

import numpy as np

from gcode_opt import features as feat
from gcode_opt import summary as summary_mod
from gcode_opt import pipeline
from gcode_opt.coverage import coverage, feature_figures, feature_overshoot_r
from gcode_opt.pipeline import Options, process


def _profile(name, path):
    if name == "auto":
        from gcode_opt.detect import auto_profile
        return auto_profile(path).profile
    from gcode_opt.profile import load_profile
    return load_profile(name)


def _per_feature_caps(real_plan_inputs):
    """plan_inputs with coverage.feature_overshoot_r applied: the speed cap of a stroke
    whose feature may not overshoot is its slicer F (what the lead wires into
    schedule.plan_inputs' v_cap line; the same numbers, applied after the fact here)."""
    def plan_inputs(strokes, profile, opts):
        pin = real_plan_inputs(strokes, profile, opts)
        for i, st in enumerate(strokes):
            over = feature_overshoot_r(st.feature, opts)
            if over < opts.overshoot_r:
                pin.v_cap[i] = min(pin.v_cap[i], max(st.v_feed * (1 + over), 1e-9))
        return pin
    return plan_inputs


def study(path, profile_name="auto", features=feat.DEFAULT_SELECTED, overshoot_r=0.25, by_feature=False,
          out_path=None, policy=False, min_length_d=2.0):
    profile = _profile(profile_name, path)
    opts = Options(features=features, overshoot_r=overshoot_r, min_length_d=min_length_d)
    seen = {}
    real = summary_mod.build_summary
    real_pi = pipeline.plan_inputs

    def capture(*a, **k):          # process() imports build_summary at call time
        seen["strokes"], seen["plan"] = a[6], a[8]
        return real(*a, **k)

    real_rw = pipeline.rewrite
    over = defaultdict(float)      # feature -> largest F above the slicer's, as a ratio (last pass)

    def rewrite(path_, fh, strokes, plan, *a, **k):     # segments are freed after the rewrite
        over.clear()
        for i, st in enumerate(strokes):
            seg = plan.segs[i] if plan.retime[i] else None
            if seg is not None and st.v_feed > 0:
                # a law's segments reach their knot speeds (F only caps: under classic jerk
                # it is raised towards the neighbours'); a one-move trapezoid cruises at F
                top = np.max(seg.feed) if getattr(seg, "shape", "law") != "law" else np.max(seg.v)
                over[st.feature] = max(over[st.feature], float(top) / st.v_feed - 1.0)
        return real_rw(path_, fh, strokes, plan, *a, **k)

    pipeline.rewrite = rewrite
    summary_mod.build_summary = capture
    if policy:
        pipeline.plan_inputs = _per_feature_caps(real_pi)
    tmp = None
    try:
        if out_path is None:
            fd, tmp = tempfile.mkstemp(suffix=".gcode")
            os.close(fd)
            out_path = tmp
        s = process(path, out_path, profile, opts)
    finally:
        summary_mod.build_summary = real
        pipeline.plan_inputs = real_pi
        pipeline.rewrite = real_rw
        if tmp:
            os.unlink(tmp)
    strokes, plan = seen["strokes"], seen["plan"]
    w0 = s["whole_file"]["before"]
    outside = feature_figures(path, profile, strokes) if by_feature else None
    cov = coverage(strokes, plan, w0["int_a2"], w0["time_t"], outside)
    kinds = defaultdict(int)
    for i, st in enumerate(strokes):
        if plan.retime[i]:
            kinds[f"{st.feature}/{st.kind}"] += 1
    return {"file": os.path.basename(path), "profile": profile.name, "features": list(features),
            "min_length_d": min_length_d,
            "overshoot": overshoot_r if not policy else f"{overshoot_r} (per feature)",
            "int_a2_change": s["whole_file"]["int_a2_change"], "time_change": s["print_time_s"]["change"],
            "retimed": s["strokes"]["retimed"], "candidates": s["strokes"]["candidates"],
            "full_stops": [s["whole_file"]["before"].get("full_stops"), s["whole_file"]["after"].get("full_stops")],
            "retimed_by": dict(kinds), "overshoot_by_feature": dict(over), "coverage": cov}


def format_study(r):
    out = [f"{r['file']} ({r['profile']}, features {','.join(r['features'])}, overshoot {r['overshoot']}, "
           f"min length {r['min_length_d']} mm): "
           f"whole file int|a|^2 {r['int_a2_change'] * 100:+.1f}%, time {r['time_change'] * 100:+.2f}%, "
           f"re-timed {r['retimed']} of {r['candidates']}, full stops {r['full_stops'][0]} -> {r['full_stops'][1]}"]
    out.append("  re-timed: " + ", ".join(f"{k} {v}" for k, v in sorted(r["retimed_by"].items())))
    out.append("  peak F over slicer F: " + ", ".join(f"{k} {v * 100:+.1f}%"
                                                      for k, v in sorted(r["overshoot_by_feature"].items())))
    for k, c in r["coverage"].items():
        n = "" if c["count"] is None else c["count"]
        out.append(f"  {k:52} {n!s:>6} int|a|^2 {c['int_a2_share'] * 100:6.2f}%  time {c['time_share'] * 100:6.2f}%")
    return "\n".join(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="+")
    ap.add_argument("--features", default=",".join(feat.DEFAULT_SELECTED))
    ap.add_argument("--profile", default="auto")
    ap.add_argument("--overshoot", type=float, default=0.25)
    ap.add_argument("--by-feature", action="store_true")
    ap.add_argument("--policy", action="store_true",
                    help="per-feature overshoot (coverage.feature_overshoot_r) instead of --overshoot for all")
    ap.add_argument("--min-length", type=float, default=2.0, help="shortest stroke (mm), as process --min-length")
    ap.add_argument("--json")
    a = ap.parse_args(argv)
    fts = feat.ALL if a.features == "all" else tuple(a.features.split(","))
    res = []
    for f in a.files:
        r = study(f, a.profile, fts, a.overshoot, a.by_feature, policy=a.policy, min_length_d=a.min_length)
        print(format_study(r), flush=True)
        res.append(r)
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(res, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
