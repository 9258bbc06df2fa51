"""Make the .bgcode fixtures with libbgcode (Prusa's own reader/writer, through the PyPI
binding `pybgcode-jneilliii`): an implementation independent of gcode_opt/bgcode*.py.

    pip install pybgcode-jneilliii && python tests/bgcode/make_fixtures.py

From sample_gcode/prusa_mk3s_rectilinear.gcode (real PrusaSlicer 2.5 output) with two
thumbnails added the way PrusaSlicer writes them (`; thumbnail begin WxH LEN` + base64):
  sample.bgcode           the whole file, PrusaSlicer 2.7+'s defaults (CRC32; G-code
                          MeatPack-with-comments + heatshrink 12,4; slicer metadata deflate)
  cut_<name>.bgcode       its first 700 lines + its closing metadata, one per case below:
                          every compression, every G-code encoding, both checksum types
  <name>.ref.gcode.gz     libbgcode's own conversion of each back to text (the reference)
"""
from __future__ import annotations

import base64
import gzip
import os
import struct
import sys
import tempfile
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLE = os.path.join(HERE, "..", "..", "sample_gcode", "prusa_mk3s_rectilinear.gcode")

# name: (checksum, gcode compression, gcode encoding, metadata compression)
CASES = {
    "default": ("CRC32", "Heatshrink_12_4", "MeatPackComments", "none"),
    "hs11_meatpack": ("CRC32", "Heatshrink_11_4", "MeatPack", "Heatshrink_11_4"),
    "deflate_plain": ("CRC32", "Deflate", "none", "Deflate"),
    "none_nochecksum": ("none", "none", "none", "none"),
    "hs12_plain_nochecksum": ("none", "Heatshrink_12_4", "none", "Heatshrink_12_4"),
}


def png(width, height, seed):
    """A small valid PNG (RGB gradient), written by hand: no imaging library needed."""
    rows = b"".join(b"\x00" + bytes(((x * 7 + y * 3 + seed) % 256, (x * seed) % 256, (y * 11) % 256)[c]
                                    for x in range(width) for c in range(3)) for y in range(height))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


THUMBNAILS = [(16, 16, png(16, 16, 1)), (32, 24, png(32, 24, 5))]


def thumbnail_text():
    out = []
    for w, h, data in THUMBNAILS:
        b64 = base64.b64encode(data).decode()
        out.append(f";\n; thumbnail begin {w}x{h} {len(b64)}\n")
        out += [f"; {b64[i:i + 78]}\n" for i in range(0, len(b64), 78)]
        out.append("; thumbnail end\n;\n")
    return "".join(out)


def source_text(cut=None):
    with open(SAMPLE, encoding="utf-8") as fh:
        lines = fh.readlines()
    if cut:
        tail = next(i for i, ln in enumerate(lines) if ln.startswith("; filament used [mm]"))
        lines = lines[:cut] + ["\n"] + lines[tail:]
    return lines[0] + "\n" + thumbnail_text() + "".join(lines[1:])


def convert(text, case, dst):
    import pybgcode as bg
    cs, gz, enc, meta = CASES[case]
    cfg = bg.get_config()
    cfg.checksum = getattr(type(cfg.checksum), cs)
    cfg.gcode_encoding = getattr(type(cfg.gcode_encoding), enc)
    comp = cfg.compression
    comp.gcode = getattr(bg.CompressionType, gz)
    for k in ("file_metadata", "printer_metadata", "print_metadata", "slicer_metadata"):
        setattr(comp, k, getattr(bg.CompressionType, meta))
    cfg.compression = comp
    with tempfile.TemporaryDirectory() as d:
        src = os.path.join(d, "in.gcode")
        with open(src, "w", encoding="utf-8") as fh:
            fh.write(text)
        fi, fo = bg.open(src, "rb"), bg.open(dst, "wb")
        res = bg.from_ascii_to_binary(fi, fo, cfg)
        bg.close(fi)
        bg.close(fo)
        assert res == bg.EResult.Success, res
        back = os.path.join(d, "back.gcode")
        fi, fo = bg.open(dst, "rb"), bg.open(back, "wb")
        res = bg.from_binary_to_ascii(fi, fo, True)
        bg.close(fi)
        bg.close(fo)
        assert res == bg.EResult.Success, res
        with open(back, "rb") as fh:
            return fh.read()


def main():
    jobs = [("sample", source_text(), "default")]
    jobs += [(f"cut_{case}", source_text(700), case) for case in CASES]
    for name, text, case in jobs:
        dst = os.path.join(HERE, name + ".bgcode")
        ref = convert(text, case, dst)
        with gzip.GzipFile(os.path.join(HERE, name + ".ref.gcode.gz"), "wb", mtime=0) as fh:
            fh.write(ref)
        print(name, os.path.getsize(dst), "bytes")


if __name__ == "__main__":
    sys.exit(main())
