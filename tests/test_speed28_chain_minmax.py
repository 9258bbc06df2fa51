"""Session 28 (chaincpu): the chain core's np.maximum / np.minimum (np_max, np_min in
laws/_chaincore.c) take both tests without a short cut, a select instead of branches
(chain_finish: ~5 % less time on the gyroid plate's batches).  The same predicate, so the same
bits; here on the ties and signed zeros where a maximum's choice of operand shows: chain_finish
(chains._finish_core) against the numpy code before the core (test_speed21's verbatim copy)
on real batches whose knot speeds are -0.0 / +0.0 at stops, equal to their neighbours, and
whose durations sit exactly on the 1e-12 floor np.maximum(t, 1e-12) takes.  (Measured: np_max
made a minimum fails the voron cases; a tie or NaN rule changed in the predicate passes them:
no NaN reaches chain_finish, which declines non-finite inputs, and on these batches no output
depends on which of two equal zeros a maximum keeps.  The predicate is the old one by
construction: (a >= b || isnan(a)) with both tests taken.)"""
import numpy as np
import pytest

from gcode_opt import chains

from test_speed21_chainfin_core import (CASES, _batches, _ref_finish_stacked_dt, _same,  # noqa: E402
                                        needs_core)


def _ties(b, rng):
    sts, gs, own, vk, tk, rules, prof, predict = b
    vk = vk * rng.uniform(0.8, 1.2, vk.shape)
    tk = tk.copy()
    stop = rng.random(vk.shape) < 0.08
    vk[stop] = np.where(rng.random(int(stop.sum())) < 0.5, -0.0, 0.0)      # signed zeros at stops
    same = rng.random(vk.shape) < 0.1
    same[:, 0] = False
    vk[same] = vk[np.nonzero(same)[0], np.nonzero(same)[1] - 1]              # a knot as fast as the last
    tk[rng.random(tk.shape) < 0.03] = 1e-12                                  # on the floor exactly
    return (sts, gs, own, vk, tk, rules, prof, predict)


@needs_core
@pytest.mark.parametrize("name", ["mk3s", "voron", "voron_buf"])
def test_finish_core_ties_and_signed_zeros_same_bits(tmp_path_factory, name):
    rng = np.random.default_rng(28)
    taken = 0
    for b in _batches(tmp_path_factory, name)[:10]:
        for predict in (True, False):
            p = _ties(b, rng)[:7] + (predict,)
            got = chains._finish_core(*p)
            want = _ref_finish_stacked_dt(*p)
            if got is None:                    # declined (a classic-jerk tent input not > 0): numpy's
                assert _same(chains._finish_stacked_dt(*p), want)
                continue
            taken += 1
            assert _same(got, want)
    assert taken >= 10
    assert name in CASES
