"""Marlin's junction deviation ("jd": Marlin 2, the Ender 3 profile) on the chains' finishing
over arrays: every new array form gives the per-junction form's floats, bit for bit, and
the chains are finished by groups as under classic jerk and Klipper (a Cura gyroid file on
an Ender 3 took 8.6 s of CPU, 13 k lines/s, nearly all of it the per-vertex loops).

Checked against the per-junction functions they replace (firmware/junction.py's
marlin_jd_v2 and accel_to_pass_junction, curves.accel_in_force, chains._junction_v), on
junctions drawn to hit every branch, and end to end against the whole job with the
per-junction paths put back."""
import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import chains, curves
from gcode_opt.firmware.junction import marlin_jd_v2, marlin_jd_v2_rows
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.schedule import plan_inputs
from gcode_opt.segments import SegmentRules
from gcode_opt.strokes import K_CHAIN

SAMPLES = Path(__file__).resolve().parent.parent / "sample_gcode"


def _bits(a):
    return np.ascontiguousarray(np.asarray(a, float)).view(np.int64).tolist()


def _directions(rng, m):
    """Unit directions: random, plus the cases the law branches on (straight on, reversal,
    axis-aligned, nearly straight, sharp)."""
    th = rng.uniform(-math.pi, math.pi, m)
    u = np.stack([np.cos(th), np.sin(th)], 1)
    pth = th + rng.choice([0.0, math.pi, 1e-4, 0.3, 2.5, math.pi - 1e-7, rng.uniform(-3, 3)], m)
    pu = np.stack([np.cos(pth), np.sin(pth)], 1)
    k = rng.integers(0, m, m // 8)
    u[k] = [1.0, 0.0]
    pu[k[: k.size // 2]] = [0.0, 1.0]
    pu[k[k.size // 2:]] = [1.0, 0.0]
    return pu, u


def test_marlin_jd_v2_rows_is_the_scalar_law():
    rng = np.random.default_rng(55)
    m = 4000
    pu, u = _directions(rng, m)
    d = rng.choice([0.05, 0.4, 0.99, 1.0, 3.0, 25.0], m) * rng.uniform(0.5, 1.5, m)
    a = rng.choice([500.0, 1500.0, 3000.0, 9000.0], m)
    jd, cx, cy = 0.08, 1000.0, 2500.0                # caps that bind on some junctions
    got, odd = marlin_jd_v2_rows(pu[:, 0], pu[:, 1], u[:, 0], u[:, 1], d, a, jd, cx, cy)
    want = [marlin_jd_v2(pu[i, 0], pu[i, 1], 0.0, u[i, 0], u[i, 1], 0.0, d[i], a[i], jd, cx, cy, 1e9)
            for i in range(m)]
    assert not odd.any()
    assert _bits(got) == _bits(want)
    # every branch was taken: reversal, straight on (inf), the short-block limit, the caps
    assert np.isinf(got).any() and (got == 0.05 * 0.05).any()
    assert (np.asarray(want) < a * jd).any()


def test_accel_in_force_rows_is_accel_in_force():
    rng = np.random.default_rng(7)
    prof = load_profile("ender3")
    lim = type("Lim", (), {"ax_max": 500.0, "ay_max": 1700.0})()
    _, u = _directions(rng, 2000)
    acc = rng.choice([0.0, -1.0, 300.0, 800.0, 2500.0, np.nan], 2000)
    got = curves.accel_in_force_rows(prof.default_accel_a, acc, u[:, 0], u[:, 1], lim.ax_max, lim.ay_max)
    want = [curves.accel_in_force(prof, lim, acc[i], u[i])[1] for i in range(2000)]
    assert _bits(got) == _bits(want)


def _chain_like(rng, n, prev=True, nxt=True):
    th = np.cumsum(rng.normal(0.0, 0.6, n))
    U = np.stack([np.cos(th), np.sin(th)], 1)
    d = rng.uniform(0.05, 3.0, n)
    st = type("St", (), {})()
    st.prev_u = (math.cos(th[0] - 0.7), math.sin(th[0] - 0.7)) if prev else None
    st.next_u = (math.cos(th[-1] + 1.1), math.sin(th[-1] + 1.1)) if nxt else None
    return st, U, d


@pytest.mark.parametrize("junction", ["jd", "scv"])
def test_junctions_raised_rows_are_the_per_junction_loop(junction):
    rng = np.random.default_rng(3 if junction == "jd" else 4)
    for case in range(40):
        n = int(rng.integers(1, 30))
        st, U, d = _chain_like(rng, n, prev=case % 3 != 0, nxt=case % 4 != 0)
        k = 3
        vj = rng.uniform(0.0, 80.0, (k, n + 1))
        vj[0, 1] = 0.0
        acc = rng.uniform(10.0, 4000.0, (k, n))
        a_top = 3000.0
        rows = curves._junctions_raised(st, U, d, vj, acc, junction, 0.08, a_top)
        for r in range(k):
            want = curves._junctions_raised_row(st, U, d, vj[r], acc[r], junction, 0.08, a_top)
            assert _bits(rows[r]) == _bits(want), (case, r)
            one = curves._junctions_raised(st, U, d, vj[r], acc[r], junction, 0.08, a_top)
            assert _bits(one) == _bits(want), (case, r)


def test_jd_vertex_speeds_are_the_per_junction_loop():
    rng = np.random.default_rng(11)
    prof = load_profile("ender3")
    lim = type("Lim", (), {"ax_max": prof.max_accel_a * 0.4, "ay_max": prof.max_accel_a, "jd": 0.08})()
    for case in range(30):
        n = int(rng.integers(2, 25))
        _, U, d = _chain_like(rng, n)
        acc = rng.uniform(50.0, 3000.0, (4, n))
        acc[0, 0] = 0.0                          # the acceleration in force: the profile's default
        feed = rng.uniform(5.0, 150.0, (4, n))
        got = chains._vertex_v_rows(prof, lim, U, d, acc, feed)
        want = chains._vertex_v_loop(prof, lim, U, d, acc, feed)
        assert _bits(got) == _bits(want), case


def _ender3_chains(tmp_path, lines=9000):
    src = SAMPLES / "prusa_gyroid_fullspeed.gcode"
    head = tmp_path / "head.gcode"
    with open(src) as fh:
        head.write_text("".join(fh.readlines()[:lines]))
    prof = load_profile("ender3")
    strokes, _ = analyse(str(head), prof, Options())
    plan_inputs(strokes, prof, Options())
    return [s for s in strokes if chains.plan_kind(s) == K_CHAIN], prof


@pytest.mark.parametrize("buffer", [None, 16])
def test_jd_chains_finished_by_groups_equal_chain_by_chain(tmp_path, buffer):
    """As tests/test_speed_plan_groups.py for jerk and scv: each chain's numbers its own."""
    sts, prof = _ender3_chains(tmp_path)
    if buffer is not None:
        prof = dataclasses.replace(prof, block_buffer=buffer)
    assert prof.junction == "jd" and "jd" in chains.GROUP_JUNCTIONS
    sts = sts[:80]
    n_seg = [st.curv.d.size for st in sts]
    assert len(sts) >= 20 and len(set(n_seg)) < len(n_seg)
    rules = SegmentRules.for_profile(prof, 10)
    T0 = np.array([st.time_t for st in sts])
    items = [(st, []) for st in sts]
    for r in (1.0, 1.05, 1.25):
        T = T0 * r
        for (st, laws), law in zip(items, chains.solve(sts, T, (T / chains.GAMMA_MIN) ** 2, prof)):
            laws.append(law)
    items = [(st, [lw for lw in laws if lw.converged]) for st, laws in items]
    items = [it for it in items if it[1]]
    got = chains.finish_groups(items, rules, prof)
    for (st, laws), (kept, fits) in zip(items, got):
        want, want_fits = chains._finish_rows(st, laws, rules, prof)
        assert _bits(fits) == _bits(want_fits)
        for f in ("vk", "acc", "feed", "t_pred", "a2_pred"):
            assert _bits(getattr(kept, f)) == _bits(getattr(want, f)), f


def test_jd_job_writes_what_the_per_junction_paths_write(tmp_path, monkeypatch):
    """The whole job on a gyroid (the head of prusa_gyroid_fullspeed) for an Ender 3
    (junction deviation) writes the same bytes as with the chains finished one by one and
    every junction taken alone."""
    from gcode_opt.pipeline import process
    src = tmp_path / "head.gcode"
    with open(SAMPLES / "prusa_gyroid_fullspeed.gcode") as fh:
        src.write_text("".join(fh.readlines()[:12000]))
    prof = load_profile("ender3")
    fast = tmp_path / "fast.gcode"
    s_fast = process(str(src), str(fast), prof, Options())
    assert s_fast["retimed_strokes"]["by_kind"]["curve"]["retimed"] > 100
    monkeypatch.setattr(chains, "GROUP_JUNCTIONS", ("jerk", "scv"))
    monkeypatch.setattr(chains, "_vertex_v_rows", chains._vertex_v_loop)
    monkeypatch.setattr(curves, "_junctions_raised",
                        lambda st, U, d, vj, acc, junction, jd, a_top:
                        np.array([curves._junctions_raised_row(st, U, d, v, a, junction, jd, a_top)
                                  for v, a in zip(np.atleast_2d(vj), np.atleast_2d(acc))]).reshape(np.shape(acc)))
    slow = tmp_path / "slow.gcode"
    process(str(src), str(slow), prof, Options())
    assert fast.read_bytes() == slow.read_bytes()
