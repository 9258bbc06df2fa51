"""Round 64 (crv): the curve candidates' screen of rough laws in one compiled pass.

candidates_curve._screen rejects the candidates whose rough law is over on |a| alone by a
band (SCREEN_BAND_R); the others are solved in full and decided there, so the screen is a
filter: its verdicts need the accuracy of the probe's numbers, not BLAS's bits.
curves.screen_a_only has those numbers from _curvecore.c screen_rows (the series and its
derivative summed in the order of the coefficients, one pass a row), not eval_tau's chunks.

* screen_rows' AVX rows are its scalar rows, bit for bit (NaN, inf and zero rows too);
* its speeds and tangential |a| are eval_tau's to ~1e-15 of the row's scale, and its
  decisions probe_rows' of its own numbers;
* screen_a_only names the laws surely_over's why names, on the pipeline's screen calls
  (bundled gyroid and concentric files) at several caps, and falls back to surely_over
  without the core or with a layer-regime law;
* a law it names is over on |a| alone on its full law (surely_over of solve_circles), the
  property that makes the screen a filter."""
from pathlib import Path

import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt.laws import circle
from gcode_opt.pipeline import Options, process
from gcode_opt.profile import load_profile

CORE = circle.CORE_MOD
pytestmark = pytest.mark.skipif(CORE is None or not hasattr(CORE, "screen_rows"), reason="no compiled curve core")
S = Path(__file__).resolve().parent.parent / "sample_gcode"
M = curves._PROBE_TAU.size


def _screen_rows(coef, R, T, v_cap, a_cap, kv2ok=None):
    """screen_rows' decisions (rest: the rows left, over_v, over_a), then the rows left's
    speeds and tangential |a| (v, at: its second call, packed)."""
    nb, K = coef.shape
    vand, dvand = curves._screen_tables(K)
    rest = np.full(nb, -1, np.int64)
    over_v, over_a = np.empty((2, nb), bool)
    kv2ok = np.ones(nb, bool) if kv2ok is None else kv2ok
    args = (np.ascontiguousarray(coef), nb, K, vand, dvand, vand.shape[1], M, R, T, v_cap, a_cap, kv2ok)
    n = CORE.screen_rows(*args, np.empty((0, M)), np.empty((0, M)), rest, over_v, over_a, 0, 0)
    v, at = np.full((n, M), -1.0), np.full((n, M), -1.0)
    ov, oa = over_v.copy(), over_a.copy()
    CORE.screen_rows(*args, v, at, rest[:n], over_v, over_a, 1, n)
    assert np.array_equal(ov, over_v) and np.array_equal(oa, over_a)       # (the second call decides nothing)
    return v, at, rest[:n], over_v, over_a


def _laws(seed, n):
    rng = np.random.default_rng(seed)
    phi, T = rng.uniform(0.1, 9.0, n), rng.uniform(0.05, 1.0, n)
    law = circle.solve_circles(phi, T, 10.0 ** rng.uniform(-5, -2, n), phi / T * rng.uniform(0, 1.2, n),
                               phi / T * rng.uniform(0, 1.2, n), 2.0)
    return law.take(np.flatnonzero(~law.regime)), rng       # (Chebyshev laws: the layer regime has none)


def test_screen_rows_avx_as_scalar():
    law, rng = _laws(64, 300)
    coef = law.coef.copy()
    coef[0] = np.nan
    coef[1, 3] = np.inf
    coef[2] = 0.0
    coef[3, 1:] = 0.0                                  # (one coefficient)
    coef[4, 0] = 1e300
    nb = coef.shape[0]
    R, T = np.full(nb, 2.0), law.T_t.copy()
    R[5], T[6] = np.nan, 0.0
    v_cap, a_cap = rng.uniform(10.0, 500.0, nb), rng.uniform(100.0, 1e5, nb)
    kv2ok = rng.uniform(size=nb) < 0.8
    got = []
    for flag in (1, 0):
        try:
            CORE.simd(flag)
            with np.errstate(all="ignore"):
                got.append(_screen_rows(coef, R, T, v_cap, a_cap, kv2ok))
        finally:
            CORE.simd(1)
    for a, b in zip(*got):
        assert a.tobytes() == b.tobytes()
    v, at, rest, over_v, over_a = got[0]
    assert over_v.any() and not over_v.all() and over_a.any() and not over_a.all()
    assert 10 < rest.size < nb and np.array_equal(rest, np.flatnonzero(~(over_v | over_a)))


def test_screen_rows_near_eval_tau_and_probe_rows_decisions():
    law, rng = _laws(65, 500)
    nb = len(law)
    R = rng.uniform(0.5, 20.0, nb)
    tau = np.broadcast_to(curves._PROBE_TAU[None, :], (nb, M))
    _, w, w1, _ = law.eval_tau(tau, w2=False, phi=False)
    v_ref, at_ref = curves._row_scale(w, R, law.T_t, 1), curves._row_scale(w1, R, law.T_t, 2)
    # every row left (no speed cap, κ(s) always asked): every row's numbers, in order
    v, at, rest, _, _ = _screen_rows(law.coef, R, law.T_t, np.full(nb, np.inf), np.zeros(nb), np.zeros(nb, bool))
    assert np.array_equal(rest, np.arange(nb))
    assert np.all(np.abs(v - v_ref) <= 1e-14 * np.abs(v_ref).max(axis=1, keepdims=True))
    assert np.all(np.abs(at - at_ref) <= 1e-14 * np.abs(at_ref).max(axis=1, keepdims=True))
    v_cap = np.max(v_ref, axis=1) * rng.choice([0.9, 1.1], nb)
    a_cap = np.sqrt(np.max(at_ref * at_ref, axis=1)) * rng.choice([0.9, 1.1], nb)
    kv2ok = rng.uniform(size=nb) < 0.9
    _, _, rest, over_v, over_a = _screen_rows(law.coef, R, law.T_t, v_cap, a_cap, kv2ok)
    want = np.empty((3, nb), bool)
    CORE.probe_rows(v, at, nb, M, v_cap, a_cap, want[0], want[1], want[2])
    assert np.array_equal(over_v, want[0]) and np.array_equal(over_a, want[1] & want[2] & kv2ok)
    assert np.array_equal(rest, np.flatnonzero(~(over_v | over_a)))
    assert over_v.any() and not over_v.all() and over_a.any() and not over_a.all()


@pytest.fixture(scope="module")
def screens(tmp_path_factory):
    """screen_a_only's calls of the curve planner on the bundled gyroid and concentric files
    (the rough laws, R, geometries, the screen's limits, knots)."""
    got = []
    f = curves.screen_a_only
    mp = pytest.MonkeyPatch()

    def rec(law, R, geos, v_lim, a_lim, memo=None):
        got.append((law, R.copy(), list(geos), v_lim.copy(), a_lim.copy(), memo))
        return f(law, R, geos, v_lim, a_lim, memo)
    try:
        mp.setattr(curves, "screen_a_only", rec)
        d = tmp_path_factory.mktemp("screen64")
        for name in ("prusa_gyroid.gcode", "prusa_concentric.gcode"):
            process(str(S / name), str(d / name), load_profile("prusa-mk3s"), Options())
    finally:
        mp.undo()
    assert sum(len(a[2]) for a in got) > 500
    return got


def _why(law, R, geos, v_lim, a_lim, memo):
    why = []
    curves.surely_over(law, R, geos, v_lim, a_lim, memo, why)
    return why[0]


def test_screen_a_only_as_surely_over_on_the_pipelines_calls(screens):
    if not isinstance(screens[0][5], curves._Knots):
        pytest.skip("no compiled knots")
    named = kept = 0
    for law, R, geos, v_lim, a_lim, memo in screens:
        for scale_v, scale_a in ((1.0, 1.0), (1.0, 0.2), (0.3, 1.0), (1.0, 5.0), (0.1, 0.05)):
            with np.errstate(all="ignore"):
                got = curves.screen_a_only(law, R, geos, v_lim * scale_v, a_lim * scale_a, memo)
                want = _why(law, R, geos, v_lim * scale_v, a_lim * scale_a, memo)
            assert np.array_equal(got, want)
            named += int(got.sum())
            kept += int((~got).sum())
    assert named > 100 and kept > 100


def test_screen_a_only_falls_back_to_surely_over(screens, monkeypatch):
    law, R, geos, v_lim, a_lim, memo = max(screens, key=lambda a: len(a[2]))
    want = _why(law, R, geos, v_lim, a_lim, memo)
    calls = []
    so = curves.surely_over

    def count(*a, **k):
        calls.append(1)
        return so(*a, **k)
    monkeypatch.setattr(curves, "surely_over", count)
    lay = law.take(np.arange(len(law)))
    lay.regime[0] = True                               # a layer-regime law: eval_tau's layers
    with np.errstate(all="ignore"):
        curves.screen_a_only(lay, R, geos, v_lim, a_lim, memo)
        assert len(calls) == 1
        monkeypatch.setattr(curves, "_SCREEN_ROWS", None)
        assert np.array_equal(curves.screen_a_only(law, R, geos, v_lim, a_lim, memo), want)
        assert len(calls) == 2


def test_screened_laws_are_over_on_a_alone_on_their_full_laws(screens):
    """The screen's filter: the laws it names (rough laws over the |a| cap raised by
    SCREEN_BAND_R, not over the speed cap lowered by it) are over on |a| alone at the
    candidates' own caps on their full laws."""
    band = curves.SCREEN_BAND_R
    checked = 0
    for law, R, geos, v_lim, a_lim, memo in screens[:6]:
        with np.errstate(all="ignore"):
            named = np.flatnonzero(curves.screen_a_only(law, R, geos, v_lim, a_lim, memo))
            if not named.size:
                continue
            full = circle.solve_circles(law.phi_total[named], law.T_t[named], law.beta_s2[named], law.w0[named],
                                        law.w1[named], law.R_d[named])
            sub = memo.sub(named) if isinstance(memo, curves._Knots) else {}
            why = []
            curves.surely_over(full, R[named], [geos[i] for i in named.tolist()], v_lim[named] / (1.0 - band),
                               a_lim[named] / (1.0 + band), sub, why)
        assert why[0].all()
        checked += named.size
    assert checked > 100
