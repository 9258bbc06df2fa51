"""Round 45 (read45): the firmware model's play path and the reader's run loop.

- play_fused's body specialised for a Marlin planner with the jerk junction
  (CFG_MARLIN_JERK: the configuration's tests constant, set_lim not asked twice): a pass
  through the fused loop (play_buf, the reader's run_ascii, play_fused) against the
  9bb98a8 per-line loop (Move objects: Sim.move, sim_block's CFG_ANY body) on random
  files of every kind of move, under each profile (Marlin jerk, Marlin junction
  deviation with windows down to one block, Klipper): every block's ringing row, the
  per-stroke sums, the SimResult and the reader's state after the pass.
- the reader's run loop (fused_run_ascii: each line's end and ASCII test by 16-byte
  blocks; a one-pass form of it was measured and dropped, these tests kept as its guard):
  the same passes on files whose lines have every length from 1 to 40 bytes, with
  non-ASCII bytes in some (the loop's own steps read those), with blocks of bytes from 16
  bytes up, so that every line end and buffer end falls at every offset of a 16-byte block.
- c_hypot's FMA build (the squares' rounding errors by fma, not Dekker's product):
  math.hypot's bits, and the plain build's, on random pairs of every kind and on ratios
  about the 2^-400 bound where it takes Dekker's product again.
"""
from __future__ import annotations

import math
import os
import random
import struct

import pytest

from gcode_opt import state as st
from gcode_opt.firmware import simulate as fw
from gcode_opt.profile import load_profile

from test_speed40_sim_block_path import PROFILES as BLOCK_PROFILES, _gcode
from test_speed_measure_fused import PROFILES, _Taps
from test_speed_measure_loop import _ref_play, bits, res_bits

pytestmark = pytest.mark.skipif(fw._core is None or st._reader is None or not fw.use_fused(True)
                                or not hasattr(fw._core.Sim, "play_buf"),
                                reason="the compiled firmware core or reader is not built here")

# the fused tests' flavours, session 40's junction laws and Marlin windows (mk3s-lowjerk: a
# jerk law whose Z caps bind), and the MK4's (Marlin 2, jerk)
PROFILES = dict(PROFILES, **{k: (lambda p=p: p) for k, p in BLOCK_PROFILES.items()},
                **{"prusa-mk4": lambda: load_profile("prusa-mk4")})


def _odd_lines(rng, n):
    """Lines of every length from 1 to 40 bytes (its LF included): moves padded with a
    comment, M204s, blank and comment lines, a few with non-ASCII bytes."""
    out = []
    for _ in range(n):
        size = rng.randint(1, 40)
        r = rng.random()
        if r < 0.5 and size >= 12:
            head = f"G1 X{rng.uniform(90, 110):.2f}"[:size - 1]
            line = head if rng.random() < 0.5 else (head + " ;" + "x" * 40)[:size - 1]
        elif r < 0.7 and size >= 8:
            line = ("M204 S" + str(rng.randint(1, 9999)))[:size - 1]
        elif r < 0.9:
            line = (";" + "c" * 40)[:size - 1]
        else:
            line = (";" + "\xe9" * 40)[:max(size - 2, 0)]
        out.append(line + "\n")
    return out


def _write(tmp_path, name, lines):
    path = str(tmp_path / name)
    with open(path, "w", encoding="utf-8", newline="") as fh:
        fh.writelines(lines)
    return path


def _pass(path, profile, block_bytes, monkeypatch, ref):
    """(rows, sums, SimResult bits, final state bits): the 9bb98a8 loop (ref) or play_buf."""
    with open(path, encoding="utf-8", errors="surrogateescape", newline="") as fh:
        lines = fh.readlines()
    taps = _Taps(len(lines), 5)
    state = st.MachineState(profile, path)
    state.warnings = []
    sim = fw.new_sim(profile, taps.sums, taps.sink)
    if ref:
        _ref_play(enumerate(lines), state, sim, None, None)
    else:
        monkeypatch.setattr(fw, "BLOCK_BYTES", block_bytes)
        blocks = fw.Blocks(path)
        fw._play_blocks(blocks, state, sim, None, None)
        assert blocks.n_lines == len(lines)
    sim.stop()
    rows, sums = taps.result()
    return rows, sums, res_bits(sim.res), bits([state.snapshot(), state.warnings])


@pytest.mark.parametrize("prof", sorted(PROFILES))
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_play_random_moves_same_bits(tmp_path, monkeypatch, prof, seed):
    """The fused loop's blocks (play_fused: CFG_MARLIN_JERK under the Marlin jerk
    profiles) against Move objects played by Sim.move (CFG_ANY), on session 40's moves
    (every length and turn, Z moves, E-only moves, dwells, M204, M205)."""
    path = str(tmp_path / "moves.gcode")
    with open(path, "w") as fh:
        fh.write(_gcode(random.Random(seed), 3000))
    profile = PROFILES[prof]()
    ref = _pass(path, profile, 0, monkeypatch, True)
    assert ref[2] != _pass(path, load_profile("voron24" if prof != "voron24" else "prusa-mk3s"), 1 << 16,
                           monkeypatch, False)[2]          # (the profiles differ: a test that can fail)
    for block_bytes in (1 << 16, 777):
        assert _pass(path, profile, block_bytes, monkeypatch, False) == ref, (prof, block_bytes)


@pytest.mark.parametrize("seed", [11, 12])
def test_run_lines_at_every_offset(tmp_path, monkeypatch, seed):
    """run_ascii: every line length, line end and buffer end against the 9bb98a8 loop (a
    line it cannot end in a whole block, or not ASCII: play_loop's steps)."""
    rng = random.Random(seed)
    lines = ["G21\n", "G90\n", "M83\n"] + _odd_lines(rng, 4000)
    path = _write(tmp_path, "odd.gcode", lines)
    profile = load_profile("prusa-mk3s")
    ref = _pass(path, profile, 0, monkeypatch, True)
    for block_bytes in (16, 17, 31, 33, 48, 1000, 1 << 16):
        assert _pass(path, profile, block_bytes, monkeypatch, False) == ref, block_bytes


def test_run_lines_written_file(tmp_path, monkeypatch):
    """A re-timed file's shapes (G1 X Y E F, M204 S, fences) through run_ascii."""
    src = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "sample_gcode",
                       "prusa_gyroid.gcode")
    out = str(tmp_path / "out.gcode")
    from gcode_opt import cli
    assert cli.main(["process", src, "-o", out, "-q"]) in (0, None)
    profile = load_profile("prusa-mk3s")
    ref = _pass(out, profile, 0, monkeypatch, True)
    for block_bytes in (61, 1 << 16):
        assert _pass(out, profile, block_bytes, monkeypatch, False) == ref


# ---------------------------------------------------------------- c_hypot's FMA build
def _b(x):
    return struct.pack("<d", x)


def _pairs(rng, n):
    for _ in range(n):
        k = rng.randrange(6)
        if k == 0:
            yield rng.uniform(-300, 300), rng.uniform(-300, 300)
        elif k == 1:
            yield round(rng.uniform(-250, 250), 3), round(rng.uniform(-250, 250), 3)
        elif k == 2:                   # any bits: subnormals, huge, every exponent
            a, c = (struct.unpack("<d", struct.pack("<Q", rng.getrandbits(63)))[0] for _ in range(2))
            if math.isfinite(a) and math.isfinite(c):
                yield a, c
        elif k == 3:                   # the smaller about 2^-400 of the larger: fma's bound
            a = rng.uniform(0.5, 2.0) * 2.0 ** rng.randint(-600, 600)
            yield a, a * 2.0 ** -rng.uniform(380.0, 420.0)
        elif k == 4:                   # far below it: Dekker's product in both builds
            a = rng.uniform(0.5, 2.0) * 2.0 ** rng.randint(-200, 200)
            yield a, -a * 2.0 ** -rng.uniform(420.0, 600.0)
        else:
            a = 2.0 ** rng.randint(-1074, 1023)
            yield a, rng.choice((0.0, -0.0, a, -a, a * (1 + 2 ** -52), a / 3))


needs_fma = pytest.mark.skipif(fw._core is None or fw._core.hypot(3.0, 4.0, 1) is None,
                               reason="no FMA build of c_hypot on this machine")


@needs_fma
@pytest.mark.parametrize("seed", [21, 22])
def test_hypot_fma_build_is_math_hypot(seed):
    h = fw._core.hypot
    assert h() is True
    bad = []
    for a, c in _pairs(random.Random(seed), 100_000):
        want = _b(math.hypot(a, c))
        for got in (h(a, c, 1), h(c, a, 1), h(a, c, 0), h(a, c)):
            if _b(got) != want:
                bad.append((a, c))
    assert not bad, bad[:5]


@needs_fma
def test_hypot_fma_build_on_corpus_lengths():
    """The G-code lengths run_lines takes (3-decimal coordinates): each build's bits."""
    h = fw._core.hypot
    rng = random.Random(7)
    for _ in range(100_000):
        dx = (rng.randint(-300000, 300000) - rng.randint(-300000, 300000)) / 1000
        dy = (rng.randint(-300000, 300000) - rng.randint(-300000, 300000)) / 1000
        want = _b(math.hypot(dx, dy))
        assert _b(h(dx, dy, 1)) == want and _b(h(dx, dy, 0)) == want, (dx, dy)
