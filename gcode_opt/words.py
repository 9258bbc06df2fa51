"""Tokenise one G-code line.

Fast path first: a slicer file is ~95 % G0/G1 lines, so the split is a single regex
scan over the code part; unknown commands are named but their parameters are not parsed
until somebody asks.  The raw text is never rebuilt from tokens: lines we do not
re-time are written back byte for byte by the caller.
"""
from __future__ import annotations

import re

# letter + number, spaces optional ("G1X10Y10E.5" is legal and common in hand edits)
_WORD = re.compile(r"([A-Za-z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")
_KEYVAL = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)\s*=\s*(\"[^\"]*\"|'[^']*'|\S+)")
_LINE_NUMBER = re.compile(r"^\s*[Nn]\d+\s*")
_CLASSIC = re.compile(r"^([A-Za-z])\s*(\d+(?:\.\d+)?)")


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
    """'G1', 'M204', 'M862.3', 'T0' for classic words (Klipper's rule: a letter then a
    digit); the upper-cased first token for extended commands ('SET_VELOCITY_LIMIT');
    '' for an empty line.  'G01' is normalised to 'G1'."""
    s = code.lstrip()
    if not s:
        return ""
    if s[0].isalpha() and s[1:2].isdigit():
        m = _CLASSIC.match(s)
        whole, _, frac = m.group(2).partition(".")
        return s[0].upper() + str(int(whole)) + ("." + frac if frac else "")
    return s.split(None, 1)[0].upper()


def param_texts(code: str) -> dict[str, str]:
    """Letter parameters of a classic command as the number's text (to copy a value
    without re-rounding), letters upper-cased, the command word itself skipped."""
    return {letter.upper(): num for letter, num in _WORD.findall(code)[1:]}


def params_of(code: str) -> dict[str, float]:
    """Letter parameters of a classic command as floats."""
    return {letter.upper(): float(num) for letter, num in _WORD.findall(code)[1:]}


def keyvals_of(code: str) -> dict[str, str]:
    """KEY=VALUE parameters of an extended command, keys upper-cased."""
    return {k.upper(): v.strip("\"'") for k, v in _KEYVAL.findall(code)}


def decimals(num_text: str) -> int:
    """Digits after the decimal point in a number's text ('1.250' -> 3, '12' -> 0)."""
    i = num_text.find(".")
    return 0 if i < 0 else len(num_text) - i - 1
