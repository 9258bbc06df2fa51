"""Round 65 (crv): curve work not done twice.

* curves._distinct_rows: laws grouped by their arguments' bits (a 64-bit mix, each row then
  compared with its group's first; the keys' own np.unique where a mix is shared).
* curves._distinct_curve_rows: candidates_curve makes each set of rows that read the same
  numbers once; the tables are those of every row solved.
* curves._knot_speeds_distinct: a distinct law solved and its grid values made once, every
  stroke at its own knots.
The reference in each case is the same code with the step turned off, compared bit for bit."""
import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt import schedule as sc
from gcode_opt.laws import circle
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_CURVE
from test_speed47_bud47_knots import S, _curve_laws, _same_knots  # noqa: E402

INV = circle.rows_invariant()
need_inv = pytest.mark.skipif(not INV, reason="this BLAS does not give rows their own bits")

def _args(rng, n):
    """solve_circles' arguments of n arcs of curve-like numbers (a few in the layer regime)."""
    phi = rng.uniform(0.2, 6.0, n)
    T = rng.uniform(0.05, 1.0, n)
    beta = (T / rng.uniform(0.3, 30.0, n)) ** 2
    w0, w1 = phi * rng.uniform(0.0, 1.2, n), phi * rng.uniform(0.0, 1.2, n)
    R = rng.uniform(1.0, 40.0, n)
    return [phi, T, beta, w0, w1, R]


def test_distinct_rows_groups_by_bits():
    rng = np.random.default_rng(65)
    args = _args(rng, 40)
    rep = rng.integers(0, 40, 25)
    args = [np.concatenate([a, a[rep]]) for a in args]
    args[0][3] = -0.0 if args[0][3] == 0.0 else args[0][3]
    args[1][0], args[1][1] = np.nan, np.nan                  # (NaN rows: equal where their bits are)
    args[2][0] = args[2][1]
    for a in args:
        a[1] = a[0]
    first, inv = curves._distinct_rows(args)
    assert (np.diff(first) > 0).all() and first[0] == 0
    keys = np.stack(args, 1).view(np.uint64)
    assert (keys[first[inv]] == keys).all()
    assert len({keys[i].tobytes() for i in range(keys.shape[0])}) == first.size
    zero = [np.array([0.0, -0.0]) for _ in range(6)]        # -0.0 is not 0.0
    assert curves._distinct_rows(zero) is None
    assert curves._distinct_rows([a[:40] for a in _args(np.random.default_rng(1), 40)]) is None


def test_distinct_rows_when_a_mix_is_shared(monkeypatch):
    """A hash shared by different rows (forced: every row's the same) is told apart by the keys."""
    rng = np.random.default_rng(7)
    args = _args(rng, 10)
    args = [np.concatenate([a, a[:4]]) for a in args]
    want = curves._distinct_rows(args)
    monkeypatch.setattr(curves, "unique_first_inverse", lambda h: (np.zeros(1, np.int64), np.zeros(h.size, np.intp)))
    got = curves._distinct_rows(args)
    assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
    assert np.array_equal(want[0], np.arange(10)) and np.array_equal(want[1][10:], np.arange(4))


@pytest.fixture(scope="module")
def gyroid_laws():
    return _curve_laws("prusa_gyroid.gcode", "prusa-mk3s")


@need_inv
def test_knot_speeds_of_repeated_laws(gyroid_laws, monkeypatch):
    """Every law three times (other strokes' knots where they repeat): each stroke's knots
    those of its law evaluated for it alone."""
    sts, T, beta, prof = gyroid_laws[:4]
    n = len(sts)
    pick = np.concatenate([np.arange(n), np.arange(n)[::-1], np.arange(0, n, 3)])
    sts3 = [sts[i] for i in pick]
    got = curves.curve_knots(sts3, T[pick], beta[pick], prof)
    monkeypatch.setattr(curves, "_distinct_rows", lambda args: None)
    want = curves.curve_knots(sts3, T[pick], beta[pick], prof)
    _same_knots(got, want)
    monkeypatch.undo()
    monkeypatch.setattr(curves, "_INTERP_ROWS", None)
    _same_knots(curves.curve_knots(sts3, T[pick], beta[pick], prof), want)


def _pin_rows(name, prof_name):
    prof = load_profile(prof_name)
    opts = Options()
    strokes, _ = analyse(S + name, prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    rows = np.array([i for i in sc._rows_by_kind(strokes)[K_CURVE] if not pin.fault[i]], int)
    return strokes, pin, rows, prof


def _lv(own):
    """An own_levels entry's (levels, made figures), the levels asked where a function."""
    lv, made = own
    return (lv() if callable(lv) else lv), made


@need_inv
@pytest.mark.parametrize("name", ["prusa_gyroid.gcode", "prusa_concentric.gcode"])
def test_distinct_curve_rows_same_tables(name, monkeypatch):
    """Rows given twice (and the file's own repeats): the tables of every row solved, its
    own levels too."""
    strokes, pin, rows, prof = _pin_rows(name, "prusa-mk3s")
    rows2 = np.concatenate([rows, rows[::2]])
    d = curves._distinct_curve_rows(pin, rows2, strokes, prof)
    assert d is not None and d[0].size <= rows.size
    own = []
    got = curves.candidates_curve(pin, rows2, strokes, prof, own_levels=own)
    with monkeypatch.context() as m:
        m.setattr(curves, "_distinct_curve_rows", lambda *a: None)
        m.setattr(curves, "_distinct_rows", lambda args: None)
        own0 = []
        want = curves.candidates_curve(pin, rows2, strokes, prof, own_levels=own0)
        assert [_lv(x) for x in own] == [_lv(x) for x in own0]
    for a, b in zip(got, want):
        assert a.tobytes() == b.tobytes()
    assert np.isfinite(got[2]).sum() > 20
