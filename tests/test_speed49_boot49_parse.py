"""Session 49: a plain process command line is read without argparse (cli._plain_process;
argparse's import, the parser's build and its parse were ~17 M instructions of each run).
Against the argparse process parser the code used before (cli._argparser(True), built from
the same option list), on many command lines -- plain ones, and abbreviations, --opt=value,
bad and missing values, flags, '--', -h, a missing or second input: the plain reader gives
the same attributes with the same values, or None (argparse parses that line then: its
namespace, or its message and exit).  (A process run imports no argparse:
test_speed49_boot49_startup.py.)"""
from __future__ import annotations

import contextlib
import io
import random
from pathlib import Path

import pytest

from gcode_opt import cli

ROOT = Path(__file__).resolve().parent.parent

PLAIN = [
    ["process", "x.gcode"],
    ["process", "x.gcode", "-o", "y.gcode", "-q"],
    ["process", "-q", "--profile-time", "x.gcode", "--output", "y.gcode", "--profile", "prusa-mk3s"],
    ["process", "x.gcode", "--alpha", "0.5", "--features", "all", "--overshoot", "25%", "--max-slowdown", "0.05"],
    ["process", "x.gcode", "--corners", "auto", "--segments", "7", "--max-turn", "12.5", "--min-length", "0"],
    ["process", "x.gcode", "--json", "s.json", "--report", "r.html", "--no-ringing", "--quiet"],
    ["process", "x.gcode", "--segments", "3", "--segments", "4", "-o", "", "--features", "sparse_infill"],
]

VALUES = ["0.5", "25%", "2", "3", "0", "1e3", "-1", "abc", "auto", "all", "nonsense", "", "-", "nan", "89",
          "90", "y.gcode", "sparse_infill,solid_infill", "0.03", "prusa-mk3s"]
ODD = ["--", "-h", "--help", "--version", "-qo", "--seg", "--prof", "--m", "--nope", "-x", "--output=y.gcode",
       "--alpha=0.5", "-oy.gcode"]


def _argparse(argv, parser):
    """vars of the argparse namespace, or (exit code, stdout, stderr) where it exits."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            return vars(parser.parse_args(list(argv)))
        except SystemExit as e:
            return (e.code, out.getvalue(), err.getvalue())


def _random_lines(n, seed=49):
    rng = random.Random(seed)
    flags = [f for fl, _ in cli.PROCESS_OPTIONS for f in fl]
    for _ in range(n):
        words = ["x.gcode"] * rng.choice((0, 1, 1, 1, 2))
        for _ in range(rng.randrange(6)):
            r = rng.random()
            if r < 0.75:
                words += [rng.choice(flags)] + ([rng.choice(VALUES)] if rng.random() < 0.9 else [])
            elif r < 0.9:
                words.append(rng.choice(ODD))
            else:
                words.append(rng.choice(VALUES))
        if rng.random() < 0.3:
            rng.shuffle(words)
        yield ["process"] + words


@pytest.fixture(scope="module")
def parser():
    return cli._argparser(True)


@pytest.mark.parametrize("argv", PLAIN, ids=[" ".join(a) for a in PLAIN])
def test_a_plain_line_is_read_as_argparse_reads_it(argv, parser):
    got = cli._plain_process(argv)
    assert got is not None
    assert vars(got) == _argparse(argv, parser)
    assert cli.build_parser(only_process=True).parse_args(argv) == got


def test_every_line_the_same_namespace_or_left_to_argparse(parser):
    read = 0
    for argv in _random_lines(1500):
        want = _argparse(argv, parser)
        got = cli._plain_process(argv)
        if got is None:
            continue
        read += 1
        assert isinstance(want, dict), (argv, want)
        assert vars(got) == want, argv
        assert [type(v) for v in vars(got).values()] == [type(want[k]) for k in vars(got)], argv
    assert read > 100            # (the lines it reads: plain ones are common among them)


def test_others_go_to_argparse_with_its_messages(parser, monkeypatch):
    """ProcessLine.parse_args on a line the plain reader does not read: argparse's exit and message."""
    for argv in (["process", "x.gcode", "--segments", "0"], ["process"], ["process", "x", "--m", "1"],
                 ["process", "x", "--seg", "3"]):
        assert cli._plain_process(argv) is None
        assert _argparse(argv, cli.build_parser(only_process=True)) == _argparse(argv, parser)

