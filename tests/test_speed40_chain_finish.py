"""Session 40 (chain): chain_finish's shaping tail and the jerk tent's first step as vector
passes give the same bits.

- cf_clamp: the feeds' floor (min_feed), the accelerations' cap (a_top) and the row's fit
  test (every acceleration <= a_top (1 + SPEED_TOL_R)) over a row at once, after the
  trapezoids tried on the bumps (scv), not in the bumps' scalar loop;
- cf_tent_base: the tent's two side ramps at each segment and its search's first step
  (dd = 0: the segment's own feed) over a row at once, the search going on from dd = 1;
- cf_pos_max: the row's largest feed (the search's bound) as a vector maximum.
Against the numpy code the core stands for (test_speed21_chainfin_core's verbatim
reference), bit for bit, on real batches perturbed as test_speed21 does and so that rows do
and do not fit, feeds
sit on the floor (near-stops), and feeds along a row differ by up to ~20x (the tent's
search runs many steps; its side ramps bind on short rows), for both junction rules."""
import numpy as np
import pytest

from test_speed21_chainfin_core import CASES, _batches, _perturbed, _ref_finish_stacked_dt, _same

from gcode_opt import chains
from gcode_opt.laws import chain as chain_law
from gcode_opt.plan import SPEED_TOL_R

CORE = chain_law.CORE_MOD
needs_core = pytest.mark.skipif(CORE is None or not hasattr(CORE, "chain_finish"), reason="no chain core")


def _rough(b, rng):
    """b with half its rows' knot speeds spread (0.05 .. 1 times their own: a tent search of
    many steps; a near-stop at one knot in ten: the feed floor), a fifth of its rows'
    durations cut short (rows that do not fit) and a third of its rows slowed but for their
    first or last segment (the tent's largest feed at an end of the row)."""
    sts, gs, own, vk, tk, rules, prof, predict = b
    R = vk.shape[0]
    vk, tk = vk.copy(), tk.copy()
    spread = rng.random(R) < 0.5
    vk[spread] *= rng.uniform(0.05, 1.0, vk[spread].shape)
    slow = spread[:, None] & (rng.random(vk.shape) < 0.1)
    vk[slow] *= 1e-6
    tk[rng.random(R) < 0.2] *= 0.05
    peak = rng.random(R) < 0.3                     # the row's fastest feed at one of its ends
    vk[peak] *= 0.3
    ends = rng.random(R) < 0.5
    vk[peak & ends, -2:] *= 10.0
    vk[peak & ~ends, :2] *= 10.0
    return (sts, gs, own, vk, tk, rules, prof, predict)


@needs_core
@pytest.mark.parametrize("name", list(CASES))
def test_shaping_tail_and_tent_equal_numpy(tmp_path_factory, name):
    rng = np.random.default_rng(4040)
    fit_rows = [0, 0]
    for b in _batches(tmp_path_factory, name)[:12]:
        for p in (_rough(b, rng), _rough(b, rng), _perturbed(b, rng), _perturbed(b, rng)):
            for pr in (True, False):
                q = p[:7] + (pr,)
                got = chains._finish_core(*q)
                want = _ref_finish_stacked_dt(*q)
                if got is None:                    # the core declines (a jerk tent input <= 0)
                    continue
                assert _same(got, want), name
                fits = want[4]
                fit_rows[0] += int(np.sum(fits))
                fit_rows[1] += int(np.sum(~fits))
    assert min(fit_rows) >= 10, fit_rows


def _within_tolerance(b, rng):
    """b with a third of its rows remade: knot 0 as it was, its first segment a ramp (no
    bump: its duration exactly 2 d / (v0 + v1)) whose acceleration is a_top (1 + 1/2
    SPEED_TOL_R), above the cap but within the fit test's slack; the rest a cruise at v1."""
    sts, gs, own, vk, tk, rules, prof, predict = b
    vk, tk = vk.copy(), tk.copy()
    for r in np.flatnonzero(rng.random(vk.shape[0]) < 0.35):
        c = own[r]
        d, a_top = gs[c].d, chains._a_top(sts[c])
        v0 = max(vk[r, 0], 1.0)
        v1 = np.sqrt(v0 * v0 + 2.0 * d[0] * a_top * (1.0 + 0.5 * SPEED_TOL_R))
        vk[r, 0], vk[r, 1:] = v0, v1
        tk[r, 0] = 2.0 * d[0] / (v0 + v1)
        tk[r, 1:] = d[1:] / v1
    return (sts, gs, own, vk, tk, rules, prof, predict)


@needs_core
@pytest.mark.parametrize("name", list(CASES))
def test_fit_test_within_its_slack_equals_numpy(tmp_path_factory, name):
    rng = np.random.default_rng(4041)
    slack_rows = 0
    for b in _batches(tmp_path_factory, name)[:12]:
        p = _within_tolerance(b, rng)
        got = chains._finish_core(*p)
        want = _ref_finish_stacked_dt(*p)
        if got is None:
            continue
        assert _same(got, want), name
        sts, gs, own, vk, tk = p[:5]
        a_top = np.array([chains._a_top(sts[c]) for c in own])
        d0 = np.array([gs[c].d[0] for c in own])
        a_first = np.abs(vk[:, 1] ** 2 - vk[:, 0] ** 2) / (2.0 * d0)
        slack_rows += int(np.sum(want[4] & (a_first > a_top)))      # fit, their first ramp above the cap
    assert slack_rows >= 5
