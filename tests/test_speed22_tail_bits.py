"""s22 tail: the same bits from the faster and smaller rewrite / measure / ringing / summary.

- summary.round_list against round() itself (random values, ties, odd values, numpy
  scalars and ints), and summary._per_stroke_rows against the 479aedb code kept here
  verbatim (ref_per_stroke_rows) on a real run's inputs, plain and altered;
- the measure pass's ledger with the watched ranges passed over in C (Sim.play's
  8-argument form, _LedgerWriter.ranges_start) against one play() call per range
  (USE_PLAY_FIRSTS off: the 479aedb loop), on real files, every ledger field;
- the ringing figures with the ramp / corner / turn memos sharing one RingRoom against
  one room a memo (the 479aedb layout), and against the Python rows (no RowSink), with
  small chunks too (rooms reused chunk after chunk); ring_release gives the room back.
"""
from __future__ import annotations

import math
import random
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import ringing as rg
from gcode_opt import summary as sm
from strokes_kept import _strokes_kept
from gcode_opt.firmware import resonance as res
from gcode_opt.firmware import simulate as fwsim
from gcode_opt.profile import load_profile

ROOT = Path(__file__).resolve().parent.parent
SAMPLES = ROOT / "sample_gcode"
FILES = ["prusa_gyroid.gcode", "prusa_klipper.gcode", "prusa_concentric_arcs.gcode"]


def bits(x):
    return np.float64(x).tobytes()


def same(a, b, where="$"):
    if isinstance(a, float) or isinstance(b, float):
        assert type(a) is type(b), (where, a, b)
        assert bits(a) == bits(b), (where, a, b)
    elif isinstance(a, dict):
        assert isinstance(b, dict) and list(a) == list(b), (where, list(a), list(b))
        for k in a:
            same(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, (list, tuple)):
        assert type(a) is type(b) and len(a) == len(b), (where, len(a), len(b))
        for k, (x, y) in enumerate(zip(a, b)):
            same(x, y, f"{where}[{k}]")
    else:
        assert type(a) is type(b) and a == b, (where, a, b)


# ---------------------------------------------------------------- round_list
def _values(rng, nd, n):
    out = []
    for _ in range(n):
        r = rng.random()
        if r < 0.3:
            v = rng.uniform(0, 300)
        elif r < 0.55:
            v = (rng.randrange(10 ** 7) + 0.5) / 10 ** nd          # next to a tie
        elif r < 0.65:
            v = rng.randrange(10 ** 6) / 10 ** nd
        elif r < 0.75:
            v = math.ldexp(rng.random(), rng.randrange(-1080, 60))
        elif r < 0.85:
            v = -rng.uniform(0, 1e3)
        else:
            v = rng.choice([0.0, -0.0, math.inf, -math.inf, math.nan, 5e-324, 1e308, 2.0 ** 52, 2.0 ** 53 + 2,
                            4503599627370495.5 / 10 ** nd, 0.0005, 0.00005, 2.5e-3, 1.0005, 0.1235, 0.12345])
        out.append(v)
    return out


@pytest.mark.parametrize("nd", [3, 4])
def test_round_list_is_round(nd):
    rng = random.Random(nd)
    vals = _values(rng, nd, 60000)
    got, want = sm.round_list(vals, nd), [round(v, nd) for v in vals]
    assert len(got) == len(want)
    for v, x, y in zip(vals, got, want):
        assert type(x) is type(y) and bits(x) == bits(y), (v, x, y)


def test_round_list_other_types():
    vals = [float(k) / 7 for k in range(200)]
    vals[3], vals[50], vals[77] = np.float64(1.23456789), 5, np.float64(0.00015)
    got, want = sm.round_list(vals, 4), [round(v, 4) for v in vals]
    for x, y in zip(got, want):
        assert type(x) is type(y) and bits(x) == bits(y)
    assert sm.round_list([], 3) == []
    assert sm.round_list([0.12345], 4) == [round(0.12345, 4)]


# ---------------------------------------------------------------- per-stroke rows
def ref_per_stroke_rows(rows, strokes, add_row, by_kind):
    """479aedb summary._per_stroke_rows, verbatim."""
    isfinite = math.isfinite
    for i, out_first, t0, i0, t_law, i_law, t1, a21, beta in rows:
        s = strokes[i]
        kind = getattr(s, "kind", "line")
        add_row({
            "line": s.first_idx + 1, "lines": s.n_moves, "kind": kind, "out_line": out_first + 1,
            "feature": s.feature, "layer": s.layer, "length_mm": round(s.length_d, 4),
            "v0_mm_s": round(s.v0, 3), "v1_mm_s": round(s.v1, 3), "feed_mm_s": round(s.v_feed, 3),
            "time_s": {"before": t0, "law": t_law, "after": t1},
            "int_a2": {"before": i0, "law": i_law, "after": a21},
            "beta_s2": beta if isfinite(beta) else None,
        })
        g = by_kind.get(kind)
        if g is None:
            g = by_kind[kind] = {"retimed": 0, "time_s": {"before": 0.0, "law": 0.0, "after": 0.0},
                                 "int_a2": {"before": 0.0, "law": 0.0, "after": 0.0}}
        g["retimed"] += 1
        gt, ga = g["time_s"], g["int_a2"]
        gt["before"] += t0
        gt["law"] += t_law
        gt["after"] += t1
        ga["before"] += i0
        ga["law"] += i_law
        ga["after"] += a21


@pytest.fixture(scope="module")
def summary_args(tmp_path_factory):
    """build_summary's arguments of a real run (prusa_gyroid, prusa-mk3s)."""
    from gcode_opt import pipeline
    from gcode_opt.pipeline import Options
    d = tmp_path_factory.mktemp("tail_sum")
    got = {}
    keep = sm.build_summary

    def spy(*a, **k):
        got["args"] = a
        return keep(*a, **k)
    sm.build_summary = spy
    try:
        with _strokes_kept() as strokes:
            pipeline.process(str(SAMPLES / "prusa_gyroid.gcode"), str(d / "out.gcode"), load_profile("prusa-mk3s"),
                             Options())
    finally:
        sm.build_summary = keep
    args = list(got["args"])
    args[6] = strokes[0]            # the strokes (the run hands build_summary their StrokeColumns)
    return args


def _columns(args):
    strokes, plan, out_ranges, t_after, a2_after = args[6], args[8], args[11], args[12], args[13]
    pin = args[7]
    idx = np.array([r[2] for r in out_ranges], dtype=int)
    return (idx.tolist(), [r[0] for r in out_ranges], pin.T_orig[idx].tolist(), pin.I_orig[idx].tolist(),
            plan.T[idx].tolist(), plan.I_law[idx].tolist(), np.asarray(t_after).tolist(),
            np.asarray(a2_after).tolist(), plan.beta[idx].tolist()), strokes


def _both_rows(cols, strokes):
    want, want_k = [], {}
    ref_per_stroke_rows(zip(*cols), strokes, want.append, want_k)
    got, got_k = [], {}
    sm._per_stroke_rows(*cols, strokes, got, got_k)
    same(got, want)
    same(got_k, want_k)
    return got


def test_per_stroke_rows_real(summary_args):
    cols, strokes = _columns(summary_args)
    assert len(cols[0]) > 100
    _both_rows(cols, strokes)


@pytest.mark.parametrize("seed", range(3))
def test_per_stroke_rows_altered(summary_args, seed):
    import copy
    rng = random.Random(seed)
    cols, strokes = _columns(summary_args)
    strokes = [copy.copy(s) for s in strokes]
    for s in strokes:
        r = rng.random()
        if r < 0.2:
            s.length_d, s.v0, s.v1, s.v_feed = (np.float64(x) for x in (s.length_d, s.v0, s.v1, s.v_feed))
        elif r < 0.3:
            s.v0 = rng.choice([0.0, -0.0, 1e-300, 0.0005, 0.0015, 2.5e-3, math.inf, 1e300, 7])
        elif r < 0.35:
            s.kind = rng.choice(["arc", "curve", "chain"])
    cols = [list(c) for c in cols]
    for c in cols[2:]:
        for j in range(len(c)):
            if rng.random() < 0.03:
                c[j] = rng.choice([math.nan, math.inf, -math.inf, 0.0, -0.0, 5e-324, 1e308])
    _both_rows(cols, strokes)


# ---------------------------------------------------------------- the measure pass's ledger
def _ledger(path, profile, watch, batch):
    keep = fwsim.USE_PLAY_FIRSTS
    fwsim.USE_PLAY_FIRSTS = batch
    try:
        r, led = fwsim.simulate_ledger(path, profile, watch)
    finally:
        fwsim.USE_PLAY_FIRSTS = keep
    return r, led


@pytest.mark.skipif(fwsim.CORE != "c" or not getattr(fwsim._core, "PLAY_FIRSTS", 0), reason="compiled core")
@pytest.mark.parametrize("name", FILES)
@pytest.mark.parametrize("step", [1, 5, 17])
def test_ledger_batched_ranges(name, step):
    path = str(SAMPLES / name)
    profile = load_profile("prusa-mk3s" if "klipper" not in name else "voron24")
    n = sum(1 for _ in open(path, "rb"))
    # disjoint sorted ranges: some one line, some several, some running over stops
    rng = random.Random(step)
    watch, k = [], rng.randrange(3)
    while k < n + 5:            # (a range past the end too)
        ln = rng.choice([0, 0, 1, 3, 8])
        watch.append((k, k + ln))
        k += ln + step + rng.randrange(3)
    r1, led1 = _ledger(path, profile, watch, True)
    r0, led0 = _ledger(path, profile, watch, False)
    assert len(led0.lo) > 10
    for f in ("line", "sums", "peak_v", "peak_a", "lo", "hi"):
        assert getattr(led1, f).tobytes() == getattr(led0, f).tobytes(), f
    assert led1.state == led0.state
    assert led1.stop_lines == led0.stop_lines and led1.n_lines == led0.n_lines and led1.ok == led0.ok
    same(r1.as_dict(), r0.as_dict())


# ---------------------------------------------------------------- ringing rooms
def _figures(path, profile, monkeypatch, layout, chunk_blocks=rg.CHUNK_BLOCKS):
    with monkeypatch.context() as m:
        if layout == "own rooms":          # 479aedb: one room a memo
            m.setattr(rg, "RingMemo", lambda room=None: res.RingMemo())
        elif layout == "python rows":
            m.setattr(rg, "USE_SINK", False)
        col = rg.Collector(profile, chunk_blocks=chunk_blocks)
        rg.play(path, profile, col)
        return col.figures(), col.chunks


@pytest.mark.parametrize("name,prof", [("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_klipper.gcode", "voron24"),
                                       ("prusa_concentric_arcs.gcode", "prusa-mk3s")])
@pytest.mark.parametrize("chunk", [rg.CHUNK_BLOCKS, 700])
def test_ringing_shared_room(name, prof, chunk, monkeypatch):
    path = str(SAMPLES / name)
    profile = load_profile(prof)
    got, n_chunks = _figures(path, profile, monkeypatch, "shared", chunk)
    for layout in ("own rooms", "python rows"):
        want, _ = _figures(path, profile, monkeypatch, layout, chunk)
        same(got, want, layout)
    if chunk < rg.CHUNK_BLOCKS:
        assert n_chunks > 3
    core = res._core()
    if core is not None and hasattr(core, "ring_release"):
        assert core.ring_release() == 0           # figures() gave the room back already


def test_ring_room_clears_the_last_writer():
    room = res.RingRoom()
    a, b = res.RingMemo(room), res.RingMemo(room)
    a.key, a.amps = ("k",), ("x",)
    a.out(10)
    a.key, a.amps = ("k",), ("x",)
    a.out(12)                                       # its own room again: kept
    assert a.key == ("k",)
    b.out(5)                                        # another memo writes: a's numbers go
    assert a.key is None and a.amps is None
    assert len(room.arr) >= 5 * 12 + 4 * 11
    c = res.RingMemo()
    assert c.shared is not room
