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

    def add(self, items, tag=None):
        """tag: the file's ("before": the original; default: the first file added)."""
        tag = tag or ("before", "after")[len(self.st)]
        if self.given is None:
            col = rg.Collector(model=self.model)
            col.add_rows(memoryview(items)[rg.ROW:len(items) - rg.ROW])   # (without the idle rows)
            self.figs.append(col.figures())
        rt = rg.RowTable(items, self.model, padded=True)
        if self.s0 is None:                    # where the original rings most
            self.s0 = rg.busiest_stretch_rows(rt, self.length_d)
        s, rx, ry = rg.stretch_rows(rt, self.s0, self.length_d, SAMPLES)
        self.st[tag] = {"s_mm": s.tolist(), "x_um": rx.tolist(), "y_um": ry.tolist()}

    # Streamed instead of add(): the original's pass into busiest_sink() (its figures, where
    # it rings most), the processed file's into sink() (its figures and stretch), a replay
    # of the original into stretch_sink() (its stretch); each given back by add_sink().
    def _collector(self):
        return rg.Collector(model=self.model) if self.given is None else None

    def busiest_sink(self) -> BusiestSink:
        return BusiestSink(self.model, self.length_d, self._collector())

    def sink(self) -> StretchSink:
        """The processed file's sink (the stretch is known: after add() or busiest_sink())."""
        return StretchSink(self.model, self.s0, self.length_d, self._collector())

    def stretch_sink(self) -> StretchSink:
        """The original's stretch from a second pass (no figures: its first pass gave them)."""
        return StretchSink(self.model, self.s0, self.length_d)

    def add_sink(self, sink, tag="after"):
        """A sink's figures and stretch (its pass is over)."""
        sink.close()
        if sink.col is not None:
            self.figs.append(sink.col.figures())
        if isinstance(sink, BusiestSink):
            self.s0 = sink.busiest() if self.s0 is None else self.s0
            return
        s, rx, ry = sink.samples()
        self.st[tag] = {"s_mm": s.tolist(), "x_um": rx.tolist(), "y_um": ry.tolist()}

    def data(self) -> dict:
        f0, f1 = self.given or self.figs
        return {"model": self.model, "before": f0, "after": f1, "headline": headline(f0, f1),
                "stretch": {"from_mm": self.s0, "length_mm": self.length_d,
                            **{tag: self.st[tag] for tag in ("before", "after") if tag in self.st}}}


class _PlacedRows:
    """One file's ringing rows as its firmware-model pass makes them (on_block / rest, as
    ringing.Rows; then close()), placed a chunk at a time as the whole file's RowTable
    places them (t, s: its cumulative sums, carried from chunk to chunk: the same bits),
    the idle row at both ends; a subclass keeps the rows it reads (parts) and drops the
    others.  With a Collector, the rows feed it a chunk of its own size at a time: its
    add_rows over all the rows, the same figures."""

    def __init__(self, model: dict, collector=None):
        self.model, self.col = model, collector
        self.limit = collector.limit if collector is not None else rg.ROW * rg.CHUNK_BLOCKS
        probe = rg.RowTable.part(None, None, None, model)       # the windows' history and span
        self.history_t, self.span_t = probe.history_t, probe.span_t
        self.pend = array("d")
        self.parts = []                      # [first row, m, t, s] of the rows kept, in order
        self.n = 0                           # rows placed so far (the leading idle row included)
        self.sum_t = self.sum_s = None       # cumulative duration and path of the rows placed
        self.done = False                    # no more rows are read

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
        self._placed(final)

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
        self.parts.append([self.n, m, t, s])
        self.n += len(m)
        self.last_s = float(s[-1])

    def _placed(self, final):
        """The rows placed so far are in parts (final: all of them)."""

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
        # a window from t_start starts at the last row starting by t_start - history_t and
        # reads the row before it too (its carry): the rows before those go
        lim = t_start - self.history_t
        while len(self.parts) > 1 and len(self.parts[1][2]) > 1 and self.parts[1][2][1] <= lim:
            del self.parts[0]

    def _table(self):
        """(RowTable of the rows kept, the first one's row)."""
        m, t, s = (np.concatenate([p[k] for p in self.parts]) for k in (1, 2, 3))
        return rg.RowTable.part(m, t, s, self.model), self.parts[0][0]


class StretchSink(_PlacedRows):
    """_PlacedRows keeping only the rows stretch_rows reads of the stretch [s0_d, s0_d +
    length_d]: the same samples as over the whole file's RowTable.  Rows go once they lie
    more than the window's history before the stretch's start (or before the newest row,
    while the start is not reached); none are kept past the rows the window's end reads."""

    def __init__(self, model: dict, s0_d: float, length_d: float, collector=None):
        super().__init__(model, collector)
        self.s0, self.length_d = float(s0_d), length_d
        self.r_a = self.r_b = None           # rows where the stretch starts and ends (stretch_rows')

    def _placed(self, final):
        if self.done or not self.parts:
            return
        first, _m, t, s = self.parts[-1]
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

    def samples(self, n: int = SAMPLES):
        """(s, rx, ry) of the stretch: stretch_rows over the rows kept (close() first)."""
        rt, _first = self._table()
        self.parts = []
        return rg.stretch_rows(rt, self.s0, self.length_d, n)


class BusiestSink(_PlacedRows):
    """_PlacedRows giving busiest_stretch_rows' start (busiest()) without the whole file's
    rows: its chunks of STRETCH_ROWS rows are solved as soon as the rows their window reads
    are placed, each over the rows kept (its window's), their energies added to the bins in
    the same order; rows go once behind the next chunk's window."""

    def __init__(self, model: dict, length_d: float, collector=None):
        super().__init__(model, collector)
        self.length_d, self.bin_d = length_d, 0.5 * length_d
        self.per_bin = np.zeros(64)
        self.c0 = 0                          # the first row of the next chunk to solve

    def _placed(self, final):
        chunk = rg.STRETCH_ROWS
        while self.c0 < self.n:
            r0, r1 = self.c0, self.c0 + chunk
            if final:
                r1 = min(r1, self.n)
            elif r1 >= self.n:
                break
            else:                            # the chunk's window reads up to the row after q
                q = self._first_after(self._at(r1, 2) + self.span_t)
                if q is None or q + 1 >= self.n:
                    break
            rt, first = self._table()
            for bins, per in rg.stretch_energy(rt, r0 - first, r1 - first, final and r1 == self.n, self.bin_d):
                if len(bins) and bins.max() >= len(self.per_bin):
                    self.per_bin = np.concatenate([self.per_bin, np.zeros(int(bins.max()) + len(self.per_bin))])
                np.add.at(self.per_bin, bins, per)
            self.c0 = r1
            if self.c0 < self.n:
                self._trim(self._at(self.c0, 2))

    def busiest(self) -> float:
        """busiest_stretch_rows' start (close() first)."""
        self.parts = []
        total_s = self.last_s                # (the closing idle row's s: the whole RowTable's s[-1])
        if total_s <= self.length_d:
            return 0.0
        per_bin = np.zeros(rg.stretch_bins(total_s, self.length_d))
        k = min(len(per_bin), len(self.per_bin))
        per_bin[:k] = self.per_bin[:k]
        return rg.busiest_bin(per_bin, self.length_d)


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
