"""cli.build_parser looks each of argparse's messages up once (gettext searched the locale
folders anew for each of its 21 lookups): the same parser, the same help and errors, under
any translation, and argparse's lookup is its own again afterwards."""
import argparse
import collections

import pytest

from gcode_opt import cli


def _helps(ap):
    """The help of the parser and of every subcommand's parser."""
    out = [ap.format_help()]
    for act in ap._actions:
        if isinstance(act, argparse._SubParsersAction):
            out += [(name, p.format_help()) for name, p in act.choices.items()]
    return out


@pytest.mark.parametrize("translate", [lambda m: m, lambda m: m.upper() + " (tr)"])
def test_same_parser_and_one_lookup_a_message(monkeypatch, translate):
    calls = collections.Counter()

    def lookup(message):
        calls[message] += 1
        return translate(message)
    monkeypatch.setattr(argparse, "_", lookup)
    plain = cli._build_parser()                     # the code it replaces: a lookup a use
    n_plain = sum(calls.values())
    calls.clear()
    once = cli.build_parser()
    assert n_plain > len(calls) and max(calls.values()) == 1
    assert argparse._ is lookup                      # restored
    assert _helps(once) == _helps(plain)             # (its help asks argparse._ itself)


def test_parse_and_errors_unchanged(capsys):
    ap = cli.build_parser()
    a = ap.parse_args(["process", "in.gcode", "-o", "out.gcode", "-q", "--segments", "4"])
    assert (a.cmd, a.input, a.output, a.quiet, a.segments) == ("process", "in.gcode", "out.gcode", True, 4)
    with pytest.raises(SystemExit):
        ap.parse_args(["process"])
    err = capsys.readouterr().err
    assert "the following arguments are required: IN.gcode" in err
