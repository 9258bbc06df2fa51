"""Issue 8 (s33, the chains' candidates): solve_fixed's glue around its C calls in three
more C passes (laws/_chaincore.c): the active chains' vertices (step_vertices, for
_Flat._step_vertices), the knot times (knot_times, for _knot_times: each chain's running
sums, as piece_cumsum and the scatter to the knots made them) and the vertices before their
time of distance (vert_prep, for _Flat._vertex_starts).  These tests hold each to its numpy
twin (the same helper without the core), bit for bit, on every call of real candidate-table
solves (a gyroid sample's chains under classic jerk and Klipper SCV, cold and warm steps),
and solve_flat with the core to solve_flat without it; and that the comparison sees one
ulp in one knot time."""
import numpy as np
import pytest

from gcode_opt import chains
from gcode_opt.laws import chain as lc

from chain_cases import fresh_chains, float_bits

pytestmark = pytest.mark.skipif(lc.CORE_MOD is None or not hasattr(lc.CORE_MOD, "vert_prep"),
                                reason=f"the chain core is not used here ({lc.CORE_WHY})")

CASES = [("sample_gcode/prusa_gyroid.gcode", "prusa-mk3s"),
         ("sample_gcode/prusa_gyroid_fullspeed_klipper.gcode", "voron24")]


def _flat(path, prof_name, ratio):
    """The file's chains as one _Flat at ratio x their original durations."""
    strokes, pin, rows, prof, _ = fresh_chains(path, prof_name)
    rows = rows[:400]
    base = chains._flat_chains([strokes[i] for i in rows.tolist()], prof)
    T = pin.T_orig[rows] * ratio
    return base.with_T(T, (T / chains.GAMMA_MIN) ** 2)


def _bits(x):
    x = np.asarray(x)
    return x.dtype.str, (float_bits(x) if x.dtype.kind == "f" else np.ascontiguousarray(x).tobytes())


def _same(got, want):
    assert len(got) == len(want)
    for x, y in zip(got, want):
        assert _bits(x) == _bits(y)


def _recorded_solve(fl, monkeypatch):
    """solve_flat of fl (cold, then warm from its own law at 1.1 x) with each helper's inputs
    recorded: [(name, args)]."""
    calls = []
    for name in ("_step_vertices", "_vertex_starts"):
        real = getattr(lc._Flat, name)

        def rec(self, *a, _real=real, _name=name):
            calls.append((_name, self, tuple(np.copy(x) if isinstance(x, np.ndarray) else x for x in a)))
            return _real(self, *a)
        monkeypatch.setattr(lc._Flat, name, rec)
    real_kt = lc._knot_times

    def rec_kt(*a):
        calls.append(("_knot_times", None, tuple(np.copy(x) for x in a[:4]) + a[4:]))
        return real_kt(*a)
    monkeypatch.setattr(lc, "_knot_times", rec_kt)
    m = fl.S.size
    res = lc.solve_flat(fl, lc.cold_binding(fl), np.zeros(fl.sv.size), np.zeros(m, bool), pieces=False)
    fl2 = fl.with_T(fl.T * 1.1, fl.beta)
    lc.solve_flat(fl2, res.bound.copy(), res.vert_t * 1.1, np.ones(m, bool), pieces=False)
    return calls


def _call(name, self, args):
    if name == "_knot_times":
        return (lc._knot_times(*args),)
    return getattr(lc._Flat, name)(self, *args)


@pytest.mark.parametrize("path,prof_name", CASES)
def test_step_helpers_equal_their_numpy_twins(path, prof_name, monkeypatch):
    fl = _flat(path, prof_name, 1.0)
    with monkeypatch.context() as m:
        calls = _recorded_solve(fl, m)
    seen = set()
    for name, self, args in calls:
        got = _call(name, self, args)
        with monkeypatch.context() as m:
            m.setattr(lc, "CORE_MOD", None)
            want = _call(name, self, args)
        _same(got, want)
        seen.add(name)
    assert seen == {"_step_vertices", "_knot_times", "_vertex_starts"}
    assert len(calls) >= 9          # cold and warm solves, a few active-set steps each


@pytest.mark.parametrize("path,prof_name", CASES)
def test_solve_flat_with_and_without_the_core(path, prof_name, monkeypatch):
    for ratio in (0.8, 1.0):
        fl = _flat(path, prof_name, ratio)
        m = fl.S.size
        args = (np.zeros(fl.sv.size), np.zeros(m, bool))
        got = lc.solve_flat(fl, lc.cold_binding(fl), *args, pieces=False)
        with monkeypatch.context() as mp:
            mp.setattr(lc, "CORE_MOD", None)
            want = lc.solve_flat(fl, lc.cold_binding(fl), *args, pieces=False)
        for f in ("bound", "vert_v", "vert_t", "conv", "iv", "peak_v", "min_v", "piece_T", "piece_off"):
            assert _bits(getattr(got, f)) == _bits(getattr(want, f)), f


def test_the_comparison_sees_one_ulp():
    Tj = np.array([0.1, 0.2, 0.3, 0.05, 0.07])
    koff = np.array([0, 4, 7], np.int64)            # chains of 3 and 2 pieces
    owner = np.array([0, 0, 0, 1, 1], np.int64)
    p0 = np.arange(5) + owner
    got = lc._knot_times(Tj, koff, owner, p0, 7)
    assert got[0] == 0.0 and got[4] == 0.0 and got[3] == (0.1 + 0.2) + 0.3
    off = got.copy()
    off[5] = np.nextafter(off[5], 1.0)
    with pytest.raises(AssertionError):
        _same((off,), (got,))
