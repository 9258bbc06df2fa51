"""Is this file ASCII G-code at all?  A cheap look at its head, before any work.

`check_input(path)` raises `InputRefused` (a ValueError whose str is
`FILE: what it is and what to do`) for a directory, a missing or unreadable file, an
empty file, a Prusa binary G-code (.bgcode) and any other binary file (NUL bytes, or
mostly bytes that text never holds, in the first 64 KB).  It reads at most HEAD_BYTES.
`check_input(path, binary_gcode=True)` (process, simulate: they decode .bgcode) lets a
.bgcode through after a look at its file header, and returns "bgcode" (else "text").
Whether the text moves the printer at all is decided later, by the pipeline.
"""
from __future__ import annotations

import os
import stat

HEAD_BYTES = 65536
BGCODE_MAGIC = b"GCDE"
# bytes a text file never holds: C0 controls other than \t \n \v \f \r, ESC and DEL
_CONTROL = bytes(set(range(32)) - {9, 10, 11, 12, 13, 27}) + b"\x7f"
MAX_CONTROL_R = 0.01       # share of such bytes above which the head is not text
MAX_UNDECODABLE_R = 0.30   # share of bytes that are not UTF-8 (comments may hold a few)


class InputRefused(ValueError):
    """The input is not something gcode-opt can read; str names the file and what to do."""

    def __init__(self, path, what):
        super().__init__(f"{path}: {what}")


def check_input(path, binary_gcode: bool = False) -> str:
    """Raise InputRefused unless `path` is a readable, non-empty, text (ASCII G-code) file, or
    (binary_gcode) a file that starts as a binary G-code does.  Returns "text" or "bgcode"."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise InputRefused(path, "no such file") from None
    except OSError as e:
        raise InputRefused(path, f"cannot read it: {e.strerror or e}") from None
    if stat.S_ISDIR(st.st_mode):
        raise InputRefused(path, "is a directory: give a G-code file")
    try:
        with open(path, "rb") as fh:
            head = fh.read(HEAD_BYTES)
    except OSError as e:
        raise InputRefused(path, f"cannot read it: {e.strerror or e}") from None
    if not head:
        raise InputRefused(path, "the file is empty: nothing to process (did the slicer finish writing it?)")
    if head.startswith(BGCODE_MAGIC):
        if not binary_gcode:
            raise InputRefused(path, "Prusa binary G-code (.bgcode): this command reads ASCII G-code only "
                                     "(`gcode-opt process` and `simulate` read .bgcode); export ASCII G-code "
                                     "(PrusaSlicer: Printer Settings > General > Firmware > Supports binary "
                                     "G-code off) or convert it with libbgcode's bgcode tool")
        why = _not_bgcode(head)
        if why:
            raise InputRefused(path, f"starts like a Prusa binary G-code (.bgcode) but {why}")
        return "bgcode"
    why = _not_text(head)
    if why:
        raise InputRefused(path, f"not a text file ({why}): gcode-opt reads ASCII G-code only")
    return "text"


def _not_bgcode(head: bytes) -> str:
    """Why this head is not a binary G-code file header gcode-opt reads, or ''."""
    if len(head) < 10:
        return f"is only {len(head)} bytes long (a header alone is 10)"
    version = int.from_bytes(head[4:8], "little")
    checksum_type = int.from_bytes(head[8:10], "little")
    if version != 1:
        return f"has version {version}; gcode-opt reads version 1"
    if checksum_type not in (0, 1):
        return f"has an unknown checksum type {checksum_type} (0 none, 1 CRC32)"
    return ""


def _not_text(head: bytes) -> str:
    """Why these bytes are not a text file's, or '' if they may be."""
    nul = head.find(b"\x00")
    if nul >= 0:
        return f"a NUL byte at offset {nul}"
    n = len(head)
    n_control = n - len(head.translate(None, _CONTROL))
    if n_control > MAX_CONTROL_R * n:
        return f"{n_control} control bytes in the first {n} bytes"
    # a head cut in the middle of a multi-byte character is still UTF-8
    text = head.decode("utf-8", errors="replace")
    n_bad = text.count("\ufffd") - head.decode("utf-8", errors="ignore").count("\ufffd")
    if n_bad > MAX_UNDECODABLE_R * n:
        return f"{n_bad} of its first {n} bytes are not UTF-8"
    return ""
