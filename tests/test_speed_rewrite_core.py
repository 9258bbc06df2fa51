"""The compiled rewrite core (gcode_opt/_emit.c, module _gcode_opt_emit) against the Python
code it stands in for, which stays and runs where the core is missing or declines a case:

  * decimal_value (the core's float() of a plain decimal) is float(), bit for bit;
  * plain_moves is emit._plain_moves_py's reading (texts, flags, comments, values, -0.0
    kept) plus StrokeText's dec_xy and dec_e;
  * emit_body writes emit_stroke's Python text (or declines; then the Python loop raises
    what it raises);
  * fast_body passes a block only where validate._fast_ok's Python checks pass it, and
    passes the blocks the emitter writes;
  * a real file's rewrite is the same bytes with the core and without it.

The references are the live Python paths with the core switched off (emit.CORE_MOD and
validate._FAST_BODY set to None), which test_speed_rewrite_text pins to the fcf532c code."""
from __future__ import annotations

import math
import os
import random
import subprocess
import sys

import numpy as np
import pytest

from gcode_opt import emit, validate
from gcode_opt.validate import Geometry
from test_speed_rewrite_text import (CASES, NOISE, SAMPLES, _mutate, _planned, _raw_lines, _real_run, _rewrite,
                                     _synthetic_stroke, _verdict)

CORE = emit.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None, reason=f"no compiled emit core: {emit.CORE_WHY}")


@pytest.fixture
def pure(monkeypatch):
    """A function that runs fn(*args) with the core switched off."""
    def run(fn, *args, **kw):
        with monkeypatch.context() as m:
            m.setattr(emit, "CORE_MOD", None)
            m.setattr(validate, "_FAST_BODY", None)
            return fn(*args, **kw)
    return run


def _bits(vals):
    return [(v, math.copysign(1.0, v)) for v in vals]


# ------------------------------------------------------------------ numbers
def _random_decimal(rng):
    nd, nf = rng.randint(0, 18), rng.randint(0, 18)
    if nd + nf == 0:
        nd = 1
    w = "".join(rng.choice("0123456789") for _ in range(nd))
    f = "".join(rng.choice("0123456789") for _ in range(nf))
    return rng.choice(["", "-"]) + w + ("." + f if nf or rng.random() < 0.3 else "")


EDGES = ["0", "-0", "-0.0", "0.", ".0", "-.0", ".5", "-.5", "5.", "0.1", "0.3", "2.675", "9007199254740991",
         "9007199254740992", "9007199254740993", "999999999999999", "1000000000000000", "123456789012345",
         "1234567890123456", "0.000000000000001", "0.0000000000000001", "99999999.99999999", "1" * 320,
         "0." + "0" * 330 + "1", "179769313486231570" + "0" * 291, "4.9406564584124654e-324".split("e")[0],
         "0.30000000000000004", "1.00000000000000011102230246251565404236316680908203125", "12.345000",
         "1.5", "2.5", "0.05", "0.15", "0.25", "0.35", "8.0078125", "1.0000000000000002", "0.9999999999999999"]


def test_decimal_value_is_float():
    """The core's number reading (the Clinger fast path up to 15 digits, float()'s own
    routine past it) gives float()'s bits on 80 k random texts and the edges: halves,
    2^53 +- 1, 15 and 16 digits, -0, overflow, underflow, long fractions."""
    dv = CORE.decimal_value
    rng = random.Random(41)
    texts = EDGES + [_random_decimal(rng) for _ in range(80_000)]
    for t in texts:
        got = dv(t)
        want = float(t)
        assert got is not None and _bits([got]) == _bits([want]), t
    for t in ["", "-", ".", "-.", "1.2.3", "--1", "+1", "1e5", "inf", "nan", " 1", "1 ", "1_0", "١"]:
        assert dv(t) is None, t


@pytest.mark.slow
def test_decimal_value_is_float_on_millions():
    dv = CORE.decimal_value
    rng = random.Random(43)
    for _ in range(3_000_000):
        t = _random_decimal(rng)
        assert _bits([dv(t)]) == _bits([float(t)]), t


# ------------------------------------------------------------------ the emitter's reading
def _line_lists(rng, n_lists):
    """Stroke line lists: plain, the general reading's shapes, tokens replaced by noise,
    lines with other line ends, non-ASCII comments."""
    for _ in range(n_lists):
        raws, _ = _raw_lines(rng, rng.randint(1, 12), rng.uniform(-5, 200), rng.uniform(-5, 200), 0.0,
                             rng.random() < 0.7, odd=rng.random() < 0.5)
        r = rng.random()
        if r < 0.3:                                      # a character replaced, inserted, deleted
            k = rng.randrange(len(raws))
            line = raws[k]
            i = rng.randrange(len(line))
            c = rng.choice(NOISE)
            raws[k] = rng.choice([line[:i] + c + line[i + 1:], line[:i] + c + line[i:], line[:i] + line[i + 1:]])
        elif r < 0.35:
            k = rng.randrange(len(raws))
            raws[k] = raws[k].rstrip("\n") + rng.choice([" ;é\n", "\r\n", "\r\r\n", " ; a\rb\n", "\t\n", "  \n"])
        elif r < 0.4:
            raws = [rng.choice(["G1 X-.5 Y-0 E.0\n", "G1 X0 Y0 E0 ;\n", "G1 X5. Y1\n", "G1 X1 Y1 E-.0001\n",
                                "G1 X-0.0 Y2.50000000000 E12345678901234567890\n", "G1 X1 Y1 E1 \n"])
                    for _ in range(rng.randint(1, 4))]
        if rng.random() < 0.3 and raws[0].startswith("G1 X"):     # Cura's feed first, or an odd one
            f = rng.choice(["F1200", "F1200", "F.5", "F-0", "F1500.25", "F1.2.3", "F-", "F", "F1200 ", "F 12"])
            raws[0] = "G1 " + f + " " + raws[0][3:]
        yield raws


def test_plain_moves_is_the_python_reading(pure):
    rng = random.Random(19)
    n_plain = n_none = 0
    for raws in _line_lists(rng, 3000):
        x0t, y0t = rng.choice([(f"{rng.uniform(-5, 200):.8f}", f"{rng.uniform(-5, 200):.8f}"),
                               ("12.34500000", "-0.10000000"), ("1", "2"), ("0.12345678", "3.1")])
        got = CORE.plain_moves(raws, x0t, y0t)
        if any(not r.isascii() for r in raws):
            assert got is NotImplemented
            continue
        want = emit._plain_moves_py(raws)
        if want is None:
            assert got is None, raws
            n_none += 1
            continue
        assert got[:5] == want[:5], raws
        assert [_bits(v) for v in got[5]] == [_bits(v) for v in want[5]], raws
        # StrokeText's decimals, as the Python reading computes them
        xs, ys, es = want[:3]
        assert got[6] == max(emit._decimals_at_least(xs + ys, 3), emit._start_decimals(x0t),
                             emit._start_decimals(y0t))
        assert got[7] == emit._decimals_at_least(es, 5)
        n_plain += 1
    assert n_plain > 1000 and n_none > 500
    # and through StrokeText: the same fields as the pure Python StrokeText
    for raws in _line_lists(random.Random(23), 500):
        new = _verdict(emit.StrokeText, raws, "1.50000000", "2.00000000", 0)
        ref = pure(_verdict, emit.StrokeText, raws, "1.50000000", "2.00000000", 0)
        assert new == ref
        if new is None:
            a = emit.StrokeText(raws, "1.50000000", "2.00000000", 0)
            b = pure(emit.StrokeText, raws, "1.50000000", "2.00000000", 0)
            assert vars(a).keys() == vars(b).keys()
            for k in vars(a):
                va, vb = getattr(a, k), getattr(b, k)
                assert (va == vb) if k != "values" else (va is None) == (vb is None), k
            if a.values is not None:
                assert [_bits(v) for v in a.values] == [_bits(v) for v in b.values]


# ------------------------------------------------------------------ the emitter
def _emit_args(rng, case):
    raws, x0, y0, e0, e_rel, ends, s, accels, feeds = case
    flavour = rng.choice(["klipper", "marlin2", "marlin-legacy", "rrf"])
    kw = dict(x0_text=f"{x0:.8f}", y0_text=f"{y0:.8f}", e_rel=e_rel, flavour=flavour,
              accel_restore=rng.choice([1000.0, 1234.5678, 0.25]), mcr_restore=rng.choice([0.0, 0.5]),
              feed_restore_v=rng.choice([30.0, 0.1884 / 60.0]), extruding=rng.random() < 0.85,
              header=": replaces x", first_cmds=rng.choice([None, None, ("M205 X5 Y5", "M205 X8 Y8")]))
    if rng.random() < 0.7:               # the values of a real plan (_synthetic_stroke's are mostly extreme)
        accels = np.array([rng.choice([1500.0, rng.uniform(100, 5000)]) for _ in accels])
        feeds = np.array([rng.choice([50.0, rng.uniform(1, 300)]) for _ in feeds])
    form = rng.random()                  # the core takes float64 arrays and lists of floats
    if form < 0.25:
        s, accels, feeds, ends = (list(map(float, v)) for v in (s, accels, feeds, ends))
    elif form < 0.3:
        accels = np.asarray(accels, np.float32)           # declined: the Python loop's tolist
    return raws, x0, y0, e0, ends, s, accels, feeds, kw


def _emit(raws, x0, y0, e0, ends, s, accels, feeds, kw):
    st = emit.StrokeText(raws, kw["x0_text"], kw["y0_text"], 0)
    st.e_start_units = int(round(e0 * 10 ** st.dec_e))
    try:
        return emit.emit_stroke(st, ends, s, None, accels, feeds, **kw)
    except Exception as e:               # noqa: BLE001 -- the same refusal, for the same reason
        return type(e).__name__, str(e)


def _core_took(raws, x0, y0, e0, ends, s, accels, feeds, kw):
    st = emit.StrokeText(raws, kw["x0_text"], kw["y0_text"], 0)
    st.e_start_units = int(round(e0 * 10 ** st.dec_e))
    return emit._emit_core(st, ends, s, accels, feeds, kw["x0_text"], kw["y0_text"], kw["e_rel"], kw["flavour"],
                           kw["accel_restore"], kw["mcr_restore"], kw["feed_restore_v"], kw["extruding"],
                           kw["header"], kw["first_cmds"]) is not None


def test_emit_core_is_the_python_loop(pure):
    """Synthetic strokes (points inside moves, knots past the end, a skipped vertex, huge
    and tiny feeds and accelerations, refused values, comments, CRLF, junction commands):
    the same text or the same exception as the Python loop; the core writes most."""
    rng = random.Random(29)
    n_core = n_text = n_err = 0
    for _ in range(2500):
        args = _emit_args(rng, _synthetic_stroke(rng))
        got = _emit(*args)
        want = pure(_emit, *args)
        assert got == want, args
        n_text += isinstance(got, str)
        n_err += not isinstance(got, str)
        n_core += _core_took(*args)
    assert n_core > 1200 and n_err > 50 and n_text > 2000


def test_emit_core_at_rounding_edges(pure):
    """Feeds and accelerations a hair either side of a tenth (and at 2^50 tenths, where the
    Python code formats a float), and interpolated points at half units."""
    rng = random.Random(31)
    vals = []
    for k in (1, 2, 9, 10, 11, 599, 600, 601, 12345, 99999, 1 << 49, (1 << 50) - 1, 1 << 50, 1 << 51):
        for scale in (10.0, 600.0):
            x = k / scale
            vals += [x, math.nextafter(x, 0), math.nextafter(x, math.inf), x + 1e-9, x - 1e-9, x + 1e-6, x - 1e-6]
    small = [v for v in vals if 0 < v < 1e12]
    vals = [v for v in vals if v > 0]
    n_core = 0
    for _ in range(300):
        raws = ["G1 X10.5 Y20 E.5\n", "G1 X11.5 Y20.001 E0.25\n", "G1 X12 Y20.002 E1\n"]
        ends = np.cumsum([math.hypot(10.5 - 10.0, 20.0 - 20.0), math.hypot(1.0, 0.001), math.hypot(0.5, 0.001)])
        knots = [0.0, ends[0], ends[0] + (ends[1] - ends[0]) * 0.5, ends[1], ends[1] + (ends[2] - ends[1]) * 0.25,
                 ends[2]]
        n = len(knots) - 1
        pick = vals if rng.random() < 0.3 else small     # 2^50 tenths and past: the Python formatting
        accels = np.array([rng.choice(pick) for _ in range(n)])
        feeds = np.array([rng.choice(pick) for _ in range(n)])
        kw = dict(x0_text="10.00000000", y0_text="20.00000000", e_rel=rng.random() < 0.5,
                  flavour=rng.choice(["klipper", "rrf"]), accel_restore=1000.0, mcr_restore=0.0,
                  feed_restore_v=30.0, extruding=True, header=": h", first_cmds=None)
        args = (raws, 10.0, 20.0, 3.0, ends, np.array(knots), accels, feeds, kw)
        got, want = _emit(*args), pure(_emit, *args)
        assert got == want
        n_core += _core_took(*args)
    assert n_core > 150


# ------------------------------------------------------------------ the validator
def _fast_both(pure, text, flavour, accel_max_a, geo, kw):
    """(the core passed the block in validate._fast_ok, the Python _fast_ok's answer), on
    fresh geometries (they keep a search position)."""
    args = lambda: (text, flavour, accel_max_a, None if geo is None else Geometry(geo[0], geo[1]),  # noqa: E731
                    kw.get("extruding", True), kw.get("kind"), kw.get("e_check"), kw.get("min_move_d", 0.0))
    seen = []
    real = validate._FAST_BODY

    def recording(*a):
        seen.append(real(*a))
        return seen[-1]
    validate._FAST_BODY = recording
    try:
        validate._fast_ok(*args())
    finally:
        validate._FAST_BODY = real
    return seen == [True], pure(validate._fast_ok, *args())


def _other_args(rng, text, flavour, accel_max_a, geo, kw):
    kw = dict(kw)
    what = rng.randrange(6)
    if what == 0:
        flavour = rng.choice(["klipper", "marlin2", "marlin-legacy", "rrf"])
    elif what == 1:
        hi = max([float(ln[6:]) for ln in text.split("\n") if ln.startswith("M204 ")] or [1000.0])
        accel_max_a = rng.choice([hi - 0.1 - 2e-9, hi - 0.1 + 2e-9, hi - 0.1 - 1e-9, hi - 0.15, hi])
    elif what == 2 and kw.get("e_check"):
        e_rel, v = kw["e_check"]
        lim = 1e-7 * (1.0 + abs(v))
        kw["e_check"] = rng.choice([(not e_rel, v), (e_rel, v + lim * 0.999), (e_rel, v + lim * 1.001),
                                    (e_rel, v - lim), (e_rel, v + lim * (1 - 1e-13))])
    elif what == 3:
        kw["extruding"] = not kw.get("extruding", True)
    elif what == 4:
        kw["min_move_d"] = rng.choice([0.0, 0.05, 0.5, 2.0, 5.0])
    else:
        geo = None
    return text, flavour, accel_max_a, geo, kw


def _off_path(text, rng):
    """One point of a move moved by about its tolerance (0.75 units of its last decimal,
    capped at 2 um, + 1e-7): either side of it, or a hair from it."""
    lines = text.split("\n")
    ks = [k for k, ln in enumerate(lines) if ln.startswith("G1 X")]
    if not ks:
        return text
    k = rng.choice(ks)
    toks = lines[k].split(" ")
    t = rng.choice([1, 2])
    num = toks[t][1:]
    dec = len(num.partition(".")[2])
    step = min(2e-3, 0.75 * 10.0 ** -dec) + 1e-7
    v = float(num) + rng.choice([-1, 1]) * step * rng.choice([0.5, 0.999999, 1.0, 1.000001, 1.5])
    toks[t] = toks[t][0] + f"{v:.{min(dec + 3, 8)}f}"
    lines[k] = " ".join(toks)
    return "\n".join(lines)


@pytest.mark.parametrize("name", ["prusa_gyroid.gcode", "prusa_absolute_e.gcode", "prusa_klipper.gcode"])
def test_fast_body_passes_only_what_python_passes(pure, tmp_path_factory, name):
    """Real blocks: the core passes nearly all (it is what runs); those blocks, their
    mutations, points moved about their tolerance and other arguments: whatever the core
    passes, the Python checks pass, and blocks the Python checks fail are among them."""
    _, _, calls, _ = _real_run(name, tmp_path_factory)
    n_core = 0
    for text, flavour, accel_max_a, geo, kw in calls:
        core, py = _fast_both(pure, text, flavour, accel_max_a, geo, kw)
        assert py
        n_core += core
    assert n_core >= 0.95 * len(calls)
    rng = random.Random(len(name))
    n_py_fail = n_core_pass = 0
    for _ in range(1500):
        text, flavour, accel_max_a, geo, kw = rng.choice(calls)
        how = rng.random()
        if how < 0.4:
            text = _mutate(text, rng)
        elif how < 0.7:
            text = _off_path(text, rng)
        else:
            text, flavour, accel_max_a, geo, kw = _other_args(rng, text, flavour, accel_max_a, geo, kw)
        core, py = _fast_both(pure, text, flavour, accel_max_a, geo, kw)
        assert py or not core, (text, flavour, accel_max_a, kw)
        n_py_fail += not py
        n_core_pass += core
    assert n_py_fail > 150 and n_core_pass > 350


def test_fast_body_on_synthetic_blocks(pure):
    """Blocks the emitter writes for synthetic strokes (points inside moves, comments,
    junction commands, absolute E, non-extruding) and their mutations, with a polyline,
    without one, and with a min_move_d: the core passes only what Python passes."""
    rng = random.Random(37)
    n_py_fail = n_core_pass = n_py_plain = n_core_plain = 0
    for _ in range(800):
        raws, x0, y0, e0, e_rel, ends, s, accels, feeds = _synthetic_stroke(rng)
        if rng.random() < 0.7:           # the values of a real plan
            accels = np.array([rng.choice([1500.0, rng.uniform(100, 2900)]) for _ in accels])
            feeds = np.array([rng.choice([50.0, rng.uniform(1, 300)]) for _ in feeds])
        flavour = rng.choice(["klipper", "marlin2", "marlin-legacy", "rrf"])
        st = emit.StrokeText(raws, f"{x0:.8f}", f"{y0:.8f}", 0)
        st.e_start_units = int(round(e0 * 10 ** st.dec_e))
        extruding = rng.random() < 0.9
        try:
            text = emit.emit_stroke(st, ends, s, None, accels, feeds, x0_text=f"{x0:.8f}", y0_text=f"{y0:.8f}",
                                    e_rel=e_rel, flavour=flavour, accel_restore=1000.0, mcr_restore=0.0,
                                    feed_restore_v=30.0, extruding=extruding,
                                    header=": replaces 3 lines, kind=line, 4 segments",
                                    first_cmds=rng.choice([None, None, ("M205 X5 Y5", "M205 X8 Y8")]))
        except Exception:                # noqa: BLE001 -- a plan the emitter refuses: no block
            continue
        pts = [(x0, y0)] + [(float(x), float(y)) for x, y in zip(st.x_texts, st.y_texts)]
        e_words = [float(t) for t, g in zip(st.e_texts, st.e_given) if g]
        e_check = None if not e_words else ((True, math.fsum(e_words)) if e_rel else (False, e_words[-1]))
        kw = dict(extruding=extruding, kind=rng.choice(["line", None]), e_check=e_check,
                  min_move_d=rng.choice([0.0, 0.07, 0.3]))
        geo = rng.choice([(pts, None), (pts, None), None])
        accel_max_a = rng.choice([3000.0, 3000.0, 1500.0])
        for j, block in enumerate((text, _mutate(text, rng), _off_path(text, rng))):
            core, py = _fast_both(pure, block, flavour, accel_max_a, geo, kw)
            assert py or not core, block
            n_py_fail += not py
            n_core_pass += core
            if j == 0 and py:            # an unchanged block Python's column pass takes: the core's
                n_py_plain += 1
                n_core_plain += core
    assert n_py_fail > 100 and n_core_pass > 200 and n_core_plain > 0.9 * n_py_plain and n_py_plain > 100


def test_fast_body_at_the_path_tolerance(pure):
    """A point beside a segment, at distances stepping through its tolerance (0.75 units
    of its last decimal, capped, + 1e-7) for 3 to 8 decimals, on horizontal, diagonal and
    other segments: the core passes only points Python passes, and most of those."""
    rng = random.Random(47)
    n_py_pass = n_core_pass = n_py_fail = 0
    for dec in range(3, 9):
        unit = 10.0 ** -dec
        for ang in [0.0, math.pi / 4, 1.0, 2.5, rng.uniform(0, math.pi)]:
            ax, ay = 100.0, 50.0
            bx, by = round(ax + 10 * math.cos(ang), 3), round(ay + 10 * math.sin(ang), 3)
            nx, ny = -math.sin(ang), math.cos(ang)
            for m in range(0, 40):
                d = m * unit * 0.25
                px, py = f"{(ax + bx) / 2 + d * nx:.{dec}f}", f"{(ay + by) / 2 + d * ny:.{dec}f}"
                text = (f"; gcode-opt begin: replaces 1 lines, kind=line\nM204 S1000\nG1 X{px} Y{py} E0.1 F600\n"
                        f"G1 X{bx:.3f} Y{by:.3f} E0.1 F600\n; gcode-opt end\n")
                geo = ([(ax, ay), (bx, by)], None)
                kw = dict(kind="line", e_check=(True, 0.2), min_move_d=0.0)
                core, py = _fast_both(pure, text, "klipper", 3000.0, geo, kw)
                assert py or not core, text
                n_py_pass += py
                n_core_pass += core
                n_py_fail += not py
    assert n_py_fail > 300 and n_py_pass > 200 and n_core_pass > 0.95 * n_py_pass
    # the segment placed at the tolerance from the point, a relative 1e-3 .. 1e-15 or an
    # ulp either side: the verdict flips there, and the core never passes a point Python fails
    n_py_fail = n_py_pass = 0
    for yt, dec in (("50.5", 1), ("50.125", 3), ("50.12345678", 8), ("-3.0625", 4)):
        tol = min(2e-3, 0.75 * 10.0 ** -dec) + 1e-7
        for eps in (1e-3, 1e-6, 1e-9, 1e-12, 1e-15, 0.0):
            for sign in (-1, 1):
                for side in (-1, 1):
                    y_seg = float(yt) - side * tol * (1 + sign * eps)
                    for y_s in (y_seg, math.nextafter(y_seg, math.inf), math.nextafter(y_seg, -math.inf)):
                        text = (f"; gcode-opt begin: replaces 1 lines, kind=line\nM204 S1000\nG1 X20 Y{yt} E0.1 F600\n"
                                f"; gcode-opt end\n")
                        core, py = _fast_both(pure, text, "klipper", 3000.0, ([(10.0, y_s), (30.0, y_s)], None),
                                              dict(kind="line", e_check=(True, 0.1)))
                        assert py or not core, (yt, eps, sign, side)
                        n_py_fail += not py
                        n_py_pass += py
    assert n_py_fail > 50 and n_py_pass > 50


def test_fast_body_declines_what_it_does_not_read():
    """Arcs, coordinates past _polyline_walk's bound, a text not ASCII: the core declines
    (the Python checks run)."""
    body = "; gcode-opt begin: replaces 1 lines, kind=line\nM204 S1000\nG1 X1 Y1 E0.1 F600\n; gcode-opt end\n"
    g = Geometry([(0.0, 0.0), (1.0, 1.0)])
    assert validate._fast_core(body, body.find("\n"), "klipper", "S", 3000.0, g, (True, 0.1), 0.0)
    arc = Geometry([(0.0, 0.0), (1.0, 1.0)], (0.5, 0.5, 0.7, 0.0, 1.0))
    assert not validate._fast_core(body, body.find("\n"), "klipper", "S", 3000.0, arc, None, 0.0)
    big = Geometry.polyline([0.0, 1e151], [0.0, 1.0])
    assert not validate._fast_core(body, body.find("\n"), "klipper", "S", 3000.0, big, None, 0.0)
    odd = body.replace("kind=line", "kind=lineé")
    assert not validate._fast_core(odd, odd.find("\n"), "klipper", "S", 3000.0, g, None, 0.0)


# ------------------------------------------------------------------ whole files
@pytest.mark.parametrize("name", ["prusa_gyroid.gcode",     # the others' core bytes: test_speed_rewrite_text
                                  pytest.param("prusa_klipper.gcode", marks=pytest.mark.slow),
                                  pytest.param("prusa_absolute_e.gcode", marks=pytest.mark.slow)])
def test_rewrite_same_bytes_with_and_without_core(pure, tmp_path, name):
    prof, opts, strokes, plan = _planned(name, dict(CASES)[name])
    with_core = _rewrite(SAMPLES + name, strokes, plan, prof, opts, tmp_path, "core")
    without = pure(_rewrite, SAMPLES + name, strokes, plan, prof, opts, tmp_path, "pure")
    assert with_core[0] == without[0] and with_core[1:] == without[1:]
    assert sum(with_core[2]) > 0


def test_pure_python_asked_leaves_the_core_out():
    code = "from gcode_opt import emit, validate; print(emit.CORE, validate._FAST_BODY is None, emit.CORE_WHY)"
    env = dict(os.environ, GCODE_OPT_PURE_PYTHON="1")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.startswith("python True GCODE_OPT_PURE_PYTHON")


def test_core_reads_plan_arrays_without_keeping_anything():
    """The plan's float64 arrays reach the core as their bytes (the same doubles as their
    tolist()), not through the buffer protocol: numpy would keep a buffer's format and
    shape with each array until it dies, and the plan's arrays live to the end of the run.
    Emitting from 2000 live plans leaves no traced memory behind."""
    import tracemalloc
    rng = np.random.default_rng(5)
    a = rng.uniform(100, 3000, 17)
    assert emit._doubles(a) == a.tobytes() and np.frombuffer(emit._doubles(a)).tolist() == a.tolist()
    assert emit._doubles(a[::2]) == a[::2].tobytes()                  # a strided view: its own items
    assert emit._doubles(a.astype(np.float32)) == a.astype(np.float32).tolist()   # the list path
    assert emit._doubles(a.astype(">f8")) == a.tolist()
    raws = ["G1 X10.5 Y20 E.5\n", "G1 X12 Y20 E1\n"]
    plans = []
    for _ in range(2000):
        s = np.array([0.0, 0.25, 0.5, 1.0, 2.0])
        plans.append((np.array([0.5, 2.0]), s, rng.uniform(100, 3000, 4), rng.uniform(10, 200, 4)))
    kw = dict(x0_text="10.00000000", y0_text="20.00000000", e_rel=True, flavour="klipper", accel_restore=1000.0,
              mcr_restore=0.0, feed_restore_v=30.0, extruding=True, header=": h", first_cmds=None)
    st = emit.StrokeText(raws, "10.00000000", "20.00000000", 0)
    emit.emit_stroke(st, *plans[0][:2], None, *plans[0][2:], **kw)        # warm: caches, code paths
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        for ends, s, acc, feeds in plans:
            assert emit._emit_core(st, ends, s, acc, feeds, kw["x0_text"], kw["y0_text"], True, "klipper", 1000.0,
                                   0.0, 30.0, True, ": h", None) is not None
        grown = tracemalloc.get_traced_memory()[0] - before
    finally:
        tracemalloc.stop()
    assert grown < 20_000, grown
    # an array handed over as it is: the core does not read it (declines)
    assert CORE.emit_body("h\n", st.x_texts, st.y_texts, st.e_texts, st.comments, plans[0][1], plans[0][2].tobytes(),
                          plans[0][3].tobytes(), plans[0][0].tobytes(), st.dec_xy, st.dec_e, True, True, 0,
                          "10.00000000", "20.00000000", "M204 S", "\n", None, None, "end\n") is None


def test_polyline_points_made_when_read():
    """Geometry.polyline keeps the vertex lists (the core reads them); pts is made from them
    when read, and a pts set afterwards is the path the checks walk."""
    g = Geometry.polyline([0.0, 1.0, 3.0], [0.0, 2.0, 2.0])
    assert g._pts is None and g.pts == [(0.0, 0.0), (1.0, 2.0), (3.0, 2.0)]
    assert validate._polyline_walk(g) == ([0.0, 1.0, 3.0], [0.0, 2.0, 2.0])
    g.pts = [(5.0, 5.0), (6.0, 6.0)]
    assert validate._polyline_walk(g) == ([5.0, 6.0], [5.0, 6.0])
    assert Geometry.polyline([0.0, 1e151], [0.0, 1.0]).pts == [(0.0, 0.0), (1e151, 1.0)]
    assert validate._polyline_walk(Geometry.polyline([0.0, 1e151], [0.0, 1.0])) is None
