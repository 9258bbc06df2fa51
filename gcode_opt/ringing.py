"""Ringing of a G-code file: the firmware model's commanded motion through the resonance
model (firmware/resonance.py).

``trace(path, profile)`` plays the file with the firmware model and returns the commanded
XY motion as pieces of constant acceleration (three per planned block: accelerate, cruise,
decelerate; one per rest: E-only moves and dwells), with the velocity jump at each piece's
start.  ``figures(path, profile)`` gives, per axis, RMS and peak ringing (micrometres) and
their parts excited by the ramps (acceleration steps), the corners (junctions turning more
than 30 degrees, the firmware model's corner threshold, and the jumps into and out of rest)
and the gentle turns (junctions of curves cut into segments); with an input shaper in the
profile, the ringing of the shaped motion and the shaper's path smoothing.

What is modelled: X and Y of the toolhead as the firmware commands them (Z and E are not);
each axis a linear damped oscillator with the profile's [resonance] frequency and damping;
the machine at rest before the file starts and after it ends (the last ring-down counts).
"""
from __future__ import annotations

import dataclasses
import math
from array import array

import numpy as np

from . import state as st
from .firmware.resonance import Oscillator, Response, shaped_events, shaper_pulses, smoothing
from .firmware.simulate import CORNER_COS, simulate_events

UM = 1000.0               # mm -> micrometres
NONE, CORNER, TURN = 0, 1, 2
PARTS = ("ramp", "corner", "turn")


class Trace:
    """Commanded XY motion, one row per piece (numpy arrays of equal length n):
    t0 (s) start, dur (s), acc (n x 2, mm/s^2), vel (n x 2, mm/s, at the start, after the
    jump), dv (n x 2, the velocity jump at the start), da (n x 2, the acceleration step at
    the start), pos (n x 2, mm, relative to the first move's start), s (mm of path at the
    start), speed (mm/s at the start), tan_a (mm/s^2 along the path), cls (NONE / CORNER /
    TURN: what kind of velocity jump starts the piece), idx (0-based source line, -1 for
    rests).  The first and the last three pieces are the machine idle (1 s) before and after
    the file; time 0 is the file's start."""

    def __init__(self, rows):
        self.__dict__.update(rows)

    @property
    def total_t(self) -> float:
        return float(self.dur[3:-3].sum())

    def __len__(self):
        return len(self.t0)


def trace(path, profile) -> Trace:
    """Play the file (firmware/simulate.py) and collect its commanded motion."""
    items = array("d")                      # per block or rest: 12 numbers, flat
    add = items.extend

    def on_block(b):
        add((b.ux, b.uy, b.start_v, b.cruise_v, b.end_v, b.accel, b.accel_t, b.cruise_t,
             b.decel_t, 1.0 if b.after_stop else 0.0, b.idx, 1.0))

    def rest(dt):
        if dt > 0.0:
            add((0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, dt, 0.0, 1.0, -1, 0.0))

    def on_line(rec):
        if rec.kind == st.EONLY:
            rest(rec.time_t)

    def events():
        for item in st.events(path, profile):
            yield item
            # resumed only after the simulator took the barrier: its blocks are flushed
            ev = item[2]
            if type(ev) is st.Barrier:
                rest(ev.dwell_t)

    res = simulate_events(events(), profile, on_line, on_block)
    tr = trace_from_items(items)
    tr.sim = res                             # the firmware model's SimResult of the same pass
    return tr


def trace_from_items(items) -> Trace:
    """Build the pieces from (ux, uy, start_v, cruise_v, end_v, accel, accel_t, cruise_t,
    decel_t, after_stop, idx, is_block) rows (rests: is_block 0, cruise_t = duration)."""
    m = np.asarray(items, float).reshape(-1, 12)
    idle = np.array([[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, -1, 0.0]])
    m = np.vstack([idle, m, idle])          # at rest before and after (1 s each, not counted)
    ux, uy, sv, cv, ev, a, at, ct, dt, after, idx, isb = m.T
    nb = len(m)
    dur = np.stack([at, ct, dt], 1).ravel()
    speed = np.stack([sv, cv, cv], 1).ravel()
    tan_a = np.stack([a, 0.0 * a, -a], 1).ravel()
    u = np.repeat(np.stack([ux, uy], 1), 3, axis=0)
    vel = speed[:, None] * u
    acc = tan_a[:, None] * u
    end_speed = speed + tan_a * dur
    vel_end = end_speed[:, None] * u
    t0 = np.concatenate([[-1.0], np.cumsum(dur)[:-1] - 1.0])   # file starts at t = 0
    ds = speed * dur + 0.5 * tan_a * dur * dur
    s = np.concatenate([[0.0], np.cumsum(ds)[:-1]])
    disp = ds[:, None] * u
    pos = np.vstack([[0.0, 0.0], np.cumsum(disp, axis=0)[:-1]])
    n = 3 * nb
    # velocity jumps: only where a block or a rest begins (inside a block the speed is
    # continuous; take it exactly so rounding does not ring)
    starts = np.zeros(n, bool)
    starts[::3] = True
    prev_end = np.vstack([[0.0, 0.0], vel_end[:-1]])
    dv = np.where(starts[:, None], vel - prev_end, 0.0)
    prev_acc = np.vstack([[0.0, 0.0], acc[:-1]])
    da = acc - prev_acc
    # a junction is a gentle turn when consecutive blocks are both moving and turn < 30 deg
    cls = np.zeros(n, np.int8)
    cos_turn = np.concatenate([[-1.0], ux[1:] * ux[:-1] + uy[1:] * uy[:-1]])
    moving_pair = np.concatenate([[False], (isb[1:] > 0) & (isb[:-1] > 0) & (after[1:] == 0)])
    gentle = moving_pair & (cos_turn >= CORNER_COS)
    cls[::3] = np.where(gentle, TURN, CORNER)
    # an axis-parallel pair (e.g. pure Z) has cos 0 with no XY turn: its XY jump is 0 anyway
    return Trace(dict(t0=t0, dur=dur, acc=acc, vel=vel, dv=dv, da=da, pos=pos, s=s,
                      speed=speed, tan_a=tan_a, cls=cls, idx=np.repeat(idx, 3).astype(np.int64)))


def model_of(profile):
    """The resonance and shaper in force, as the profile states them."""
    fx = getattr(profile, "freq_x_hz", 50.0)
    fy = getattr(profile, "freq_y_hz", 50.0)
    sfx = getattr(profile, "shaper_freq_x_hz", 0.0) or fx
    sfy = getattr(profile, "shaper_freq_y_hz", 0.0) or fy
    return dict(freq_x_hz=fx, freq_y_hz=fy, damping_r=getattr(profile, "damping_r", 0.1),
                shaper=getattr(profile, "shaper", "none"), shaper_freq_x_hz=sfx,
                shaper_freq_y_hz=sfy, shaper_damping_r=getattr(profile, "shaper_damping_r", 0.1))


def _jumps(tr: Trace, model: dict, name: str, ax: int, part: str):
    """(dr, drp): the ringing's jumps at the pieces' starts for one axis and part."""
    w = 2.0 * math.pi * model[f"freq_{name}_hz"]
    if part == "ramp":
        return tr.da[:, ax] / (w * w), None
    if part == "all":
        return tr.da[:, ax] / (w * w), -tr.dv[:, ax]
    cls = CORNER if part == "corner" else TURN
    return None, np.where(tr.cls == cls, -tr.dv[:, ax], 0.0)


def response(tr: Trace, model: dict, name: str, part: str = "all", shaper: str | None = None):
    """The Response of axis name ('x'/'y') to the jumps of `part` ('all', 'ramp', 'corner',
    'turn'), through the shaper (the model's unless given).  Events whose jumps are both
    zero are left out (the free decay runs on across them)."""
    shaper = model["shaper"] if shaper is None else shaper
    ax = "xy".index(name)
    osc = Oscillator(model[f"freq_{name}_hz"], model["damping_r"])
    dr, drp = _jumps(tr, model, name, ax, part)
    keep = np.zeros(len(tr), bool)
    for j in (dr, drp):
        if j is not None:
            keep |= j != 0.0
    t = tr.t0[keep]
    zero = np.zeros(len(t))
    dr = zero if dr is None else dr[keep]
    drp = zero if drp is None else drp[keep]
    a_p, t_p = shaper_pulses(shaper, model[f"shaper_freq_{name}_hz"], model["shaper_damping_r"])
    t_ev, (dr_s, drp_s) = shaped_events(t, (dr, drp), a_p, t_p)
    return Response(osc, t_ev, dr_s, drp_s)


def responses(tr: Trace, model: dict, shaper: str | None = None):
    """{axis: {part: Response}} for parts 'all', 'ramp', 'corner', 'turn' (all in memory at
    once: for plots and tests; figures_of_trace solves one at a time)."""
    return {name: {part: response(tr, model, name, part, shaper) for part in ("all",) + PARTS}
            for name in "xy"}


def _axis_figures(tr: Trace, model: dict, name: str, shaper: str, total_t: float) -> dict:
    d = {}
    for part in ("all",) + PARTS:
        r = response(tr, model, name, part, shaper)
        key = "" if part == "all" else "_" + part
        d["rms" + key + "_um"] = math.sqrt(max(r.int_r2(), 0.0) / total_t) * UM if total_t > 0 else 0.0
        d["peak" + key + "_um"] = r.peak() * UM
        del r
    return d


def figures_of_trace(tr: Trace, model: dict, shaper: str | None = None) -> dict:
    shaper = model["shaper"] if shaper is None else shaper
    total_t = tr.total_t
    out = {"model": dict(model, shaper=shaper), "time_s": total_t}
    for name in "xy":
        out[name] = _axis_figures(tr, model, name, shaper, total_t)
    # the XY error vector: RMS adds in squares; its peak is at least the larger axis'
    xy = {}
    for key in ("rms_um", "rms_ramp_um", "rms_corner_um", "rms_turn_um"):
        xy[key] = math.hypot(out["x"][key], out["y"][key])
    xy["peak_um"] = max(out["x"]["peak_um"], out["y"]["peak_um"])
    out["xy"] = xy
    if shaper != "none":
        pulses = [shaper_pulses(shaper, model[f"shaper_freq_{a}_hz"], model["shaper_damping_r"])
                  for a in "xy"]
        rms_d, max_d = smoothing(tr.t0, tr.pos, tr.vel, tr.acc, pulses)
        out["smoothing"] = {"rms_um": rms_d * UM, "max_um": max_d * UM}
    return out


def figures(path, profile, shaper: str | None = None) -> dict:
    """Ringing figures of one file (for the summary JSON, `simulate` and the report):
    {"model": {...}, "time_s", "x": {...}, "y": {...}, "xy": {...}[, "smoothing": {...}]}
    with rms_um / peak_um and their _ramp / _corner / _turn parts per axis.  `shaper`
    overrides the profile's ("none" for the unshaped machine)."""
    return figures_of_trace(trace(path, profile), model_of(profile), shaper)


def compare(before: dict, after: dict) -> dict:
    """Before / after / change of the XY ringing (RMS, peak, the parts, the shaper's
    smoothing): the summary's and the report's headline."""
    out = {}
    for key in ("rms_um", "peak_um", "rms_ramp_um", "rms_corner_um", "rms_turn_um"):
        b, a = before["xy"][key], after["xy"][key]
        out[key] = {"before": b, "after": a, "change": (a / b - 1.0) if b else None}
    if "smoothing" in before and "smoothing" in after:
        out["smoothing_rms_um"] = {"before": before["smoothing"]["rms_um"],
                                   "after": after["smoothing"]["rms_um"]}
    return out


def summary(original, processed, profile) -> dict:
    """The summary JSON's "ringing": both files' figures (the profile's shaper in force)
    and their comparison.  Two more firmware-model passes (one per file)."""
    before, after = figures(original, profile), figures(processed, profile)
    return {"model": before["model"], "before": before, "after": after,
            "change": compare(before, after)}


def text_rows(fig: dict) -> list:
    """(label, text) rows for `gcode-opt simulate`'s table."""
    m, xy = fig["model"], fig["xy"]
    rows = [("ringing RMS / peak",
             f"{xy['rms_um']:.2f} / {xy['peak_um']:.1f} um XY (X {fig['x']['rms_um']:.2f}, "
             f"Y {fig['y']['rms_um']:.2f}) at {m['freq_x_hz']:g} / {m['freq_y_hz']:g} Hz, "
             f"damping {m['damping_r']:g}, shaper {m['shaper']}"),
            ("ringing excited by", f"ramps {xy['rms_ramp_um']:.2f}, corners {xy['rms_corner_um']:.2f}, "
                                   f"gentle turns {xy['rms_turn_um']:.2f} um RMS")]
    if "smoothing" in fig:
        rows.append(("shaper smoothing", f"{fig['smoothing']['rms_um']:.1f} um RMS, "
                                         f"{fig['smoothing']['max_um']:.0f} um max"))
    return rows


def with_shaper(profile, shaper: str):
    """The profile with another input shaper (tuned where the profile says)."""
    return dataclasses.replace(profile, shaper=shaper)


# ---------------------------------------------------------------- a stretch for plots
def time_at_s(tr: Trace, s_d):
    """Times at which the commanded motion reaches path distance s_d (first reach)."""
    s_d = np.asarray(s_d, float)
    k = np.clip(np.searchsorted(tr.s, s_d, side="right") - 1, 0, len(tr) - 1)
    v, a, rem = tr.speed[k], tr.tan_a[k], s_d - tr.s[k]
    disc = np.maximum(v * v + 2.0 * a * rem, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = np.where(np.abs(a) > 1e-12, (np.sqrt(disc) - v) / np.where(a == 0, 1, a),
                       rem / np.where(v > 0, v, np.inf))
    return tr.t0[k] + np.clip(np.nan_to_num(tau), 0.0, tr.dur[k])


def s_at_t(tr: Trace, t):
    t = np.asarray(t, float)
    k = np.clip(np.searchsorted(tr.t0, t, side="right") - 1, 0, len(tr) - 1)
    tau = np.clip(t - tr.t0[k], 0.0, tr.dur[k])
    return tr.s[k] + tr.speed[k] * tau + 0.5 * tr.tan_a[k] * tau * tau


def busiest_stretch(tr: Trace, model: dict, length_d: float = 50.0) -> float:
    """Start (mm of path) of the stretch of length_d where this trace rings most (by the
    exact integral of |r|^2 over time, binned by path distance)."""
    e = np.zeros(len(tr))
    for name in "xy":
        r = response(tr, model, name)
        per = r.osc.integral_r2(r.c, r.dur)
        k = np.clip(np.searchsorted(tr.t0, r.t_ev, side="right") - 1, 0, len(tr) - 1)
        np.add.at(e, k, per)
    total_s = float(tr.s[-1])
    if total_s <= length_d:
        return 0.0
    bins = np.floor(tr.s / (0.5 * length_d)).astype(np.int64)
    per_bin = np.bincount(bins, weights=e)
    win = per_bin[:-1] + per_bin[1:] if len(per_bin) > 1 else per_bin
    return float(np.argmax(win) * 0.5 * length_d)


def stretch(tr: Trace, model: dict, s0_d: float, length_d: float, n: int = 4000,
            shaper: str | None = None):
    """(s_d, rx_um, ry_um): the ringing sampled (exactly) at n instants evenly spaced in
    time over the part of the path [s0_d, s0_d + length_d]."""
    t_a, t_b = time_at_s(tr, [s0_d, s0_d + length_d])
    t = np.linspace(t_a, t_b, n)
    rx = response(tr, model, "x", shaper=shaper).at(t)
    ry = response(tr, model, "y", shaper=shaper).at(t)
    return s_at_t(tr, t), rx * UM, ry * UM
