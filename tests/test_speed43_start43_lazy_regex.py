"""validate's block patterns are compiled at their first call (most runs never call them:
the compiled core checks the blocks), then stand in their place: the same patterns, the
same matches as the module-level compiles they replace."""
import re

import pytest

from gcode_opt import validate

_N8 = r"(-?(?:\d+(?:\.\d{0,8})?|\.\d{1,8}))"
_C = r"([-.0-9]+)"
# the code it replaces: name -> re.compile(pattern).method at import
REFERENCE = {
    "_M204_PLAIN": (rf"M204 ([A-Za-z]){_N8}", "fullmatch"),
    "_G1_PLAIN": (rf"G1 X{_N8} Y{_N8}(?: E{_N8})? F{_N8}", "fullmatch"),
    "_FAST_MOVES": (rf"\nG1 X{_C} Y{_C}(?: E{_C})? F{_C}(?=\n)", "findall"),
    "_FAST_FEEDS": (rf"\nG1 F{_C}(?=\n)", "findall"),
    "_FAST_MCR": (rf"\nSET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO={_C}(?=\n)", "findall"),
    "_LONG_FRACTION": (r"\.[0-9]{%d}" % (8 + 1), "search"),
    "_OTHER_BREAKS": ("[\r\x0b\x0c\x1c\x1d\x1e\x85\u2028\u2029]", "search"),
}
M204 = {c: (rf"\nM204 {c}{_C}(?=\n)", "findall") for c in "SPT"}

TEXTS = ["M204 S1500", "M204 P800.12345678", "M204 T1.123456789", "G1 X1.5 Y-2 F3000", "G1 X1 Y2 E.5 F60",
         "G1 X1 Y2 E0.123456789 F60", "\nG1 X10.25 Y3 E0.01 F1800\nG1 F900\nM204 S500\nM204 P1\nM204 T2\n"
         "SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO=0.5\n", "a\rb", "x\u2028y", "1.000000001", "12.34567890",
         "\nG1 X-.5 Y.5 F1\n", "G1 X1 Y2", ""]


def _same(got, want):
    if isinstance(want, re.Match) or want is None:
        return (None if got is None else (got.span(), got.groups())) == \
               (None if want is None else (want.span(), want.groups()))
    return got == want


@pytest.mark.parametrize("name", sorted(REFERENCE) + [f"_FAST_M204[{c}]" for c in "SPT"])
def test_same_matches_and_compiled_once(monkeypatch, name):
    if name.startswith("_FAST_M204"):
        c = name[-2]
        table, key, (pattern, method) = validate._FAST_M204, c, M204[c]
        monkeypatch.setitem(table, key, table[key])
    else:
        table, key, (pattern, method) = vars(validate), name, REFERENCE[name]
        monkeypatch.setattr(validate, name, getattr(validate, name))
    want = getattr(re.compile(pattern), method)
    for text in TEXTS:
        assert _same(table[key](text), want(text)), (name, text)
    fn = table[key]                              # after a call: the compiled pattern's own method
    assert fn.__self__.pattern == pattern and fn.__name__ == method


def test_import_compiles_none_of_them():
    import subprocess
    import sys
    code = ("import gcode_opt.validate as v\n"
            "names = [n for n in " + repr(sorted(REFERENCE)) + " if hasattr(getattr(v, n), '__self__')]\n"
            "names += [c for c, f in v._FAST_M204.items() if hasattr(f, '__self__')]\n"
            "print(names)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
