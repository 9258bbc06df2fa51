"""Session 33 of issue 8 (memory) in laws/circle.py: the Chebyshev regime's levels solved
_COEF_CHUNK arcs at a time from their start nodes to their coefficients (circle._solve_coefs),
Newton on the arcs the preconditioned iteration leaves in the one batch the whole level gave
it.  The same laws bit for bit as the whole-level solve (the path kept for a BLAS that does
not give rows their own bits), with less memory held at once."""
import tracemalloc

import numpy as np
import pytest

from gcode_opt.laws import circle


def _arcs(seed, nb, steep):
    """(phi, gam2, u0, u1, lam_est) of nb arcs; steep: end layers steep enough that the
    preconditioned iteration leaves some arcs to Newton and some go up the N ladder."""
    rng = np.random.default_rng(seed)
    if steep:
        phi = rng.uniform(0.05, 3.0, nb) * rng.choice([1.0, -1.0], nb)
        gam2 = 10.0 ** rng.uniform(-3, 3.5, nb)
        u0, u1 = phi * rng.uniform(0.0, 6.0, nb), phi * rng.uniform(0.0, 6.0, nb)
    else:
        phi = rng.uniform(0.05, 1.0, nb)
        gam2 = 10.0 ** rng.uniform(-1, 1, nb)
        u0, u1 = phi * rng.uniform(0.5, 1.5, nb), phi * rng.uniform(0.5, 1.5, nb)
    return phi, gam2, u0, u1, np.sqrt(gam2 + 6.0 * phi ** 2)


def _solve(monkeypatch, chunked, args):
    """_solve_cheb_batch's (coefficients as solve_circles lays them out, C), by chunks or
    by the whole-level path."""
    monkeypatch.setattr(circle, "rows_invariant", lambda: chunked)
    blocks, cvals = circle._solve_cheb_batch(*args)
    coef = np.zeros((args[0].size, max(c.shape[1] for _, c in blocks)))
    for ia, c in blocks:
        coef[ia, :c.shape[1]] = c
    return coef, cvals, [(ia.size, c.shape[1]) for ia, c in blocks]


def test_levels_solved_in_chunks_are_the_whole_levels_laws(monkeypatch):
    if not circle.rows_invariant():
        pytest.skip("this BLAS does not give rows their own bits: the whole-level path only")
    args = _arcs(1, 400, steep=True)
    whole = _solve(monkeypatch, False, args)
    monkeypatch.setattr(circle, "_COEF_CHUNK", 7)       # many chunks, most with arcs left to Newton
    n0 = circle.NEWTON_ARCS[0]
    chunked = _solve(monkeypatch, True, args)
    assert circle.NEWTON_ARCS[0] - n0 > 50               # Newton took part, after the chunks
    assert len({k for _, k in chunked[2]}) >= 4          # arcs went up the N ladder (warm starts)
    assert chunked[2] == whole[2]
    assert np.array_equal(chunked[0], whole[0]) and np.array_equal(chunked[1], whole[1])


def test_levels_in_chunks_hold_less(monkeypatch):
    """30 k gentle arcs (the size of a plate's curve candidates): the solve's memory above
    what it returns is at most 60 % of the whole-level path's (measured 4.5 vs 10.5 MB at
    1024 arcs a chunk; the default 4096 holds ~8 MB, a quarter of the arcs at once).
    Round 46: the preconditioned iteration holds no work arrays any more (pc_solve works on
    each arc's row in place), which took the whole-level path down to 5.5 MB (the chunked
    one stays at 4.6 MB): at most 90 %."""
    if not circle.rows_invariant():
        pytest.skip("this BLAS does not give rows their own bits: the whole-level path only")
    monkeypatch.setattr(circle, "_COEF_CHUNK", 1024)
    args = _arcs(2, 30000, steep=False)
    over = {}
    for chunked in (False, True):
        monkeypatch.setattr(circle, "rows_invariant", lambda c=chunked: c)
        tracemalloc.start()
        try:
            got = circle._solve_cheb_batch(*args)
            held, peak = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
        over[chunked] = peak - held
        del got
    assert over[True] < 0.9 * over[False], over
