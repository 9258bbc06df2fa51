"""inputcheck.check_input: what is not ASCII G-code is refused before any work, by name."""
import glob
import os
import random

import pytest

from gcode_opt.inputcheck import HEAD_BYTES, InputRefused, check_input


def refused(path):
    with pytest.raises(InputRefused) as ei:
        check_input(str(path))
    msg = str(ei.value)
    assert msg.startswith(f"{path}: ")
    return msg


def test_prusa_binary_gcode(tmp_path):
    f = tmp_path / "part.bgcode"
    f.write_bytes(b"GCDE\x01\x00\x00\x00\x01\x00" + bytes(range(256)) * 4)
    msg = refused(f)
    assert "Prusa binary G-code (.bgcode)" in msg and "Supports binary G-code" in msg and "bgcode tool" in msg


def test_nul_bytes_random_bytes_and_control_bytes(tmp_path):
    f = tmp_path / "nul.gcode"
    f.write_bytes(b"G1 X1\n" * 100 + b"\x00" + b"G1 X2\n")
    assert "NUL byte at offset 600" in refused(f)
    rnd = random.Random(7)
    g = tmp_path / "random.gcode"
    g.write_bytes(bytes(rnd.choice([b for b in range(256) if b]) for _ in range(5000)))  # no NUL
    assert "not a text file" in refused(g)


def test_directory_missing_empty(tmp_path):
    assert "is a directory" in refused(tmp_path)
    assert "no such file" in refused(tmp_path / "nope.gcode")
    e = tmp_path / "empty.gcode"
    e.write_bytes(b"")
    assert "empty" in refused(e)


@pytest.mark.skipif(os.geteuid() == 0 if hasattr(os, "geteuid") else True,
                    reason="root reads every file: permissions cannot be tested")
def test_unreadable(tmp_path):
    f = tmp_path / "locked.gcode"
    f.write_text("G1 X1\n")
    f.chmod(0)
    assert "cannot read" in refused(f)


def test_text_that_must_pass(tmp_path):
    # Latin-1 comments, a BOM, CRLF, tabs: a few odd bytes never make a G-code file binary
    f = tmp_path / "ok.gcode"
    f.write_bytes(b"\xef\xbb\xbf; caf\xe9 \xb0C\r\nG1\tX1 Y2\r\n" + b"G1 X1 Y2 E0.1 ; \xff\xfe\n" * 200)
    check_input(str(f))
    for path in sorted(glob.glob("sample_gcode/*.gcode") + glob.glob("sample_gcode/edge/*.gcode")):
        check_input(path)


def test_reads_only_the_head(tmp_path):
    # binary garbage after the first 64 KB is not looked at (the reader refuses it by line)
    f = tmp_path / "long.gcode"
    f.write_bytes(b"G1 X1 Y2\n" * (HEAD_BYTES // 9 + 10) + b"\x00" * 100)
    check_input(str(f))
