"""Issue 8, stop 18 (D8): curves.curve_knots makes each chunk's R phi, max(R w / T, 0) and
running max of s in one call each (was per law), interpolates with np.interp's compiled
core, and evaluates the laws without w''.  The knots must be the same bits as 9bb98a8's
curve_knots, copied below."""
import numpy as np
import pytest

from gcode_opt import curves
from gcode_opt import schedule as sc
from gcode_opt.pipeline import Options, analyse
from gcode_opt.profile import load_profile
from gcode_opt.strokes import K_CURVE

S = "sample_gcode/"


def _old_curve_knots(strokes, T, beta, profile):
    m = len(strokes)
    if m == 0:
        return []
    geos = [curves.geom(st, profile) for st in strokes]
    S_ = np.array([st.length_d for st in strokes])
    v0 = np.array([st.v0 for st in strokes])
    v1 = np.array([st.v1 for st in strokes])
    T, beta = np.asarray(T, float), np.asarray(beta, float)
    law, R = curves._solve(None, geos, S_, T, beta, v0, v1)
    out = []
    for sl in [slice(a, a + curves.KNOT_ROWS) for a in range(0, m, curves.KNOT_ROWS)]:
        sub = law.rows(sl)
        tau = np.broadcast_to(np.linspace(0.0, 1.0, 513)[None, :], (len(sub), 513))
        phi, w, _, _ = sub.eval_tau(tau)
        for k, i in enumerate(range(m)[sl]):
            st = strokes[i]
            sd = R[i] * phi[k]
            vd = np.maximum(R[i] * w[k] / T[i], 0.0)
            s = np.concatenate([[0.0], np.asarray(st.ends_d, float)])
            v = np.interp(s, np.maximum.accumulate(sd), vd)
            v[0], v[-1] = v0[i], v1[i]
            out.append((s, v))
    return out


@pytest.mark.parametrize("name,profile", [("prusa_gyroid.gcode", "prusa-mk3s"),
                                          ("prusa_gyroid_fullspeed.gcode", "prusa-mk3s"),
                                          ("prusa_gyroid.gcode", "voron24")])
def test_curve_knots_same_bits(name, profile):
    prof = load_profile(profile)
    opts = Options()
    strokes, _ = analyse(S + name, prof, opts)
    pin = sc.plan_inputs(strokes, prof, opts)
    rows = np.array([i for i in sc._rows_by_kind(strokes)[K_CURVE] if not pin.fault[i]], int)
    T, beta, I, _ = curves.candidates_curve(pin, rows, strokes, prof)
    fin = np.isfinite(I)
    have = fin.any(axis=1)
    assert have.sum() > 20
    j = np.argmax(fin, axis=1)[have]
    r = np.flatnonzero(have)
    sts = [strokes[i] for i in rows[r]]
    # more laws than one chunk of KNOT_ROWS: repeat the strokes with each finite column
    Ts, bs, ss = [T[r, j]], [beta[r, j]], list(sts)
    for col in range(T.shape[1]):
        ok = fin[r, col]
        Ts.append(T[r, col][ok])
        bs.append(beta[r, col][ok])
        ss += [st for st, o in zip(sts, ok) if o]
    Tc, bc = np.concatenate(Ts), np.concatenate(bs)
    assert len(ss) > curves.KNOT_ROWS
    got = curves.curve_knots(ss, Tc, bc, prof)
    want = _old_curve_knots(ss, Tc, bc, prof)
    assert len(got) == len(want)
    for (s1, v1), (s2, v2) in zip(got, want):
        assert s1.tobytes() == s2.tobytes() and v1.dtype == v2.dtype and v1.tobytes() == v2.tobytes()
