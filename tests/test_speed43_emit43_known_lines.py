"""block_into's check of the lines emit_cols writes from numbers (segment lines and accel
lines) is done as emit_cols writes them, with the values the reading would give
(known_units, plain_line's values, tenths), not by reading them back; set_text_check(True)
makes it read every line, as it did before.  The two must give
the same verdict, so stroke_block the same bytes or None, on every line stroke of real
files and on perturbed ones whose checks land on either side of their limits: the
acceleration bound, the command-length limit, the shortest-move floor, the path tolerance
(a start text off its value), decimals past 8, E sums (relative and absolute E), and
first_cmds' lines (read between the lines emit_cols checks; a segment line among them:
every line read)."""
from __future__ import annotations

import random

import numpy as np
import pytest

from gcode_opt import emit
from gcode_opt.strokes import K_ARC

from test_speed20_rewrite_core import CASES, SAMPLES, _block_args, _perturb, _planned, _stroke_lines

CORE = emit.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "set_text_check"),
                                reason=f"no compiled emit core: {emit.CORE_WHY}")


def _both(args):
    """stroke_block's result with the recorded values, then with every line read."""
    def call():
        try:
            return CORE.stroke_block(*args)
        except (ValueError, TypeError, OverflowError):
            return "raised"
    was = CORE.set_text_check(False)
    try:
        known = call()
        CORE.set_text_check(True)
        read = call()
    finally:
        CORE.set_text_check(was)
    return known, read


def _near_limits(rng, args):
    """args with one check moved next to what the block's lines give: the accel bound, the
    line-length limit, the shortest-move floor, a start text off the start's value, first_cmds'
    lines, or a line's numbers with more decimals."""
    args = list(args)
    r = rng.randrange(8)
    if r == 0:                    # accel_max_a: at, just below or far below the block's accels
        acc = np.asarray(args[14], dtype=float)
        a = float(np.ceil(acc.max() * 10.0 - 1e-9) / 10.0) if acc.size else 1000.0
        args[20] = rng.choice([a, a - 0.1, a - 0.1 - 2e-9, a - 0.05, a * 0.5, 0.05])
    elif r == 1:                  # the command-length limit around the lines' lengths
        ctx = list(args[19])
        ctx[3] = rng.randrange(8, 40)
        args[19] = tuple(ctx)
    elif r == 2:                  # the shortest-move floor
        ctx = list(args[19])
        ctx[4] = rng.choice([1e-4, 1e-3, 0.01, 0.1, 0.5, 2.0])
        args[19] = tuple(ctx)
    elif r == 3:                  # the start's text rounded: its first move's points off the path
        d = rng.choice([0, 1, 2, 3])
        args[8] = f"{args[10] + rng.choice([0.0, 4e-4, 9e-4, -7e-4]):.{d}f}"
        args[9] = f"{args[11]:.{d}f}"
    elif r == 4:                  # the start's value moved a little (its text kept)
        args[10] = args[10] + rng.choice([1e-4, 5e-4, 7.5e-4, 1e-3, 3e-3])
    elif r == 5:                  # both, by about the path tolerances (0.75e-3 for 3 decimals, 2e-3)
        args[10] = args[10] + rng.choice([-1, 1]) * rng.uniform(5e-4, 2.2e-3)
        args[11] = args[11] + rng.choice([-1, 1]) * rng.uniform(5e-4, 2.2e-3)
    elif r == 6:                  # first_cmds' lines around the first move: lines the check reads
        word = args[19][0]
        lines = ["G1 F1200\n", f"{word}500\n", f"{word}99999999\n", "G1 F0\n", "M205 X8\n",
                 f"G1 X{args[10]:.3f} Y{args[11]:.3f} F100\n", f"{word}700\nG1 F300\n"]
        args[6], args[7] = rng.choice(lines), rng.choice(lines)
    else:                         # a line's numbers with trailing zeros: more decimals, the same values
        data = args[0].split(b"\n")
        k = rng.randrange(max(1, len(data) - 1))
        zeros = rng.choice([b"0", b"000", b"00000", b"0000000"])
        word = rng.choice([b" X", b" Y", b" E"])
        parts = data[k].split(word, 1)
        if len(parts) == 2:
            num = parts[1].split(b" ", 1)
            if b"." not in num[0]:
                num[0] += b"."
            num[0] += zeros
            data[k] = parts[0] + word + b" ".join(num)
        args[0] = b"\n".join(data)
        args[2] = len(args[0])
    return tuple(args)


@pytest.mark.parametrize("name,prof_name", CASES[:3])
def test_recorded_values_give_the_reading_s_verdict(name, prof_name):
    prof, opts, strokes, plan = _planned(name, prof_name)
    order = [i for i in np.flatnonzero(plan.retime).tolist() if strokes[i].kind != K_ARC]
    lines = _stroke_lines(SAMPLES + name, strokes, order)
    n_bytes = n_none = 0
    for i in order:
        known, read = _both(_block_args(strokes[i], lines[i], plan.segs[i], plan.beta[i], prof))
        assert known == read, i
        n_bytes += isinstance(known, bytes)
    assert n_bytes >= 0.9 * len(order) > 0
    rng = random.Random(4301 + len(name))
    n_bytes = 0
    for _ in range(3000):
        i = rng.choice(order)
        s2, raws, seg2 = strokes[i], lines[i], plan.segs[i]
        if rng.random() < 0.5:
            s2, raws, seg2 = _perturb(rng, s2, raws, seg2)
        try:
            args = _block_args(s2, raws, seg2, plan.beta[i], prof)
        except ValueError:        # (a start accel the closing text refuses: no block)
            continue
        if rng.random() < 0.7:
            args = _near_limits(rng, args)
        known, read = _both(args)
        assert known == read, (i, raws, args[8:12], args[19:])
        n_bytes += isinstance(known, bytes)
        n_none += known is None
    assert n_bytes > 500 and n_none > 500, (n_bytes, n_none)


def test_text_check_setting_is_restored():
    assert CORE.set_text_check(True) is False
    assert CORE.set_text_check(False) is True
