"""Output validator: every line of a re-timed block is one the firmware accepts.

Run by pipeline.rewrite() on each block before it is written; a block that fails is
replaced by the stroke's original lines (and counted by reason).  Independent of the
emitter: it re-reads the text with its own strict grammar.

What each firmware parses (why the rules are what they are):
  * numbers: Marlin's parser.value_float() cuts a value at 'E'/'e' before strtof (so
    `Y2e1` is Y2 then an E word); Prusa-Firmware's code_value() is strtod (2e1 = 20);
    Klipper splits words at letters (Y2 E1).  Only plain decimals mean the same to all:
    [-]digits[.digits] or [-].digits, finite, no exponent, no inf/nan, no leading '+'.
  * Marlin and Prusa-Firmware read commands into a MAX_CMD_SIZE = 96 byte buffer: a
    longer code part would be cut.
  * acceleration: Klipper's M204 rejects S <= 0 ("S must be above 0.0", a print from SD
    stops there); Marlin 2 / RRF take M204 P (print) / T (travel); Prusa's Marlin 1.x
    (marlin-legacy) takes M204 S.  SET_VELOCITY_LIMIT is Klipper's, with known keys.
  * G1/G2/G3 carry X Y I J E F only (Z never changes inside a stroke), F > 0.
  * short moves: Marlin 2 drops a move of fewer than MIN_STEPS_PER_SEGMENT (6) steps and
    Prusa-Firmware one of at most dropsegments (5), joining its distance with the next
    move; Klipper and RRF keep any.  A block's move shorter than the profile's
    min_move_d in X and in Y (and than the original's own shortest move, which the
    firmware treats alike in both files) would move the next move's start.
"""
from __future__ import annotations

import math
import operator
import os

from . import native
from .words import LazyPattern, compiled_on_first_call

# The compiled column pass (_emit.c, module _gcode_opt_emit): optional; it passes only the
# blocks _fast_ok's Python checks certainly pass, else they run (tests/test_speed_rewrite_core.py)
_CORE_MOD, _ = native.load("_gcode_opt_emit",
                           os.path.join(os.path.dirname(os.path.abspath(__file__)), "_emit.c"), "emit core")
_FAST_BODY = None if _CORE_MOD is None else _CORE_MOD.fast_body

BEGIN = "; gcode-opt begin"
END = "; gcode-opt end"


def _compiled_on_first_call(name, pattern, method, table=None):
    """re.compile(pattern).method, compiled at its first call, which puts it in its place
    (module global `name`, or table[name]): most runs never call them (the compiled core
    checks the blocks), and the compiles of the ten below were ~6 M instructions of every
    run's start."""
    return compiled_on_first_call(globals() if table is None else table, name, pattern, method)


NUM = LazyPattern(globals(), "NUM", r"-?(?:\d+(?:\.\d*)?|\.\d+)\Z")    # PrusaSlicer writes E.84612
WORD = LazyPattern(globals(), "WORD", r"([A-Za-z])(.*)\Z")
_N8 = r"(-?(?:\d+(?:\.\d{0,8})?|\.\d{1,8}))"     # NUM with at most MAX_DECIMALS decimals
_M204_PLAIN = _compiled_on_first_call("_M204_PLAIN", rf"M204 ([A-Za-z]){_N8}", "fullmatch")
_G1_PLAIN = _compiled_on_first_call("_G1_PLAIN", rf"G1 X{_N8} Y{_N8}(?: E{_N8})? F{_N8}", "fullmatch")
MAX_CMD_BYTES = {"marlin2": 96, "marlin-legacy": 96}
SVL_KEYS = ("VELOCITY", "ACCEL", "ACCEL_TO_DECEL", "SQUARE_CORNER_VELOCITY", "MINIMUM_CRUISE_RATIO")
MAX_DECIMALS = 8            # our own texts never have more; the firmwares parse any
E_TOL = 1e-7                # relative: E is split in integer units of the file's precision, exactly


class BlockInvalid(ValueError):
    """A re-timed block the firmware might reject or misread; str() is the reason."""


def _num(text, what):
    if not NUM.match(text):
        raise BlockInvalid(f"validator: {what} not a plain decimal")
    if len(text.partition(".")[2]) > MAX_DECIMALS:
        raise BlockInvalid(f"validator: {what} has too many decimals")
    v = float(text)
    if not math.isfinite(v):
        raise BlockInvalid(f"validator: {what} not finite")
    return v


class Geometry:
    """Where the block's points may lie: a polyline (lines, curves) or an arc."""

    def __init__(self, pts=None, arc=None, tol_d=2e-3):
        self._pts = None if pts is None else [(float(x), float(y)) for x, y in pts]
        self.arc = arc              # (cx, cy, r, theta0, sweep); pts: the original's own points
        self.tol_d = tol_d
        self._k = 0                 # polyline segment the last point was found on
        self._walk = False          # _fast_ok's view of the polyline, made on first use
        self._xy = None             # polyline(): the vertices' (xs, ys), pts made from them when read

    @classmethod
    def polyline(cls, xs, ys, tol_d=2e-3):
        """Geometry(list(zip(xs, ys))) for lists of Python floats (the vertices, start first),
        without copying them point by point (pts is made only if read)."""
        g = cls(None, None, tol_d)
        g._xy = (xs, ys)
        return g

    @property
    def pts(self):
        if self._pts is None and self._xy is not None:
            self._pts = list(zip(*self._xy))
        return self._pts

    @pts.setter
    def pts(self, pts):
        self._pts, self._xy, self._walk = pts, None, False

    def on_path(self, x, y, tol_d) -> bool:
        """(x, y) within tol_d of the original path.  A block's points come in path order:
        the polyline is searched from the segment of the last point on, then (only if that
        fails) whole, so the answer is off_path(x, y) <= tol_d at a few segments' cost."""
        p = self.pts
        if self.arc is not None or p is None or len(p) < 2:
            return self.off_path(x, y) <= tol_d
        for k in range(self._k, len(p) - 1):
            # _seg_dist(x, y, p[k], p[k + 1]) written out: once per point and segment tried
            ax, ay = p[k]
            bx, by = p[k + 1]
            dx, dy = bx - ax, by - ay
            dd = dx * dx + dy * dy
            t = 0.0 if dd <= 0 else min(1.0, max(0.0, ((x - ax) * dx + (y - ay) * dy) / dd))
            if math.hypot(x - ax - t * dx, y - ay - t * dy) <= tol_d:
                self._k = k
                return True
        return self.off_path(x, y) <= tol_d

    def off_path(self, x, y):
        """Distance (mm) from (x, y) to the original path."""
        if self.arc is not None:
            # the original's own end text may sit off its circle by the slicer's rounding
            for px, py in self.pts or ():
                if math.hypot(x - px, y - py) <= 1e-6:
                    return 0.0
            cx, cy, r, th0, sw = self.arc
            ang = math.atan2(y - cy, x - cx)
            # angle along the sweep, in [0, |sweep|] when on the arc
            rel = (ang - th0) * (1 if sw >= 0 else -1) % (2 * math.pi)
            if rel <= abs(sw) + 1e-9:
                return abs(math.hypot(x - cx, y - cy) - r)
            ends = [(cx + r * math.cos(th0), cy + r * math.sin(th0)),
                    (cx + r * math.cos(th0 + sw), cy + r * math.sin(th0 + sw))]
            return min(math.hypot(x - ex, y - ey) for ex, ey in ends)
        best = math.inf
        p = self.pts
        for a, b in zip(p[:-1], p[1:]):
            best = min(best, _seg_dist(x, y, a, b))
        return best


def _polyline_walk(geometry):
    """(xs, ys) of a polyline's vertices for _fast_ok, or None (an arc, fewer than two
    points, or coordinates so large that a segment's squared length could overflow: there
    a vertex need not be at distance 0 from its own segment by _seg_dist's arithmetic)."""
    if geometry._walk is False:
        p = geometry.pts
        walk = None
        if geometry.arc is None and p is not None and len(p) >= 2:
            xs, ys = geometry._xy or ([q[0] for q in p], [q[1] for q in p])
            if max(map(abs, xs)) < 1e150 and max(map(abs, ys)) < 1e150:
                walk = (xs, ys)
        geometry._walk = walk
    return geometry._walk


def _seg_dist(x, y, a, b):
    """Distance (mm) from (x, y) to the segment a-b."""
    ax, ay = a
    dx, dy = b[0] - ax, b[1] - ay
    dd = dx * dx + dy * dy
    t = 0.0 if dd <= 0 else min(1.0, max(0.0, ((x - ax) * dx + (y - ay) * dy) / dd))
    return math.hypot(x - ax - t * dx, y - ay - t * dy)


def validate_block(text: str, flavour: str, accel_max_a: float, geometry: Geometry | None = None,
                   extruding: bool = True, kind: str | None = None, e_check=None,
                   min_move_d: float = 0.0) -> None:
    """Raise BlockInvalid (reason in its message) unless every line of the block is well
    formed for `flavour`, every value is finite and in range (F > 0, 0 < accel <=
    accel_max_a + the 0.1 of the emitter's rounding) and every point is on the path.

    e_check = (e_rel, e_value): the filament the block must lay, as the original did: with
    relative E the sum of its E words equals e_value (the original's sum), with absolute E
    its last E word equals e_value (the original's last).

    min_move_d: no move may travel less than this in both X and Y (Profile.min_move_d),
    unless the original has a move as short (geometry's polyline)."""
    if _fast_ok(text, flavour, accel_max_a, geometry, extruding, kind, e_check, min_move_d):
        return
    # the general reading, line by line: any block _fast_ok does not pass (its reason)
    lines = text.splitlines()
    if len(lines) < 2 or not lines[0].startswith(BEGIN + ": replaces ") or lines[-1] != END:
        raise BlockInvalid("validator: block not fenced")
    if kind is not None and f"kind={kind}" not in lines[0]:
        raise BlockInvalid("validator: header does not name the kind")
    limit = MAX_CMD_BYTES.get(flavour)
    e_words = []
    short = _ShortMoves(geometry, min_move_d) if min_move_d > 0 and geometry is not None else None
    for line in lines[1:-1]:
        # the emitter's own plain lines (no comment, no spaces around: the line is its own
        # code part) take the same checks without the general path's splitting
        m = _G1_PLAIN(line)
        if m is not None:
            if limit is not None and len(line.encode()) > limit:
                raise BlockInvalid("validator: line longer than the firmware's command buffer")
            e, x, y = _check_plain_g1(m, geometry)
            if e is not None:
                e_words.append(e)
            if short is not None:
                short.check(x, y)
            continue
        m = _M204_PLAIN(line)
        if m is not None:
            if limit is not None and len(line.encode()) > limit:
                raise BlockInvalid("validator: line longer than the firmware's command buffer")
            _check_m204_value(m.group(1), float(m.group(2)), flavour, accel_max_a, extruding)
            continue
        code = line.split(";", 1)[0].strip()
        if not code:
            raise BlockInvalid("validator: empty or comment line inside a block")
        if limit is not None and len(code.encode()) > limit:
            raise BlockInvalid("validator: line longer than the firmware's command buffer")
        toks = code.split()
        cmd = toks[0].upper()
        if cmd != toks[0]:
            raise BlockInvalid("validator: lower-case command")
        if cmd == "G1":
            m = _G1_PLAIN(code)
            e, x, y = _check_plain_g1(m, geometry) if m is not None else _check_move(cmd, toks[1:], geometry)
            if e is not None:
                e_words.append(e)
            if short is not None:
                short.check(x, y)
        elif cmd in ("G2", "G3"):
            e, x, y = _check_move(cmd, toks[1:], geometry)
            if e is not None:
                e_words.append(e)
            if short is not None:
                short.check(x, y)
        elif cmd == "M204":
            m = _M204_PLAIN(code)
            if m is not None:            # one word, its letter and number proven: the value checks
                _check_m204_value(m.group(1), float(m.group(2)), flavour, accel_max_a, extruding)
            else:
                _check_m204(toks[1:], flavour, accel_max_a, extruding)
        elif cmd == "SET_VELOCITY_LIMIT":
            _check_svl(toks[1:], flavour, accel_max_a)
        elif cmd == "M205":
            _check_m205(toks[1:], flavour)
        else:
            raise BlockInvalid(f"validator: command {cmd} not allowed in a block")
    if e_check is not None:
        e_rel, e_value = e_check
        got = math.fsum(e_words) if e_rel else (e_words[-1] if e_words else None)
        if got is None or abs(got - e_value) > E_TOL * (1.0 + abs(e_value)):
            raise BlockInvalid("validator: filament differs from the original's")


# _fast_ok: the block as the emitter writes it.  Each pattern starts at a line's "\n" (a
# literal prefix the regex engine finds fast) and ends before the next.  A number is a run
# of [-.0-9] there (ASCII: a character is a byte, for the command-buffer check); float()
# then takes exactly the plain decimals among those, and _LONG_FRACTION finds one with
# more than MAX_DECIMALS: the two together are _N8's grammar
_C = r"([-.0-9]+)"
_FAST_MOVES = _compiled_on_first_call("_FAST_MOVES", rf"\nG1 X{_C} Y{_C}(?: E{_C})? F{_C}(?=\n)", "findall")
_FAST_FEEDS = _compiled_on_first_call("_FAST_FEEDS", rf"\nG1 F{_C}(?=\n)", "findall")
_FAST_M204 = {}
_FAST_M204.update({c: _compiled_on_first_call(c, rf"\nM204 {c}{_C}(?=\n)", "findall", _FAST_M204) for c in "SPT"})
_FAST_MCR = _compiled_on_first_call("_FAST_MCR", rf"\nSET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO={_C}(?=\n)", "findall")
_LONG_FRACTION = _compiled_on_first_call("_LONG_FRACTION", r"\.[0-9]{%d}" % (MAX_DECIMALS + 1), "search")
# line breaks of str.splitlines other than "\n": without them its lines are split("\n")'s
_OTHER_BREAKS = _compiled_on_first_call("_OTHER_BREAKS", "[\r\x0b\x0c\x1c\x1d\x1e\x85\u2028\u2029]", "search")
_END_LINE = "\n" + END + "\n"
_INF = math.inf


def _fast_ok(text, flavour, accel_max_a, geometry, extruding, kind, e_check, min_move_d) -> bool:
    """True when the block certainly passes validate_block's line-by-line checks: every line
    is one the emitter writes (a plain "G1 X Y [E] F" move, "G1 F", the flavour's M204,
    Klipper's cruise ratio) and passes the same tests, taken a column at a time.  False
    says nothing: the caller reads the block the general way (which then finds the reason,
    or passes).  Only a pass is final, so every check here is the general one's or stricter."""
    if not text.endswith(_END_LINE):
        return False
    i = text.find("\n")
    head = text[:i]
    if not head.startswith(BEGIN + ": replaces ") or (kind is not None and f"kind={kind}" not in head) \
            or _OTHER_BREAKS(head) is not None:
        return False
    want = "S" if flavour in ("klipper", "marlin-legacy") else ("P" if extruding else "T")
    if _FAST_BODY is not None and _fast_core(text, i, flavour, want, accel_max_a, geometry, e_check, min_move_d):
        return True
    # "\n" line "\n" line ... "\n": when every line below has a shape (none holds a line
    # break), text.splitlines() is [head] + these lines + [END]
    body = text[i:len(text) - len(END) - 1]
    if _LONG_FRACTION(body) is not None:
        return False
    moves = _FAST_MOVES(body)
    feeds = _FAST_FEEDS(body)
    accels = _FAST_M204[want](body)
    ratios = _FAST_MCR(body) if flavour == "klipper" else ()
    if len(moves) + len(feeds) + len(accels) + len(ratios) != body.count("\n") - 1:
        return False                               # a line of another shape
    limit = MAX_CMD_BYTES.get(flavour)
    if limit is not None and max(map(len, body.split("\n"))) > limit:
        return False
    try:                      # ValueError: a number text that is not a plain decimal
        return _fast_values(moves, feeds, accels, ratios, accel_max_a, geometry, e_check, min_move_d)
    except ValueError:
        return False


def _fast_core(text, i, flavour, want, accel_max_a, geometry, e_check, min_move_d) -> bool:
    """The compiled column pass over text[i:] less its end line (the same checks as the
    code below _fast_ok's head checks; it reads the text itself): True certainly passes,
    False says nothing (the core declined: an arc, a value near its limit, ...)."""
    px = py = None
    if geometry is not None:
        # a polyline's vertices (the core declines coordinates _polyline_walk refuses)
        walk = geometry._xy if geometry.arc is None else None
        if walk is None:
            walk = _polyline_walk(geometry)
            if walk is None:
                return False
        px, py = walk
    e_mode, e_value = 0, 0.0
    if e_check is not None:
        e_rel, e_value = e_check
        if type(e_value) is not float:
            return False
        e_mode = 1 if e_rel else 2
    return _FAST_BODY(text, i, len(text) - len(END) - 1, want, flavour == "klipper", MAX_CMD_BYTES.get(flavour, 0),
                      accel_max_a, px, py, geometry.tol_d if geometry is not None else 0.0, e_mode, e_value,
                      min_move_d) is True


# number texts already found good, by what they were checked for: float(text) is a function
# of the text, so a text seen to pass passes again, without its float() (a print's blocks
# repeat few F and M204 texts: the gyroid plate's 335 k F words are 3.5 k texts).  Bounded:
# a full set is emptied and refilled
_GOOD_MAX = 1 << 16
_GOOD_FEEDS: set = set()         # plain decimals with 0 < value < inf (F)
_GOOD_ACCELS: dict = {}          # accel_max_a -> plain decimals with 0 < value <= accel_max_a + 0.1


def _remember(good: set, texts) -> None:
    if len(good) >= _GOOD_MAX:
        good.clear()
    good.update(texts)


def _fast_values(moves, feeds, accels, ratios, accel_max_a, geometry, e_check, min_move_d) -> bool:
    """_fast_ok's checks of the numbers (float() raising ValueError on a text that is not one)."""
    if accels:
        good = _GOOD_ACCELS.get(accel_max_a)
        if good is None or not good.issuperset(accels):
            v = list(map(float, accels))
            hi = max(v)
            if not (min(v) > 0.0 and hi <= accel_max_a + 0.1 + 1e-9 and hi < _INF):
                return False
            if good is None:
                if len(_GOOD_ACCELS) >= 64:      # a few limits a print (the profile's, the slicer's)
                    _GOOD_ACCELS.clear()
                good = _GOOD_ACCELS[accel_max_a] = set()
            _remember(good, accels)
    if feeds and not _GOOD_FEEDS.issuperset(feeds):
        v = list(map(float, feeds))
        if not (min(v) > 0.0 and max(v) < _INF):
            return False
        _remember(_GOOD_FEEDS, feeds)
    if ratios:
        v = list(map(float, ratios))
        if not (min(v) >= 0.0 and max(v) < 1.0):
            return False
    e_words = []
    if moves:
        xts, yts, ets, fts = zip(*moves)
        if not _GOOD_FEEDS.issuperset(fts):
            v = list(map(float, fts))
            if not (min(v) > 0.0 and max(v) < _INF):
                return False
            _remember(_GOOD_FEEDS, fts)
        xs, ys = list(map(float, xts)), list(map(float, yts))
        if not (max(xs) < _INF and min(xs) > -_INF and max(ys) < _INF and min(ys) > -_INF):
            return False
        e_words = list(map(float, filter(None, ets)))
        if e_words and not (max(e_words) < _INF and min(e_words) > -_INF):
            return False
        if geometry is not None and not _fast_path_ok(geometry, xs, ys, xts, yts, min_move_d):
            return False
    if e_check is not None:
        e_rel, e_value = e_check
        got = math.fsum(e_words) if e_rel else (e_words[-1] if e_words else None)
        if got is None or abs(got - e_value) > E_TOL * (1.0 + abs(e_value)):
            return False
    return True


def _tol(geometry, xt, yt):
    """_check_plain_g1's tolerance for a point written with these texts."""
    dec = max(len(xt.partition(".")[2]), len(yt.partition(".")[2]))
    return min(geometry.tol_d, 0.75 * 10.0 ** -dec) + 1e-7


def _fast_path_ok(geometry, xs, ys, xts, yts, min_move_d) -> bool:
    """Every point on the path (Geometry.on_path with _check_plain_g1's tolerance) and no
    move shorter than _ShortMoves allows.  A point equal to the next original vertex is at
    distance 0 from the segment it ends (_seg_dist's arithmetic: t = dd / dd = 1, then
    (x - ax) - dx = 0); another is tried on the segment being walked, then on all of them."""
    walk = _polyline_walk(geometry)
    pts = geometry.pts or []
    if walk is None:              # an arc: the general point test
        for x, y, xt, yt in zip(xs, ys, xts, yts):
            if not geometry.on_path(x, y, _tol(geometry, xt, yt)):
                return False
    else:
        px, py = walk
        nv = len(px)
        j = 1                     # the next original vertex
        hypot = math.hypot
        tol_least = min(geometry.tol_d, 0.75 * 10.0 ** -MAX_DECIMALS) + 1e-7   # any point's tolerance >= this
        for x, y, xt, yt in zip(xs, ys, xts, yts):
            if j < nv and x == px[j] and y == py[j]:
                j += 1
                continue
            k = j - 1 if j < nv else nv - 2
            ax, ay = px[k], py[k]
            dx, dy = px[k + 1] - ax, py[k + 1] - ay
            dd = dx * dx + dy * dy
            t = 0.0 if dd <= 0 else min(1.0, max(0.0, ((x - ax) * dx + (y - ay) * dy) / dd))
            d = hypot(x - ax - t * dx, y - ay - t * dy)
            if d > tol_least:
                tol = _tol(geometry, xt, yt)
                if d > tol and not any(_seg_dist(x, y, a, b) <= tol for a, b in zip(pts[:-1], pts[1:])):
                    return False
    if min_move_d > 0.0 and xs:
        # _ShortMoves.check on every move, from the path's start: gap = max(|dx|, |dy|)
        if pts:
            x_prev, y_prev = [pts[0][0]] + xs[:-1], [pts[0][1]] + ys[:-1]
            x_next, y_next = xs, ys
        else:                     # (no start: the first point only sets the position)
            x_prev, y_prev, x_next, y_next = xs[:-1], ys[:-1], xs[1:], ys[1:]
        gaps = list(map(max, map(abs, map(operator.sub, x_next, x_prev)),
                        map(abs, map(operator.sub, y_next, y_prev))))
        if gaps and min(gaps) < min_move_d:
            if min(gaps) < _ShortMoves(geometry, min_move_d).floor:
                return False
    return True


class _ShortMoves:
    """Tracks the block's position (from the geometry's start) and rejects a move the
    firmware would drop (validate_block's min_move_d)."""

    def __init__(self, geometry, min_move_d):
        pts = geometry.pts or []
        self.x, self.y = pts[0] if pts else (None, None)
        floor = min_move_d
        if geometry.arc is None and len(pts) > 2:   # the original's own shortest move passes too
            own = min(max(abs(b[0] - a[0]), abs(b[1] - a[1])) for a, b in zip(pts, pts[1:]))
            floor = min(floor, own * (1.0 - 1e-9))
        self.floor = floor

    def check(self, x, y):
        """(x, y): the move's end point, None when it has none (the checks before made sure
        a move has both or neither)."""
        if x is None:
            return
        if self.x is not None and max(abs(x - self.x), abs(y - self.y)) < self.floor:
            raise BlockInvalid("validator: move shorter than the firmware keeps (min_move_d)")
        self.x, self.y = x, y


def _check_plain_g1(m, geometry):
    """_check_move for the emitter's own form "G1 X Y [E] F" (_G1_PLAIN matched: the
    words, their order and the plain-decimal grammar with at most 8 decimals are proven).
    Returns (E, X, Y) as _check_move does."""
    xt, yt, et, ft = m.group(1, 2, 3, 4)
    x, y, f = float(xt), float(yt), float(ft)
    e = None if et is None else float(et)
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(f) and (e is None or math.isfinite(e))):
        raise BlockInvalid("validator: G1 value not finite")
    if f <= 0:
        raise BlockInvalid("validator: F not above 0")
    if geometry is not None:
        dec = max(len(xt.partition(".")[2]), len(yt.partition(".")[2]))
        tol = min(geometry.tol_d, 0.75 * 10.0 ** -dec) + 1e-7
        if not geometry.on_path(x, y, tol):
            raise BlockInvalid("validator: point off the original path")
    return e, x, y


def _check_move(cmd, words, geometry):
    seen, texts = {}, {}
    allowed = "XYEF" if cmd == "G1" else "XYIJEF"
    for w in words:
        m = WORD.match(w)
        if not m or m.group(1) not in allowed:
            raise BlockInvalid(f"validator: {cmd} word {w[:1] or '?'} not allowed")
        if m.group(1) in seen:
            raise BlockInvalid(f"validator: {cmd} word {m.group(1)} repeated")
        seen[m.group(1)] = _num(m.group(2), f"{cmd} {m.group(1)}")
        texts[m.group(1)] = m.group(2)
    if "F" in seen and seen["F"] <= 0:
        raise BlockInvalid("validator: F not above 0")
    if cmd != "G1" and not ({"I", "J"} & seen.keys()):
        raise BlockInvalid("validator: arc without I/J")
    if cmd != "G1" and not ({"X", "Y"} <= seen.keys()):
        raise BlockInvalid("validator: arc without its end point")
    if ("X" in seen) != ("Y" in seen):
        raise BlockInvalid("validator: point without both X and Y")
    if "X" in seen and geometry is not None:
        # a new point is the path's point rounded to the digits it is written with
        dec = max(len(texts["X"].partition(".")[2]), len(texts["Y"].partition(".")[2]))
        tol = min(geometry.tol_d, 0.75 * 10.0 ** -dec) + 1e-7
        if not geometry.on_path(seen["X"], seen["Y"], tol):
            raise BlockInvalid("validator: point off the original path")
    if "X" not in seen and "E" in seen:
        raise BlockInvalid("validator: extrusion without a move")
    return seen.get("E"), seen.get("X"), seen.get("Y")


def _check_m204(words, flavour, accel_max_a, extruding):
    if len(words) != 1:
        raise BlockInvalid("validator: M204 takes one value")
    m = WORD.match(words[0])
    letter = m.group(1) if m else ""
    want = "S" if flavour in ("klipper", "marlin-legacy") else ("P" if extruding else "T")
    if letter != want:
        raise BlockInvalid(f"validator: M204 {letter or '?'} is not the {flavour} form")
    _check_m204_value(letter, _num(m.group(2), "M204 value"), flavour, accel_max_a, extruding)


def _check_m204_value(letter, a, flavour, accel_max_a, extruding):
    want = "S" if flavour in ("klipper", "marlin-legacy") else ("P" if extruding else "T")
    if letter != want:
        raise BlockInvalid(f"validator: M204 {letter or '?'} is not the {flavour} form")
    if not math.isfinite(a):
        raise BlockInvalid("validator: M204 value not finite")
    if not 0.0 < a <= accel_max_a + 0.1 + 1e-9:
        raise BlockInvalid("validator: M204 value out of range")


MAX_JERK_V = 100.0          # mm/s: no classic-jerk firmware is set near this


def _check_m205(words, flavour):
    """A classic-jerk junction command (corners.junction_commands): M205 X<j> Y<j>, both
    words, values in (0, MAX_JERK_V].  Marlin 2 and Prusa-Firmware apply it to the moves
    planned after it without waiting for the queue; Klipper ignores M205 (not written)."""
    if flavour not in ("marlin2", "marlin-legacy"):
        raise BlockInvalid("validator: M205 is not read by this firmware")
    if len(words) != 2 or words[0][:1] != "X" or words[1][:1] != "Y":
        raise BlockInvalid("validator: M205 takes X and Y")
    for w in words:
        v = _num(w[1:], "M205 " + w[0])
        if not 0.0 < v <= MAX_JERK_V:
            raise BlockInvalid("validator: M205 jerk out of range")


def _check_svl(words, flavour, accel_max_a):
    if flavour != "klipper":
        raise BlockInvalid("validator: SET_VELOCITY_LIMIT is Klipper's")
    if not words:
        raise BlockInvalid("validator: SET_VELOCITY_LIMIT without a key")
    for w in words:
        key, eq, val = w.partition("=")
        if not eq or key.upper() not in SVL_KEYS:
            raise BlockInvalid("validator: SET_VELOCITY_LIMIT key unknown")
        v = _num(val, key)
        if key.upper() == "MINIMUM_CRUISE_RATIO":
            if not 0.0 <= v < 1.0:
                raise BlockInvalid("validator: MINIMUM_CRUISE_RATIO out of range")
        elif key.upper() in ("ACCEL", "ACCEL_TO_DECEL"):
            if not 0.0 < v <= accel_max_a + 0.1 + 1e-9:
                raise BlockInvalid("validator: SET_VELOCITY_LIMIT accel out of range")
        elif v <= 0.0:
            raise BlockInvalid("validator: SET_VELOCITY_LIMIT value not above 0")
