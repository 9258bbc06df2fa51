"""The rewrite core's line scan and start/head digits (issue 8, session 45):

  * skip_n and skip_lines find a line's end by line_break_at (a 16-byte SSE2 scan for
    "\\n" or "\\r", the rest byte by byte) where skip_n took memchr for "\\n" and then for a
    "\\r" before it: skip_lines against the text reading and against the replaced byte
    loop, on lines of every length about the 16-byte steps; stroke_run (skip_n) on a
    sample whose untouched lines carry long comments and "\\r\\n" ends, against
    pipeline's reference rewrite (test_speed20's ede93db copy);
  * fmt_f_n's digits by f_digits (n's last 8 digits one digits8 store, the leading zeros
    of |x| < 1 cut by ctz) against PyOS_double_to_string (format_check) on the doubles
    where that matters: n about multiples of 10^8, |x| < 1 with any count of leading
    zeros, halfway cases, every precision 0..20."""
from __future__ import annotations

import copy
import itertools
import math
import random
import struct
import types

import pytest

from gcode_opt import emit, pipeline

from test_speed20_rewrite_core import SAMPLES, _text_lines, ref_rewrite

CORE = emit.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "skip_lines"),
                                reason=f"no compiled emit core: {emit.CORE_WHY}")


def _old_skip(data, pos, n, final):
    """skip_lines as it was (f656414's byte loop): (end, got)."""
    got, size = 0, len(data)
    while got < n and pos < size:
        q = pos
        while q < size and data[q] not in b"\r\n":
            q += 1
        if q == size:
            return size, got + final
        pos = q + 1
        if data[q:q + 1] == b"\r" and pos < size and data[pos:pos + 1] == b"\n":
            pos += 1
        got += 1
    return pos, got


def _long_lines(rng, n_lines):
    """Lines of 0..70 bytes (every offset of a 16-byte step) and a few of hundreds, their
    ends "\\n", "\\r", "\\r\\n" or none, some with a lone "\\r" inside."""
    parts = []
    for _ in range(n_lines):
        m = rng.choice([rng.randrange(0, 70), rng.randrange(0, 70), rng.randrange(200, 700)])
        body = bytearray(rng.choice(b"G1 X0.5;abc\xc3\xa9 ") for _ in range(m))
        if m and rng.random() < 0.15:
            body[rng.randrange(m)] = 13
        parts.append(bytes(body) + rng.choice([b"\n", b"\n", b"\r\n", b"\r", b""]))
    return b"".join(parts)


def test_skip_lines_long_lines():
    rng = random.Random(4501)
    for _ in range(300):
        data = _long_lines(rng, rng.randrange(0, 40))
        # the end of the first k lines, every k: the text reading's
        ends = list(itertools.accumulate(len(ln) for ln in _text_lines(data)))
        got = [CORE.skip_lines(data, 0, k + 1, True) for k in range(len(ends))]
        assert got == [(z, k + 1) for k, z in enumerate(ends)]
        for _ in range(10):
            pos = rng.randrange(0, len(data) + 1)
            n = rng.randrange(0, 12)
            final = rng.random() < 0.5
            assert CORE.skip_lines(data, pos, n, final) == _old_skip(data, pos, n, final), (data, pos, n, final)


def _planned_file(path, prof_name, features=None):
    from gcode_opt.profile import load_profile
    from gcode_opt.schedule import plan_inputs, plan_strokes
    prof = load_profile(prof_name)
    opts = pipeline.Options() if features is None else pipeline.Options(features=features)
    strokes, sim0 = pipeline.analyse(str(path), prof, opts)
    plan = plan_strokes(strokes, plan_inputs(strokes, prof, opts), prof, opts, opts.max_slowdown_r * sim0.time_t)
    return prof, opts, strokes, plan


def _rewrite(fn, path, strokes, plan, prof, opts, out):
    plan = copy.deepcopy(plan)
    digests = {}
    with open(out, "w", encoding="utf-8", errors="surrogateescape", newline="") as fh:
        ranges = fn(str(path), fh, strokes, plan, prof, opts, digests)
    return open(out, "rb").read(), ranges, digests, list(plan.reason), plan.retime.tolist()


def _run_counted(monkeypatch, path, strokes, plan, prof, opts, out):
    """pipeline.rewrite with the run on, through a module counting the strokes each
    stroke_run call took: (the rewrite's result, strokes taken)."""
    runs = []

    class Counted(types.ModuleType):              # (the run is taken through modules only)
        def __getattr__(self, name):
            return getattr(CORE, name)

        def stroke_run(self, *args):
            r = CORE.stroke_run(*args)
            runs.append(r[0] - args[4])               # the strokes the call took
            return r

    with monkeypatch.context() as m:
        m.setattr(emit, "CORE_MOD", Counted("_gcode_opt_emit_counted"))
        m.setattr(pipeline, "_STROKE_RUN", True)
        got = _rewrite(pipeline.rewrite, path, strokes, plan, prof, opts, out)
    return got, sum(runs)


def test_run_over_long_and_odd_untouched_lines(tmp_path, monkeypatch):
    """The untouched lines between strokes (comments of up to ~700 bytes, "\\r\\n" ends;
    a lone "\\r" is an input error) skipped by stroke_run's skip_n: the reference's bytes,
    ranges, digests."""
    rng = random.Random(4502)
    src = open(SAMPLES + "prusa_gyroid.gcode", "rb").read().split(b"\n")
    out = []
    for ln in src:
        if ln.startswith(b";") or ln.startswith(b"M") or not ln:
            r = rng.random()
            if r < 0.3:
                ln += b" ;" + b"x" * rng.choice([rng.randrange(0, 40), rng.randrange(200, 700)])
            elif r < 0.4:
                ln += b"\r"                                         # a "\r\n" end
        out.append(ln)
    path = tmp_path / "odd.gcode"
    path.write_bytes(b"\n".join(out))
    prof, opts, strokes, plan = _planned_file(path, "prusa-mk3s")
    ref = _rewrite(ref_rewrite, path, strokes, plan, prof, opts, tmp_path / "ref.gcode")
    got, taken = _run_counted(monkeypatch, path, strokes, plan, prof, opts, tmp_path / "run.gcode")
    assert got == ref
    assert taken > 100, taken                             # the run took strokes past those lines


def _f_doubles(rng, n):
    out = [0.0, -0.0, 5e-324, 1.0, 0.5, 0.05, 0.00005, 0.00000005, 0.000000005, 99999999.5, 1e8, 1e8 - 1e-8]
    for _ in range(n):
        kind = rng.random()
        prec = rng.choice((4, 8, rng.randrange(0, 9)))
        if kind < 0.25:                      # n about a multiple of 10^8 (the store's split)
            x = (rng.randrange(0, 10 ** rng.randrange(1, 5)) * 10 ** 8 + rng.randrange(-3, 4)) / 10 ** prec
        elif kind < 0.5:                     # |x| < 1: any count of leading zeros
            x = rng.randrange(1, 10 ** rng.randrange(1, 9)) / 10 ** rng.randrange(1, 12)
        elif kind < 0.7:                     # halfway cases of prec decimals
            x = (rng.randrange(0, 10 ** rng.randrange(1, 12)) + 0.5) / 10 ** prec
        elif kind < 0.85:                    # plate coordinates and times
            x = rng.uniform(0, 400) if rng.random() < 0.5 else rng.uniform(0, 1e4)
        else:                                # a random bit pattern (finite)
            x = struct.unpack("<d", struct.pack("<Q", rng.getrandbits(64)))[0]
            if not math.isfinite(x):
                x = 2.5
        out.append(-x if rng.random() < 0.4 else x)
    return out


def test_fmt_f_digits_are_python():
    rng = random.Random(4503)
    raw = struct.pack("<%dd" % 60_000, *_f_doubles(rng, 60_000 - 12))
    xs = struct.unpack("<%dd" % 60_000, raw)
    for prec in range(0, 21):
        taken, bad = CORE.format_check(raw, "f", prec)
        assert bad == -1, (prec, xs[bad], CORE.format_text(xs[bad], "f", prec), format(xs[bad], f".{prec}f"))
        assert taken > (40_000 if prec <= 8 else 5_000), (prec, taken)   # (f_digits: prec <= 8)


def test_run_reads_its_strokes_to_their_end(tmp_path, monkeypatch):
    """stroke_run without skip_n over a stroke's own lines (block_into reads them to their
    end from the data's end): strokes whose later lines end "\\r\\n", a first line ending
    "\\r\\n" (declined), and the file cut after a re-timed stroke's last line without its
    line end (declined: the loop's): the reference rewrite's bytes, ranges, digests, and
    the run still taking strokes."""
    prof, opts, strokes, plan = _planned_file(SAMPLES + "prusa_gyroid.gcode", "prusa-mk3s")
    lines = open(SAMPLES + "prusa_gyroid.gcode", "rb").read().split(b"\n")
    retimed = sorted((strokes[i] for i in range(len(strokes)) if plan.retime[i]), key=lambda s: s.first_idx)
    rng = random.Random(4504)
    for st in retimed[5:-5]:
        r = rng.random()
        if r < 0.3 and st.last_idx > st.first_idx:          # later lines "\r\n"
            for j in range(st.first_idx + 1, st.last_idx + 1):
                if rng.random() < 0.7:
                    lines[j] += b"\r"
        elif r < 0.35:                                      # the first line "\r\n"
            lines[st.first_idx] += b"\r"
    last = retimed[len(retimed) * 3 // 4]
    data = b"\n".join(lines[:last.last_idx + 1])            # (no line end after its last line)
    path = tmp_path / "ends.gcode"
    path.write_bytes(data)
    prof, opts, strokes, plan = _planned_file(path, "prusa-mk3s")
    assert any(s.last_idx == data.count(b"\n") and plan.retime[i] for i, s in enumerate(strokes))
    ref = _rewrite(ref_rewrite, path, strokes, plan, prof, opts, tmp_path / "ref.gcode")
    got, taken = _run_counted(monkeypatch, path, strokes, plan, prof, opts, tmp_path / "run.gcode")
    assert got == ref
    assert taken > 100, taken


def _fresh(text):
    """An equal str that is not the same object (not interned)."""
    out = "".join(list(text))
    assert out == text and out is not text or len(text) <= 1
    return out


def test_run_compares_feature_and_kind_by_value(tmp_path, monkeypatch):
    """stroke_run's travel and arc tests (str_eq: identity, else an ASCII str's length and
    bytes; other objects the rich comparison): strokes whose feature and kind are equal
    str that are other objects give the bytes of the originals, the run taking the same
    strokes (a travel stroke taken as extruding fails its check: the loop's); a str
    subclass the same bytes (by the loop)."""
    import re
    from gcode_opt import features as feat
    # travel moves without their F word: plain lines, travel strokes the run takes
    text = open(SAMPLES + "prusa_gyroid_arcs.gcode", "rb").read()
    path = tmp_path / "travel.gcode"
    path.write_bytes(re.sub(rb"^(G1 X[-.0-9]+ Y[-.0-9]+) F10800$", rb"\1", text, flags=re.M))
    prof, opts, strokes, plan = _planned_file(path, "prusa-mk3s", feat.ALL)

    class Sub(str):
        pass

    def counted_rewrite(sts, out):
        return _run_counted(monkeypatch, path, sts, plan, prof, opts, out)

    want, taken = counted_rewrite(strokes, tmp_path / "want.gcode")
    n_travel = sum(1 for i, s in enumerate(strokes) if s.feature == feat.TRAVEL and plan.retime[i])
    assert n_travel > 5 and any(s.kind == "arc" for s in strokes) and taken > 100
    for make in (_fresh, Sub):
        odd = copy.deepcopy(strokes)
        for s in odd:
            s.feature = make(s.feature)
            s.kind = make(s.kind)
        got, got_taken = counted_rewrite(odd, tmp_path / "got.gcode")
        assert got == want, make
        # (a subclass's kind is not a text the run writes: the loop takes every stroke)
        assert got_taken == (taken if make is _fresh else 0), (make, got_taken, taken)


def test_run_copies_vertex_texts_of_any_length(tmp_path, monkeypatch):
    """A vertex's texts copied by emit_cols (copy_short; a 16-byte copy where the data had
    16 bytes to read was measured and not kept): X, Y and E texts padded with leading
    zeros to 1..20 bytes, and the file ending right after a re-timed stroke (the block
    block_into reads to the data's end): the reference rewrite's bytes, ranges and
    digests, the run taking strokes."""
    import re
    rng = random.Random(4505)
    lines = open(SAMPLES + "prusa_gyroid.gcode", "rb").read().split(b"\n")

    def pad(m):
        word, num = m.group(1), m.group(2)
        if rng.random() < 0.5:
            return m.group(0)
        neg = num.startswith(b"-")
        body = num[1:] if neg else num
        body = b"0" * rng.randrange(0, max(1, 18 - len(body))) + body
        return word + (b"-" if neg else b"") + body

    lines = [re.sub(rb"( [XYE])(-?[0-9]*\.?[0-9]+)", pad, ln) if ln.startswith(b"G1 X") else ln for ln in lines]
    prof, opts, strokes, plan = _planned_file(SAMPLES + "prusa_gyroid.gcode", "prusa-mk3s")
    last = sorted((s for i, s in enumerate(strokes) if plan.retime[i] and s.last_idx > s.first_idx + 2),
                  key=lambda s: s.first_idx)[-3]
    path = tmp_path / "pad.gcode"
    path.write_bytes(b"\n".join(lines[:last.last_idx + 1]) + b"\n")
    prof, opts, strokes, plan = _planned_file(path, "prusa-mk3s")
    ref = _rewrite(ref_rewrite, path, strokes, plan, prof, opts, tmp_path / "ref.gcode")
    got, taken = _run_counted(monkeypatch, path, strokes, plan, prof, opts, tmp_path / "run.gcode")
    assert got == ref
    assert taken > 50, taken
    # the last stroke's block written by the run (its texts at the data's end)
    assert got[0].rstrip(b"\n").endswith(b"; gcode-opt end")
