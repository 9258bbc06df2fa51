"""outfile's temporary files made without tempfile: unnamed_file (plan.write_arrays' spills)
as tempfile.TemporaryFile(dir=, buffering=0) makes them, _mkstemp (AtomicOutput's file) as
tempfile.mkstemp(prefix=, suffix=, dir=) does: the same flags, mode, place and naming."""
import errno
import fcntl
import os
import stat
import tempfile

import numpy as np
import pytest

from gcode_opt import outfile, plan


def _fd_flags(fd):
    return (fcntl.fcntl(fd, fcntl.F_GETFL) & (os.O_ACCMODE | os.O_APPEND),
            fcntl.fcntl(fd, fcntl.F_GETFD) & fcntl.FD_CLOEXEC)


def _file_props(fh):
    st = os.fstat(fh.fileno())
    return type(fh), fh.mode, _fd_flags(fh.fileno()), stat.S_IMODE(st.st_mode), st.st_nlink


def test_unnamed_file_as_temporaryfile(tmp_path):
    ref = tempfile.TemporaryFile(dir=tmp_path, buffering=0)
    new = outfile.unnamed_file(str(tmp_path))
    try:
        assert os.listdir(tmp_path) == []                   # neither has a name there
        assert _file_props(new) == _file_props(ref)
        assert os.fstat(new.fileno()).st_dev == os.stat(tmp_path).st_dev
        for fh in (ref, new):
            fh.write(b"abc" * 1000)
            fh.seek(0)
        assert new.read() == ref.read()
    finally:
        ref.close()
        new.close()


def test_unnamed_file_default_folder(monkeypatch, tmp_path):
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    tempfile.tempdir = None                                 # (tempfile's cached choice)
    try:
        with outfile.unnamed_file() as fh:
            assert os.fstat(fh.fileno()).st_dev == os.stat(tmp_path).st_dev
            assert stat.S_IMODE(os.fstat(fh.fileno()).st_mode) == 0o600
    finally:
        tempfile.tempdir = None


def test_unnamed_file_falls_back_to_tempfile(monkeypatch, tmp_path):
    """Where O_TMPFILE is missing (or refused) tempfile makes the file."""
    made = []
    real = tempfile.TemporaryFile
    monkeypatch.setattr(tempfile, "TemporaryFile", lambda **kw: made.append(kw) or real(**kw))
    real_open = os.open

    def refusing(path, flags, *a, **kw):                    # a filesystem without O_TMPFILE
        if flags & os.O_TMPFILE == os.O_TMPFILE:
            raise OSError(errno.EOPNOTSUPP, "Operation not supported")
        return real_open(path, flags, *a, **kw)
    monkeypatch.setattr(os, "open", refusing)
    with outfile.unnamed_file(str(tmp_path)) as fh:
        fh.write(b"x")
    assert made == [dict(dir=str(tmp_path), buffering=0)]
    assert os.listdir(tmp_path) == []


def test_unnamed_file_missing_folder(tmp_path):
    with pytest.raises(OSError):
        outfile.unnamed_file(str(tmp_path / "missing"))
    assert plan.write_arrays([np.arange(3.0)], str(tmp_path / "missing")) is None


def test_write_arrays_round_trip(tmp_path):
    arrays = [np.arange(12.0).reshape(3, 4), np.asfortranarray(np.arange(6).reshape(2, 3)), np.zeros(0)]
    fh, layout = plan.write_arrays(arrays, str(tmp_path))
    assert os.listdir(tmp_path) == []
    back = plan.read_arrays(fh, layout, "test arrays")
    fh.close()
    for a, b in zip(arrays, back):
        assert a.dtype == b.dtype and a.shape == b.shape and a.strides == b.strides
        assert a.tobytes() == b.tobytes()


def test_mkstemp_as_tempfile(tmp_path):
    fd_r, path_r = tempfile.mkstemp(prefix=outfile.TMP_PREFIX, suffix=outfile.TMP_SUFFIX, dir=str(tmp_path))
    fd_n, path_n = outfile._mkstemp(str(tmp_path))
    try:
        assert _fd_flags(fd_n) == _fd_flags(fd_r)
        st_r, st_n = os.fstat(fd_r), os.fstat(fd_n)
        assert stat.S_IMODE(st_n.st_mode) == stat.S_IMODE(st_r.st_mode) == 0o600
        assert os.path.isabs(path_n) and os.path.dirname(path_n) == os.path.dirname(path_r)
        base_r, base_n = os.path.basename(path_r), os.path.basename(path_n)
        assert len(base_n) == len(base_r)
        name = base_n[len(outfile.TMP_PREFIX):-len(outfile.TMP_SUFFIX)]
        assert base_n.startswith(outfile.TMP_PREFIX) and base_n.endswith(outfile.TMP_SUFFIX)
        assert set(name) <= set(outfile._NAME_CHARS)
        assert (st_n.st_dev, st_n.st_ino) == (os.stat(path_n).st_dev, os.stat(path_n).st_ino)
    finally:
        os.close(fd_r)
        os.close(fd_n)


def test_mkstemp_relative_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    fd, path = outfile._mkstemp(".")
    os.close(fd)
    assert os.path.isabs(path) and os.path.dirname(path) == str(tmp_path)


def test_mkstemp_takes_another_name_where_one_exists(tmp_path, monkeypatch):
    first = bytes(8)                                        # "aaaaaaaa", then another
    draws = iter([first, first, bytes(range(1, 9))])
    monkeypatch.setattr(os, "urandom", lambda n: next(draws))
    taken = tmp_path / (outfile.TMP_PREFIX + "aaaaaaaa" + outfile.TMP_SUFFIX)
    fd0, p0 = outfile._mkstemp(str(tmp_path))
    os.close(fd0)
    assert p0 == str(taken)
    fd1, p1 = outfile._mkstemp(str(tmp_path))
    os.close(fd1)
    assert p1 == str(tmp_path / (outfile.TMP_PREFIX + "bcdefghi" + outfile.TMP_SUFFIX))


def test_mkstemp_gives_up(tmp_path, monkeypatch):
    monkeypatch.setattr(os, "urandom", lambda n: bytes(n))
    fd, _ = outfile._mkstemp(str(tmp_path))
    os.close(fd)
    with pytest.raises(FileExistsError):
        outfile._mkstemp(str(tmp_path), tries=3)


def test_no_tempfile_import_on_the_path(tmp_path):
    """The command's run does not import tempfile (nor shutil, random, bz2, lzma with it)."""
    import subprocess
    import sys
    src = os.path.join(os.path.dirname(__file__), "..", "sample_gcode", "prusa_gyroid.gcode")
    code = ("import sys, runpy; sys.argv = ['gcode_opt', 'process', %r, '-o', %r, '-q'];\n"
            "try:\n    runpy.run_module('gcode_opt', run_name='__main__')\n"
            "except SystemExit:\n    pass\n"
            "print(sorted(m for m in ('tempfile', 'shutil', 'random', 'bz2', 'lzma')"
            " if m in sys.modules))") % (src, str(tmp_path / "out.gcode"))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env=dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path)))
    assert out.stdout.strip().splitlines()[-1] == "[]"
