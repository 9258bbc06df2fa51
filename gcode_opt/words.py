"""Tokenise one G-code line: one strict tokenizer for the reader and the emitter.

A number is ASCII `[-+]?(digits[.digits] | .digits)` and nothing else: no exponent, no
inf/nan, no '_', no non-ASCII digit.  Firmwares disagree on anything looser (`Y2e1` is
Y=20 for a strtod-based parser, Y=2 E=1 for Klipper), so a line we must read that holds
anything else raises `WordError`; the caller names the file and line.  Lines we do not
read (unknown commands) are never parsed.  The raw text is never rebuilt from tokens:
lines we do not re-time are written back byte for byte by the caller.
"""
from __future__ import annotations

import re

# one way to match each number (digits, then an optional fraction): the older
# `[0-9]+\.?[0-9]*` split a run of digits n ways, so a failing match of a long word was
# quadratic (a fuzzed 574 k-digit word hung the reader); same language, linear
_NUM = r"[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)"
_WS = "[ \t\r\n\v\f]"


class LazyPattern:
    """re.compile(pattern, flags), made at its first use: a module's pattern that a run may
    never use (the compiled reader reads most lines) costs no compile (~0.5-2 M
    instructions a pattern, at every start).  At its first use the compiled pattern takes
    this stand-in's place under `name` in the module's globals (`where`), so later uses
    there are the pattern's own; a reference kept elsewhere goes on working through this
    stand-in (re's cache).  .pattern and .flags read without compiling."""
    __slots__ = ("where", "name", "pattern", "flags")

    def __init__(self, where: dict, name: str, pattern, flags: int = 0):
        self.where, self.name, self.pattern, self.flags = where, name, pattern, flags

    def __getattr__(self, attr):
        compiled = re.compile(self.pattern, self.flags)
        self.where[self.name] = compiled
        return getattr(compiled, attr)


def compiled_on_first_call(where: dict, name, pattern, method: str, flags: int = 0):
    """re.compile(pattern, flags).method (a pattern's bound fullmatch, findall, ...), compiled
    at its first call, which puts it in its place: where[name], a module's globals() or a
    table.  LazyPattern's twin for a module that keeps the bound method, not the pattern."""
    def first(*args):
        fn = getattr(re.compile(pattern, flags), method)
        where[name] = fn
        return fn(*args)
    return first


# a classic command's whole code part: command word, then letter+number words (spaces
# optional: "G1X10Y10E.5" is legal), no number followed by what strtod reads as an exponent
_STRICT = LazyPattern(globals(), "_STRICT", rf"{_WS}*[A-Za-z][0-9]+(?:\.[0-9]+)?"
                      rf"(?:{_WS}*[A-Za-z][ \t]*{_NUM}(?![eE][-+]?[0-9]))*{_WS}*")
_LOOSE = LazyPattern(globals(), "_LOOSE", rf"{_WS}*[A-Za-z][0-9]+(?:\.[0-9]+)?(?:{_WS}*[A-Za-z][ \t]*{_NUM})*{_WS}*")
_spaced = re.compile(r"[ \t]*[A-Za-z][0-9]+(?:\.[0-9]+)?(?:[ \t]+[A-Za-z][-+.0-9]+)*[ \t\r\n]*").fullmatch
_EXP_AT = LazyPattern(globals(), "_EXP_AT", r"[eE]([-+]?[0-9]+)")
_WORD = LazyPattern(globals(), "_WORD", rf"([A-Za-z])[ \t]*({_NUM})")
# a key starts at the first letter of a run of [A-Za-z0-9_] (its leading digits skipped):
# tried from every character of the run, a long run without '=' was quadratic
_KEYVAL = LazyPattern(globals(), "_KEYVAL",
                      r"(?<![A-Za-z0-9_])[0-9]*([A-Za-z_][A-Za-z0-9_]*)[ \t]*=[ \t]*(\"[^\"]*\"|'[^']*'|[^ \t\r\n]+)")
_NUM_ONLY = LazyPattern(globals(), "_NUM_ONLY", _NUM)
_LINE_NUMBER = LazyPattern(globals(), "_LINE_NUMBER", rf"{_WS}*[Nn][0-9]+{_WS}*")
_CLASSIC = re.compile(r"([A-Za-z])[ \t]*([0-9]+(?:\.[0-9]+)?)")
_DIGITS = frozenset("0123456789")
# a classic word's letter (not str.isalpha: 'é'): string.ascii_letters, spelled out (the string
# module's import, its Template class compiling a pattern, was ~2.5 M instructions of each run)
_LETTERS = frozenset("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ")
# a number followed by what strtod reads as an exponent: searched for, so only its last
# digit (and an optional '.') matters; `{_NUM}[eE]...` searched from every digit (cubic)
_EXPONENT = LazyPattern(globals(), "_EXPONENT", r"[0-9]\.?[eE][-+]?[0-9]")


def shown(text: str, limit: int = 160) -> str:
    """repr(text) for an error message, cut to its first `limit` characters and its length
    when longer: a message that quotes a 574 k-character line is no message."""
    if len(text) <= limit:
        return repr(text)
    return f"{text[:limit]!r}... ({len(text)} characters)"


class WordError(ValueError):
    """A line whose words cannot be read unambiguously; str is the reason."""


def split_comment(raw: str) -> tuple[str, str]:
    """Return (code, comment) where comment keeps its leading ';' (or '' if none)."""
    i = raw.find(";")
    if i < 0:
        return raw, ""
    return raw[:i], raw[i:]


def strip_checksum(code: str) -> tuple[str, bool]:
    """Drop 'N123 ' and '*45'.  Returns (code, had_line_number_or_checksum)."""
    had = False
    if code.lstrip()[:1] in ("N", "n"):
        m = _LINE_NUMBER.match(code)
        if m:
            code = code[m.end():]
            had = True
    star = code.find("*")
    if star >= 0:
        code = code[:star]
        had = True
    return code, had


def command_of(code: str) -> str:
    """'G1', 'M204', 'M862.3', 'T0' for classic words (Klipper's rule: a letter then an
    ASCII digit); the upper-cased first token for extended commands ('SET_VELOCITY_LIMIT');
    '' for an empty line.  'G01' is normalised to 'G1'."""
    s = code.lstrip()
    if not s:
        return ""
    if s[0] in _LETTERS and s[1:2] in _DIGITS:
        m = _CLASSIC.match(s)
        whole, _, frac = m.group(2).partition(".")
        return s[0].upper() + str(int(whole)) + ("." + frac if frac else "")
    return s.split(None, 1)[0].upper()


def command_text(code: str) -> str:
    """The command word as written, upper-cased ('G01' stays 'G01'): Klipper looks its
    handler up by this text, so 'G01' is an unknown command there."""
    s = code.lstrip()
    m = _CLASSIC.match(s)
    if m is None or s[1:2] not in _DIGITS:
        return command_of(code)
    return s[0].upper() + m.group(2)


def _why(code: str) -> str:
    """The reason a classic command's code part failed _STRICT (for the error message)."""
    if not code.isascii():
        bad = next(c for c in code if not c.isascii())
        if 0xDC80 <= ord(bad) <= 0xDCFF:      # a byte that is not UTF-8, kept by surrogateescape
            return f"byte 0x{ord(bad) - 0xDC00:02x} that is not UTF-8 text"
        return f"non-ASCII character {bad!r}"
    s = code.lstrip()
    m = _CLASSIC.match(s)
    tokens = s[m.end() if m else 0:].split()
    for tok in tokens:
        if _EXPONENT.search(tok):
            return f"number with an exponent in {shown(tok)} (firmwares read it differently)"
    for tok in tokens:
        low = tok.lower()
        if "inf" in low or "nan" in low:
            return f"non-finite number {shown(tok)}"
    for tok in tokens:
        rest = tok
        while rest:
            m = _WORD.match(rest)
            if m is None:
                if rest[0].isalpha() and (len(rest) == 1 or rest[1].isalpha()):
                    return f"parameter {rest[0].upper()} without a number in {shown(tok)}"
                return f"unreadable parameter {shown(tok)}"
            rest = rest[m.end():]
    return "unreadable parameters"


def _refuse_exponents(code: str) -> None:
    """'Y2e1' is Y=2 E=1 for Klipper and Marlin 2 but Y=20 for a strtod reader
    (Prusa-Firmware): refused, unless both readings agree (mantissa or exponent 0, as in
    the compact 'J0e0.587' = J0 E0.587)."""
    for m in _WORD.finditer(code):
        x = _EXP_AT.match(code, m.end())
        if x is not None and float(m.group(2)) != 0.0 and int(x.group(1)) != 0:
            raise WordError(f"number with an exponent {shown(m.group(0) + x.group(0))} (firmwares read it "
                            "differently: write the E word apart)")


def _text(num: str) -> str:
    float(num)                 # ValueError unless the text is a number ("1.2.3", "1-2", ".")
    return num


def _words(code: str, conv) -> dict:
    """{LETTER: conv(number text)} of every parameter after the command word; WordError if
    the code part is not strictly letter+number words or names a parameter twice (Klipper
    keeps the last, Marlin the first).  A leading BOM is the file's encoding mark (the
    reader drops it on line 1 only)."""
    if code[:1] == "\ufeff":
        code = code[1:]
    if _spaced(code) is not None:
        # the usual spaced words: split them; a number text here holds only "+-.0-9", where
        # float() accepts exactly the strict grammar
        toks = code.split()
        try:
            if conv is _text:          # _text inlined: float() only checks the text
                out = {t[0].upper(): t[1:] for t in toks[1:] if float(t[1:]) or True}
            else:
                out = {t[0].upper(): conv(t[1:]) for t in toks[1:]}
        except ValueError:
            raise WordError(_why(code)) from None
        n = len(toks) - 1
    else:
        if _STRICT.fullmatch(code) is None:
            if _LOOSE.fullmatch(code) is None:
                raise WordError(_why(code))
            _refuse_exponents(code)
        found = _WORD.findall(code)[1:]
        out = {letter.upper(): conv(num) for letter, num in found}
        n = len(found)
    if len(out) != n:                      # a letter twice: name it
        letters = [letter.upper() for letter, _ in _WORD.findall(code)[1:]]
        twice = next(c for i, c in enumerate(letters) if c in letters[:i])
        raise WordError(f"parameter {twice} given twice")
    return out


def param_texts(code: str) -> dict[str, str]:
    """Letter parameters of a classic command as the number's text (to copy a value
    without re-rounding), letters upper-cased, the command word itself skipped."""
    return _words(code, _text)


def params_of(code: str) -> dict[str, float]:
    """Letter parameters of a classic command as floats (finite unless the text has
    more than 308 digits: the caller checks ranges)."""
    return _words(code, float)


def keyvals_of(code: str) -> dict[str, str]:
    """KEY=VALUE parameters of an extended command, keys upper-cased, quotes removed."""
    return {k.upper(): v.strip("\"'") for k, v in _KEYVAL.findall(code)}


def strict_number(text: str) -> float:
    """A KEY=VALUE value as a float, by the same number grammar; WordError otherwise."""
    if _NUM_ONLY.fullmatch(text) is None:
        raise WordError(f"unreadable number {shown(text)}")
    return float(text)


def decimals(num_text: str) -> int:
    """Digits after the decimal point in a number's text ('1.250' -> 3, '12' -> 0)."""
    i = num_text.find(".")
    return 0 if i < 0 else len(num_text) - i - 1
