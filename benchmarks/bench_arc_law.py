"""Time the fast circle-law solver on a realistic batch of printer arcs.

Usage: python benchmarks/bench_arc_law.py [n_arcs] [beta_s2]
Prints mean ms/arc for the vectorised batch (`solve_circles`), for one-at-a-time calls
(`solve_circle`), and the ratio to scipy solve_bvp (tolerance stepped 1e-4 -> 1e-6 -> 1e-8)
on a small subset, with the largest deviation seen on that subset."""
from __future__ import annotations

import sys
import time

import numpy as np
from scipy.integrate import solve_bvp

import os as _os
import sys as _sys
_sys.path.insert(0, _os.path.join(_os.path.dirname(_os.path.abspath(__file__)), ".."))

from gcode_opt.laws.circle import solve_circle, solve_circles

DEFAULT_BETA_S2 = 1e-4      # β = α·m; √β = 10 ms boundary layers


def realistic_arcs(n, beta_s2=DEFAULT_BETA_S2, seed=1):
    """R 1–50 mm, swept 10°–360°, mean speed 30–200 mm/s, end speeds 0–0.8× mean."""
    rng = np.random.default_rng(seed)
    r_d = rng.uniform(1.0, 50.0, n)
    phi = np.radians(rng.uniform(10.0, 360.0, n))
    v_mean_v = rng.uniform(30.0, 200.0, n)
    t_t = r_d * phi / v_mean_v
    w0 = rng.uniform(0.0, 0.8, n) * v_mean_v / r_d          # rad/s
    w1 = rng.uniform(0.0, 0.8, n) * v_mean_v / r_d
    return phi, t_t, np.full(n, beta_s2), w0, w1, r_d


def bvp_reference(phi, t_t, beta_s2, w0, w1):
    """Dimensionless 4th-order BVP φ'''' = (γ² + 6φ'²)φ'' with stepped tolerances."""
    g2, u0, u1 = t_t ** 2 / beta_s2, w0 * t_t, w1 * t_t
    tau = np.linspace(0.0, 1.0, 200)
    y = np.vstack([phi * (3 * tau ** 2 - 2 * tau ** 3), phi * 6 * tau * (1 - tau),
                   phi * (6 - 12 * tau), np.full_like(tau, -12 * phi)])
    sol = None
    for tol in (1e-4, 1e-6, 1e-8):
        sol = solve_bvp(lambda t, y: np.vstack([y[1], y[2], y[3], (g2 + 6 * y[1] ** 2) * y[2]]),
                        lambda a, b: np.array([a[0], a[1] - u0, b[0] - phi, b[1] - u1]),
                        tau, y, tol=tol, max_nodes=300000)
        tau, y = sol.x, sol.y
    return sol


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 2000
    beta_s2 = float(sys.argv[2]) if len(sys.argv) > 2 else DEFAULT_BETA_S2
    args = realistic_arcs(n, beta_s2)
    gam = args[1] / np.sqrt(beta_s2)
    print(f"{n} arcs, beta={beta_s2:g} s^2, gamma=T/sqrt(beta) in [{gam.min():.3g}, {gam.max():.3g}]")

    solve_circles(*args[:5], R=args[5])                       # warm caches
    t0 = time.perf_counter()
    batch = solve_circles(*args[:5], R=args[5])
    t_solve = time.perf_counter() - t0
    t0 = time.perf_counter()
    batch.integrals()
    batch.peak_speed()
    batch.peak_accel()
    t_post = time.perf_counter() - t0
    print(f"batch solve:        {1e3 * t_solve / n:.4f} ms/arc  "
          f"({np.mean(batch.regime) * 100:.0f}% boundary-layer regime)")
    print(f"integrals+peaks:    {1e3 * t_post / n:.4f} ms/arc")

    m = min(n, 300)
    t0 = time.perf_counter()
    for i in range(m):
        solve_circle(*(a[i] for a in args[:5]), R=args[5][i])
    t_single = (time.perf_counter() - t0) / m
    print(f"one-at-a-time:      {1e3 * t_single:.4f} ms/arc")

    k = 10
    sub = np.random.default_rng(2).choice(n, k, replace=False)
    t0 = time.perf_counter()
    sols = [bvp_reference(*(a[i] for a in args[:5])) for i in sub]
    t_bvp = (time.perf_counter() - t0) / k
    err = 0.0
    tau = np.linspace(0, 1, 101)
    for i, sol in zip(sub, sols):
        phi, w, w1, _ = batch.eval_tau(tau[None, :], [i])
        y = sol.sol(tau)
        ph = args[0][i]
        err = max(err, *(np.abs(a[0] - b).max() / ph for a, b in ((phi, y[0]), (w, y[1]), (w1, y[2]))))
    print(f"solve_bvp (tight):  {1e3 * t_bvp:.1f} ms/arc on {k} arcs -> batch is "
          f"{t_bvp / (t_solve / n):.0f}x faster, single {t_bvp / t_single:.0f}x; "
          f"max rel deviation {err:.1e}")


if __name__ == "__main__":
    main()
