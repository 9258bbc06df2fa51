"""Session 42 (numpy42): curves._parts_block's differences of adjacent row elements
(_segments, np.diff of s_v and of the headings, the mean lengths ell) and seg / d[..., None]
compiled (_curvecore.c lag_rows, div_pairs), as numpy 2 copies strided or broadcast
operands through its iterator buffers row by row: the same bits as the numpy code, and
_parts_block's results the same as with the numpy helpers."""
import numpy as np
import pytest

from gcode_opt import curves


def _bits(a):
    return np.ascontiguousarray(a).view(np.int64)


def _same(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return a.shape == b.shape and bool(((_bits(a) == _bits(b)) | (np.isnan(a) & np.isnan(b))).all())


def _arrays():
    rng = np.random.default_rng(42)
    special = np.array([0.0, -0.0, 1.0, -2.5, np.inf, -np.inf, np.nan, 1e308, -1e308, 5e-324])
    for nb in (0, 1, 3, 17):
        for cols in (1, 2, 3, 5, 8, 33):
            yield rng.standard_normal((nb, cols)) * np.exp(rng.uniform(-50, 50, (nb, 1)))
            yield rng.choice(special, (nb, cols))
            yield np.cumsum(rng.uniform(0.0, 3.0, (nb, cols)), axis=1)


@pytest.mark.skipif(curves._LAG_ROWS is None, reason="curve core not built")
def test_lag_rows_same_bits_as_numpy():
    n = 0
    with np.errstate(all="ignore"):
        for x in _arrays():
            for lag in (1, 2):
                if x.shape[1] < lag:
                    continue
                assert _same(curves._lag_rows(x, lag), x[:, lag:] - x[:, :-lag])
                assert _same(curves._lag_rows(x, lag, add=True), x[:, :-lag] + x[:, lag:])
                if lag == 1:
                    assert _same(curves._lag_rows(x, 1), np.diff(x, axis=1))
                n += 1
    assert n > 100


@pytest.mark.skipif(curves._DIV_PAIRS is None, reason="curve core not built")
def test_div_pairs_same_bits_as_numpy():
    rng = np.random.default_rng(7)
    special = np.array([0.0, -0.0, 1.0, -2.5, np.inf, -np.inf, np.nan, 1e-308, 5e-324])
    with np.errstate(all="ignore"):
        for shape in ((0, 4), (1, 1), (5, 7), (64, 30)):
            seg = rng.standard_normal(shape + (2,)) * np.exp(rng.uniform(-300, 300, shape + (1,)))
            d = np.hypot(seg[..., 0], seg[..., 1])
            assert _same(curves._div_pairs(seg, d), seg / d[..., None])
            seg = rng.choice(special, shape + (2,))
            d = rng.choice(special, shape)
            assert _same(curves._div_pairs(seg, d), seg / d[..., None])


def test_parts_block_same_as_numpy_helpers(monkeypatch):
    """_parts_block with the compiled helpers and with numpy's expressions (the helpers'
    fallbacks): every result the same, bit for bit."""
    rng = np.random.default_rng(3)
    blocks = []
    for m, npt in ((1, 3), (4, 5), (20, 12), (7, 40)):
        t = np.cumsum(rng.uniform(0.05, 0.5, (m, npt)), axis=1)
        r = rng.uniform(1.0, 30.0, (m, 1))
        pts = np.stack([r * np.cos(t / r), r * np.sin(t / r)], axis=2) + rng.normal(0, 1e-3, (m, npt, 2))
        pts[0, npt // 2] = pts[0, npt // 2 - 1]      # a zero-length segment
        blocks.append(np.ascontiguousarray(pts))
    with np.errstate(all="ignore"):
        new = [curves._parts_block(p) for p in blocks]
        monkeypatch.setattr(curves, "_LAG_ROWS", None)
        monkeypatch.setattr(curves, "_DIV_PAIRS", None)
        old = [curves._parts_block(p) for p in blocks]
    for a, b in zip(new, old):
        assert len(a) == len(b)
        for u, v in zip(a, b):
            assert _same(u, v)
