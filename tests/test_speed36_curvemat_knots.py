"""Round 36 (curvemat): curve_knots evaluates its laws without w'.

CircleBatch.eval_tau(w1=False) leaves w' out (None): each series is evaluated apart (its
own products, row by row; the layers' terms elementwise), so φ, w and w'' are the same
numbers, bit for bit, in both regimes; curve_knots (which reads φ and w at 513 points a
law) asks for them alone.
"""
import numpy as np
import pytest

from gcode_opt.laws.circle import solve_circles


def _bits(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("w2", [False, True])
def test_eval_tau_without_w1_same_phi_w(w2):
    rng = np.random.default_rng(36)
    nb = 300
    # long and short arcs: both the layer regime and the Chebyshev one
    T = rng.uniform(0.005, 2.0, nb)
    law = solve_circles(rng.uniform(0.1, 6.0, nb), T, 1e-4 * rng.uniform(0.5, 2.0, nb),
                        rng.uniform(0.0, 3.0, nb) / T, rng.uniform(0.0, 3.0, nb) / T)
    assert law.regime.any() and (~law.regime).any()
    tau = np.broadcast_to(np.linspace(0.0, 1.0, 513)[None, :], (nb, 513))
    full = law.eval_tau(tau, w2=w2)
    part = law.eval_tau(tau, w2=w2, w1=False)
    assert len(part) == 4 and part[2] is None and full[2] is not None
    for k in (0, 1, 3):
        if full[k] is None:
            assert part[k] is None
        else:
            assert _bits(part[k], full[k])
