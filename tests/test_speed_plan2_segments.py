"""Round 2 of issue 8's planning CPU in segments.py: the per-stroke helpers (predict,
ramp_accels, rounding_junction_accels, tent_feeds) without np.diff / np.sum / np.max's
per-call overhead and with tent_feeds' distance matrix cached by segment count.  The
start commit's forms (a071b70) are kept here as references; same bits required."""
import numpy as np
import pytest

from gcode_opt import segments


def _predict_ref(s, v, a):
    d = np.diff(s)
    dv = np.abs(np.diff(v))
    vmax = np.maximum(v[:-1], v[1:])
    a = np.maximum(a, 1e-12)
    ramp_d = np.abs(np.diff(v * v)) / (2.0 * a)
    t = dv / a + np.maximum(d - ramp_d, 0.0) / np.maximum(vmax, 1e-9)
    return float(np.sum(t)), float(np.sum(a * dv))


def _ramp_ref(s, v):
    d = np.diff(s)
    return np.abs(np.diff(v * v)) / (2.0 * d)


def _rounding_ref(s, v):
    d = np.diff(s)
    need = np.zeros(d.size)
    if d.size < 2:
        return need
    theta = segments.ROUND_TURN_D / np.minimum(d[:-1], d[1:])
    v2 = v[1:-1] ** 2
    need[:-1] = np.maximum(need[:-1], v2 * theta / d[:-1])
    need[1:] = np.maximum(need[1:], v2 * theta / d[1:])
    return need


def _tent_ref(need, v_feed, step_v):
    if not np.isfinite(step_v):
        return need
    n = len(need)
    k = np.arange(n)
    pad = np.concatenate([[v_feed + step_v], need, [v_feed + step_v]])
    j = np.arange(-1, n + 1)
    return np.max(pad[None, :] - step_v * np.abs(k[:, None] - j[None, :]), axis=1)


def _same(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape
    assert np.array_equal(a.view(np.int64), b.view(np.int64))


def _strokes(seed, count=400):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        n = int(rng.integers(1, 200))               # segments; > 128 reaches the pairwise sum's blocks
        s = np.concatenate([[0.0], np.cumsum(rng.uniform(1e-3, 3.0, n))])
        v = rng.uniform(0.0, 250.0, n + 1)
        v[rng.random(n + 1) < 0.1] = 0.0
        a = rng.uniform(0.0, 5000.0, n)
        yield s, v, a, float(rng.uniform(1.0, 200.0)), float(rng.choice([rng.uniform(0.5, 20.0), np.inf]))


@pytest.mark.parametrize("seed", [0, 1])
def test_segment_helpers_same_bits(seed):
    for s, v, a, v_feed, step_v in _strokes(seed):
        t, i2 = segments.predict(s, v, a)
        tr, i2r = _predict_ref(s, v, a)
        assert t.hex() == tr.hex() and i2.hex() == i2r.hex()
        with np.errstate(divide="ignore", invalid="ignore"):
            _same(segments.ramp_accels(s, v), _ramp_ref(s, v))
        _same(segments.rounding_junction_accels(s, v), _rounding_ref(s, v))
        need = np.maximum(np.maximum(v[:-1], v[1:]), segments.MIN_FEED_V)
        _same(segments.tent_feeds(need, v_feed, step_v), _tent_ref(need, v_feed, step_v))
        _same(segments.tent_feeds(need, v_feed, step_v), _tent_ref(need, v_feed, step_v))   # cached matrix


def test_diff_takes_lists():
    _same(segments._diff([0.0, 1.5, 4.0]), np.diff([0.0, 1.5, 4.0]))
    assert segments._diff(np.array([2.0])).size == 0
