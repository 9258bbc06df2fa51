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

import functools
import math
import operator
import os

import numpy as np

from . import native
from .words import compiled_on_first_call, decimals, param_texts, split_comment, strip_checksum

# The compiled rewrite core (_emit.c, module _gcode_opt_emit): optional, the same texts as
# the Python code below, which runs where it is missing or declines a case
# (tests/test_speed_rewrite_core.py)
CORE_MOD, CORE_WHY = native.load("_gcode_opt_emit",
                                 os.path.join(os.path.dirname(os.path.abspath(__file__)), "_emit.c"),
                                 "emit core")
CORE = "c" if CORE_MOD is not None else "python"
if CORE_MOD is not None and hasattr(CORE_MOD, "set_types"):
    import array as _array
    # what the core reads as a sequence of doubles besides lists and bytes: a 1-D float64
    # ndarray (its tobytes()) and an array.array('d') (pipeline._rewrite_bytes passes them as they are)
    # (the probe: the core reads such an ndarray's doubles in place once it has checked
    # that it reads this one's right)
    _probe = np.array([0.5, 1.5, 2.5])
    CORE_MOD.set_types(np.ndarray, np.dtype(np.float64), _array.array, _probe, _probe.ctypes.data)
    del _probe

BEGIN = "; gcode-opt begin"
END = "; gcode-opt end"


def accel_command(flavour: str, accel_a: float, extruding: bool, round_up: bool = True) -> str:
    """The flavour's command for the acceleration of printing (or travel) moves.  Segment
    accelerations are rounded up so a ramp reaches its knot rather than falling short."""
    if not (math.isfinite(accel_a) and accel_a > 0.0):
        raise ValueError(f"acceleration {accel_a!r} is not a positive number")   # M204 S0 stops Klipper
    if round_up:
        a = _tenths_up(math.ceil(accel_a * 10.0 - 1e-9))
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
    return _tenths_up(math.ceil(feed_v * 600.0 - 1e-6))


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
        got = NotImplemented
        if CORE_MOD is not None:  # the compiled reading, its decimals too
            got = CORE_MOD.plain_moves(raws, x_start_text, y_start_text)
            if got is not None and got is not NotImplemented:
                (self.x_texts, self.y_texts, self.e_texts, self.e_given, self.comments, self.values,
                 self.dec_xy, self.dec_e) = got
                self.e_start_units = e_start_units
                self.newline = raws[0][len(raws[0].rstrip("\r\n")):] or "\n"
                return
        if got is NotImplemented:
            got = _plain_moves_py(raws)
        if got is not None:      # every line "G1 X Y [E] [;comment]": one regex over the stroke
            xs, ys, es, given, self.comments, self.values = got
        else:
            self.values = None        # (x, y, given e) floats of a plain stroke
            xs, ys, es, given = self._read_lines(raws, x_start_text, y_start_text)
        self.x_texts, self.y_texts, self.e_texts = xs, ys, es
        self.e_given = given          # the line has an E word (the validator sums those)
        # the start point's precision counts too (a 4-decimal start, 3-decimal end: new
        # points rounded to 3 decimals would be up to 0.0015 mm off the segment)
        self.dec_xy = max(_decimals_at_least(xs + ys, 3), _start_decimals(x_start_text),
                          _start_decimals(y_start_text))
        self.dec_e = _decimals_at_least(es, 5)
        self.e_start_units = e_start_units
        self.newline = raws[0][len(raws[0].rstrip("\r\n")):] or "\n"

    def _read_lines(self, raws, xt, yt):
        """The general reading (any line the strict tokenizer takes): word by word."""
        self.comments = []
        xs, ys, es, given = [], [], [], []
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
        return xs, ys, es, given


# a stroke's usual line, "G1 [F<n> ]X<n> Y<n> [E<n>]" and an optional comment (Cura names
# the feed first on a run's first move; nothing the rewrite writes reads it, and the strict
# tokenizer checks its number as float() does: below), as the strict
# tokenizer reads it (words.py: the code part before ';', trailing blanks and the line
# end dropped).  The pattern starts at the line's "\n" (a literal prefix: found fast); a
# number is any run of [-.0-9] here, and the plain-decimal grammar is float()'s check:
# over those characters float() takes exactly words.py's numbers (without '+').  Compiled at
# their first call (as _MORE_DECIMALS'): the compiled core reads those lines in most runs
_MOVE_LINES = compiled_on_first_call(
    globals(), "_MOVE_LINES",
    r"\nG1 (?:F([-.0-9]+) )?X([-.0-9]+) Y([-.0-9]+)(?: E([-.0-9]+))?[ \t]*(;[^\r\n]*)?\r?(?=\n)", "findall")
_MOVE_XYE = compiled_on_first_call(globals(), "_MOVE_XYE",
                                   r"\nG1 (?:F([-.0-9]+) )?X([-.0-9]+) Y([-.0-9]+) E([-.0-9]+)(?=\n)",
                                   "findall")    # the commonest
_ends_nl = operator.methodcaller("endswith", "\n")


def _plain_moves(raws):
    """_plain_moves_py(raws), by the compiled core when it takes the lines (ASCII str in a list)."""
    if CORE_MOD is not None:
        got = CORE_MOD.plain_moves(raws, "", "")
        if got is not NotImplemented:
            return got if got is None else got[:6]
    return _plain_moves_py(raws)


def _plain_moves_py(raws):
    """(x texts, y texts, e texts, e given, comments, (x values, y values, given e values))
    when every line of raws is a plain "G1 X Y [E]" line ending in "\n" (then the n
    matches are the n lines), else None."""
    n = len(raws)
    text = "".join(raws)
    if n == 0 or text.count("\n") != n or not all(map(_ends_nl, raws)):
        return None
    text = "\n" + text
    found = _MOVE_XYE(text)
    if len(found) == n:
        fs, xs, ys, es = map(list, zip(*found))
        given, comments = [True] * n, [""] * n
    else:
        found = _MOVE_LINES(text)
        if len(found) != n:
            return None
        fs, xs, ys, es, comments = map(list, zip(*found))
        given = [e != "" for e in es]
        es = [e or "0" for e in es]
    try:                         # the number grammar (the values are the validator's path)
        for f in filter(None, fs):        # an F's number: only checked, as the strict tokenizer does
            float(f)
        values = (list(map(float, xs)), list(map(float, ys)),
                  list(map(float, es)) if all(given) else [float(e) for e, g in zip(es, given) if g])
    except ValueError:           # "1.2.3", "-": the general reading says why
        return None
    return xs, ys, es, given, comments, values


_MORE_DECIMALS = {}
_MORE_DECIMALS.update((d, compiled_on_first_call(_MORE_DECIMALS, d, r"\.[0-9]{%d}" % (d + 1), "search"))
                      for d in (3, 5))


def _decimals_at_least(texts, least: int) -> int:
    """max([decimals(t) for t in texts] + [least]) for number texts (their only '.' is
    the decimal point): one search of the joined texts finds whether any has more."""
    if _MORE_DECIMALS[least](" ".join(texts)) is None:
        return least
    return max(max(map(decimals, texts)), least)


def _closing(flavour, accel_restore, extruding, mcr_restore, feed_restore_v, nl):
    """Lines that end every block: the original's acceleration, Klipper's cruise ratio
    and the modal F back in force, then the end marker."""
    out = [accel_command(flavour, accel_restore, extruding, round_up=False) + nl]
    if flavour == "klipper":
        out.append(f"SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO={_num(mcr_restore, 3)}{nl}")
    out.append(f"G1 F{_exact_text(feed_restore_v * 60.0)}{nl}")
    out.append(f"{END}{nl}")
    return out


@functools.lru_cache(maxsize=256)
def _closing_text(flavour, accel_restore, extruding, mcr_restore, feed_restore_v, nl):
    """"".join(_closing(...)), cached: a print restores the same few values block after
    block (a value that raises is not cached: it raises each time)."""
    return "".join(_closing(flavour, accel_restore, extruding, mcr_restore, feed_restore_v, nl))


_TENTHS_MAX = 1 << 50         # below this an integer k and float(k) / 10 print alike


def _tenths(k: int) -> str:
    """_num1(k / 10) for an integer k >= 1 (below _TENTHS_MAX): k / 10 is within half an
    ulp of the decimal k/10, so its one-decimal text is k's digits with the point put in."""
    q, r = divmod(k, 10)
    return f"{q}.{r}" if r else str(q)


def _tenths_up(k: int) -> str:
    """_num(max(k / 10, 0.1), 1) for an integer k (a value rounded up to k tenths): the
    text of the feeds and accelerations the emitter writes."""
    if k <= 1:
        return "0.1"
    return _tenths(k) if k < _TENTHS_MAX else _num1(k / 10.0)


# texts by value: a block's feeds and accelerations repeat across a print (the gyroid plate:
# 335 k feeds, 3.5 k texts).  Bounded: a full table is emptied and refilled.
_CACHE_MAX = 1 << 16
_FEED_TEXTS: dict = {}           # feed (mm/s, float) -> F text
_ACCEL_CMDS: dict = {}           # (M204 word, line end) -> {ceil(10 a): command line}


def _feed_segment_text(f: float) -> str:
    """_feed_text(f), remembered in _FEED_TEXTS (a feed it refuses raises and is never
    stored; 0.0 == -0.0 is refused, so equal keys have one text)."""
    text = _feed_text(f)
    if len(_FEED_TEXTS) >= _CACHE_MAX:
        _FEED_TEXTS.clear()
    _FEED_TEXTS[f] = text
    return text


def _accel_cmd_text(ka: int, accel_a: float, flavour: str, extruding: bool, nl: str, table: dict) -> str:
    """accel_command's line for accel_a (rounded up to ka tenths: its text is a function
    of ka), remembered in table by ka."""
    cmd = accel_command(flavour, accel_a, extruding) + nl
    if len(table) >= _CACHE_MAX:
        table.clear()
    table[ka] = cmd
    return cmd


def _canon(text: str) -> str:
    """_fmt_units(_units(text, dec), dec) for a number text with at most dec decimals
    (dec >= 1): the same value written without leading or trailing zeros."""
    if text[:1] == "." and text[-1:] != "0" and text[1:].isdigit():   # PrusaSlicer's E.0123
        return "0" + text
    neg = text[:1] == "-"
    whole, _, frac = text.lstrip("+-").partition(".")
    whole = whole.lstrip("0") or "0"
    frac = frac.rstrip("0")
    if frac:
        whole = f"{whole}.{frac}"
    elif whole == "0":
        return "0"
    return "-" + whole if neg else whole


def emit_stroke(st: StrokeText, ends_d, s, v, accels, feeds, *, x0_text, y0_text, e_rel, flavour,
                accel_restore, mcr_restore, feed_restore_v, extruding=True, header="", first_cmds=None):
    """Text of the block replacing the stroke.  s, v: knots (mm, mm/s) including every
    original vertex (ends_d); accels (mm/s^2) and feeds (mm/s): one per segment.
    first_cmds: (before, after) lines around the first move (a junction command that
    slows the corner into the stroke, and the value in force back: corners.py)."""
    if CORE_MOD is not None:
        text = _emit_core(st, ends_d, s, accels, feeds, x0_text, y0_text, e_rel, flavour, accel_restore,
                          mcr_restore, feed_restore_v, extruding, header, first_cmds)
        if text is not None:
            return text
    nl = st.newline
    dxy, de = st.dec_xy, st.dec_e
    # Python floats, not numpy scalars: the same IEEE numbers, a fraction of the per-use cost
    s, accels, feeds, ends_d = _floats(s), _floats(accels), _floats(feeds), _floats(ends_d)
    out = [f"{BEGIN}{header}{nl}"]
    if flavour == "klipper":
        out.append(f"SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=0{nl}")
    append = out.append
    x_texts, y_texts, e_texts, comments = st.x_texts, st.y_texts, st.e_texts, st.comments
    # integer units of the start point (a vertex's own units are taken when a new point
    # is put inside its move: _move_units); the start's text is checked here as before
    start_u = (_units(x0_text, dxy), _units(y0_text, dxy))
    n_moves = len(ends_d)
    move = 0
    mu = None                            # _move_units of the current move, once needed
    e_done_u = 0                         # units extruded so far inside the current move
    e_again_u = 0                        # absolute E: the last move's E per walk past the end
    last_accel = None
    last_a = None
    k_total = len(s) - 1
    # accel_command's word: "M204 S" / "M204 P" / "M204 T"
    accel_word = "M204 S" if flavour in ("klipper", "marlin-legacy") else ("M204 P" if extruding else "M204 T")
    isfinite, ceil = math.isfinite, math.ceil
    feed_texts = _FEED_TEXTS
    accel_cmds = _ACCEL_CMDS.get((accel_word, nl))
    if accel_cmds is None:
        if len(_ACCEL_CMDS) >= 64:       # a print has one or two (word, line end) pairs
            _ACCEL_CMDS.clear()
        accel_cmds = _ACCEL_CMDS[(accel_word, nl)] = {}
    tol_d = 1e-9 * max(1.0, ends_d[-1])
    end_d = ends_d[0]
    start_d = 0.0
    n_head = len(out)
    for k in range(1, k_total + 1):
        # which original move does this segment end in?  (vertices are knots)
        sk = s[k]
        if sk > end_d + tol_d:
            raise AssertionError("a knot skipped an original vertex")   # would lose its E
        at_vertex = abs(sk - end_d) <= tol_d
        if at_vertex:
            xt, yt = x_texts[move], y_texts[move]
            comment = comments[move]
            if not e_rel:
                e_txt = e_texts[move]
            elif e_done_u == 0:          # the move's E, as _fmt_units(_units(text)) writes it
                e_txt = e_texts[move]
                e_txt = "0" + e_txt if e_txt[:1] == "." and e_txt[-1] != "0" else _canon(e_txt)
            else:                        # the move's E less what its new points laid
                e_txt = _fmt_units(_units(e_texts[move], de) - e_done_u, de)
        else:
            d_move = end_d - start_d
            frac = 1.0 if d_move <= 0 else min(1.0, max(0.0, (sk - start_d) / d_move))
            if mu is None:
                mu = _move_units(st, move, start_u, dxy, de, e_rel)
            x_a, x_b, y_a, y_b, e_move_u, e_before_u = mu
            xt = _fmt_units(round(x_a + (x_b - x_a) * frac), dxy)
            yt = _fmt_units(round(y_a + (y_b - y_a) * frac), dxy)
            e_target_u = round(e_move_u * frac)
            e_txt = _fmt_units(e_target_u - e_done_u if e_rel else e_before_u + e_again_u + e_target_u, de)
            e_done_u = e_target_u
            comment = ""
        a = accels[k - 1]
        if a != last_a:                  # the same value gives the same command
            if not (isfinite(a) and a > 0.0):
                accel_command(flavour, a, extruding)     # raises, saying why
            ka = ceil(a * 10.0 - 1e-9)   # accel_command's rounding: its text is ka's
            cmd = accel_cmds.get(ka)
            if cmd is None:
                cmd = _accel_cmd_text(ka, a, flavour, extruding, nl, accel_cmds)
            last_a = a
            if cmd != last_accel:
                append(cmd)
                last_accel = cmd
        f = feed_texts.get(feeds[k - 1])      # _feed_text, cached by value (a print has few)
        if f is None:
            f = _feed_segment_text(feeds[k - 1])
        if not extruding:
            append(f"G1 X{xt} Y{yt} F{f}{(' ' + comment) if comment else ''}{nl}")
        elif comment:
            append(f"G1 X{xt} Y{yt} E{e_txt} F{f} {comment}{nl}")
        else:
            append(f"G1 X{xt} Y{yt} E{e_txt} F{f}{nl}")
        if at_vertex:
            e_done_u = 0
            if move < n_moves - 1:
                move += 1
                start_d, end_d = end_d, ends_d[move]
            elif not e_rel:              # knots past the end walk the last move again, its E on top
                e_again_u += (mu or _move_units(st, move, start_u, dxy, de, e_rel))[4]
            mu = None
    if first_cmds and k_total >= 1:
        # around the first move, after its acceleration (the first segment always writes one)
        out[n_head + 2:n_head + 2] = [first_cmds[1] + nl]
        out[n_head + 1:n_head + 1] = [first_cmds[0] + nl]
    append(_closing_text(flavour, accel_restore, extruding, mcr_restore, feed_restore_v, nl))
    return "".join(out)


def _emit_core(st, ends_d, s, accels, feeds, x0_text, y0_text, e_rel, flavour, accel_restore,
               mcr_restore, feed_restore_v, extruding, header, first_cmds):
    """emit_stroke's text by the compiled core, or None: the core declined (the Python loop
    then writes it, or raises saying why), or a piece made here raised (the Python loop
    raises it in its own order)."""
    nl = st.newline
    try:
        closing = _closing_text(flavour, accel_restore, extruding, mcr_restore, feed_restore_v, nl)
        before = after = None
        if first_cmds and len(s) >= 2:
            before, after = first_cmds[0] + nl, first_cmds[1] + nl
        head = f"{BEGIN}{header}{nl}"
        if flavour == "klipper":
            head += f"SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=0{nl}"
        word = "M204 S" if flavour in ("klipper", "marlin-legacy") else ("M204 P" if extruding else "M204 T")
        s, accels, feeds, ends_d = _doubles(s), _doubles(accels), _doubles(feeds), _doubles(ends_d)
        return CORE_MOD.emit_body(head, st.x_texts, st.y_texts, st.e_texts, st.comments, s, accels, feeds, ends_d,
                                  st.dec_xy, st.dec_e, e_rel, extruding, st.e_start_units, x0_text, y0_text,
                                  word, nl, before, after, closing)
    except Exception:             # noqa: BLE001 -- the Python loop gives the exception
        return None


_F64 = np.dtype(np.float64)


def _doubles(xs):
    """What the core reads as a sequence of doubles: a 1-D float64 array's bytes (its items
    are the floats of its tolist()), else _floats(xs)."""
    if getattr(xs, "dtype", None) is _F64 and xs.ndim == 1:
        return xs.tobytes()
    return _floats(xs)


def _move_units(st, move, start_u, dxy, de, e_rel):
    """Integer units of one original move, for points put inside it: its start and end
    X and Y, its E (units it lays) and, with absolute E, the E before it."""
    if move == 0:
        x_a, y_a = start_u
    else:
        x_a, y_a = _units(st.x_texts[move - 1], dxy), _units(st.y_texts[move - 1], dxy)
    x_b, y_b = _units(st.x_texts[move], dxy), _units(st.y_texts[move], dxy)
    e_u = _units(st.e_texts[move], de)
    if e_rel:
        return x_a, x_b, y_a, y_b, e_u, 0
    e_before_u = st.e_start_units if move == 0 else _units(st.e_texts[move - 1], de)
    return x_a, x_b, y_a, y_b, e_u - e_before_u, e_before_u


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
