"""Round 34 (analyse): slicer_config reads the settings block with "\\n;" patterns.

_findall_at_line_starts(p)(text) must be p.findall(text) for the two multiline "^;" patterns
read over a file's tail (_KEY_VALUE, _CURA_SETTING): on the bundled samples' and the corpus
plates' heads and tails, on hand texts at the edges (a match at the text's start, blank and
CR lines, a key with no value, ";" lines that are not settings) and on random texts of the
characters the patterns care about."""
from __future__ import annotations

import random
from pathlib import Path

import pytest

from gcode_opt import slicer_config as sc

ROOT = Path(__file__).resolve().parent.parent
FILES = sorted((ROOT / "sample_gcode").glob("*.gcode")) + sorted((Path.home() / ".cache" / "gcode-opt-corpus")
                                                                 .glob("*.gcode"))
HAND = ["", ";a=1", "\n;a=1\n", ";a = 1\n;b=2\n\n;c =3 \n", "x;a=1\n;b=2", ";\na=1\n;b=\n\n;c=\r\n",
        ';SETTING_3 {"a":1}\n;SETTING_3 x\r\n', ";a=1\n\n\n;b=2", ";a=\n;b=1", ";  \n  ;a=1\n;\n\nb=2\n",
        ";SETTING_3 \n;SETTING_3", "\r;a=1\r\n;b=2\r"]


def random_texts(n):
    rng = random.Random(34)
    pieces = [";", "\n", "\r", " ", "\t", "a", "b", "_", "1", "=", "S", "SETTING_3 ", ";SETTING_3 ", "x", "\n;"]
    return ["".join(rng.choice(pieces) for _ in range(rng.randint(0, 30))) for _ in range(n)]


def file_texts():
    out = []
    for f in FILES:
        out += list(sc._head_tail(str(f)))
    return out


@pytest.mark.parametrize("pattern", [sc._KEY_VALUE, sc._CURA_SETTING], ids=["key_value", "cura_setting"])
def test_findall_at_line_starts_is_findall(pattern):
    find = sc._findall_at_line_starts(pattern)
    texts = HAND + random_texts(5000) + file_texts()
    for text in texts:
        assert find(text) == pattern.findall(text), repr(text[:80])
    assert sum(len(find(t)) for t in texts) > 100      # (the texts hold matches)


def test_readers_use_them():
    assert sc._find_key_values(";layer_height = 0.2\n") == [("layer_height", "0.2")]
    assert sc._find_cura_settings(";SETTING_3 {x}\r\n") == ["{x}"]
