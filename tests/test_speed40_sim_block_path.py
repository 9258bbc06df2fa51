"""The compiled firmware model's per-block path as one body (session 40): the block made in
its queue slot (the Marlin planner's last block is q[n - 1], not a copy), the planner,
the trapezoid, the junction laws (the jerk law's axes written out), the integrals, the
on_line records (RecordLog, StrokeSums) and the RowSink's rows written in place.  Each is
checked against the Python model, bit for bit, on moves that reach every branch: Z moves
past the Z jerk and the Z caps, reversals, tiny and zero-length segments, E-only moves,
dwells, M204 and M205, for the three junction laws, Marlin windows down to one block and small
Klipper chunks."""
from __future__ import annotations

import random
import struct

import numpy as np
import pytest

import fwcore_compare as fc
from gcode_opt import ringing as rg
from gcode_opt import state as st
from gcode_opt.firmware import simulate as sm
from gcode_opt.profile import Profile, load_profile

pytestmark = pytest.mark.skipif(sm._core is None or not hasattr(sm._core, "RowSink"),
                                reason="the compiled firmware-model core is not built here")

LAWS = ("prusa-mk3s", "generic-marlin", "voron24")


def _gcode(rng: random.Random, n: int) -> str:
    """Moves in X, Y and Z of every length and turn, E-only moves, dwells, M204, M205."""
    out = ["G21", "G90", "M83", "G1 Z0.2 F600", "G1 X100 Y100 F6000"]
    x = y = 100.0
    z = 0.2
    heading = 0.0
    for _ in range(n):
        r = rng.random()
        f = rng.choice([300, 1200, 3000, 6000, 12000, 30000])
        if r < 0.05:
            out.append(f"G1 E{rng.uniform(-1.5, 1.5):.4f} F{f}")
        elif r < 0.08:
            out.append(f"G4 P{rng.choice([0, 20, 150])}")
        elif r < 0.11:
            out.append(f"M204 S{rng.choice([150, 400, 1500, 8000])}")
        elif r < 0.12:
            out.append(f"M205 X{rng.choice([0.5, 2, 8, 20])} Y{rng.choice([0.5, 2, 8, 20])}")
        elif r < 0.17:
            z = max(0.2, z + rng.choice([0.2, 0.05, -0.1, 3.0]))
            x += rng.uniform(-2.0, 2.0) * rng.choice([0.0, 1.0])
            out.append(f"G1 X{x:.4f} Y{y:.4f} Z{z:.4f} E{rng.uniform(0.0, 0.05):.4f} F{f}")
        elif r < 0.19:
            out.append(f"G1 X{x:.4f} Y{y:.4f} F{f}")        # zero length
        else:
            heading += rng.choice([0.0, 0.0, 0.05, -0.3, 1.2, 3.14159265, -2.5, rng.uniform(-3.2, 3.2)])
            d = rng.choice([0.02, 0.3, 1.0, 4.0, 25.0, rng.uniform(0.01, 40.0)])
            x = min(240.0, max(10.0, x + d * np.cos(heading)))
            y = min(240.0, max(10.0, y + d * np.sin(heading)))
            e = rng.choice([0.0, d * 0.033, d * 0.05])
            out.append(f"G1 X{x:.4f} Y{y:.4f} E{e:.5f} F{f}")
    return "\n".join(out) + "\n"


def _profiles():
    for law in LAWS:
        yield law, load_profile(law)
    base = load_profile("ender3")
    for window in (1, 2, 3):                  # block_buffer B: a window of B - 1 blocks
        yield f"ender3-b{window}", Profile(**{**base.__dict__, "block_buffer": window})
    mk3 = load_profile("prusa-mk3s")
    yield "mk3s-lowjerk", Profile(**{**mk3.__dict__, "jerk_xy_v": 1.0, "max_z_velocity_v": 2.0})


PROFILES = dict(_profiles())


def _events(tmp_path, seed, n=500):
    path = tmp_path / f"r{seed}.gcode"
    path.write_text(_gcode(random.Random(seed), n))
    return path


@pytest.mark.parametrize("name", sorted(PROFILES))
@pytest.mark.parametrize("seed", range(3))
def test_blocks_records_and_result_same_bits(tmp_path, name, seed):
    prof = PROFILES[name]
    evs = fc.events_of(str(_events(tmp_path, seed)), prof)
    a = fc.run(evs, prof, "python")
    b = fc.run(evs, prof, "c")
    assert len(a[2]) > 300
    assert fc.first_difference(a, b) is None


def test_klipper_small_chunk_same_bits(tmp_path, monkeypatch):
    monkeypatch.setattr(sm, "KLIPPER_CHUNK", 2)
    prof = PROFILES["voron24"]
    evs = fc.events_of(str(_events(tmp_path, 7)), prof)
    assert fc.first_difference(fc.run(evs, prof, "python"), fc.run(evs, prof, "c")) is None


def _sink_rows(core, prof, evs, cap):
    """The rows a RowSink holds after a pass on `core` (ringing's hooks: the compiled model
    writes the blocks' rows and the rests itself, the Python one through the sink's calls)."""
    chunks = []
    sink = sm._core.RowSink(cap, lambda: chunks.append(bytes(sink.take())))
    old = sm.use_core(core)
    try:
        sim = sm.new_sim(prof, sink.line, sink)
        for _idx, _raw, ev in rg.wrap_events(iter(evs), sink.dwell):
            if type(ev) is st.Move:
                sim.move(ev)
            elif type(ev) is st.Barrier:
                sim.barrier(ev)
        sim.stop()
    finally:
        sm.use_core(old)
    chunks.append(bytes(sink.take()))
    return b"".join(chunks)


@pytest.mark.parametrize("name", sorted(PROFILES))
@pytest.mark.parametrize("cap", [5, 4096])
def test_sink_rows_are_the_python_models_rows(tmp_path, name, cap):
    prof = PROFILES[name]
    evs = fc.events_of(str(_events(tmp_path, 11)), prof)
    c = _sink_rows("c", prof, evs, cap)
    py = _sink_rows("python", prof, evs, cap)
    assert len(c) == len(py) and len(c) > 300 * 96
    rows = [struct.unpack_from("12d", c, 96 * i) for i in range(len(c) // 96)]
    assert any(r[11] == 0.0 for r in rows)                    # rests among the blocks
    assert c == py


def _records(prof, evs):
    recs = []
    old = sm.use_core("python")
    try:
        sm.simulate_events(iter(evs), prof, recs.append)
    finally:
        sm.use_core(old)
    return recs


@pytest.mark.parametrize("name", sorted(PROFILES))
def test_record_log_holds_the_python_records(tmp_path, name):
    prof = PROFILES[name]
    evs = fc.events_of(str(_events(tmp_path, 3)), prof)
    recs = _records(prof, evs)
    log = sm._core.RecordLog()
    old = sm.use_core("c")
    try:
        sm.simulate_events(iter(evs), prof, log)
    finally:
        sm.use_core(old)
    assert log.rows == len(recs) > 300
    # one stroke a record: its own start_v, end_v and sums
    idx = np.array([r.idx for r in recs], np.int64)
    got = np.zeros(len(recs), np.int64)
    v0, v1, t, a2, v2 = (np.zeros(len(recs)) for _ in range(5))
    log.stroke_sums(idx, idx, got, v0, v1, t, a2, v2)
    assert (got == 3).all()
    for name_, arr, want in (("start_v", v0, [r.start_v for r in recs]), ("end_v", v1, [r.end_v for r in recs]),
                             ("time_t", t, [r.time_t for r in recs]),
                             ("a2", a2, [r.int_a2 + r.int_a2_j for r in recs]),
                             ("int_v2", v2, [r.int_v2 for r in recs])):
        assert arr.tobytes() == np.array(want, np.float64).tobytes(), name_


@pytest.mark.parametrize("name", sorted(PROFILES))
def test_stroke_sums_hand_on_the_python_records(tmp_path, name):
    # StrokeSums(also=...): every record summed, then handed on as a LineRecord
    prof = PROFILES[name]
    evs = fc.events_of(str(_events(tmp_path, 5)), prof)
    want = [tuple(fc.bits(getattr(r, f)) for f in fc.LINE_FIELDS) for r in _records(prof, evs)]
    seen = []
    empty = np.zeros(0, np.int64)
    sums = sm._core.StrokeSums(empty, empty, np.zeros(0), np.zeros(0), np.zeros(0),
                               lambda r: seen.append(tuple(fc.bits(getattr(r, f)) for f in fc.LINE_FIELDS)))
    old = sm.use_core("c")
    try:
        sm.simulate_events(iter(evs), prof, sums)
    finally:
        sm.use_core(old)
    assert len(want) > 300 and seen == want


def test_one_block_window_past_the_queue_compaction(tmp_path):
    # A window of one block (block_buffer 1 or 2) executes each block as it is added
    # (head == n); after 4096 of them the queue drops the executed blocks, and the next
    # add reads the last one as q[n - 1]: the compaction must keep it.  It once dropped it
    # too, and the next add read before the queue (a crash where the queue was mmap'd:
    # glibc's default thresholds, GCODE_OPT_MALLOC=default).  A subprocess: a crash is a
    # failure here, not the end of the test run.  The output and figures must be the pure
    # Python model's.
    import os
    import subprocess
    import sys
    lines = ["G21", "G90", "M82", "G1 Z0.2 F600", "G1 X10 Y10 F3000", ";TYPE:Solid infill"]
    e = 0.0
    x, y = 10.0, 10.0
    for i in range(6000):                     # no stop: one run of moves past 4096 blocks
        nx, ny = 10 + (i % 200) * 0.5, 10 + 5 * np.sin(i * 0.11) + (i // 200) * 0.4
        e += float(np.hypot(nx - x, ny - y)) * 0.04
        lines.append(f"G1 X{nx:.3f} Y{ny:.3f} E{e:.5f}")
        x, y = nx, ny
    src = tmp_path / "long.gcode"
    src.write_text("\n".join(lines) + "\n")
    prof = tmp_path / "b2.toml"
    from gcode_opt import profile as gp
    with open(os.path.join(gp._bundled_dir(), "ender3.toml"), encoding="utf-8") as fh:
        toml = fh.read()
    prof.write_text("\n".join("block_buffer = 2" if ln.startswith("block_buffer") else ln
                              for ln in toml.splitlines()) + "\n")
    outs = {}
    for mode in ("c", "python"):
        env = {**os.environ, "GCODE_OPT_MALLOC": "default"}
        env.pop("GCODE_OPT_PURE_PYTHON", None)
        if mode == "python":
            env["GCODE_OPT_PURE_PYTHON"] = "1"
        out = tmp_path / f"out_{mode}.gcode"
        r = subprocess.run([sys.executable, "-m", "gcode_opt", "process", str(src), "--profile", str(prof),
                            "-o", str(out), "-q"], env=env, capture_output=True, text=True)
        assert r.returncode == 0, (mode, r.returncode, r.stderr[-2000:])
        outs[mode] = out.read_bytes()
    assert outs["c"] == outs["python"]
