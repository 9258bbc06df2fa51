"""A core is used only if it was built from the C source (and local headers) beside the
Python code.  setup.py records their digest and, beside it, each file's stat key as it
hashed them (native.stat_record, the SOURCE_STAT constant); native.load takes the recorded
digest without hashing while every file keeps that key, and hashes as before otherwise."""
import importlib
import os
import shutil
import sys
import types
from pathlib import Path

import pytest

from gcode_opt import native

PKG = Path(native.__file__).resolve().parent
SOURCES = {
    "_gcode_opt_fwcore": PKG / "firmware" / "_core.c",
    "_gcode_opt_reader": PKG / "_reader.c",
    "_gcode_opt_chaincore": PKG / "laws" / "_chaincore.c",
    "_gcode_opt_emit": PKG / "_emit.c",
    "_gcode_opt_curvecore": PKG / "laws" / "_curvecore.c",
}


@pytest.fixture
def tree(tmp_path):
    """A copy of the chain core's source and its header, laid out as in the package."""
    (tmp_path / "laws").mkdir()
    src = tmp_path / "laws" / "_chaincore.c"
    shutil.copy(SOURCES["_gcode_opt_chaincore"], src)
    shutil.copy(PKG / "_npsum.h", tmp_path / "_npsum.h")
    return src


@pytest.fixture
def fake_core(monkeypatch):
    """make(digest, record): a module as a build would leave it, importable by name."""
    def make(digest, record):
        mod = types.ModuleType("_gcode_opt_fake_core")
        mod.SOURCE_SHA256, mod.SOURCE_STAT = digest, record
        mod.__file__ = "/nowhere/_gcode_opt_fake_core.so"
        monkeypatch.setitem(sys.modules, mod.__name__, mod)
        return mod.__name__
    monkeypatch.delenv("GCODE_OPT_PURE_PYTHON", raising=False)
    return make


def hashes(monkeypatch):
    """A list that gets the source of every source_digest call made after this."""
    calls, real = [], native.source_digest
    monkeypatch.setattr(native, "source_digest", lambda s: calls.append(s) or real(s))
    return calls


def test_record_names_the_digest_then_each_file_with_its_stat(tree):
    native._DIGESTS.pop(str(tree), None)
    rec = native.stat_record(str(tree))
    rows = rec.split(";")
    assert rows[0] == native.source_digest(str(tree))
    assert [r.split("|")[0] for r in rows[1:]] == ["_chaincore.c", "../_npsum.h"]
    for r, path in zip(rows[1:], [tree, tree.parent.parent / "_npsum.h"]):
        st = os.stat(path)
        assert r.split("|")[1:] == [str(st.st_size), str(st.st_mtime_ns), str(st.st_ctime_ns), str(st.st_ino)]
    assert '"' not in rec and "\\" not in rec      # a C string literal in a -D macro as it is


def test_an_unchanged_tree_is_trusted_without_hashing(tree, fake_core, monkeypatch):
    rec = native.stat_record(str(tree))
    name = fake_core(rec.split(";")[0], rec)
    calls = hashes(monkeypatch)
    mod, why = native.load(name, str(tree), "core")
    assert mod is sys.modules[name] and why == "" and calls == []


@pytest.mark.parametrize("which", ["source", "header"])
def test_a_written_file_is_hashed_again_and_a_changed_one_refused(tree, fake_core, monkeypatch, which):
    rec = native.stat_record(str(tree))
    digest = rec.split(";")[0]
    name = fake_core(digest, rec)
    path = tree if which == "source" else tree.parent.parent / "_npsum.h"
    path.write_bytes(path.read_bytes() + b"/* changed */\n")
    native._DIGESTS.pop(str(tree), None)
    calls = hashes(monkeypatch)
    mod, why = native.load(name, str(tree), "core")
    assert calls == [str(tree)] and mod is None and "built from another" in why


def test_a_file_put_back_is_hashed_and_taken(tree, fake_core, monkeypatch):
    # the same bytes under a new inode (a checkout, a copy): hashed, same digest, used
    rec = native.stat_record(str(tree))
    name = fake_core(rec.split(";")[0], rec)
    tmp = tree.with_suffix(".new")
    shutil.copy(tree, tmp)
    os.replace(tmp, tree)
    calls = hashes(monkeypatch)
    mod, why = native.load(name, str(tree), "core")
    assert calls == [str(tree)] and mod is sys.modules[name] and why == ""


def test_a_missing_header_is_refused(tree, fake_core, monkeypatch):
    rec = native.stat_record(str(tree))
    name = fake_core(rec.split(";")[0], rec)
    os.unlink(tree.parent.parent / "_npsum.h")
    native._DIGESTS.pop(str(tree), None)
    mod, why = native.load(name, str(tree), "core")
    assert mod is None and "built from another" in why


def test_a_record_of_another_digest_or_file_is_not_trusted(tree, fake_core, monkeypatch):
    rec = native.stat_record(str(tree))
    digest = rec.split(";")[0]
    # a record made with another digest than the module's (a stale SOURCE_SHA256, as the
    # tests that fake one set it): hashed, refused
    name = fake_core("0" * 64, rec)
    calls = hashes(monkeypatch)
    assert native.load(name, str(tree), "core")[0] is None and calls == [str(tree)]
    # a record whose first file is another source: hashed
    other = tree.parent / "other.c"
    shutil.copy(tree, other)
    name = fake_core(digest, rec)
    calls.clear()
    native._DIGESTS.pop(str(other), None)
    assert native.load(name, str(other), "core")[0] is not None and calls == [str(other)]
    # no record (a core built before SOURCE_STAT): hashed as before
    name = fake_core(digest, "")
    calls.clear()
    assert native.load(name, str(tree), "core")[0] is not None and calls == [str(tree)]


@pytest.mark.parametrize("mod", sorted(SOURCES))
def test_built_cores_record_their_digest_and_files(mod):
    try:
        core = importlib.import_module(mod)
    except ImportError:
        pytest.skip(f"{mod} not built")
    rows = core.SOURCE_STAT.split(";")
    assert rows[0] == core.SOURCE_SHA256
    src = SOURCES[mod]
    want = [src.name] + [os.path.relpath(h, src.parent).replace(os.sep, "/") for h in native.local_headers(str(src))]
    assert [r.split("|")[0] for r in rows[1:]] == want
