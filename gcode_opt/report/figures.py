"""`gcode-opt figures`: the paper's Figures 1-7, recomputed from the verified equations
(/work/shared/MATH.md), T = 1 s, m = 1 kg (β = α), several α, with a trapezoid of the same
duration (ramps T/4) for comparison.

  1  line y = -2x + 1 from (0, 1) to (1, -1): x(t)
  2  the same: vx(t) and ax(t)
  3  semicircle (R = 1, angle 0 -> π): φ(t)
  4  the same: φ̇(t) and φ̈(t)
  5  ellipse a = 1, b = 2, one full turn: the path, and p(t) (p = eccentric anomaly)
  6  the same: ṗ(t)
  7  the same: p̈(t)

The ellipse law is the arc-length Euler-Lagrange law of curve.py with the exact curvature;
the paper's printed ellipse equation (its (31)) is wrong -- its solution is drawn thin and
dotted for contrast, labelled as the paper's.
"""
from __future__ import annotations

import math
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ALPHAS = (0.001, 0.01, 0.1, 1.0)        # s²/kg; with m = 1 kg, β = α
T = 1.0
N = 801
LINE = (0.0, 1.0, 1.0, -1.0)
ELLIPSE = (1.0, 2.0)
COLORS = ("#1b9e77", "#d95f02", "#7570b3", "#e7298a")
TRAP = dict(color="0.35", lw=1.4, ls="--")
NAMES = ("fig1_line_x.png", "fig2_line_vx_ax.png", "fig3_semicircle_angle.png", "fig4_semicircle_rates.png",
         "fig5_ellipse_path_p.png", "fig6_ellipse_pdot.png", "fig7_ellipse_pddot.png")


def trapezoid(D, T_t=T, ramp_r=0.25, t=None):
    """(s, v, a) of the symmetric rest-to-rest trapezoid covering D in T_t, ramps ramp_r*T_t."""
    t = np.linspace(0.0, T_t, N) if t is None else t
    ta = ramp_r * T_t
    vp = D / (T_t - ta)
    acc = vp / ta
    s = np.where(t < ta, 0.5 * acc * t ** 2,
                 np.where(t <= T_t - ta, 0.5 * acc * ta ** 2 + vp * (t - ta),
                          D - 0.5 * acc * (T_t - t) ** 2))
    v = np.where(t < ta, acc * t, np.where(t <= T_t - ta, vp, acc * (T_t - t)))
    a = np.where(t < ta, acc, np.where(t <= T_t - ta, 0.0, -acc))
    return s, v, a


def _label(alpha):
    return f"α = {alpha:g} s²/kg"


def _save(fig, out_dir, name):
    path = os.path.join(out_dir, name)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path



def _rates_figure(t, laws, trap, v_label, a_label, title, out_dir, name):
    """Speed and acceleration side by side: each law (alpha, _, rate, rate'), and the trapezoid."""
    fig, (av, aa) = plt.subplots(1, 2, figsize=(12, 4.5))
    for (al, _, rate, drate), col in zip(laws, COLORS):
        av.plot(t, rate, color=col, label=_label(al))
        aa.plot(t, drate, color=col, label=_label(al))
    av.plot(t, trap[1], label="trapezoid, ramps T/4", **TRAP)
    aa.plot(t, trap[2], label="trapezoid, ramps T/4", **TRAP)
    _finish(av, "t (s)", v_label)
    _finish(aa, "t (s)", a_label)
    av.legend(fontsize=9)
    aa.legend(fontsize=9)
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    return _save(fig, out_dir, name)

def _finish(ax, xlabel, ylabel):
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)


# --------------------------------------------------------------------------- line (Figures 1, 2)
def line_curves():
    from ..laws.line import line_law
    x0, y0, x1, y1 = LINE
    L = math.hypot(x1 - x0, y1 - y0)
    c = (x1 - x0) / L                     # dx/ds
    t = np.linspace(0.0, T, N)
    out = []
    for al in ALPHAS:
        s, v, a = line_law(L, T, al, 0.0, 0.0).eval(t)
        out.append((al, x0 + c * s, c * v, c * a))
    s, v, a = trapezoid(L, t=t)
    return t, out, (x0 + c * s, c * v, c * a)


def fig_line(out_dir):
    t, laws, trap = line_curves()
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for (al, x, _, _), col in zip(laws, COLORS):
        ax.plot(t, x, color=col, label=_label(al))
    ax.plot(t, trap[0], label="trapezoid, ramps T/4", **TRAP)
    _finish(ax, "t (s)", "x (length unit)")
    ax.set_title("Fig. 1 – abscissa x(t) on the line y = −2x + 1, (0, 1) → (1, −1); T = 1 s, m = 1 kg",
                 fontsize=10)
    ax.legend()
    p1 = _save(fig, out_dir, NAMES[0])
    return [p1, _rates_figure(t, laws, trap, "vx (length unit / s)", "ax (length unit / s²)",
                              "Fig. 2 – velocity and acceleration along Ox, straight line, optimal law",
                              out_dir, NAMES[1])]


# --------------------------------------------------------------------------- semicircle (3, 4)
def semicircle_curves():
    from ..laws.circle import solve_circle
    t = np.linspace(0.0, T, N)
    out = []
    for al in ALPHAS:
        phi, w, wd = solve_circle(math.pi, T, al, 0.0, 0.0, 1.0).eval(t)
        out.append((al, phi, w, wd))
    return t, out, trapezoid(math.pi, t=t)


def fig_semicircle(out_dir):
    t, laws, trap = semicircle_curves()
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for (al, phi, _, _), col in zip(laws, COLORS):
        ax.plot(t, phi, color=col, label=_label(al))
    ax.plot(t, trap[0], label="trapezoid, ramps T/4", **TRAP)
    ax.set_yticks([0, math.pi / 2, math.pi], ["0", "π/2", "π"])
    _finish(ax, "t (s)", "rotation angle φ (rad)")
    ax.set_title("Fig. 3 – rotation angle φ(t) on a semicircle, 0 → π; T = 1 s, m = 1 kg", fontsize=10)
    ax.legend()
    p1 = _save(fig, out_dir, NAMES[2])
    return [p1, _rates_figure(t, laws, trap, "angular velocity φ̇ (rad/s)", "angular acceleration φ̈ (rad/s²)",
                              "Fig. 4 – angular velocity and acceleration on the semicircle, optimal law",
                              out_dir, NAMES[3])]


# --------------------------------------------------------------------------- ellipse (5, 6, 7)
def paper_ellipse_law(alpha, guess_t, guess_z, a=ELLIPSE[0], b=ELLIPSE[1]):
    """The paper's printed equation (31) -- INCORRECT (MATH.md) -- solved as printed, for
    contrast only.  Returns (t, p, ṗ, p̈) or None if the BVP solver fails."""
    from scipy.integrate import solve_bvp
    beta = alpha * 1.0

    def f(t, z):
        p, z1, z2, z3 = z
        Q = (a * a - b * b) * np.sin(p) * np.cos(p) / (a * a * np.sin(p) ** 2 + b * b * np.cos(p) ** 2)
        dz3 = z2 / beta - Q * ((z1 - 2 * z1 ** 2) / beta + 4 * z1 * z3 + 3 * z2 ** 2) + 6 * z1 ** 2 * z2 \
            + 5 * Q * z1 ** 4
        return np.vstack([z1, z2, z3, dz3])

    def bc(za, zb):
        return np.array([za[0], za[1], zb[0] - 2 * math.pi, zb[1]])

    try:
        r = solve_bvp(f, bc, guess_t, guess_z, tol=1e-6, max_nodes=200000)
    except Exception:
        return None
    if r.status != 0:
        return None
    t = np.linspace(0.0, T, N)
    z = r.sol(t)
    return t, z[0], z[1], z[2]


def ellipse_curves(with_paper=True):
    from .law_table import ellipse_law
    from .ellipse import Ellipse
    a, b = ELLIPSE
    t = np.linspace(0.0, T, N)
    out = []
    for al in ALPHAS:
        e, law = ellipse_law(a, b, T, al)
        s, v, acc = law.eval(t)
        p, pd, pdd = e.p_law(np.clip(s, 0.0, e.length_d), v, acc)
        paper = None
        if with_paper:
            tg = np.linspace(0.0, T, 401)
            sg, vg, ag = law.eval(tg)
            pg, pdg, pddg = e.p_law(np.clip(sg, 0.0, e.length_d), vg, ag)
            paper = paper_ellipse_law(al, tg, np.vstack([pg, pdg, pddg, np.gradient(pddg, tg)]))
        out.append((al, p, pd, pdd, paper))
    e = Ellipse(a, b)
    s, v, acc = trapezoid(e.length_d, t=t)
    return t, out, e.p_law(np.clip(s, 0.0, e.length_d), v, acc), e


def fig_ellipse(out_dir):
    t, laws, trap, e = ellipse_curves()
    a, b = ELLIPSE
    paper_lbl = "paper's eq. (31), incorrect (dotted)"
    fig, (ap, ax) = plt.subplots(1, 2, figsize=(12, 5), gridspec_kw={"width_ratios": [1, 1.6]})
    q = np.linspace(0, 2 * math.pi, 400)
    ap.plot(a * np.cos(q), b * np.sin(q), color="k", lw=1.5)
    ap.plot([a], [0], "o", ms=10, mfc="none", mec="tab:red", mew=2, label="start = end (a, 0)")
    ap.annotate("", xy=(a * math.cos(0.5), b * math.sin(0.5)), xytext=(a * math.cos(0.3), b * math.sin(0.3)),
                arrowprops=dict(arrowstyle="->", color="tab:red", lw=1.5))
    ap.set_aspect("equal")
    _finish(ap, "x (length unit)", "y (length unit)")
    ap.set_title(f"toolpath: x = {a:g} cos p, y = {b:g} sin p", fontsize=10)
    ap.legend(loc="lower left", fontsize=9)
    _plot_family(ax, t, laws, trap, 1, paper_lbl)
    ax.set_yticks([0, math.pi / 2, math.pi, 3 * math.pi / 2, 2 * math.pi], ["0", "π/2", "π", "3π/2", "2π"])
    _finish(ax, "t (s)", "eccentric anomaly p (rad)")
    ax.set_title("optimal law p(t) over [0, 2π]", fontsize=10)
    fig.suptitle("Fig. 5 – ellipse a = 1, b = 2, one full turn; T = 1 s, m = 1 kg (law from the arc-length "
                 "equation, exact curvature)", fontsize=10)
    fig.tight_layout()
    paths = [_save(fig, out_dir, NAMES[4])]
    for k, (name, ylab, title) in enumerate(
            ((NAMES[5], "ṗ (rad/s)", "Fig. 6 – rate of the eccentric anomaly ṗ(t) on the ellipse"),
             (NAMES[6], "p̈ (rad/s²)", "Fig. 7 – its acceleration p̈(t) on the ellipse")), start=2):
        fig, ax = plt.subplots(figsize=(9, 5))
        _plot_family(ax, t, laws, trap, k, paper_lbl)
        _finish(ax, "t (s)", ylab)
        ax.set_title(title + "; solid: correct law, dotted: the paper's printed equation", fontsize=10)
        paths.append(_save(fig, out_dir, name))
    return paths


def _plot_family(ax, t, laws, trap, k, paper_lbl):
    """k: 1 = p, 2 = ṗ, 3 = p̈."""
    shown = False
    for law, col in zip(laws, COLORS):
        ax.plot(t, law[k], color=col, label=_label(law[0]))
        paper = law[4]
        if paper is not None:
            ax.plot(paper[0], paper[k], color=col, lw=1.0, ls=":", label=None if shown else paper_lbl)
            shown = True
    ax.plot(t, trap[k - 1], label="trapezoid in arc length, ramps T/4", **TRAP)
    ax.legend(fontsize=8)


def write_figures(out_dir="figures"):
    os.makedirs(out_dir, exist_ok=True)
    return fig_line(out_dir) + fig_semicircle(out_dir) + fig_ellipse(out_dir)
