"""Session 49: the bundled profiles are read without tomllib (profile._plain_toml: the plain
TOML they are written in; tomllib's import and parse cost ~10 M instructions more a run).
Against tomllib itself, on the bundled files, on random documents of that TOML and beyond
it (escapes, dotted and quoted keys, booleans, dates, bad numbers, inline arrays, repeated
keys and tables, control characters, CR ...) and on random edits of the bundled files:
where the plain reader gives a dict, tomllib reads the text to the same dict, the same
types (int / float / str / list / dict) at every level; where tomllib refuses the text,
the plain reader gives None (tomllib reads it then, with its message).  A user's own
profile file is still read by tomllib.  (A process run imports no tomllib:
test_speed49_boot49_startup.py.)"""
from __future__ import annotations

import random
from pathlib import Path

import pytest

from gcode_opt import profile

try:
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parent.parent
BUNDLED = sorted((ROOT / "profiles").glob("*.toml"))


def _same(a, b):
    """a == b with the same types all the way down (1 == 1.0 == True would pass ==)."""
    if type(a) is not type(b):
        return False
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(map(_same, a, b))
    return a == b or (a != a and b != b)


def _check(text):
    """1 where the plain reader read text (and agreed with tomllib), 0 where it left it."""
    got = profile._plain_toml(text)
    try:
        want = tomllib.loads(text)
    except tomllib.TOMLDecodeError:
        assert got is None, repr(text)
        return 0
    if got is None:
        return 0
    assert _same(got, want), repr(text)
    return 1


@pytest.mark.parametrize("path", BUNDLED, ids=[p.name for p in BUNDLED])
def test_every_bundled_profile_is_plain(path):
    text = path.read_text(encoding="utf-8")
    assert profile._plain_toml(text) is not None
    assert _check(text) == 1


# each list: its plain entries first (PLAIN_* of them), then others
KEYS = ["a", "b", "max_accel_a", "x-y", "1", "a.b", '"q"', "a b", "", "é"]
STRINGS = ['"s"', '"a # b"', '""', '"ünï"', '"tab\there"', '"esc\\"q"', '"bs\\\\"', '"ctl\x01"', '"open',
           "'lit'", '"""ml"""', '"x" y', '"del\x7f"']
NUMBERS = ["0", "1", "-1", "+1", "1.5", "-0.0", "1e3", "1E-05", "1.5e+2", "0.0e0", "1#c", "01", "1.", ".5",
           "1e", "1_000", "0x1f", "inf", "nan", "true", "1979-05-27", "12:30:00", "1 2", "--1", "+"]
COMMENTS = ["", " # c", "# c", "\t# tab\there", " #", " # ünï", " # ctl\x02", " # del\x7f", " x"]
NAMES = ["firmware", "limits", "a", "a.b", "", "x y", "[t]"]
PLAIN = {"KEYS": 5, "STRINGS": 4, "NUMBERS": 11, "COMMENTS": 6, "NAMES": 3}


def _pick(rng, name, plain):
    pool = globals()[name]
    return rng.choice(pool[:PLAIN[name]] if plain else pool)


def _value(rng, plain):
    r = rng.random()
    if r < 0.35:
        return _pick(rng, "STRINGS", plain)
    if r < 0.75:
        return _pick(rng, "NUMBERS", plain)
    if r < 0.85 and not plain:
        return rng.choice(['["a", "b"]', "[]", "{a = 1}", "[ 1 ]"])
    items = [rng.choice(STRINGS[:3]) + rng.choice([",", ",", " ,"] + ([""] if not plain else []))
             + rng.choice(COMMENTS[:4]) for _ in range(rng.randrange(4))]
    if not plain and rng.random() < 0.2:
        items.insert(rng.randrange(len(items) + 1), rng.choice(["", "# c", "1,"]))
    close = ["]", " ]", "] # c"] + (["],", "] x", ""] if not plain else [])
    return "[" + rng.choice(COMMENTS[:4]) + "\n" + "\n".join("  " + i for i in items) + "\n" + rng.choice(close)


def _document(rng):
    plain = rng.random() < 0.6               # (plain entries only: mostly read, but for repeats)
    lines = []
    for _ in range(rng.randrange(1, 9)):
        r = rng.random()
        if r < 0.15:
            lines.append(_pick(rng, "COMMENTS", plain).lstrip(" x"))
        elif r < 0.3:
            lines.append(rng.choice(["[", "[ ", "[\t"]) + _pick(rng, "NAMES", plain)
                         + rng.choice(["]", " ]"] + (["", "]]"] if not plain else [])) + _pick(rng, "COMMENTS", plain))
        else:
            lines.append(_pick(rng, "KEYS", plain) + rng.choice([" = ", "=", " =\t"] + ([" "] if not plain else []))
                         + _value(rng, plain) + _pick(rng, "COMMENTS", plain))
    newline = rng.choice(["\n", "\n\n"] + (["\r\n"] if not plain else []))
    return newline.join(lines) + rng.choice(["", "\n"])


def test_random_documents_as_tomllib_reads_them():
    rng = random.Random(49)
    read = sum(_check(_document(rng)) for _ in range(6000))
    assert read > 600                     # (the reader is exercised, not only refused)


def test_random_edits_of_the_bundled_files():
    rng = random.Random(4949)
    texts = [p.read_text(encoding="utf-8") for p in BUNDLED]
    pool = ' "#[]=,.\t\n\r\\x1e-_+\x00\x7fé'
    read = 0
    for _ in range(1500):
        t = rng.choice(texts)
        for _ in range(rng.randrange(1, 3)):
            i = rng.randrange(len(t))
            r = rng.random()
            if r < 0.4:
                t = t[:i] + t[i + 1:]
            elif r < 0.8:
                t = t[:i] + rng.choice(pool) + t[i:]
            else:                           # a line repeated (a repeated key or table)
                lines = t.split("\n")
                j = rng.randrange(len(lines))
                lines.insert(rng.randrange(len(lines)), lines[j])
                t = "\n".join(lines)
        read += _check(t)
    assert read > 100


def test_a_users_profile_file_is_read_by_tomllib(tmp_path, monkeypatch):
    src = BUNDLED[0].read_text(encoding="utf-8")
    (tmp_path / "mine.toml").write_text(src)
    monkeypatch.setattr(profile, "_plain_toml", lambda text: pytest.fail("the plain reader read a user's file"))
    p = profile.load_profile(str(tmp_path / "mine.toml"))
    assert p == profile.profile_from_dict(tomllib.loads(src), "mine", "mine.toml")


def test_a_bundled_profile_it_cannot_read_goes_to_tomllib(monkeypatch):
    """(None from the plain reader: tomllib reads the file, to the same profile)"""
    want = profile.load_profile("prusa-mk3s")
    monkeypatch.setattr(profile, "_plain_toml", lambda text: None)
    assert profile.load_profile("prusa-mk3s") == want

