"""The report's ringing: figures of the original and the processed file, and a plot of the
ringing along a representative stretch of the path (gcode_opt/ringing.py's exact model).

    d = ringing_data(original, processed, profile)    # JSON-ready dict
    png = ringing_plot(d)                              # PNG bytes

The stretch is the `length_d` mm of path where the original rings most (its exact ringing
energy binned by path distance); both files are drawn over the same path distances (the
path is unchanged), each sampled at its own instants, so the x axis is where on the print
the toolhead is, not when.
"""
from __future__ import annotations

import numpy as np

from .. import ringing as rg
from .plots import COLORS, plt, png_bytes

STRETCH_D = 40.0          # mm of path drawn
SAMPLES = 3000            # instants per file over the stretch


headline = rg.compare      # before / after / change of RMS, peak, parts, smoothing


class RingingRows:
    """ringing_data from each file's kept rows, one file at a time: add(items) the original's,
    then the processed file's (ringing.Rows.padded()'s items, the idle row at both ends, e.g.
    report/trace.py's ring_rows), then data().  Figures streamed (or the summary's), the
    busiest stretch window by window, only the stretch's window solved -- no whole trace in
    memory; a file's rows can go once add() took them (so the report drops the original's
    before it plays the processed file)."""

    def __init__(self, profile, length_d: float = STRETCH_D, from_d=None, figures=None):
        self.model = model = rg.model_of(profile)
        self.length_d = length_d
        self.s0 = None if from_d is None else float(from_d)
        self.given = None
        if figures and figures.get("model") == model and "before" in figures and "after" in figures:
            self.given = figures["before"], figures["after"]
        self.figs, self.st = [], {}

    def add(self, items):
        tag = ("before", "after")[len(self.st)]
        if self.given is None:
            col = rg.Collector(model=self.model)
            col.add_rows(memoryview(items)[rg.ROW:len(items) - rg.ROW])   # (without the idle rows)
            self.figs.append(col.figures())
        rt = rg.RowTable(items, self.model, padded=True)
        if self.s0 is None:                    # where the original rings most
            self.s0 = rg.busiest_stretch_rows(rt, self.length_d)
        s, rx, ry = rg.stretch_rows(rt, self.s0, self.length_d, SAMPLES)
        self.st[tag] = {"s_mm": s.tolist(), "x_um": rx.tolist(), "y_um": ry.tolist()}

    def data(self) -> dict:
        f0, f1 = self.given or self.figs
        return {"model": self.model, "before": f0, "after": f1, "headline": headline(f0, f1),
                "stretch": {"from_mm": self.s0, "length_mm": self.length_d, **self.st}}


def ringing_data_rows(rows, profile, length_d: float = STRETCH_D, from_d=None,
                      figures=None) -> dict:
    """RingingRows over both files' rows, rows = [original's, processed's]; each file's rows
    leave the list once taken."""
    rr = RingingRows(profile, length_d, from_d, figures)
    for k in range(2):
        items, rows[k] = rows[k], None
        rr.add(items)
        del items
    return rr.data()


def ringing_data(original, processed, profile, length_d: float = STRETCH_D, from_d=None,
                 figures=None, traces=None) -> dict:
    """Figures of both files (the profile's shaper in force) and the sampled stretch (from
    path distance from_d mm; default where the original rings most).  figures: the
    summary's "ringing" (its before / after are used when figured with this profile's
    model); traces: both files' ringing.Trace when a pass already made them."""
    model = rg.model_of(profile)
    tr0, tr1 = traces if traces is not None else (rg.trace(original, profile), rg.trace(processed, profile))
    if figures and figures.get("model") == model and "before" in figures and "after" in figures:
        f0, f1 = figures["before"], figures["after"]
    else:
        f0, f1 = rg.figures_of_trace(tr0, model), rg.figures_of_trace(tr1, model)
    s0 = rg.busiest_stretch(tr0, model, length_d) if from_d is None else float(from_d)
    st = {}
    for tag, tr in (("before", tr0), ("after", tr1)):
        s, rx, ry = rg.stretch(tr, model, s0, length_d, SAMPLES)
        st[tag] = {"s_mm": s.tolist(), "x_um": rx.tolist(), "y_um": ry.tolist()}
    return {"model": model, "before": f0, "after": f1, "headline": headline(f0, f1),
            "stretch": {"from_mm": s0, "length_mm": length_d, **st}}


def ringing_plot(d: dict) -> bytes:
    fig, axes = plt.subplots(2, 1, figsize=(12, 5.2), sharex=True)
    m = d["model"]
    for ax, name in zip(axes, "xy"):
        for tag in ("before", "after"):
            s = d["stretch"][tag]
            f = d[tag][name]
            ax.plot(np.asarray(s["s_mm"]), np.asarray(s[f"{name}_um"]), lw=0.9, color=COLORS[tag],
                    label=f"{'original' if tag == 'before' else 'processed'}: RMS {f['rms_um']:.2f} µm "
                          f"(ramps {f['rms_ramp_um']:.2f}, corners {f['rms_corner_um']:.2f}), "
                          f"peak {f['peak_um']:.1f} µm")
        ax.axhline(0, color="k", lw=0.5)
        ax.set_ylabel(f"{name.upper()} ringing (µm)")
        ax.legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("path distance (mm): the stretch where the original rings most")
    shaper = m["shaper"] if m["shaper"] != "none" else "no input shaper"
    axes[0].set_title(f"Ringing (error minus its quasi-static lag) at {m['freq_x_hz']:g} / "
                      f"{m['freq_y_hz']:g} Hz, damping {m['damping_r']:g}, {shaper}; "
                      "RMS and peak over the whole file")
    return png_bytes(fig)
