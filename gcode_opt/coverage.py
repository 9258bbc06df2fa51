"""Coverage: how much of the file's motion was re-timed, and why the rest was not.

The figures are shares of the ORIGINAL file as the firmware model plays it: a stroke's
∫|a|²dt and time are the original's (the analyse pass measured them), the denominators
the whole original file's.  What no stroke holds (features not selected, travel, strokes
shorter than --min-length, moves between strokes) is "not a candidate", optionally split
by feature (outside_by_feature, from a separate firmware-model pass: see
feature_figures).

    coverage(strokes, plan, whole_int_a2, whole_time_t) ->
        {reason: {"count": n, "int_a2_share": r, "time_share": r}, ...}   largest share first

Also here: the per-feature speed overshoot the planner may use (feature_overshoot_r),
the policy issue 9 measured for perimeters (see benchmarks/coverage_study.py).
"""
from __future__ import annotations

from collections import defaultdict

from . import features as feat

RETIMED = "retimed"
NOT_CANDIDATE = "not a candidate"


def coverage(strokes, plan, whole_int_a2, whole_time_t, outside_by_feature=None):
    """Reasons -> count, share of the original file's ∫|a|²dt and of its print time.

    strokes: the analyse pass' strokes (int_a2, time_t: the original's figures); plan: the
    plan (plan.reason per stroke, "retimed" for the re-timed ones); whole_*: the original
    file's totals (sim0.int_a2, sim0.time_t).  The rest of the file is NOT_CANDIDATE, or,
    with outside_by_feature = {feature: (int_a2, time_t)} for the moves outside every
    stroke, "not a candidate: FEATURE" per feature (count = None: moves, not strokes)."""
    acc = defaultdict(lambda: [0, 0.0, 0.0])
    in_a2 = in_t = 0.0
    for i, st in enumerate(strokes):
        r = acc[str(plan.reason[i]) or "not planned"]
        r[0] += 1
        r[1] += st.int_a2
        r[2] += st.time_t
        in_a2 += st.int_a2
        in_t += st.time_t
    out = {k: {"count": c, "int_a2_share": _share(a, whole_int_a2), "time_share": _share(t, whole_time_t)}
           for k, (c, a, t) in acc.items()}
    if outside_by_feature:
        for f, (a, t) in outside_by_feature.items():
            out[f"{NOT_CANDIDATE}: {f}"] = {"count": None, "int_a2_share": _share(a, whole_int_a2),
                                           "time_share": _share(t, whole_time_t)}
    else:
        out[NOT_CANDIDATE] = {"count": None, "int_a2_share": _share(max(whole_int_a2 - in_a2, 0.0), whole_int_a2),
                              "time_share": _share(max(whole_time_t - in_t, 0.0), whole_time_t)}
    return dict(sorted(out.items(), key=lambda kv: -(kv[1]["int_a2_share"] or 0.0)))


def _share(x, whole):
    return None if not whole else float(x) / float(whole)


def feature_figures(path, profile, strokes):
    """{feature: (int_a2, time_t)} of the original file's moves outside every stroke, by
    feature (an XY move without extrusion is travel): one more firmware-model pass."""
    from .firmware.simulate import simulate_events
    from .state import events

    inside = set()
    for st in strokes:
        inside.update(range(st.first_idx, st.last_idx + 1))
    label = {}

    def labelled():
        for idx, raw, ev in events(path, profile):
            if ev is not None and idx not in inside and hasattr(ev, "feature"):
                xy = ev.x1 != ev.x0 or ev.y1 != ev.y0
                label[idx] = feat.TRAVEL if (xy and not ev.e > 0) else (ev.feature or feat.OTHER)
            yield idx, raw, ev

    acc = defaultdict(lambda: [0.0, 0.0])

    def on_line(r):
        f = label.pop(r.idx, None)
        if f is not None:
            a = acc[f]
            a[0] += r.int_a2 + r.int_a2_j
            a[1] += r.time_t

    simulate_events(labelled(), profile, on_line=on_line)
    return {k: (a, t) for k, (a, t) in acc.items()}


# ------------------------------------------------------------------ per-feature overshoot
# Visible surfaces are never run faster than the slicer asked (its F is the quality the
# user chose); inner perimeters and infill may overshoot by --overshoot.
NO_OVERSHOOT = (feat.EXTERNAL_PERIMETER, feat.OVERHANG_PERIMETER, feat.TOP_SOLID_INFILL,
                feat.BRIDGE_INFILL, feat.IRONING)


def feature_overshoot_r(feature, opts) -> float:
    """Overshoot ratio (peak speed over the slicer's F) allowed on a stroke of `feature`."""
    return 0.0 if feature in NO_OVERSHOOT else float(opts.overshoot_r)
