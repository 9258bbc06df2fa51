"""The chains' compiled time sharing, restructured (session 19, issue 8): share_args and
share_step of laws/_chaincore.c now run each step's elementwise work in vectorisable
passes (γ and the np.sinh arguments of all active pieces at once; J at the three durations
in chunks of 256 pieces, its n, m, S1 series kept in L1; the slopes d1, 1/d2 of all
pieces before the per-chain sums), with AVX-512 clones beside the AVX2 ones; the Python
loop hands np.sinh and ** 3 preallocated outputs.  Each element's operations are the
same, in the same order, so the bits are: the reference below is ddecd40's
_share_time_numpy and _J3 verbatim (the code the compiled steps have always had to
match), run on the batches real chains of the bundled full-speed gyroid hand
_share_time (classic jerk and square-corner velocity, cold and warm, several durations)
and on random batches whose active piece counts straddle the chunk size, with chains
converging at different steps, one-piece chains, zero-length pieces and an infinite β.

Since session 20 (chainprim) the whole iteration is one C call (share_time) and both it
and _share_time_numpy use the deterministic sinh and cube of laws/prims.py where the
reference has np.sinh and ** 3: the core is checked bit for bit against today's
_share_time_numpy, and against the reference within a tolerance (see _close_to_old)."""
import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.laws import chain as lc
from gcode_opt.laws.chain import FD_H_R, MAX_NEWTON, NEWTON_TOL_R
from gcode_opt.laws.line import _gamma_coeffs

pytestmark = pytest.mark.skipif(lc.CORE_MOD is None, reason=f"the chain core is not used here ({lc.CORE_WHY})")

from test_speed_chains import _chain_problems  # noqa: E402


# ---------------------------------------------------------------- the reference (ddecd40)
def _J3(L, Tm, T0, Tp, beta, va, vb):
    """J = ∫ṡ² + β∫s̈² (LineLaw.integrals) at the three durations Tm, T0, Tp of the same
    pieces, in one batch: each element's arithmetic is LineLaw's (__init__, integrals), and what does not depend on
    T (√β, v0 ± v1, L²) is computed once instead of three times.  Raises LineLaw's
    ValueError, in its order, on bad inputs."""
    n = T0.size
    T = np.concatenate([Tm, T0, Tp])
    if not (np.all(T > 0) and np.all(np.isfinite(T))):
        raise ValueError("T must be finite and > 0")
    if not np.all(beta > 0):
        raise ValueError("beta must be > 0 (np.inf allowed)")
    if not (np.all(np.isfinite(L)) and np.all(np.isfinite(va)) and np.all(np.isfinite(vb))):
        raise ValueError("L, v0, v1 must be finite")
    tile = lambda a: np.concatenate([a, a, a])          # noqa: E731
    gamma = T / tile(np.sqrt(beta))
    c = _gamma_coeffs(gamma)
    A = tile(L) - T * tile(va + vb) / 2
    d = T * tile(va - vb) / 2
    iv = (tile(L**2) + A**2 * c["Ig1"] + d**2 * c["Ih"]) / T
    ia = (A**2 * c["Igp"] + d**2 * c["Ihp"]) / T**3
    b3 = tile(beta)
    J = iv + b3 * ia
    return J[:n], J[n:2 * n], J[2 * n:]


def ref_share_time(L, beta, va, vb, owner, T_total, T_init):
    """Durations T_j of all pieces with J_j'(T_j) = -λ_c per chain c and Σ_c T_j = T_total[c]
    (Newton on the KKT system).  Returns (T_j, λ_c, converged per chain).  A chain that has
    converged is frozen (its pieces leave the batch): each chain's iterates are its own,
    whatever else is in the batch, and the batch shrinks as chains converge."""
    n_c = T_total.size
    T = T_init.copy()
    lam = np.zeros(n_c)
    conv = np.zeros(n_c, bool)
    fresh = np.ones(n_c, bool)
    n_p = np.bincount(owner, None, n_c)
    for _ in range(MAX_NEWTON):
        ix = np.flatnonzero(~conv[owner])
        if ix.size == 0:
            break
        o, Ti, Li, bi, ai, ci = owner[ix], T[ix], L[ix], beta[ix], va[ix], vb[ix]
        h = FD_H_R * Ti
        jm, j0, jp = _J3(Li, Ti - h, Ti, Ti + h, bi, ai, ci)
        d1 = (jp - jm) / (2.0 * h)
        d2 = (jp - 2.0 * j0 + jm) / (h * h)
        d2 = np.maximum(d2, 1e-12 * np.abs(j0) / (Ti * Ti) + 1e-300)
        inv = 1.0 / d2
        s_inv = np.bincount(o, inv, n_c)
        with np.errstate(invalid="ignore", divide="ignore"):
            lam0 = -np.bincount(o, d1 * inv, n_c) / s_inv
        lam = np.where(fresh & ~conv, lam0, lam)   # λ that best matches the first slopes
        fresh[:] = False
        r = d1 + lam[o]
        e = T_total - np.bincount(o, Ti, n_c)
        with np.errstate(invalid="ignore", divide="ignore"):
            dlam = -(e + np.bincount(o, r * inv, n_c)) / s_inv
            scale = np.maximum(np.abs(lam), np.bincount(o, np.abs(d1), n_c) / n_p)
        dT = -(r + dlam[o]) * inv
        rr = np.bincount(o, np.abs(r), n_c)
        now = (~conv) & (rr <= NEWTON_TOL_R * scale * n_p) & (np.abs(e) <= 1e-12 * T_total)
        conv |= now
        move = ~now[o]
        # damped: no piece may lose more than half or gain more than its duration in a step
        step = np.clip(dT, -0.5 * Ti, Ti)
        T[ix[move]] = Ti[move] + step[move]
        lam = np.where(conv, lam, lam + np.nan_to_num(dlam))
    return T, lam, conv


# ---------------------------------------------------------------- checks
def _bits(x):
    x = np.asarray(x)
    return x.view(np.uint8) if x.dtype == bool else x.view(np.int64)


def _close_to_old(got, a):
    """The reference (np.sinh, ** 3) vs the primitives (prims.sinh, prims.cube): J's last
    bits differ, the central differences amplify that to ~1e-12 of the slopes, so the
    durations agree to ~1e-12..1e-10 of the chain's duration (more Newton steps, more
    amplification: bounded by 1e-9 here); a chain whose stopping test sits at
    its threshold may take a step more or less: within the Newton tolerance (1e-8), bounded
    here by 1e-7.  Such chains are rare; the convergence flags are the same."""
    old = ref_share_time(*(np.array(x) for x in a))
    owner, T_total = a[4], a[5]
    assert np.array_equal(got[2], old[2])
    d = np.zeros(T_total.size)
    np.maximum.at(d, owner, np.abs(got[0] - old[0]) / T_total[owner])
    assert np.all(d <= 1e-7), float(d.max())
    assert np.count_nonzero(d > 1e-9) <= 1 + 0.03 * d.size, np.sort(d)[-5:]


def _check(a):
    got = lc._share_time_core(lc.CORE_MOD, *a)
    assert got is not None
    want = lc._share_time_numpy(*(np.array(x) for x in a))
    for x, y in zip(got, want, strict=True):
        assert np.array_equal(_bits(x), _bits(y))
    _close_to_old(got, a)
    return want


def _record(monkeypatch):
    calls = []
    orig = lc._share_time

    def rec(*a, **k):
        calls.append([np.array(x) for x in a])
        return orig(*a, **k)
    monkeypatch.setattr(lc, "_share_time", rec)
    return calls


@pytest.mark.parametrize("prof", ["prusa-mk3s", "voron24"])
def test_share_time_on_real_batches(prof, monkeypatch):
    sts, T0, profile = _chain_problems(prof)
    calls = _record(monkeypatch)
    for r in (1.0, 1.05, 1.25):                # cold at each duration, then warm from its law
        T = T0 * r
        probs = chains._problems(sts, T, (T / chains.GAMMA_MIN) ** 2, profile)
        laws = lc.solve_chains(probs)
        T2 = T * 1.02
        lc.solve_chains(chains._problems(sts, T2, (T2 / chains.GAMMA_MIN) ** 2, profile),
                        init_binding=[lw.binding for lw in laws], init_vert_t=[lw.vert_t * 1.02 for lw in laws])
    assert len(calls) >= 12 and max(c[0].size for c in calls) > 256       # batches over a chunk
    steps = 0
    for a in calls:
        want = _check(a)
        steps += int(want[2].sum())
    assert steps > 100


def _batch(rng, n_c, kmax, T_scale=1.0):
    """n_c chains of 1..kmax pieces of a gyroid's sizes (γ ~ 0.1), first guesses off by up to 30 %."""
    k = rng.integers(1, kmax + 1, n_c)
    owner = np.repeat(np.arange(n_c), k)
    P = owner.size
    L = rng.uniform(0.05, 1.5, P)
    va, vb = rng.uniform(5, 80, P), rng.uniform(5, 80, P)
    T_total = np.bincount(owner, L, n_c) / rng.uniform(20, 70, n_c) * T_scale
    w = rng.uniform(0.7, 1.3, P) * L
    T_init = T_total[owner] * w / np.bincount(owner, w, n_c)[owner]
    beta = (T_total[owner] / 0.1) ** 2
    return L, beta, va, vb, owner, T_total, T_init


@pytest.mark.parametrize("n_c,kmax", [(1, 1), (1, 7), (3, 1), (40, 6), (85, 6), (86, 6), (120, 5), (300, 9),
                                      (700, 2)])
def test_share_time_on_random_batches(n_c, kmax):
    rng = np.random.default_rng(n_c * 31 + kmax)
    a = _batch(rng, n_c, kmax)
    want = _check(a)
    assert want[2].all()


def test_active_counts_around_the_chunk():
    """Batches whose active piece counts cross 256 and 512 as chains converge."""
    rng = np.random.default_rng(5)
    for P in (255, 256, 257, 511, 512, 513, 769):
        k = 3
        n_c = -(-P // k)
        L, beta, va, vb, owner, T_total, T_init = _batch(rng, n_c, k)
        sel = np.flatnonzero(np.arange(owner.size) < P)     # cut the last chain short: P pieces
        owner, L, beta, va, vb, T_init = owner[sel], L[sel], beta[sel], va[sel], vb[sel], T_init[sel]
        T_total = np.bincount(owner, T_init, n_c) * rng.uniform(0.9, 1.1, n_c)    # some need many steps
        _check((L, beta, va, vb, owner, T_total, T_init))


def test_degenerate_pieces():
    rng = np.random.default_rng(9)
    L, beta, va, vb, owner, T_total, T_init = _batch(rng, 60, 5)
    L[::7] = 0.0                                  # zero-length pieces
    vb[::5] = va[::5]                              # level pieces (v0 - v1 = 0)
    _check((L, beta, va, vb, owner, T_total, T_init))
    b2 = beta.copy()
    b2[owner == 3] = np.inf                        # γ = 0 (shc's 1 at z = 0), then J = nan: a nan
    a = (L, b2, va, vb, owner, T_total, T_init)     # duration; the core declines, the numpy code raises
    assert lc._share_time_core(lc.CORE_MOD, *a) is None
    with np.errstate(all="ignore"), pytest.raises(ValueError, match="T must be finite"):
        ref_share_time(*a)
    with np.errstate(all="ignore"), pytest.raises(ValueError, match="T must be finite"):
        lc._share_time(*a)
    T_far = T_init * np.where(owner % 2 == 0, 3.0, 0.2)       # damped steps (clip) on every side
    _check((L, beta, va, vb, owner, T_total, T_far))


def test_declines_as_before():
    """Where ddecd40's core declined (a duration not finite and > 0, a γ past the series
    branch) the new one does too, whatever the place of the bad piece in the batch."""
    rng = np.random.default_rng(2)
    L, beta, va, vb, owner, T_total, T_init = _batch(rng, 100, 5)
    for q in (0, 137, owner.size - 1):
        for bad in (-1.0, 0.0, np.nan, np.inf):
            Tb = T_init.copy()
            Tb[q] = bad
            assert lc._share_time_core(lc.CORE_MOD, L, beta, va, vb, owner, T_total, Tb) is None
        bb = beta.copy()
        bb[q] = (T_init[q] / 4.5) ** 2               # γ = 4.5 > GAMMA_SWITCH at T
        assert lc._share_time_core(lc.CORE_MOD, L, bb, va, vb, owner, T_total, T_init) is None
