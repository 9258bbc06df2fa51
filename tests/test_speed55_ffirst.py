"""A stroke's lines that name the feed first ("G1 F1200 X.. Y.. E..": Cura opens every run
so) are read by the plain readings (the rewrite core's plain_line / plain_moves and
emit._plain_moves_py) as the general reading (StrokeText._read_lines) reads them: the
F's number checked by float()'s grammar, nothing else read of it.  Before, every such
stroke went through the Python per-block path (a Cura gyroid file: rewrite 0.47 s of
1.12 s)."""
import random

import pytest

from gcode_opt import emit
from gcode_opt.words import WordError

CORE = emit.CORE_MOD


def _general(raws):
    st = emit.StrokeText.__new__(emit.StrokeText)
    xs, ys, es, given = st._read_lines(raws, "1.00000000", "2.00000000")
    return xs, ys, es, given, st.comments


def _lists(rng, n):
    for _ in range(n):
        raws = []
        for k in range(rng.randint(1, 6)):
            f = rng.choice(["", "", "F1200 ", "F.5 ", "F-0 ", "F1500.25 ", "F9000 "]) if k == 0 or rng.random() < 0.1 else ""
            e = rng.choice(["", f" E{rng.uniform(-1, 50):.5f}"])
            c = rng.choice(["", "", " ;c", "\t; x"])
            raws.append(f"G1 {f}X{rng.uniform(-5, 200):.3f} Y{rng.uniform(-5, 200):.3f}{e}{c}\n")
        yield raws


@pytest.mark.parametrize("reader", ["python", "core"])
def test_feed_first_lines_read_as_the_general_reading(reader):
    if reader == "core" and CORE is None:
        pytest.skip("no rewrite core")
    rng = random.Random(55)
    n_f = 0
    for raws in _lists(rng, 2000):
        got = emit._plain_moves_py(raws) if reader == "python" else CORE.plain_moves(raws, "1", "2")
        assert got is not None and got is not NotImplemented, raws
        assert tuple(got[:5]) == _general(raws), raws
        n_f += any(r.startswith("G1 F") for r in raws)
    assert n_f > 500


@pytest.mark.parametrize("reader", ["python", "core"])
@pytest.mark.parametrize("line", ["G1 F1.2.3 X1 Y2 E3\n", "G1 F- X1 Y2\n", "G1 F X1 Y2\n", "G1 F12  X1 Y2\n",
                                  "G1 F12 F13 X1 Y2\n", "G1 FX1 Y2\n"])
def test_odd_feed_words_left_to_the_general_reading(reader, line):
    """An F the plain grammar does not take: no plain reading (None), so the general
    reading says what it makes of it (a WordError for a number float() refuses)."""
    if reader == "core" and CORE is None:
        pytest.skip("no rewrite core")
    raws = ["G1 X0 Y0 E1\n", line]
    got = emit._plain_moves_py(raws) if reader == "python" else CORE.plain_moves(raws, "1", "2")
    assert got is None
    if line.startswith(("G1 F1.2.3", "G1 F- ", "G1 F X")):
        with pytest.raises(WordError):
            _general(raws)
