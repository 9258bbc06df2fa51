"""Issue 8, stop 18 (D8): segments.tent_feeds_rows on many rows goes one offset |k - j| at a
time (_tent_by_offsets) instead of through a (rows, n, n + 2) array.  The same bits as
9bb98a8's form, copied below, on every input (the old form where the new one cannot be
sure of them: a zero, a negative or NaN need, a step <= 0)."""
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


@pytest.mark.parametrize("seed", range(6))
def test_same_bits_as_the_dense_envelope(seed):
    rng = np.random.default_rng(seed)
    for _ in range(60):
        k, n = int(rng.integers(1, 400)), int(rng.integers(1, 90))
        need = rng.uniform(0.1, 250.0, (k, n))
        if rng.random() < 0.3:                                # slicer-like: speeds on a 0.1 grid
            need = np.round(need, 1) + 0.1
        step = rng.choice([1.2, 0.75, 3.0, 0.013]) if rng.random() < 0.5 else rng.uniform(0.01, 5.0, k)
        vf = rng.uniform(10.0, 200.0, k) if rng.random() < 0.5 else float(rng.uniform(10.0, 200.0))
        if rng.random() < 0.2 and np.ndim(step):
            step = step.copy()
            step[rng.integers(k)] = np.inf                    # a row left as it is
        got = segments.tent_feeds_rows(need, vf, step)
        assert _bits(got, _old_tent_feeds_rows(need, vf, step)), (k, n)


def test_large_batches_take_the_offsets():
    """The shapes the chains make on the gyroid plate (k x n up to ~1500 x 88) go by
    offsets, and give the dense form's bits."""
    rng = np.random.default_rng(9)
    calls = []
    real = segments._tent_by_offsets
    try:
        segments._tent_by_offsets = lambda *a: calls.append(a[0].shape) or real(*a)
        for k, n in ((1488, 76), (300, 88), (40, 47)):
            need = np.maximum(rng.uniform(-50.0, 200.0, (k, n)), segments.MIN_FEED_V)
            vf = rng.uniform(50.0, 150.0, k)
            assert _bits(segments.tent_feeds_rows(need, vf, 1.2), _old_tent_feeds_rows(need, vf, 1.2))
        assert calls == [(1488, 76), (300, 88), (40, 47)]
        assert _bits(segments.tent_feeds_rows(need[:10, :10], vf[:10], 1.2),
                     _old_tent_feeds_rows(need[:10, :10], vf[:10], 1.2))
        assert len(calls) == 3                                # small: the dense form
    finally:
        segments._tent_by_offsets = real


@pytest.mark.parametrize("what", ["zero", "negzero", "negative", "nan", "step0", "stepneg"])
def test_inputs_the_offsets_do_not_take(what):
    rng = np.random.default_rng(1)
    k, n = 200, 40
    need = rng.uniform(0.1, 200.0, (k, n))
    step = np.full(k, 1.2)
    if what == "zero":
        need[3, 5] = 0.0
    elif what == "negzero":
        need[7] = -0.0
    elif what == "negative":
        need[3, 5] = -4.0
    elif what == "nan":
        need[3, 5] = np.nan
    elif what == "step0":
        step[2] = 0.0
    else:
        step[2] = -1.0
    got = segments.tent_feeds_rows(need, 60.0, step)
    want = _old_tent_feeds_rows(need, 60.0, step)
    assert _bits(got, want) or (np.isnan(got) == np.isnan(want)).all() and _bits(np.nan_to_num(got),
                                                                                  np.nan_to_num(want))


def test_envelope_meaning():
    """Independent of both forms: feeds >= need, neighbours within the step, the ends at
    least the slicer's feed, and each feed the tent max_j(need_j - step |k - j|) by brute
    force."""
    rng = np.random.default_rng(2)
    need = rng.uniform(1.0, 100.0, (300, 30))
    vf, step = 40.0, 2.5
    got = segments.tent_feeds_rows(need, vf, step)
    assert (got >= need).all()
    assert (np.abs(np.diff(got, axis=1)) <= step * (1 + 1e-12)).all()
    assert (got[:, 0] >= vf).all() and (got[:, -1] >= vf).all()          # the slicer's feed at both ends
    k = np.arange(30)
    brute = np.max(np.concatenate([need, np.full((300, 1), vf + step), np.full((300, 1), vf + step)], axis=1)[:, None, :]
                   - step * np.abs(k[:, None] - np.r_[k, -1, 30][None, :]), axis=2)
    assert np.allclose(got, brute, rtol=0, atol=1e-12)
