"""native.source_digest keeps a digest for the process while the source's and its headers'
stat keys stay the same (a run loads the model's core and the writer's core twice each).
A file rewritten, even at the same size, or a header removed must be hashed again."""
import hashlib
import os
import shutil
from pathlib import Path

from gcode_opt import native

PKG = Path(native.__file__).resolve().parent


def _tree(tmp_path):
    (tmp_path / "laws").mkdir()
    src = tmp_path / "laws" / "_chaincore.c"
    shutil.copy(PKG / "laws" / "_chaincore.c", src)
    shutil.copy(PKG / "_npsum.h", tmp_path / "_npsum.h")
    return src, tmp_path / "_npsum.h"


def _want(src, hdr):
    return hashlib.sha256(src.read_bytes() + hdr.read_bytes()).hexdigest()


def test_a_second_call_reads_no_file(tmp_path, monkeypatch):
    src, hdr = _tree(tmp_path)
    d0 = native.source_digest(str(src))
    assert d0 == _want(src, hdr)
    opened = []
    real_open = open
    monkeypatch.setattr("builtins.open", lambda p, *a, **k: opened.append(p) or real_open(p, *a, **k))
    assert native.source_digest(str(src)) == d0
    assert opened == []


def test_same_size_rewrite_of_the_source_or_the_header_is_hashed_again(tmp_path):
    src, hdr = _tree(tmp_path)
    d0 = native.source_digest(str(src))
    for f in (src, hdr):
        b = f.read_bytes()
        st = os.stat(f)
        f.write_bytes(b[:-2] + bytes([b[-2] ^ 1]) + b[-1:])     # one byte flipped, same size
        os.utime(f, ns=(st.st_atime_ns, st.st_mtime_ns))         # even with the old mtime
        got = native.source_digest(str(src))
        assert got == _want(src, hdr) and got != d0
        f.write_bytes(b)
        assert native.source_digest(str(src)) == d0


def test_a_removed_header_is_not_answered_from_the_memo(tmp_path):
    src, hdr = _tree(tmp_path)
    native.source_digest(str(src))
    hdr.unlink()
    try:
        native.source_digest(str(src))
    except OSError:
        pass
    else:
        raise AssertionError("a missing header must fail as before (load() then calls the build stale)")
