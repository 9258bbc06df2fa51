"""Runs closed and opened in C (issue 8, round 25): the model's Sim.run_lines, given
strokes.group_lines' kit, does group_lines' commonest other line itself -- a G1 that
continues the open run in everything but its direction closes the run (no stroke, a
K_LINE stroke of one move, or a curve) and opens the next one at itself -- making the
Stroke slot by slot.  pipeline.analyse must still give, bit for bit, what the line-by-line
code gave: every stroke slot (floats by their bit patterns), the model's sums, the feature
tally, the ringing figures.  The reference is test_speed_analyse2_runs' verbatim copy of
that code (commit ddecd40: step() and sim.move() a line, group_lines in Python), not the
code under test.  The C path must be the one compared (most strokes made in C), and its
strokes must share their float objects as the Python ones do (memory: ~50 k strokes)."""
from __future__ import annotations

import math
import os
import random

import pytest

from gcode_opt import features as feat
from gcode_opt import pipeline as pl
from gcode_opt import strokes
from gcode_opt.firmware import simulate as fwsim
from gcode_opt.profile import load_profile
from test_speed_analyse2_runs import COMPILED, _analyse_both, _random_file, _same

SAMPLES = "sample_gcode/"
_CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus/")

pytestmark = pytest.mark.skipif(not COMPILED, reason="the compiled model and reader are not built")


class _Made:
    """Counts the runs Sim.run_lines closed and opened itself (group_lines' fast: the 8th
    item of what it returns), and checks group_lines hands it the kit."""

    def __init__(self, monkeypatch):
        self.reopened = self.calls = 0
        real = pl.group_lines

        def group_lines(*a):
            a = list(a)
            f = a[-2]                      # fast
            if f is not None:
                def counted(*x, _f=f):
                    assert len(x) == 23, "group_lines hands fast its kit and rs"
                    got = _f(*x)
                    self.calls += 1
                    if got:
                        self.reopened += got[7]
                    return got
                a[-2] = counted
            return real(*a)
        monkeypatch.setattr(pl, "group_lines", group_lines)


def _corpus(name):
    path = _CORPUS + name + ".gcode"
    if not os.path.exists(path):
        pytest.skip("corpus not built")
    return path


@pytest.mark.parametrize("name,prof", [("plate_rectilinear", "prusa-mk3s"), ("plate_gyroid", "prusa-mk3s")])
def test_plates_strokes_made_in_c_are_the_reference(monkeypatch, name, prof):
    """The issue's plates: most strokes are made in C, every slot is the reference's."""
    made = _Made(monkeypatch)
    got = _same(_corpus(name), prof, ringing=False)
    assert made.reopened > len(got) // 2, (made.reopened, len(got))


@pytest.mark.parametrize("kw", [dict(), dict(max_turn_deg=0.0), dict(min_length_d=0.0), dict(min_length_d=3.0),
                                dict(features=feat.ALL), dict(max_turn_deg=10.0, min_length_d=1.0)])
@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "prusa-mk3s"),
                                       ("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"),
                                       ("prusa_klipper.gcode", "voron24"), ("cura_box.gcode", "ender3"),
                                       ("prusa_gyroid_arcs.gcode", "generic-klipper")])
def test_samples_other_options_are_the_reference(monkeypatch, name, prof, kw):
    """Without curves every closed run is a line or none; a long min_length_d drops most;
    every feature selected puts travels into runs (E 0, the travel acceleration)."""
    made = _Made(monkeypatch)
    _same(SAMPLES + name, prof, **kw)
    assert made.calls > 0


def test_sample_gyroid_most_strokes_made_in_c(monkeypatch):
    made = _Made(monkeypatch)
    got = _same(SAMPLES + "prusa_gyroid.gcode", "prusa-mk3s")
    assert made.reopened > len(got) // 3, (made.reopened, len(got))


@pytest.mark.parametrize("seed", range(6))
def test_random_files_are_the_reference(tmp_path, monkeypatch, seed):
    """Runs that turn, reverse, cross chunks, end at comments, M204, feed changes, ..."""
    made = _Made(monkeypatch)
    f = tmp_path / f"random{seed}.gcode"
    f.write_text(_random_file(random.Random(1000 + seed), 6000))
    prof = ["prusa-mk3s", "voron24", "ender3"][seed % 3]
    kw = [dict(), dict(features=feat.ALL), dict(max_turn_deg=0.0)][seed // 2 % 3]
    _same(str(f), prof, **kw)
    assert made.calls > 0


def _drifting_runs(rng, n_runs):
    """Straight runs whose direction drifts by less than the collinear tolerance a move but
    more than it along the run (strokes split into straight parts), some of moves shorter
    than min_length_d, each run ended by a sharp turn (the line that opens the next run)."""
    out = ["M83", ";TYPE:Internal infill", "G1 F3000"]
    x, y, th = 10.0, 10.0, 0.0
    for _ in range(n_runs):
        th += rng.choice([1.2, -1.5, 2.0, 3.1])           # radians: past any curve limit
        step = rng.choice([0.0004, 0.0008, 0.0015])      # drift a move (|sin| ~ step)
        for _ in range(rng.randint(1, 9)):
            th += rng.choice([step, -step, step])
            d = rng.choice([0.05, 0.3, 1.0, 2.5, 6.0])
            x = min(max(x + d * math.cos(th), -200.0), 200.0)
            y = min(max(y + d * math.sin(th), -200.0), 200.0)
            out.append(f"G1 X{x:.4f} Y{y:.4f} E{rng.choice([0.01, 0.02, 0.05]) * d:.5f}")
        if rng.random() < 0.05:
            out.append(rng.choice([";a comment", "G1 F3000", "M204 S1000", "G1 Z0.4", "G1 Z0.2"]))
    return "\n".join(out) + "\n"


@pytest.mark.parametrize("kw", [dict(), dict(max_turn_deg=0.0), dict(min_length_d=0.0), dict(min_length_d=2.0)])
def test_straight_parts_made_in_c_are_the_reference(tmp_path, monkeypatch, kw):
    """Runs that are not curves but split into parts (run_parts: prev_u / next_u of the
    parts, their start E sums, the short ones dropped and the last kept given the run's
    next_u)."""
    made = _Made(monkeypatch)
    f = tmp_path / "drift.gcode"
    f.write_text(_drifting_runs(random.Random(7), 3000))
    got = _same(str(f), "prusa-mk3s", **kw)
    assert made.reopened > 2000, made.reopened
    assert sum(1 for st in got if st.n_moves > 1) > 300


def _float_objects(strokes_):
    """The distinct float objects the strokes hold (what they cost in memory, beside themselves)."""
    ids = set()
    for st in strokes_:
        for n in strokes.Stroke.__slots__:
            v = getattr(st, n)
            if type(v) is float:
                ids.add(id(v))
    return len(ids)


def test_strokes_share_floats_as_the_reference():
    """A stroke's next_u is the next run's ux, uy; a run's prev_u the last move's direction;
    v0 ... int_v2 one 0.0; Z the run's: the C strokes hold no more float objects than the
    line-by-line ones (~50 bytes a stroke more on the plates otherwise)."""
    path = SAMPLES + "prusa_gyroid.gcode"
    (s1, _, _), (s2, _, _) = _analyse_both(path, "prusa-mk3s", ringing=False)
    for a, b in ((s1, s2), (s1[:-1], s2[:-1])):
        assert len(a) == len(b)
    n1, n2 = _float_objects(s1), _float_objects(s2)
    assert n2 <= n1 * 1.01, (n1, n2)


def test_run_lines_without_kit_opens_no_run():
    """run_lines' 23-argument form (and a kit of None) is the round-24 loop: it stops at the
    line that turns the run, hands nothing over and reports no run opened."""
    from gcode_opt import state as reader
    profile = load_profile("prusa-mk3s")
    lines = ["M83\n", "G1 X1 Y1 E1 F600\n", "G1 X2 Y1 E1\n", "G1 X3 Y1 E1\n", "G1 X3 Y5 E1\n", "G1 X3 Y9 E1\n"]
    for kit in ("none", None):
        st = reader.MachineState(profile)
        log = fwsim._core.RecordLog()
        sim = fwsim.new_sim(profile, log)
        for i in range(2):
            ev = st.step(i, lines[i])
            if ev is not None:
                sim.move(ev)
        m = ev
        cur = [lines, 2, 0]
        run, ends, xy = [m], [1.0], [m.x0, m.y0, m.x1, m.y1]
        args = [cur, st.step, run, ends, xy, m.v, m.accel, m.feature, m.z1, m.e_rel, False, 1.0, 0.0, 1.0, 1.0,
                m.e, False, 0.5, 1e-3, False, None, 1.0, 0.0]
        got = sim.run_lines(*args) if kit == "none" else sim.run_lines(*args, None, [1, 1.0, 0.0, None, None, None])
        assert got[0] == 2 and cur[1] == 4 and len(run) == 3
        assert len(got) == (7 if kit == "none" else 8)
        if kit is None:
            assert got[7] == 0
        sim.stop()


_DUMP = r"""
import pickle, sys
from gcode_opt import pipeline as pl
from gcode_opt.firmware import simulate as fwsim
from gcode_opt.profile import load_profile
from test_speed_analyse import _stroke_bits
o = pl.Options()
o.ringing = False
st, sim = pl.analyse(sys.argv[1], load_profile("prusa-mk3s"), o)
pickle.dump((fwsim.CORE, [_stroke_bits(s) for s in st]), sys.stdout.buffer)
"""


def test_pure_python_path_gives_the_same_strokes():
    """GCODE_OPT_PURE_PYTHON=1 (no compiled model or reader: group_lines reads every line,
    no kit) gives the strokes of the C path, bit for bit."""
    import pickle
    import subprocess
    import sys
    from test_speed_analyse import _stroke_bits
    path = SAMPLES + "prusa_gyroid.gcode"
    o = pl.Options()
    o.ringing = False
    here, _ = pl.analyse(path, load_profile("prusa-mk3s"), o)
    env = dict(os.environ, GCODE_OPT_PURE_PYTHON="1",
               PYTHONPATH=os.pathsep.join([os.getcwd(), os.path.dirname(__file__)]))
    out = subprocess.run([sys.executable, "-c", _DUMP, path], env=env, capture_output=True, check=True).stdout
    core, there = pickle.loads(out)
    assert core == "python" and fwsim.CORE == "c"
    assert there == [_stroke_bits(s) for s in here]
