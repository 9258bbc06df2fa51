"""analyse's reading and the compiled run loop (issue 8, round 30), same bits:

- the compiled model's run_lines / gap_lines compute math.hypot's length in C (c_hypot:
  CPython's algorithm, no Python call a line) where a check against the real math.hypot
  passed: its bits must be math.hypot's on random pairs of every kind and on the corpus'
  moves;
- analyse reads the file with state.line_chunks (the compiled reader's split_lines on bytes
  blocks, no TextIOWrapper): the same lines, in the same order, as simulate.read_chunks
  (open_text's UTF-8 with surrogateescape, "\\n" / "\\r\\n" / lone "\\r" endings kept) on
  the corpus and on random bytes (endings at block edges, bad UTF-8), at any block size;
- every stroke field (floats by their bit patterns), the model's sums and the feature
  tally of analyse stay the reference's: test_speed_analyse2_runs' verbatim copy of the
  line-by-line code (Python's math.hypot, readlines) on the corpus plates, and the
  pure-Python path (GCODE_OPT_PURE_PYTHON=1, a subprocess) on a corpus file."""
from __future__ import annotations

import math
import os
import pickle
import random
import struct
import subprocess
import sys

import pytest

from gcode_opt import state
from gcode_opt.firmware import simulate as fwsim
from test_speed_analyse import _stroke_bits
from test_speed_analyse2_runs import COMPILED, _same

_CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus/")
_TOP = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _corpus(name):
    path = _CORPUS + name + ".gcode"
    if not os.path.exists(path):
        pytest.skip("corpus not built")
    return path


def _b(x):
    return struct.pack("<d", x)


# ---------------------------------------------------------------- c_hypot
needs_core = pytest.mark.skipif(fwsim.CORE != "c" or not hasattr(fwsim._core, "hypot"),
                                reason="the compiled model is not built")


@needs_core
def test_c_hypot_is_math_hypot_random():
    h = fwsim._core.hypot
    assert h() is True, "run_lines must use the C length (its check against math.hypot failed)"
    rng = random.Random(30)
    special = [0.0, -0.0, math.inf, -math.inf, math.nan, 5e-324, 1e-310, 2.2250738585072014e-308, 1e308,
               1.7976931348623157e308, 1.0, 3.0, 4.0, 0.1, 1e-3]
    pairs = [(a, b) for a in special for b in special]
    for i in range(200_000):
        k = i % 5
        if k == 0:          # a slicer's mm deltas
            a = round(rng.uniform(-250, 250), 3)
            pairs.append((a, round(a + rng.uniform(-3, 3), 3) - a))
        elif k == 1:
            pairs.append((rng.uniform(-300, 300), rng.uniform(-300, 300)))
        elif k == 2:        # very different magnitudes
            pairs.append((rng.uniform(-1, 1) * 10 ** rng.uniform(-8, 3), rng.uniform(-1, 1) * 10 ** rng.uniform(-8, 3)))
        elif k == 3:        # the whole range, subnormals included
            pairs.append((rng.uniform(-1, 1) * 10 ** rng.uniform(-320, 308), rng.uniform(-1, 1) * 10 ** rng.uniform(-320, 308)))
        else:               # any bit pattern
            pairs.append(struct.unpack("<2d", rng.getrandbits(128).to_bytes(16, "little")))
    bad = [(a, b) for a, b in pairs
           if _b(h(a, b)) != _b(math.hypot(a, b)) and not (math.isnan(h(a, b)) and math.isnan(math.hypot(a, b)))]
    assert not bad, bad[:5]


@needs_core
def test_c_hypot_is_math_hypot_at_the_bit_path_ends():
    """c_hypot reads frexp's exponent from the bits for a normal max away from both ends of
    the range (else frexp / ldexp): every biased exponent near those ends."""
    h = fwsim._core.hypot
    bad = []
    for be in list(range(0, 80)) + list(range(1970, 2047)):
        for frac in (0, 1, 12345, (1 << 52) - 1):
            m = struct.unpack("<d", struct.pack("<Q", (be << 52) | frac))[0]
            for o in (m, m * 0.3, m * 1e-10, 0.0, m * 0.999, -m):
                if _b(h(m, o)) != _b(math.hypot(m, o)) or _b(h(o, m)) != _b(math.hypot(o, m)):
                    bad.append((m, o))
    assert not bad, bad[:5]


@needs_core
def test_c_hypot_is_math_hypot_corpus_moves():
    """Every XY move of a corpus file (its deltas as the reader computes them)."""
    path = _corpus("plate_gyroid")
    h = fwsim._core.hypot
    st = state.MachineState(__import__("gcode_opt.profile", fromlist=["load_profile"]).load_profile("prusa-mk3s"),
                            path)
    n = bad = 0
    for idx, lines in state.line_chunks(path):
        for i, raw in enumerate(lines):
            ev = st.step(idx + i, raw)
            if type(ev) is state.Move:
                dx, dy = ev.x1 - ev.x0, ev.y1 - ev.y0
                n += 1
                bad += _b(h(dx, dy)) != _b(math.hypot(dx, dy))
    assert n > 200_000 and bad == 0, (n, bad)


# ---------------------------------------------------------------- line_chunks
def _lines(chunks):
    out = []
    for idx0, lines in chunks:
        assert idx0 == len(out) and lines
        out.extend(lines)
    return out


@pytest.mark.parametrize("name", ["plate_rectilinear", "bridges", "bridges_klipper", "no_type_comments"])
def test_line_chunks_are_read_chunks_corpus(name):
    path = _corpus(name)
    got = []
    assert _lines(state.line_chunks(path, got.append)) == _lines(fwsim.read_chunks(path))
    assert sum(got) == os.path.getsize(path)          # (ASCII: characters are bytes)


def test_line_chunks_are_read_chunks_random(tmp_path, monkeypatch):
    rng = random.Random(7)
    alpha = [b"\r", b"\n", b"\r\n", b"a", b"G1 X1.5 Y2", b";c", b"\xc3\xa9", b"\xe2\x82\xac", b"\xff", b"\xe2"]
    texts = [b"", b"a", b"a\n", b"a\r", b"a\r\n", b"\r\n\r\n", b"\r\r\n\n", b"x\ry\r\nz\nw", b"\xef\xbb\xbfG1 X1\n",
             b"\xe2\x82\n\xff\r\xc3\xa9\r\n"]
    texts += [b"".join(rng.choice(alpha) for _ in range(rng.randint(1, 300))) for _ in range(150)]
    texts += [b"".join(rng.choice(alpha[:6]) for _ in range(rng.randint(1, 300))) for _ in range(150)]   # ASCII
    path = str(tmp_path / "t.gcode")
    for block in (1, 2, 7, 64, 1 << 16):
        monkeypatch.setattr(fwsim, "CHUNK_HINT", block)       # (line_chunks' bytes a block)
        for t in texts:
            with open(path, "wb") as fh:
                fh.write(t)
            assert _lines(state.line_chunks(path)) == _lines(fwsim.read_chunks(path)), (block, t)


# ---------------------------------------------------------------- analyse, field by field
@pytest.mark.skipif(not COMPILED, reason="the compiled model and reader are not built")
@pytest.mark.parametrize("name,prof", [("plate_gyroid", "prusa-mk3s"), ("plate_rectilinear", "prusa-mk3s")])
def test_plates_analyse_is_the_reference(name, prof):
    _same(_corpus(name), prof, ringing=False)


_DUMP = r"""
import pickle, sys
from gcode_opt import pipeline as pl
from gcode_opt.profile import load_profile
from test_speed_analyse import _stroke_bits
o = pl.Options()
o.ringing = False
s, res = pl.analyse(sys.argv[1], load_profile(sys.argv[2]), o)
sys.stdout.buffer.write(pickle.dumps(([_stroke_bits(x) for x in s], sorted(o.by_feature.items()))))
"""


@pytest.mark.skipif(not COMPILED, reason="the compiled model and reader are not built")
def test_corpus_analyse_is_the_pure_path():
    """The pure-Python path (its own reader, model and group_lines) in a subprocess."""
    path = _corpus("gyroid_fwretract")
    env = dict(os.environ, GCODE_OPT_PURE_PYTHON="1",
               PYTHONPATH=os.pathsep.join([_TOP, os.path.join(_TOP, "tests")]))
    out = subprocess.run([sys.executable, "-c", _DUMP, path, "prusa-mk3s"], env=env, cwd=_TOP,
                         capture_output=True, check=True).stdout
    pure, pure_feat = pickle.loads(out)
    from gcode_opt import pipeline as pl
    from gcode_opt.profile import load_profile
    o = pl.Options()
    o.ringing = False
    got, _ = pl.analyse(path, load_profile("prusa-mk3s"), o)
    assert len(got) == len(pure) > 1000
    assert [_stroke_bits(x) for x in got] == pure
    assert sorted(o.by_feature.items()) == pure_feat


# ---------------------------------------------------------------- the reader's numbers
@pytest.mark.skipif(state._reader is None, reason="the compiled reader is not built")
def test_reader_number_shapes_are_pythons():
    """read_words scans digits[.digits] in two tight loops, then the general loop goes on
    (a second ".", a sign inside): every shape must read as the Python reader reads it."""
    from test_reader_core_bits import Counter as _Counter, compare_lines
    from gcode_opt.profile import load_profile

    class _MP:                       # (compare_lines' Counter wants a monkeypatch: none here)
        def setattr(self, *a):
            pass
    py_step = _Counter(_MP()).py
    rng = random.Random(30)

    def num():
        parts = [rng.choice(["", "", "-", "+", "--", "+-"])]
        for _ in range(rng.choice([1, 1, 1, 2, 3])):
            parts.append("".join(rng.choice("0123456789") for _ in range(rng.choice([0, 1, 2, 3, 5, 17, 19, 20, 25]))))
            parts.append(rng.choice([".", ".", "", "-", "+", ".."]))
        return "".join(parts[:-1]) if rng.random() < 0.6 else "".join(parts)
    lines = ["G1 X%s Y%s E%s%s\n" % (num(), num(), num(), rng.choice(["", " F%s" % num(), " ;c", "\r"]))
             for _ in range(6000)]
    lines += ["G1 X1.5 Y2.25 E.0312\n", "G1 X00012.50000 Y-0.0\n", "G1 X12345678901234567890.5\n",
              "G1 X9007199254740993\n", "G1 X0.1234567890123456789012\n", "G1 X1..5\n", "G1 X.5.\n"]
    diff = compare_lines(lines, load_profile("prusa-mk3s"), py_step)
    assert diff is None, diff
