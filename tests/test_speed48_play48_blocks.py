"""Session 48 (play48): Blocks.blocks reads a block without "\\r" once for it, not twice.

The cut after a block's last line ending and its cr flag come from one `b"\\r" in data`
where the block holds no "\\r" (a file of LF endings: every block).  Reference: the
generator it replaced, kept here verbatim; the same (bytes, cr) blocks, the same progress
calls and the same Blocks.cr, on files of LF, CR LF and lone CR endings (also at a block's
edge and at the file's end), lines longer than a block, with and without a final ending, at
block sizes from 1 byte up; read from a file (seek back) and from a pipe (no seek)."""
from __future__ import annotations

import os
import random
import threading

import pytest

from gcode_opt.firmware import simulate as fw


# ---------------------------------------------------------------- the replaced code (verbatim)
def _ref_blocks(self):
    progress = self.progress
    self.cr = False
    with open(self.path, "rb") as fh:
        seek = fh.seekable()
        rest = b""
        while True:
            data = fh.read(fw.BLOCK_BYTES)
            if not data:
                if rest:
                    cr = b"\r" in rest
                    self.cr |= cr
                    yield rest, cr
                return
            n_read = len(data)
            if rest:
                data = rest + data
            # cut after the last line ending; a "\r" at the very end may be the start of a
            # "\r\n" (one ending): its line waits for the next block
            stop = len(data) - 1 if data[-1] == 13 else len(data)
            k = max(data.rfind(b"\n", 0, stop), data.rfind(b"\r", 0, stop)) + 1
            if k == 0:
                if progress is not None:
                    progress(n_read)
                rest = data
                continue
            # the cut line is read again with the next block (a seek back) rather than
            # joined to it (rest + data copied the whole block: ~12 M bytes a pass of
            # the gyroid plate); it lies in the bytes just read
            tail = len(data) - k if seek else 0
            if tail:
                fh.seek(-tail, 1)
                rest = b""
            else:
                rest = data[k:]
            if progress is not None:
                progress(n_read - tail)     # (each byte told once)
            cr = data.find(b"\r", 0, k) >= 0
            self.cr |= cr
            yield memoryview(data)[:k], cr


def _text(rng, endings):
    parts = []
    for _ in range(rng.randint(0, 60)):
        n = rng.choice([0, 1, 5, 12, 40, 200])
        parts.append("G1 X%d" % rng.randint(0, 9) + "y" * n + rng.choice(endings))
    return "".join(parts).encode()


def _run(path, ref):
    told = []
    b = fw.Blocks(path, told.append)
    gen = _ref_blocks(b) if ref else b.blocks()
    got = [(bytes(buf), cr) for buf, cr in gen]
    return got, told, b.cr


CASES = [("\n",), ("\r\n",), ("\r",), ("\n", "\r\n"), ("\n", "\r"), ("\n", "\r\n", "\r", "")]


@pytest.mark.parametrize("endings", CASES)
@pytest.mark.parametrize("seed", range(4))
def test_blocks_are_the_replaced_generators(tmp_path, endings, seed, monkeypatch):
    rng = random.Random(repr((endings, seed)))
    data = _text(rng, endings) + rng.choice([b"", b"G1 X9", b"\r", b"\r\n", b"\n", b"G1 X9\r"])
    path = str(tmp_path / "f.gcode")
    with open(path, "wb") as fh:
        fh.write(data)
    for size in (1, 2, 3, 7, 16, 64, 1000, 1 << 16):
        monkeypatch.setattr(fw, "BLOCK_BYTES", size)
        got = _run(path, False)
        assert got == _run(path, True), size
        assert b"".join(b for b, _ in got[0]) == data


def test_blocks_from_a_pipe_are_the_replaced_generators(tmp_path, monkeypatch):
    """No seek back: the cut line's rest is joined to the next block."""
    data = b"G1 X1\nG1 X2\r\nG1 X3\r" * 30 + b"G1 X4"
    path = str(tmp_path / "fifo")
    monkeypatch.setattr(fw, "BLOCK_BYTES", 7)
    got = []
    for ref in (False, True):
        os.mkfifo(path)
        writer = threading.Thread(target=lambda: open(path, "wb").write(data))
        writer.start()
        got.append(_run(path, ref))
        writer.join()
        os.unlink(path)
    assert got[0] == got[1]
    assert b"".join(b for b, _ in got[0][0]) == data
