"""The compiled cores share headers (gcode_opt/_npsum.h: numpy's pairwise sum;
gcode_opt/_linestr.h: a line's str as read_lines gives it; gcode_opt/_strokefields.h: the
layout of the firmware core's stroke fields that the rewrite core reads).  A core
built from a source is used only with that same source AND the same headers beside it:
native.source_digest hashes both, setup.py records the same digest, and a changed header
makes the build stale (the Python path plays, and says why), as a changed .c does."""
import hashlib
import importlib
import shutil
from pathlib import Path

import pytest

from gcode_opt import native

PKG = Path(native.__file__).resolve().parent
SOURCES = {                     # module -> the C source it is built from
    "_gcode_opt_fwcore": PKG / "firmware" / "_core.c",
    "_gcode_opt_reader": PKG / "_reader.c",
    "_gcode_opt_chaincore": PKG / "laws" / "_chaincore.c",
    "_gcode_opt_emit": PKG / "_emit.c",
    "_gcode_opt_curvecore": PKG / "laws" / "_curvecore.c",
}
HEADER = PKG / "_npsum.h"
LINESTR = PKG / "_linestr.h"
FIELDS = PKG / "_strokefields.h"


def test_the_three_summing_cores_include_the_shared_header():
    assert native.local_headers(str(SOURCES["_gcode_opt_fwcore"])) == [str(HEADER), str(LINESTR), str(FIELDS)]
    for mod in ("_gcode_opt_chaincore", "_gcode_opt_curvecore"):
        assert native.local_headers(str(SOURCES[mod])) == [str(HEADER)]
    # no core keeps a copy of its own any more
    for src in SOURCES.values():
        text = src.read_text()
        assert "static double ring_pairwise" not in text and "static double pw_sum" not in text
        assert "static double cf_pw_sum" not in text
        assert "static PyObject *line_str" not in text


def test_the_reader_and_the_model_share_line_str():
    # one definition of a line's str for the reader's Lines / split_lines and the model
    assert native.local_headers(str(SOURCES["_gcode_opt_reader"])) == [str(LINESTR)]
    assert "static PyObject *line_str" in LINESTR.read_text()


def test_the_model_and_the_rewrite_share_the_stroke_fields_layout():
    # one StrokeFieldsAPI for the capsule's writer (the firmware core) and its reader (the
    # rewrite core): a copy in each could drift apart, and the reader would misread strokes
    assert native.local_headers(str(SOURCES["_gcode_opt_emit"])) == [str(FIELDS)]
    assert "} StrokeFieldsAPI;" in FIELDS.read_text()
    for src in SOURCES.values():
        assert "} StrokeFieldsAPI;" not in src.read_text()


def test_headers_include_no_local_header():
    # source_digest reads one level of local includes: a header including another would
    # leave that one out of the digest
    for src in SOURCES.values():
        for h in native.local_headers(str(src)):
            assert native.local_headers(h) == [], h


def test_digest_of_a_source_without_headers_is_its_sha256(tmp_path):
    src = tmp_path / "_plain.c"        # (every core includes a shared header now)
    src.write_bytes(b"#include <Python.h>\nstatic int x;\n")
    assert native.local_headers(str(src)) == []
    assert native.source_digest(str(src)) == hashlib.sha256(src.read_bytes()).hexdigest()


def test_digest_covers_the_header(tmp_path):
    (tmp_path / "laws").mkdir()
    src = tmp_path / "laws" / "_chaincore.c"
    shutil.copy(SOURCES["_gcode_opt_chaincore"], src)
    shutil.copy(HEADER, tmp_path / "_npsum.h")
    d0 = native.source_digest(str(src))
    assert d0 == hashlib.sha256(src.read_bytes() + HEADER.read_bytes()).hexdigest()
    (tmp_path / "_npsum.h").write_bytes(HEADER.read_bytes() + b"/* changed */\n")
    assert native.source_digest(str(src)) != d0


@pytest.mark.parametrize("mod", sorted(SOURCES))
def test_built_cores_record_the_digest_and_a_changed_header_is_stale(mod, tmp_path):
    try:
        core = importlib.import_module(mod)
    except ImportError:
        pytest.skip(f"{mod} not built")
    src = SOURCES[mod]
    assert core.SOURCE_SHA256 == native.source_digest(str(src))
    got, why = native.load(mod, str(src), "core")
    if native.pure_python_asked():
        assert got is None
        return
    assert got is core and why == ""
    # the same source beside a changed (or missing) header: not what the core was built from
    rel = src.relative_to(PKG)
    copy = tmp_path / rel
    copy.parent.mkdir(parents=True, exist_ok=True)
    shutil.copy(src, copy)
    for h in native.local_headers(str(src)):
        (tmp_path / Path(h).relative_to(PKG)).write_bytes(Path(h).read_bytes() + b"\n")
    got, why = native.load(mod, str(copy), "core")
    if native.local_headers(str(src)):
        assert got is None and "another" in why
        for h in native.local_headers(str(src)):
            (tmp_path / Path(h).relative_to(PKG)).unlink()
        got, why = native.load(mod, str(copy), "core")
        assert got is None and "another" in why
    else:
        assert got is core

