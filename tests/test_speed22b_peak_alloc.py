"""Issue 8, s22b (peak): plan._allocate's choices() calls itself, so its closure was a
reference cycle holding the allocation tables Tx and Ix (~13 MB on the gyroid plate) until
the cyclic collector ran: through the second budget run's segments.  The cycle is cut
when _allocate returns (or raises); Candidates.allocation_tables drops its mask and
positions before its checks.  The choices themselves are tests/test_speed21_allocate_
same_bits.py's (same bits as before); here: the tables go with the last reference, with
the collector off, on every path (core or numpy, narrow or dense, early or bisected)."""
import gc
import weakref

import numpy as np
import pytest

from gcode_opt import plan as plan_mod


def _tables(seed, n=300, k=6):
    rng = np.random.default_rng(seed)
    T_orig = rng.uniform(0.5, 2.0, n)
    Tx = np.empty((n, k + 1))
    Tx[:, :k] = T_orig[:, None] * np.linspace(0.6, 1.4, k)[None, :]
    Tx[:, k] = T_orig
    Ix = rng.uniform(0.0, 100.0, (n, k + 1))
    Ix[:, k] = 150.0
    Ix[:, :k][rng.random((n, k)) < 0.4] = np.inf
    finite = np.isfinite(Ix)
    return Tx, Ix, finite, T_orig


@pytest.mark.parametrize("use_core", [True, False])
@pytest.mark.parametrize("budget", [1e9, 0.0, -5.0])
def test_allocate_frees_tables_without_collector(monkeypatch, use_core, budget):
    monkeypatch.setattr(plan_mod, "USE_CORE", use_core)
    was = gc.isenabled()
    gc.disable()
    try:
        for seed in range(3):
            Tx, Ix, finite, T_orig = _tables(seed)
            ref = plan_mod._allocate(Tx.copy(), Ix.copy(), finite.copy(), T_orig.copy(), budget, True)
            wt, wi = weakref.ref(Tx), weakref.ref(Ix)
            got = plan_mod._allocate(Tx, Ix, finite, T_orig, budget, True)
            del Tx, Ix
            assert wt() is None and wi() is None
            assert np.array_equal(got[0], ref[0]) and got[1] == ref[1]
    finally:
        if was:
            gc.enable()


def test_allocate_frees_tables_on_error(monkeypatch):
    def boom(*a, **k):
        raise RuntimeError("x")
    monkeypatch.setattr(plan_mod, "_fixed", boom)
    was = gc.isenabled()
    gc.disable()
    try:
        Tx, Ix, finite, T_orig = _tables(1)
        wt = weakref.ref(Tx)
        with pytest.raises(RuntimeError):
            plan_mod._allocate(Tx, Ix, finite, T_orig, 0.0, True)
        del Tx, Ix
        assert wt() is None
    finally:
        if was:
            gc.enable()
