"""The compiled firmware-model core (firmware/_core.c) against the Python one, bit for bit.

Both cores play the same events; every LineRecord field (on_line order), every planner.Block
field (on_block order) and every SimResult field must be the same bits (tests/fwcore_compare.py),
on real files for the three junction laws and both planners (prusa-mk3s: classic jerk,
Marlin buffer; generic-marlin: junction deviation, Marlin buffer; voron24: Klipper scv, full
lookahead with minimum_cruise_ratio), on random files with the corner cases a reader lets
through, and whole runs of the pipeline (ledger, replay, ringing on the model's blocks) must
write the same bytes.  Skipped, with the reason, where the extension is not built."""
from __future__ import annotations

import json
import math
import os
import random
import subprocess
import sys
from pathlib import Path

import pytest

from ring_close import assert_figures_close

import fwcore_compare as fc
from gcode_opt import state as st
from gcode_opt.firmware import simulate as sm
from gcode_opt.profile import Profile, load_profile

ROOT = Path(__file__).resolve().parent.parent
SAMPLES = ROOT / "sample_gcode"
CORPUS = Path.home() / ".cache" / "gcode-opt-corpus"
LAWS = ("prusa-mk3s", "generic-marlin", "voron24")

pytestmark = pytest.mark.skipif(sm._core is None, reason="the compiled firmware-model core is not built "
                                "here (pip install . with a C compiler); the Python core runs alone")


def same_bits(path, prof, digest=False):
    evs = fc.events_of(str(path), prof)
    a = fc.run(evs, prof, "python", digest)
    b = fc.run(evs, prof, "c", digest)
    assert len(a[1]) > 0 or "empty" in str(path)
    return fc.first_difference(a, b)


SLOW = [pytest.mark.slow]


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("name", ["prusa_gyroid_arcs.gcode", "prusa_klipper.gcode", "cura_box.gcode"]
                         + [pytest.param(n, marks=SLOW) for n in
                            ("prusa_gyroid.gcode", "prusa_concentric_arcs.gcode", "prusa_benchy_like.gcode",
                             "prusa_gyroid_fullspeed_klipper.gcode", "prusa_absolute_e.gcode")])
def test_samples_same_bits(name, law):
    assert same_bits(SAMPLES / name, load_profile(law)) is None


@pytest.mark.parametrize("law", LAWS + ("prusa-mk4", "ender3"))
def test_edge_files_same_bits(law):
    prof = load_profile(law)
    for path in sorted((SAMPLES / "edge").glob("*.gcode")):
        assert same_bits(path, prof) is None, path.name


@pytest.mark.slow
@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("name", ["plate_gyroid", "plate_rectilinear", "bridges_klipper", "cura_gyroid",
                                  "gyroid_fwretract", "cura_bridges"])
def test_corpus_same_bits(name, law):
    path = CORPUS / f"{name}.gcode"
    if not path.exists():
        pytest.skip(f"{path} not made (sample_gcode/make_corpus.sh)")
    assert same_bits(path, load_profile(law), digest=True) is None


# ---------------------------------------------------------------- random files
def random_gcode(rng: random.Random, n: int, klipper: bool) -> str:
    """n lines of motion with what the reader lets through: zero-length and 1e-7 mm moves,
    reversals, Z and helical moves, arcs (tiny to 1 m radius), E-only moves, dwells, homing,
    accel / speed / jerk / junction changes, M221 flow."""
    out = ["G21", "G90", "M83", "G28", "G1 Z0.2 F600"]
    x, y, z = 100.0, 100.0, 0.2
    for _ in range(n):
        r = rng.random()
        if r < 0.45:                                   # a straight move, some tiny, some back
            k = rng.random()
            if k < 0.1:
                nx, ny = x, y
            elif k < 0.2:
                nx, ny = x + rng.choice([1e-7, -1e-6, 1e-4]), y
            elif k < 0.3:
                nx, ny = x - (rng.random() - 0.5) * 2, y
            else:
                nx, ny = x + rng.uniform(-30, 30), y + rng.uniform(-30, 30)
            words = f"G1 X{nx:.7f} Y{ny:.7f}"
            if rng.random() < 0.1:
                z = round(z + rng.choice([0.2, -0.1, 0.0]), 3)
                words += f" Z{max(z, 0.0):.3f}"
            if rng.random() < 0.7:
                words += f" E{rng.uniform(-0.01, 0.5):.5f}"
            if rng.random() < 0.3:
                words += f" F{rng.choice([60, 600, 1800, 7200, 30000, 0.5]):g}"
            out.append(words)
            x, y = nx, ny
        elif r < 0.6:                                  # an arc about a centre off the pen
            rad = rng.choice([0.05, 1.0, 5.0, 40.0, 1000.0])
            a0 = rng.uniform(0, 2 * math.pi)
            cx, cy = x - rad * math.cos(a0), y - rad * math.sin(a0)
            sweep = rng.uniform(0.01, 6.2) if rad < 100.0 else rng.uniform(1e-4, 0.05)
            a1 = a0 + sweep * rng.choice([1, -1])
            nx, ny = cx + rad * math.cos(a1), cy + rad * math.sin(a1)
            g = "G3" if a1 > a0 else "G2"
            words = f"{g} X{nx:.4f} Y{ny:.4f} I{cx - x:.4f} J{cy - y:.4f} E{rng.uniform(0, 1):.4f}"
            if rng.random() < 0.2:
                z = round(z + 0.2, 3)
                words += f" Z{z:.3f}"
            out.append(words)
            x, y = nx, ny
        elif r < 0.68:
            out.append(f"G1 E{rng.choice([-0.8, 0.8, 0.0001]):.4f} F{rng.choice([2100, 300]):d}")
        elif r < 0.71:
            out.append(rng.choice(["G4 P10", "G4 S0", "G28 X", "M400"]))
        elif r < 0.8:
            a = rng.choice([100, 500, 1250, 4000, 20000])
            out.append(f"M204 S{a}" if klipper or rng.random() < 0.5 else f"M204 P{a} T{a * 2}")
        elif r < 0.88:
            if klipper:
                out.append(rng.choice([f"SET_VELOCITY_LIMIT SQUARE_CORNER_VELOCITY={rng.uniform(0.1, 20):.2f}",
                                       f"SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO={rng.uniform(0, 0.9):.2f}",
                                       f"SET_VELOCITY_LIMIT VELOCITY={rng.uniform(5, 500):.1f}",
                                       f"SET_VELOCITY_LIMIT ACCEL={rng.uniform(100, 9000):.0f}"]))
            else:
                out.append(rng.choice([f"M201 X{rng.uniform(200, 5000):.0f} Y{rng.uniform(200, 5000):.0f}",
                                       f"M203 X{rng.uniform(5, 500):.0f} Y{rng.uniform(5, 500):.0f}",
                                       f"M205 X{rng.uniform(0, 20):.1f} Y{rng.uniform(0, 20):.1f}",
                                       f"M205 J{rng.uniform(0.01, 0.3):.3f}"]))
        else:
            out.append(f"M221 S{rng.choice([50, 95, 100, 130])}")
    return "\n".join(out) + "\n"


@pytest.mark.parametrize("law", LAWS + ("ender3", "generic-klipper"))
@pytest.mark.parametrize("seed", range(6))
def test_random_files_same_bits(tmp_path, law, seed):
    prof = load_profile(law)
    text = random_gcode(random.Random(seed * 7919 + len(law)), 400, prof.flavour == "klipper")
    path = tmp_path / "r.gcode"
    path.write_text(text)
    assert same_bits(path, prof) is None


@pytest.mark.parametrize("window", [1, 2, 3, 16])
def test_marlin_buffer_sizes_same_bits(tmp_path, window):
    # block_buffer B plays a window of B - 1 (B = 2: one block, no lookahead at all)
    prof = load_profile("ender3")
    prof = Profile(**{**prof.__dict__, "block_buffer": window})
    path = tmp_path / "r.gcode"
    path.write_text(random_gcode(random.Random(window), 300, False))
    assert same_bits(path, prof) is None


def test_klipper_small_chunk_same_bits(tmp_path, monkeypatch):
    # the lazy flush every 3 moves (many partial flushes) and the constants the core takes
    # from the module when a pass starts
    monkeypatch.setattr(sm, "KLIPPER_CHUNK", 3)
    path = tmp_path / "r.gcode"
    path.write_text(random_gcode(random.Random(5), 300, True))
    assert same_bits(path, load_profile("voron24")) is None


# ---------------------------------------------------------------- moves made by hand
def _lim(**kw):
    base = dict(v_max=500.0, ax_max=3000.0, ay_max=3000.0, scv=5.0, mcr=0.5, jd=0.02,
                jerk_x=8.0, jerk_y=8.0)
    base.update(kw)
    return st.Limits(**base)


def _move(idx, x0, y0, x1, y1, v=100.0, accel=1000.0, e=0.1, lim=None, kind=st.LINE, z0=0.0, z1=0.0):
    return st.Move(idx, kind, x0, y0, z0, x1, y1, z1, e, v, accel, "infill", 0, lim or _lim())


def _play(core, prof, moves):
    out = []
    old = sm.use_core(core)
    try:
        sim = sm.new_sim(prof, lambda r: out.append(fc.bits(r.time_t)), None)
        for mv in moves:
            sim.move(mv)
        sim.stop()
        return out, sim.res.as_dict()
    except Exception as exc:            # the same error, from the same move
        return type(exc).__name__, len(out)
    finally:
        sm.use_core(old)


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("case", ["zero_speed", "zero_accel_nan", "nan_speed", "inf_coords", "reversal",
                                  "int_fields", "accel_zero_default"])
def test_hand_moves_same_result_or_same_error(law, case):
    prof = load_profile(law)
    nan, inf = float("nan"), float("inf")
    moves = {
        "zero_speed": [_move(0, 0, 0, 10, 0), _move(1, 10, 0, 20, 5, v=0.0)],
        "zero_accel_nan": [_move(0, 0, 0, 10, 0, accel=nan), _move(1, 10, 0, 20, 0)],
        "nan_speed": [_move(0, 0, 0, 10, 0, v=nan), _move(1, 10, 0, 0, 0)],
        "inf_coords": [_move(0, 0, 0, inf, 0)],
        "reversal": [_move(0, 0, 0, 10, 0), _move(1, 10, 0, 0, 0), _move(2, 0, 0, 10, 1e-9)],
        "int_fields": [_move(0, 0, 0, 10, 0, v=100, accel=1000), _move(1, 10, 0, 20, 3, v=50, accel=2000)],
        "accel_zero_default": [_move(0, 0, 0, 10, 0, accel=0.0), _move(1, 10, 0, 10, 10, accel=-5.0)],
    }[case]
    py = _play("python", prof, moves)
    c = _play("c", prof, moves)
    if case == "int_fields":
        # an int the Python model passes through unchanged (an uncapped accel as peak_a)
        # stays an int there; the core reports every figure as a float: same values
        assert py == c
    else:
        assert repr(py) == repr(c)


def test_junction_name_outside_the_three_plays_as_the_python_model():
    # _Sim takes any other name as the jerk junction without the safe speed
    prof = load_profile("prusa-mk3s")
    prof = Profile(**{**prof.__dict__, "junction": "other"})
    moves = [_move(i, 10.0 * i, 0.0, 10.0 * i + 10.0, 2.0 * (i % 3)) for i in range(30)]
    assert repr(_play("c", prof, moves)) == repr(_play("python", prof, moves))


def test_core_refuses_reentry_from_its_callback():
    prof = load_profile("voron24")
    old = sm.use_core("c")
    try:
        box = []
        sim = sm.new_sim(prof, lambda r: box[0].move(_move(9, 0, 0, 1, 0)), None)
        box.append(sim)
        sim.move(_move(0, 0, 0, 10, 0))
        with pytest.raises(RuntimeError, match="re-entered"):
            sim.stop()
    finally:
        sm.use_core(old)


def test_duck_typed_moves_are_read_by_name():
    # objects that are not state.Move (no slot offsets): the core reads them by getattr
    class M:
        pass

    prof = load_profile("voron24")
    real = [_move(0, 0, 0, 10, 0), _move(1, 10, 0, 20, 5)]
    ducks = []
    for mv in real:
        d = M()
        for k in st.Move.__slots__:
            setattr(d, k, getattr(mv, k))
        ducks.append(d)
    assert _play("c", prof, ducks) == _play("python", prof, real)


def test_callback_errors_propagate():
    prof = load_profile("voron24")

    def boom(_):
        raise KeyError("from the callback")

    for core in ("c", "python"):
        old = sm.use_core(core)
        try:
            sim = sm.new_sim(prof, boom, None)
            sim.move(_move(0, 0, 0, 10, 0))
            with pytest.raises(KeyError, match="from the callback"):
                sim.stop()
        finally:
            sm.use_core(old)


def test_blocks_kept_by_the_callback_keep_their_values():
    # the ringing Collector keeps the Block objects and reads them later: each is its own
    prof = load_profile("prusa-mk3s")
    moves = [_move(i, i * 10.0, 0.0, i * 10.0 + 10.0, (i % 2) * 1.0) for i in range(40)]
    kept = {}
    for core in ("c", "python"):
        blocks = []
        old = sm.use_core(core)
        try:
            sim = sm.new_sim(prof, None, blocks.append)
            for mv in moves:
                sim.move(mv)
            sim.stop()
        finally:
            sm.use_core(old)
        kept[core] = [tuple(fc.bits(getattr(b, f)) for f in fc.BLOCK_FIELDS) for b in blocks]
    assert len(kept["c"]) == 40 and kept["c"] == kept["python"]


def test_result_fields_written_by_python_are_seen_by_the_core():
    # _play (the ledger pass) resets res.peak_v / peak_a at every stop and reads them back
    prof = load_profile("voron24")
    old = sm.use_core("c")
    try:
        sim = sm.new_sim(prof, None, None)
        sim.move(_move(0, 0, 0, 50, 0))
        sim.stop()
        assert sim.res.peak_v == pytest.approx(100.0)
        sim.res.peak_v = 0.0
        sim.res.stop_lines = [7]
        sim.max_stop_lines = math.inf
        sim.move(_move(1, 50, 0, 51, 0, v=20.0))
        sim.stop()
        assert sim.res.peak_v == pytest.approx(20.0) and sim.res.stop_lines == [7]
        assert sim.empty() and sim.max_stop_lines == math.inf
    finally:
        sm.use_core(old)


# ---------------------------------------------------------------- the whole pipeline
def _process(tmp_path, core, name, prof, tag):
    env = dict(os.environ)
    if core == "python":
        env["GCODE_OPT_PURE_PYTHON"] = "1"
    else:
        env.pop("GCODE_OPT_PURE_PYTHON", None)
    (tmp_path / tag).mkdir()
    out = tmp_path / tag / "out.gcode"         # the same name: the summary holds it
    js = tmp_path / tag / "out.json"
    r = subprocess.run([sys.executable, "-m", "gcode_opt", "process", str(SAMPLES / name), "-o", str(out),
                        "--profile", prof, "-q", "--json", str(js)], cwd=ROOT, env=env,
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    summary = json.loads(js.read_text())
    for k in ("timing_s", "elapsed_s", "output", "firmware_core", "reader_core", "chain_core", "emit_core", "curve_core"):   # CPU and wall s; the path; the cores
        summary.pop(k, None)
    return out.read_bytes(), summary


@pytest.mark.parametrize("name,prof", [("prusa_gyroid_arcs.gcode", "prusa-mk3s"),
                                       pytest.param("prusa_klipper.gcode", "voron24", marks=SLOW)])
def test_pipeline_writes_the_same_bytes_on_both_cores(tmp_path, name, prof):
    # analyse, measure, the ledger's replays and the ringing figures all ride on the model
    c = _process(tmp_path, "c", name, prof, "c")
    py = _process(tmp_path, "python", name, prof, "py")
    assert c[0] == py[0]
    diff = sorted(k for k in set(c[1]) | set(py[1]) if k != "ringing" and c[1].get(k) != py[1].get(k))
    assert not diff
    # (the ringing: the compiled ring_solve's recursion, the pure path's numpy steps -- the
    # same figures to rounding since session 46, not the same bits)
    assert_figures_close(c[1]["ringing"], py[1]["ringing"])


def test_a_core_built_from_another_source_is_not_used(monkeypatch):
    # a stale build (the C file changed since): the Python model plays, and says why
    monkeypatch.setattr(sm._core, "SOURCE_SHA256", "0" * 64)
    monkeypatch.setattr(sm, "CORE_WHY", "")
    assert sm._load_core() is None
    assert "another _core.c" in sm.CORE_WHY


def test_environment_forces_the_python_core():
    code = "from gcode_opt.firmware import simulate as s; print(s.CORE)"
    env = dict(os.environ, GCODE_OPT_PURE_PYTHON="1")
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True)
    assert r.stdout.strip() == "python"
    env.pop("GCODE_OPT_PURE_PYTHON")
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True)
    assert r.stdout.strip() == "c"
