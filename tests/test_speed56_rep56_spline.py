"""Round 42 (rep56): laws.spline.NotAKnotCubic, the curvature spline the report's curve law
reads (laws.curve.PolylineCurvature), in numpy: scipy's CubicSpline (not-a-knot, its default)
is the independent check, value and derivatives, inside and outside the knots, on random
knots of every size the code treats apart (2, 3, 4 and more) and on real curvature; and
`process --report` no longer imports scipy.interpolate (~45 MB resident).  And the curve law
the report draws, solved to a plot's tail (report.profiles.PLOT_TAIL_TOL), against the law
solved to the solver's own."""
import os
import subprocess
import sys

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from gcode_opt.laws.curve import curvature_from_polyline, solve_curve
from gcode_opt.laws.spline import NotAKnotCubic
from gcode_opt.report.profiles import N_LAW, PLOT_TAIL_TOL

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _agree(x, y):
    a, b = CubicSpline(x, y), NotAKnotCubic(x, y)
    xq = np.concatenate([np.linspace(x[0] - 0.3, x[-1] + 0.3, 777), x])
    for nu in range(4):
        scale = np.abs(y).max() / np.diff(x).min() ** nu + 1e-300
        np.testing.assert_allclose(b(xq, nu), a(xq, nu), rtol=0, atol=1e-11 * scale)


@pytest.mark.parametrize("n", [2, 3, 4, 5, 7, 66, 400])
def test_as_scipys_on_random_knots(n):
    rng = np.random.default_rng(n)
    for _ in range(10):
        x = np.cumsum(rng.uniform(0.005, 3.0, n))
        _agree(x, rng.normal(size=n))


def test_as_scipys_on_real_curvature():
    rng = np.random.default_rng(5)
    th = np.cumsum(rng.normal(0.0, 0.08, 120))
    pts = np.cumsum(np.stack([np.cos(th), np.sin(th)], 1) * rng.uniform(0.2, 0.6, (120, 1)), 0)
    k = curvature_from_polyline(pts)
    _agree(k.s_d, k.kappa_v)
    s = np.linspace(0.0, k.length_d, 301)
    np.testing.assert_allclose(k.kappa(s), CubicSpline(k.s_d, k.kappa_v)(s), rtol=0, atol=1e-12)


def test_a_cubic_is_its_own_spline():
    x = np.array([0.0, 0.4, 1.1, 1.5, 2.9, 3.0])
    y = 2.0 * x ** 3 - x ** 2 + 0.5 * x - 1.0
    sp = NotAKnotCubic(x, y)
    xq = np.linspace(-1.0, 4.0, 51)
    np.testing.assert_allclose(sp(xq), 2.0 * xq ** 3 - xq ** 2 + 0.5 * xq - 1.0, atol=1e-11)
    np.testing.assert_allclose(sp(xq, 3), 12.0, atol=1e-9)
    with pytest.raises(ValueError):
        sp(xq, 4)


def test_report_of_a_curve_without_scipy_interpolate(tmp_path):
    """The curve representative's law is drawn without scipy.interpolate imported."""
    src = os.path.join(ROOT, "sample_gcode", "prusa_gyroid_arcs.gcode")
    code = ("import sys\nfrom gcode_opt import cli\n"
            "from gcode_opt.report import profiles\n"
            "drawn = []\n_law = profiles._curve_law\n"
            "def spy(*a):\n    r = _law(*a)\n    drawn.append(r)\n    return r\n"
            "profiles._curve_law = spy\n"
            f"rc = cli.main(['process', {src!r}, '-o', 'o.gcode', '-q', '--profile', 'prusa-mk3s', "
            "'--report', 'r.html'])\n"
            "print(rc, len(drawn), 'scipy.interpolate' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], cwd=str(tmp_path), env=dict(os.environ, PYTHONPATH=ROOT),
                         capture_output=True, text=True, check=True).stdout.split()
    assert out == ["0", "1", "False"]


# ---------------------------------------------------------------- the drawn curve law's tail
# The gyroid plate's curve representative (plate_gyroid.gcode of sample_gcode/make_corpus.sh,
# prusa-mk3s): its 66 vertices as the file has them, and the law's T, beta, v0, v1 the report asked
PLATE_CURVE = [
    (155.704, 99.426), (154.606, 98.597), (154.248, 98.161), (154.019, 97.724), (153.816, 96.85), (153.879, 96.414),
    (154.213, 95.977), (155.371, 95.103), (155.729, 94.666), (155.957, 94.23), (156.16, 93.356), (156.097, 92.919),
    (155.764, 92.483), (154.606, 91.609), (154.248, 91.172), (154.019, 90.736), (153.816, 89.862), (153.879, 89.425),
    (154.213, 88.988), (155.371, 88.115), (155.729, 87.678), (155.957, 87.241), (156.16, 86.368), (156.097, 85.931),
    (155.764, 85.494), (154.606, 84.621), (154.248, 84.184), (154.019, 83.747), (153.816, 82.874), (153.879, 82.437),
    (154.213, 82.0), (155.371, 81.126), (155.729, 80.69), (155.957, 80.253), (156.16, 79.379), (156.097, 78.943),
    (155.764, 78.506), (154.606, 77.632), (154.248, 77.195), (154.019, 76.759), (153.816, 75.885), (153.879, 75.448),
    (154.213, 75.012), (155.371, 74.138), (155.729, 73.701), (155.957, 73.264), (156.16, 72.391), (156.097, 71.954),
    (155.764, 71.517), (154.606, 70.644), (154.248, 70.207), (154.019, 69.77), (153.816, 68.897), (153.879, 68.46),
    (154.213, 68.023), (155.371, 67.15), (155.729, 66.713), (155.957, 66.276), (156.16, 65.403), (156.097, 64.966),
    (155.848, 64.64), (155.295, 64.389), (154.127, 63.95), (152.934, 63.587), (151.719, 63.304), (150.452, 63.098)]
PLATE_LAW = (1.3659650534096164, 194.31605905055065, 13.276786836076171, 8.21500042766483)


def _law_args(pts, T, beta, v0, v1):
    k = curvature_from_polyline(np.asarray(pts, float))
    return (k.kappa, k.dkappa_ds, k.length_d, T, beta, v0, v1, k.d2kappa_ds2), k.length_d


def _close_laws(a, b, T, S, v0, v1, rel):
    """a and b agree within rel of their largest s, v, a on N_LAW points, and a keeps the ends."""
    t = np.linspace(0.0, T, N_LAW)
    for x, y in zip(a.eval(t), b.eval(t)):
        assert np.abs(x - y).max() <= rel * np.abs(y).max()
    s, v, _ = a.eval(np.array([0.0, T]))
    np.testing.assert_allclose(s, [0.0, S], rtol=0, atol=1e-9 * S)
    np.testing.assert_allclose(v, [v0, v1], rtol=0, atol=1e-7 * max(v0, v1, 1.0))


def test_drawn_law_as_the_strict_one_on_a_smooth_curve():
    """Where the solver's own tail is met, the law at PLOT_TAIL_TOL is the same law to plot
    accuracy (a sine-like wave of 0.4 mm segments)."""
    x = np.arange(0.0, 30.0, 0.4)
    pts = np.stack([x, 2.0 * np.sin(x / 3.0)], 1)
    T, beta, v0, v1 = 0.5, 50.0, 20.0, 10.0
    args, S = _law_args(pts, T, beta, v0, v1)
    strict = solve_curve(*args)
    drawn = solve_curve(*args, tail_tol=PLOT_TAIL_TOL)
    assert drawn.n <= strict.n
    _close_laws(drawn, strict, T, S, v0, v1, 1e-4)      # (a pixel of the chart: ~2.5e-3 of its height)


@pytest.mark.slow
def test_plate_curve_drawn_where_the_strict_tail_fails():
    """The plate's curve: the solver's own tail (1e-11) is not met at N = 512 (the report drew
    no law, after ~6 s and ~37 MB); at PLOT_TAIL_TOL the law is solved at a lower N and agrees
    with the N = 512 law (tail 5.7e-11) to well under a pixel."""
    T, beta, v0, v1 = PLATE_LAW
    args, S = _law_args(PLATE_CURVE, T, beta, v0, v1)
    with pytest.raises(RuntimeError):
        solve_curve(*args)
    drawn = solve_curve(*args, tail_tol=PLOT_TAIL_TOL)
    best = solve_curve(*args, tail_tol=1e-10)
    assert drawn.n < best.n == 512
    _close_laws(drawn, best, T, S, v0, v1, 1e-4)
