"""The reader's digit runs two digits at a time (issue 8, session 43; gcode_opt/_reader.c
digit_run): usual_words and sess_m204_s read a run of digits by pairs (one table load a pair,
then at most one digit alone), and read the byte after the line's ending only where it is in
the same 4 KiB page (past_readable); a line that ends a page reads no byte past its ending.
Every value must still be float()'s of its text, whatever the digits either side of the
point (odd and even counts, 0 to 16 of them), the sign, and where the line ends.

References: the Python step (MachineState._step_python) against the compiled step line by
line (test_reader_core_bits.compare_lines), and the measure loop (Sim.play_buf) against the
Python step (test_speed36_reader_lines._python_play), the loop fed blocks in page-aligned
anonymous maps whose every page ends with a G1 or M204 line (the path that reads no byte past
a line), the block's last line at the map's end."""
from __future__ import annotations

import mmap
import random

import pytest

from gcode_opt import state as st
from gcode_opt.firmware import simulate as fw

from test_reader_core_bits import PROFILES, Counter, compare_lines
from test_speed28_measure_buf import _run
from test_speed36_reader_lines import _python_play

pytestmark = pytest.mark.skipif(st._reader is None, reason="the compiled reader is not built here")

PAGE = 4096


def _digits(rng, n):
    return "".join(rng.choice("0123456789") for _ in range(n))


def _value(rng):
    """digits[.digits] with 0 to 9 digits either side (every parity), now and then 15 or 16
    in all (the rule's edge), a '-' on some"""
    if rng.random() < 0.1:
        n = rng.choice([15, 16])
        a = rng.randint(0, n)
        t = _digits(rng, a) + "." + _digits(rng, n - a)
    else:
        a, b = rng.randint(0, 9), rng.randint(0, 9)
        t = _digits(rng, a) + rng.choice([".", ".", ""]) + _digits(rng, b)
    return ("-" if rng.random() < 0.2 else "") + t


def _fine_value(rng, sign=True):
    """a value the Python step takes in a move or an M204 (in range, a digit at least, F and
    S above 0): 1 to 4 digits before the point, 0 to 9 after it"""
    a, b = rng.randint(0, 3), rng.randint(0, 9)
    t = rng.choice("123456789") + _digits(rng, a) + rng.choice([".", "." + _digits(rng, b), ""])
    if a == 0 and rng.random() < 0.3:
        t = "0." + _digits(rng, b) + "1"
    return ("-" if sign and rng.random() < 0.2 else "") + t


def _g1(rng, value=_value):
    return rng.choice(["G1", "G0"]) + "".join(f" {c}{value(rng) if c != 'F' else _fine_value(rng, False)}"
                                              for c in rng.sample("XYZEF", rng.randint(1, 5)))


def _m204(rng, value=_value):
    return f"M204 S{value(rng).lstrip('-')}"


def _lines(rng, n, value=_value):
    return [_m204(rng, value) if rng.random() < 0.25 else _g1(rng, value) for _ in range(n)]


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
@pytest.mark.parametrize("seed", range(3))
def test_step_reads_pairs_as_python(prof, seed, monkeypatch):
    cnt = Counter(monkeypatch)
    rng = random.Random(4300 + seed)
    lines = [ln + rng.choice(["\n"] * 6 + ["\r\n", "\r", ""]) for ln in _lines(rng, 3000)]
    lines[:0] = ["G90\n", "M83\n", "M204 S1000\n"]
    diff = compare_lines(lines, PROFILES[prof](), cnt.py)
    assert diff is None, diff


def _paged_file(rng, pages):
    """LF lines of G1s and M204s (_fine_value's values) laid out so that each PAGE bytes end
    with a G1 or M204 line (a comment line pads before it); pages * PAGE bytes in all"""
    text = bytearray()
    for _ in range(pages):
        page = bytearray(b"G90\nM83\n" if not text else b"")
        while len(page) < PAGE - 300:
            page += _lines(rng, 1, _fine_value)[0].encode() + b"\n"
        last = (_g1(rng, _fine_value) if rng.random() < 0.7 else _m204(rng, _fine_value)).encode() + b"\n"
        room = PAGE - len(page) - len(last)
        page += b";" + b"p" * (room - 2) + b"\n" + last
        assert len(page) == PAGE
        text += page
    return bytes(text)


def _mapped_blocks(data, pages_a_block):
    """Blocks.blocks' replacement: the file's bytes in anonymous maps of pages_a_block pages"""
    def blocks(self):
        self.cr = False
        size = pages_a_block * PAGE
        for a in range(0, len(data), size):
            chunk = data[a:a + size]
            m = mmap.mmap(-1, len(chunk))
            m.write(chunk)
            yield m, False
    return blocks


@pytest.mark.skipif(fw._core is None or not hasattr(fw._core.Sim, "play_buf"),
                    reason="the compiled firmware core is not built here")
@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
@pytest.mark.parametrize("seed", range(2))
def test_measure_reads_page_ends_as_python(tmp_path, prof, seed, monkeypatch):
    rng = random.Random(4310 + seed)
    data = _paged_file(rng, 24)
    assert all(data[p - 1:p] == b"\n" and data[data.rfind(b"\n", 0, p - 1) + 1:][:1] in (b"G", b"M")
               for p in range(PAGE, len(data) + 1, PAGE))
    path = tmp_path / f"pages{seed}.gcode"
    path.write_bytes(data)
    profile = PROFILES[prof]()
    ref = _python_play(str(path), profile, monkeypatch)
    for pages_a_block in (1, 3):
        with monkeypatch.context() as m:
            m.setattr(fw.Blocks, "blocks", _mapped_blocks(data, pages_a_block))
            got = _run(str(path), profile, 1 << 16, False, monkeypatch=m)
        assert got == ref, pages_a_block
