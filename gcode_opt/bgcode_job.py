"""Run the text pipeline on a binary G-code file: decode, process, encode, check, replace.

    job = BinaryJob(in_path, out_path)     # reads every block, verifies checksums, decodes
    summary = job.run(lambda: process(job.src, job.dst, ...))   # paths in errors name the input
    job.finish(summary)                    # encodes job.dst, checks it, writes out_path atomically
    job.close()                            # removes the temporary folder

The pipeline sees the G-code exactly as the printer will (libbgcode's decoding), in a
temporary text file; the metadata blocks and thumbnails are copied byte for byte.  Before
the output replaces anything, it is read back with the same reader: every checksum must
hold and its G-code must be, byte for byte, the text the pipeline wrote and validated.
"""
from __future__ import annotations

import os
import shutil
import tempfile

from . import bgcode


class BinaryJob:
    def __init__(self, in_path: str, out_path: str):
        self.in_path, self.out_path = in_path, out_path
        self.file = bgcode.read(in_path)             # BGCodeError (exit 2) names file and block
        text = bgcode.gcode_text(self.file, in_path)
        self.settings = bgcode.settings(self.file)
        self.tmpdir = tempfile.mkdtemp(prefix="gcode-opt-bgcode-")
        base = os.path.splitext(os.path.basename(in_path))[0] or "input"
        self.src = os.path.join(self.tmpdir, base + ".gcode")
        self.dst = os.path.join(self.tmpdir, base + ".out.gcode")
        try:
            with open(self.src, "wb") as fh:
                fh.write(text)
        except BaseException:
            self.close()
            raise
        self.in_bytes = os.path.getsize(in_path)
        self.out_bytes = None
        self.warnings = []
        if any(b.encoding == bgcode.ENC_MEATPACK for b in self.file.gcode_blocks()):
            self.warnings.append(f"{in_path}: its G-code was stored without comments (MeatPack), so the "
                                 "slicer's feature comments (;TYPE:) are gone: only --features all selects strokes "
                                 "(PrusaSlicer's default, MeatPack with comments, keeps them)")

    def _named(self, msg: str) -> str:
        """Messages about the temporary texts name the user's file."""
        return (msg.replace(self.src, f"{self.in_path} (decoded G-code)")
                   .replace(self.dst, f"{self.out_path} (G-code)"))

    def run(self, fn):
        from .outfile import OutputError
        try:
            return fn()
        except OutputError as e:
            raise OutputError(self._named(str(e))) from None
        except ValueError as e:                     # a refusal 'FILE:LINE: why' (exit 2)
            raise ValueError(self._named(str(e))) from None

    def finish(self, summary: dict) -> dict:
        """Write the output; a G-code the pipeline left as it was keeps the input's bytes (copied
        when the output is elsewhere, untouched in place)."""
        from .outfile import AtomicOutput, OutputError, describe, target_of
        data = None
        if not summary.get("unchanged"):
            with open(self.dst, "rb") as fh:
                text = fh.read()
            with open(self.src, "rb") as fh:
                changed = fh.read() != text
            if changed:
                data = bgcode.encode_file(self.file, text)
                back = bgcode.parse(data, self.out_path)    # every checksum and the block order
                if bgcode.gcode_text(back, self.out_path) != text:
                    raise RuntimeError(f"{self.out_path}: the encoded binary G-code does not decode to "
                                       "the processed text; nothing written")
        if data is None and target_of(self.out_path) == target_of(self.in_path):
            self.out_bytes = self.in_bytes
            return self._label(summary)
        with AtomicOutput(self.out_path) as out:
            try:
                if data is None:
                    shutil.copyfile(self.in_path, out.tmp)
                else:
                    with open(out.tmp, "wb") as fh:
                        fh.write(data)
                        fh.flush()
                        os.fsync(fh.fileno())
            except OSError as e:
                if e.filename not in (None, out.tmp):
                    raise
                raise OutputError(describe(e, self.out_path)) from None
            out.commit()
        self.out_bytes = self.in_bytes if data is None else len(data)
        return self._label(summary)

    def _label(self, summary):
        summary["input"], summary["output"] = self.in_path, self.out_path
        comp, enc = bgcode.output_format(self.file)
        summary["bgcode"] = {"bytes_before": self.in_bytes, "bytes_after": self.out_bytes,
                             "gcode_compression": bgcode.COMPRESSION_NAMES[comp],
                             "gcode_encoding": ["none", "MeatPack", "MeatPack with comments"][enc],
                             "blocks_kept": sum(b.type != bgcode.GCODE for b in self.file.blocks)}
        return summary

    def close(self):
        shutil.rmtree(self.tmpdir, ignore_errors=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False
