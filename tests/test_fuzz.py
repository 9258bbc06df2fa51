"""Mutation fuzzing of the real samples (issue 7, "never break a print").

Each case is a window of a real sample (~200 lines around infill, with the header's state
lines kept) damaged by one to three mutations, processed by the CLI in-process. The case
passes when either
  * exit 0: the output verifies against the input (toolpath, E, untouched lines), no
    written (re-timed) line carries a non-finite number, F <= 0 or an acceleration <= 0,
    no motion line of the output carries a non-finite number, and every block passes the
    flavour's validator (gcode_opt.validate, run here on the written file); or
  * exit 2 with `gcode-opt: IN:LINE: why` (or `gcode-opt: IN: why` for a whole file),
and in both cases the input is byte-identical, no temporary file is left behind, nothing
escapes as an exception, and it ends within HANG_T seconds.

The mutation engine (`build_case`, `check_case`) is shared with benchmarks/fuzz_campaign.py.
Minimal reproducers of bugs found live in tests/cases/ and run here as regression tests.
"""
from __future__ import annotations

import contextlib
import io
import os
import random
import re
import shutil
import signal
import tempfile
import traceback
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SAMPLES = ROOT / "sample_gcode"
CASES = Path(__file__).resolve().parent / "cases"
HANG_T = 60.0                       # s: a 200-line case takes ~1 s; anything near this is a hang

# ------------------------------------------------------------------ seeds ---
_STATE = re.compile(rb"^\s*(G9[01]|G2[01]|M8[23]|M20[1345]|SET_VELOCITY_LIMIT)\b", re.I)
_INFILL = re.compile(rb"^;\s*(TYPE|FEATURE)\s*:\s*(Solid infill|Internal infill|FILL|Sparse infill)", re.I)
_MOTION = re.compile(rb"^\s*G0*[0-3](?![0-9.])", re.I)
_WORDNUM = re.compile(rb"([XYZEF])(-?\d*\.?\d+)")


def _window(path: Path, lines_n: int = 200) -> bytes:
    """A self-contained window of a sample: the last of each state command before it,
    the position (and E, for absolute E) it starts from, then lines_n lines that begin
    a little before an infill section in the middle of the print."""
    lines = path.read_bytes().splitlines(keepends=True)
    marks = [i for i, l in enumerate(lines) if _INFILL.match(l)]
    start = max(marks[len(marks) // 2] - 20, 0) if marks else len(lines) // 2
    last = {}
    pos = {}
    for l in lines[:start]:
        m = _STATE.match(l)
        if m:
            last[m.group(1).upper()] = l
        if _MOTION.match(l):
            for k, v in _WORDNUM.findall(l.split(b";")[0]):
                pos[k] = v
        elif l.startswith(b"G92"):
            for k, v in _WORDNUM.findall(l.split(b";")[0]):
                pos[k] = v
    head = [b"; fuzz seed: %s from line %d\n" % (path.name.encode(), start + 1)]
    head += [last[k] for k in sorted(last)]
    if b"Z" in pos:
        head.append(b"G1 Z%s F720\n" % pos[b"Z"])
    if b"X" in pos and b"Y" in pos:
        head.append(b"G1 X%s Y%s F9000\n" % (pos[b"X"], pos[b"Y"]))
    if b"E" in pos and b"M82" in last:
        head.append(b"G92 E%s\n" % pos[b"E"])
    return b"".join(head + lines[start:start + lines_n])


def seeds() -> dict[str, bytes]:
    return {p.stem: _window(p) for p in sorted(SAMPLES.glob("*.gcode"))}


# -------------------------------------------------------------- mutations ---
WEIRD_NUMBERS = [b"nan", b"NaN", b"inf", b"-inf", b"Infinity", b"1e300", b"-1e300", b"2e1", b"1E5", b"3.5e-2",
                 b"99999999", b"123456.789", b"-0", b"0", b"1e-300", b"0.0000001", "\u0663".encode(),
                 "\uff11\uff10".encode(), b"0x10", b"1.2.3", b"--1", b"", b".", b"+.5", b"-", b"1_000", b"12,5"]
MODE_LINES = [b"G91\n", b"G20\n", b"M82\n", b"M83\n", b"G92 E0\n", b"G92 E-12.5\n", b"G92 X0 Y0\n", b"G92 Z5\n",
              b"G90\n", b"G21\n", b"M82\nG92 E0\n", b"G91\nG1 X1 Y1\nG90\n", b"G92\n", b"M83\nG1 E-1 F2400\n"]
TOOL_LINES = [b"T1\n", b"T0\n", b"T-1\n", b"T\n", b"T1 ; change\nG1 E5 F300\n", b"M6 T2\n", b"T2 S1\n",
              b"T1\nT0\n", b"T99\n"]
ACCEL_LINES = [b"M204 S0\n", b"M204 S-500\n", b"M204 P0\n", b"M204 P1000\n", b"M204 T0\n", b"M204 R0\n",
               b"M204\n", b"M204 S1e9\n", b"M204 Snan\n", b"M204 P-1 T-1\n", b"M204 S0.0001\n",
               b"SET_VELOCITY_LIMIT ACCEL=0\n", b"SET_VELOCITY_LIMIT ACCEL=-1\n", b"SET_VELOCITY_LIMIT ACCEL=nan\n",
               b"SET_VELOCITY_LIMIT ACCEL=inf\n", b"SET_VELOCITY_LIMIT SQUARE_CORNER_VELOCITY=0\n",
               b"SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=2\n", b"SET_VELOCITY_LIMIT ACCEL_TO_DECEL=0\n",
               b"SET_VELOCITY_LIMIT VELOCITY=0\n", b"SET_VELOCITY_LIMIT ACCEL=abc\n", b"SET_VELOCITY_LIMIT\n",
               b"M201 X0 Y0\n", b"M201 X-1000 Y-1000\n", b"M203 X0 Y0\n", b"M203 X-5\n", b"M205 X0 Y0\n",
               b"M205 J0\n", b"M205 X-1\n", b"M201 Xnan\n", b"M204 S500 T0\n", b"m204 s2000\n"]
FEED_WORDS = [b"F0", b"F-100", b"F1e9", b"F.001", b"Fnan", b"F", b"F99999999", b"F-0"]


def _motions(L):
    return [i for i, l in enumerate(L) if _MOTION.match(l)]


def _pick_motion(r, L):
    m = _motions(L)
    return r.choice(m) if m else (r.randrange(len(L)) if L else None)


def _xy_at(L, i):
    """Last X, Y written at or before line i (floats; 100, 100 if unknown)."""
    x = y = None
    for l in reversed(L[:i + 1]):
        code = l.split(b";")[0]
        for k, v in _WORDNUM.findall(code):
            try:
                if k == b"X" and x is None:
                    x = float(v)
                if k == b"Y" and y is None:
                    y = float(v)
            except ValueError:
                pass
        if x is not None and y is not None:
            break
    return (100.0 if x is None else x), (100.0 if y is None else y)


def m_delete(r, L):
    i = r.randrange(len(L))
    del L[i:i + r.randint(1, 5)]


def m_duplicate(r, L):
    i = r.randrange(len(L))
    L[i:i] = L[i:i + r.randint(1, 3)] * r.randint(1, 2)


def m_swap(r, L):
    i = r.randrange(len(L))
    j = min(len(L) - 1, max(0, i + r.randint(-3, 3))) if r.random() < 0.7 else r.randrange(len(L))
    L[i], L[j] = L[j], L[i]


def m_digit_flip(r, L):
    i = _pick_motion(r, L)
    digits = [k for k, c in enumerate(L[i]) if 48 <= c <= 57]
    if digits:
        k = r.choice(digits)
        L[i] = L[i][:k] + bytes([48 + r.randrange(10)]) + L[i][k + 1:]


def m_number(r, L):
    i = _pick_motion(r, L)
    nums = list(re.finditer(rb"(?<=[XYZEFIJRxyzef])-?\d*\.?\d+", L[i]))
    if nums:
        m = r.choice(nums)
        L[i] = L[i][:m.start()] + r.choice(WEIRD_NUMBERS) + L[i][m.end():]


def m_truncate(r, L):
    data = b"".join(L)
    cut = r.randrange(1, len(data)) if len(data) > 1 else 0
    L[:] = data[:cut].splitlines(keepends=True)


def m_mode(r, L):
    L.insert(r.randrange(len(L) + 1), r.choice(MODE_LINES))


def m_bad_arc(r, L):
    i = _pick_motion(r, L)
    x, y = _xy_at(L, i)
    g = r.choice((b"G2", b"G3"))
    arcs = [b"%s X%.3f Y%.3f I5 J3 E0.5" % (g, x + 10, y),                # end off the circle
            b"%s X%.3f Y%.3f I0 J0 E0.1" % (g, x, y),                     # zero radius
            b"%s X%.3f Y%.3f I0 J1000000 E0.2" % (g, x + 5, y),           # huge radius
            b"%s X%.3f Y%.3f I0 J1e6 E0.2" % (g, x + 5, y),
            b"%s X%.3f Y%.3f I1e300 J0 E0.2" % (g, x + 5, y),
            b"%s X%.3f Y%.3f R5 E0.4" % (g, x + 6, y),                    # R form
            b"%s X%.3f Y%.3f R-3 E0.4" % (g, x + 4, y + 1),
            b"%s X%.3f Y%.3f R0 E0.4" % (g, x + 4, y),
            b"%s X%.3f Y%.3f R1e9 E0.4" % (g, x + 4, y),
            b"%s X%.3f Y%.3f R1 E0.4" % (g, x + 10, y),                   # R shorter than half the chord
            b"%s X%.3f Y%.3f E0.3" % (g, x + 10, y),                      # no I/J/R
            b"%s X%.3f Y%.3f I5 J0 E1.5" % (g, x, y),                     # full circle
            b"%s X%.4f Y%.3f I0.0005 J0 E0.0001" % (g, x + 0.001, y),     # tiny
            b"%s X%.3f Y%.3f Z5 I5 J0 E0.5" % (g, x + 10, y),             # helical
            b"%s X%.3f Y%.3f I5 J0 P3 E2" % (g, x + 10, y),               # several turns
            b"%s X%.3f Y%.3f I5 J0 E0.5 F3000" % (g, x + 10, y),          # a good arc
            b"%s X%.3f Y%.3f I5.001 J0.002 E0.5" % (g, x + 10, y),        # end a hair off
            b"%s I5 J0 E0.5" % g]                                         # no end: full circle in place
    L.insert(i + 1, r.choice(arcs) + b"\n")


def _checksum(code: bytes) -> int:
    cs = 0
    for c in code:
        cs ^= c
    return cs


def m_checksum(r, L):
    i = r.randrange(len(L))
    code = L[i].split(b";")[0].rstrip(b"\r\n ")
    if not code:
        return
    n = r.randint(1, 9999)
    body = b"N%d %s" % (n, code)
    cs = _checksum(body) if r.random() < 0.7 else r.randrange(256)
    L[i] = body + (b"*%d" % cs if r.random() < 0.9 else b"") + b"\n"


def m_tool(r, L):
    L.insert(r.randrange(len(L) + 1), r.choice(TOOL_LINES))


def m_accel(r, L):
    L.insert(r.randrange(len(L) + 1), r.choice(ACCEL_LINES))


def m_feed(r, L):
    i = _pick_motion(r, L)
    f = r.choice(FEED_WORDS)
    if re.search(rb"F-?\d*\.?\d+", L[i]):
        L[i] = re.sub(rb"F-?\d*\.?\d+", f, L[i], count=1)
    else:
        L.insert(i, b"G1 " + f + b"\n")


def m_crlf(r, L):
    how = r.randrange(3)
    if how == 0:
        L[:] = [l.replace(b"\n", b"\r\n") for l in L]
    elif how == 1:                                   # mixed endings
        for i in r.sample(range(len(L)), min(len(L), 20)):
            L[i] = L[i].replace(b"\n", b"\r\n")
    else:                                            # a lone CR (old Mac ending) inside the file
        i = r.randrange(len(L))
        L[i] = L[i].replace(b"\n", b"\r")


def m_bom(r, L):
    how = r.randrange(3)
    if how == 0:
        L[0] = b"\xef\xbb\xbf" + L[0]
    elif how == 1:                                   # the whole file as UTF-16 (with its BOM)
        L[:] = [b"".join(L).decode("latin-1").encode("utf-16")]
    else:                                            # a BOM in the middle (files concatenated)
        i = r.randrange(len(L))
        L[i] = b"\xef\xbb\xbf" + L[i]


def m_tabs(r, L):
    for i in r.sample(range(len(L)), min(len(L), r.randint(1, 30))):
        L[i] = L[i].replace(b" ", b"\t")


def m_non_utf8(r, L):
    i = r.randrange(len(L))
    k = r.randrange(len(L[i]) + 1)
    L[i] = L[i][:k] + r.choice((b"\xff", b"\xfe\xff", b"\x80", b"\xc3", b"\xed\xa0\x80", b"\xe9")) + L[i][k:]


def m_letter(r, L):
    """A line's command letter replaced by a letter outside A-Z (UTF-8: 'é1' is isalpha
    before a digit; session 39's crash), or such a letter put before the line."""
    i = _pick_motion(r, L)
    letter = r.choice(("\u00e9", "\u00c9", "\u00df", "\u01c5", "\u00aa", "\u03a9", "\uff27")).encode()
    L[i] = letter + (L[i][1:] if r.random() < 0.7 else L[i])


def m_nul(r, L):
    if r.random() < 0.3:
        L.insert(r.randrange(len(L) + 1), b"\x00" * r.randint(1, 4096) + b"\n")
    else:
        i = r.randrange(len(L))
        k = r.randrange(len(L[i]) + 1)
        L[i] = L[i][:k] + b"\x00" + L[i][k:]


def m_long_line(r, L):
    n = 1 << 20
    line = r.choice((b";" + b"x" * n + b"\n", b"G1 X1" + b" Y1" * (n // 3) + b"\n",
                     b"G1 X" + b"1" * n + b" Y1\n", b"A" * n))
    if line.endswith(b"\n"):
        L.insert(r.randrange(len(L) + 1), line)
    else:
        L.append(line)                               # a last line without a newline


def m_case_space(r, L):
    i = _pick_motion(r, L)
    L[i] = r.choice((L[i].lower(), L[i].replace(b" ", b""), L[i].replace(b" ", b"  "), b"  " + L[i],
                     L[i].replace(b"G1", b"G01"), L[i].replace(b"G1", b"G1.0")))


def m_binary(r, L):
    body = bytes(r.randrange(256) for _ in range(r.randint(0, 4096)))
    L[:] = [r.choice((b"GCDE\x01\x00\x00\x00" + body, body, b"", b"; only a comment\n", b"\n\n\n"))]


def m_coords(r, L):
    i = _pick_motion(r, L)
    nums = list(re.finditer(rb"(?<=[XYZ])-?\d*\.?\d+", L[i]))
    if nums:
        m = r.choice(nums)
        L[i] = L[i][:m.start()] + r.choice((b"100001", b"-100001", b"1e5", b"-99999", b"123456789")) + L[i][m.end():]


def m_value(r, L):
    """A plausible but odd value: zero-length moves, reversals, tiny/huge feeds and flows."""
    i = _pick_motion(r, L)
    nums = list(re.finditer(rb"(?<=[XYZEF])-?\d*\.?\d+", L[i]))
    if nums:
        m = r.choice(nums)
        v = float(m.group()) if re.fullmatch(rb"-?\d*\.?\d+", m.group()) else 1.0
        new = r.choice((0.0, v * 1e-3, v * 10, v * 1000, -v, v + 0.001, r.uniform(-300, 300), 1e-4, 5e4))
        L[i] = L[i][:m.start()] + (b"%.4f" % new).rstrip(b"0").rstrip(b".") + L[i][m.end():]


def m_feature(r, L):
    """Feature comments where they do not belong (every stroke kind becomes a candidate)."""
    L.insert(r.randrange(len(L) + 1), r.choice((b";TYPE:Solid infill\n", b";TYPE:Internal infill\n",
                                                b";TYPE:External perimeter\n", b";TYPE:FILL\n", b"; FEATURE: Sparse infill\n",
                                                b";TYPE:Bridge infill\n", b";TYPE:\n", b";TYPE:Custom\n")))


def m_scale(r, L):
    """Valid but extreme geometry or speed: every X/Y (about the first point), or every F, scaled."""
    letters, k = r.choice(((b"XY", 0.01), (b"XY", 0.1), (b"XY", 3.0), (b"F", 0.01), (b"F", 20.0), (b"E", 50.0)))
    pat = re.compile(rb"([%s])(-?\d*\.?\d+)" % letters)
    x0 = y0 = None
    for i in _motions(L):
        code, sep, comment = L[i].partition(b";")

        def sub(m):
            nonlocal x0, y0
            v = float(m.group(2))
            if m.group(1) == b"X":
                x0 = v if x0 is None else x0
                v = x0 + (v - x0) * k
            elif m.group(1) == b"Y":
                y0 = v if y0 is None else y0
                v = y0 + (v - y0) * k
            else:
                v *= k
            return m.group(1) + (b"%.5f" % v).rstrip(b"0").rstrip(b".")
        L[i] = pat.sub(sub, code) + sep + comment


MUTATIONS = {f.__name__[2:]: f for f in (
    m_delete, m_duplicate, m_swap, m_digit_flip, m_number, m_truncate, m_mode, m_bad_arc, m_checksum, m_tool,
    m_accel, m_feed, m_crlf, m_bom, m_tabs, m_non_utf8, m_letter, m_nul, m_long_line, m_case_space, m_binary, m_coords,
    m_value, m_feature, m_scale)}
WEIGHTS = {"binary": 0.2, "long_line": 0.3, "value": 2.0}   # relative draw weights (default 1)


def build_case(seed_text: bytes, ops) -> bytes:
    """Apply [(mutation name, int seed), ...] in order; deterministic."""
    L = seed_text.splitlines(keepends=True)
    for name, s in ops:
        if not L:
            L = [b"\n"]
        MUTATIONS[name](random.Random(s), L)
    return b"".join(L)


def random_ops(r: random.Random, k_max: int = 3):
    names = list(MUTATIONS)
    weights = [WEIGHTS.get(n, 1.0) for n in names]
    return [(r.choices(names, weights)[0], r.randrange(1 << 31)) for _ in range(r.randint(1, k_max))]


# ------------------------------------------------------------- the property ---
OK, REFUSED = "ok", "refused"
FAILURES = ("traceback", "hang", "bad-exit", "bad-message", "input-changed", "temp-left", "corruption",
            "bad-value", "accepted-nonfinite", "invalid-block")


class Hang(BaseException):
    """Raised by the alarm; a BaseException so that no `except Exception` in the code swallows it."""


def _on_alarm(signum, frame):
    raise Hang()


_NUM_TEXT = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_NONFINITE = re.compile(r"(?:^|[\s=A-Za-z])[-+]?(?:nan|inf(?:inity)?)\b", re.I)
_WRITTEN_MOVE = re.compile(r"G[0-3](?: [XYZEFIJR]-?(?:\d+\.?\d*|\.\d+))+")
_ACCEL = re.compile(r"^\s*M204\b(.*)|^\s*SET_VELOCITY_LIMIT\b(.*)", re.I)


def written_line_problem(line: str) -> str | None:
    """What is wrong with one line gcode-opt wrote itself (inside a begin/end block), or None."""
    code = line.split(";")[0].strip()
    if not code:
        return None
    if _NONFINITE.search(code):
        return "non-finite number"
    m = _ACCEL.match(code)
    if m and m.group(1) is not None:
        words = re.findall(r"([A-Za-z])\s*(\S*)", m.group(1))
        if not words:
            return "M204 without a value"
        for k, v in words:
            if not re.fullmatch(_NUM_TEXT, v):
                return f"M204 {k}{v}: not a number"
            if float(v) <= 0:
                return f"M204 {k}{v}: acceleration <= 0"
    elif m:
        for k, v in re.findall(r"([A-Za-z_]+)\s*=\s*(\S+)", m.group(2)):
            if not re.fullmatch(_NUM_TEXT, v):
                return f"{k}={v}: not a number"
            if k.upper() in ("ACCEL", "VELOCITY", "ACCEL_TO_DECEL") and float(v) <= 0:
                return f"{k}={v}: <= 0"
    if re.match(r"^G0*[0-3](?![0-9.])", code, re.I):
        # what we write is plain: one space between words, each letter once, plain decimals
        if not _WRITTEN_MOVE.fullmatch(code):
            return "malformed move"
        words = re.findall(r" ([A-Z])(\S+)", code)
        if len({k for k, _ in words}) != len(words):
            return "a letter twice"
        for k, v in words:
            if k == "F" and float(v) <= 0:
                return f"F{v}: feed <= 0"
    return None


def scan_output(path: str) -> tuple[str, str] | None:
    """(category, detail) of the first bad line of an output, or None."""
    from gcode_opt.emit import BEGIN, END
    inside = False
    with open(path, "r", encoding="utf-8", errors="surrogateescape", newline="") as fh:
        for n, line in enumerate(fh, 1):
            if line.startswith(BEGIN):
                inside = True
                continue
            if line.startswith(END):
                inside = False
                continue
            if inside:
                why = written_line_problem(line)
                if why:
                    return "bad-value", f"output line {n}: {why}: {line.strip()[:120]!r}"
            elif _MOTION.match(line.encode("utf-8", "surrogateescape")) and _NONFINITE.search(line.split(";")[0]):
                return "accepted-nonfinite", f"output line {n}: {line.strip()[:120]!r}"
    return None


# (a line number before the command counts: the reader drops "N123 " and "*45" and plays the rest)
_ACCEL_VALUE = re.compile(r"^\s*(?:N\d+\s*)?(?:M204\b[^;]*?[SPT]|SET_VELOCITY_LIMIT\b[^;]*?\bACCEL=)(\d+\.?\d*)",
                          re.I | re.M)


def validator_problem(inp: str, out: str, profile) -> str | None:
    """The product's own per-flavour validator (gcode_opt.validate), run independently on every
    block of the output: flavour's command forms, plain decimals, 0 < accel <= the largest of the
    profile's maximum and start-up values and of what the input itself commands."""
    try:
        from gcode_opt.validate import BlockInvalid, validate_block
    except ImportError:                                  # pragma: no cover - older trees
        return None
    from gcode_opt.emit import BEGIN, END
    with open(inp, encoding="utf-8", errors="surrogateescape") as fh:
        commanded = [float(v) for v in _ACCEL_VALUE.findall(fh.read())]
    # restoring what was in force is fair: the profile's start-up values or what the file commands
    accel_max_a = max([profile.max_accel_a, profile.default_accel_a, profile.travel_accel_a] + commanded)
    block = None
    with open(out, encoding="utf-8", errors="surrogateescape", newline="") as fh:
        for n, line in enumerate(fh, 1):
            if line.startswith(BEGIN):
                block, first = [line.rstrip("\r\n")], n
            elif block is not None:
                block.append(line.rstrip("\r\n"))
                if line.startswith(END):
                    text = "\n".join(block)
                    block = None
                    try:
                        validate_block(text, profile.flavour, accel_max_a, None, extruding=True)
                    except BlockInvalid as e:
                        try:                             # a travel block takes Marlin 2's M204 T form
                            validate_block(text, profile.flavour, accel_max_a, None, extruding=False)
                        except BlockInvalid:
                            return f"block at output line {first}: {e}"
    return None


def run_cli(argv, hang_t=HANG_T):
    """(exit code or 'exception', stderr text, traceback text) of gcode_opt.cli.main(argv) in-process."""
    from gcode_opt.cli import main
    err = io.StringIO()
    tb = ""
    old = signal.signal(signal.SIGALRM, _on_alarm)
    signal.setitimer(signal.ITIMER_REAL, hang_t)
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            try:
                rc = main(argv)
            except SystemExit as e:
                rc = e.code if isinstance(e.code, int) else (0 if e.code is None else 2)
                if isinstance(e.code, str):
                    err.write(e.code + "\n")
            except Hang:
                raise
            except BaseException:
                rc, tb = "exception", traceback.format_exc()
    except Hang:
        rc, tb = "hang", traceback.format_exc()
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    if rc in (130, 143) or (rc == "exception" and "KeyboardInterrupt" in tb):
        raise KeyboardInterrupt     # the user stopped the run (the CLI turns Ctrl-C into an exit code)
    return rc, err.getvalue(), tb


def check_case(data: bytes, profile: str, features_all: bool, work_dir: str | None = None,
               hang_t: float = HANG_T, in_place: bool = False, extra=()) -> tuple[str, str]:
    """Run one case; (category, detail). category is OK, REFUSED or one of FAILURES.
    in_place: no -o (the way slicers call it): the input is rewritten, or left as it was.
    extra: more CLI arguments (e.g. --corners auto)."""
    import warnings
    from gcode_opt.profile import load_profile
    from gcode_opt.verify import verify
    own = work_dir is None
    d = tempfile.mkdtemp(prefix="fuzz-") if own else work_dir
    orig = None
    try:
        inp = os.path.join(d, "in.gcode")
        out = inp if in_place else os.path.join(d, "out.gcode")
        with open(inp, "wb") as fh:
            fh.write(data)
        argv = (["process", inp] + ([] if in_place else ["-o", out]) + ["-q", "--profile", profile]
                + (["--features", "all"] if features_all else []) + list(extra))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rc, err, tb = run_cli(argv, hang_t)
        if rc == "hang":
            return "hang", tb.strip().splitlines()[-1] if tb else ""
        if rc == "exception":
            return "traceback", "\n".join(tb.strip().splitlines()[-4:])
        if not in_place or rc != 0:
            with open(inp, "rb") as fh:
                if fh.read() != data:
                    return "input-changed", f"exit {rc}"
        extra = sorted(set(os.listdir(d)) - {"in.gcode", "out.gcode"})
        if extra:
            return "temp-left", f"exit {rc}: {extra}"
        if rc == 2:
            msg = err.strip().splitlines()[-1] if err.strip() else ""
            if not re.match(r"gcode-opt: " + re.escape(inp) + r"(:\d+)?: \S", msg):
                return "bad-message", f"exit 2 with {err.strip()[-300:]!r}"
            if not in_place and os.path.exists(out):
                return "bad-exit", "exit 2 but an output was written"
            return REFUSED, msg[len("gcode-opt: ") + len(inp):][:160]
        if rc != 0:
            return "bad-exit", f"exit {rc}: {err.strip()[-300:]!r}"
        if not os.path.exists(out):
            return "bad-exit", "exit 0 without an output"
        if in_place:                            # the original, to verify the rewritten file against
            fd, orig = tempfile.mkstemp(suffix=".gcode", prefix="fuzz-orig-")
            with os.fdopen(fd, "wb") as fh:
                fh.write(data)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                verify(orig or inp, out, load_profile(profile))
        except AssertionError as e:
            return "corruption", f"verify: {str(e)[:300]}"
        except Exception as e:
            return "corruption", f"verify raised {type(e).__name__}: {str(e)[:300]}"
        bad = scan_output(out)
        if bad:
            return bad
        why = validator_problem(orig or inp, out, load_profile(profile))
        if why:
            return "invalid-block", why
        return OK, ""
    finally:
        if orig:
            os.unlink(orig)
        if own:
            shutil.rmtree(d, ignore_errors=True)


# ----------------------------------------------------------------- tests ---
def _profiles():
    from gcode_opt.profile import profile_names
    return list(profile_names())


def test_seeds_are_processed_as_they_are(tmp_path):
    """The unmutated windows themselves must pass and re-time something (else the fuzz tests little)."""
    from gcode_opt.emit import BEGIN
    for name, text in seeds().items():
        cat, detail = check_case(text, "generic-klipper", False, str(tmp_path))
        assert cat == OK, (name, cat, detail)
        out = (tmp_path / "out.gcode").read_text(errors="replace")
        assert BEGIN in out, f"{name}: nothing re-timed in the seed window"
        (tmp_path / "out.gcode").unlink()


def test_property_checker_catches_bad_written_lines():
    """The scanner must flag what the firmware would reject (it would be a test that cannot fail otherwise)."""
    for bad in ("G1 X1 Y2 F0", "G1 X1 Ynan F100", "M204 S0", "M204 P-5 T100", "SET_VELOCITY_LIMIT ACCEL=0",
                "SET_VELOCITY_LIMIT ACCEL=inf", "G1 X2e1 Y1", "M204 S", "G1 X1 F-3"):
        assert written_line_problem(bad + "\n"), bad
    for good in ("G1 X1.5 Y-2 E.03 F3000", "M204 P1200 T1500", "SET_VELOCITY_LIMIT ACCEL=3000 MINIMUM_CRUISE_RATIO=0.5",
                 "M204 S800 ; restore", "; a comment"):
        assert written_line_problem(good + "\n") is None, good


def test_build_case_is_deterministic():
    text = next(iter(seeds().values()))
    r = random.Random(5)
    for _ in range(30):
        ops = random_ops(r)
        assert build_case(text, ops) == build_case(text, ops)


try:
    from hypothesis import HealthCheck, given, settings, strategies as st
except ImportError:                                      # pragma: no cover
    given = None


if given is not None:
    _SEEDS = seeds()
    _case = st.tuples(st.sampled_from(sorted(_SEEDS)), st.sampled_from(_profiles()), st.booleans(), st.booleans(),
                      st.lists(st.tuples(st.sampled_from(sorted(MUTATIONS)), st.integers(0, (1 << 31) - 1)),
                               min_size=1, max_size=3))

    def _assert_case(case):
        name, prof, all_, in_place, ops = case
        cat, detail = check_case(build_case(_SEEDS[name], ops), prof, all_, in_place=in_place)
        assert cat in (OK, REFUSED), f"{cat}: {detail}\n  case: {case!r}"

    @settings(max_examples=50, deadline=None, derandomize=True, database=None,
              suppress_health_check=list(HealthCheck))
    @given(_case)
    def test_mutated_samples_process_or_are_refused(case):
        _assert_case(case)

    # (the example database kept, and the blob printed: a failure of a random campaign is
    # replayed first by the next run, and can be reproduced with @reproduce_failure)
    @pytest.mark.slow
    @settings(max_examples=600, deadline=None, print_blob=True, suppress_health_check=list(HealthCheck))
    @given(_case)
    def test_mutated_samples_long(case):
        _assert_case(case)


# ------------------------------------------------ minimal reproducers (tests/cases) ---
def _repro_cases():
    return sorted(CASES.glob("*.gcode")) if CASES.is_dir() else []


def repro_options(path: Path) -> tuple[str, bool]:
    """The header's `profile=NAME` and `features=all` (defaults: generic-klipper, default features)."""
    head = path.read_bytes().split(b"\n", 1)[0].decode("utf-8", "replace")
    m = re.search(r"profile=(\S+)", head)
    return (m.group(1) if m else "generic-klipper"), "features=all" in head


@pytest.mark.parametrize("path", _repro_cases(), ids=lambda p: p.stem)
def test_minimal_reproducer(path):
    """Each file in tests/cases/ is a bug once found: it must now process cleanly or be refused cleanly."""
    prof, all_ = repro_options(path)
    cat, detail = check_case(path.read_bytes(), prof, all_)
    assert cat in (OK, REFUSED), f"{path.name}: {cat}: {detail}"
