"""The file readers that cut a block after its last whole line (simulate.Blocks.blocks, the
measure pass's; state.line_chunks, analyse's) read the cut line again with the next block
(a seek back) instead of joining the rest to it (rest + data: a copy of every block).
Against the joining readers they replace (copied here as they were at 23d24f4): the same
lines bit for bit (the blocks and chunks may end elsewhere: the reads start after each
cut; their readers take any chunking), each block whole lines, its cr flag, the same
bytes told to progress in all; on texts with LF, CRLF, lone CRs (also at a block's edge),
no final newline, lines longer than a block, bytes that are not UTF-8; and through a FIFO
(not seekable: the joining path)."""
from __future__ import annotations

import io
import os
import random

import pytest

from fifo_cases import through_fifo
from gcode_opt import state
from gcode_opt.firmware import simulate as fwsim


def _ref_blocks(path, size, progress=None):
    """Blocks.blocks as it was (rest + data): [(bytes, cr)]."""
    out = []
    with open(path, "rb") as fh:
        rest = b""
        while True:
            data = fh.read(size)
            if not data:
                if rest:
                    out.append((rest, b"\r" in rest))
                return out
            if progress is not None:
                progress(len(data))
            if rest:
                data = rest + data
            stop = len(data) - 1 if data[-1] == 13 else len(data)
            k = max(data.rfind(b"\n", 0, stop), data.rfind(b"\r", 0, stop)) + 1
            if k == 0:
                rest = data
                continue
            rest = data[k:]
            out.append((bytes(data[:k]), data.find(b"\r", 0, k) >= 0))


def _ref_chunks(path, size, progress=None, cr=None):
    """line_chunks as it was (rest + data): [(idx0, [str, ...])]."""
    split = state._reader.split_block
    out = []
    with open(path, "rb") as fh:
        idx0, rest = 0, b""
        while True:
            data = fh.read(size)
            final = not data
            if cr is not None and not cr[0] and b"\r" in data:
                cr[0] = True
            if rest:
                data = rest + data
            lines, used = split(data, final)
            rest = data[used:]
            if lines:
                if progress is not None:
                    progress(used if data.isascii() else sum(map(len, lines)))
                out.append((idx0, list(lines)))
                idx0 += len(lines)
            if final:
                return out


def _texts():
    rng = random.Random(38)
    alpha = [b"\r", b"\n", b"\r\n", b"a", b"G1 X1.5 Y2 E0.1", b";c", b"\xc3\xa9", b"\xe2\x82\xac", b"\xff", b"x" * 40]
    texts = [b"", b"a", b"a\n", b"a\r", b"a\r\n", b"\r\n\r\n", b"\r\r\n\n", b"x\ry\r\nz\nw", b"\xef\xbb\xbfG1 X1\n",
             b"G1 X1\n" * 50 + b"G1 X2", b"y" * 300 + b"\n" + b"z" * 5]
    texts += [b"".join(rng.choice(alpha) for _ in range(rng.randint(1, 200))) for _ in range(60)]
    texts += [b"".join(rng.choice(alpha[:6]) for _ in range(rng.randint(1, 200))) for _ in range(60)]  # ASCII
    return texts


SIZES = (1, 2, 3, 7, 64, 1 << 16)


def _split(blocks):
    """The lines of [(bytes, cr)] blocks as read_lines splits each block."""
    lines = []
    for b, _ in blocks:
        lines += list(io.TextIOWrapper(io.BytesIO(b), encoding="utf-8", errors="surrogateescape", newline=""))
    return lines


def _flat(chunks):
    """The lines of [(idx0, lines)] chunks, each idx0 checked."""
    out = []
    for idx0, lines in chunks:
        assert idx0 == len(out) and lines
        out.extend(lines)
    return out


def _blocks(path, progress=None):
    b = fwsim.Blocks(path, progress)
    got = [(bytes(buf), cr) for buf, cr in b.blocks()]
    return got, b.cr


def _chunks(path, progress=None, cr=None):
    return [(i, list(lines)) for i, lines in state.line_chunks(path, progress, cr)]


def test_blocks_are_the_joining_reader(tmp_path, monkeypatch):
    path = str(tmp_path / "t.gcode")
    for size in SIZES:
        monkeypatch.setattr(fwsim, "BLOCK_BYTES", size)
        for t in _texts():
            with open(path, "wb") as fh:
                fh.write(t)
            told, ref_told = [], []
            got, cr = _blocks(path, told.append)
            ref = _ref_blocks(path, size, ref_told.append)
            assert _split(got) == _split(ref), (size, t)
            assert b"".join(b for b, _ in got) == t
            assert all(b.endswith((b"\n", b"\r")) for b, _ in got[:-1])          # whole lines,
            assert not any(a.endswith(b"\r") and b.startswith(b"\n") for (a, _), (b, _) in zip(got, got[1:]))
            assert all(c == (b"\r" in b) for b, c in got)                     # its own cr
            assert cr == any(c for _, c in ref)
            assert sum(told) == sum(ref_told) == len(t), (size, t)


@pytest.mark.skipif(state._reader is None, reason="the compiled reader is not built")
def test_line_chunks_are_the_joining_reader(tmp_path, monkeypatch):
    path = str(tmp_path / "t.gcode")
    for size in SIZES:
        monkeypatch.setattr(fwsim, "CHUNK_HINT", size)
        for t in _texts():
            with open(path, "wb") as fh:
                fh.write(t)
            told, ref_told, cr, ref_cr = [], [], [False], [False]
            assert _flat(_chunks(path, told.append, cr)) == _flat(_ref_chunks(path, size, ref_told.append, ref_cr)), \
                (size, t)
            assert sum(told) == sum(ref_told) and cr == ref_cr, (size, t)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_not_seekable_reads_the_same(tmp_path, monkeypatch):
    text = b"G1 X1 Y2\r\n" * 30 + b"\r" + b"; " + b"c" * 100 + b"\nG1 X3"
    plain = str(tmp_path / "plain.gcode")
    with open(plain, "wb") as fh:
        fh.write(text)
    for size in (7, 64):
        monkeypatch.setattr(fwsim, "BLOCK_BYTES", size)
        # (a FIFO's reads may come short: the blocks, chunks may end elsewhere again)
        got, cr = through_fifo(tmp_path, text, _blocks)
        assert _split(got) == _split(_ref_blocks(plain, size)) and b"".join(b for b, _ in got) == text and cr
        if state._reader is not None:
            monkeypatch.setattr(fwsim, "CHUNK_HINT", size)
            assert _flat(through_fifo(tmp_path, text, _chunks)) == _flat(_ref_chunks(plain, size))
