"""Session 32's cheaper C loops of the rewrite (_emit.c) at the same bits:

  * the hand-made float texts (fmt_f, fmt_g4: the block heads' T and beta, the start's
    x0/y0 texts) against PyOS_double_to_string, which format() calls, on ~3 M random and
    edge doubles (exact binary ties, 9.9995-style carries, -0.0, subnormals, values at
    the 2^64 bound, the '.4g' range's ends), and against format() on the edges;
  * put_units / put_tenths_up (two digits a division) against emit._fmt_units /
    emit._tenths_up;
  * the validator's one-pass number reading (dec_value) against the two passes it
    replaced (plain_decimal, then to_double);
  * stroke_run's attribute reads by the types' descriptors: a type changed between runs
    (a property put over a slot) is read anew, as the loop's Python reads it;
  * RowPlan rows read in place from their 2-D blocks (C order, a strided block, Fortran
    order, a negative row): the same bytes as the reference rewrite."""
from __future__ import annotations

import copy
import random
import struct

import numpy as np
import pytest

from gcode_opt import emit, pipeline, segments

from test_speed20_rewrite_core import SAMPLES, _planned, _run, ref_rewrite

CORE = emit.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "format_check"),
                                reason=f"no compiled emit core with the session-32 hooks: {emit.CORE_WHY}")


def _bits(xs):
    return struct.pack(f"<{len(xs)}d", *xs)


# ------------------------------------------------------------------ float texts
def _edges():
    base = [0.0, -0.0, 5e-324, -5e-324, 2.2250738585072014e-308, 1e-300, 1e-20, 1e-9, 5e-9, 4.9999999e-9,
            1e-5, 1e-4, 0.0001, 0.00099995, 0.0009999, 0.5, 0.125, 0.375, 0.625, 1.0, 2.5, 9.9995, 99.995,
            0.99995, 999.95, 9999.5, 9999.4999, 9999.49999, 1e4, 10000.5, 1.8e11, -1.8e11, 1.8446744073709552e11,
            1.8446744073709552e15, 1e19, 1.8446744073709552e19, 2.0 ** 64, 2.0 ** 63, 1e300, 1.7976931348623157e308,
            123.456, -123.456, 0.1, 0.2, 0.3, 2.675, 1.005, 1.0000000049999999, 0.000049995, 0.00005]
    out = []
    with np.errstate(over="ignore"):
        for v in base:
            for x in (v, -v):
                out += [x, float(np.nextafter(x, np.inf)), float(np.nextafter(x, -np.inf))]
    # exact binary ties at 4 and 8 decimals: odd / 2^(p+1) (x 10^p = odd 5^p / 2)
    for p in (4, 8):
        out += [k / 2.0 ** (p + 1) for k in range(1, 4000, 2)]
        out += [(2 ** 40 + k) / 2.0 ** (p + 1) for k in range(1, 400, 2)]
    return out


def _random_sets(n):
    rng = np.random.default_rng(32)
    return [rng.uniform(-300.0, 300.0, n),                                     # coordinates, mm
            rng.uniform(0.0, 30.0, n),                                        # times, s
            np.exp(rng.uniform(-25.0, 25.0, n)) * rng.choice([-1.0, 1.0], n),  # every scale
            rng.integers(0, 2 ** 63, n, dtype=np.uint64).view(np.float64),     # any bits
            (rng.integers(-10 ** 12, 10 ** 12, n) + 0.5) / 1e8,               # near 8-decimal halves
            (rng.integers(-10 ** 8, 10 ** 8, n) + 0.5) / 1e4,                 # near 4-decimal halves
            rng.integers(-2 ** 40, 2 ** 40, n) / 2.0 ** rng.integers(0, 45, n)]   # dyadic: exact ties


@pytest.mark.parametrize("code,prec", [("f", 8), ("f", 4), ("g", 4)])
def test_float_texts_against_pyos(code, prec):
    """~1 M doubles per format (3 M in all): every text the hand path makes is the one
    PyOS_double_to_string makes, and it takes nearly all of the common values."""
    taken = total = 0
    for arr in _random_sets(140_000) + [np.array(_edges())]:
        got, bad = CORE.format_check(np.ascontiguousarray(arr, dtype=np.float64).tobytes(), code, prec)
        assert bad == -1, (code, prec, float(arr[bad]), CORE.format_text(float(arr[bad]), code, prec))
        taken += got
        total += len(arr)
    assert taken > 0.5 * total, (taken, total)
    # the common values are all taken
    rng = np.random.default_rng(7)
    common = rng.uniform(0.001 if code == "g" else -300.0, 300.0, 20_000)
    assert CORE.format_check(common.tobytes(), code, prec) == (len(common), -1)


def test_float_texts_against_format():
    """format() itself on the edges and a sweep; declines (None) only where the hand path
    does not go: not finite, past 2^64 units, a '.4g' text with an exponent or of zero."""
    xs = _edges() + [float(v) for v in np.random.default_rng(3).uniform(-1e4, 1e4, 20_000)]
    for x in xs:
        for code, prec in (("f", 8), ("f", 4), ("f", 0), ("f", 1), ("f", 12), ("f", 20), ("g", 4)):
            t = CORE.format_text(x, code, prec)
            if t is not None:
                assert t == format(x, f".{prec}{code}"), (x, code, prec, t)
    for x in (float("inf"), float("-inf"), float("nan"), 1e300, 2.0 ** 64 / 1e8 * 2):
        assert CORE.format_text(x, "f", 8) is None, x
    for x in (0.0, -0.0, 1e-5, 99995.0, 9999.5, 12345.0, float("nan")):
        assert CORE.format_text(x, "g", 4) is None, x
    assert CORE.format_text(9999.4, "g", 4) == "9999"
    assert CORE.format_text(9.9995, "f", 3) == format(9.9995, ".3f")
    assert CORE.format_text(-0.0, "f", 8) == "-0.00000000"
    assert CORE.format_text(-1e-12, "f", 4) == "-0.0000"
    assert CORE.format_text(0.00012345, "g", 4) == "0.0001234"      # a tie below: even
    assert CORE.format_text(1200.0, "g", 4) == "1200" and CORE.format_text(0.5, "g", 4) == "0.5"


# ------------------------------------------------------------------ integer texts
def test_units_and_tenths_texts():
    rng = random.Random(32)
    us = [0, 1, -1, 9, 10, 99, 100, 101, -100, 10 ** 15, -10 ** 15, 2 ** 53, -(2 ** 53), 2 ** 62, -(2 ** 63) + 1]
    us += [rng.randint(-10 ** 9, 10 ** 9) for _ in range(20_000)]
    us += [rng.randint(-(2 ** 62), 2 ** 62) for _ in range(5_000)]
    us += [rng.randint(-999, 999) * 10 ** rng.randint(0, 12) for _ in range(5_000)]
    for u in us:
        for dec in (-1, 0, 1, 3, 5, 8, 15, 30):
            assert CORE.units_text(u, dec) == emit._fmt_units(u, dec), (u, dec)
    assert CORE.units_text(5, 31) is None
    ks = [-5, 0, 1, 2, 9, 10, 11, 99, 100, 101, 12340, (1 << 50) - 1]
    ks += [rng.randint(2, 10 ** 7) for _ in range(20_000)] + [rng.randint(2, (1 << 50) - 1) for _ in range(2_000)]
    for k in ks:
        assert CORE.tenths_text(k) == emit._tenths_up(k), k


# ------------------------------------------------------------------ the validator's reading
def _random_number_text(rng):
    sign = rng.choice(["", "", "-"])
    whole = "".join(rng.choice("0123456789") for _ in range(rng.choice([0, 1, 1, 2, 3, 5, 9, 14, 16, 20])))
    frac = "".join(rng.choice("0123456789") for _ in range(rng.choice([0, 1, 2, 3, 5, 8, 12, 15, 17])))
    dot = rng.choice([".", ".", ""]) if frac == "" else "."
    tail = rng.choice(["", "", " F1200", " Y5", "x", ".5", "-", "e5"])
    return sign + whole + dot + frac + tail


def test_one_pass_number_reading():
    """dec_value (the validator's fused reading) against plain_decimal then to_double on
    200 k texts: the same length, decimals and bits (or the same refusal)."""
    rng = random.Random(320)
    texts = ["", "-", ".", "-.", "0", "-0", "-0.0", ".5", "5.", "123456789012345", "1234567890123456",
             "0.000000000000001", "0.0000000000000001", "99999999.99999999", "1" * 40, "-" + "9" * 30 + ".5"]
    texts += [_random_number_text(rng) for _ in range(200_000)]
    for t in texts:
        (n1, d1, v1), (n2, d2, v2) = CORE.dec_read(t)
        assert (n1, d1) == (n2, d2), t
        assert (v1 is None) == (v2 is None), t
        if v1 is not None:
            assert _bits([v1]) == _bits([v2]), t
            assert _bits([v1]) == _bits([float(t[:n1])]), t


# ------------------------------------------------------------------ stroke_run's reads
def test_a_changed_type_is_read_anew(tmp_path, monkeypatch):
    """A run (the descriptors kept), then SegmentPlan's time_t slot covered by a property
    that adds a second: the next run writes the property's T, as the reference does."""
    prof, opts, strokes, plan = _planned("prusa_gyroid.gcode", "prusa-mk3s")
    path = SAMPLES + "prusa_gyroid.gcode"
    before = _run(pipeline.rewrite, path, strokes, plan, prof, opts, tmp_path / "a.gcode")
    assert before == _run(ref_rewrite, path, strokes, plan, prof, opts, tmp_path / "r.gcode")
    slot = segments.SegmentPlan.__dict__["time_t"]
    with monkeypatch.context() as m:
        m.setattr(segments.SegmentPlan, "time_t", property(lambda self: slot.__get__(self) + 1.0,
                                                           lambda self, v: slot.__set__(self, v)))
        changed = _run(pipeline.rewrite, path, strokes, plan, prof, opts, tmp_path / "b.gcode")
        ref = _run(ref_rewrite, path, strokes, plan, prof, opts, tmp_path / "rb.gcode")
    assert changed == ref and changed[0] != before[0]
    after = _run(pipeline.rewrite, path, strokes, plan, prof, opts, tmp_path / "c.gcode")
    assert after == before


def _as_rowplans(plan, layout):
    """plan with each SegmentPlan / RowPlan made a RowPlan whose blocks hold its arrays as
    one row among others, laid out as `layout` says."""
    plan = copy.deepcopy(plan)
    for i, seg in enumerate(plan.segs):
        if seg is None:
            continue
        rows = [np.asarray(seg.s), np.asarray(seg.v), np.asarray(seg.accel), np.asarray(seg.feed)]
        blocks = []
        for j, r in enumerate(rows):
            other = r if j == 0 else r * 0.97             # (a valid plan: another row read writes other texts)
            b = np.stack([other, r, other])              # row 1 is the plan's
            if layout == "strided":
                b = np.repeat(b, 2, axis=0)[::2]         # rows 2 rows apart
            elif layout == "fortran":
                b = np.asfortranarray(b)                 # a row's doubles not contiguous
            blocks.append(b)
        row = -2 if layout == "negative" else 1          # numpy's -2 is row 1 of 3
        plan.segs[i] = segments.RowPlan(*blocks, row, seg.time_t, seg.int_a2, seg.shape, seg.first_cmds)
    return plan


@pytest.mark.parametrize("layout", ["c", "strided", "fortran", "negative"])
def test_rowplan_rows_read_in_place(layout, tmp_path):
    prof, opts, strokes, plan = _planned("prusa_gyroid.gcode", "prusa-mk3s")
    path = SAMPLES + "prusa_gyroid.gcode"
    want = _run(ref_rewrite, path, strokes, plan, prof, opts, tmp_path / "ref.gcode")
    rp = _as_rowplans(plan, layout)
    got = _run(pipeline.rewrite, path, strokes, rp, prof, opts, tmp_path / "got.gcode")
    assert got == want


# ------------------------------------------------------------------ the stroke lines' reading
def _noisy_line(rng):
    nums = ["0", "-0", "1.5", "-12.345", ".5", "-.25", "5.", "123.45678", "1" * 17, "0.1234567890123456",
            "-", ".", "-.", "1.2.3", "--1", "1-2", "+1", "1e5", "12a"]
    line = f"G1 X{rng.choice(nums)} Y{rng.choice(nums)}"
    if rng.random() < 0.7:
        line += f" E{rng.choice(nums)}"
    line += rng.choice(["", "", " ;c", "\t; a comment", "  ", " F1200", ";x\r", "\r", " ;a\rb"])
    if rng.random() < 0.2:
        k = rng.randrange(len(line))
        line = rng.choice([line[:k] + rng.choice(" XYE-.9;\t") + line[k + 1:], line[:k] + line[k + 1:]])
    return line


def test_stroke_line_reading():
    """plain_line (one pass a number: dec_value) against plain_moves' reading of the same
    line (num_run, plain_decimal, to_double, emit._plain_moves' twin) on 100 k plain and
    noisy lines: taken alike, with the same texts, comments and bits."""
    rng = random.Random(3232)
    taken = 0
    for _ in range(100_000):
        line = _noisy_line(rng)
        got = CORE.line_read(line)
        want = CORE.plain_moves([line + "\n"], "0", "0")
        assert (got is None) == (want is None), line
        if got is None:
            continue
        taken += 1
        xs, ys, es, given, comments, (xv, yv, ev), _, _ = want
        xt, yt, et, ct, dx, dy, de, x, y, e = got
        assert (xt, yt, et or "0", ct, et is not None) == (xs[0], ys[0], es[0], comments[0], given[0]), line
        assert _bits([x, y]) == _bits([xv[0], yv[0]]) and (e is None or _bits([e]) == _bits(ev)), line
        assert (dx, dy, de) == tuple(len(t.partition(".")[2]) for t in (xt, yt, et or "")), line
    assert taken > 10_000
