"""The module patterns a plate's run never uses (the compiled reader and rewrite read those
lines), compiled at their first use since session 48: the same matches as the module-level
compiles they replace (their code, verbatim, below), the compiled pattern in their place
after a first use, and none of them compiled by the import."""
import re
import subprocess
import sys

import pytest

from gcode_opt import emit, state, validate, words

# name -> re.compile(pattern).method, as the modules had it at import
BOUND = {
    (state, "_fast_m204"): (r"M204(?:[ \t]+[SPTR][-+.0-9]+)*[ \t\r\n]*", "fullmatch"),
    (state, "_fast_match"): (r"G[01](?:[ \t]+[XYZEF][-+.0-9]+)*[ \t\r\n]*", "fullmatch"),
    (emit, "_MOVE_LINES"): (r"\nG1 (?:F([-.0-9]+) )?X([-.0-9]+) Y([-.0-9]+)(?: E([-.0-9]+))?[ \t]*(;[^\r\n]*)?\r?(?=\n)",
                            "findall"),
    (emit, "_MOVE_XYE"): (r"\nG1 (?:F([-.0-9]+) )?X([-.0-9]+) Y([-.0-9]+) E([-.0-9]+)(?=\n)", "findall"),
}
MORE_DECIMALS = {d: (r"\.[0-9]{%d}" % (d + 1), "search") for d in (3, 5)}
PATTERNS = {(validate, "NUM"): r"-?(?:\d+(?:\.\d*)?|\.\d+)\Z", (validate, "WORD"): r"([A-Za-z])(.*)\Z"}

TEXTS = ["G1 X10 Y10 E.5", "G1 X1.5 Y-2 F3000", "G0 X1 Y2 Z3 F60 \r\n", "G1 X1 Y2 ; c", "G2 X1", "M204 S1000",
         "M204 P800 T900\n", "M204 Q1", "\nG1 X10.25 Y3 E0.01\nG1 X1 Y2\nG1 X1 Y2 E1 ;c\r\n", "\nG1 X-.5 Y.5\n",
         "\nG1 F1200 X1 Y2 E3\nG1 X2 Y3 E4\n",
         "1.2345", "1.234567", "12", "-.5", "E.84612", "X", "x1 2", "", "1.2.3", "G1 X1e3 Y2"]


def _same(got, want):
    if isinstance(want, re.Match) or want is None:
        return (None if got is None else (got.span(), got.groups())) == \
               (None if want is None else (want.span(), want.groups()))
    return got == want


CASES = ([(f"{m.__name__}.{n}", vars(m), n, p, meth) for (m, n), (p, meth) in BOUND.items()]
         + [(f"emit._MORE_DECIMALS[{d}]", emit._MORE_DECIMALS, d, p, meth) for d, (p, meth) in MORE_DECIMALS.items()])


@pytest.mark.parametrize("label,table,key,pattern,method", CASES, ids=[c[0] for c in CASES])
def test_bound_methods_match_as_compiled_and_take_their_place(monkeypatch, label, table, key, pattern, method):
    monkeypatch.setitem(table, key, table[key])      # (put back after: the module's own state)
    want = getattr(re.compile(pattern), method)
    for text in TEXTS:
        assert _same(table[key](text), want(text)), (label, text)
    fn = table[key]
    assert fn.__self__.pattern == pattern and fn.__self__.flags == re.compile(pattern).flags and fn.__name__ == method


@pytest.mark.parametrize("module,name", list(PATTERNS), ids=[f"{m.__name__}.{n}" for m, n in PATTERNS])
def test_patterns_match_as_compiled_and_take_their_place(monkeypatch, module, name):
    monkeypatch.setattr(module, name, getattr(module, name))
    ref = re.compile(PATTERNS[module, name])
    p = getattr(module, name)
    for text in TEXTS:
        for meth in ("match", "fullmatch", "search"):
            assert _same(getattr(p, meth)(text), getattr(ref, meth)(text)), (name, meth, text)
    assert isinstance(getattr(module, name), re.Pattern) and getattr(module, name).pattern == ref.pattern


def test_compiled_on_first_call_compiles_once_with_its_flags():
    where = {}
    fn = words.compiled_on_first_call(where, "P", r"([a-z])([0-9]+)", "findall", re.I)
    assert "P" not in where
    assert fn("G1 x10") == [("G", "1"), ("x", "10")]
    assert where["P"].__self__.flags & re.I and where["P"].__name__ == "findall"
    assert fn("M3") == [("M", "3")]                    # the stand-in goes on working


def test_importing_the_modules_compiles_none_of_them():
    code = ("import re\n"
            "from gcode_opt import emit, state, validate\n"
            "names = ['state._fast_m204', 'state._fast_match', 'emit._MOVE_LINES', 'emit._MOVE_XYE',\n"
            "         'validate.NUM', 'validate.WORD']\n"
            "mods = {'state': state, 'emit': emit, 'validate': validate}\n"
            "def made(v):\n"
            "    return type(v) is re.Pattern or type(getattr(v, '__self__', None)) is re.Pattern\n"
            "got = [n for n in names if made(vars(mods[n.split('.')[0]])[n.split('.')[1]])]\n"
            "got += [d for d, f in emit._MORE_DECIMALS.items() if made(f)]\n"
            "print(got)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
