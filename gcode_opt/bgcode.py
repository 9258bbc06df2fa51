"""Prusa binary G-code (.bgcode): read every block, verify its checksum, write it back.

Layout (libbgcode's doc/specifications.md, version 1; integers little-endian):
  file header   "GCDE", u32 version, u16 checksum type (0 none, 1 CRC32)
  blocks        u16 type, u16 compression, u32 uncompressed size, [u32 compressed size
                if compressed], parameters (u16 encoding; thumbnails: u16 format, width,
                height), data (compressed size bytes, or uncompressed size if not
                compressed), [u32 CRC32 of header + parameters + data]
  order         file metadata?  printer metadata  thumbnail*  print metadata
                slicer metadata (INI; a second one, JSON-encoded, since libbgcode 2025)  G-code+
Compression: 0 none, 1 deflate (zlib stream), 2 heatshrink 11,4, 3 heatshrink 12,4.
G-code encoding: 0 text, 1 MeatPack, 2 MeatPack keeping comment lines.

gcode-opt changes only the G-code: `write()` copies every other block byte for byte
(header, parameters, data and checksum as they were) and re-encodes the new text in
blocks of at most 64 KiB of text, with the input's compression and encoding (MeatPack
becomes MeatPack-with-comments: the `; gcode-opt begin/end` markers are comments).
"""
from __future__ import annotations

import re
import struct
import zlib
from dataclasses import dataclass, field

from . import bgcode_heatshrink as heatshrink
from . import bgcode_meatpack as meatpack

MAGIC = b"GCDE"
VERSION = 1
CHECKSUM_NONE, CHECKSUM_CRC32 = 0, 1
FILE_METADATA, GCODE, SLICER_METADATA, PRINTER_METADATA, PRINT_METADATA, THUMBNAIL = range(6)
BLOCK_NAMES = {FILE_METADATA: "file metadata", GCODE: "G-code", SLICER_METADATA: "slicer metadata",
               PRINTER_METADATA: "printer metadata", PRINT_METADATA: "print metadata",
               THUMBNAIL: "thumbnail"}
COMP_NONE, COMP_DEFLATE, COMP_HEATSHRINK_11_4, COMP_HEATSHRINK_12_4 = range(4)
COMPRESSION_NAMES = {0: "none", 1: "deflate", 2: "heatshrink 11,4", 3: "heatshrink 12,4"}
ENC_NONE, ENC_MEATPACK, ENC_MEATPACK_COMMENTS = range(3)
METADATA_INI, METADATA_JSON = 0, 1
THUMBNAIL_FORMATS = {0: "PNG", 1: "JPG", 2: "QOI"}
GCODE_BLOCK_TEXT = 65536          # libbgcode's cache: a G-code block holds at most this much text


class BGCodeError(ValueError):
    """A .bgcode file that is not valid; str() is 'FILE: what, where'."""


@dataclass
class Block:
    type: int
    compression: int
    uncompressed_size: int
    compressed_size: int
    params: bytes
    data: bytes                      # as stored (compressed, encoded)
    raw: bytes                       # the whole block as in the file, checksum included
    offset: int
    index: int

    @property
    def name(self):
        return BLOCK_NAMES.get(self.type, f"type {self.type}")

    @property
    def encoding(self):
        return struct.unpack_from("<H", self.params)[0]

    def where(self):
        return f"block {self.index} ({self.name}, offset {self.offset})"


@dataclass
class BGCode:
    version: int
    checksum_type: int
    blocks: list = field(default_factory=list)

    def gcode_blocks(self):
        return [b for b in self.blocks if b.type == GCODE]

    def metadata(self, block_type):
        """key -> value of the first INI metadata block of that type ({} if none)."""
        for b in self.blocks:
            if b.type == block_type and b.encoding == METADATA_INI:
                return dict(parse_ini(unpack(b)))
        return {}

    def thumbnails(self):
        """[(format name, width, height, image bytes)]"""
        out = []
        for b in self.blocks:
            if b.type == THUMBNAIL:
                fmt, w, h = struct.unpack("<3H", b.params)
                out.append((THUMBNAIL_FORMATS.get(fmt, str(fmt)), w, h, b.data))
        return out


def is_bgcode(path) -> bool:
    with open(path, "rb") as fh:
        return fh.read(4) == MAGIC


def parse_ini(data: bytes):
    """key=value lines, as libbgcode writes metadata (INI encoding)."""
    out = []
    for line in data.split(b"\n"):
        k, eq, v = line.partition(b"=")
        if eq:
            out.append((k.decode("utf-8", "surrogateescape"), v.decode("utf-8", "surrogateescape")))
    return out


# ----------------------------------------------------------------------------- read
def read(path) -> BGCode:
    with open(path, "rb") as fh:
        buf = fh.read()
    return parse(buf, str(path))


def parse(buf: bytes, name: str = "<bgcode>") -> BGCode:
    """Every block, each checksum verified; BGCodeError names the file and the block."""
    if len(buf) < 10 or buf[:4] != MAGIC:
        raise BGCodeError(f"{name}: not a binary G-code file (no GCDE header)")
    version, cs_type = struct.unpack_from("<IH", buf, 4)
    if version != VERSION:
        raise BGCodeError(f"{name}: binary G-code version {version}; gcode-opt reads version {VERSION}")
    if cs_type not in (CHECKSUM_NONE, CHECKSUM_CRC32):
        raise BGCodeError(f"{name}: unknown checksum type {cs_type}")
    out = BGCode(version, cs_type)
    pos = 10
    while pos < len(buf):
        out.blocks.append(_read_block(buf, pos, len(out.blocks), cs_type, name))
        pos += len(out.blocks[-1].raw)
    _check_order(out, name)
    return out


def _read_block(buf, pos, index, cs_type, name):
    start = pos

    def need(n, what):
        if pos + n > len(buf):
            raise BGCodeError(f"{name}: block {index} at offset {start}: file ends inside its {what} "
                              "(truncated?)")
    need(8, "header")
    btype, comp, usize = struct.unpack_from("<HHI", buf, pos)
    where = f"block {index} ({BLOCK_NAMES.get(btype, f'type {btype}')}, offset {start})"
    if btype not in BLOCK_NAMES:
        raise BGCodeError(f"{name}: {where}: unknown block type {btype}")
    if comp not in COMPRESSION_NAMES:
        raise BGCodeError(f"{name}: {where}: unknown compression {comp}")
    pos += 8
    csize = usize
    if comp != COMP_NONE:
        need(4, "header")
        csize = struct.unpack_from("<I", buf, pos)[0]
        pos += 4
    n_params = 6 if btype == THUMBNAIL else 2
    need(n_params, "parameters")
    params = buf[pos:pos + n_params]
    pos += n_params
    need(csize, "data")
    data = buf[pos:pos + csize]
    pos += csize
    if cs_type == CHECKSUM_CRC32:
        need(4, "checksum")
        stored = struct.unpack_from("<I", buf, pos)[0]
        computed = zlib.crc32(buf[start:pos])
        pos += 4
        if stored != computed:
            raise BGCodeError(f"{name}: {where}: checksum mismatch (CRC32 stored {stored:08x}, "
                              f"computed {computed:08x}): the file is damaged; slice or copy it again")
    return Block(btype, comp, usize, csize, params, data, buf[start:pos], start, index)


def _check_order(f: BGCode, name):
    """The order of the spec (and of libbgcode's validity check)."""
    types = [b.type for b in f.blocks]
    k = 0
    if k < len(types) and types[k] == FILE_METADATA:
        k += 1
    expect = [(PRINTER_METADATA, "printer metadata")]
    for t, what in expect:
        if k >= len(types) or types[k] != t:
            raise BGCodeError(f"{name}: invalid sequence of blocks: {what} block expected as block {k}")
        k += 1
    while k < len(types) and types[k] == THUMBNAIL:
        k += 1
    for t, what in ((PRINT_METADATA, "print metadata"), (SLICER_METADATA, "slicer metadata")):
        if k >= len(types) or types[k] != t:
            raise BGCodeError(f"{name}: invalid sequence of blocks: {what} block expected as block {k}")
        k += 1
    if k < len(types) and types[k] == SLICER_METADATA:     # the second (JSON) slicer metadata
        k += 1
    if k >= len(types):
        raise BGCodeError(f"{name}: no G-code block")
    bad = [i for i in range(k, len(types)) if types[i] != GCODE]
    if bad:
        i = bad[0]
        raise BGCodeError(f"{name}: invalid sequence of blocks: {f.blocks[i].where()} after the G-code")


def unpack(b: Block, name: str = "<bgcode>") -> bytes:
    """A block's data, decompressed (not decoded)."""
    try:
        if b.compression == COMP_NONE:
            out = b.data
        elif b.compression == COMP_DEFLATE:                 # never more than the header says
            d = zlib.decompressobj()
            out = d.decompress(b.data, b.uncompressed_size + 1)
            if not d.eof and len(out) <= b.uncompressed_size:
                raise zlib.error("incomplete deflate stream")
        else:
            out = heatshrink.decode(b.data, 11 if b.compression == COMP_HEATSHRINK_11_4 else 12,
                                    b.uncompressed_size)
    except (zlib.error, heatshrink.HeatshrinkError) as e:
        raise BGCodeError(f"{name}: {b.where()}: cannot decompress ({COMPRESSION_NAMES[b.compression]}): "
                          f"{e}") from None
    if len(out) != b.uncompressed_size:
        raise BGCodeError(f"{name}: {b.where()}: decompressed to {len(out)} bytes, header says "
                          f"{b.uncompressed_size}")
    return out


def gcode_text(f: BGCode, name: str = "<bgcode>") -> bytes:
    """The G-code the blocks hold, as one text (MeatPack decoded as libbgcode decodes it)."""
    parts = []
    for b in f.gcode_blocks():
        data = unpack(b, name)
        enc = b.encoding
        if enc == ENC_NONE:
            parts.append(data)
        elif enc in (ENC_MEATPACK, ENC_MEATPACK_COMMENTS):
            parts.append(meatpack.decode(data))
        else:
            raise BGCodeError(f"{name}: {b.where()}: unknown G-code encoding {enc}")
    return b"".join(parts)


def settings(f: BGCode) -> dict:
    """The slicer's settings the metadata blocks hold (slicer config over printer metadata):
    what a text file's closing config block says."""
    return {**f.metadata(PRINTER_METADATA), **f.metadata(SLICER_METADATA)}


# ----------------------------------------------------------------------------- write
def _split_text(text: bytes, limit: int = GCODE_BLOCK_TEXT):
    """Chunks of whole lines, each at most `limit` bytes (a longer line gets a chunk of its own).
    An empty line starts a chunk: MeatPack keeps an empty line only as a block's first."""
    chunks = []
    cuts = [m.end() for m in re.finditer(b"\n(?=\n)", text)]
    for a, b in zip([0] + cuts, cuts + [len(text)]):
        start = a
        while start < b:
            end = min(start + limit, b)
            if end < b:
                cut = text.rfind(b"\n", start, end)
                end = cut + 1 if cut >= start else (text.find(b"\n", end, b) + 1 or b)
            chunks.append(text[start:end])
            start = end
    return chunks


def _pack_block(btype, comp, params: bytes, payload: bytes, cs_type) -> bytes:
    """One block from its uncompressed payload."""
    if comp == COMP_NONE:
        data = payload
        head = struct.pack("<HHI", btype, comp, len(payload))
    else:
        if comp == COMP_DEFLATE:
            data = zlib.compress(payload)
        else:
            data = heatshrink.encode(payload, 11 if comp == COMP_HEATSHRINK_11_4 else 12)
        head = struct.pack("<HHII", btype, comp, len(payload), len(data))
    body = head + params + data
    if cs_type == CHECKSUM_CRC32:
        body += struct.pack("<I", zlib.crc32(body))
    return body


def gcode_blocks(text: bytes, comp: int, enc: int, cs_type: int):
    """The G-code block bytes for `text`."""
    out = []
    for chunk in _split_text(text):
        if enc == ENC_NONE:
            payload = chunk
        else:
            payload = meatpack.encode(chunk, keep_comments=enc == ENC_MEATPACK_COMMENTS)
        out.append(_pack_block(GCODE, comp, struct.pack("<H", enc), payload, cs_type))
    return out


def output_format(f: BGCode):
    """(compression, encoding) for the re-encoded G-code: the input's first G-code block's,
    MeatPack keeping comments where the input dropped them."""
    first = f.gcode_blocks()[0]
    enc = first.encoding
    if enc == ENC_MEATPACK:
        enc = ENC_MEATPACK_COMMENTS
    return first.compression, enc


def encode_file(f: BGCode, text: bytes) -> bytes:
    """The input's header and non-G-code blocks byte for byte, then `text` as G-code blocks."""
    comp, enc = output_format(f)
    head = MAGIC + struct.pack("<IH", f.version, f.checksum_type)
    kept = [b.raw for b in f.blocks if b.type != GCODE]
    return b"".join([head] + kept + gcode_blocks(text, comp, enc, f.checksum_type))
