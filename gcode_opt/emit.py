"""Emit: write one re-timed stroke as G-code text.

The block replaces the stroke's original lines and is fenced by two marker comments so
that a reader (or `verify.py`) can tell our lines from the slicer's:

    ; gcode-opt begin: replaces <m> lines, kind=line|curve|arc, <n> segments, T=<s>, beta=<s^2>
    SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=0     (Klipper: its smoothing would cap the law)
    M204 S<a_1>                                   (flavour's print-acceleration command)
    G1 X.. Y.. E.. F..                            (segment 1)
    ...
    M204 S<accel before>  /  SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=<before>  /  G1 F<feed before>
    ; gcode-opt end

Original vertices keep their original coordinate and E text; new points are
interpolated inside the original move they split, in integer units of the file's own
precision, so cumulative E at every original vertex is exactly the original's.
"""
from __future__ import annotations

import math

from .words import decimals, param_texts, split_comment, strip_checksum

BEGIN = "; gcode-opt begin"
END = "; gcode-opt end"


def accel_command(flavour: str, accel_a: float, extruding: bool, round_up: bool = True) -> str:
    """The flavour's command for the acceleration of printing (or travel) moves.  Segment
    accelerations are rounded up so a ramp reaches its knot rather than falling short."""
    if not (math.isfinite(accel_a) and accel_a > 0.0):
        raise ValueError(f"acceleration {accel_a!r} is not a positive number")   # M204 S0 stops Klipper
    if round_up:
        a = _num(max(math.ceil(accel_a * 10.0 - 1e-9) / 10.0, 0.1), 1)
    else:                                 # a restore: the value in force, not a rounded one
        a = _num(accel_a, 3 if accel_a >= 1.0 else 8)
        if a == "0":
            raise ValueError(f"acceleration {accel_a!r} has no plain decimal text")
    if flavour in ("klipper", "marlin-legacy"):
        return f"M204 S{a}"
    return f"M204 {'P' if extruding else 'T'}{a}"


def _feed_text(feed_v: float) -> str:
    """F (mm/min) of a segment, rounded up: never below the knot speed, never 0."""
    if not (math.isfinite(feed_v) and feed_v > 0.0):
        raise ValueError(f"feed {feed_v!r} is not a positive number")
    return _num(max(math.ceil(feed_v * 600.0 - 1e-6) / 10.0, 0.1), 1)


def _num(x: float, dec: int) -> str:
    s = f"{x:.{dec}f}"
    if "." in s:
        s = s.rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def _num1(x: float) -> str:
    """_num(x, 1) for x >= 0.1 (a rounded-up accel or feed): one decimal, ".0" dropped."""
    s = f"{x:.1f}"
    return s[:-2] if s[-1] == "0" else s


def _exact_text(x: float) -> str:
    """Plain decimal text of a value in force (12 significant digits, never an exponent):
    a restore must give back the slicer's F0.1884, not F0.188.  The value went through
    /60 and *60, so 12 digits drop that float noise and keep every digit a slicer writes."""
    if not (math.isfinite(x) and x > 0.0):
        raise ValueError(f"feed {x!r} is not a positive number")
    return _num(x, max(12 - (math.floor(math.log10(x)) + 1), 0))


def _start_decimals(text: str) -> int:
    """Decimals a start-point text really carries (the pipeline writes it with 8 digits:
    trailing zeros are not precision).  Capped at 6: past that it is float noise."""
    frac = text.partition(".")[2].rstrip("0")
    return min(len(frac), 6)


def _units(text: str, dec: int) -> int:
    """Exact integer value of a decimal text in units of 10^-dec (digits past dec cut)."""
    # one int() of the digits with the point taken out: the texts are the strict
    # tokenizer's numbers; anything else takes the long way below
    whole, _, frac = text.partition(".")
    n = len(frac)
    digits = whole + frac if n <= dec else whole + frac[:dec]
    if digits.isascii() and (digits.isdigit() or (digits[1:].isdigit() and digits[0] in "+-")):
        v = int(digits)
        return v * 10 ** (dec - n) if n < dec else v
    return _units_slow(text, dec)


def _units_slow(text: str, dec: int) -> int:
    neg = text.startswith("-")
    t = text.lstrip("+-")
    whole, _, frac = t.partition(".")
    frac = (frac + "0" * dec)[:dec]
    v = int(whole or "0") * 10 ** dec + int(frac or "0")
    return -v if neg else v


def _fmt_units(u: int, dec: int) -> str:
    """_num(u / 10**dec, dec) done in integers (the same text, without float formatting)."""
    if dec <= 0:
        return str(u)
    digits = str(-u if u < 0 else u)
    if len(digits) <= dec:
        digits = "0" * (dec + 1 - len(digits)) + digits
    whole, frac = digits[:-dec], digits[-dec:].rstrip("0")
    if u < 0 and (whole != "0" or frac):
        whole = "-" + whole
    return f"{whole}.{frac}" if frac else whole


def _floats(xs) -> list:
    """A list of Python floats from a numpy array or a sequence."""
    return xs.tolist() if hasattr(xs, "tolist") else [float(x) for x in xs]


class StrokeText:
    """What emission needs from the original lines of one stroke."""

    def __init__(self, raws, x_start_text, y_start_text, e_start_units):
        self.raws = raws
        self.x_start_text, self.y_start_text = x_start_text, y_start_text
        self.comments = []
        xs, ys, es, given = [], [], [], []
        xt, yt = x_start_text, y_start_text
        for raw in raws:
            body = raw.rstrip("\r\n")
            code, comment = split_comment(body)
            if code[:1] != "G" or "*" in code:     # else there is no N word or checksum to drop
                code, _ = strip_checksum(code)
            p = param_texts(code)
            xt = p.get("X", xt)
            yt = p.get("Y", yt)
            xs.append(xt)
            ys.append(yt)
            es.append(p.get("E", "0"))
            given.append("E" in p)
            self.comments.append(comment)
        self.x_texts, self.y_texts, self.e_texts = xs, ys, es
        self.e_given = given          # the line has an E word (the validator sums those)
        # the start point's precision counts too (a 4-decimal start, 3-decimal end: new
        # points rounded to 3 decimals would be up to 0.0015 mm off the segment)
        self.dec_xy = max([decimals(t) for t in xs + ys] + [_start_decimals(x_start_text),
                                                            _start_decimals(y_start_text), 3])
        self.dec_e = max([decimals(t) for t in es] + [5])
        self.e_start_units = e_start_units
        self.newline = raws[0][len(raws[0].rstrip("\r\n")):] or "\n"


def _closing(flavour, accel_restore, extruding, mcr_restore, feed_restore_v, nl):
    """Lines that end every block: the original's acceleration, Klipper's cruise ratio
    and the modal F back in force, then the end marker."""
    out = [accel_command(flavour, accel_restore, extruding, round_up=False) + nl]
    if flavour == "klipper":
        out.append(f"SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO={_num(mcr_restore, 3)}{nl}")
    out.append(f"G1 F{_exact_text(feed_restore_v * 60.0)}{nl}")
    out.append(f"{END}{nl}")
    return out


def emit_stroke(st: StrokeText, ends_d, s, v, accels, feeds, *, x0_text, y0_text, e_rel, flavour,
                accel_restore, mcr_restore, feed_restore_v, extruding=True, header="", first_cmds=None):
    """Text of the block replacing the stroke.  s, v: knots (mm, mm/s) including every
    original vertex (ends_d); accels (mm/s^2) and feeds (mm/s): one per segment.
    first_cmds: (before, after) lines around the first move (a junction command that
    slows the corner into the stroke, and the value in force back: corners.py)."""
    nl = st.newline
    dxy, de = st.dec_xy, st.dec_e
    # Python floats, not numpy scalars: the same IEEE numbers, a fraction of the per-use cost
    s, accels, feeds = _floats(s), _floats(accels), _floats(feeds)
    out = [f"{BEGIN}{header}{nl}"]
    if flavour == "klipper":
        out.append(f"SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=0{nl}")
    # integer units of every original vertex
    xu = [_units(x0_text, dxy)] + [_units(t, dxy) for t in st.x_texts]
    yu = [_units(y0_text, dxy)] + [_units(t, dxy) for t in st.y_texts]
    if e_rel:
        e_move_u = [_units(t, de) for t in st.e_texts]
    else:
        ev = [st.e_start_units] + [_units(t, de) for t in st.e_texts]
        e_move_u = [ev[i + 1] - ev[i] for i in range(len(st.e_texts))]
    starts_d = [0.0] + list(ends_d[:-1])
    move = 0
    e_done_u = 0                         # units extruded so far inside the current move
    e_abs_u = st.e_start_units
    last_accel = None
    last_a = None
    k_total = len(s) - 1
    accel_word = accel_command(flavour, 1.0, extruding)[:-1]      # "M204 S" / "M204 P" / "M204 T"
    isfinite, ceil = math.isfinite, math.ceil
    tol_d = 1e-9 * max(1.0, ends_d[-1])
    for k in range(1, k_total + 1):
        # which original move does this segment end in?  (vertices are knots)
        if s[k] > ends_d[move] + tol_d:
            raise AssertionError("a knot skipped an original vertex")   # would lose its E
        d_move = ends_d[move] - starts_d[move]
        frac = 1.0 if d_move <= 0 else min(1.0, max(0.0, (s[k] - starts_d[move]) / d_move))
        at_vertex = abs(s[k] - ends_d[move]) <= tol_d
        if at_vertex:
            xt, yt = st.x_texts[move], st.y_texts[move]
            e_target_u = e_move_u[move]
            comment = st.comments[move]
        else:
            xt = _fmt_units(round(xu[move] + (xu[move + 1] - xu[move]) * frac), dxy)
            yt = _fmt_units(round(yu[move] + (yu[move + 1] - yu[move]) * frac), dxy)
            e_target_u = round(e_move_u[move] * frac)
            comment = ""
        de_u = e_target_u - e_done_u
        e_done_u = e_target_u
        e_abs_u += de_u
        a = accels[k - 1]
        if a != last_a:                  # the same value gives the same command
            if not (isfinite(a) and a > 0.0):
                accel_command(flavour, a, extruding)     # raises, saying why
            # accel_command(flavour, a, extruding) written out: once per segment
            cmd = accel_word + _num1(max(ceil(a * 10.0 - 1e-9) / 10.0, 0.1))
            last_a = a
            if cmd != last_accel:
                out.append(cmd + nl)
                last_accel = cmd
        f = feeds[k - 1]                 # _feed_text written out
        if not (isfinite(f) and f > 0.0):
            _feed_text(f)                # raises, saying why
        f = _num1(max(ceil(f * 600.0 - 1e-6) / 10.0, 0.1))
        if e_rel:
            e_txt = _fmt_units(de_u, de)
        elif at_vertex:
            e_txt = st.e_texts[move]
        else:
            e_txt = _fmt_units(e_abs_u, de)
        words = f"G1 X{xt} Y{yt}"
        if extruding:
            words += f" E{e_txt}"
        if k == 1 and first_cmds:
            out.append(first_cmds[0] + nl)
        out.append(f"{words} F{f}{(' ' + comment) if comment else ''}{nl}")
        if k == 1 and first_cmds:
            out.append(first_cmds[1] + nl)
        if at_vertex:
            e_done_u = 0
            if move < len(ends_d) - 1:
                move += 1
    out += _closing(flavour, accel_restore, extruding, mcr_restore, feed_restore_v, nl)
    return "".join(out)


def emit_arc(raw, x0_text, y0_text, e_start, arc, s, accels, feeds, *, e_rel, flavour, accel_restore,
             mcr_restore, feed_restore_v, header=""):
    """Text replacing one G2/G3 (I/J form) by sub-arcs ending at arc lengths s[1:] (s[-1] =
    the arc's length).  Every sub-arc keeps the original centre exactly (in integer units of
    the file's precision: I/J = centre - the sub-arc's own rounded start); interior end
    points are on the circle, rounded; the last one is the original end text.  E is split
    in proportion to arc length in integer units, exact at the end."""
    body = raw.rstrip("\r\n")
    nl = raw[len(body):] or "\n"
    code, comment = split_comment(body)
    code, _ = strip_checksum(code)
    p = param_texts(code)
    cw = arc.sweep < 0
    x1t, y1t = p.get("X", x0_text), p.get("Y", y0_text)
    it, jt = p.get("I", "0"), p.get("J", "0")
    dxy = max([decimals(t) for t in (x1t, y1t, it, jt) if t is not x0_text and t is not y0_text]
              + [_start_decimals(x0_text), _start_decimals(y0_text), 3])
    de = max(decimals(p.get("E", "0")), 5)
    x0u, y0u = _units(x0_text, dxy), _units(y0_text, dxy)
    cxu, cyu = x0u + _units(it, dxy), y0u + _units(jt, dxy)
    scale = 10 ** dxy
    e_start_u = int(round(e_start * 10 ** de))
    e_total_u = _units(p.get("E", "0"), de) if e_rel else _units(p.get("E", "0"), de) - e_start_u
    S = s[-1]
    out = [f"{BEGIN}{header}{nl}"]
    if flavour == "klipper":
        out.append(f"SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=0{nl}")
    cmd = "G2" if cw else "G3"
    sxu, syu = x0u, y0u
    e_done_u = 0
    last_accel = None
    n = len(s) - 1
    for k in range(1, n + 1):
        if k == n:
            xt, yt = x1t, y1t
            exu, eyu = _units(x1t, dxy), _units(y1t, dxy)
            e_u = e_total_u
        else:
            th = arc.theta0 + arc.sweep * s[k] / S
            exu = round((arc.cx + arc.r * math.cos(th)) * scale)
            eyu = round((arc.cy + arc.r * math.sin(th)) * scale)
            xt, yt = _fmt_units(exu, dxy), _fmt_units(eyu, dxy)
            e_u = round(e_total_u * s[k] / S)
        de_u = e_u - e_done_u
        e_done_u = e_u
        cmd_a = accel_command(flavour, accels[k - 1], True)
        if cmd_a != last_accel:
            out.append(cmd_a + nl)
            last_accel = cmd_a
        f = _feed_text(feeds[k - 1])
        e_txt = _fmt_units(de_u, de) if e_rel else _fmt_units(e_start_u + e_u, de)
        if k == n and not e_rel:
            e_txt = p.get("E")
        words = (f"{cmd} X{xt} Y{yt} I{_fmt_units(cxu - sxu, dxy)} J{_fmt_units(cyu - syu, dxy)} "
                 f"E{e_txt} F{f}")
        out.append(f"{words}{(' ' + comment) if (comment and k == n) else ''}{nl}")
        sxu, syu = exu, eyu
    out += _closing(flavour, accel_restore, True, mcr_restore, feed_restore_v, nl)
    return "".join(out)
