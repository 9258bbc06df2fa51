"""Issue 8 (s33, the chains' candidates): _share_time_exact's input checks and exact_share's
inputs (vs = va + vb, vd = va - vb, each chain's piece count and offsets) are made by the
chain core in one pass (exact_prep) instead of ~15 numpy calls a solve step.  These tests
hold exact_prep to its numpy twin (the checks and arrays _share_time_exact made before):
  - on random batches: the same decision and the same bits of vs, vd, npc, poff;
  - a planted bad input (nan, inf, a β of 0 or -0.0) in each array: declined (-1), as the
    numpy checks decline it; owners out of chain order: 0 (the numpy loop runs);
and _share_time_exact with the core to the numpy iteration on such a batch, bit for bit
(tests/test_speed29_chainnewton_slopes.py does it on the plates' real batches), and that
the comparison sees one ulp in vd."""
import numpy as np
import pytest

from gcode_opt.laws import chain as lc

pytestmark = pytest.mark.skipif(lc.CORE_MOD is None or not hasattr(lc.CORE_MOD, "exact_prep"),
                                reason=f"the chain core is not used here ({lc.CORE_WHY})")


def _batch(seed, n_c=40):
    rng = np.random.default_rng(seed)
    npc = rng.integers(1, 6, n_c)
    owner = np.repeat(np.arange(n_c), npc)
    P = owner.size
    L = rng.uniform(0.05, 2.0, P)
    va, vb = rng.uniform(0.0, 120.0, P), rng.uniform(0.0, 120.0, P)
    T_total = np.bincount(owner, L, n_c) / 60.0
    beta = (T_total[owner] * rng.uniform(2.0, 10.0, n_c)[owner]) ** 2     # γ of a chain 0.1 .. 0.5
    T_init = T_total[owner] * L / np.bincount(owner, L, n_c)[owner]
    return L, beta, va, vb, owner, T_total, T_init


def _numpy_prep(L, beta, va, vb, owner, n_c):
    """What _share_time_exact computed in numpy before exact_prep: (status, vs, vd, poff, npc)."""
    if not (np.all(beta > 0) and np.all(np.isfinite(beta)) and np.all(np.isfinite(L))
            and np.all(np.isfinite(va)) and np.all(np.isfinite(vb))):
        return -1, None, None, None, None
    if np.any(np.diff(owner) < 0):
        return 0, None, None, None, None
    npc = np.bincount(owner, None, n_c)
    poff = np.zeros(n_c + 1, np.int64)
    np.cumsum(npc, out=poff[1:])
    return 1, va + vb, va - vb, poff, npc.astype(float)


def _core_prep(L, beta, va, vb, owner, n_c):
    P = L.size
    vs, vd, npc, poff = np.empty(P), np.empty(P), np.empty(n_c), np.empty(n_c + 1, np.int64)
    got = lc.CORE_MOD.exact_prep(L, beta, va, vb, owner, vs, vd, poff, npc)
    return (got, vs, vd, poff, npc) if got == 1 else (got, None, None, None, None)


def _same(a, b):
    if a is None or b is None:
        return a is None and b is None
    return a.dtype == b.dtype and np.array_equal(np.ascontiguousarray(a).view(np.uint8),
                                                 np.ascontiguousarray(b).view(np.uint8))


def _check(L, beta, va, vb, owner, n_c):
    want = _numpy_prep(L, beta, va, vb, owner, n_c)
    got = _core_prep(L, beta, va, vb, owner, n_c)
    assert got[0] == want[0]
    for x, y in zip(got[1:], want[1:], strict=True):
        assert _same(x, y)
    return got[0]


def test_exact_prep_equals_numpy_on_random_batches():
    for seed in range(6):
        L, beta, va, vb, owner, T_total, _ = _batch(seed)
        assert _check(L, beta, va, vb, owner, T_total.size) == 1
        assert _check(L, beta, -va, vb, owner, T_total.size) == 1         # negative speeds: fine


def test_exact_prep_declines_bad_inputs_as_numpy():
    L, beta, va, vb, owner, T_total, _ = _batch(7)
    n_c = T_total.size
    for which in range(4):
        for bad in (np.nan, np.inf, -np.inf, 0.0, -0.0):
            args = [a.copy() for a in (L, beta, va, vb)]
            args[which][11] = bad
            want = -1 if (which == 1 or not np.isfinite(bad)) else 1
            assert _check(*args, owner, n_c) == want
    swapped = owner.copy()
    swapped[[3, 30]] = swapped[[30, 3]]
    assert _check(L, beta, va, vb, swapped, n_c) == 0


def test_share_time_exact_with_prep_equals_numpy():
    for seed in range(3):
        a = _batch(seed)
        got = lc._share_time_exact(*a, core=lc.CORE_MOD)
        want = lc._share_time_exact(*a, core=False)
        assert got is not None and want is not None
        for x, y in zip(got, want, strict=True):
            assert _same(np.asarray(x), np.asarray(y))
    # owners out of chain order: the numpy iteration, the same numbers
    L, beta, va, vb, owner, T_total, T_init = _batch(4)
    perm = np.random.default_rng(0).permutation(owner.size)
    a = (L[perm], beta[perm], va[perm], vb[perm], owner[perm], T_total, T_init[perm])
    got, want = lc._share_time_exact(*a, core=lc.CORE_MOD), lc._share_time_exact(*a, core=False)
    for x, y in zip(got, want, strict=True):
        assert _same(np.asarray(x), np.asarray(y))


def test_the_comparison_sees_one_ulp():
    L, beta, va, vb, owner, T_total, _ = _batch(1)
    got = _core_prep(L, beta, va, vb, owner, T_total.size)
    off = got[2].copy()
    off[5] = np.nextafter(off[5], np.inf)
    assert not _same(off, got[2])
