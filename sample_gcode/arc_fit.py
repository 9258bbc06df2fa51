#!/usr/bin/env python3
"""arc_fit.py - an ArcWelder-like post-processor, written for gcode-opt's test samples.

No slicer available here emits G2/G3 (PrusaSlicer 2.5 has no arc fitting; ArcWelder is not
on PyPI), so the arc samples are made from real PrusaSlicer output with this script:

    python3 sample_gcode/arc_fit.py IN.gcode OUT.gcode [--tol 0.02]

It replaces runs of >= 3 consecutive extruding `G1 X.. Y.. E..` lines (absolute XY,
relative E - M83 -, no Z, no F except on the run's first line, nothing in between) whose
points all lie within --tol mm of one circle, turning one way, by a single
`G2/G3 X Y I J E` (I/J from the arc's start, rounded to 3 decimals; X/Y the run's last
point, copied; E the exact sum of the run's E in the file's precision).  Like ArcWelder it
also checks the mid-point of every replaced segment against the circle, so the arc never
strays more than --tol from the original polyline.  Radii outside [0.5, 1000] mm are not
fitted.  Everything else is copied byte for byte.
"""
from __future__ import annotations

import math
import re
import sys

_WORD = re.compile(r"([A-Za-z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")
R_MIN, R_MAX = 0.5, 1000.0


def _words(code):
    return {k.upper(): v for k, v in _WORD.findall(code)}


def _units(t, dec):
    neg = t.startswith("-")
    w, _, f = t.lstrip("+-").partition(".")
    v = int(w or "0") * 10 ** dec + int(((f + "0" * dec)[:dec]) or "0")
    return -v if neg else v


def _fmt(u, dec):
    s = f"{u / 10 ** dec:.{dec}f}".rstrip("0").rstrip(".")
    return "0" if s in ("", "-0") else s


def _circle(a, b, c):
    ax, ay = a
    bx, by = b
    cx, cy = c
    d = 2.0 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
    if abs(d) < 1e-12:
        return None
    a2, b2, c2 = ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy
    ux = (a2 * (by - cy) + b2 * (cy - ay) + c2 * (ay - by)) / d
    uy = (a2 * (cx - bx) + b2 * (ax - cx) + c2 * (bx - ax)) / d
    return ux, uy, math.hypot(ax - ux, ay - uy)


def _fits(pts, tol):
    """(cx, cy, r, ccw) if pts (>= 4) lie on one circle turning one way, else None."""
    c = _circle(pts[0], pts[len(pts) // 2], pts[-1])
    if c is None:
        return None
    cx, cy, r = c
    if not R_MIN <= r <= R_MAX:
        return None
    sweep = 0.0
    sign = 0
    for (x0, y0), (x1, y1) in zip(pts[:-1], pts[1:]):
        if abs(math.hypot(x1 - cx, y1 - cy) - r) > tol:
            return None
        mx, my = (x0 + x1) / 2, (y0 + y1) / 2
        if abs(math.hypot(mx - cx, my - cy) - r) > tol:
            return None
        cr = (x0 - cx) * (y1 - cy) - (y0 - cy) * (x1 - cx)
        s = 1 if cr > 0 else -1
        if sign and s != sign:
            return None
        sign = s
        sweep += math.atan2(abs(cr), (x0 - cx) * (x1 - cx) + (y0 - cy) * (y1 - cy))
    if sweep >= 2 * math.pi - 1e-3:
        return None
    return cx, cy, r, sign > 0


def convert(lines, tol=0.02):
    out = []
    x = y = 0.0
    xt, yt = "0", "0"
    rel_e = False
    abs_xy = True
    run = []          # (raw, x_text, y_text, e_text, f_text)

    def flush():
        nonlocal run
        if not run:
            return
        i = 0
        sx, sy, sxt, syt = run[0][5]
        pts = [(sx, sy)] + [(float(r[1]), float(r[2])) for r in run]
        while i < len(run):
            best = None
            j = i + 3
            while j <= len(run):
                f = _fits(pts[i:j + 1], tol)
                if f is None:
                    break
                best = (j, f)
                j += 1
            if best is None:
                out.append(run[i][0])
                i += 1
                continue
            j, (cx, cy, r, ccw) = best
            seg = run[i:j]
            dxy = max(3, *(len(t.partition(".")[2]) for s in seg for t in (s[1], s[2])))
            de = max(5, *(len(s[3].partition(".")[2]) for s in seg))
            x0t, y0t = (sxt, syt) if i == 0 else (run[i - 1][1], run[i - 1][2])
            x0, y0 = float(x0t), float(y0t)
            iu = round((cx - x0) * 10 ** dxy)
            ju = round((cy - y0) * 10 ** dxy)
            e_u = sum(_units(s[3], de) for s in seg)
            words = f"{'G3' if ccw else 'G2'} X{seg[-1][1]} Y{seg[-1][2]} I{_fmt(iu, dxy)} J{_fmt(ju, dxy)} E{_fmt(e_u, de)}"
            if seg[0][4]:
                words += f" F{seg[0][4]}"
            nl = seg[-1][0][len(seg[-1][0].rstrip("\r\n")):]
            out.append(words + nl)
            i = j
        run = []

    for raw in lines:
        code = raw.split(";", 1)[0]
        toks = code.split()
        cmd = toks[0].upper() if toks else ""
        if cmd == "G1" and not raw.rstrip("\r\n").count(";"):
            w = _words(code)
            w.pop("G", None)
            if (abs_xy and rel_e and set(w) <= {"X", "Y", "E", "F"} and "E" in w and float(w["E"]) > 0
                    and ("X" in w or "Y" in w) and not ("F" in w and run)):
                nx, ny = w.get("X", xt), w.get("Y", yt)
                if not run:
                    start = (x, y, xt, yt)
                run.append((raw, nx, ny, w["E"], w.get("F"), start))
                xt, yt, x, y = nx, ny, float(nx), float(ny)
                continue
        flush()
        out.append(raw)
        if cmd in ("G0", "G1", "G2", "G3", "G92"):
            w = _words(code)
            if cmd == "G92" or abs_xy:
                if "X" in w:
                    xt, x = w["X"], float(w["X"])
                if "Y" in w:
                    yt, y = w["Y"], float(w["Y"])
            else:
                x += float(w.get("X", 0))
                y += float(w.get("Y", 0))
                xt, yt = repr(x), repr(y)
        elif cmd == "M83":
            rel_e = True
        elif cmd == "M82":
            rel_e = False
        elif cmd == "G90":
            abs_xy = True
        elif cmd == "G91":
            abs_xy = False
    flush()
    return out


def main(argv):
    tol = 0.02
    if "--tol" in argv:
        k = argv.index("--tol")
        tol = float(argv[k + 1])
        del argv[k:k + 2]
    src, dst = argv[1], argv[2]
    with open(src, newline="") as fh:
        lines = fh.readlines()
    out = convert(lines, tol)
    n_arcs = sum(1 for l in out if l[:2] in ("G2", "G3"))
    with open(dst, "w", newline="") as fh:
        fh.write(f"; arcs fitted by gcode-opt sample_gcode/arc_fit.py (tolerance {tol} mm) from {src.split('/')[-1]}\n")
        fh.writelines(out)
    print(f"{dst}: {len(lines)} -> {len(out) + 1} lines, {n_arcs} arcs")


if __name__ == "__main__":
    main(sys.argv)
