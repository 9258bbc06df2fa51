"""`gcode-opt law`: the optimal law along one path as a table a controller can play back.

Paths: a line, a circular arc, an ellipse (full turn, exact curvature through curve.py), or
a stroke of a G-code file (its straight run of collinear moves, or its arc), with the
duration and end speeds the firmware model gives it unless told otherwise.

Columns (units in the names): t_s, x_mm, y_mm, s_mm, v_mm_s, vx_mm_s, vy_mm_s, a_t_mm_s2
(tangential, along the path), a_n_mm_s2 (normal, v²κ, towards the centre of curvature),
a_mm_s2 (|a|), ax_mm_s2, ay_mm_s2.
"""
from __future__ import annotations

import csv
import io
import json
import math
import sys

import numpy as np

COLUMNS = ("t_s", "x_mm", "y_mm", "s_mm", "v_mm_s", "vx_mm_s", "vy_mm_s", "a_t_mm_s2", "a_n_mm_s2",
           "a_mm_s2", "ax_mm_s2", "ay_mm_s2")


class LawTable:
    def __init__(self, meta: dict, cols: dict):
        self.meta = meta            # path, duration_s, beta_s2, v0/v1, length_mm, integrals...
        self.cols = cols            # column name -> np.ndarray

    def as_dict(self):
        return {**self.meta, "columns": list(COLUMNS),
                "rows": np.column_stack([self.cols[c] for c in COLUMNS]).tolist()}


def _assemble(meta, t, x, y, s, v, a_t, tx, ty, kappa_signed):
    """Columns from the law along the path: unit tangent (tx, ty), signed curvature κ (+ = left)."""
    nx, ny = -ty, tx                                    # left normal
    a_n_signed = kappa_signed * v * v                   # towards the centre when κ > 0
    ax = a_t * tx + a_n_signed * nx
    ay = a_t * ty + a_n_signed * ny
    cols = {"t_s": t, "x_mm": x, "y_mm": y, "s_mm": s, "v_mm_s": v, "vx_mm_s": v * tx, "vy_mm_s": v * ty,
            "a_t_mm_s2": a_t, "a_n_mm_s2": np.abs(a_n_signed), "a_mm_s2": np.hypot(a_t, a_n_signed),
            "ax_mm_s2": ax, "ay_mm_s2": ay}
    return LawTable(meta, {k: np.asarray(c, float) for k, c in cols.items()})


def _meta(kind, params, T, beta, v0, v1, length, mass):
    m = {"path": {"kind": kind, **params}, "duration_s": T, "beta_s2": beta, "v0_mm_s": v0, "v1_mm_s": v1,
         "length_mm": length}
    if mass is not None:
        m["mass_kg"] = mass
        m["alpha_s2_kg"] = beta / mass
    return m


def line_table(x0, y0, x1, y1, T, beta, v0=0.0, v1=0.0, n=101, mass=None):
    from ..laws.line import line_law
    L = math.hypot(x1 - x0, y1 - y0)
    if L <= 0:
        raise ValueError("the line has zero length")
    tx, ty = (x1 - x0) / L, (y1 - y0) / L
    law = line_law(L, T, beta, v0, v1)
    t = np.linspace(0.0, T, n)
    s, v, a = (np.asarray(q, float) for q in law.eval(t))
    meta = _meta("line", {"x0_mm": x0, "y0_mm": y0, "x1_mm": x1, "y1_mm": y1}, T, beta, v0, v1, L, mass)
    return _assemble(meta, t, x0 + tx * s, y0 + ty * s, s, v, a, np.full(n, tx), np.full(n, ty), np.zeros(n))


def circle_table(cx, cy, R, theta0_deg, sweep_deg, T, beta, v0=0.0, v1=0.0, n=101, mass=None):
    from ..laws.circle import solve_circle
    if not (R > 0 and sweep_deg != 0):
        raise ValueError("the arc needs R > 0 and a non-zero sweep")
    phi = math.radians(abs(sweep_deg))
    sgn = 1.0 if sweep_deg > 0 else -1.0
    law = solve_circle(phi, T, beta, v0 / R, v1 / R, R)
    t = np.linspace(0.0, T, n)
    s, v, a = (np.asarray(q, float) for q in law.eval_s(t))
    th = math.radians(theta0_deg) + sgn * s / R
    tx, ty = -np.sin(th) * sgn, np.cos(th) * sgn
    meta = _meta("circle", {"cx_mm": cx, "cy_mm": cy, "r_mm": R, "theta0_deg": theta0_deg,
                            "sweep_deg": sweep_deg}, T, beta, v0, v1, R * phi, mass)
    return _assemble(meta, t, cx + R * np.cos(th), cy + R * np.sin(th), s, v, a, tx, ty,
                     np.full(n, sgn / R))


def ellipse_law(a_d, b_d, T, beta, v0=0.0, v1=0.0):
    """(Ellipse, CurveLaw) for a full counter-clockwise turn from (a, 0)."""
    from ..laws.curve import solve_curve
    from .ellipse import Ellipse
    e = Ellipse(a_d, b_d)
    law = solve_curve(e.kappa, e.dkappa_ds, e.length_d, T, beta, v0, v1)
    return e, law


def ellipse_table(a_d, b_d, T, beta, v0=0.0, v1=0.0, n=101, mass=None):
    e, law = ellipse_law(a_d, b_d, T, beta, v0, v1)
    t = np.linspace(0.0, T, n)
    s, v, a = (np.asarray(q, float) for q in law.eval(t))
    s = np.clip(s, 0.0, e.length_d)
    p = e.p_of_s(s)
    g = e.g(p)
    tx, ty = -a_d * np.sin(p) / g, b_d * np.cos(p) / g
    x, y = e.xy(p)
    meta = _meta("ellipse", {"a_mm": a_d, "b_mm": b_d}, T, beta, v0, v1, e.length_d, mass)
    return _assemble(meta, t, x, y, s, v, a, tx, ty, e.kappa_p(p))


def gcode_stroke(path, line_number, profile):
    """The stroke starting at 1-based line_number: ('line', x0, y0, x1, y1, ...) or ('arc', move),
    with its firmware time, start and end speed, and effective masses (m, m2/m)."""
    from .. import state as st
    from ..firmware.simulate import simulate_events
    from ..strokes import COLLINEAR_SIN
    target = line_number - 1
    found = {"first": None, "last": None, "open": True}
    recs = {}

    def feed():
        for idx, raw, ev in st.events(path, profile):
            if type(ev) is st.Move:
                f = found
                if idx == target:
                    if ev.kind == st.EONLY:
                        raise ValueError(f"{path}:{line_number} moves only the extruder")
                    f["first"] = f["last"] = ev
                elif f["first"] is not None and f["open"]:
                    m0, last = f["first"], f["last"]
                    d = math.hypot(ev.x1 - ev.x0, ev.y1 - ev.y0)
                    ux, uy = m0.x1 - m0.x0, m0.y1 - m0.y0
                    n0 = math.hypot(ux, uy)
                    ok = (m0.kind == st.LINE and ev.kind == st.LINE and ev.idx == last.idx + 1 and d > 0
                          and ev.v == m0.v and ev.feature == m0.feature and ev.z0 == ev.z1 == m0.z0
                          and abs((ev.x1 - ev.x0) * uy - (ev.y1 - ev.y0) * ux) <= COLLINEAR_SIN * d * n0
                          and (ev.x1 - ev.x0) * ux + (ev.y1 - ev.y0) * uy > 0)
                    if ok:
                        f["last"] = ev
                    else:
                        f["open"] = False
            elif ev is not None and found["first"] is not None:
                found["open"] = False
            yield idx, raw, ev

    simulate_events(feed(), profile, on_line=lambda r: recs.__setitem__(r.idx, r))
    m0, m1 = found["first"], found["last"]
    if m0 is None:
        raise ValueError(f"{path}:{line_number} is not a move")
    T = sum(recs[i].time_t for i in range(m0.idx, m1.idx + 1) if i in recs)
    v0, v1 = recs[m0.idx].start_v, recs[m1.idx].end_v
    if m0.kind == st.ARC:
        th0, th1 = m0.arc.theta0, m0.arc.theta0 + m0.arc.sweep
        ux, uy = -math.sin(0.5 * (th0 + th1)), math.cos(0.5 * (th0 + th1))
    else:
        L = math.hypot(m1.x1 - m0.x0, m1.y1 - m0.y0)
        ux, uy = (m1.x1 - m0.x0) / L, (m1.y1 - m0.y0) / L
    m, m2 = profile.moving_mass_kg(ux, uy)
    return m0, m1, T, v0, v1, m, m2 / m


def gcode_table(path, line_number, profile, T=None, beta=None, alpha=None, mass=None, v0=None, v1=None, n=101):
    from .. import state as st
    m0, m1, T_fw, v0_fw, v1_fw, m_eff, m_beta = gcode_stroke(path, line_number, profile)
    T = T or T_fw
    v0 = v0_fw if v0 is None else v0
    v1 = v1_fw if v1 is None else v1
    if beta is None:
        beta = alpha * (mass if mass is not None else m_beta)
    if m0.kind == st.ARC:
        a = m0.arc
        tab = circle_table(a.cx, a.cy, a.r, math.degrees(a.theta0), math.degrees(a.sweep), T, beta, v0, v1, n,
                           mass or m_eff)
    else:
        tab = line_table(m0.x0, m0.y0, m1.x1, m1.y1, T, beta, v0, v1, n, mass or m_eff)
    tab.meta["mass_kg"] = mass or m_eff
    tab.meta["alpha_s2_kg"] = beta / (mass or m_beta)      # the pipeline's beta = alpha * m2/m
    tab.meta["path"].update({"gcode": path, "first_line": m0.idx + 1, "last_line": m1.idx + 1,
                             "firmware_time_s": T_fw, "firmware_v0_mm_s": v0_fw, "firmware_v1_mm_s": v1_fw})
    return tab


def law_table_from_args(a) -> LawTable:
    if a.beta is None and a.alpha is None:
        raise ValueError("give the weight: --beta S2, or --alpha S2_PER_KG (with --mass)")
    if a.points < 2:
        raise ValueError("--points must be at least 2")
    if a.gcode:
        if a.line_number is None:
            raise ValueError("--gcode needs --line-number N")
        from ..profile import load_profile
        return gcode_table(a.gcode, a.line_number, load_profile(a.profile), a.duration, a.beta, a.alpha,
                           a.mass, a.v0, a.v1, a.points)
    mass = a.mass if a.mass is not None else (1.0 if a.alpha is not None else None)
    beta = a.beta if a.beta is not None else a.alpha * mass
    T = a.duration or 1.0
    v0 = a.v0 or 0.0
    v1 = a.v1 or 0.0
    if a.line:
        return line_table(*a.line, T, beta, v0, v1, a.points, mass)
    if a.circle:
        return circle_table(*a.circle, T, beta, v0, v1, a.points, mass)
    return ellipse_table(*a.ellipse, T, beta, v0, v1, a.points, mass)


def to_csv(tab: LawTable) -> str:
    buf = io.StringIO()
    buf.write("# gcode-opt law: " + json.dumps(tab.meta) + "\n")
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(COLUMNS)
    for row in np.column_stack([tab.cols[c] for c in COLUMNS]):
        w.writerow([repr(float(x)) for x in row])
    return buf.getvalue()


def write_table(tab: LawTable, fmt: str, out=None):
    text = to_csv(tab) if fmt == "csv" else json.dumps(tab.as_dict(), indent=1) + "\n"
    if out:
        with open(out, "w") as fh:
            fh.write(text)
    else:
        sys.stdout.write(text)
