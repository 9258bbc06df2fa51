"""Round 20 (curves): the circle law's preconditioned iteration (laws/circle.py
_precond_cheb) and the curvature kernel of curves._parts_block run their elementwise work
in the optional compiled core laws/_curvecore.c (module _gcode_opt_curvecore).  The start
commit's (ede93db) functions are kept here verbatim as the references; the new ones (the
compiled path and the numpy fallback) must give the same bits on real inputs: every call
the pipeline makes on the bundled gyroid, concentric and benchy-like files (and the
gyroid plate's curve strokes, when the corpus is there), plus random and degenerate
inputs.  Without the core (GCODE_OPT_PURE_PYTHON=1) the fallback is the old code.
Round 46: the iteration's three products are sums in the order of k (circle._mm_ordered,
the compiled pc_solve's), no longer BLAS calls of 32-row blocks: the reference takes
_mm_ordered_ref (below) where it took _rows_matmul."""
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt.laws import circle
from gcode_opt.laws.circle import (_PRECOND_FLOOR, _PRECOND_ITER, _PRECOND_SLOW_R, _PRECOND_TOL, _cheb_setup,
                                   _eig_setup)
from gcode_opt.curves import MAX_R_OVER_S, SMOOTH_MIN_D, _pmax
from gcode_opt.pipeline import Options, analyse, process
from gcode_opt.profile import load_profile

S = Path(__file__).resolve().parent.parent / "sample_gcode"
PLATE = Path.home() / ".cache/gcode-opt-corpus/plate_gyroid.gcode"
HAVE_CORE = circle.CORE_MOD is not None


# ---------------------------------------------------------------- references (ede93db, verbatim)
def _mm_ordered_ref(x, m):
    """x @ m as the sum over k of x[:, k] m[k] in the order of k (round 46's products)."""
    out = np.empty((x.shape[0], m.shape[1]))
    for i in range(x.shape[0]):
        acc = x[i, 0] * m[0]
        for k in range(1, m.shape[0]):
            acc = acc + x[i, k] * m[k]
        out[i] = acc
    return out


def _precond_cheb_ref(n, phi, gam2, u0, u1, w_start, tol=_PRECOND_TOL):
    """The collocation equations of _newton_cheb solved by a preconditioned fixed-point
    iteration: each step is the Newton step with the Jacobian's diagonal γ² + 6w² replaced
    by its mid-range value ḡ, whose inverse is diagonal in the eigenbasis of the second-
    derivative block (two small matrix products per step instead of an LU of (N, N) per
    arc).  The contraction factor is ≤ (half the range of 6w²) / (π² + ḡ) < 1; on the
    gentle laws of curves and arcs it is ~0.1, so ~15 cheap steps replace ~4 LU solves.
    The fixed point is the same collocation solution (the residual is computed exactly).
    Returns (w nodes, C, ok); arcs not converged (a slow contraction: steep layers) have
    ok False and are left to _newton_cheb.  (Round 48: tol, the stop, a parameter: the
    pipeline's rough laws stop at circle._ROUGH_TOL.)"""
    cs = _cheb_setup(n)
    eg = _eig_setup(n)
    nb = phi.size
    w = w_start.copy()
    w[:, 0], w[:, -1] = u0, u1
    cc = np.zeros(nb)
    ok = np.zeros(nb, dtype=bool)
    if eg is None or nb == 0:
        return w, cc, ok
    # row-wise products only (_rows_matmul, sums along rows): an arc's iteration is its own,
    # bit for bit, whatever the batch
    d2_t = np.ascontiguousarray(cs["d2"][1:-1].T)
    q, lam_e, qv, e = cs["q"], eg["lam"], eg["qv"], eg["e"]
    scale = np.maximum.reduce([np.abs(phi), np.abs(u0), np.abs(u1), np.full(nb, 1e-300)])
    act = np.arange(nb)
    last = np.full(nb, np.inf)
    for it in range(_PRECOND_ITER):
        wa, ca = w[act], cc[act]
        wi = wa[:, 1:-1]
        g2 = gam2[act]
        w2 = wi * wi
        r1 = _mm_ordered_ref(wa, d2_t) - g2[:, None] * wi - 2.0 * wi * w2 - ca[:, None]
        r2 = (wa * q).sum(axis=1) - phi[act]
        den = lam_e[None, :] - (g2 + 3.0 * (w2.max(axis=1) + w2.min(axis=1)))[:, None]
        b = -_mm_ordered_ref(r1, eg["vinv_t"])
        dc = (-r2 - ((b / den) * qv).sum(axis=1)) / ((qv * e) / den).sum(axis=1)
        dw = _mm_ordered_ref((b + dc[:, None] * e) / den, eg["v_t"])
        w[act, 1:-1] = wi + dw
        cc[act] = ca + dc
        step = np.abs(dw).max(axis=1)
        # done: at the rounding floor of the residual (steps no longer shrink), or below it
        slow = (it >= 4) & ~(step < _PRECOND_SLOW_R * last[act])
        done = (step <= tol * scale[act]) | (slow & (step <= _PRECOND_FLOOR * scale[act]))
        if it >= 1:       # (round 49: or the steps left, a geometric series at the last ratio, within it)
            rho = step / last[act]
            done |= (rho < 1.0) & (step * rho <= tol * scale[act] * (1.0 - rho))
        ok[act[done]] = True
        keep = ~done & np.isfinite(step) & ~slow
        last[act] = step
        act = act[keep]
        if act.size == 0:
            break
    return w, cc, ok


def _parts_block_ref(pts):
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
    smooth_d = _pmax(med, SMOOTH_MIN_D)
    # curvature_from_polyline(pts, smooth_d): its one window covers every interior vertex
    heading = np.arctan2(seg[..., 1], seg[..., 0])
    turn = np.angle(np.exp(1j * np.diff(heading, axis=1)))
    s_i = s_v[:, 1:-1]
    ell = 0.5 * (d[:, :-1] + d[:, 1:])
    # kern = exp(-0.5 (z2 - min z2)), z2 = ((s_v - s_i) / smooth_d)^2: the same operations
    # in place in one array (x ** 2 is np.square; -0.5 x = x (-0.5)), not one new array of
    # m (n+1)(n-1) doubles per step
    kern = np.subtract(s_v[:, :, None], s_i[:, None, :])
    np.divide(kern, smooth_d[:, None, None], out=kern)
    np.square(kern, out=kern)
    np.subtract(kern, kern.min(axis=2, keepdims=True), out=kern)
    np.multiply(kern, -0.5, out=kern)
    np.exp(kern, out=kern)
    # matrix-vector products stacked: numpy makes the same BLAS gemv call per stroke as the
    # per-stroke path's kern @ turn (same shapes and strides), so the same bits
    kappa_v = (kern @ turn[:, :, None])[..., 0] / (kern @ ell[:, :, None])[..., 0]
    good &= np.isfinite(kappa_v).all(axis=1)
    # np.interp(s_v, s_d, kappa_v) at its own nodes is kappa_v itself
    S = s_v[:, -1]
    mid = 0.5 * (kappa_v[:, :-1] ** 2 + kappa_v[:, 1:] ** 2)
    k2 = np.sum(mid * d, axis=1) / S
    kappa_eff = _pmax(np.sqrt(k2), 1.0 / (MAX_R_OVER_S * S))
    return d, u, cos_turn, s_v, kappa_v, kappa_eff.tolist(), good


# ---------------------------------------------------------------- real inputs
def _bits(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def _record(monkeypatch, mod, name, sink):
    f = getattr(mod, name)

    def rec(*args):
        sink.append(tuple(a.copy() if isinstance(a, np.ndarray) else a for a in args))
        return f(*args)
    monkeypatch.setattr(mod, name, rec)


CASES = (("prusa_gyroid.gcode", "prusa-mk3s"), ("prusa_concentric.gcode", "prusa-mk3s"),
         ("prusa_benchy_like.gcode", "prusa-mk3s"), ("prusa_gyroid.gcode", "voron24"))


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """Every _precond_cheb call of the pipeline on the bundled curve files, the blocks of
    their curve strokes' vertices (_curve_blocks: the pipeline's build_geoms makes the same
    parts from one flat pass over several blocks since session 55, not a _parts_block call
    a block) and each output file's bytes."""
    mp = pytest.MonkeyPatch()
    pcs, outs = [], {}
    try:
        _record(mp, circle, "_precond_cheb", pcs)
        d = tmp_path_factory.mktemp("curves20")
        for name, prof in CASES:
            out = d / (name + "." + prof)
            process(str(S / name), str(out), load_profile(prof), Options())
            outs[(name, prof)] = out.read_bytes()
    finally:
        mp.undo()
    pbs = [(b,) for name, prof in CASES[:3] for b in _curve_blocks(S / name, prof)]
    assert len(pcs) > 5 and len(pbs) > 20
    return pcs, pbs, outs


def _curve_blocks(path, prof_name):
    """The file's curve strokes' vertices as blocks of strokes of one vertex count, of
    build_geoms' block size (curves._GEOM_BLOCK)."""
    strokes, _ = analyse(str(path), load_profile(prof_name), Options())
    by = {}
    for st in strokes:
        if st.kind == "curve":
            by.setdefault(len(st.pts), []).append(curves._xy(st))
    for npt, xs in by.items():
        if 3 <= npt <= curves._GEOM_MAX_PTS:
            step = max(1, curves._GEOM_BLOCK // (npt * npt))
            for a in range(0, len(xs), step):
                yield np.concatenate(xs[a:a + step]).reshape(-1, npt, 2)


def _precond_forms():
    forms = [circle._precond_cheb_np]
    if HAVE_CORE:
        forms.append(circle._precond_cheb_c)
    return forms


def _check_precond(args):
    want = _precond_cheb_ref(*args)
    for form in _precond_forms():
        got = form(*args)
        assert _bits(got[0], want[0]) and _bits(got[1], want[1]) and _bits(got[2], want[2]), form.__name__


def test_precond_bitwise_on_the_pipelines_calls(recorded):
    pcs, _, _ = recorded
    assert sum(a[1].size for a in pcs) > 1000
    for args in pcs:
        _check_precond(args)


def test_precond_bitwise_on_random_and_degenerate_arcs():
    """Batch sizes around _rows_matmul's 32-row blocks, several N of the ladder (N >= 128:
    pairwise sums of more than 128 terms), steep laws the iteration leaves to Newton,
    zero and NaN inputs, non-finite steps."""
    rng = np.random.default_rng(20)
    for n in (16, 20, 24, 64, 128):
        for nb in (1, 32, 33, 70):
            phi = rng.uniform(-3.0, 6.0, nb) * rng.choice([1.0, 1.0, 1e-3, 40.0], nb)
            gam2 = rng.uniform(0.0, 20.0, nb) * rng.choice([1.0, 1.0, 100.0, 1e4], nb)
            u0 = rng.uniform(0.0, 3.0, nb) * rng.choice([1.0, 0.0, 10.0], nb)
            u1 = rng.uniform(0.0, 3.0, nb) * rng.choice([1.0, 0.0, 10.0], nb)
            if nb > 30:
                phi[3], gam2[5], u0[7] = 0.0, np.nan, np.inf
                u0[8] = u1[8] = phi[8] = 0.0
            w0 = np.empty((nb, n + 1))
            w0[:] = phi[:, None]
            if n in (20, 64):
                w0 = w0 + rng.normal(0.0, 0.1, w0.shape)      # a warm start that is not constant
            with np.errstate(all="ignore"):
                _check_precond((n, phi, gam2, u0, u1, w0))


def _check_parts(pts):
    with np.errstate(all="ignore"):
        want = _parts_block_ref(pts)
        core = curves._CURVE_CORE
        forms = [None] + ([core] if core is not None else [])
        for c in forms:
            curves._CURVE_CORE = c
            try:
                got = curves._parts_block(pts)
            finally:
                curves._CURVE_CORE = core
            for x, y in zip(got, want):
                if isinstance(y, list):
                    assert [float(v).hex() for v in x] == [float(v).hex() for v in y]
                else:
                    assert _bits(x, y), c


def test_parts_block_bitwise_on_the_pipelines_blocks(recorded):
    _, pbs, _ = recorded
    assert sum(a[0].shape[0] for a in pbs) > 500
    for (pts,) in pbs:
        _check_parts(pts)


@pytest.mark.skipif(not PLATE.exists(), reason="corpus plate not there")
def test_parts_block_bitwise_on_the_gyroid_plates_curves():
    prof = load_profile("prusa-mk3s")
    strokes, _ = analyse(str(PLATE), prof, Options())
    by = {}
    for st in strokes:
        if st.kind == "curve":
            by.setdefault(len(st.pts), []).append(curves._xy(st))
    assert sum(len(v) for v in by.values()) > 10000
    for npt, xs in by.items():
        if npt < 3 or npt > curves._GEOM_MAX_PTS:
            continue
        step = max(1, curves._GEOM_BLOCK // (npt * npt))
        for a in range(0, len(xs), step):
            _check_parts(np.concatenate(xs[a:a + step]).reshape(-1, npt, 2))


def test_parts_block_bitwise_on_degenerate_strokes():
    """Duplicate points, NaN and infinite coordinates, tiny and huge segments."""
    rng = np.random.default_rng(5)
    for npt in (3, 4, 7, 8, 30, 90):
        pts = np.cumsum(rng.normal(0.0, 1.0, (12, npt, 2)), axis=1)
        pts[1, 2] = pts[1, 1]
        pts[2, 1, 0] = np.nan
        pts[3, -1, 1] = np.inf
        pts[4] *= 1e-7
        pts[5] *= 1e150
        pts[6] = np.round(pts[6], 3)
        pts[7] = 0.0
        _check_parts(pts)


def test_outputs_the_same_without_the_core(recorded, tmp_path, monkeypatch):
    """The pipeline with the numpy forms (core missing) writes the same bytes."""
    _, _, outs = recorded
    monkeypatch.setattr(circle, "CORE_MOD", None)
    monkeypatch.setattr(curves, "_CURVE_CORE", None)
    for (name, prof), want in outs.items():
        if name != "prusa_gyroid.gcode":
            continue
        out = tmp_path / (name + "." + prof)
        process(str(S / name), str(out), load_profile(prof), Options())
        assert out.read_bytes() == want, (name, prof)


def test_core_is_loaded_and_falls_back():
    """Built here (the CI builds the cores); GCODE_OPT_PURE_PYTHON=1 or a core built from
    another source leaves the numpy forms."""
    from gcode_opt import native
    src = Path(circle.__file__).resolve().parent / "_curvecore.c"
    if HAVE_CORE:
        assert circle.CORE == "c" and curves._CURVE_CORE is circle.CORE_MOD
        assert native.load("_gcode_opt_curvecore", str(src), "curve core")[0] is not None
    code = ("from gcode_opt.laws import circle; from gcode_opt import curves; "
            "print(circle.CORE, curves._CURVE_CORE is None)")
    env = dict(os.environ, GCODE_OPT_PURE_PYTHON="1")
    got = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert got.stdout.split() == ["python", "True"]


def test_stale_core_is_not_used(tmp_path):
    from gcode_opt import native
    if not HAVE_CORE:
        pytest.skip("core not built")
    other = tmp_path / "_curvecore.c"
    other.write_text("/* another source */\n")
    mod, why = native.load("_gcode_opt_curvecore", str(other), "curve core")
    assert mod is None and "another" in why


def _cheb_der_int_ref(coef):
    """ede93db's CircleBatch._eval_cheb: numpy.polynomial's own functions."""
    from numpy.polynomial import chebyshev as C
    return C.chebder(coef, axis=1, scl=2.0), C.chebint(coef, axis=1, lbnd=-1.0, scl=0.5)


def _check_cheb(coef):
    want = _cheb_der_int_ref(coef)
    got = circle._cheb_der_int(coef)
    for x, y in zip(got, want):
        assert x.shape == y.shape and x.strides == y.strides and _bits(x, y)


def test_cheb_der_int_bitwise_on_real_curves_laws():
    """The series of the circle laws of the bundled files' curve strokes at a few
    durations and betas (trimmed as _eval_cheb trims them: the padding common to all
    rows dropped), and every third row of them."""
    got = []
    for name in ("prusa_gyroid.gcode", "prusa_concentric.gcode"):
        prof = load_profile("prusa-mk3s")
        strokes, _ = analyse(str(S / name), prof, Options())
        sts = [st for st in strokes if st.kind == "curve"][:400]
        curves.build_geoms(sts, prof)
        geos = [curves.geom(st, prof) for st in sts]
        S_ = np.array([st.length_d for st in sts])
        T = S_ / np.array([st.v_feed for st in sts]) * 1.05
        for beta in (1e-4, 1e-3, 3e-2):
            law, _ = curves._solve(None, geos, S_, T, np.full(len(sts), beta), np.array([st.v0 for st in sts]),
                                   np.array([st.v1 for st in sts]))
            ch = ~law.regime
            coef = law.coef[ch]
            nz = np.nonzero(np.any(coef != 0, axis=0))[0]
            got.append(coef[:, : (nz[-1] + 1 if nz.size else 1)])
    assert sum(c.shape[0] for c in got) > 300
    for coef in got:
        _check_cheb(coef)
        _check_cheb(coef[::3])


def test_cheb_der_int_bitwise_on_random_series():
    rng = np.random.default_rng(2)
    # (K to 256: the core's 4-row AVX form; 257, 300: its scalar rows; nb 5, 7: both at once)
    for K in (1, 2, 3, 4, 5, 8, 17, 21, 33, 64, 129, 200, 256, 257, 300):
        for nb in (1, 5, 7, 64):
            c = rng.normal(size=(nb, K)) * rng.choice([1.0, 1e-3, 1e5, 0.0], (nb, K))
            if nb > 3:
                c[1, :] = 0.0
                c[2, -1] = -0.0
                c[3, 0] = np.nan
            with np.errstate(all="ignore"):
                _check_cheb(c)
                _check_cheb(c[:, : max(K - 1, 1)])       # a column slice (_eval_cheb's trimmed view)
