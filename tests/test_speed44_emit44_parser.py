"""Session 44: main's parser for a command line that starts with `process` is built with
that command alone (cli.build_parser(only_process=True): no other command's parser, no
import of the report package).  Against the whole parser, on command lines that start
with process -- good ones, every option, abbreviations, bad values, unknown options,
missing input, -h, --version after the command: the same namespace, or the same exit
code, stdout and stderr."""
from __future__ import annotations

import contextlib
import io

import pytest

from gcode_opt import cli

ARGVS = [
    ["process", "x.gcode"],
    ["process", "x.gcode", "-o", "y.gcode", "-q"],
    ["process", "x.gcode", "--output=y.gcode", "--profile", "prusa-mk3s", "--alpha", "0.5"],
    ["process", "x.gcode", "--alpha", "auto", "--features", "all", "--overshoot", "25%", "--max-slowdown", "0.05"],
    ["process", "x.gcode", "--corners", "auto", "--segments", "7", "--max-turn", "12.5", "--min-length", "0"],
    ["process", "x.gcode", "--json", "s.json", "--report", "r.html", "--no-ringing", "--profile-time"],
    ["process", "--quiet", "x.gcode", "--seg", "3", "--prof", "voron24"],            # abbreviations
    ["process", "x.gcode", "--features", "sparse_infill,solid_infill"],
    ["process", "x.gcode", "--features", "nonsense"],
    ["process", "x.gcode", "--alpha", "-1"],
    ["process", "x.gcode", "--alpha", "nan"],
    ["process", "x.gcode", "--segments", "0"],
    ["process", "x.gcode", "--max-turn", "90"],
    ["process", "x.gcode", "--min-length", "-1"],
    ["process", "x.gcode", "--overshoot", "abc"],
    ["process", "x.gcode", "--corners", "2"],
    ["process", "x.gcode", "--m", "1"],                                             # ambiguous prefix
    ["process", "x.gcode", "--nope"],
    ["process", "x.gcode", "extra.gcode"],
    ["process"],
    ["process", "-h"],
    ["process", "x.gcode", "--help"],
    ["process", "x.gcode", "--version"],
    ["process", "x.gcode", "-o"],
]


def _parse(argv, only_process):
    out, err = io.StringIO(), io.StringIO()
    code = None
    ns = None
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            ns = vars(cli.build_parser(only_process=only_process).parse_args(list(argv)))
        except SystemExit as e:
            code = e.code
    return ns, code, out.getvalue(), err.getvalue()


@pytest.mark.parametrize("argv", ARGVS, ids=[" ".join(a) for a in ARGVS])
def test_process_parser_is_the_whole_parser(argv):
    whole = _parse(argv, False)
    assert _parse(argv, True) == whole
    assert whole[0] is not None or whole[1] is not None


def test_main_takes_the_process_parser(monkeypatch):
    """main builds the small parser for `process ...` and the whole one otherwise."""
    seen = []
    real = cli.build_parser

    def spy(only_process=False):
        seen.append(only_process)
        return real(only_process)
    monkeypatch.setattr(cli, "build_parser", spy)
    for argv, want in ((["process", "--segments", "0", "x.gcode"], True), (["simulate", "--nope"], False),
                       (["--debug", "process", "--segments", "0", "x.gcode"], True), (["profiles", "-x"], False)):
        with contextlib.redirect_stderr(io.StringIO()), pytest.raises(SystemExit):
            cli.main(argv)
        assert seen.pop() is want, argv
