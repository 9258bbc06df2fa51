"""chains._tent_rows by the chain core's tent_rows (session 19, issue 8): the envelope
out[r, k] = max over j = -1..n of pad[r, j] - step[r] |k - j| no longer makes the
differences that cannot reach the maximum: from k outwards, it stops at the distance d
where (largest need of the row) - step d is below the maximum so far (the products grow
with d and each rounding is monotone, so every difference from there on is below it).
The maximum of the same differences, which are never nan or -0 here: the same value.
The reference is the numpy envelope of segments.tent_feeds_rows as it stood at ddecd40
(its generic branch, verbatim), on the rows the bundled full-speed gyroid's chains hand
_tent_rows under classic jerk and on random rows built for ties, exact bounds and maxima
far from k (whole-row cones); mutants of the stop rule fail it."""
import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.laws import chain as lc

pytestmark = pytest.mark.skipif(lc.CORE_MOD is None, reason=f"the chain core is not used here ({lc.CORE_WHY})")

from test_speed_chains import _chain_problems  # noqa: E402


# ---------------------------------------------------------------- the reference (ddecd40)
_TENT_DIST: dict[int, np.ndarray] = {}    # tent_feeds' distance matrices by segment count


def _tent_dist(n):
    """|k - j| for k segments and j = -1..n (the ends), cached by n."""
    dist = _TENT_DIST.get(n)
    if dist is None:
        dist = _TENT_DIST[n] = np.abs(np.arange(n)[:, None] - np.arange(-1, n + 1)[None, :])
    return dist


def ref_tent_feeds_rows(need, v_feed, step_v, max_cells=4_000_000):
    """tent_feeds of every row of need (k, n): (rows, n, n + 2) envelopes of at most
    max_cells cells at a time.  A max of the same differences: the same numbers.  v_feed
    and step_v: one value, or one per row (rows of several chains)."""
    if np.ndim(step_v) == 0 and np.ndim(v_feed) == 0:
        if not np.isfinite(step_v):
            return need
    k, n = need.shape
    step = np.broadcast_to(np.asarray(step_v, float), (k,))
    vf = np.broadcast_to(np.asarray(v_feed, float), (k,))
    out = np.array(need, float)
    live = np.flatnonzero(np.isfinite(step))        # an infinite step leaves the row as it is
    ar = _tent_dist(n)
    per = max(1, max_cells // max(n * (n + 2), 1))
    for a in range(0, live.size, per):
        r = live[a:a + per]
        side = (vf[r] + step[r])[:, None]
        pad = np.concatenate([side, need[r], side], axis=1)
        dist = step[r][:, None, None] * ar[None, :, :]
        out[r] = np.max(pad[:, None, :] - dist, axis=2)
    return out


# ---------------------------------------------------------------- checks
def _same(need, vf, step):
    got = chains._tent_rows(need, vf, step)
    want = ref_tent_feeds_rows(need, vf, step)
    assert got.shape == want.shape
    assert np.array_equal(got.view(np.int64), want.view(np.int64))


def test_rows_of_real_chains(monkeypatch):
    sts, T0, profile = _chain_problems("prusa-mk3s")          # classic jerk: finite steps
    calls = []
    orig = chains._tent_rows

    def rec(need, v_feed, step_v, core=None):
        calls.append((np.array(need), np.array(v_feed), np.array(step_v)))
        return orig(need, v_feed, step_v, core)
    monkeypatch.setattr(chains, "_tent_rows", rec)
    # the numpy finishing (the chain core's chain_finish does its tent itself: checked in
    # test_speed21_chainfin_core.py); here the tent's own inputs are what is recorded
    monkeypatch.setattr(chains, "_finish_core", lambda *a, **k: None)
    rules = chains.SegmentRules.for_profile(profile, 10)
    for r in (1.0, 1.05):
        T = T0 * r
        laws = chains.solve(sts, T, (T / chains.GAMMA_MIN) ** 2, profile)
        chains.finish_groups([(st, [lw]) for st, lw in zip(sts, laws)], rules, profile)
    monkeypatch.setattr(chains, "_tent_rows", orig)
    assert len(calls) >= 3 and sum(c[0].size for c in calls) > 1000
    for need, vf, step in calls:
        assert np.all(np.isfinite(step)) and np.all(step > 0)       # the core's case
        _same(need, vf, step)


def _rows(rng, R, n):
    kind = rng.integers(0, 6, R)
    need = rng.uniform(10.0, 200.0, (R, n))
    step = rng.uniform(0.5, 20.0, R)
    for r in range(R):
        if kind[r] == 1:            # one large need at the far end: its cone spans the row
            need[r] = rng.uniform(1.0, 2.0, n)
            need[r, -1 if r % 2 else 0] = 500.0
            step[r] = 1e-3
        elif kind[r] == 2:          # exact arithmetic: ties and bounds met with equality
            step[r] = 2.0 ** int(rng.integers(-2, 4))
            need[r] = 64.0 + step[r] * rng.integers(0, 8, n)
        elif kind[r] == 3:          # a flat row
            need[r] = 100.0
        elif kind[r] == 4:          # a tiny step: nothing is pruned
            step[r] = 1e-12
        elif kind[r] == 5:          # a huge step: everything is
            step[r] = 1e6
    vf = rng.uniform(1.0, 300.0, R)
    vf[::4] = need.max(axis=1)[::4] * 2.0          # the ends above every need
    return need, vf, step


@pytest.mark.parametrize("n", [1, 2, 3, 5, 16, 47, 88])
def test_random_rows_with_ties_and_far_maxima(n):
    rng = np.random.default_rng(n)
    need, vf, step = _rows(rng, 300, n)
    _same(need, vf, step)
    _same(need, float(vf[0]), float(step[0]))               # one feed and step for all rows
    _same(need[::-1].copy(), vf[::-1].copy(), step[::-1].copy())


# ---------------------------------------------------------------- two small ones in chains.py
def test_knots_s_as_concatenate():
    from array import array
    rng = np.random.default_rng(4)
    for e in (array("d"), array("d", (1.5,)), array("d", np.cumsum(rng.uniform(0, 1, 40)).tolist()),
              [0.5, 1.0], np.array([0.25, 2.0]), array("f", (1.0, 2.5))):
        want = np.concatenate([[0.0], np.asarray(e, float)])
        got = chains._knots_s(e)
        assert got.dtype == want.dtype and got.shape == want.shape and got.flags.writeable
        assert np.array_equal(got.view(np.int64), want.view(np.int64))


def test_classify_marks_the_same_chains():
    """classify with np.minimum.reduce marks the strokes np.min's test marked (ddecd40's
    test, verbatim, on the bundled gyroid's curve strokes under both junction laws)."""
    from gcode_opt import curves
    from gcode_opt.pipeline import Options, analyse
    from gcode_opt.profile import load_profile
    from gcode_opt.strokes import K_CURVE
    for prof in ("prusa-mk3s", "voron24"):
        profile = load_profile(prof)
        opts = Options()
        opts.ringing = False
        strokes, _ = analyse("sample_gcode/prusa_gyroid_fullspeed.gcode", profile, opts)
        rows = list(range(len(strokes)))
        chains.classify(strokes, rows, profile)
        got = [st.chain_T is not None for st in strokes]
        want = []
        for st in strokes:
            ok = False
            if st.kind == K_CURVE:
                caps = curves.geom(st, profile).caps
                ok = bool(caps.size and curves.CAP_MARGIN * float(np.min(caps)) < st.v_feed)
            want.append(ok)
        assert got == want and sum(got) > 50
