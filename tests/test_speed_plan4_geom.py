"""Issue 8, stop 19 (D9): curves._parts_block makes the curvature kernel exp(-0.5 (z2 - min
z2)) in place in one array (the same operations: x ** 2 is np.square, -0.5 x is x (-0.5))
instead of a new array per step.  Every output must be the same bits as ddecd40's
_parts_block, copied below, on real curves of every vertex count and on random and
degenerate points."""
import os

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_CURVE

S = "sample_gcode/"
CORPUS = os.path.expanduser("~/.cache/gcode-opt-corpus/")


# ---------------------------------------------------------------- ddecd40's form
def _old_parts_block(pts):
    """_batch_parts on one block of strokes with the same vertex count: pts (m, n + 1, 2)."""
    seg = pts[:, 1:] - pts[:, :-1]                           # _segments
    d = np.hypot(seg[..., 0], seg[..., 1])
    u = seg / d[..., None]
    cos_turn = np.einsum("bij,bij->bi", u[:, :-1], u[:, 1:])
    s_v = np.empty(d.shape[:1] + (d.shape[1] + 1,))
    s_v[:, 0] = 0.0
    np.cumsum(d, axis=1, out=s_v[:, 1:])
    good = np.isfinite(pts).all(axis=(1, 2)) & (d > 1e-9).all(axis=1) & (np.diff(s_v, axis=1) > 0.0).all(axis=1)
    n = d.shape[1]                                          # _median
    k = n // 2
    if n % 2:
        med = np.partition(d, k, axis=1)[:, k]
    else:
        p = np.partition(d, [k - 1, k], axis=1)
        med = (p[:, k - 1] + p[:, k]) / 2.0
    smooth_d = curves._pmax(med, curves.SMOOTH_MIN_D)
    # curvature_from_polyline(pts, smooth_d): its one window covers every interior vertex
    heading = np.arctan2(seg[..., 1], seg[..., 0])
    turn = np.angle(np.exp(1j * np.diff(heading, axis=1)))
    s_i = s_v[:, 1:-1]
    ell = 0.5 * (d[:, :-1] + d[:, 1:])
    z2 = ((s_v[:, :, None] - s_i[:, None, :]) / smooth_d[:, None, None]) ** 2
    kern = np.exp(-0.5 * (z2 - z2.min(axis=2, keepdims=True)))
    # matrix-vector products stacked: numpy makes the same BLAS gemv call per stroke as the
    # per-stroke path's kern @ turn (same shapes and strides), so the same bits
    kappa_v = (kern @ turn[:, :, None])[..., 0] / (kern @ ell[:, :, None])[..., 0]
    good &= np.isfinite(kappa_v).all(axis=1)
    # np.interp(s_v, s_d, kappa_v) at its own nodes is kappa_v itself
    S = s_v[:, -1]
    mid = 0.5 * (kappa_v[:, :-1] ** 2 + kappa_v[:, 1:] ** 2)
    k2 = np.sum(mid * d, axis=1) / S
    kappa_eff = curves._pmax(np.sqrt(k2), 1.0 / (curves.MAX_R_OVER_S * S))
    return d, u, cos_turn, s_v, kappa_v, kappa_eff.tolist(), good


# ---------------------------------------------------------------- comparisons
def _same(got, want):
    assert len(got) == len(want) == 7
    for x, y in zip(got, want):
        if isinstance(y, list):
            assert type(x) is list and len(x) == len(y)
            assert all(type(a) is type(b) and np.float64(a).tobytes() == np.float64(b).tobytes() for a, b in zip(x, y))
        else:
            assert type(x) is type(y) and x.dtype == y.dtype and x.shape == y.shape
            assert x.tobytes() == y.tobytes()


def _blocks(path):
    strokes, _ = analyse(path, load_profile("prusa-mk3s"), Options())
    by_n = {}
    for st in strokes:
        if st.kind == K_CURVE and 3 <= len(st.pts) <= curves._GEOM_MAX_PTS:
            by_n.setdefault(len(st.pts), []).append(curves._xy(st))
    return {n: np.concatenate(v).reshape(len(v), n, 2) for n, v in by_n.items()}


@pytest.mark.parametrize("path", [S + "prusa_gyroid.gcode", S + "prusa_concentric.gcode",
                                  S + "prusa_gyroid_fullspeed.gcode", CORPUS + "gyroid_fwretract.gcode"])
def test_parts_block_same_as_ddecd40(path):
    if not os.path.exists(path):
        pytest.skip("corpus file not present")
    blocks = _blocks(path)
    assert len(blocks) > 5
    for n, pts in blocks.items():
        with np.errstate(all="ignore"):
            _same(curves._parts_block(pts), _old_parts_block(pts))


def test_parts_block_random_and_degenerate():
    rng = np.random.default_rng(19)
    for npt in (3, 4, 5, 9, 17, 60, 200):
        m = 40
        steps = rng.uniform(0.05, 3.0, (m, npt - 1, 1)) * np.stack(
            [np.cos(np.cumsum(rng.uniform(-0.5, 0.5, (m, npt - 1)), axis=1)),
             np.sin(np.cumsum(rng.uniform(-0.5, 0.5, (m, npt - 1)), axis=1))], axis=2)
        pts = np.concatenate([rng.uniform(-100, 100, (m, 1, 2)), steps], axis=1).cumsum(axis=1)
        pts[1, 2] = pts[1, 1]                       # a duplicate point
        pts[2, 0, 0] = np.nan
        pts[3, -1, 1] = np.inf
        pts[4] *= 1e-7                              # tiny segments
        pts[5] *= 1e5                               # kernels that underflow to 0
        with np.errstate(all="ignore"):
            got, want = curves._parts_block(pts), _old_parts_block(pts)
        _same(got, want)
        assert not got[-1][1] and not got[-1][2] and got[-1][0]
