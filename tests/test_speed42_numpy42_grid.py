"""Session 42 (numpy42): laws/circle._graded_grid's nodes and weights made in one compiled
pass (_curvecore.c graded_grid), not numpy's ~10 operations on broadcast operands (each
copied row by row through numpy 2's iterator buffers): the same bits as the numpy code."""
import numpy as np
import pytest

from gcode_opt.laws import circle


def _ref_graded_grid(h, levels):
    """circle._graded_grid before session 42 (numpy only)."""
    gx, gw = circle._gauss(10)
    edges = h[:, None] * np.concatenate([[0.0], 2.0 ** -np.arange(levels, -1, -1.0)])[None, :]
    a, b = edges[:, :-1], edges[:, 1:]
    xl = (a[..., None] + (b - a)[..., None] * gx).reshape(h.size, -1)
    wl = ((b - a)[..., None] * gw).reshape(h.size, -1)
    mx, mw = circle._gauss(24)
    xm = h[:, None] + (1 - 2 * h)[:, None] * mx
    wm = (1 - 2 * h)[:, None] * mw
    xs = np.concatenate([xl, xm, 1.0 - xl[:, ::-1]], axis=1)
    ws = np.concatenate([wl, wm, wl[:, ::-1]], axis=1)
    return xs, ws


def _bits(a):
    return np.ascontiguousarray(a).view(np.int64)


def test_graded_grid_same_bits_as_numpy():
    if circle.CORE_MOD is None:
        pytest.skip("curve core not built")
    rng = np.random.default_rng(42)
    n = 0
    for nb in (1, 2, 7, 128, 300):
        for levels in (2, 3, 9, 17, 40):
            h = np.minimum(0.5, 30.0 / np.exp(rng.uniform(-2.0, 12.0, nb)))
            h[: nb // 3] = 0.5
            for hh in (h, h[::-1].copy()[: max(1, nb - 1)]):
                want = _ref_graded_grid(hh, levels)
                got = circle._graded_grid(hh, levels)
                for g, w in zip(got, want):
                    assert g.shape == w.shape and g.flags.c_contiguous
                    assert np.array_equal(_bits(g), _bits(w)), (nb, levels)
                n += 1
    assert n == 50


def test_graded_grid_view_rows():
    """h a slice of a batch's widths (grid_chunks' h[sl]): the same as a copy of it."""
    rng = np.random.default_rng(5)
    h = np.minimum(0.5, 30.0 / np.exp(rng.uniform(0.0, 9.0, 40)))
    for sl in (slice(0, 13), slice(13, 40), slice(5, 6)):
        for g, w in zip(circle._graded_grid(h[sl], 6), _ref_graded_grid(h[sl].copy(), 6)):
            assert np.array_equal(_bits(g), _bits(w))
