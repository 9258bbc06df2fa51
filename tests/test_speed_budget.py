"""The budget loop's per-stroke Python made cheaper with the same bits (issue 8, G7):
plan._allocate (narrow cost tables, a kept T - T_orig per row, the second least by a
min), schedule._seg_fault (one pass over the four arrays, the old path for the reason),
curves.predict_curve and curves.junction_accels (fewer numpy calls; classic jerk skips
the per-vertex loop).  Each is compared bit for bit with its c8abe7b form, copied below."""
import math
import types

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt import plan as plan_mod
from gcode_opt import schedule as sc
from gcode_opt.segments import SegmentPlan


# ---------------------------------------------------------------- c8abe7b's forms
def _old_allocate(Tx, Ix, finite, T_orig, budget_t, settle):
    """allocate on its extended tables (the original as the last column); settle: the
    costs cannot cancel (every finite I and every T >= 0), so the margin test holds."""
    n, k = Ix.shape
    rows = np.arange(n)

    def spent(j):
        return float(np.sum(Tx[rows, j] - T_orig))

    def choices(lam, r):
        """Choice and margin to the next candidate of rows r at lam (margin inf where only
        one candidate is finite or none is: then the choice cannot change).  By blocks of
        rows, so that the cost matrices stay small (row-wise: the same numbers)."""
        if len(r) > plan_mod.ALLOCATE_ROWS:
            parts = [choices(lam, r[a:a + plan_mod.ALLOCATE_ROWS]) for a in range(0, len(r), plan_mod.ALLOCATE_ROWS)]
            return tuple(np.concatenate(x) for x in zip(*parts))
        cost = np.where(finite[r], Ix[r] + lam * Tx[r], np.inf)
        j = np.argmin(cost, axis=1)
        if k < 2:                 # one candidate: it cannot change
            return j, np.full(len(r), np.inf), np.zeros(len(r))
        two = np.partition(cost, 1, axis=1)
        c1, c2 = two[:, 0], two[:, 1]
        with np.errstate(invalid="ignore"):
            margin = np.where(np.isinf(c2), np.inf, c2 - c1)
        return j, margin, plan_mod.MARGIN_R * (np.abs(c1) + np.abs(c2))

    j_lo, m_lo, _ = choices(0.0, rows)
    if spent(j_lo) <= budget_t:
        return j_lo, 0.0
    lo, hi = 0.0, 1.0
    while True:
        j_hi, m_hi, tol_hi = choices(hi, rows)
        if not (spent(j_hi) > budget_t and hi < 1e30):
            break
        hi *= 10.0
    J = j_hi.copy()               # every stroke's choice; those of `act` are the bracket's ends'
    act = rows
    for _ in range(80):
        # the costs grow with lambda (T >= 0): the rounding anywhere in the bracket is
        # at most the top end's, tol_hi, which both margins must clear
        keep = (j_lo != j_hi) | ~(m_lo > tol_hi) | ~(m_hi > tol_hi)
        if settle and not keep.all():        # settled: J holds their choice for the rest of the bisection
            act, j_lo, m_lo, j_hi, m_hi, tol_hi = (a[keep] for a in (act, j_lo, m_lo, j_hi, m_hi, tol_hi))
        mid = 0.5 * (lo + hi)
        j_mid, m_mid, tol_mid = choices(mid, act)
        J[act] = j_mid
        if spent(J) > budget_t:
            lo, j_lo, m_lo = mid, j_mid, m_mid
        else:
            hi, j_hi, m_hi, tol_hi = mid, j_mid, m_mid, tol_mid
    J[act] = j_hi
    return J, hi


def _old_seg_fault(seg):
    try:
        s, v, a, f = (np.asarray(x, float) for x in (seg.s, seg.v, seg.accel, seg.feed))
    except (TypeError, ValueError):
        return "error: segments (malformed)"
    if not (np.isfinite(s).all() and np.isfinite(v).all() and np.isfinite(a).all() and np.isfinite(f).all()
            and math.isfinite(seg.time_t) and math.isfinite(seg.int_a2)):
        return "error: segments (non-finite)"
    if len(s) < 2 or a.size != len(s) - 1 or f.size != len(s) - 1:
        return "error: segments (malformed)"
    if not (np.diff(s) > 0).all():
        return "error: segments (knots not increasing)"
    if not ((a > 0).all() and (f > 0).all() and (v >= 0).all()):
        return "error: segments (acceleration, feed or speed not above 0)"
    return ""


def _old_predict_curve(s, v, a, cos_turn, cos_end0=None, cos_end1=None):
    """Firmware execution of the curve's G1 segments: each ramps at a_k over |Δv| and
    cruises the rest (time, tangential Σ a_k |Δv_k|), plus the normal term the firmware
    model counts at every vertex turning <= 30 deg: (2 v sin(θ/2))² / ((t_k + t_{k+1})/2),
    and half of it at the curve's two ends (the other half belongs to the neighbour)."""
    d = np.diff(s)
    va, vb = v[:-1], v[1:]
    vmax = np.maximum(va, vb)
    a = np.maximum(a, 1e-12)
    ramp_d = np.abs(vb * vb - va * va) / (2.0 * a)
    t = np.abs(vb - va) / a + np.maximum(d - ramp_d, 0.0) / np.maximum(vmax, 1e-9)
    a2 = float(np.sum(a * np.abs(vb - va)))
    vi = v[1:-1]
    dv2 = 2.0 * vi * vi * (1.0 - cos_turn)
    tj = 0.5 * (t[:-1] + t[1:])
    a2 += float(np.sum(np.where(cos_turn >= curves.CORNER_COS, dv2 / np.maximum(tj, 1e-12), 0.0)))
    for c, vv, tt in ((cos_end0, v[0], t[0]), (cos_end1, v[-1], t[-1])):
        if c is not None and c >= curves.CORNER_COS:
            a2 += 0.5 * 2.0 * vv * vv * (1.0 - c) / max(tt, 1e-12)
    return float(np.sum(t)), a2


def _old_junction_accels(st, g, vk, acc, rules, profile, vmax=None):
    """Segment accelerations `acc` raised to what the firmware's junction law needs to
    pass each original vertex at the knot speed vk (x curves.ACCEL_MARGIN), and to the floor a
    finite-lookahead planner needs to stop within the blocks it knows (vmax: each
    segment's top speed, default the faster knot); never above the acceleration in force."""
    d = g.d
    n = len(d)
    acc = np.array(acc, float)
    jd = st.lim.jd
    a_top = min(st.accel, st.lim.ax_max, st.lim.ay_max)
    v0 = st.v0 if st.v0 >= curves.FULL_STOP_V else 0.0
    v1 = st.v1 if st.v1 >= curves.FULL_STOP_V else 0.0
    vj = np.array(vk, float)
    vj[0], vj[-1] = v0, v1
    u = [tuple(x) for x in g.u]
    pus = [st.prev_u] + u[:-1]            # direction before each segment's start vertex
    nus = u[1:] + [st.next_u]             # direction after each segment's end vertex
    for k in range(n):
        need = curves.accel_to_pass_junction(rules.junction, vj[k], pus[k], u[k], d[k], jd)
        if rules.junction == "scv":       # Klipper: both moves' accelerations bound the junction
            need = max(need, curves.accel_to_pass_junction("scv", vj[k + 1], u[k], nus[k], d[k], jd))
        acc[k] = max(acc[k], min(curves.ACCEL_MARGIN * need, a_top))
    if profile.block_buffer > 0:
        # a finite-lookahead planner must be able to stop within the blocks it knows
        nb = max(profile.block_buffer - 3, 1)
        ext = np.concatenate([d, np.full(nb, d[-1])])
        window = np.convolve(ext, np.ones(nb), "valid")[:n]
        if vmax is None:
            vmax = np.maximum(vk[:-1], vk[1:])
        acc = np.maximum(acc, np.minimum(1.1 * vmax ** 2 / (2.0 * window), a_top))
    return acc


# ---------------------------------------------------------------- allocate


def _ext(T, I, T_orig, I_orig):
    Tx = np.concatenate([T, T_orig[:, None]], axis=1)
    Ix = np.concatenate([I, I_orig[:, None]], axis=1)
    finite = np.isfinite(Ix)
    settle = bool(np.all(Ix[finite] >= 0.0) and np.all(Tx >= 0.0))
    return Tx, Ix, finite, settle


def _same_alloc(T, I, T_orig, I_orig, budget_t):
    Tx, Ix, finite, settle = _ext(T, I, T_orig, I_orig)
    j_ref, lam_ref = _old_allocate(Tx.copy(), Ix.copy(), finite.copy(), T_orig, budget_t, settle)
    j, lam = plan_mod._allocate(Tx, Ix, finite, T_orig, budget_t, settle)
    assert j.dtype == j_ref.dtype
    assert np.array_equal(j, j_ref)
    assert lam == lam_ref


def _lines_like(rng, n, k=23):
    """Tables shaped like the real ones: most rows a few finite laws (narrow), some wide,
    some with none; duplicates and last-bit differences."""
    T_orig = rng.uniform(0.02, 3.0, n)
    T = T_orig[:, None] * np.linspace(0.7, 1.5, k)[None, :]
    I_orig = rng.uniform(1e2, 1e7, n)
    I = I_orig[:, None] * rng.uniform(0.05, 1.3, (n, k))
    width = rng.choice([0, 1, 2, 5, 8, 9, 18, 23], n, p=[0.1, 0.2, 0.1, 0.3, 0.05, 0.05, 0.1, 0.1])
    for i in range(n):
        keep = rng.permutation(k)[:width[i]]
        drop = np.setdiff1d(np.arange(k), keep)
        I[i, drop] = np.inf
        T[i, drop] = rng.choice([0.0, 5.0])          # an infeasible entry's T is never read
    I[::13, 3] = I[::13, 2]                            # exact duplicates
    T[::13, 3] = T[::13, 2]
    I[::7, 6] = np.nextafter(I[::7, 5], np.inf)
    T[::7, 6] = T[::7, 5]
    # lines that cross at lambdas the bisection visits (a tie there: argmin's first)
    for i, lam in zip(range(1, n, 5), np.tile(2.0 ** np.arange(-3, 9), n)):
        I[i, 8] = I[i, 9] + lam * (T[i, 9] - T[i, 8])
    return T, I, T_orig, I_orig


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_allocate_narrow_tables_same_bits(seed):
    rng = np.random.default_rng(seed)
    T, I, T_orig, I_orig = _lines_like(rng, 3000)
    for b in (0.0, 1.0, 20.0, 150.0, -1.0):
        _same_alloc(T, I, T_orig, I_orig, b)


def test_allocate_mixed_blocks(monkeypatch):
    """Blocks holding narrow and wide rows (merged) and blocks of one kind."""
    rng = np.random.default_rng(11)
    T, I, T_orig, I_orig = _lines_like(rng, 1500)
    I[:200, :] = I_orig[:200, None] * rng.uniform(0.05, 1.3, (200, I.shape[1]))   # a wide run
    for rows in (37, 256, 4096):
        monkeypatch.setattr(plan_mod, "ALLOCATE_ROWS", rows)
        for b in (5.0, 60.0):
            _same_alloc(T, I, T_orig, I_orig, b)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_allocate_not_plain_tables():
    """An infinite or negative T, NaN costs, an original with no finite cost: the masked
    path, whatever the widths."""
    rng = np.random.default_rng(5)
    T, I, T_orig, I_orig = _lines_like(rng, 800)
    T2 = T.copy()
    T2[::11, 4] = np.inf
    _same_alloc(T2, I, T_orig, I_orig, 10.0)
    T3 = T.copy()
    T3[::9, 1] = -0.5
    _same_alloc(T3, I, T_orig, I_orig, 10.0)
    I4 = I.copy()
    I4[::5, 0] = np.nan
    I_o4 = I_orig.copy()
    I_o4[::3] = np.inf
    _same_alloc(T, I4, T_orig, I_o4, 10.0)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_allocate_overflowing_costs():
    """Costs I + lambda T that overflow to inf for every finite entry of a row: argmin's
    first inf is then another column in the full table; the narrow one must not differ."""
    rng = np.random.default_rng(9)
    T, I, T_orig, I_orig = _lines_like(rng, 300)
    T[:40] *= 1e290
    T_orig[:40] *= 1e290
    I_orig[:40] = 1e300
    for b in (0.0, 10.0, -1.0, -1e300):
        _same_alloc(T, I, T_orig, I_orig, b)


def test_allocate_public_api_keeps_its_tables():
    """allocate() builds its own extended tables: the caller's T and I stay as they were."""
    rng = np.random.default_rng(3)
    T, I, T_orig, I_orig = _lines_like(rng, 500)
    T0, I0 = T.copy(), I.copy()
    plan_mod.allocate(T, I, T_orig, I_orig, 10.0)
    assert np.array_equal(T, T0) and np.array_equal(I, I0)


# ---------------------------------------------------------------- seg_fault


def _seg(s, v, a, f, time_t=1.0, int_a2=1.0):
    return types.SimpleNamespace(s=s, v=v, accel=a, feed=f, time_t=time_t, int_a2=int_a2)


def _fine():
    s = np.array([0.0, 1.0, 2.5, 4.0])
    v = np.array([10.0, 20.0, 20.0, 5.0])
    return s, v, np.array([100.0, 1e-3, 50.0]), np.array([20.0, 20.0, 21.0])


def _cases():
    s, v, a, f = _fine()
    yield _seg(s, v, a, f)
    yield _seg(s, v, a, f, time_t=np.float64(2.0))
    for which in range(4):
        for bad in (np.nan, np.inf, -np.inf):
            arrs = [x.copy() for x in (s, v, a, f)]
            arrs[which][1] = bad
            yield _seg(*arrs)
    yield _seg(s, v, a, f, time_t=math.inf)
    yield _seg(s, v, a, f, int_a2=math.nan)
    yield _seg(s[:1], v[:1], a[:0], f[:0])                       # one knot
    yield _seg(s, v, a[:2], f)                                   # wrong sizes
    yield _seg(s, v, a, f[:1])
    yield _seg(s, v[:0], a, f)                                   # no speeds: not checked
    yield _seg(s, v[:2], a, f)
    yield _seg(np.array([0.0, 1.0, 1.0, 4.0]), v, a, f)          # a repeated knot
    yield _seg(np.array([0.0, 2.0, 1.0, 4.0]), v, a, f)
    yield _seg(np.array([0.0, 5e-324, 1e-323, 4.0]), v, a, f)    # subnormal steps
    yield _seg(s, v, np.array([100.0, 0.0, 50.0]), f)
    yield _seg(s, v, np.array([100.0, -0.0, 50.0]), f)
    yield _seg(s, v, a, np.array([20.0, -1.0, 21.0]))
    yield _seg(s, np.array([10.0, -1e-300, 20.0, 5.0]), a, f)
    yield _seg(s, np.array([10.0, -0.0, 20.0, 5.0]), a, f)
    yield _seg(np.array([0.0, 1e308, 1.7e308, 1.79e308]), v, a, f)   # the sum overflows: still fine
    yield _seg(s, np.array([1e308, 1e308, 20.0, 5.0]), a, f)
    yield _seg(list(s), list(v), list(a), list(f))               # lists: the old path
    yield _seg(s.astype(np.float32), v, a, f)
    yield _seg(s, v.astype(np.float32), a, f)
    yield _seg(s[None, :], v, a, f)                               # 2-D
    yield _seg(s, v, a[None, :], f)
    yield _seg(s, v, a, ["x", 1.0, 2.0])                          # malformed
    yield _seg(np.array([0.0, 1.0, 2.0, 3.0]).astype(">f8"), v, a, f)   # other byte order


def test_seg_fault_same_reasons():
    for seg in _cases():
        assert sc._seg_fault(seg) == _old_seg_fault(seg), (seg.s, seg.v, seg.accel, seg.feed)


def test_seg_fault_random_plans():
    rng = np.random.default_rng(2)
    for _ in range(3000):
        n = int(rng.integers(2, 40))
        s = np.cumsum(rng.uniform(0.0, 1.0, n))
        s[0] = 0.0
        v = rng.uniform(0.0, 100.0, n)
        a = rng.uniform(0.0, 3000.0, n - 1)
        f = rng.uniform(0.0, 100.0, n - 1)
        for x in (s, v, a, f):
            if rng.random() < 0.05:
                x[rng.integers(x.size)] = rng.choice([0.0, -1.0, np.nan, np.inf, -0.0])
        seg = _seg(s, v, a, f, float(rng.choice([1.0, np.inf])) if rng.random() < 0.05 else 1.0)
        assert sc._seg_fault(seg) == _old_seg_fault(seg)


def test_seg_fault_of_a_segment_plan_is_kept():
    s, v, a, f = _fine()
    seg = SegmentPlan(s, v, a, f, 1.0, 1.0)
    assert sc.seg_fault(seg) == "" and seg.fault == ""
    bad = SegmentPlan(s, v, np.array([1.0, 0.0, 1.0]), f, 1.0, 1.0)
    assert sc.seg_fault(bad) == "error: segments (acceleration, feed or speed not above 0)"


# ---------------------------------------------------------------- curves


def _bits(x, y):
    return np.asarray(x).tobytes() == np.asarray(y).tobytes()


def test_predict_curve_same_bits():
    rng = np.random.default_rng(4)
    for _ in range(2000):
        n = int(rng.integers(2, 90))
        s = np.concatenate([[0.0], np.cumsum(rng.uniform(1e-3, 2.0, n))])
        v = rng.uniform(0.0, 150.0, n + 1)
        if rng.random() < 0.2:
            v[rng.integers(n + 1)] = 0.0
        a = rng.uniform(0.0, 4000.0, n)
        if rng.random() < 0.2:
            a[rng.integers(n)] = 0.0
        cos_turn = rng.uniform(0.5, 1.0, n - 1)
        c0 = None if rng.random() < 0.3 else float(rng.uniform(0.5, 1.0))
        c1 = None if rng.random() < 0.3 else float(rng.uniform(0.5, 1.0))
        got = curves.predict_curve(s, v, a, cos_turn, c0, c1)
        want = _old_predict_curve(s, v, a, cos_turn, c0, c1)
        assert _bits(got[0], want[0]) and _bits(got[1], want[1])
        assert type(got[0]) is type(want[0]) and type(got[1]) is type(want[1])


def _stroke(rng, n, junction_jd=0.02):
    u = rng.normal(size=(n, 2))
    u /= np.hypot(u[:, 0], u[:, 1])[:, None]
    lim = types.SimpleNamespace(jd=junction_jd, ax_max=3000.0, ay_max=2500.0)
    st = types.SimpleNamespace(lim=lim, accel=float(rng.choice([1500.0, 4000.0])),
                               v0=float(rng.uniform(0.0, 50.0)), v1=float(rng.choice([0.0, 30.0])),
                               prev_u=None if rng.random() < 0.3 else tuple(u[0]),
                               next_u=None if rng.random() < 0.3 else tuple(u[-1]))
    g = types.SimpleNamespace(d=rng.uniform(0.05, 3.0, n), u=u)
    return st, g


@pytest.mark.parametrize("junction", ["jerk", "jd", "scv"])
def test_junction_accels_same_bits(junction):
    rng = np.random.default_rng({"jerk": 1, "jd": 2, "scv": 3}[junction])
    for _ in range(400):
        n = int(rng.integers(1, 30))
        st, g = _stroke(rng, n)
        vk = rng.uniform(0.0, 120.0, n + 1)
        acc = rng.uniform(0.0, 3000.0, n)
        pick = rng.random()
        if pick < 0.2:
            acc[rng.integers(n)] = -5.0            # below the floor: the loop raises it
        elif pick < 0.3:
            acc[rng.integers(n)] = np.nan
        elif pick < 0.4:
            acc[rng.integers(n)] = -0.0
        rules = types.SimpleNamespace(junction=junction)
        prof = types.SimpleNamespace(block_buffer=int(rng.choice([0, 16])))
        got = curves.junction_accels(st, g, vk, acc.copy(), rules, prof)
        want = _old_junction_accels(st, g, vk, acc.copy(), rules, prof)
        assert _bits(got, want), (junction, acc, got, want)
        assert got.dtype == want.dtype
