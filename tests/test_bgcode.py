"""Binary G-code (.bgcode): reader, writer, heatshrink, MeatPack, and `gcode-opt process/simulate`.

Independent references: the fixtures in tests/bgcode/ were written by libbgcode (Prusa's
implementation, via the PyPI binding pybgcode-jneilliii, see make_fixtures.py), each with
libbgcode's own conversion back to text; hand-computed bit strings from the format's
description; and, where installed, libbgcode itself and the C heatshrink library
(heatshrink2) as readers of what gcode-opt writes.
"""
from __future__ import annotations

import glob
import gzip
import json
import os
import random
import shutil
import struct
import sys

import pytest

from gcode_opt import bgcode
from gcode_opt import bgcode_heatshrink as hs
from gcode_opt import bgcode_meatpack as mp
from gcode_opt.cli import main
from gcode_opt.inputcheck import InputRefused, check_input
from gcode_opt.profile import load_profile
from gcode_opt.verify import verify

HERE = os.path.dirname(os.path.abspath(__file__))
FIX = os.path.join(HERE, "bgcode")
sys.path.insert(0, FIX)
import make_fixtures  # noqa: E402  (the thumbnails the fixtures were made with)

FIXTURES = sorted(glob.glob(os.path.join(FIX, "*.bgcode")))
CUTS = [p for p in FIXTURES if os.path.basename(p).startswith("cut_")]

try:
    import heatshrink2
except ImportError:
    heatshrink2 = None


def ref_text(path):
    with gzip.open(path[:-len(".bgcode")] + ".ref.gcode.gz") as fh:
        return fh.read()


def bits_to_bytes(bits: str) -> bytes:
    bits += "0" * (-len(bits) % 8)
    return bytes(int(bits[i:i + 8], 2) for i in range(0, len(bits), 8))


# ----------------------------------------------------------------------------- heatshrink
@pytest.mark.parametrize("window_bits", [11, 12])
def test_heatshrink_hand_vector(window_bits):
    # "abab": literal a, literal b, then a back-reference 2 bytes back, 2 long:
    # tag 1 + 8 bits, tag 1 + 8 bits, tag 0 + (offset-1 = 1 in W bits) + (length-1 = 1 in 4 bits)
    bits = "1" + "01100001" + "1" + "01100010" + "0" + format(1, f"0{window_bits}b") + "0001"
    vec = bits_to_bytes(bits)
    assert hs.decode(vec, window_bits, 4, use_c=False) == b"abab"
    assert hs.encode(b"abab", window_bits, use_c=False) == vec
    # "aaaaaa": one literal, then an overlapping reference 1 back, 5 long
    bits = "1" + "01100001" + "0" + format(0, f"0{window_bits}b") + "0100"
    assert hs.decode(bits_to_bytes(bits), window_bits, 6, use_c=False) == b"aaaaaa"
    if heatshrink2 is not None:
        assert heatshrink2.decompress(vec, window_sz2=window_bits, lookahead_sz2=4) == b"abab"


def _samples():
    rnd = random.Random(11)
    with open(os.path.join(HERE, "..", "sample_gcode", "prusa_mk3s_rectilinear.gcode"), "rb") as fh:
        gcode = fh.read(40000)
    return [b"", b"x", b"ab" * 3000, bytes(rnd.randrange(256) for _ in range(5000)),
            bytes(rnd.choice(b"G1 X.0123\n") for _ in range(9000)), gcode]


@pytest.mark.parametrize("window_bits", [11, 12])
def test_heatshrink_round_trip_and_cross_check(window_bits):
    for data in _samples():
        enc = hs.encode(data, window_bits, use_c=False)
        assert hs.decode(enc, window_bits, len(data), use_c=False) == data
        if heatshrink2 is not None:          # the C library reads ours, ours reads the C library's
            assert heatshrink2.decompress(enc, window_sz2=window_bits, lookahead_sz2=4) == data
            c_enc = heatshrink2.compress(data, window_sz2=window_bits, lookahead_sz2=4)
            assert hs.decode(c_enc, window_bits, len(data), use_c=False) == data
    with pytest.raises(hs.HeatshrinkError):
        hs.decode(b"\xb0", window_bits, 10, use_c=False)     # one literal, then nothing


# ----------------------------------------------------------------------------- MeatPack
START = b"\xff\xff\xfb\xff\xff\xf7"          # packing on, no-spaces on


def test_meatpack_hand_vectors():
    # G line: spaces dropped, 7 characters + '\n' padding: G1 X1 0\n \n\n
    assert mp.encode(b"G1 X10\n") == START + bytes([0x1D, 0x1E, 0xC0, 0xCC])
    # M line keeps its space (not packable with no-spaces on): M2 -> 0x2F 'M'; 04; ' P' whole; 15; 00; \n\n
    assert mp.encode(b"M204 P1500\n") == START + bytes([0x2F]) + b"M" + bytes([0x40, 0xFF]) + b" P" \
        + bytes([0x51, 0x00, 0xCC])
    # a comment line: packing off, the line verbatim; the next G line turns it on again
    enc = mp.encode(b";TYPE:Solid infill\nG1 X10\n")
    assert enc == START + b"\xff\xff\xfa;TYPE:Solid infill\n\xff\xff\xfb" + bytes([0x1D, 0x1E, 0xC0, 0xCC])
    # without comments: the comment line goes, and the stream ends with a reset
    assert mp.encode(b";c\nG1 X10\n", keep_comments=False) == START + bytes([0x1D, 0x1E, 0xC0, 0xCC]) \
        + b"\xff\xff\xf9"
    assert mp.decode(enc) == b";TYPE:Solid infill\nG1 X10\n"
    assert mp.decode(START + bytes([0x2F]) + b"M" + bytes([0x40, 0xFF]) + b" P" + bytes([0x51, 0x00, 0xCC])) \
        == b"M204 P1500\n"


def test_meatpack_what_the_reader_gives():
    # libbgcode's reader: words of a G line spaced out, inline comments and blank lines gone,
    # e/x/g upper-cased in G lines, M lines as written
    text = b"G1  x1.5 Y2 e.3 F1800 ; move\n\n   \nM107\n;keep me\nG28 W\nM117 Hello\n"
    assert mp.decode(mp.encode(text)) == b"G1 X1.5 Y2 E.3 F1800\nM107\n;keep me\nG28 W\nM117 Hello\n"


def test_meatpack_fixed_point_on_real_text():
    text = bgcode.gcode_text(bgcode.read(os.path.join(FIX, "sample.bgcode")))
    assert mp.decode(mp.encode(text)) == text


# ----------------------------------------------------------------------------- reader
@pytest.mark.parametrize("path", FIXTURES, ids=os.path.basename)
def test_reads_what_libbgcode_wrote(path):
    f = bgcode.read(path)
    text = bgcode.gcode_text(f, path)
    ref = ref_text(path)
    assert len(text) > 10000 and text in ref            # libbgcode's own text of the same file
    assert [t[:3] for t in f.thumbnails()] == [("PNG", w, h) for w, h, _ in make_fixtures.THUMBNAILS]
    assert [t[3] for t in f.thumbnails()] == [d for _, _, d in make_fixtures.THUMBNAILS]
    printer = f.metadata(bgcode.PRINTER_METADATA)
    assert printer["printer_model"] == "MK3S"
    for k, v in list(printer.items()) + list(f.metadata(bgcode.SLICER_METADATA).items())[:50]:
        assert f"; {k} = {v}".encode() in ref


def test_every_compression_encoding_and_checksum_is_covered():
    seen = set()
    for p in FIXTURES:
        f = bgcode.read(p)
        seen |= {("checksum", f.checksum_type)}
        seen |= {("compression", b.compression) for b in f.blocks}
        seen |= {("encoding", b.encoding) for b in f.gcode_blocks()}
    assert {("checksum", 0), ("checksum", 1)} <= seen
    assert {("compression", c) for c in range(4)} <= seen
    assert {("encoding", e) for e in range(3)} <= seen


def _block_offset(path, block_type):
    f = bgcode.read(path)
    b = next(b for b in f.blocks if b.type == block_type)
    return b, b.offset + len(b.raw) - 10         # a byte inside the data, before the CRC


@pytest.mark.parametrize("block_type,name", [(bgcode.GCODE, "G-code"), (bgcode.THUMBNAIL, "thumbnail"),
                                             (bgcode.PRINTER_METADATA, "printer metadata")])
def test_bad_checksum_names_file_and_block(tmp_path, capsys, block_type, name):
    p = tmp_path / "damaged.bgcode"
    data = bytearray(open(os.path.join(FIX, "cut_default.bgcode"), "rb").read())
    b, at = _block_offset(os.path.join(FIX, "cut_default.bgcode"), block_type)
    data[at] ^= 0x40
    p.write_bytes(bytes(data))
    with pytest.raises(bgcode.BGCodeError) as ei:
        bgcode.read(str(p))
    msg = str(ei.value)
    assert msg.startswith(f"{p}: block {b.index} ({name}, offset {b.offset}): checksum mismatch"), msg
    rc = main(["process", str(p), "-q"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and err[0] == f"gcode-opt: {msg}"
    assert p.read_bytes() == bytes(data)                 # untouched
    assert not [n for n in os.listdir(tmp_path) if n != "damaged.bgcode"]


def test_truncated_and_misordered_files(tmp_path):
    data = open(os.path.join(FIX, "cut_default.bgcode"), "rb").read()
    p = tmp_path / "t.bgcode"
    p.write_bytes(data[:-7])
    with pytest.raises(bgcode.BGCodeError, match="file ends inside"):
        bgcode.read(str(p))
    f = bgcode.parse(data)
    blocks = [b.raw for b in f.blocks]
    swapped = data[:10] + b"".join([blocks[1], blocks[0]] + blocks[2:])
    with pytest.raises(bgcode.BGCodeError, match="invalid sequence of blocks"):
        bgcode.parse(swapped)
    with pytest.raises(bgcode.BGCodeError, match="version 2"):
        bgcode.parse(b"GCDE" + struct.pack("<IH", 2, 1) + data[10:])


def test_text_only_check_still_refuses_bgcode_but_process_accepts_it(tmp_path):
    p = os.path.join(FIX, "cut_default.bgcode")
    with pytest.raises(InputRefused, match="process` and `simulate` read .bgcode"):
        check_input(p)
    assert check_input(p, binary_gcode=True) == "bgcode"
    q = tmp_path / "bad.bgcode"
    q.write_bytes(b"GCDE" + struct.pack("<IH", 1, 7) + b"\0" * 20)
    with pytest.raises(InputRefused, match="unknown checksum type 7"):
        check_input(str(q), binary_gcode=True)


# ----------------------------------------------------------------------------- writer
@pytest.mark.parametrize("path", CUTS, ids=os.path.basename)
def test_writer_round_trip_each_format(tmp_path, path):
    f = bgcode.read(path)
    text = bgcode.gcode_text(f) + b";gcode-opt added line\nG1 X10 Y10 F3000\n"
    data = bgcode.encode_file(f, text)
    g = bgcode.parse(data)
    assert bgcode.gcode_text(g) == text
    assert [b.raw for b in g.blocks if b.type != bgcode.GCODE] == [b.raw for b in f.blocks if b.type != bgcode.GCODE]
    assert g.checksum_type == f.checksum_type and data[:10] == open(path, "rb").read(10)
    comp, enc = f.gcode_blocks()[0].compression, f.gcode_blocks()[0].encoding
    assert {(b.compression, b.encoding) for b in g.gcode_blocks()} == {(comp, 2 if enc == 1 else enc)}
    pybgcode = pytest.importorskip("pybgcode")
    out = tmp_path / "w.bgcode"
    out.write_bytes(data)
    assert text in _libbgcode_text(pybgcode, out, tmp_path)   # Prusa's reader reads ours


def _libbgcode_text(pybgcode, path, tmp_path):
    dst = tmp_path / "lib.gcode"
    fi, fo = pybgcode.open(str(path), "rb"), pybgcode.open(str(dst), "wb")
    try:
        assert pybgcode.from_binary_to_ascii(fi, fo, True) == pybgcode.EResult.Success
    finally:
        pybgcode.close(fi)
        pybgcode.close(fo)
    return dst.read_bytes()


def test_gcode_blocks_hold_whole_lines_of_at_most_64_kib():
    text = b"".join(b"G1 X%d.5 Y%d E0.01\n" % (i, i % 97) for i in range(12000))
    blocks = bgcode.gcode_blocks(text, bgcode.COMP_HEATSHRINK_12_4, bgcode.ENC_MEATPACK_COMMENTS, 1)
    g = bgcode.parse(b"GCDE" + struct.pack("<IH", 1, 1) + b"".join(
        [bgcode._pack_block(t, 0, b"\0\0", b"k=v\n", 1) for t in (3, 4, 2)] + blocks))
    parts = [mp.decode(bgcode.unpack(b)) for b in g.gcode_blocks()]
    assert len(parts) > 3 and b"".join(parts) == text
    assert all(len(x) <= 65536 and x.endswith(b"\n") for x in parts)


# ----------------------------------------------------------------------------- the command
def _decoded(path, tmp_path, name):
    p = tmp_path / name
    p.write_bytes(bgcode.gcode_text(bgcode.read(str(path))))
    return str(p)


def test_process_bgcode_to_another_file(tmp_path, capsys):
    src = tmp_path / "part.bgcode"
    shutil.copy(os.path.join(FIX, "cut_default.bgcode"), src)
    before = src.read_bytes()
    out = tmp_path / "out.bgcode"
    rc = main(["process", str(src), "-o", str(out), "--profile", "prusa-mk3s", "-q", "--json",
               str(tmp_path / "s.json")])
    assert rc == 0 and src.read_bytes() == before
    s = json.loads((tmp_path / "s.json").read_text())
    assert s["strokes"]["retimed"] > 0 and s["input"] == str(src) and s["output"] == str(out)
    assert s["bgcode"]["bytes_after"] == out.stat().st_size
    f, g = bgcode.read(str(src)), bgcode.read(str(out))
    assert [b.raw for b in g.blocks if b.type != bgcode.GCODE] == [b.raw for b in f.blocks if b.type != bgcode.GCODE]
    assert g.thumbnails() == f.thumbnails()
    counts = verify(_decoded(src, tmp_path, "o.gcode"), _decoded(out, tmp_path, "n.gcode"), load_profile("prusa-mk3s"))
    assert counts["blocks"] == s["strokes"]["retimed"]
    pybgcode = pytest.importorskip("pybgcode")
    assert bgcode.gcode_text(g) in _libbgcode_text(pybgcode, out, tmp_path)


def test_process_bgcode_in_place_with_report(tmp_path, capsys):
    src = tmp_path / "part.bgcode"
    shutil.copy(os.path.join(FIX, "cut_deflate_plain.bgcode"), src)
    orig = bgcode.read(str(src))
    rc = main(["process", str(src), "--profile", "prusa-mk3s", "--report", str(tmp_path / "r.html")])
    err = capsys.readouterr().err
    assert rc == 0, err
    assert f"gcode-opt: {src} (prusa-mk3s" in err
    assert (tmp_path / "r.html").stat().st_size > 1000
    g = bgcode.read(str(src))
    assert g.thumbnails() == orig.thumbnails()
    assert b"; gcode-opt begin" in bgcode.gcode_text(g) and b"; gcode-opt begin" not in bgcode.gcode_text(orig)
    assert {(b.compression, b.encoding) for b in g.gcode_blocks()} == {(bgcode.COMP_DEFLATE, bgcode.ENC_NONE)}
    assert sorted(os.listdir(tmp_path)) == ["part.bgcode", "r.html"]


def test_meatpack_without_comments(tmp_path, capsys):
    # encoding 1 drops every comment, ;TYPE: included: an infill-only selection finds nothing
    # and the file keeps its bytes; the default for a comment-less file (every extruding
    # move) re-times it, written back with comments kept
    src = tmp_path / "part.bgcode"
    shutil.copy(os.path.join(FIX, "cut_hs11_meatpack.bgcode"), src)
    before = src.read_bytes()
    assert main(["process", str(src), "--profile", "prusa-mk3s", "--features", "sparse_infill,solid_infill"]) == 0
    assert "stored without comments (MeatPack)" in capsys.readouterr().err
    assert src.read_bytes() == before
    out = tmp_path / "o.bgcode"
    assert main(["process", str(src), "-o", str(out), "--profile", "prusa-mk3s"]) == 0
    assert "no feature comments" in capsys.readouterr().err
    g = bgcode.read(str(out))
    assert {b.encoding for b in g.gcode_blocks()} == {bgcode.ENC_MEATPACK_COMMENTS}
    counts = verify(_decoded(src, tmp_path, "o.gcode"), _decoded(out, tmp_path, "n.gcode"), load_profile("prusa-mk3s"))
    assert counts["blocks"] > 0


def test_unchanged_bgcode_is_copied_byte_for_byte(tmp_path, capsys):
    f = bgcode.read(os.path.join(FIX, "cut_default.bgcode"))
    src = tmp_path / "empty.bgcode"
    src.write_bytes(bgcode.encode_file(f, b"; nothing that moves\nM107\n"))
    out = tmp_path / "out.bgcode"
    assert main(["process", str(src), "-o", str(out), "-q", "--profile", "prusa-mk3s"]) == 0
    assert out.read_bytes() == src.read_bytes()
    assert "unchanged" in capsys.readouterr().err


def test_simulate_bgcode_equals_its_text(tmp_path, capsys):
    path = os.path.join(FIX, "cut_deflate_plain.bgcode")
    text = _decoded(path, tmp_path, "t.gcode")
    assert main(["simulate", path, "--json", "--profile", "prusa-mk3s"]) == 0
    a = json.loads(capsys.readouterr().out)
    assert main(["simulate", text, "--json", "--profile", "prusa-mk3s"]) == 0
    b = json.loads(capsys.readouterr().out)
    assert a == b and a["n_moves"] > 100


def test_gcode_error_names_the_bgcode(tmp_path, capsys):
    f = bgcode.read(os.path.join(FIX, "cut_default.bgcode"))
    src = tmp_path / "bad.bgcode"
    src.write_bytes(bgcode.encode_file(f, b"G90\nM83\nG1 X1 Y1 F1200\nG2 X5 Y5 E1\n"))
    rc = main(["process", str(src), "-q", "--profile", "prusa-mk3s"])
    err = capsys.readouterr().err
    assert rc == 2 and f"{src} (decoded G-code)" in err and "gcode-opt-bgcode-" not in err, err


def test_second_slicer_metadata_block_json_is_kept(tmp_path):
    # libbgcode (2025) may add a second slicer-metadata block, JSON-encoded, after the INI one
    data = open(os.path.join(FIX, "cut_default.bgcode"), "rb").read()
    f = bgcode.parse(data)
    k = max(i for i, b in enumerate(f.blocks) if b.type == bgcode.SLICER_METADATA) + 1
    js = bgcode._pack_block(bgcode.SLICER_METADATA, bgcode.COMP_DEFLATE, struct.pack("<H", bgcode.METADATA_JSON),
                            b'{"printer": {"model": "MK3S"}}', 1)
    with_json = data[:10] + b"".join([b.raw for b in f.blocks[:k]] + [js] + [b.raw for b in f.blocks[k:]])
    g = bgcode.parse(with_json)
    assert bgcode.gcode_text(g) == bgcode.gcode_text(f)
    assert bgcode.unpack(g.blocks[k]) == b'{"printer": {"model": "MK3S"}}'
    assert bgcode.settings(g) == bgcode.settings(f)           # INI settings only
    out = bgcode.encode_file(g, bgcode.gcode_text(g) + b"M107\n")
    assert js in out and bgcode.parse(out).blocks[k].raw == js


def test_as_prusaslicer_runs_a_post_processor_on_binary_output(tmp_path):
    # PrusaSlicer >= 2.7 with binary output hands scripts the .bgcode itself (a ".pp" copy),
    # path last, single-quoted, through sh -c (PostProcessor.cpp); --profile auto reads the
    # printer from the binary file's metadata blocks
    import subprocess
    folder = tmp_path / "my prints ü'q"
    folder.mkdir()
    target = folder / "Part 1.gcode.pp"
    shutil.copy(os.path.join(FIX, "cut_default.bgcode"), target)
    before = target.read_bytes()
    script = f"{sys.executable} -m gcode_opt.cli process"
    quoted = "'" + str(target).replace("'", "'\\''") + "'"
    env = dict(os.environ, SLIC3R_PP_HOST="File", SLIC3R_PP_OUTPUT_NAME=str(folder / "Part 1.bgcode"))
    r = subprocess.run(["/bin/sh", "-c", f"{script} {quoted}"], capture_output=True, text=True, env=env,
                       cwd=os.path.join(HERE, ".."), timeout=300)
    assert r.returncode == 0, r.stderr
    assert "profile prusa-mk3s" in r.stderr and "printer_model = MK3S" in r.stderr
    after = target.read_bytes()
    assert after != before and after[:4] == b"GCDE"
    assert b"; gcode-opt begin" in bgcode.gcode_text(bgcode.read(str(target)))
    assert sorted(os.listdir(folder)) == ["Part 1.gcode.pp"]


def _random_gcode(rnd, n_lines):
    """G-code-like lines with the awkward bits MeatPack meets: tabs, lowercase words, inline
    comments, blank lines, '*' checksums, odd and even lengths, non-ASCII comments."""
    words = ["G1", "G0", "G2", "G3", "G28", "G92", "M204", "M107", "M117", "M73", "T0", "g1", "G1.0"]
    params = "XYZEFIJRSPWHCA"
    out = []
    for _ in range(n_lines):
        r = rnd.random()
        if r < 0.15:
            out.append(rnd.choice([";TYPE:Solid infill", ";WIDTH:0.45", "; comment ü", ";", ";G1 X1"]))
        elif r < 0.2:
            out.append(rnd.choice(["", "   ", "\t", " ;x"]))
        else:
            w = rnd.choice(words)
            ps = [f"{rnd.choice(params)}{rnd.choice(['', '-'])}{rnd.randint(0, 999)}.{rnd.randint(0, 99999)}"
                  for _ in range(rnd.randint(0, 5))]
            sep = rnd.choice([" ", "  ", "\t", ""])
            line = w + "".join(sep + (p.lower() if rnd.random() < 0.1 else p) for p in ps)
            if w == "M117":
                line = "M117 Hello G1 world"
            if rnd.random() < 0.2:
                line += rnd.choice([" ; inline", ";c", " *71"])
            out.append(rnd.choice(["", " "]) + line)
    return "\n".join(out) + "\n"


@pytest.mark.parametrize("seed", range(6))
def test_differential_against_libbgcode_on_random_gcode(tmp_path, seed):
    pybgcode = pytest.importorskip("pybgcode")
    rnd = random.Random(seed)
    head = "; generated by PrusaSlicer 2.7.0 on 2026-01-01 at 00:00:00 UTC\n\n; printer_model = MK4\n"
    tail = ("\n; filament used [mm] = 1.0\n; estimated printing time (normal mode) = 1m 0s\n"
            "; prusaslicer_config = begin\n; printer_model = MK4\n; prusaslicer_config = end\n")
    src = tmp_path / "in.gcode"
    src.write_text(head + _random_gcode(rnd, 3000) + tail, encoding="utf-8")
    case = ["default", "hs11_meatpack"][seed % 2]
    made = tmp_path / "lib.bgcode"
    make_fixtures.convert(src.read_text(encoding="utf-8"), case, str(made))
    f = bgcode.read(str(made))
    ours = bgcode.gcode_text(f)
    lib = _libbgcode_text(pybgcode, made, tmp_path)
    assert len(ours) > 1000 and ours in lib              # our reader on libbgcode's writer
    new = ours + b"G1 X1 Y2 F300\n"
    mine = tmp_path / "ours.bgcode"
    mine.write_bytes(bgcode.encode_file(f, new))
    assert new in _libbgcode_text(pybgcode, mine, tmp_path)   # libbgcode's reader on our writer
    assert mp.decode(mp.encode(ours)) == ours


def test_line_checksum_survives_a_round_trip(tmp_path):
    # libbgcode rewrites '*' checksums into text its own reader cannot give back
    # ("G1 X1*71 ; c" -> "G1 X171*25"); ours packs the decoded line as it is, so re-encoding a
    # decoded file is exact, and libbgcode's reader agrees
    text = b"G1 X171*25\nM105*30\n"
    assert mp.decode(mp.encode(text)) == text
    pybgcode = pytest.importorskip("pybgcode")
    f = bgcode.read(os.path.join(FIX, "cut_default.bgcode"))
    p = tmp_path / "c.bgcode"
    p.write_bytes(bgcode.encode_file(f, text))
    assert text in _libbgcode_text(pybgcode, p, tmp_path)


def test_pure_python_codecs_read_and_write_every_format(monkeypatch):
    # a machine without the optional C binding: the same files, the same texts
    monkeypatch.setattr(hs, "_hs2", None)
    for path in CUTS:
        f = bgcode.read(path)
        text = bgcode.gcode_text(f)
        assert text in ref_text(path)
        assert bgcode.gcode_text(bgcode.parse(bgcode.encode_file(f, text + b"M107\n"))) == text + b"M107\n"


def test_deflate_block_larger_than_its_header_says_is_refused():
    f = bgcode.read(os.path.join(FIX, "cut_deflate_plain.bgcode"))
    b = f.gcode_blocks()[0]
    liar = bgcode.Block(b.type, b.compression, 100, b.compressed_size, b.params, b.data, b.raw, b.offset, b.index)
    with pytest.raises(bgcode.BGCodeError, match="header says 100"):
        bgcode.unpack(liar, "x.bgcode")


@pytest.mark.slow
def test_whole_sample_round_trip(tmp_path):
    # the whole PrusaSlicer sample (two G-code blocks), as libbgcode wrote it (~6 s)
    src = tmp_path / "sample.bgcode"
    shutil.copy(os.path.join(FIX, "sample.bgcode"), src)
    out = tmp_path / "out.bgcode"
    assert main(["process", str(src), "-o", str(out), "-q", "--profile", "prusa-mk3s", "--json",
                 str(tmp_path / "s.json")]) == 0
    s = json.loads((tmp_path / "s.json").read_text())
    f, g = bgcode.read(str(src)), bgcode.read(str(out))
    assert [b.raw for b in g.blocks if b.type != bgcode.GCODE] == [b.raw for b in f.blocks if b.type != bgcode.GCODE]
    text_in = _decoded(src, tmp_path, "o.gcode")
    counts = verify(text_in, _decoded(out, tmp_path, "n.gcode"), load_profile("prusa-mk3s"))
    assert counts["blocks"] == s["strokes"]["retimed"] > 0
    # the binary file's G-code is re-timed as its decoded text is (an independent run of the
    # text path: the same strokes, the same written G-code)
    text_out = tmp_path / "t.gcode"
    assert main(["process", text_in, "-o", str(text_out), "-q", "--profile", "prusa-mk3s", "--json",
                 str(tmp_path / "t.json")]) == 0
    assert json.loads((tmp_path / "t.json").read_text())["strokes"]["retimed"] == s["strokes"]["retimed"]
    assert bgcode.gcode_text(g) == text_out.read_bytes()


def _through_writer(text):
    blocks = bgcode.gcode_blocks(text, bgcode.COMP_NONE, bgcode.ENC_MEATPACK_COMMENTS, 0)
    head = b"GCDE" + struct.pack("<IH", 1, 0)
    meta = [bgcode._pack_block(t, 0, b"\0\0", b"k=v\n", 0) for t in (3, 4, 2)]
    return bgcode.gcode_text(bgcode.parse(head + b"".join(meta + blocks))) if blocks else b""


def test_any_decoded_text_is_written_back_exactly():
    # whatever libbgcode's reader can give (here: our reader on arbitrary text's encoding,
    # including blank lines at block starts, lines starting with '\r', tabs, lowercase), the
    # writer gives back byte for byte: the read-back check of `process` can always hold
    rnd = random.Random(5)
    for _ in range(1500):
        text = bytes(rnd.choice(b"G1 XYZEF;\n\t*.-0123456789abcxeg\r\xc3") for _ in range(rnd.randint(1, 40)))
        decoded = mp.decode(mp.encode(text + b"\n"))
        assert _through_writer(decoded) == decoded, text
    # two blocks whose texts meet at a blank line, and a block starting with one
    assert _through_writer(b"G1 X1\n\nM107\n") == b"G1 X1\n\nM107\n"
    assert _through_writer(b"\nG1 X1\n") == b"\nG1 X1\n"
    assert _through_writer(b"\rZ\n\r\n") == b"\rZ\n\r\n"


def test_output_named_as_the_other_kind_is_said(tmp_path, capsys):
    out = tmp_path / "out.gcode"
    assert main(["process", os.path.join(FIX, "cut_default.bgcode"), "-o", str(out), "--profile", "prusa-mk3s"]) == 0
    assert f"{out}: written as binary G-code" in capsys.readouterr().err
    assert out.read_bytes()[:4] == b"GCDE"
