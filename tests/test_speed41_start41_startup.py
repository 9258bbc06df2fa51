"""Start-up cuts of session 41 against what they replace: the patterns compiled at first use
(words.LazyPattern) are re.compile's, with the same matches; the help formatters' width without
shutil is shutil.get_terminal_size's; outfile.make_temp makes its file as tempfile.mkstemp does;
the dataclasses with a docstring of their own keep their fields and behaviour."""
import dataclasses
import os
import re
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from gcode_opt import cli, detect, outfile, profile, slicer_config, words

ROOT = Path(__file__).resolve().parent.parent

LINES = ["G1 X10 Y10 E.5", "G1X10Y10E.5", "G1 X1e3 Y2", "g1 x-.5 y+3.", "N12 G1 X1*57", "M204 S1000",
         "G1 X10 Y10 E.5 F1800 ; c", "SET_VELOCITY_LIMIT ACCEL=1000 SQUARE_CORNER_VELOCITY=5",
         "G1 X", "T0", "  G28  ", "G1 X1.2.3", "M117 hi=there 'a b'", "", "é1", "N5 M107", "G1 X3E+2",
         "G1 Y-0.000 Z.2", "KEY=\"v w\" k2='x' k3=y", "G1 X10\tY20\r\n"]


def _pattern_names(module):
    return [k for k, v in vars(module).items() if isinstance(v, (words.LazyPattern, re.Pattern))]


@pytest.mark.parametrize("module", [words, slicer_config], ids=["words", "slicer_config"])
def test_lazy_patterns_match_as_compiled(module):
    """Every module pattern (stand-in or compiled): re.compile of its text gives the same
    matches on varied lines, and a first use puts the compiled pattern in the module."""
    for name in _pattern_names(module):
        p = getattr(module, name)
        ref = re.compile(p.pattern, p.flags)
        for text in LINES + ["\n".join(LINES), ";SETTING_3 a=b\\nc=d\n;FLAVOR:Marlin\n; key = val\n"]:
            for meth in ("match", "fullmatch", "search"):
                got, want = getattr(p, meth)(text), getattr(ref, meth)(text)
                assert (got and got.span()) == (want and want.span()), (name, meth, text)
                assert (got and got.groups()) == (want and want.groups())
            assert p.findall(text) == ref.findall(text)
        assert isinstance(getattr(module, name), re.Pattern)      # the compiled one took its place


def test_lazy_pattern_is_compiled_at_first_use_only():
    where = {}
    lp = words.LazyPattern(where, "P", r"([A-Z])([0-9]+)", re.I)
    assert lp.pattern == r"([A-Z])([0-9]+)" and lp.flags == re.I and "P" not in where
    assert lp.findall("g1 x10") == [("g", "1"), ("x", "10")]
    assert isinstance(where["P"], re.Pattern) and where["P"].flags & re.I
    assert lp.match("m3").groups() == ("m", "3")           # the stand-in goes on working


def test_words_parse_as_before_their_patterns_compiled():
    """The tokenizer's answers on varied lines (its errors too) are those of a fresh module
    whose patterns are compiled up front, as before."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("_words_eager", words.__file__)
    eager = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(eager)
    for name in _pattern_names(eager):
        p = getattr(eager, name)
        if isinstance(p, words.LazyPattern) or type(p).__name__ == "LazyPattern":
            setattr(eager, name, re.compile(p.pattern, p.flags))
    assert not [n for n in _pattern_names(eager) if not isinstance(getattr(eager, n), re.Pattern)]

    def answers(mod, text):
        out = []
        for fn in ("params_of", "param_texts", "command_of", "keyvals_of", "strip_checksum", "strict_number"):
            try:
                out.append(repr(getattr(mod, fn)(text)))
            except Exception as e:       # noqa: BLE001 - the error is part of the answer
                out.append(f"{type(e).__name__}: {e}")
        return out
    for text in LINES + ["1.5", "-.5", "+3.", "1e3", "", "N10 G1 X1 Y2*33"]:
        assert answers(words, text) == answers(eager, text), text


@pytest.mark.parametrize("env", [{}, {"COLUMNS": "60"}, {"COLUMNS": "200"}, {"COLUMNS": "0"}, {"COLUMNS": "x"},
                                 {"COLUMNS": " 120 "}])
def test_terminal_columns_is_shutils(env, monkeypatch):
    monkeypatch.delenv("COLUMNS", raising=False)
    monkeypatch.delenv("LINES", raising=False)
    for k, v in env.items():
        monkeypatch.setenv(k, v)
    assert cli._terminal_columns() == shutil.get_terminal_size().columns


@pytest.mark.parametrize("argv", [["-h"], ["process", "-h"], ["simulate", "-h"], ["report", "-h"], ["law", "-h"],
                                  ["process"], ["bogus"], ["process", "x.gcode", "--segments", "0"]])
@pytest.mark.parametrize("columns", ["", "50", "150"])
def test_help_and_errors_as_argparse_writes_them(argv, columns):
    """The command's help and usage errors, word for word, as argparse's own formatters
    (shutil's width) write them."""
    code = ("import argparse, sys\n"
            "from gcode_opt import cli\n"
            "if sys.argv[1] == 'plain':\n"
            "    class P(argparse.ArgumentParser):\n"
            "        error = cli.Parser.error\n"
            "    cli.Parser = P\n"
            "sys.exit(cli.main(sys.argv[2:]))\n")
    env = dict(os.environ, COLUMNS=columns)
    got = [subprocess.run([sys.executable, "-c", code, kind] + argv, cwd=ROOT, env=env, capture_output=True,
                          text=True, timeout=120) for kind in ("ours", "plain")]
    assert got[0].returncode == got[1].returncode
    assert got[0].stdout == got[1].stdout and got[0].stderr == got[1].stderr
    assert len(got[0].stdout + got[0].stderr) > 20


def test_make_temp_as_mkstemp(tmp_path):
    fd, path = outfile.make_temp(str(tmp_path))
    os.close(fd)
    name = os.path.basename(path)
    assert os.path.dirname(path) == str(tmp_path)
    assert re.fullmatch(re.escape(outfile.TMP_PREFIX) + r"[a-z0-9_]{8}" + re.escape(outfile.TMP_SUFFIX), name)
    st = os.stat(path)
    assert stat.S_IMODE(st.st_mode) == 0o600 and st.st_size == 0
    names = {name}
    for _ in range(50):                    # new names, never an existing file
        fd, p = outfile.make_temp(str(tmp_path))
        os.close(fd)
        assert os.path.basename(p) not in names
        names.add(os.path.basename(p))
    # a name that exists is not opened: another is tried
    taken = iter(sorted(names))
    real = os.urandom
    first = []

    def urandom(n):
        if not first:                       # the first try: an existing file's name
            first.append(1)
            return bytes(outfile._NAME_CHARS.index(c) for c in next(taken)[len(outfile.TMP_PREFIX):][:8])
        return real(n)
    os.urandom = urandom
    try:
        fd, p = outfile.make_temp(str(tmp_path))
    finally:
        os.urandom = real
    os.close(fd)
    assert first and os.path.basename(p) not in names
    with pytest.raises(FileNotFoundError):
        outfile.make_temp(str(tmp_path / "no such folder"))


def test_atomic_output_still_works(tmp_path):
    target = tmp_path / "out.gcode"
    target.write_text("old")
    with outfile.AtomicOutput(str(target)) as o:
        assert os.path.basename(o.tmp).startswith(outfile.TMP_PREFIX)
        Path(o.tmp).write_text("new")
        o.commit()
    assert target.read_text() == "new"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(outfile.TMP_PREFIX)]


def test_dataclasses_keep_their_fields_and_behaviour():
    p = profile.load_profile("prusa-mk3s")
    assert [f.name for f in dataclasses.fields(profile.Profile)][:3] == ["name", "flavour", "junction"]
    assert len(dataclasses.fields(profile.Profile)) == 35
    q = dataclasses.replace(p, max_accel_a=1234.0)
    assert q != p and q.max_accel_a == 1234.0 and hash(dataclasses.replace(q, max_accel_a=p.max_accel_a)) == hash(p)
    assert repr(p).startswith("Profile(name='prusa-mk3s', flavour=")
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.name = "x"
    s = slicer_config.SlicerSettings()
    assert s.values == {} and s.slicer == "" and [f.name for f in dataclasses.fields(s)] == \
        ["values", "where", "slicer", "head"]
    assert [f.name for f in dataclasses.fields(detect.AutoProfile)] == ["profile", "base", "why_base", "taken", "notes"]
    for cls in (profile.Profile, slicer_config.SlicerSettings, detect.AutoProfile):
        assert cls.__doc__ and not cls.__doc__.startswith(cls.__name__ + "(")
