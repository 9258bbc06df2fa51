"""Check a re-timed file against its original: the invariants gcode-opt promises.

  * every line outside a `; gcode-opt begin ... end` block is the original's, byte for
    byte and in order, and each block stands where a run of original motion lines was;
  * inside a block, the toolpath is the original's: every original vertex is visited, in
    order, and every new point lies on the original segment it splits;
  * the filament is the original's: cumulative E at every original vertex equals the
    original to the file's precision, and E per mm inside each original move is unchanged;
  * after a block the machine is in the original's modal state: position, E, E mode,
    feedrate, accelerations, Klipper's cruise ratio.
Independent of emit.py: it reads both files with the machine-state reader only.
"""
from __future__ import annotations

import math
import re

from .emit import BEGIN, END
from .profile import Profile
from .state import ARC, EONLY, MachineState, read_lines

_REPLACES = re.compile(r"replaces (\d+) lines")


class Violation(AssertionError):
    pass


def _state_key(st: MachineState):
    return (round(st.v, 6), st.accel_print, st.accel_travel, st.accel_retract, st.lim.mcr,
            st.e_relative, st.abs_xyz, st.inch)


def _walk(st, lines, first_idx):
    """Run lines through st; return the list of (x, y, z, e_cum) after every motion."""
    pts = []
    e_cum = 0.0
    for k, raw in enumerate(lines):
        ev = st.step(first_idx + k, raw)
        if ev is not None and hasattr(ev, "kind"):
            if ev.kind == EONLY:
                raise Violation(f"line {first_idx + k + 1}: E-only move inside a re-timed run")
            e_cum += ev.e
            pts.append((ev.x0, ev.y0, ev.x1, ev.y1, ev.z1, e_cum, ev.e, ev.kind, ev.arc))
    return pts


def verify(orig_path: str, out_path: str, profile: Profile, tol_d: float = 1e-3, tol_e: float = 1e-5):
    """tol_d, tol_e: the file's rounding step for XY and E (3 and 5 decimals by default)."""
    """Raise Violation on the first broken invariant; return counts when all hold."""
    orig = read_lines(orig_path)
    out = read_lines(out_path)
    so, sn = MachineState(profile, orig_path), MachineState(profile, out_path)
    blocks = 0
    checked_vertices = 0
    for n_idx, n_raw in out:
        if n_raw.startswith(BEGIN):
            m = _REPLACES.search(n_raw)
            if not m:
                raise Violation(f"{out_path}:{n_idx + 1}: block marker without 'replaces N lines'")
            count = int(m.group(1))
            run = []
            for _ in range(count):
                o_idx, o_raw = next(orig)
                run.append(o_raw)
            first_o = o_idx - count + 1
            block = []
            for b_idx, b_raw in out:
                if b_raw.startswith(END):
                    break
                block.append(b_raw)
            else:
                raise Violation(f"{out_path}: block opened at line {n_idx + 1} never ends")
            if _state_key(so) != _state_key(sn) or (so.x, so.y, so.z) != (sn.x, sn.y, sn.z):
                raise Violation(f"{out_path}:{n_idx + 1}: state differs before the block")
            e_before_o, e_before_n = so.e, sn.e
            po = _walk(so, run, first_o)
            pn = _walk(sn, block, n_idx + 1)
            if len(po) != count:
                raise Violation(f"{orig_path}:{first_o + 1}: replaced run has non-motion lines")
            if len(po) == 1 and po[0][7] == ARC:
                checked_vertices += _compare_arc(po[0], pn, tol_d, tol_e, out_path, n_idx)
            else:
                checked_vertices += _compare_paths(po, pn, tol_d, tol_e, out_path, n_idx)
            if abs((so.e - e_before_o) - (sn.e - e_before_n)) > tol_e:
                raise Violation(f"{out_path}:{n_idx + 1}: filament differs over the block")
            if (_state_key(so) != _state_key(sn) or abs(so.x - sn.x) > 1e-9 or abs(so.y - sn.y) > 1e-9
                    or so.z != sn.z):
                raise Violation(f"{out_path}:{b_idx + 1}: modal state after the block differs from the "
                                f"original's ({_state_key(sn)} vs {_state_key(so)})")
            sn.step(b_idx, b_raw)
            blocks += 1
            continue
        try:
            o_idx, o_raw = next(orig)
        except StopIteration:
            raise Violation(f"{out_path}:{n_idx + 1}: extra line not in the original")
        if o_raw != n_raw:
            raise Violation(f"{out_path}:{n_idx + 1}: differs from {orig_path}:{o_idx + 1}: "
                            f"{n_raw.rstrip()!r} vs {o_raw.rstrip()!r}")
        so.step(o_idx, o_raw)
        sn.step(n_idx, n_raw)
    for o_idx, o_raw in orig:
        raise Violation(f"{orig_path}:{o_idx + 1}: line missing from the output")
    return {"blocks": blocks, "vertices": checked_vertices}


def _compare_paths(po, pn, tol_d, tol_e, path, line_idx):
    """Original polyline po vs new polyline pn (tuples x0,y0,x1,y1,z,e_cum,e)."""
    j = 0
    if any(p[7] == ARC for p in po) or any(p[7] == ARC for p in pn):
        raise Violation(f"{path}:{line_idx + 1}: arc inside a re-timed polyline block")
    for (ax, ay, bx, by, z, e_cum, e, *_) in po:
        seg_d = math.hypot(bx - ax, by - ay)
        rate = e / seg_d if seg_d > 0 else 0.0
        while True:
            if j >= len(pn):
                raise Violation(f"{path}:{line_idx + 1}: original vertex ({bx:.3f},{by:.3f}) never reached")
            px0, py0, px, py, pz, pe_cum, pe = pn[j][:7]
            j += 1
            if pz != z:
                raise Violation(f"{path}:{line_idx + 1}: Z changed inside a block")
            # the new point lies on the original segment a-b
            dist = abs((bx - ax) * (py - ay) - (by - ay) * (px - ax)) / seg_d if seg_d else math.hypot(px - ax, py - ay)
            if dist > tol_d:
                raise Violation(f"{path}:{line_idx + 1}: point ({px:.4f},{py:.4f}) is {dist:.4f} mm off the path")
            sub_d = math.hypot(px - px0, py - py0)
            # rounding: both ends of a sub-segment move by <= tol_d/2 per axis, E by <= tol_e/2
            tol_rate = (abs(rate) * 1.5 * tol_d + tol_e) / sub_d if sub_d > 0 else 0.0
            if sub_d > 0.05 and abs(pe / sub_d - rate) > tol_rate:
                raise Violation(f"{path}:{line_idx + 1}: extrusion {pe / sub_d:.6f} mm/mm vs original {rate:.6f}")
            if abs(px - bx) <= tol_d and abs(py - by) <= tol_d:
                if abs(pe_cum - e_cum) > tol_e:
                    raise Violation(f"{path}:{line_idx + 1}: cumulative E at vertex ({bx:.3f},{by:.3f}) is "
                                    f"{pe_cum:.6f}, original {e_cum:.6f}")
                break
    if j != len(pn):
        raise Violation(f"{path}:{line_idx + 1}: block moves past the original run's end")
    return len(po)


def _compare_arc(o, pn, tol_d, tol_e, path, line_idx):
    """One original G2/G3 vs its sub-arcs: all arcs turning the same way about the same
    centre (to the file's rounding), end points on the circle, the same total sweep, E per
    mm of each sub-arc equal to the original's, cumulative E exact at the end."""
    ax, ay, bx, by, z, e_cum, e, _, arc = o
    rate = e / arc.length_d if arc.length_d > 0 else 0.0
    where = f"{path}:{line_idx + 1}"
    sweep = 0.0
    for (px0, py0, px, py, pz, pe_cum, pe, kind, a) in pn:
        if kind != ARC:
            raise Violation(f"{where}: a re-timed arc contains a non-arc move")
        if pz != z:
            raise Violation(f"{where}: Z changed inside a block")
        if (a.sweep > 0) != (arc.sweep > 0):
            raise Violation(f"{where}: sub-arc turns the other way")
        if math.hypot(a.cx - arc.cx, a.cy - arc.cy) > tol_d:
            raise Violation(f"{where}: sub-arc centre ({a.cx:.4f},{a.cy:.4f}) is not the original's "
                            f"({arc.cx:.4f},{arc.cy:.4f})")
        off = abs(math.hypot(px - arc.cx, py - arc.cy) - arc.r)
        if off > tol_d and (px, py) != (bx, by):
            raise Violation(f"{where}: sub-arc end ({px:.4f},{py:.4f}) is {off:.4f} mm off the circle")
        sweep += a.sweep
        if a.length_d > 0.05:
            tol_rate = (abs(rate) * 1.5 * tol_d + tol_e) / a.length_d
            if abs(pe / a.length_d - rate) > tol_rate:
                raise Violation(f"{where}: extrusion {pe / a.length_d:.6f} mm/mm vs original {rate:.6f}")
    if abs(sweep - arc.sweep) > 2.0 * tol_d / arc.r + 1e-9 * abs(arc.sweep):
        raise Violation(f"{where}: sub-arcs sweep {sweep:.6f} rad, original {arc.sweep:.6f}")
    if (pn[-1][2], pn[-1][3]) != (bx, by):
        raise Violation(f"{where}: sub-arcs end at ({pn[-1][2]:.4f},{pn[-1][3]:.4f}), not ({bx:.4f},{by:.4f})")
    if abs(pn[-1][5] - e_cum) > tol_e:
        raise Violation(f"{where}: cumulative E at the arc's end is {pn[-1][5]:.6f}, original {e_cum:.6f}")
    return len(pn)
