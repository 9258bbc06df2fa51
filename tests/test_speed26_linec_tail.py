"""Issue 8 (s26, "linec"): segments._jerk_rows' tail (held accelerations, tent feeds,
predicted figures, verdicts of the line plans made in rows) in one compiled call a block
(firmware/_core.c jerk_tail) instead of ~25 numpy calls.

The reference is the numpy path (segments._jerk_tail: hold_cruise_accels_rows,
tent_feeds_rows, _predict_rows, fine_rows), compared bit for bit on random blocks made to
reach every branch (cruise runs at the start, in the middle, whole rows; steps infinite,
NaN, zero, negative, shared and per row; NaN and inf knots; rows of 3..140 knots, past the
8 and 128 of numpy's pairwise sum), on the rows the planner makes from sample files
(through plan_segments, core on and off), and with GCODE_OPT_PURE_PYTHON=1."""
import os
import subprocess
import sys

import numpy as np
import pytest

from gcode_opt import pipeline, schedule, segments
from gcode_opt.profile import load_profile

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")

core = segments._rows_core()
needs_core = pytest.mark.skipif(core is None, reason="compiled core not built")


def _bits(x):
    return np.asarray(x, float).view(np.int64)


def _same_bits(x, y):
    """Bit for bit, but a NaN is any NaN: a NaN a plan holds makes it faulty (fine_rows,
    schedule.seg_fault: only isfinite is read), and its sign bit is the one x86 gives a NaN
    made by an operation or the one an operand carried, which numpy's loops and C need not
    agree on."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    assert x.shape == y.shape
    nx, ny = np.isnan(x), np.isnan(y)
    assert np.array_equal(nx, ny)
    assert np.array_equal(_bits(x)[~nx], _bits(y)[~ny])


def _same(a, b):
    for x, y in zip(a[:2], b[:2]):
        assert x.dtype == y.dtype
        _same_bits(x, y)
    _same_bits(a[2], b[2])
    _same_bits(a[3], b[3])
    assert a[4] == b[4]


def _block(rng, m, K, wild):
    ds = rng.random((m, K - 1)) * 10 ** rng.uniform(-3, 1, (m, 1))
    S = np.concatenate([np.zeros((m, 1)), np.cumsum(ds, axis=1)], axis=1)
    V = rng.random((m, K)) * 10 ** rng.uniform(-2, 2.5, (m, 1))
    V[rng.random((m, K)) < 0.05] = 0.0
    acc = rng.random((m, K - 1)) * 10 ** rng.uniform(-8, 4, (m, K - 1))
    cruise = rng.random((m, K - 1)) < 0.25
    acc[cruise] = rng.choice([0.0, 1e-7, 1e-6, -0.0], int(cruise.sum()))
    acc[rng.random(m) < 0.05] = 0.0                          # whole rows cruising
    accel = rng.random(m) * 3000 + 1
    step = rng.random(m) * 20
    v_feed = rng.random(m) * 200
    if wild:
        acc[rng.random((m, K - 1)) < 0.02] = np.nan
        S[rng.random((m, K)) < 0.01] = rng.choice([np.nan, np.inf, -1.0])
        V[rng.random((m, K)) < 0.01] = rng.choice([np.nan, np.inf, -1.0])
        step[rng.random(m) < 0.1] = rng.choice([np.inf, np.nan, 0.0, -0.0, -2.0])
        accel[rng.random(m) < 0.05] = np.nan
    return S, V, acc, accel, step, v_feed


@needs_core
@pytest.mark.parametrize("seed", range(30))
def test_tail_random(seed):
    rng = np.random.default_rng(seed)
    K = int(rng.choice([3, 4, 5, 8, 9, 10, 11, 13, 17, 24, 40, 129, 130, 140]))
    m = int(rng.integers(1, 60))
    S, V, acc, accel, step, v_feed = _block(rng, m, K, wild=seed % 2 == 1)
    if seed % 5 == 0:
        step[:] = step[0]                 # one step for the whole block (tent's grouped path)
    ref = segments._jerk_tail(S, V, acc, accel, step, v_feed)
    got = segments._jerk_tail_core(core, S, V, acc, accel, step, v_feed)
    _same(got, ref)
    assert segments._jerk_tail(S, V, acc, accel, step, v_feed)[4] == got[4]
    if seed % 2 == 0:
        assert any(got[4])                # plans that pass: the checks are compared on both


@needs_core
def test_tail_fails_on_a_changed_sum(monkeypatch):
    """The comparison can fail: a row's sum in another order differs somewhere."""
    rng = np.random.default_rng(7)
    S, V, acc, accel, step, v_feed = _block(rng, 400, 12, wild=False)
    ref = segments._jerk_tail(S, V, acc, accel, step, v_feed)
    monkeypatch.setattr(segments, "_predict_rows", lambda S, V, A: (
        [float(sum(r)) for r in segments.segment_times(S, V, A)[0]],
        [float(sum(r)) for r in (lambda t, a, dv: a * dv)(*segments.segment_times(S, V, A))]))
    other = segments._jerk_tail(S, V, acc, accel, step, v_feed)
    assert other[2] != ref[2]


def _plans(name, prof, use_core, monkeypatch):
    monkeypatch.setattr(segments, "USE_CORE", use_core)
    profile = load_profile(prof)
    opts = pipeline.Options()
    opts.ringing = False
    strokes, sim0 = pipeline.analyse(os.path.join(SAMPLES, name), profile, opts)
    pin = schedule.plan_inputs(strokes, profile, opts)
    runs = []

    def fit(run, pin_, budget_t):
        for r in (1.0, 0.5):
            p = run(r * budget_t)
            runs.append([None if s is None else (type(s).__name__, _bits(s.s).tobytes(), _bits(s.v).tobytes(),
                                                 _bits(s.accel).tobytes(), _bits(s.feed).tobytes(), s.time_t,
                                                 s.int_a2, schedule.seg_fault(s)) for s in p.segs])
        return p
    monkeypatch.setattr(schedule, "_fit_budget", fit)
    calls = []
    jr = segments._jerk_rows
    monkeypatch.setattr(segments, "_jerk_rows", lambda *a, **k: calls.append(1) or jr(*a, **k))
    schedule.plan_strokes(strokes, pin, profile, opts, opts.max_slowdown_r * sim0.time_t)
    monkeypatch.undo()
    return runs, len(calls)


@needs_core
@pytest.mark.parametrize("name,prof", [("prusa_mk3s_rectilinear.gcode", "prusa-mk3s"),
                                       ("prusa_benchy_like.gcode", "prusa-mk3s")])
def test_plans_as_numpy(name, prof, monkeypatch):
    ref, n_ref = _plans(name, prof, False, monkeypatch)
    got, n_got = _plans(name, prof, True, monkeypatch)
    assert n_got == n_ref > 0              # blocks went through the rows' path
    assert sum(s is not None and s[0] == "RowPlan" for s in got[0]) > 100
    assert got == ref


def test_pure_python_same_output(tmp_path):
    """The whole command with and without the compiled cores: the same G-code bytes."""
    src = os.path.join(SAMPLES, "prusa_mk3s_rectilinear.gcode")
    outs = []
    for pure in ("0", "1"):
        out = tmp_path / f"out{pure}.gcode"
        env = dict(os.environ, GCODE_OPT_PURE_PYTHON=pure)
        subprocess.run([sys.executable, "-m", "gcode_opt", "process", src, "-o", str(out), "--profile",
                        "prusa-mk3s", "-q"], check=True, env=env, cwd=os.path.join(HERE, ".."))
        outs.append(out.read_bytes())
    assert outs[0] == outs[1]
