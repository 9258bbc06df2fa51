"""The measure's run reads a line's end from its words (issue 8, session 48; gcode_opt/_reader.c
run_line_fast): for a G0/G1 whose words usual_words reads, or an "M204 S.." line sess_m204_s
takes, fused_run_ascii finds the line's LF by the words' own scan (usual_words_to and
m204_s_value, bounded 16 bytes before the buffer's end) instead of line_end16's.  Every other
line -- odd spacing, a comment, a tab, a CR, a non-ASCII byte, a long or odd value, a line near
the buffer's end -- is read as before (line_end16, then fused_line_body), so nothing read may
change: the play of a file must be the Python step's, line by line, whatever the buffer's size
(which moves where blocks end, and so which lines near an end the fast scan leaves).

References: the measure loop (Sim.play_buf, the compiled reader) against the same loop with
every line read by the Python step (test_speed36_reader_lines._python_play); and the blocks in
maps whose next page is PROT_NONE, so that a read past a block's end (the scan's bound) faults."""
from __future__ import annotations

import ctypes
import ctypes.util
import mmap
import random

import pytest

from gcode_opt import state as st
from gcode_opt.firmware import simulate as fw

from test_reader_core_bits import PROFILES
from test_speed28_measure_buf import _run
from test_speed36_reader_lines import _python_play
from test_speed43_read43_pairs import _digits, _fine_value, _g1, _m204

pytestmark = [
    pytest.mark.skipif(st._reader is None, reason="the compiled reader is not built here"),
    pytest.mark.skipif(fw._core is None or not hasattr(fw._core.Sim, "play_buf"),
                       reason="the compiled firmware core is not built here"),
]

PAGE = mmap.PAGESIZE
PROT_NONE = 0

# lines the fast scan must leave to line_end16's path, or read as it does (each ends in "\n")
ODD = [
    "G1 X1.5 Y2 ;c", "G1 X1.5\tY2", "G1 X1.5  Y2", "G1 X1.5 Y2 ", "G1 X1.5 Y2\t", "G1  X1",
    "G1 X1.5 ;\u00e9", "; \u00e9", "G1 X1." + "0" * 30 + "1", "G1 X-1", "G1 X+1", "G1 X.5", "G1 X5.",
    "G1", "G0", "G0 F3000", "G10", "G11", "G1 x1", "G1 A1", "G1 X1;", "G1 X1 ;", "G1 X12345.5",
    "G1 X123.4567890123 Y0.000000000000001", "G1 X0001.2000 Y-0.0 E-0", "G1 F0001200.00",
    "M204 S1000", "M204 S1000 T500", "M204 S12.5;c", "M204 S12.5 ", "M204  S5", "M204 P5",
    "M2040 S5", "M204 S1.", "M204 S.5", "M204 S0999.9990", "M204 S999999.9999999",
    ";G1 X1", " G1 X1", "", "M107", "G92 E0", "M83", "M82", "G90",
]

# lines the Python step raises for: the measure must raise the same error
FAIL = [
    "G1 X1.5\u00e9 Y2", "G1 X\u00e9", "G1 X" + "9" * 40, "G1 X1..2", "G1 X.", "G1 X", "G1 X-",
    "G1 X1 X2", "G1 X1e3", "G1 X1-2", "G1 X1 Y", "G1 X12345678901234.5", "M204 S0", "M204 S-5",
    "M204 S", "M204 S1e3", "M204 S99999999999999999", "M204 S1.2.3", "M204 S1\u00e9",
]


def _long_value(rng):
    """1 to 4 digits before the point and 8 to 16 after it: 15 digits in all is the fast
    scan's last, more go the general way"""
    t = rng.choice("123456789") + _digits(rng, rng.randint(0, 3)) + "." + _digits(rng, rng.randint(8, 16))
    return ("-" if rng.random() < 0.2 else "") + t


def _text(rng, n):
    lines = ["G90", "M83", "M204 S1000"]
    for _ in range(n):
        r = rng.random()
        if r < 0.12:
            lines.append(rng.choice(ODD))
        elif r < 0.4:
            lines.append(_m204(rng, _fine_value))
        elif r < 0.5:
            lines.append(_g1(rng, _long_value))
        else:
            lines.append(_g1(rng, _fine_value))
    return "".join(ln + "\n" for ln in lines)


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
@pytest.mark.parametrize("seed", range(3))
def test_measure_run_reads_lines_as_python(tmp_path, prof, seed, monkeypatch):
    rng = random.Random(4800 + seed)
    path = tmp_path / f"run{seed}.gcode"
    path.write_bytes(_text(rng, 1500).encode())
    profile = PROFILES[prof]()
    ref = _python_play(str(path), profile, monkeypatch)
    for size in (40, 57, 64, 100, 333, 1 << 16):
        assert _run(str(path), profile, size, False, monkeypatch=monkeypatch) == ref, size


def _guarded_blocks(data, size):
    """Blocks.blocks' replacement: blocks of whole lines (about size bytes), each the end of
    an anonymous map whose next page is PROT_NONE"""
    libc = ctypes.CDLL(ctypes.util.find_library("c"), use_errno=True)
    libc.mprotect.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int]

    def blocks(self):
        self.cr = False
        a = 0
        while a < len(data):
            b = data.rfind(b"\n", a, a + size) + 1
            if b <= a:
                b = data.find(b"\n", a) + 1 or len(data)     # (the last line may have no LF)
            chunk = data[a:b]
            pages = -(-len(chunk) // PAGE)
            m = mmap.mmap(-1, (pages + 1) * PAGE)
            off = pages * PAGE - len(chunk)
            m[off:off + len(chunk)] = chunk
            base = ctypes.addressof(ctypes.c_char.from_buffer(m))
            assert libc.mprotect(base + pages * PAGE, PAGE, PROT_NONE) == 0, ctypes.get_errno()
            yield memoryview(m)[off:pages * PAGE], False
            a = b
    return blocks


@pytest.mark.parametrize("seed", range(2))
def test_measure_run_reads_nothing_past_a_block(tmp_path, seed, monkeypatch):
    """Blocks that end at a PROT_NONE page, each ending in a G1 or M204 line (the fast shapes)
    or an odd one, of every length mod 16, the file's last line a G1 without its LF: a read
    past the block's end would fault"""
    rng = random.Random(4820 + seed)
    path = tmp_path / f"guard{seed}.gcode"
    data = (_text(rng, 600) + "G1 X1.25 Y3" + "3" * seed).encode()
    path.write_bytes(data)
    profile = PROFILES["prusa-mk3s"]()
    ref = _python_play(str(path), profile, monkeypatch)
    for size in (33, 48, 64, 200):
        with monkeypatch.context() as m:
            m.setattr(fw.Blocks, "blocks", _guarded_blocks(data, size))
            got = _run(str(path), profile, 1 << 16, False, monkeypatch=m)
        assert got == ref, size


def _error(path, profile, size, monkeypatch):
    with pytest.raises(st.GcodeError) as e:
        if size:
            _run(path, profile, size, False, monkeypatch=monkeypatch)
        else:
            _python_play(path, profile, monkeypatch)
    return str(e.value)


@pytest.mark.parametrize("bad", FAIL)
def test_measure_run_raises_as_python(tmp_path, bad, monkeypatch):
    rng = random.Random(hash(bad) & 0xffff)
    lines = _text(rng, 60).splitlines(keepends=True)
    lines.insert(rng.randint(4, len(lines)), bad + "\n")
    path = tmp_path / "bad.gcode"
    path.write_bytes("".join(lines).encode())
    profile = PROFILES["prusa-mk3s"]()
    ref = _error(str(path), profile, 0, monkeypatch)
    for size in (64, 1 << 16):
        assert _error(str(path), profile, size, monkeypatch) == ref, size
