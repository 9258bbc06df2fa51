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

from array import array

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

    def sink(self) -> StretchSink:
        """The processed file's sink (after add() took the original's rows: the stretch is
        known): give it to the pass as its ringing rows, then add_sink() it."""
        col = rg.Collector(model=self.model) if self.given is None else None
        return StretchSink(self.model, self.s0, self.length_d, col)

    def add_sink(self, sink: StretchSink):
        """The processed file's figures and stretch from its sink (the pass is over)."""
        sink.close()
        if sink.col is not None:
            self.figs.append(sink.col.figures())
        s, rx, ry = sink.samples()
        self.st["after"] = {"s_mm": s.tolist(), "x_um": rx.tolist(), "y_um": ry.tolist()}

    def data(self) -> dict:
        f0, f1 = self.given or self.figs
        return {"model": self.model, "before": f0, "after": f1, "headline": headline(f0, f1),
                "stretch": {"from_mm": self.s0, "length_mm": self.length_d, **self.st}}


class StretchSink:
    """One file's ringing rows as its firmware-model pass makes them (on_block / rest, as
    ringing.Rows; then close()), keeping only the rows stretch_rows reads of the stretch
    [s0_d, s0_d + length_d] -- the same samples as over the whole file's RowTable -- and,
    with a Collector, feeding it the rows a chunk of its own size at a time (its add_rows
    over all the rows: the same figures).  Memory: a chunk and the stretch's window, not a
    row a block.

    Each chunk's rows are timed and placed (t, s: the cumulative sums RowTable takes, carried
    from chunk to chunk: the same bits); rows are dropped once they lie more than the
    window's history before the stretch's start (or before the newest row, while the start
    is not reached), and none are kept past the rows the window's end reads."""

    def __init__(self, model: dict, s0_d: float, length_d: float, collector=None):
        self.model, self.s0, self.length_d, self.col = model, float(s0_d), length_d, collector
        self.limit = collector.limit if collector is not None else rg.ROW * rg.CHUNK_BLOCKS
        probe = rg.RowTable.part(None, None, None, model)       # the window's history and span
        self.history_t, self.span_t = probe.history_t, probe.span_t
        self.pend = array("d")
        self.parts = []                      # [first row, m, t, s] of the rows kept, in order
        self.n = 0                           # rows placed so far (the leading idle row included)
        self.sum_t = self.sum_s = None       # cumulative duration and path of the rows placed
        self.r_a = self.r_b = None           # rows where the stretch starts and ends (stretch_rows')
        self.done = False                    # every row the window reads is kept

    def on_block(self, b):
        self.pend.extend(rg._block_row(b))
        if len(self.pend) >= self.limit:
            self._chunk()

    def rest(self, dt_t):
        if dt_t > 0.0:
            self.pend.extend(rg._rest_row(dt_t))
            if len(self.pend) >= self.limit:
                self._chunk()

    def close(self):
        self._chunk(final=True)

    def _chunk(self, final=False):
        rows, self.pend = self.pend, array("d")
        if self.col is not None and len(rows):
            self.col.add_rows(rows)
        if self.done:
            return
        m = np.frombuffer(rows, float).reshape(-1, rg.ROW)
        ends = ([np.array([rg.IDLE])] if self.n == 0 else []) + [m] + ([np.array([rg.IDLE])] if final else [])
        if len(ends) > 1:
            m = np.vstack(ends)
        if len(m):
            self._place(m)

    def _place(self, m):
        dur, ds = rg.row_dur_ds(m)
        if self.sum_t is None:
            cum_t, cum_s, prev_t, prev_s = np.cumsum(dur), np.cumsum(ds), 0.0, 0.0
        else:
            prev_t, prev_s = self.sum_t, self.sum_s
            cum_t = np.cumsum(np.concatenate([[prev_t], dur]))[1:]
            cum_s = np.cumsum(np.concatenate([[prev_s], ds]))[1:]
        t = -1.0 + np.concatenate([[prev_t], cum_t[:-1]])
        s = np.concatenate([[prev_s], cum_s[:-1]])
        self.sum_t, self.sum_s = float(cum_t[-1]), float(cum_s[-1])
        first = self.n
        self.parts.append([first, m, t, s])
        self.n += len(m)
        if self.r_a is None:
            over = np.flatnonzero(s > self.s0)
            if len(over):
                self.r_a = max(first + int(over[0]) - 1, 0)
        if self.r_a is not None and self.r_b is None:
            over = np.flatnonzero(s > self.s0 + self.length_d)
            if len(over):
                self.r_b = first + int(over[0])
        if self.r_b is not None:
            q = self._first_after(self._at(self.r_b, 2) + self.span_t)
            self.done = q is not None and q + 1 < self.n
        self._trim(self._at(self.r_a, 2) if self.r_a is not None else float(t[-1]))

    def _at(self, r, k):
        """Column k (1: m, 2: t, 3: s) of kept row r."""
        for p in self.parts:
            if p[0] <= r < p[0] + len(p[1]):
                return p[k][r - p[0]]
        raise IndexError(r)

    def _first_after(self, t_lim):
        """The first kept row starting after t_lim, or None."""
        for p in self.parts:
            j = int(np.searchsorted(p[2], t_lim, side="right"))
            if j < len(p[2]):
                return p[0] + j
        return None

    def _trim(self, t_start):
        # the window starts at the last row starting by t_start - history_t (t_start: where the
        # stretch starts, or no earlier than the newest row) and reads the row before it too
        lim = t_start - self.history_t
        while len(self.parts) > 1 and len(self.parts[1][2]) > 1 and self.parts[1][2][1] <= lim:
            del self.parts[0]

    def samples(self, n: int = SAMPLES):
        """(s, rx, ry) of the stretch: stretch_rows over the rows kept (close() first)."""
        m, t, s = (np.concatenate([p[k] for p in self.parts]) for k in (1, 2, 3))
        self.parts = []
        return rg.stretch_rows(rg.RowTable.part(m, t, s, self.model), self.s0, self.length_d, n)


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
