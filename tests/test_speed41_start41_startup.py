"""Start-up cuts of session 41 against what they replace: the patterns compiled at first use
(words.LazyPattern) are re.compile's, with the same matches; the dataclasses whose methods are
profile.plain_dataclass's generic ones behave as @dataclass's generated ones."""
import dataclasses
import re

import pytest

from gcode_opt import detect, profile, slicer_config, words

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
