"""The report's pictures (matplotlib, Agg backend), returned as PNG bytes."""
from __future__ import annotations

import io

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402

COLORS = {"before": "#d62728", "after": "#1f77b4", "law": "#2ca02c"}
DPI = 100
# 0 (cruise) a light grey, strong acceleration dark red: the ramps stand out on white
ACCEL_CMAP = matplotlib.colors.LinearSegmentedColormap.from_list(
    "accel", ["#cfcfcf", "#fee08b", "#fdae61", "#f46d43", "#d73027", "#67001f"])


def png_bytes(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue()


def _pct(x):
    return np.nan if x is None else 100.0 * x


# --------------------------------------------------------------------------- reduction chart
def reduction_chart(data) -> bytes:
    feats = data["by_feature"]
    layers = data["by_layer"]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 4.2), gridspec_kw={"width_ratios": [1, 2]})
    if feats:
        x = np.arange(len(feats))
        b = [f["int_a2_mm2_s3"]["before"] for f in feats]
        a = [f["int_a2_mm2_s3"]["after"] for f in feats]
        ax1.bar(x - 0.2, b, 0.4, label="before", color=COLORS["before"])
        ax1.bar(x + 0.2, a, 0.4, label="after", color=COLORS["after"])
        ax1.set_xticks(x, [f["feature"].replace("_", " ") for f in feats])
        for xi, f in zip(x, feats):
            c = f["int_a2_mm2_s3"]["change"]
            if c is not None:
                ax1.annotate(f"{c * 100:+.0f} %", (xi + 0.2, f["int_a2_mm2_s3"]["after"]),
                             ha="center", va="bottom", fontsize=9)
        ax1.legend()
    ax1.set_ylabel("∫|a|² dt of re-timed strokes (mm²/s³)")
    ax1.set_title("Inertia norm per feature type")
    if layers:
        x = np.array([g["layer"] for g in layers])
        w = 0.4 if len(x) < 60 else 0.8
        ax2.bar(x - w / 2, [_pct(g["int_a2_mm2_s3"]["change"]) for g in layers], w,
                label="∫|a|² dt change", color=COLORS["after"])
        ax2.bar(x + w / 2, [_pct(g["time_s"]["change"]) for g in layers], w,
                label="time change", color="#ff7f0e")
        ax2.axhline(0, color="k", lw=0.8)
        ax2.legend(loc="best")
    ax2.set_xlabel("layer")
    ax2.set_ylabel("change on re-timed strokes (%)")
    ax2.set_title("Change per layer (re-timed strokes)")
    ax2.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    return png_bytes(fig)


# --------------------------------------------------------------------------- stroke profiles
_STYLE = [dict(color=COLORS["before"], lw=1.8), dict(color=COLORS["after"], lw=1.6),
          dict(color=COLORS["law"], lw=1.4, ls="--")]


def stroke_chart(sc) -> bytes:
    fig, (av, aa) = plt.subplots(1, 2, figsize=(12, 3.8))
    for k, c in enumerate(sc["curves"]):
        style = _STYLE[k] if len(sc["curves"]) > 2 or k == 0 else _STYLE[2]
        av.plot(c["t_v"], c["v"], label=c["label"], **style)
        if c["steps"]:
            aa.plot(c["t_a"], c["a"], **style)
        else:
            aa.plot(c["t_a"], c["a"], **style)
        if "a_n" in c:
            aa.plot(c["t_v"], c["a_n"], color=style["color"], lw=1.0, ls=":",
                    label=f"normal v²κ ({c['label'].split(',')[0]})")
    if sc.get("feed_v"):
        av.axhline(sc["feed_v"], color="0.4", lw=1.0, ls=":", label=f"slicer F = {sc['feed_v']:.0f} mm/s")
    av.set_xlabel("time from stroke start (s)")
    av.set_ylabel("speed (mm/s)")
    av.set_ylim(bottom=0)
    av.grid(alpha=0.3)
    av.legend(fontsize=8, loc="lower center")
    aa.axhline(0, color="k", lw=0.6)
    aa.set_xlabel("time from stroke start (s)")
    aa.set_ylabel("tangential acceleration (mm/s²)")
    aa.grid(alpha=0.3)
    if aa.get_legend_handles_labels()[0]:
        aa.legend(fontsize=8, loc="best")
    fig.suptitle(sc["title"], fontsize=11)
    fig.tight_layout()
    return png_bytes(fig)


# --------------------------------------------------------------------------- layer map
def _layer_segments(tr, layer):
    """Phase pieces (start, end) of every extruding block in the layer, and |a| of each."""
    b = tr.layer_blocks(layer)
    if not len(b["d"]):
        return np.zeros((0, 2, 2)), np.zeros(0)
    x0, y0, x1, y1, d = b["x0"], b["y0"], b["x1"], b["y1"], b["d"]
    sv, cv = b["start_v"], b["cruise_v"]
    at, ct = b["accel_t"], b["cruise_t"]
    acc = b["accel"]
    dd = np.maximum(d, 1e-12)
    ux, uy = (x1 - x0) / dd, (y1 - y0) / dd
    da = np.minimum(0.5 * (sv + cv) * at, d)
    dc = np.minimum(cv * ct, d - da)
    cuts = [np.zeros_like(d), da, da + dc, d]
    vals = [np.where(at > 0, acc, 0.0), np.zeros_like(d), np.where(b["decel_t"] > 0, acc, 0.0)]
    segs, colours = [], []
    for k in range(3):
        s0, s1 = cuts[k], cuts[k + 1]
        keep = s1 - s0 > 1e-6
        p0 = np.stack([x0 + ux * s0, y0 + uy * s0], axis=1)[keep]
        p1 = np.stack([x0 + ux * s1, y0 + uy * s1], axis=1)[keep]
        segs.append(np.stack([p0, p1], axis=1))
        colours.append(vals[k][keep])
    return np.concatenate(segs), np.concatenate(colours)


def layer_map(ctx, layer) -> bytes:
    s0, c0 = _layer_segments(ctx.tr0, layer)
    s1, c1 = _layer_segments(ctx.tr1, layer)
    vmax = max([1.0] + [float(c.max()) for c in (c0, c1) if len(c)])
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.6), sharex=True, sharey=True)
    norm = matplotlib.colors.Normalize(0.0, vmax)
    lc = None
    for ax, segs, cols, name in ((axes[0], s0, c0, "before"), (axes[1], s1, c1, "after")):
        order = np.argsort(cols, kind="stable")        # strongest on top
        lc = LineCollection(segs[order], cmap=ACCEL_CMAP, norm=norm, linewidths=1.1)
        lc.set_array(cols[order])
        ax.add_collection(lc)
        ax.set_aspect("equal")
        ax.set_xlabel("X (mm)")
        ax.set_title(f"{name} (layer {layer})")
        ax.grid(alpha=0.2)
    axes[0].set_ylabel("Y (mm)")
    allp = np.concatenate([s.reshape(-1, 2) for s in (s0, s1) if len(s)] or [np.zeros((1, 2))])
    pad = 2.0
    axes[0].set_xlim(allp[:, 0].min() - pad, allp[:, 0].max() + pad)
    axes[0].set_ylim(allp[:, 1].min() - pad, allp[:, 1].max() + pad)
    fig.suptitle("Top view: extrusion moves coloured by the firmware's tangential acceleration "
                 "(ramps of each trapezoid; cruise = grey)", fontsize=11)
    cb = fig.colorbar(lc, ax=list(axes), shrink=0.85, pad=0.02)
    cb.set_label("tangential acceleration |a| (mm/s²); 0 = cruise")
    return png_bytes(fig)
