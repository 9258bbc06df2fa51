"""curves.vertex_caps (vectorised) gives the same bits as the scalar per-vertex
curves.vertex_cap, which calls the firmware junction laws (firmware/junction.py), for
every junction model, on polylines with straight runs, reversals, short and long
segments, and per-axis acceleration caps that bind."""
import dataclasses
import math

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt.profile import load_profile
from gcode_opt.state import Limits


def _polyline(rng, n):
    turn = rng.choice([0.0, 1e-7, 0.05, 0.3, 0.5, 1.0, 2.5, math.pi, -0.4, -math.pi / 2], size=n)
    turn = np.where(rng.random(n) < 0.5, rng.normal(0.0, 0.3, n), turn)
    head = np.cumsum(turn)
    d = rng.choice([0.001, 0.3, 0.7, 0.999, 1.0, 1.5, 5.0], size=n) * rng.uniform(0.5, 1.5, n)
    seg = np.c_[np.cos(head), np.sin(head)] * d[:, None]
    seg[rng.random(n) < 0.1] = [1.0, 0.0]          # exact axis moves, exact straight runs
    seg[rng.random(n) < 0.05] = [0.0, -2.0]
    d = np.hypot(seg[:, 0], seg[:, 1])
    return seg / d[:, None], d


@pytest.mark.parametrize("junction", ["scv", "jd", "jerk"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_vertex_caps_bitwise_equal_to_scalar(junction, seed):
    rng = np.random.default_rng(seed)
    prof = dataclasses.replace(load_profile("generic-marlin"), junction=junction)
    u, d = _polyline(rng, 400)
    for ax, ay, accel in ((20000.0, 20000.0, 1500.0), (900.0, 1300.0, 2500.0), (5000.0, 700.0, 0.0)):
        lim = Limits(300.0, ax, ay, 5.0, 0.5, 0.02, 8.0, 10.0)
        for jerk_r in (0.85, 1.0):
            want = np.array([curves.vertex_cap(prof, lim, accel, tuple(u[k]), tuple(u[k + 1]), d[k], d[k + 1],
                                               jerk_r) for k in range(len(d) - 1)], float)
            got = curves.vertex_caps(prof, lim, accel, u, d, jerk_r)
            assert got.shape == want.shape
            assert got.tobytes() == want.tobytes(), np.flatnonzero(got != want)[:5]


def test_vertex_caps_non_finite_takes_scalar_path():
    prof = load_profile("prusa-mk3s")
    lim = Limits(200.0, 1000.0, 1000.0, 5.0, 0.5, 0.02, 8.0, 8.0)
    u = np.array([[1.0, 0.0], [np.nan, np.nan], [0.0, 1.0]])
    d = np.array([1.0, 0.0, 1.0])
    want = [curves.vertex_cap(prof, lim, 1000.0, tuple(u[k]), tuple(u[k + 1]), d[k], d[k + 1]) for k in range(2)]
    got = curves.vertex_caps(prof, lim, 1000.0, u, d)
    assert np.asarray(want, float).tobytes() == got.tobytes()


class _St:
    def __init__(self, lim, accel):
        self.lim, self.accel = lim, accel


@pytest.mark.parametrize("junction", ["scv", "jd", "jerk"])
def test_batch_caps_equal_stroke_by_stroke(junction):
    """Strokes of different limits, accelerations and lengths (1 segment too) in one pass."""
    rng = np.random.default_rng(7)
    prof = dataclasses.replace(load_profile("generic-marlin"), junction=junction)
    sts, us, ds = [], [], []
    for k, n in enumerate((1, 2, 14, 3, 40, 1, 9)):
        u, d = _polyline(rng, n)
        lim = Limits(300.0, rng.uniform(500, 9000), rng.uniform(500, 9000), rng.uniform(2, 9), 0.5,
                     rng.uniform(0.01, 0.1), rng.uniform(5, 12), rng.uniform(5, 12))
        sts.append(_St(lim, [0.0, 800.0, 2500.0][k % 3]))
        us.append(u)
        ds.append(d)
    for jerk_r in (0.85, 1.0):
        got = curves.batch_caps(sts, prof, us, ds, jerk_r)
        assert len(got) == len(sts)
        for st, u, d, g in zip(sts, us, ds, got):
            want = np.array([curves.vertex_cap(prof, st.lim, st.accel, tuple(u[k]), tuple(u[k + 1]), d[k], d[k + 1],
                                               jerk_r) for k in range(len(d) - 1)], float)
            assert g.tobytes() == want.tobytes()


def test_median_equals_numpy():
    rng = np.random.default_rng(23)
    for n in range(1, 120):
        for _ in range(5):
            x = rng.uniform(0.001, 3.0, n) * 10.0 ** rng.uniform(-3, 3)
            if rng.random() < 0.5:
                x = np.round(x, 3)                 # ties, as slicers' rounded lengths
            assert curves._median(x) == float(np.median(x))
