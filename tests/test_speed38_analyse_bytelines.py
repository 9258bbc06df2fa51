"""pipeline._ByteLines.take: where a stroke's lines run past the chunk read, the lines from
pos on are read again with the next chunk (a seek back) instead of copied and joined to it.
Against the joining class it replaces (copied here as it was at 23d24f4), through random
sequences of drop, copy, take, copy_take and rest on random texts (LF, CRLF, lone CRs,
no final newline, lines longer than a chunk) at chunk sizes 1 .. 1 MiB: the same bytes
written in all, the same lines and counts from each take; and on a FIFO (not seekable:
the joining path)."""
from __future__ import annotations

import os
import random

import pytest

from fifo_cases import through_fifo
from gcode_opt import emit, pipeline

CORE = emit.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "skip_lines"),
                                reason="no compiled emit core with skip_lines")


class _RefByteLines:
    """_ByteLines as it was (take joins the rest to the next chunk)."""

    def __init__(self, fh, skip, chunk):
        self.fh, self.skip, self.chunk = fh, skip, chunk
        self.data, self.pos, self.eof = b"", 0, False

    def _read(self):
        chunk = self.fh.read(self.chunk)
        while chunk.endswith(b"\r"):
            more = self.fh.read(1)
            if not more:
                break
            chunk += more
        if not chunk:
            self.eof = True
        return chunk

    def drop(self, n):
        while n > 0:
            self.pos, got = self.skip(self.data, self.pos, n, self.eof)
            n -= got
            if n > 0:
                if self.eof:
                    return
                self.data, self.pos = self._read(), 0

    def copy(self, n, write):
        while n > 0:
            end, got = self.skip(self.data, self.pos, n, self.eof)
            if end > self.pos:
                write(self.data[self.pos:end] if self.pos or end < len(self.data) else self.data)
            self.pos = end
            n -= got
            if n > 0:
                if self.eof:
                    return
                self.data, self.pos = self._read(), 0

    def take(self, n):
        while True:
            end, got = self.skip(self.data, self.pos, n, self.eof)
            if got == n or self.eof:
                start, self.pos = self.pos, end
                return self.data, start, end, got
            self.data, self.pos = self.data[self.pos:] + self._read(), 0

    def copy_take(self, n_copy, n, write):
        if n_copy:
            self.copy(n_copy, write)
        return self.take(n)

    def rest(self, write):
        if self.pos < len(self.data):
            write(self.data[self.pos:])
        self.data, self.pos = b"", 0
        while not self.eof:
            chunk = self.fh.read(self.chunk)
            if not chunk:
                break
            write(chunk)


def _ops(rng):
    ops = [(rng.choice("dctk"), rng.randint(0, 12), rng.randint(1, 12)) for _ in range(rng.randint(1, 30))]
    return ops + [("r", 0, 0)]


def _play(src, ops):
    """What a sequence of operations gives: the bytes written (joined) and each take's
    (lines, got)."""
    out, takes = [], []
    for op, a, b in ops:
        if op == "d":
            src.drop(a)
        elif op == "c":
            src.copy(a, out.append)
        elif op == "t":
            data, start, stop, got = src.take(b)
            takes.append((bytes(data[start:stop]), got))
        elif op == "k":
            data, start, stop, got = src.copy_take(a, b, out.append)
            takes.append((bytes(data[start:stop]), got))
        else:
            src.rest(out.append)
    return b"".join(bytes(x) for x in out), takes


def _texts(rng):
    alpha = [b"\r", b"\n", b"\r\n", b"G1 X1.5 Y2 E0.1", b";c", b"\xc3\xa9", b"y" * 30]
    texts = [b"", b"a", b"a\n", b"a\r", b"\r\n\r\n", b"G1 X1\n" * 40 + b"G1 X2"]
    return texts + [b"".join(rng.choice(alpha) for _ in range(rng.randint(1, 120))) for _ in range(50)]


def test_take_is_the_joining_reader(tmp_path, monkeypatch):
    rng = random.Random(3808)
    path = str(tmp_path / "t.gcode")
    for size in (1, 2, 3, 7, 64, 1 << 20):
        monkeypatch.setattr(pipeline, "_CHUNK", size)
        for t in _texts(rng):
            with open(path, "wb") as fh:
                fh.write(t)
            for _ in range(4):
                ops = _ops(rng)
                with open(path, "rb") as fh:
                    got = _play(pipeline._ByteLines(fh, CORE.skip_lines), ops)
                with open(path, "rb") as fh:
                    ref = _play(_RefByteLines(fh, CORE.skip_lines, size), ops)
                assert got == ref, (size, t, ops)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_not_seekable_reads_the_same(tmp_path, monkeypatch):
    text = (b"G1 X1 Y2\r\n" * 7 + b"\r;" + b"c" * 50 + b"\n") * 5 + b"G1 X3"
    monkeypatch.setattr(pipeline, "_CHUNK", 16)
    ops = [("d", 3, 1), ("t", 0, 5), ("k", 2, 9), ("c", 4, 1), ("t", 0, 7), ("r", 0, 0)]

    def read(path):
        with open(path, "rb") as fh:
            assert not fh.seekable()
            return _play(pipeline._ByteLines(fh, CORE.skip_lines), ops)
    got = through_fifo(tmp_path, text, read)
    plain = str(tmp_path / "plain.gcode")
    with open(plain, "wb") as fh:
        fh.write(text)
    with open(plain, "rb") as fh:
        assert got == _play(_RefByteLines(fh, CORE.skip_lines, 16), ops)
