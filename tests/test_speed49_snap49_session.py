"""The compiled reader's snapshot and its session's kept load (session 49, snap49).

snapshot(state) (MachineState.snapshot with the compiled reader) reads the modal attributes
from the state's dict: against operator.attrgetter (the code it replaced), object for
object, on states a file left along the way; other objects go to the attrgetter.

A session of the fused loop keeps what it read from the state's dict, with the dict's
version tag, past its write-back; a later session takes it while the tag is unchanged
(also after an M204 or a feature comment, read live, and after step()'s own G0/G1, which
moves what was kept on); snapshot() takes the modal objects kept with it.  Against the reference where no session reads a line (the fused
loop off: step() reads every line from the dict): the file played to each stop, the state
changed there in Python at random (attributes set, lines given to step()), the snapshots at
every stop, the model's sums and the last state to the bit.
"""
from __future__ import annotations

import os
import random

import pytest

from gcode_opt import features as feat
from gcode_opt import state as st
from gcode_opt.firmware import simulate as fw

from test_speed_measure_fused import PROFILES
from test_speed_measure_loop import bits, res_bits

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SAMPLES = os.path.join(ROOT, "sample_gcode")

HAVE_SNAPSHOT = st._reader is not None and hasattr(st._reader, "snapshot")


def _states(path, profile):
    """(idx, state) of a state stepped through the file, at ~200 of its lines."""
    every = max(1, sum(1 for _ in st.read_lines(path)) // 200)
    state = st.MachineState(profile, path)
    state.warnings = []
    for idx, raw in st.read_lines(path):
        state.step(idx, raw)
        if idx % every == 0:
            yield idx, state


@pytest.mark.skipif(not HAVE_SNAPSHOT, reason="the compiled reader is not built here")
@pytest.mark.parametrize("name,prof", [("prusa_gyroid", "prusa-mk3s"), ("prusa_klipper", "voron24"),
                                       ("edge/m204_variants", "prusa-mk3s"), ("cura_box", "rrf")])
def test_snapshot_is_the_attrgetters_tuple(name, prof):
    path = os.path.join(SAMPLES, name + ".gcode")
    assert st._modal_of is st._reader.snapshot
    n = 0
    for idx, state in _states(path, PROFILES[prof]()):
        got, ref = state.snapshot(), st._get_modal(state)
        assert type(got) is tuple and len(got) == len(ref) == len(st.MachineState.MODAL), idx
        assert all(a is b for a, b in zip(got, ref)), (idx, got, ref)
        n += 1
    assert n > 10


@pytest.mark.skipif(not HAVE_SNAPSHOT, reason="the compiled reader is not built here")
def test_snapshot_of_other_objects_is_the_attrgetters():
    profile = PROFILES["prusa-mk3s"]()

    class Sub(st.MachineState):
        @property
        def x(self):               # a subclass may read an attribute elsewhere
            return 123.0

        @x.setter
        def x(self, value):
            pass

    sub = Sub(profile, None)
    assert st._reader.snapshot(sub) == st._get_modal(sub) and st._reader.snapshot(sub)[0] == 123.0
    state = st.MachineState(profile, None)
    del state.layer                # a name missing from the dict: the attrgetter's error
    with pytest.raises(AttributeError):
        st._get_modal(state)
    with pytest.raises(AttributeError):
        st._reader.snapshot(state)
    with pytest.raises(AttributeError):
        st._reader.snapshot(object())


def _poke(state, rng, idx):
    """Change the state at a stop as Python code could (or leave it: a kept load's case)."""
    k = rng.randrange(14)
    if k == 0:
        state.x = state.x + 0.25
    elif k == 1:
        state.e = state.e + 1.5
    elif k == 2:
        state.v = 31.0 + rng.random()
    elif k == 3:
        state.accel_print = 700.0 + rng.randrange(5)
    elif k == 4:
        state.feature = rng.choice([feat.TRAVEL, "external perimeter", "solid infill"])
    elif k == 5:
        state.flow_r = 0.9
    elif k == 6:
        state.speed_r = 1.25
    elif k == 7:
        state.lim = state.lim.replace(v_max=state.lim.v_max * 0.75)
    elif k == 8:                   # step()'s G0/G1 (linear): x y z e (v) moved past a kept load
        state.step(idx, "G1 X%.3f Y%.3f E0.25 F%d\n" % (rng.uniform(10, 200), rng.uniform(10, 200),
                                                         rng.choice([1200, 3000])))
    elif k == 9:
        state.step(idx, "G1 X%.3f Y50\n" % rng.uniform(10, 200))
    elif k == 10:
        state.step(idx, "M204 P900 T1100\n")
    elif k == 11:
        state.step(idx, ";TYPE:Overhang perimeter\n")
    # else: nothing changed


def _play(path, profile, seed, fused):
    """The file played by play_buf to each stop, the state poked there; the snapshots at the
    stops (the reference's by the attrgetter), the model's sums, the last state."""
    assert fw.use_fused(fused) == fused
    try:
        state = st.MachineState(profile, path)
        state.warnings = []
        sim = fw.new_sim(profile, None, None)
        snap = st._get_modal if not fused else st.MachineState.snapshot
        rng = random.Random(seed)
        snaps, idx = [], 0
        for buf, cr in fw.Blocks(path).blocks():
            pos = 0
            while pos < len(buf):
                pos, idx, stopped = sim.play_buf(buf, pos, idx, cr, state.step, -2, True, None)
                if stopped:
                    got = snap(state)
                    # the snapshot at a stop (where the session's write-back kept its objects)
                    # is the attrgetter's, object for object
                    assert all(a is b for a, b in zip(got, st._get_modal(state))), idx
                    snaps.append((idx, got))
                    _poke(state, rng, idx)
        sim.stop()
        return bits(snaps), res_bits(sim.res), bits([st._get_modal(state), state.warnings])
    finally:
        fw.use_fused(True)


@pytest.mark.skipif(fw._core is None or st._reader is None or not fw.use_fused(True),
                    reason="the compiled reader and firmware core are not both built here")
@pytest.mark.parametrize("name,prof", [("prusa_gyroid", "prusa-mk3s"), ("prusa_klipper", "voron24"),
                                       ("prusa_absolute_e", "generic-marlin"), ("prusa_gyroid_arcs", "rrf")])
def test_kept_loads_read_what_python_changed(name, prof):
    path = os.path.join(SAMPLES, name + ".gcode")
    profile = PROFILES[prof]()
    for seed in (1, 2):
        got, ref = _play(path, profile, seed, True), _play(path, profile, seed, False)
        assert len(got[0]) > 20     # stops enough to change the state at
        assert got == ref, seed
