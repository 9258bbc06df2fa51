"""Lookahead planners: give every block its trapezoid (start, cruise, end speed).

A *block* is one straight piece of toolhead motion as the firmware queues it (a G1, or
one chord of a G2/G3).  The caller fills in the geometry and limits; the planner computes
the junction limits, runs the lookahead and hands every planned block, in order, to
``out(block)``.  ``stop()`` brings the machine to rest after the last block (barrier,
E-only move, end of file).

* ``KlipperPlanner`` - full lookahead (Klipper's LookAheadQueue): a backward pass from a
  complete stop after the last queued move, with the minimum_cruise_ratio ("mcr") pass
  that picks the peak cruise speed, and Klipper's lazy flush that commits only the moves
  that later moves can no longer change.  We call the lazy flush whenever the queue
  grows by ``chunk`` moves (Klipper calls it every 0.15 s of queued motion); the result
  is the same plan, the memory stays bounded.
* ``MarlinPlanner`` - finite lookahead: a block's exit speed is fixed when it starts to
  execute, knowing only the blocks in the buffer, planned so the machine could stop
  (MINIMUM_PLANNER_SPEED) at the end of the buffer; steady streaming = full buffer.
"""
from __future__ import annotations

import math

from .junction import INF, MINIMUM_PLANNER_SPEED


class Block:
    __slots__ = ("idx", "kind", "first", "d", "ux", "uy", "uz", "er", "accel", "jd", "nominal_v",
                 "v2max", "delta_v2", "mcr_delta_v2", "max_start_v2", "max_mcr_start_v2",
                 "safe_v", "after_stop",
                 "start_v", "cruise_v", "end_v", "accel_t", "cruise_t", "decel_t")

    def __init__(self, idx, kind, first, d, ux, uy, uz, er, accel, jd, nominal_v, mcr_accel):
        self.idx = idx                  # source line
        self.kind = kind                # state.LINE / state.ARC
        self.first = first              # first block of its line (False for arc chords 2..n)
        self.d = d
        self.ux, self.uy, self.uz = ux, uy, uz
        self.er = er                    # E mm per path mm
        self.accel = accel              # mm/s^2 after every cap
        self.jd = jd                    # junction deviation (Klipper: from scv; Marlin: M205 J)
        self.nominal_v = nominal_v      # requested speed after the speed caps
        self.v2max = nominal_v * nominal_v
        self.delta_v2 = dv2 = 2.0 * d * accel
        m = 2.0 * d * mcr_accel
        self.mcr_delta_v2 = m if m < dv2 else dv2
        self.max_start_v2 = 0.0
        self.max_mcr_start_v2 = 0.0
        self.safe_v = 0.0
        self.after_stop = True


def _set_trapezoid(b, start_v2, cruise_v2, end_v2):
    """Klipper Move.set_junction: times of the three phases."""
    half_inv_a = 0.5 / b.accel
    accel_d = (cruise_v2 - start_v2) * half_inv_a
    decel_d = (cruise_v2 - end_v2) * half_inv_a
    cruise_d = b.d - accel_d - decel_d
    if cruise_d < 0.0:                  # rounding only
        cruise_d = 0.0
    sv = math.sqrt(start_v2) if start_v2 > 0.0 else 0.0
    cv = math.sqrt(cruise_v2)
    ev = math.sqrt(end_v2) if end_v2 > 0.0 else 0.0
    b.start_v, b.cruise_v, b.end_v = sv, cv, ev
    b.accel_t = accel_d / ((sv + cv) * 0.5) if accel_d > 0.0 else 0.0
    b.cruise_t = cruise_d / cv
    b.decel_t = decel_d / ((ev + cv) * 0.5) if decel_d > 0.0 else 0.0


class KlipperPlanner:
    """Full lookahead with Klipper's junction bookkeeping.  ``junction(prev, b)`` returns
    the junction-law limit on b's squared start speed (INF if none)."""

    stop_v = 1e-6

    def __init__(self, junction, out, chunk=512):
        self.junction = junction
        self.out = out
        self.queue = []
        self.chunk = chunk
        self.next_try = chunk
        self.prev_cruise = 0.0

    def add(self, b):
        q = self.queue
        if q:
            p = q[-1]
            v2 = self.junction(p, b)
            lim = p.max_start_v2 + p.delta_v2
            if b.v2max < lim:
                lim = b.v2max
            if p.v2max < lim:
                lim = p.v2max
            if v2 < lim:
                lim = v2
            b.max_start_v2 = lim
            m = p.max_mcr_start_v2 + p.mcr_delta_v2
            b.max_mcr_start_v2 = m if m < lim else lim
            b.after_stop = False
        q.append(b)
        if len(q) >= self.next_try:
            n = self.flush(lazy=True)
            self.next_try = len(q) + self.chunk if n else 2 * len(q)

    def stop(self):
        if self.queue:
            self.flush(lazy=False)
        self.next_try = self.chunk
        self.prev_cruise = 0.0

    def flush(self, lazy):
        """Klipper LookAheadQueue.flush.  Returns the number of moves committed."""
        q = self.queue
        n = flush_count = len(q)
        update = lazy
        info_s = [0.0] * n
        info_c = [None] * n
        info_n = [0.0] * n
        next_start = next_mcr = peak = 0.0
        pending = 0
        for i in range(n - 1, -1, -1):
            m = q[i]
            reach = next_start + m.delta_v2
            start = m.max_start_v2
            if reach < start:
                start = reach
            cruise = None
            pending += 1
            reach_mcr = next_mcr + m.mcr_delta_v2
            mcr = m.max_mcr_start_v2
            if reach_mcr < mcr:
                mcr = reach_mcr
            if mcr < reach_mcr:
                # this move can accelerate
                if mcr + m.mcr_delta_v2 > next_mcr or pending > 1:
                    # it can both accelerate and decelerate, or it is a full-accel move
                    # followed by a full-decel move: a new peak
                    if update and peak:
                        flush_count = i + pending
                        update = False
                    peak = (mcr + reach_mcr) * 0.5
                cruise = (start + reach) * 0.5
                if m.v2max < cruise:
                    cruise = m.v2max
                if peak < cruise:
                    cruise = peak
                pending = 0
            info_s[i] = start
            info_c[i] = cruise
            info_n[i] = next_start
            next_start = start
            next_mcr = mcr
        if update or not flush_count:
            return 0
        prev_cruise = self.prev_cruise
        out = self.out
        for i in range(flush_count):
            m = q[i]
            start = info_s[i]
            cruise = info_c[i]
            if cruise is None:          # can't accelerate: carries the previous cruise
                cruise = prev_cruise if prev_cruise < start else start
            end = info_n[i]
            _set_trapezoid(m, start if start < cruise else cruise, cruise,
                           end if end < cruise else cruise)
            prev_cruise = cruise
            out(m)
        self.prev_cruise = prev_cruise
        del q[:flush_count]
        return flush_count


class MarlinPlanner:
    """Finite lookahead of ``window`` blocks (the executing one included).

    When block i starts, its entry speed is already fixed (the previous block's exit);
    its exit is the largest speed that (a) it can reach by accelerating over its length,
    (b) the junction allows, and (c) still lets the machine slow down to
    MINIMUM_PLANNER_SPEED at the end of the last buffered block, through the junction
    limits of the buffered blocks (Marlin's reverse pass, then forward pass)."""

    stop_v = MINIMUM_PLANNER_SPEED * (1.0 + 1e-6)

    def __init__(self, junction, out, window, start_v2=None):
        self.junction = junction        # junction(prev, b) -> max entry v2 of b
        self.start_v2 = start_v2        # start_v2(b) -> entry v2 after a stop (jerk: safe^2)
        self.out = out
        self.window = max(1, int(window))
        self.buf = []
        self.head = 0
        self.last = None
        self.entry_v2 = None            # fixed entry of buf[head]; None = after a stop

    def add(self, b):
        p = self.last
        if p is not None:
            v2 = self.junction(p, b)
            if b.v2max < v2:
                v2 = b.v2max
            if p.v2max < v2:
                v2 = p.v2max
            b.max_start_v2 = v2
            b.after_stop = False
        else:
            b.max_start_v2 = self.start_v2(b) if self.start_v2 is not None else 0.0
        self.last = b
        self.buf.append(b)
        if len(self.buf) - self.head >= self.window:
            self._execute(MINIMUM_PLANNER_SPEED * MINIMUM_PLANNER_SPEED)
            if self.head > 4096:
                del self.buf[:self.head]
                self.head = 0

    def stop(self):
        # the buffer drains: the last block ends at MINIMUM_PLANNER_SPEED, as in Marlin
        while self.head < len(self.buf):
            self._execute(MINIMUM_PLANNER_SPEED * MINIMUM_PLANNER_SPEED)
        self.buf = []
        self.head = 0
        self.last = None
        self.entry_v2 = None

    def _reverse(self, j, end_v2):
        """Max entry v2 of buf[j] such that the machine can reach end_v2 at the end of the
        buffer: min over k >= j of max_entry_k + sum of delta_v2 between."""
        buf = self.buf
        r = INF
        s = 0.0
        n = len(buf)
        for k in range(j, n):
            bk = buf[k]
            c = bk.max_start_v2 + s
            if c < r:
                r = c
            s += bk.delta_v2
            if s >= r:
                return r
        c = end_v2 + s
        return c if c < r else r

    def _execute(self, end_v2):
        # _reverse(i + 1, end_v2) and _set_trapezoid written out: this runs once per block
        buf = self.buf
        i = self.head
        b = buf[i]
        e = self.entry_v2
        if e is None:
            e = self._reverse(i, end_v2)
        n = len(buf)
        if i + 1 < n:
            x = INF                             # _reverse(i + 1, end_v2)
            acc = 0.0
            for k in range(i + 1, n):
                bk = buf[k]
                c = bk.max_start_v2 + acc
                if c < x:
                    x = c
                acc += bk.delta_v2
                if acc >= x:
                    break
            else:
                c = end_v2 + acc
                if c < x:
                    x = c
        else:
            x = end_v2
        dv2 = b.delta_v2
        f = e + dv2
        if f < x:
            x = f
        if x < e - dv2:                     # cannot happen with a consistent plan; stay physical
            x = e - dv2
        c = (e + x + dv2) * 0.5
        if b.v2max < c:
            c = b.v2max
        if c < e:
            c = e
        if c < x:
            c = x
        # _set_trapezoid(b, e, c, x)
        half_inv_a = 0.5 / b.accel
        accel_d = (c - e) * half_inv_a
        decel_d = (c - x) * half_inv_a
        cruise_d = b.d - accel_d - decel_d
        if cruise_d < 0.0:                  # rounding only
            cruise_d = 0.0
        sv = math.sqrt(e) if e > 0.0 else 0.0
        cv = math.sqrt(c)
        ev = math.sqrt(x) if x > 0.0 else 0.0
        b.start_v, b.cruise_v, b.end_v = sv, cv, ev
        b.accel_t = accel_d / ((sv + cv) * 0.5) if accel_d > 0.0 else 0.0
        b.cruise_t = cruise_d / cv
        b.decel_t = decel_d / ((ev + cv) * 0.5) if decel_d > 0.0 else 0.0
        self.entry_v2 = x
        self.head = i + 1
        self.out(b)
