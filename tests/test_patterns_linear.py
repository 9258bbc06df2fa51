"""Regular expressions that read a whole line or a file's text must take linear time.

A fuzzed 574 k-digit word hung the word parser (session 50: `words._NUM` backtracked over
every split of the digits).  A sweep of every pattern in the package with long runs of
digits, spaces and letters (session 51) found four more of that kind: the slicer
configuration's `key = value` readers (a value followed by a long run of spaces), the
extended commands' KEY=VALUE reader (a long run of letters without '='), and the report's
block-header numbers.  Each was rewritten to read the same texts in linear time.  Here:
the old and new patterns give the same answers on random texts (hypothesis), and each new
one reads a 200 k-character adversarial text in well under a second of CPU, where the old
took a minute or more (the bound, 5 s, only tells a hang from a run)."""
import re
import time

import pytest
from hypothesis import given, settings
from hypothesis import strategies as hs

from gcode_opt import slicer_config, words
from gcode_opt.report import fences

# the patterns as they were (session 50's main)
OLD_KEY_VALUE = re.compile(r"^;\s*([a-z][a-z0-9_]*)\s*=[ \t]?(.*?)\s*$", re.M)
OLD_CURA_FLAVOR = re.compile(r"^;FLAVOR:(.*?)\s*$", re.M)
OLD_CURA_VALUE = re.compile(r"^\s*([a-z][a-z0-9_]*)\s*=\s*(.*?)\s*$", re.M)
OLD_KEYVAL = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)[ \t]*=[ \t]*(\"[^\"]*\"|'[^']*'|[^ \t\r\n]+)")
OLD_SEGMENTS = re.compile(r"(\d+)\s+segments")
OLD_SUBARCS = re.compile(r"(\d+)\s+sub-arcs")


def _new(p):
    return re.compile(p.pattern, p.flags)


# what a configuration block, a Cura header and a command line hold, and the whitespace that
# `\s` reads but a line end does not (\x85, \xa0, \u2028, \x0c ...)
_CONF = hs.text(alphabet="; \t\r\n=ab_z09.,\"'\x0c\x0b\x85\xa0\u2028é", max_size=40)
_CMD = hs.text(alphabet=" \t\r\n=aZ_09\"'-.,é", max_size=30)
_HEAD = hs.text(alphabet=" \t\n0123456789segmntsub-ar,x", max_size=40)


def _spans(p, text, how):
    if how == "findall":
        return p.findall(text)
    if how == "match":
        m = p.match(text)
    else:
        m = p.search(text)
    return None if m is None else (m.span(), m.groups())


@settings(max_examples=600, deadline=None)
@given(_CONF)
def test_config_patterns_read_what_the_old_ones_read(text):
    for old, new, how in ((OLD_KEY_VALUE, slicer_config._KEY_VALUE, "findall"),
                          (OLD_CURA_FLAVOR, slicer_config._CURA_FLAVOR, "search"),
                          (OLD_CURA_VALUE, slicer_config._CURA_VALUE, "match"),
                          (OLD_CURA_VALUE, slicer_config._CURA_VALUE, "findall")):
        assert _spans(old, text, how) == _spans(_new(new), text, how), (new.pattern, how)
    # and as the reader runs it over a file's tail: "\n;" for "^;"
    assert slicer_config._findall_at_line_starts(OLD_KEY_VALUE)(text) == slicer_config._find_key_values(text)


@settings(max_examples=600, deadline=None)
@given(_CMD)
def test_keyval_pattern_reads_what_the_old_one_read(text):
    assert OLD_KEYVAL.findall(text) == _new(words._KEYVAL).findall(text)


@settings(max_examples=400, deadline=None)
@given(_HEAD)
def test_fence_numbers_read_what_the_old_ones_read(text):
    for old, new in ((OLD_SEGMENTS, fences._SEGMENTS), (OLD_SUBARCS, fences._SUBARCS)):
        assert _spans(old, text, "search") == _spans(new, text, "search")


N = 200_000
CASES = [
    ("key_value", lambda: slicer_config._find_key_values("; key = x" + " " * N + "y\n")),
    ("cura_flavor", lambda: _new(slicer_config._CURA_FLAVOR).search(";FLAVOR:x" + " " * N + "y\n")),
    ("cura_value", lambda: _new(slicer_config._CURA_VALUE).match("key = x" + " " * N + "y")),
    ("keyval", lambda: words.keyvals_of("SET_VELOCITY_LIMIT " + "a" * N)),
    ("keyval_digits", lambda: words.keyvals_of("SET_X " + "1a" * (N // 2))),
    ("segments", lambda: fences._SEGMENTS.search("; gcode-opt begin " + "1" * N + "x")),
    ("subarcs", lambda: fences._SUBARCS.search("1" * N + " sub-arc")),
]


@pytest.mark.parametrize("name,run", CASES, ids=[c[0] for c in CASES])
def test_long_adversarial_text_is_read_in_linear_time(name, run):
    t0 = time.process_time()
    run()
    spent = time.process_time() - t0
    assert spent < 5.0, f"{name}: {spent:.1f} s of CPU on a {N}-character text"
