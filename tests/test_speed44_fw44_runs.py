"""Sim.play_buf's runs of lines (issue 8, session 44): in a block with no CR, play_loop hands
the reader's run_ascii (gcode_opt/_reader.c) the block and the reader reads line after line
itself -- the 16-byte line split and ASCII test src_next_buf's, each line fused_line_ascii's,
each move played at once through a callback (play_fused) -- and returns only at a line for
step() (fused_line_ascii's 2), an E-only move where play stops at one, the next watched
range's first line or `until`, a non-ASCII line, or a line its 16-byte split does not reach
(the per-line steps read those).

The results must be the per-line loop's (test_speed_measure_loop._ref_play: step() and
Sim.move line by line), bit for bit: SimResult, per-line sums, ledger, state and warnings,
on files that mix every kind of line the run meets or stops at -- moves, travels, E-only
retracts, M204 (fast shape and not), comments (marked or not), blank lines, commands step()
reads (G92, M201, G4 dwells: barriers), SET_VELOCITY_LIMIT (Klipper), non-ASCII comments,
long lines -- with and without watched ranges, in blocks of several sizes."""
from __future__ import annotations

import random

import pytest

from gcode_opt import state as st
from gcode_opt.firmware import simulate as fw

from test_speed28_measure_buf import _run
from test_speed_measure_fused import PROFILES

pytestmark = pytest.mark.skipif(fw._core is None or not hasattr(fw._core.Sim, "play_buf"),
                                reason="the compiled firmware core is not built here")


def _num(rng, lo, hi):
    v = rng.uniform(lo, hi)
    text = f"{v:.{rng.choice([0, 1, 2, 3, 3, 3, 5])}f}"
    if text.startswith("0.") and rng.random() < 0.3:
        text = text[1:]                               # ".0756", as slicers write E
    return text


def _lines(rng, n):
    out = ["G21", "G90", "M83", "M204 S1000", ";TYPE:Perimeter", "G1 Z0.2 F3000"]
    for _ in range(n):
        r = rng.random()
        if r < 0.40:
            line = f"G1 X{_num(rng, 5, 200)} Y{_num(rng, 5, 200)} E{_num(rng, 0.001, 0.2)}"
            if rng.random() < 0.5:
                line += f" F{_num(rng, 600, 6000)}"
        elif r < 0.48:
            line = f"G1 X{_num(rng, 5, 200)} Y{_num(rng, 5, 200)} F{_num(rng, 3000, 9000)}"
        elif r < 0.52:
            line = rng.choice(["G1 E-0.8 F2100", "G1 E0.8 F2100", "G1 E-.4", "G0 X10 Y10", "G1 X10 Y10"])
        elif r < 0.70:
            line = f"M204 S{_num(rng, 0.1, 3000)}"
        elif r < 0.72:
            line = rng.choice(["M204 P1500 T2000", "M204 S0.5", "M204 S800 ;c", "M204 R1250"])
        elif r < 0.80:
            line = rng.choice([";", "; c", ";WIDTH:0.45", ";TYPE:Solid infill", ";TYPE:External perimeter",
                               ";LAYER_CHANGE", ";Z:0.4", "", "   ", "; " + "x" * rng.randint(10, 300)])
        elif r < 0.86:
            line = rng.choice(["G92 E0", "M107", "M106 S255", "G4 P50", "G4 S0", "M201 X1000 Y1000",
                               "M73 P5 R10", "G1 X12 Y13 E.1 ; comment", "G1 X12.00000000000000000001 Y3"])
        elif r < 0.90:
            line = rng.choice(["SET_VELOCITY_LIMIT ACCEL=3000", "SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=0.5",
                               "SET_VELOCITY_LIMIT SQUARE_CORNER_VELOCITY=5 ACCEL=2000"])
        elif r < 0.94:
            line = rng.choice(["; é", ";\u00ff", "G1 X20 Y20 E.1 ; é", "M117 héllo"])
        else:
            line = f"G1 X{_num(rng, 5, 200)} Y{_num(rng, 5, 200)} E{_num(rng, 0.001, 0.2)}" + " " * rng.randint(0, 40)
        out.append(line)
    return out


def _file(tmp_path, seed, n=1200):
    rng = random.Random(44000 + seed)
    path = tmp_path / f"runs{seed}.gcode"
    path.write_bytes(("\n".join(_lines(rng, n)) + rng.choice(["\n", "", "\nG1 X5 Y5"])).encode("utf-8"))
    return str(path)


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
@pytest.mark.parametrize("seed", range(3))
def test_runs_as_per_line_loop(tmp_path, prof, seed, monkeypatch):
    """play_buf with the reader's runs against the per-line loop: whole file, then watched
    ranges (every first line and end a stop for the run), with play() told the ranges'
    first lines or called once a range."""
    path = _file(tmp_path, seed)
    profile = PROFILES[prof]()
    n = sum(1 for _ in open(path, "rb"))
    watch = [(a, min(a + 5, n - 1)) for a in range(2, n, 23)]
    for w in (None, watch):
        for first in (True, False):
            monkeypatch.setattr(fw, "USE_PLAY_FIRSTS", first)
            ref = _run(path, profile, 0, True, w)
            for size in (40, 1000, 1 << 16):
                assert _run(path, profile, size, False, w, monkeypatch) == ref, (w is None, first, size)


def test_runs_read_the_usual_lines_in_c(tmp_path, monkeypatch):
    """The usual lines stay in C inside runs: step() sees only the lines the reader leaves to
    Python (here M83 and the G92s), so a run that handed other lines back would fail."""
    text = "M83\n" + "".join(f"G1 X{10 + i % 50}.5 Y{20 + i % 7}.25 E.05\nM204 S{800 + i}\n;c\nG92 E0\n"
                              for i in range(300))
    path = tmp_path / "usual.gcode"
    path.write_text(text)
    seen = []
    py = st.MachineState._step_python

    def counted(state, idx, raw):
        seen.append(raw)
        return py(state, idx, raw)
    monkeypatch.setattr(st.MachineState, "_step_python", counted)
    _run(str(path), PROFILES["prusa-mk3s"](), 1 << 16, False, monkeypatch=monkeypatch)
    assert seen.count("G92 E0\n") == 300 and set(seen) == {"M83\n", "G92 E0\n"}


# ---------------------------------------------------------------- read_g_words
def _value(rng, odd):
    """A value of the shapes a G1 carries, in range: 1 to 16 digits, the point anywhere or
    none, a '-' now and then, leading zeros; where odd, now and then one only the general
    steps read (a '+', a fraction past 15 digits, "-.5")."""
    k = rng.choice([1, 1, 2, 3, 4, 5, 6, 7, 8, 12, 15, 16])
    digits = "".join(rng.choice("0123456789") for _ in range(k))
    p = rng.randint(0, min(len(digits), 5))
    text = digits[:p] + "." + digits[p:] if rng.random() < 0.8 else digits[:5]
    if rng.random() < 0.2:
        text = "-" + text
    if odd and rng.random() < 0.05:
        text = rng.choice(["+1.5", "0.12345678901234567890123", "-.5", "00012.50000", "+.25"])
    return text


def _g_lines(rng, n, odd=True):
    out = ["G21", "G90", "M83", "M204 S1000", ";TYPE:Perimeter"]
    for _ in range(n):
        words = [f"X{_value(rng, odd)}", f"Y{_value(rng, odd)}", f"E{_value(rng, odd)}", f"F{rng.randint(100, 9000)}"]
        rng.shuffle(words)
        words = words[:rng.randint(1, 4)]
        out.append("G1 " + " ".join(words) + rng.choice(["", "", "", " ", " ;c", "\t"]))
        if rng.random() < 0.2:
            out.append(f"M204 S{rng.randint(100, 3000)}")
    return out


@pytest.mark.parametrize("seed", range(3))
def test_g_words_as_python_measure(tmp_path, seed, monkeypatch):
    """The measure loop (play_buf: the run's and the per-line fused reader) on G1 lines of
    every value shape: the Python step's moves, figures and state."""
    from test_speed36_reader_lines import _python_play
    rng = random.Random(44100 + seed)
    path = tmp_path / f"g{seed}.gcode"
    path.write_text("\n".join(_g_lines(rng, 2000)) + "\n")
    profile = PROFILES["prusa-mk3s"]()
    ref = _python_play(str(path), profile, monkeypatch)
    for size in (50, 1 << 16):
        assert _run(str(path), profile, size, False, monkeypatch=monkeypatch) == ref, size


@pytest.mark.skipif(st._reader is None, reason="the compiled reader is not built")
@pytest.mark.parametrize("seed", range(2))
def test_g_words_as_reference_analyse(tmp_path, seed):
    """analyse's run loop (fused_peek) on the same lines: the reference's strokes and sums
    (test_speed_analyse2_runs: the line-by-line code)."""
    from test_speed_analyse2_runs import _same
    rng = random.Random(44200 + seed)
    path = tmp_path / f"ga{seed}.gcode"
    path.write_text("\n".join(_g_lines(rng, 2000, odd=False)) + "\n")
    _same(str(path), "prusa-mk3s", ringing=False)


# ---------------------------------------------------------------- lines_raw
@pytest.mark.skipif(st._reader is None, reason="the compiled reader is not built")
@pytest.mark.parametrize("ending", ["\n", "\r\n"])
def test_lines_raw_chunks_as_reference_analyse(tmp_path, ending, monkeypatch):
    """run_lines and gap_lines read a Lines block that is all ASCII from its bytes and line
    starts (lines_raw, no call a line), any other block line by line (lines_at): blocks of
    ~2 kB, a non-ASCII comment in some, CRLF endings (no block without a CR: lines_at's flags
    without LINE_LF) -- the reference's strokes and sums."""
    from test_speed_analyse2_runs import _same
    rng = random.Random(44300)
    lines = _g_lines(rng, 3000, odd=False)
    for k in range(40, len(lines), 397):
        lines[k] = "; é non-ASCII"
    path = tmp_path / "raw.gcode"
    path.write_bytes((ending.join(lines) + ending).encode("utf-8"))
    monkeypatch.setattr(fw, "CHUNK_HINT", 2000)
    _same(str(path), "prusa-mk3s", ringing=False)


# ---------------------------------------------------------------- the run's line split
def _short_lines(rng, n):
    """Short lines, several to a 16-byte block, now and then a byte >= 0x80 anywhere in one
    (its code too: step() reads it and may refuse it)."""
    out = [b"G90", b"M83", b"M204 S1000"]
    for _ in range(n):
        line = rng.choice([b"M204 S%d" % rng.randint(1, 3000), b"G1 X%d Y%d E.01" % (rng.randint(1, 99), rng.randint(1, 99)),
                           b";", b"", b"G1 E-.5", b"G1 E.5", b"M107", b";c" * rng.randint(1, 12),
                           b"G1 X%d.%d" % (rng.randint(1, 99), rng.randint(0, 999))])
        if line and rng.random() < 0.03:
            at = rng.randrange(len(line) + 1)
            line = line[:at] + rng.choice([b"\xc3\xa9", b"\xe9", b"\x80"]) + line[at:]
        out.append(line)
    return b"\n".join(out) + b"\n"


@pytest.mark.parametrize("seed", range(4))
def test_run_split_as_per_line_loop(tmp_path, seed, monkeypatch):
    """The run reads a 16-byte block once for all the lines in it: the same lines, the same
    non-ASCII lines left to the per-line steps, the same moves and errors as the per-line
    loop."""
    rng = random.Random(44400 + seed)
    path = str(tmp_path / f"short{seed}.gcode")
    with open(path, "wb") as fh:
        fh.write(_short_lines(rng, 3000))
    profile = PROFILES["prusa-mk3s"]()

    def outcome(ref, size):
        try:
            return _run(path, profile, size, ref, None, monkeypatch)
        except st.GcodeError as e:                    # (a line the reader refuses: the same error)
            return str(e)
    ref = outcome(True, 0)
    for size in (23, 1000, 1 << 16):
        assert outcome(False, size) == ref, size
