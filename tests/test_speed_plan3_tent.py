"""Issue 8, stop 18 (D8): segments.tent_feeds_rows shares one distance matrix step x |k - j|
among the rows of one step and subtracts into a reused block (_tent_by_step), ~2x faster
on the gyroid plate's chain batches.  The same bits as 9bb98a8's form, copied below, on
every input (steps of 0 or below keep the per-row form)."""
import numpy as np
import pytest

from gcode_opt import segments


def _old_tent_feeds_rows(need, v_feed, step_v, max_cells=4_000_000):
    if np.ndim(step_v) == 0 and np.ndim(v_feed) == 0:
        if not np.isfinite(step_v):
            return need
    k, n = need.shape
    step = np.broadcast_to(np.asarray(step_v, float), (k,))
    vf = np.broadcast_to(np.asarray(v_feed, float), (k,))
    out = np.array(need, float)
    live = np.flatnonzero(np.isfinite(step))
    ar = segments._tent_dist(n)
    per = max(1, max_cells // max(n * (n + 2), 1))
    for a in range(0, live.size, per):
        r = live[a:a + per]
        side = (vf[r] + step[r])[:, None]
        pad = np.concatenate([side, need[r], side], axis=1)
        dist = step[r][:, None, None] * ar[None, :, :]
        out[r] = np.max(pad[:, None, :] - dist, axis=2)
    return out


def _bits(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("seed", range(5))
def test_same_bits(seed):
    rng = np.random.default_rng(seed)
    for _ in range(80):
        k, n = int(rng.integers(1, 300)), int(rng.integers(1, 90))
        need = rng.uniform(0.1, 250.0, (k, n))
        if rng.random() < 0.3:
            need = np.round(need, 1) + 0.1
        pick = rng.random()
        if pick < 0.4:
            step = float(rng.choice([1.2, 0.75, 3.0, 0.013]))                  # one step (one chain)
        elif pick < 0.7:
            step = rng.choice([1.2, 1.35, 0.9], k)                             # a few steps (several chains)
        else:
            step = rng.uniform(0.01, 5.0, k)                                   # every row its own
        vf = rng.uniform(10.0, 200.0, k) if rng.random() < 0.5 else float(rng.uniform(10.0, 200.0))
        if np.ndim(step) and rng.random() < 0.3:
            step = step.copy()
            step[rng.integers(k)] = np.inf
        if rng.random() < 0.1:
            need[rng.integers(k), rng.integers(n)] = np.nan
        got = segments.tent_feeds_rows(need, vf, step)
        want = _old_tent_feeds_rows(need, vf, step)
        assert _bits(got, want) or (np.isnan(got) == np.isnan(want)).all() and \
            _bits(np.nan_to_num(got), np.nan_to_num(want)), (k, n)


@pytest.mark.parametrize("bad", [0.0, -0.0, -1.0])
def test_steps_not_above_zero_keep_the_row_form(bad):
    rng = np.random.default_rng(3)
    need = rng.uniform(0.1, 200.0, (50, 12))
    need[4] = -0.0
    step = np.full(50, 0.0)
    step[::2] = 1.5
    step[7] = bad
    got = segments.tent_feeds_rows(need, 60.0, step)
    assert _bits(got, _old_tent_feeds_rows(need, 60.0, step))


def test_one_block_reused_for_many_rows():
    """More rows than one block (max_cells small): the block is reused, rows are right."""
    rng = np.random.default_rng(4)
    need = rng.uniform(0.1, 200.0, (500, 30))
    step = rng.choice([1.2, 0.7], 500)
    got = segments.tent_feeds_rows(need, 80.0, step, max_cells=5000)
    assert _bits(got, _old_tent_feeds_rows(need, 80.0, step))


def test_envelope_meaning():
    """Independent of both forms: the brute-force tent max_j(need_j - step |k - j|)
    with the slicer's feed + step at both ends."""
    rng = np.random.default_rng(2)
    need = rng.uniform(1.0, 100.0, (300, 30))
    vf, step = 40.0, 2.5
    got = segments.tent_feeds_rows(need, vf, step)
    assert (got >= need).all() and (np.abs(np.diff(got, axis=1)) <= step * (1 + 1e-12)).all()
    k = np.arange(30)
    ends = np.full((300, 1), vf + step)
    brute = np.max(np.concatenate([need, ends, ends], axis=1)[:, None, :]
                   - step * np.abs(k[:, None] - np.r_[k, -1, 30][None, :]), axis=2)
    assert np.allclose(got, brute, rtol=0, atol=1e-12)
