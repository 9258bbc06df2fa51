"""Speed and acceleration against time for the report's representative strokes.

For each representative (data.py picks them) this builds the curves to draw on one pair of
axes: the original file's trapezoids as the firmware model plans them (phase by phase, from
its blocks), the processed file's as-executed profile, and the optimal law itself (line.py
for straight strokes, circle.py for arcs, curve.py for curved polylines).
"""
from __future__ import annotations

import math

import numpy as np

from ..laws.line import line_law
from .trace import profile_points

N_LAW = 400
# the Chebyshev tail a drawn curve law is solved to (laws.curve.solve_curve's tail_tol): far
# below a pixel of N_LAW points.  Its default (1e-11) climbed the N ladder to 512 on a
# polyline's spline curvature, whose coefficients fall slowly: on the gyroid plate's curve
# ~6 s of CPU and ~37 MB of `--report`'s peak, for a law that then failed (5.7e-11 at N = 512)
# and was not drawn
PLOT_TAIL_TOL = 1e-8


def _series(t, v, a, label):
    return {"label": label, "t_v": np.asarray(t, float), "v": np.asarray(v, float),
            "t_a": np.asarray(t, float), "a": np.asarray(a, float), "steps": False}


def _firmware(tr, first, last, label):
    tv, v, ta, a = profile_points(tr.blocks, tr.block_range(first, last))
    return {"label": label, "t_v": tv, "v": v, "t_a": ta, "a": a, "steps": True}


def default_beta(data):
    """β (s^2) to draw the optimal law of strokes the pipeline did not re-time."""
    rows = data["per_stroke"]
    col = rows.col("beta_s2") if hasattr(rows, "col") else [r["beta_s2"] for r in rows]
    betas = [b for b in col if b is not None]
    if betas:
        return float(np.median(betas))
    return 1e-3


def _row_at_line(rows, line):
    """The first per-stroke row of that line (a StrokeTable read by its column)."""
    if hasattr(rows, "col"):
        return rows[rows.col("line").index(line)]
    return next(r for r in rows if r["line"] == line)


def stroke_curves(rep, data, ctx):
    """dict(title, note, curves[list of series], feed_v) for one representative, or None."""
    if rep.get("line") is None:
        return None
    tr0, tr1 = ctx.tr0, ctx.tr1
    o0 = rep["line"] - 1
    o1 = o0 + rep["lines"] - 1
    curves = [_firmware(tr0, o0, o1, "original: firmware trapezoids")]
    m0 = tr0.moves[o0]
    feed = m0.v
    if rep["retimed"]:
        row = _row_at_line(data["per_stroke"], rep["line"])
        f = next(f for f in ctx.fences if f.orig_first == o0)
        curves.append(_firmware(tr1, f.out_first, f.out_last, "re-timed: as executed (segments)"))
        T = row["time_s"].get("law") or f.marker_time_s
        beta = row["beta_s2"] if row["beta_s2"] is not None else math.inf
        if T and math.isfinite(T):
            btxt = "∞ (min ∫a²)" if not math.isfinite(beta) else f"{beta:.3g} s²"
            if row.get("kind") == "arc":
                try:
                    law = _arc_law(m0, T, beta if math.isfinite(beta) else 1e6 * T * T,
                                   row["v0_mm_s"], row["v1_mm_s"])
                    law["label"] = f"optimal circle law (planned), β = {btxt}"
                    curves.append(law)
                except Exception:
                    pass
            elif row.get("kind") == "curve":
                try:
                    law = _curve_law(tr0, o0, o1, T, beta if math.isfinite(beta) else 1e6 * T * T,
                                     row["v0_mm_s"], row["v1_mm_s"])
                    law["label"] = f"optimal law along the curve (planned), β = {btxt}"
                    curves.append(law)
                except Exception:            # a law that does not converge is not drawn
                    pass
            else:
                law = line_law(row["length_mm"], T, beta, row["v0_mm_s"], row["v1_mm_s"])
                t = np.linspace(0.0, T, N_LAW)
                _, v, a = law.eval(t)
                curves.append(_series(t, v, a, f"optimal law (planned), β = {btxt}"))
        title = (f"{rep['role']}: line {rep['line']}, {row['length_mm']:.1f} mm {row['feature']}, "
                 f"layer {row['layer']}")
        return {"title": title, "note": rep.get("note", ""), "curves": curves, "feed_v": feed}
    # not re-timed: arc or curve, unchanged in the output
    T = tr0.line_sum(o0, o1, "time_t")
    v0 = tr0.lines.value(o0, "start_v")
    v1 = tr0.lines.value(o1, "end_v")
    beta = default_beta(data)
    curves[0]["label"] = "firmware trapezoids (same before and after)"
    law = None
    try:
        if rep["role"] == "arc":
            law = _arc_law(m0, T, beta, v0, v1)
        else:
            law = _curve_law(tr0, o0, o1, T, beta, v0, v1)
    except Exception as e:          # a law that does not converge is a note, not a failure
        rep_note = f" (optimal law not drawn: {e})"
    else:
        rep_note = ""
    if law is not None:
        curves.append(law)
    title = f"{rep['role']}: line {rep['line']}" + (f"–{o1 + 1}" if o1 > o0 else "") + \
        f", {rep['length_mm']:.1f} mm {rep['feature']}, layer {rep['layer']}"
    return {"title": title, "note": rep.get("note", "") + rep_note, "curves": curves, "feed_v": feed}


def _arc_law(m, T, beta, v0, v1):
    from ..laws.circle import solve_circle
    arc = m.arc
    R = arc.r
    law = solve_circle(abs(arc.sweep), T, beta, v0 / R, v1 / R, R)
    t = np.linspace(0.0, T, N_LAW)
    _, v, a = law.eval_s(t)
    s = _series(t, v, a, f"optimal circle law, same T, β = {beta:.3g} s²")
    s["a_n"] = v * v / R
    return s


def _curve_law(tr, o0, o1, T, beta, v0, v1):
    from ..laws.curve import curvature_from_polyline, solve_curve
    pts = [(tr.moves[o0].x0, tr.moves[o0].y0)] + [(tr.moves[i].x1, tr.moves[i].y1) for i in range(o0, o1 + 1)]
    k = curvature_from_polyline(np.array(pts))
    law = solve_curve(k.kappa, k.dkappa_ds, k.length_d, T, beta, v0, v1, k.d2kappa_ds2, tail_tol=PLOT_TAIL_TOL)
    t = np.linspace(0.0, T, N_LAW)
    s_, v, a = law.eval(t)
    s = _series(t, v, a, f"optimal law along the curve, same T, β = {beta:.3g} s²")
    s["a_n"] = np.abs(k.kappa(s_)) * v * v
    return s
