"""Issue 8 (s26, "linec"): segments._law_sv evaluates the cubic line laws (beta = inf,
~90 % of the rectilinear plate's re-timed lines) by _cubic_sv, eval's own operations with
gamma = 0 taken out (every shc 1.0, the series at their first terms), the others by their
LineLaw.

The reference is LineLaw.eval itself (laws/line.py) on the whole batch: random batches of
cubic, small-gamma and large-gamma laws mixed (and all of one kind), knot grids as
_law_knot_blocks makes them, compared bit for bit; the ValueErrors a bad law raises; and
segments.law_knots on the rectilinear sample's strokes with _law_sv swapped for the old
call."""
import os

import numpy as np
import pytest

from gcode_opt import pipeline, schedule, segments
from gcode_opt.laws.line import line_law
from gcode_opt.profile import load_profile

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "sample_gcode")


def _old_sv(L, T, beta, v0, v1, t):
    law = line_law(L[:, None], T[:, None], beta[:, None], v0[:, None], v1[:, None])
    return law.eval(t, "sv")[:2]


def _bits(x):
    return np.asarray(x, float).view(np.int64)


def _batch(rng, m, mix):
    L = rng.random(m) * 10 ** rng.uniform(-2, 2, m)
    T = rng.random(m) * 10 ** rng.uniform(-3, 0.5, m) + 1e-4
    v0 = rng.random(m) * 200 * (rng.random(m) < 0.8)
    v1 = rng.random(m) * 200 * (rng.random(m) < 0.8)
    gamma = np.choose(rng.integers(0, 3, m) if mix == "all" else np.full(m, mix),
                      [np.zeros(m), rng.uniform(1e-4, 3.999, m), rng.uniform(4.0, 60.0, m)])
    with np.errstate(divide="ignore"):
        beta = np.where(gamma == 0, np.inf, (T / np.where(gamma == 0, 1.0, gamma)) ** 2)
    n = rng.integers(2, 14, m)
    j = np.arange(n.max() + 1)
    tau = np.minimum(j[None, :] / n[:, None], 1.0)
    return L, T, beta, v0, v1, tau * T[:, None]


@pytest.mark.parametrize("seed", range(24))
def test_law_sv_as_eval(seed):
    rng = np.random.default_rng(seed)
    mix = ["all", 0, 1, 2][seed % 4]
    args = _batch(rng, int(rng.integers(1, 400)), mix)
    with np.errstate(all="ignore"):
        ref = _old_sv(*args)
        got = segments._law_sv(*args)
    for a, b in zip(ref, got):
        assert a.shape == b.shape
        assert np.array_equal(_bits(a), _bits(b))
    if mix in ("all", 0):
        assert (args[2] == np.inf).any()          # the cubic path was taken


def test_cubic_sv_can_fail():
    """A cube made as x * x * x instead of x ** 3 gives other bits somewhere."""
    rng = np.random.default_rng(3)
    L, T, beta, v0, v1, t = _batch(rng, 500, 0)
    ref = _old_sv(L, T, beta, v0, v1, t)
    tau = np.clip(t / T[:, None], 0.0, 1.0)
    x = tau - 0.5
    assert not np.array_equal(x ** 3, x * x * x)
    got = segments._cubic_sv(L, T, v0, v1, t)
    assert np.array_equal(_bits(ref[0]), _bits(got[0]))


@pytest.mark.parametrize("bad", ["T0", "Tinf", "beta0", "Lnan", "v0inf"])
def test_law_sv_raises_as_linelaw(bad):
    rng = np.random.default_rng(1)
    L, T, beta, v0, v1, t = _batch(rng, 20, "all")
    beta[0] = np.inf
    {"T0": lambda: T.__setitem__(3, 0.0), "Tinf": lambda: T.__setitem__(3, np.inf),
     "beta0": lambda: beta.__setitem__(3, 0.0), "Lnan": lambda: L.__setitem__(3, np.nan),
     "v0inf": lambda: v0.__setitem__(3, np.inf)}[bad]()
    with np.errstate(all="ignore"):
        with pytest.raises(ValueError) as e_old:
            _old_sv(L, T, beta, v0, v1, t)
        with pytest.raises(ValueError) as e_new:
            segments._law_sv(L, T, beta, v0, v1, t)
    assert str(e_old.value) == str(e_new.value)


def test_law_knots_on_sample(monkeypatch):
    profile = load_profile("prusa-mk3s")
    opts = pipeline.Options()
    opts.ringing = False
    strokes, _ = pipeline.analyse(os.path.join(SAMPLES, "prusa_mk3s_rectilinear.gcode"), profile, opts)
    pin = schedule.plan_inputs(strokes, profile, opts)
    rows = [i for i, s in enumerate(strokes) if s.kind == "line"][:3000]
    sts = [strokes[i] for i in rows]
    T = pin.T_orig[rows] * 1.1
    rng = np.random.default_rng(0)
    beta = np.where(rng.random(len(rows)) < 0.8, np.inf, (T / rng.uniform(0.01, 30, len(rows))) ** 2)
    rules = segments.SegmentRules.for_profile(profile, opts.max_segments)
    n = segments._segment_counts(sts, T, rules)
    ok = np.flatnonzero(n >= 2)
    sts = [sts[i] for i in ok]
    got = segments.law_knots(sts, T[ok], beta[ok], n[ok])
    monkeypatch.setattr(segments, "_law_sv", _old_sv)
    ref = segments.law_knots(sts, T[ok], beta[ok], n[ok])
    assert len(got) == len(ref) > 1000
    for (s1, v1), (s2, v2) in zip(got, ref):
        assert np.array_equal(_bits(s1), _bits(s2)) and np.array_equal(_bits(v1), _bits(v2))


# ------------------------------------------------------------ plan._live_tables' figures
from gcode_opt import plan as plan_mod          # noqa: E402
from gcode_opt.laws.line import cubic_figures   # noqa: E402


def _figures_old(L, T, beta, v0, v1):
    law = line_law(L, T, beta, v0, v1)
    return (law.peak_accel(), *law.integrals())


@pytest.mark.parametrize("seed", range(24))
def test_law_figures_as_linelaw(seed):
    rng = np.random.default_rng(100 + seed)
    mix = ["all", 0, 1, 2][seed % 4]
    L, T, beta, v0, v1, _ = _batch(rng, int(rng.integers(1, 2000)), mix)
    with np.errstate(all="ignore"):
        ref = _figures_old(L, T, beta, v0, v1)
        got = plan_mod._law_figures(L, T, beta, v0, v1)
    for a, b in zip(ref, got):
        assert np.array_equal(_bits(a), _bits(b))


def test_cubic_figures_premises():
    """cosh(±0) is 1.0 in numpy's loops (cubic_figures takes h' = 2 at the ends)."""
    z = np.array([0.0, -0.0] * 40)
    assert (np.cosh(z) == 1.0).all() and (np.cosh(z[:3]) == 1.0).all()
    rng = np.random.default_rng(5)
    L, T, beta, v0, v1, _ = _batch(rng, 300, 0)
    ref = _figures_old(L, T, beta, v0, v1)
    got = cubic_figures(L, T, v0, v1)
    for a, b in zip(ref, got):
        assert np.array_equal(_bits(a), _bits(b))


def test_candidates_on_sample():
    """The line candidates of the rectilinear sample (_candidates_auto, its _live_tables)
    with _law_figures and with the LineLaw of every entry: the same tables."""
    profile = load_profile("prusa-mk3s")
    opts = pipeline.Options()
    opts.ringing = False
    strokes, _ = pipeline.analyse(os.path.join(SAMPLES, "prusa_mk3s_rectilinear.gcode"), profile, opts)
    pin = schedule.plan_inputs(strokes, profile, opts)
    rows = schedule._rows_by_kind(strokes)["line"]
    got = plan_mod.candidates_auto(pin.take(rows))
    mp = pytest.MonkeyPatch()
    mp.setattr(plan_mod, "_law_figures", _figures_old)
    try:
        ref = plan_mod.candidates_auto(pin.take(rows))
    finally:
        mp.undo()
    assert np.isinf(got[1]).sum() > 1000 and np.isfinite(got[2]).sum() > 1000
    for a, b in zip(ref, got):
        assert np.array_equal(_bits(a), _bits(b))
