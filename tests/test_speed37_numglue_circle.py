"""Session 37 (numglue): circle.py's products and evaluations without their copies.

_rows_matmul multiplies the whole blocks of a C-contiguous a in place (views) and writes
them straight into its result (or a caller's `out`), padding only the last block;
CircleBatch.eval_tau of rows all of one regime evaluates them without a gather and keeps
the evaluation's own arrays (no scatter).  Both are compared, bit for bit, with the code
they replace: _rows_matmul_padded (one stacked product of a zero-padded copy) and
eval_tau's gather / scatter loop (_eval_tau_scatter below)."""
import numpy as np
import pytest

from gcode_opt.laws import circle
from gcode_opt.laws.circle import solve_circles


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return (a.shape == b.shape and a.dtype == b.dtype
            and np.array_equal(np.ascontiguousarray(a).view(np.uint8), np.ascontiguousarray(b).view(np.uint8)))


@pytest.mark.parametrize("nb", [1, 5, 31, 32, 33, 64, 70, 129])
@pytest.mark.parametrize("k, m", [(1, 1), (3, 9), (17, 40), (25, 25)])
def test_rows_matmul_same_bits_as_padded(nb, k, m):
    if not circle._gemm_rows_invariant():
        pytest.skip("this BLAS: plain a @ b on both sides")
    rng = np.random.default_rng(nb * 1000 + k * 10 + m)
    a = rng.standard_normal((nb, k)) * 10.0 ** rng.uniform(-3, 3, (nb, 1))
    b = rng.standard_normal((k, m))
    bt = np.ascontiguousarray(rng.standard_normal((m, k))).T      # a transposed b (to_coef.T)
    for bb in (b, bt):
        ref = circle._rows_matmul_padded(a, bb)
        got = circle._rows_matmul(a, bb)
        assert _same(got, ref)
        out = np.full((nb, m), np.nan)
        assert circle._rows_matmul(a, bb, out=out) is out
        assert _same(out, ref)
        wide = np.full((nb, 2 * m), np.nan)                      # an out not C-contiguous
        assert circle._rows_matmul(a, bb, out=wide[:, ::2]) is not None
        assert _same(wide[:, ::2], ref) and np.isnan(wide[:, 1::2]).all()
        # rows of a bigger array (a slice of rows: C-contiguous) and a column slice (not)
        big = np.concatenate([a, a], axis=1)
        assert _same(circle._rows_matmul(big[:, :k], bb), circle._rows_matmul_padded(big[:, :k], bb))
        # each row's bits its own: the first rows alone give the same
        if nb > 3:
            assert _same(circle._rows_matmul(a[:3], bb), ref[:3])


def _eval_tau_scatter(batch, tau, idx=None, w2=True, w1=True):
    """CircleBatch.eval_tau as it was: each regime's rows gathered, evaluated, scattered."""
    idx = np.arange(len(batch)) if idx is None else np.asarray(idx)
    tau = np.broadcast_to(np.asarray(tau, float), (idx.size,) + np.shape(tau)[-1:]).copy()
    out = [np.empty_like(tau) if made else None for made in (True, True, w1, w2)]
    gam2 = batch.gamma[idx] ** 2
    lay = batch.regime[idx]
    for rows, part in ((lay, batch._eval_layers), (~lay, batch._eval_cheb)):
        if rows.any():
            k = np.nonzero(rows)[0]
            for o, v in zip(out, part(tau[k], idx[k], gam2[k], w2, w1)):
                if o is not None:
                    o[k] = v
    return out


def _batch(n, seed, gam_lo, gam_hi):
    rng = np.random.default_rng(seed)
    phi = rng.uniform(0.1, 4 * np.pi, n)
    T = 10 ** rng.uniform(-2, 0.3, n)
    beta = (T / 10 ** rng.uniform(gam_lo, gam_hi, n)) ** 2
    u0 = phi * rng.uniform(0, 1.5, n) * (rng.random(n) < 0.7)
    u1 = phi * rng.uniform(0, 1.5, n) * (rng.random(n) < 0.7)
    return solve_circles(phi, T, beta, u0 / T, u1 / T, R=rng.uniform(0.5, 100, n))


@pytest.mark.parametrize("gam", [(-1.0, 1.2), (2.3, 2.6), (-1.5, 2.5)])   # cheb, layers, mixed
def test_eval_tau_same_bits_as_scatter(gam):
    batch = _batch(70, 7, *gam)
    kinds = {"cheb": (-1.0, 1.2), "layers": (2.3, 2.6), "mixed": (-1.5, 2.5)}
    kind = [k for k, v in kinds.items() if v == gam][0]
    assert {"cheb": not batch.regime.any(), "layers": bool(batch.regime.all()),
            "mixed": batch.regime.any() and not batch.regime.all()}[kind]
    rng = np.random.default_rng(3)
    grid = np.linspace(0.0, 1.0, 17)
    taus = [np.broadcast_to(grid, (len(batch), grid.size)),                # a broadcast grid
            rng.uniform(0, 1, (len(batch), 23))]                           # rows of their own
    for tau in taus:
        kept = tau.copy()
        for w1, w2 in ((True, True), (True, False), (False, False)):
            ref = _eval_tau_scatter(batch, tau, None, w2, w1)
            got = batch.eval_tau(tau, None, w2, w1)
            assert _same(tau, kept)                                  # the caller's tau unchanged
            assert len(got) == 4
            for g, r in zip(got, ref):
                assert (g is None) == (r is None)
                if r is not None:
                    assert _same(g, r)
                    assert g.flags.c_contiguous and g.flags.writeable
            made = [g for g in got if g is not None]
            assert len({id(g) for g in made}) == len(made)         # arrays of their own
            assert not any(np.shares_memory(g, tau) for g in made)
    idx = np.array([5, 2, 2, 40, 69, 0])
    tau = rng.uniform(0, 1, (idx.size, 9))
    for g, r in zip(batch.eval_tau(tau, idx), _eval_tau_scatter(batch, tau, idx)):
        assert _same(g, r)


def test_own_arrays_copies_what_is_not_its_own():
    like = np.zeros((3, 4))
    fresh = np.arange(12.0).reshape(3, 4).copy()
    for view in (np.arange(24.0).reshape(6, 4)[:3], np.arange(24.0).reshape(6, 4)[::2]):   # (C-contiguous or not)
        got = circle._own_arrays((fresh, view, fresh, np.float32(1.5)), like, (True, True, True, False))
        assert got[0] is fresh and got[3] is None
        assert got[1] is not view and _same(got[1], view) and got[1].base is None
    assert got[2] is not fresh and _same(got[2], fresh)                   # given twice: a copy
    assert _same(circle._own_arrays((np.float32(2.0),), like, (True,))[0], np.full((3, 4), 2.0))
    caller = np.arange(12.0).reshape(3, 4).copy()        # the caller's tau itself: a copy
    got = circle._own_arrays((caller,), caller, (True,))[0]
    assert got is not caller and _same(got, caller)


def test_precond_buffers_need_no_zeros(monkeypatch):
    """_precond_cheb_c's arrays from np.empty: every value read is written first (round 46:
    pc_solve holds its rows' work on its own stack; no product buffers are left).  Buffers full of NaN (np.empty patched)
    give the same bits as zero-filled ones (np.empty patched to np.zeros: the code before)."""
    if circle.CORE_MOD is None or not circle._gemm_rows_invariant():
        pytest.skip("the compiled core's path only")
    rng = np.random.default_rng(11)
    n_arcs = 77                                     # not a multiple of _GEMM_ROWS: pad rows
    phi = rng.uniform(0.1, 4 * np.pi, n_arcs)
    T = 10 ** rng.uniform(-2, 0.3, n_arcs)
    beta = (T / 10 ** rng.uniform(-1.0, 1.2, n_arcs)) ** 2      # collocation regime
    real_empty = np.empty
    calls = []

    def precond(*args):
        calls.append(1)
        return real_precond(*args)
    real_precond = circle._precond_cheb_c
    monkeypatch.setattr(circle, "_precond_cheb_c", precond)

    def solve(fill):
        monkeypatch.setattr(np, "empty", lambda shape, dtype=float, **kw: np.full(shape, fill, dtype, **kw))
        try:
            b = solve_circles(phi, T, beta, 0.0, 0.0, R=1.0)
        finally:
            monkeypatch.setattr(np, "empty", real_empty)
        return b
    zero, nan = solve(0), solve(np.nan)
    assert calls and (~zero.regime).sum() > 40
    for name in ("coef", "cc", "wc"):
        assert _same(getattr(zero, name), getattr(nan, name))
    assert np.isfinite(zero.coef[~zero.regime]).all()
