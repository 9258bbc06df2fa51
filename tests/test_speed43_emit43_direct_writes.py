"""emit_cols writes a whole move's relative E text (emit.emit_stroke's "0" + t for ".ddd"
not ending in 0, else _canon(t)) straight into the line's room (canon_at), and an accel
line in room made for it at once, not by puts: the compiled emit_stroke's text against
the Python loop's (CORE_MOD None), on strokes whose knots are their vertices (each move's
E word that text) or some between, with E texts of every shape the plain reading takes,
accelerations changing segment by segment (tenths, "0.1") and each flavour's accel word."""
from __future__ import annotations

import random

import numpy as np
import pytest

from gcode_opt import emit

CORE = emit.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None, reason=f"no compiled emit core: {emit.CORE_WHY}")

E_TEXTS = [".5", ".50", ".05", "-.5", "-.50", "0", "-0", "0.000", "-0.000", "000.0100", "12.3400", "-12.34",
           "5.", "-5.", "007", "0.0001000", ".0001", "1.23456789", "-0.00000", "10", "100.", "0.1", "1e5",
           "+.5", "--1", "3.14159265358979"]


def _stroke(rng, n):
    x, y, lines = 10.0, 20.0, []
    for _ in range(n):
        x += rng.choice([0.5, 1.25, 3.0, 0.125])
        y += rng.choice([0.0, 0.375, -1.5])
        e = rng.choice(E_TEXTS)
        word = f" E{e}" if rng.random() < 0.9 else ""
        lines.append(f"G1 X{x:.3f} Y{y:.3f}{word}\n")
    return lines


ACCELS = [0.01, 0.05, 0.1, 0.15, 1500.0, 1500.04, 1234.5678, 3000.0, 99999.99]


def _emit(lines, s, ends_d, accels, flavour):
    st = emit.StrokeText(lines, "10.000", "20.000", 0)
    return emit.emit_stroke(st, ends_d, s, np.full(len(s), 10.0), accels, np.full(len(accels), 30.0),
                            x0_text="10.000", y0_text="20.000", e_rel=True, flavour=flavour,
                            accel_restore=1000.0, mcr_restore=0.5, feed_restore_v=40.0)


def test_canon_at_writes_the_python_loop_s_text(monkeypatch):
    rng = random.Random(43)
    n_canon = 0
    for _ in range(400):
        lines = _stroke(rng, rng.randrange(1, 9))
        pts = [(10.0, 20.0)] + [tuple(float(w[1:]) for w in ln.split()[1:3]) for ln in lines]
        ends_d = np.cumsum([np.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(pts, pts[1:])])
        knots = [0.0] + ends_d.tolist()
        if rng.random() < 0.3:    # some knots between vertices: those moves' E words in units
            knots = sorted(set(knots + [float(rng.uniform(0.0, ends_d[-1])) for _ in range(3)]))
        s = np.asarray(knots)
        accels = np.asarray([rng.choice(ACCELS) for _ in range(len(s) - 1)])
        flavour = rng.choice(["marlin", "marlin-legacy", "klipper", "reprapfirmware"])
        try:
            got = _emit(lines, s, ends_d, accels, flavour)
        except Exception as e:    # noqa: BLE001 -- the Python loop must raise it too
            got = type(e)
        monkeypatch.setattr(emit, "CORE_MOD", None)
        try:
            want = _emit(lines, s, ends_d, accels, flavour)
        except Exception as e:    # noqa: BLE001
            want = type(e)
        monkeypatch.undo()
        assert got == want, (lines, flavour)
        n_canon += isinstance(got, str)
    assert n_canon > 200
