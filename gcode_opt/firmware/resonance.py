"""The frame's resonance, solved exactly: a damped oscillator per axis driven by the
commanded motion, and the input shaper that filters that motion.

Each axis follows x'' = w^2 (x_c - x) + 2 z w (x_c' - x').  The error e = x - x_c obeys
e'' + 2 z w e' + w^2 e = -a_c(t).  The firmware commands piecewise-constant accelerations
(trapezoid phases) and jumps the velocity at every junction (Klipper's square corner
velocity, Marlin's junction deviation / jerk): a jump dv is an impulse, e' jumps by -dv.
Within a piece of constant a_c the error is the quasi-static lag -a_c/w^2 plus a free
damped oscillation r(t) -- the *ringing*.  At a piece boundary e is continuous, so r jumps
by da/w^2 (ramp excitation); at a junction r' jumps by -dv (corner excitation).  Between
events r is

    r(t) = Re(c exp(lam (t - t_k))),  lam = -s + i wd,  s = z w,  wd = w sqrt(1 - z^2),

with one complex amplitude c per event: everything below is closed-form (no time step).
The response is linear in the jumps, so the ramp and corner parts are solved apart and
sum to the whole; an input shaper sum A_i x_c(t - t_i) shapes the error the same way,
sum A_i e(t - t_i), so the shaped ringing is the same solve over the events repeated at
t_k + t_i with weights A_i.

Units: seconds, mm, mm/s, mm/s^2; frequencies in Hz.
"""
from __future__ import annotations

import math
import weakref

import numpy as np

from ..probe_rng import ProbeRng
from ..distinct import distinct

CHUNK_DECAY = 300.0      # exp(300) ~ 1e130: cumulative sums restart before float64 overflows
# numpy works a binary operation in place on a temporary operand of this many bytes or
# more (its temporary elision), and its complex product in place takes another loop with
# other last bits: a restart this long keeps numpy's own expressions
ELIDE_BYTES = 256 * 1024


# ---------------------------------------------------------------- compiled exponentials
# np.exp of the complex products the ringing takes, from the compiled firmware core
# (_core.c ring_exps / ring_exp: libm's exp, cos, sin as numpy's complex exp calls them,
# cos and sin shared by exp(-lam t) and exp(lam t)).  Used for a complex factor only once
# the core gave numpy's bits on a probe of times for it; else, or without the core, numpy.
_KERNEL_OK = {}
USE_KERNEL = True        # tests turn it off: numpy's exponentials for reference


_SIMULATE = None          # the simulate module, once imported here (its _core read each call: tests swap it)

# The core's steps are used only once probes showed they give numpy's bits (below: ~130 M
# instructions, ~25 ms, an oscillator), which pays off over many events only.  So a run's
# first PROBE_AFTER events (summed over the calls that take events) go by numpy -- the
# steps the probes compare the core with: the same bits -- and the core (probed then) from
# there on.  Below one chunk of the ringing's (~12 k events a call on the samples): a file
# of more than a chunk probes at its first call, as before; a small one never.  Tests set 0.
PROBE_AFTER = 8000
_EVENTS_SEEN = [0]


def _seen(n):
    """Count n more events towards PROBE_AFTER."""
    _EVENTS_SEEN[0] += n


def _core():
    """The compiled core for the steps the probes check, or None: without it, turned off
    (USE_KERNEL), or before PROBE_AFTER events."""
    if _EVENTS_SEEN[0] < PROBE_AFTER:
        return None
    return _core_built()


def _core_built():
    """The compiled core (with the ringing's functions), or None: without it, or turned off
    (USE_KERNEL)."""
    global _SIMULATE
    simulate = _SIMULATE
    if simulate is None:
        # (imported on first use, not at the top: simulate is the heavier module; an import
        # statement per call was ~9 us of importlib's bookkeeping, ~1 k calls a pass)
        from . import simulate
        _SIMULATE = simulate
    core = simulate._core
    return core if USE_KERNEL and core is not None and hasattr(core, "ring_exps") else None


_PROBE = [None, None]     # the last span (its bits) _probe made times for, and its times (read only)

# The probes' sizes.  Each probe is built to take every path of the step it checks (zeros of
# both signs, edge magnitudes, restarts, numpy's sum's blocks) many times over; past that,
# more random numbers add cost, not paths (each probe ran once a run on every large file:
# ~130 M instructions at 4-5 times these sizes).  tests/test_speed43b_probe43_sizes.py: a
# core 1 ulp off on any one path is still turned down.
PROBE_GRID = 401          # _probe's evenly spaced times (and 400 geometric, 7 edge ones)
PROBE_DRAWS = 500         # _probe's random times
JUMPS_PROBE_N = 4000      # _jumps_core's jumps


def _probe(span):
    """The times the exponential kernels are probed on, up to span.  The last span's are
    kept (read only: the probes only read them): three of an oscillator's four probes take
    1e4, one after the other (~0.25 ms a set; one set kept: 48 kB)."""
    key = float(span).hex()
    if _PROBE[0] == key:
        return _PROBE[1]
    t = np.concatenate([[0.0, 5e-324, 1e-310, 1e-300, 1e-20, 1e-9, span],
                        np.geomspace(1e-12, span, 400), np.linspace(0.0, span, PROBE_GRID)])
    t = np.concatenate([t, t * (1.0 + 2.0 ** -52), ProbeRng(7).uniform(0.0, span, PROBE_DRAWS)])
    t.flags.writeable = False
    _PROBE[:] = [key, t]
    return t


def _kernel_for(key, span):
    """The core if it gives numpy's bits for complex factor key ('pair', s, wd) or
    ('one', a, b) on times up to span (checked once per factor), else None."""
    core = _core()
    if core is None:
        return None
    ok = _KERNEL_OK.get(key)
    if ok is None:
        t = _probe(span)
        got = np.empty(len(t), complex)
        if key[0] == "pair":
            _kind, s, wd = key
            lam = complex(-s, wd)
            got2 = np.empty(len(t), complex)
            ok = bool(core.ring_exps(t, s, wd, got, got2)) \
                and got.tobytes() == np.exp(-lam * t).tobytes() \
                and got2.tobytes() == np.exp(lam * t).tobytes()
        else:
            _kind, a, b = key
            ok = bool(core.ring_exp(t, a, b, got)) and got.tobytes() == np.exp(complex(a, b) * t).tobytes()
        _KERNEL_OK[key] = ok
    return core if ok else None


_AMPS_MODE = {}
USE_AMPS = True          # tests turn it off: amplitudes' restarts by numpy (with ring_exps)


def _amps_numpy(osc, t_ev, dc):
    global USE_AMPS
    keep, USE_AMPS = USE_AMPS, False
    try:
        return osc.amplitudes(t_ev, dc)
    finally:
        USE_AMPS = keep


def _amps_mode(core, s, wd, span):
    """The core's ring_amps mode (True: numpy's fused-multiply-add complex product, False:
    the plain one) that gives amplitudes' numpy bits for this oscillator on a probe of
    events (restarts, gaps, zeros), else None (checked once per oscillator)."""
    if not USE_AMPS or not hasattr(core, "ring_amps"):
        return None
    key = (s, wd, span)
    if key not in _AMPS_MODE:
        rng = ProbeRng(11)
        gaps = rng.exponential(span / 300.0, 4000) * (rng.uniform(size=4000) < 0.9)
        gaps[rng.uniform(size=4000) < 0.01] *= 400.0       # long pauses: restarts apart
        t_ev = np.cumsum(gaps)
        dc = rng.normal(size=4000) + 1j * rng.normal(size=4000)
        dc[rng.uniform(size=4000) < 0.1] = 0.0
        dc.real[rng.uniform(size=4000) < 0.1] = -0.0
        osc = Oscillator.__new__(Oscillator)
        osc.s, osc.wd, osc.lam = s, wd, complex(-s, wd)
        want = _amps_numpy(osc, t_ev, dc).tobytes()
        _AMPS_MODE[key] = None
        for mode in (True, False):
            got = np.empty(len(t_ev), complex)
            end = core.ring_amps(t_ev, dc, s, wd, span, 1 << 30, 0, 0j, float(t_ev[0]), got, mode)
            if end == len(t_ev) and got.tobytes() == want:
                _AMPS_MODE[key] = mode
                break
    return _AMPS_MODE[key]


_JUMPS_OK = {}
USE_JUMPS = True         # tests turn it off: jump_amplitude by numpy


def _jumps_core(s, wd):
    """The core if its ring_jumps gives jump_amplitude's numpy bits for this oscillator on
    a probe (zeros of both signs, large and small jumps; once per oscillator), else None."""
    core = _core()
    if core is None or not USE_JUMPS or not hasattr(core, "ring_jumps"):
        return None
    ok = _JUMPS_OK.get((s, wd))
    if ok is None:
        rng = ProbeRng(17)
        n = JUMPS_PROBE_N
        dr = rng.normal(size=n) * np.exp(rng.normal(size=n) * 6.0)
        drp = rng.normal(size=n) * np.exp(rng.normal(size=n) * 6.0)
        for a in (dr, drp):
            a[rng.uniform(size=n) < 0.2] = 0.0
            a[rng.uniform(size=n) < 0.1] = -0.0
        drp[:100] = -s * dr[:100]                   # drp + s dr exactly 0
        want = (dr - 1j * (drp + s * dr) / wd).tobytes()
        got = np.empty(n, complex)
        ok = _JUMPS_OK[(s, wd)] = bool(core.ring_jumps(dr, drp, s, wd, got)) and got.tobytes() == want
    return core if ok else None


_INT_R2_OK = {}
USE_INT_R2 = True        # tests turn it off: integral_r2_fin's sum by numpy


def _int_r2_args(s, lam):
    """ring_int_r2's scalars: 2 lam's parts, 4 s, and _real_quotient's for 4 lam."""
    q, d = 2.0 * lam, 4.0 * lam
    qr, qi = d.real, d.imag
    if abs(qr) >= abs(qi):
        rat = qi / qr
        return q.real, q.imag, 4.0 * s, rat, 1.0 / (qr + qi * rat), True
    rat = qr / qi
    return q.real, q.imag, 4.0 * s, rat, 1.0 / (qi + qr * rat), False


# the small sizes (numpy's pairwise sum's unrolling and blocks, its SIMD loops' tails) three
# times over: their 7 k pieces give the per-piece numbers variety enough (a piece of 20011
# more was ~28 M instructions of every large file's run)
INT_R2_SIZES = (1, 7, 8, 9, 100, 127, 128, 129, 200, 255, 256, 257, 1000) * 3
# the large sizes (numpy's sum's recursion, many levels deep; past 128 the sum has no other
# branch), once each, made of INT_R2_SIZES' pieces over again (np.resize): a piece's
# integral is its own c's and dur's alone, checked there already, so what they add is the
# sums -- drawn and solved by numpy they were ~14 M instructions of every large file's run
INT_R2_DEEP = (4097, 5003)


def _int_r2_probe(s):
    """(c, dur, sizes): _int_r2_core's probe, the pieces of all sizes one after the other --
    the numbers of drawing, for each size n in turn, c = normal(n) exp(4 normal(n)) + 1j
    normal(n) exp(4 normal(n)), zeros where uniform(n) < 0.05 (c) and its imaginary part's,
    dur = exponential(0.5 / s, n) (zero where not uniform(n) < 0.95): the draws by
    ProbeRng.randoms, the steps on all pieces at once (~45 M instructions less than size
    by size; tests/test_speed37_ringflush_probe.py: the same bits)."""
    rng = ProbeRng(13)
    u = rng.randoms(INT_R2_SIZES, 8)
    normal, uniform = rng.normal_of, rng.uniform_of
    c = _complex_of(normal(u[0]) * np.exp(normal(u[1]) * 4.0), normal(u[2]) * np.exp(normal(u[3]) * 4.0))
    c[uniform(u[4]) < 0.05] = 0.0
    c.imag[uniform(u[5]) < 0.05] = 0.0
    dur = rng.exponential_of(u[6], 0.5 / s) * (uniform(u[7]) < 0.95)
    return c, dur, INT_R2_SIZES


def _int_r2_core(s, wd):
    """The core if its ring_int_r2 gives float(integral_r2_fin(c, dur).sum())'s numpy bits
    for this oscillator on a probe (checked once per oscillator), else None."""
    core = _core()
    if core is None or not USE_INT_R2 or not hasattr(core, "ring_int_r2"):
        return None
    lam = complex(-s, wd)
    q = 2.0 * lam
    if _kernel_for(("one", q.real, q.imag), 1e4) is None:
        return None
    ok = _INT_R2_OK.get((s, wd))
    if ok is None:
        osc = Oscillator.__new__(Oscillator)
        osc.s, osc.wd, osc.lam = s, wd, lam
        c, dur, sizes = _int_r2_probe(s)
        # every step but the sums is piece by piece: made for all sizes at once (the same
        # numbers as size by size), the sums and the core's calls size by size
        want = osc.integral_r2_fin(c, dur)
        if INT_R2_DEEP:
            c, dur, want = (np.concatenate([x] + [np.resize(x, n) for n in INT_R2_DEEP]) for x in (c, dur, want))
            sizes = sizes + INT_R2_DEEP
        decay2 = np.exp(-2.0 * s * dur)
        work = np.empty(len(dur))             # the core leaves each piece's integral there
        args = _int_r2_args(s, lam)
        ok = True
        a = 0
        for n in sizes:
            b = a + n
            got = core.ring_int_r2(c[a:b], dur[a:b], decay2[a:b], *args, work[a:b])
            # (the sum of a fresh array, as want.sum() of the size's own array was)
            if got is None or work[a:b].tobytes() != want[a:b].tobytes() \
                    or np.float64(got).tobytes() != np.float64(float(want[a:b].copy().sum())).tobytes():
                ok = False
                break
            a = b
        _INT_R2_OK[(s, wd)] = ok
    return core if ok else None


USE_SOLVE = True         # tests turn it off: _Stream._solve by the steps below (the reference)


def _complex_of(re, im):
    """re + 1j * im as the probes wrote it (re + 1j * a * b, im = a * b), set part by part:
    the same bits where re and im are finite and not zero, as the probes' draws are (the
    complex products' zero terms are then +-0 and drop out), without numpy's complex
    casts, products and sum (~5 passes over 16-byte numbers)."""
    c = np.empty(len(re), complex)
    c.real = re
    c.imag = im
    return c


def _solve_core(s, wd):
    """The core, whose ring_solve does _Stream._solve (no probe: its recursion gives the
    numpy steps' figures to rounding, not their bits, from a run's first event on); None
    without it, or with any of those steps turned off."""
    if not (USE_SOLVE and USE_AMPS and USE_JUMPS and USE_INT_R2):
        return None
    core = _core_built()
    return core if core is not None and hasattr(core, "ring_solve") else None


def release_solve_room():
    """Give back the room the core's ring_solve keeps from call to call (~7 doubles an event
    of a chunk: ~4 MB on the gyroid plate): a Collector calls it when its pass is over, so
    the room does not stay for the rest of the run.  Returns the bytes given back (0
    without the core)."""
    core = _core()
    release = getattr(core, "ring_release", None) if core is not None else None
    return release() if release is not None else 0


USE_MEMO = True          # tests turn it off: every exponential from libm
USE_JOIN = True          # tests turn it off: Oscillator.join declines (add_joined's own steps, the reference)


class RingMemo:
    """The exponentials one stream's last amplitudes / integral_r2_fin_sum call made, for
    the next calls of streams of the same oscillator (the ringing's parts and axes share
    most of their events and pieces; ringing.Collector): amps = (event times, each
    event's restart start (NaN: numpy made it), 4 numbers an event), pieces = (start
    times, lengths, 3 numbers a piece), each for the oscillator key (s, wd[, span]).

    room: the out arrays' memory, a RingRoom kept from chunk to chunk, this memo's own or
    shared with memos written one after the other (the Collector's ramp, corner and turn
    memos: each is cleared before the next part writes): a memo writing a shared room
    clears the memo that wrote it last, so no memo ever reads another's numbers."""

    def __init__(self, room=None):
        self.key = self.amps = self.key_p = self.pieces = None
        self.shared = room if room is not None else RingRoom()   # Oscillator.solve's out arrays

    @property
    def room(self):
        return self.shared.arr

    def clear(self):
        self.key = self.amps = self.key_p = self.pieces = None

    def out(self, n):
        """(t0, 4 numbers, lengths, 3 numbers) for n events and their n - 1 pieces: views of
        one array the room keeps (fresh memory costs a page fault a page; the readers of
        the last ones are done with them when the lead stream writes again)."""
        m = max(n - 1, 0)
        need = 5 * n + 4 * m
        r = self.shared.take(self, need)
        return r[:n], r[n:5 * n], r[5 * n:5 * n + m], r[5 * n + m:need]


class Room:
    """An array kept from chunk to chunk (fresh memory costs a page fault a page), 1/8 more
    than asked, for the next chunk's few more events: the ringing's chunks hold about the
    same number.  Its user must be done with what it wrote before it takes it again."""
    SLACK = 8

    def __init__(self):
        self.arr = None

    def grab(self, need):
        """The array, of at least `need` doubles."""
        if self.arr is None or len(self.arr) < need:
            self.arr = None
            self.arr = np.empty(need + need // self.SLACK)
        return self.arr


class RingRoom(Room):
    """The memory of RingMemo.out, for one memo or for several written one after the
    other."""

    def __init__(self):
        super().__init__()
        self.owner = None         # the memo that wrote it last (a weak reference: no cycle
                                  # holding the room after its Collector is gone)

    def take(self, memo, need):
        owner = self.owner() if self.owner is not None else None
        if owner is not None and owner is not memo:
            # (its numbers are about to be overwritten; not through clear(): the streams'
            # own clears are what the Collector calls it for)
            owner.key = owner.amps = owner.key_p = owner.pieces = None
        if owner is not memo:
            self.owner = weakref.ref(memo)
        return self.grab(need)


# ---------------------------------------------------------------- input shapers
def shaper_pulses(kind: str, freq_hz: float, damping_r: float = 0.1):
    """(A, T): pulse weights (sum 1) and times (s), centred so sum A_i T_i = 0 as Klipper's
    kin_shaper.c shift_pulses does (the shaper delays nothing, only smooths).  Definitions
    of klippy/extras/shaper_defs.py (ZV, MZV = its n=3, t=0.75 form, EI at 5 % tolerance)."""
    if kind == "none":
        return np.ones(1), np.zeros(1)
    z = damping_r
    df = math.sqrt(1.0 - z * z)
    t_d = 1.0 / (freq_hz * df)
    if kind == "zv":
        k = math.exp(-z * math.pi / df)
        a, t = [1.0, k], [0.0, 0.5 * t_d]
    elif kind == "mzv":
        k = math.exp(-0.75 * z * math.pi / df)
        a1 = 1.0 - 1.0 / math.sqrt(2.0)
        a, t = [a1, (math.sqrt(2.0) - 1.0) * k, a1 * k * k], [0.0, 0.375 * t_d, 0.75 * t_d]
    elif kind == "ei":
        v_tol = 0.05
        a1 = 0.24968 + 0.24961 * v_tol + ((0.80008 + 1.23328 * v_tol)
                                          + (0.49599 + 3.17316 * v_tol) * z) * z
        a3 = 0.25149 + 0.21474 * v_tol + ((-0.83249 + 1.41498 * v_tol)
                                          + (0.85181 - 4.90094 * v_tol) * z) * z
        t2 = 0.4999 + (((0.46159 + 8.57843 * v_tol) * v_tol)
                       + (((4.26169 - 108.644 * v_tol) * v_tol)
                          + ((1.75601 + 336.989 * v_tol) * v_tol) * z) * z) * z
        a, t = [a1, 1.0 - a1 - a3, a3], [0.0, t2 * t_d, t_d]
    else:
        raise ValueError(f"unknown input shaper {kind!r}")
    a = np.asarray(a, float)
    a = a / a.sum()
    t = np.asarray(t, float)
    return a, t - float(np.dot(a, t))


# ---------------------------------------------------------------- the oscillator
class Oscillator:
    """One axis: natural frequency freq_hz, damping ratio damping_r (0 < z < 1)."""

    def __init__(self, freq_hz: float, damping_r: float):
        if not (freq_hz > 0.0 and 0.0 < damping_r < 1.0):
            raise ValueError("need freq_hz > 0 and 0 < damping_r < 1")
        self.w = 2.0 * math.pi * freq_hz
        self.z = damping_r
        self.s = damping_r * self.w
        self.wd = self.w * math.sqrt(1.0 - damping_r * damping_r)
        self.lam = complex(-self.s, self.wd)
        self._join_args = None          # join's scalars for the core (made at its first call)

    def jump_amplitude(self, dr, drp):
        """Complex amplitude of the free response started by r += dr, r' += drp."""
        _seen(np.size(dr))
        core = _jumps_core(self.s, self.wd) if type(dr) is np.ndarray and type(drp) is np.ndarray \
            and dr.dtype == drp.dtype == np.float64 and dr.shape == drp.shape and dr.ndim == 1 else None
        if core is not None:
            out = np.empty(len(dr), complex)
            if core.ring_jumps(np.ascontiguousarray(dr), np.ascontiguousarray(drp), self.s, self.wd, out):
                return out
        return dr - 1j * (drp + self.s * dr) / self.wd

    def amplitudes(self, t_ev, dc, memo=None, keep=False):
        """c_k: the response's amplitude just after event k (events sorted by time), the
        sum over j <= k of dc_j exp(lam (t_k - t_j)).  A cumulative sum of dc_j
        exp(-lam (t_j - t0)), restarted every CHUNK_DECAY / s seconds (carrying the
        amplitude) so the growing exponential stays finite; each partial sum is dominated by
        its latest terms, so the rounding stays relative to what is still ringing.

        memo (a RingMemo of this oscillator), with the core: the exponentials of an event
        at the time and in a restart from the time of one the memo holds are taken from
        it (the same tt, the same numbers); keep: this call's go into the memo."""
        n = len(t_ev)
        _seen(n)
        c = np.empty(n, complex)
        if n == 0:
            return c
        lam = self.lam
        span = CHUNK_DECAY / self.s
        core = _kernel_for(("pair", self.s, self.wd), span)
        short = ELIDE_BYTES // 16             # restarts numpy works out of place
        fused = _amps_mode(core, self.s, self.wd, span) if core is not None else None
        extra = ()
        if fused is not None and memo is not None and USE_MEMO:
            got = memo.amps if memo.key == (self.s, self.wd, span) else None
            out = (np.full(n, np.nan), np.empty(4 * n)) if keep else (None, None)
            extra = (got or (None, None, None)) + out
        start = 0
        carry, t_carry = 0j, float(t_ev[0])
        while start < n:
            if fused is not None:
                # the short restarts in the core (the same steps, numpy's bits)
                got = core.ring_amps(t_ev, dc, self.s, self.wd, span, short, start, carry,
                                     t_carry, c, fused, *extra)
                if got > start:
                    start = got
                    carry, t_carry = c[start - 1], float(t_ev[start - 1])
                    if start >= n:
                        break
            t0 = float(t_ev[start])
            stop = int(np.searchsorted(t_ev, t0 + span, side="right"))
            if stop <= start:
                stop = start + 1
            tt = t_ev[start:stop] - t0
            if core is not None and stop - start < short:
                # np.exp(-lam tt), np.exp(lam tt) by the core; the products as numpy's
                e_dn, e_up = np.empty(stop - start, complex), np.empty(stop - start, complex)
                if core.ring_exps(tt, self.s, self.wd, e_dn, e_up):
                    g = np.cumsum(dc[start:stop] * e_dn)
                    c0 = carry * np.exp(lam * (t0 - t_carry))
                    c[start:stop] = (c0 + g) * e_up
                    carry, t_carry = c[stop - 1], float(t_ev[stop - 1])
                    start = stop
                    continue
            g = np.cumsum(dc[start:stop] * np.exp(-lam * tt))
            c0 = carry * np.exp(lam * (t0 - t_carry))
            c[start:stop] = (c0 + g) * np.exp(lam * tt)
            carry, t_carry = c[stop - 1], float(t_ev[stop - 1])
            start = stop
        if keep and extra:
            memo.key, memo.amps = (self.s, self.wd, span), (t_ev, extra[3], extra[4])
        return c

    def integral_r2(self, c, dur):
        """Exact integral of r(t)^2 over each piece [0, dur] (dur may be inf)."""
        s, lam = self.s, self.lam
        fin = np.isfinite(dur)
        d = np.where(fin, dur, 0.0)
        decay2 = np.where(fin, np.exp(-2.0 * s * d), 0.0)
        osc2 = np.where(fin, np.exp(2.0 * lam * d), 0.0)
        return np.abs(c) ** 2 * (1.0 - decay2) / (4.0 * s) + np.real(c * c * (osc2 - 1.0) / (4.0 * lam))

    def integral_r2_fin(self, c, dur):
        """integral_r2 for finite durations, the same bits at less cost: no masks, and of
        the complex quotient by 4 lam only its real part, by the division numpy does
        (Smith's, as in its complex divide loop; tests/test_speed_ringing.py checks it)."""
        s, lam = self.s, self.lam
        _seen(np.size(dur))
        decay2 = np.exp(-2.0 * s * dur)
        q = 2.0 * lam
        core = _kernel_for(("one", q.real, q.imag), 1e4)
        osc2 = None
        if core is not None:
            osc2 = np.empty(len(dur), complex)
            if not core.ring_exp(np.ascontiguousarray(dur), q.real, q.imag, osc2):
                osc2 = None
        if osc2 is None:
            osc2 = np.exp(q * dur)
        y = c * c * (osc2 - 1.0)
        return np.abs(c) ** 2 * (1.0 - decay2) / (4.0 * s) + _real_quotient(y, 4.0 * lam)

    def integral_r2_fin_sum(self, c, dur, memo=None, keep=False, ts=None) -> float:
        """float(integral_r2_fin(c, dur).sum()), the same bits: in one pass of the core
        (ring_int_r2) once it gave numpy's bits on a probe for this oscillator; numpy's
        real exponential (its own SIMD loop) stays numpy's.  memo (a RingMemo of this
        oscillator) and ts (the pieces' start times): a piece from the start and of the
        length of one the memo holds takes its exponentials (the same argument, the same
        numbers); keep: this call's go into the memo."""
        _seen(len(dur))
        core = _int_r2_core(self.s, self.wd)
        if core is not None and len(dur):
            decay2 = np.exp(-2.0 * self.s * dur)
            extra = ()
            if memo is not None and ts is not None and USE_MEMO:
                got = memo.pieces if memo.key_p == (self.s, self.wd) else None
                extra = (ts,) + (got or (None, None, None)) + ((np.empty(3 * len(dur)),) if keep else (None,))
            got = core.ring_int_r2(c, dur, decay2, *_int_r2_args(self.s, self.lam), np.empty(len(dur)), *extra)
            if got is not None:
                if keep and extra:
                    memo.key_p, memo.pieces = (self.s, self.wd), (ts, dur, extra[4])
                return got
        return float(self.integral_r2_fin(c, dur).sum())

    def solve(self, t, dr, drp, first, floor=0.0):
        """_Stream._solve's numbers in one call of the core (ring_solve): the amplitudes of
        the events at t (jump_amplitude(dr, drp), after `first`, the carried amplitude at
        t[0], unless None), then over the pieces between them integral_r2_fin_sum and
        max_abs_r -- (sum, peak, last amplitude), sum and peak None for one event; None
        where the core does not do it (not there or turned off, a number that is not
        finite): the caller takes the steps itself.  The amplitudes by their recursion,
        c_k = c_(k-1) exp(lam (t_k - t_(k-1))) + dc_k, each piece length's numbers made
        once (the core's table): the steps' figures to rounding, not their bits (closer to
        the exact ones: tests/test_speed46_ring46_recursion.py).

        floor: a peak the caller has already (its earlier chunks' max): pieces whose |c|
        (1 + 1e-9) is below it are not solved (|r| <= |c| on a piece), and the peak
        returned is then only at least this chunk's largest |Re c|, not its max -- the
        caller's max stays the same."""
        _seen(len(t))
        core = _solve_core(self.s, self.wd)
        if core is None:
            return None
        t, dr, drp = (np.ascontiguousarray(a, np.float64) for a in (t, dr, drp))
        return core.ring_solve(t, dr, drp, first, self.s, self.wd, *_int_r2_args(self.s, self.lam), floor)

    def join(self, t1, dr1, drp1, has_last, nw, horizon_t, first, floor):
        """ringing._Stream.add_joined's steps for a stream without a shaper, in one call of
        the core (ring_join) rather than numpy's steps and solve()'s call (~20 us of
        Python a call: ~5 ms of a plate's ringing pass): 0.0 added to the new times
        t1[has_last + nw:] in place, k = the events of t1[has_last:] before horizon_t
        (np.searchsorted, "left"), and solve(t1[:has_last + k], dr1[:k], drp1[:k], first,
        floor) where k > 0.  Returns (k, solve's result, None if k is 0), or None where the
        core does not take these steps (not there or turned off, the times after the
        carried one not in order, a number not finite: solve would decline; arrays not
        contiguous float64, t1 not writable): the caller's own steps then (the times' 0.0
        added twice is the same)."""
        core = _solve_core(self.s, self.wd) if USE_JOIN else None
        if core is None or not hasattr(core, "ring_join"):
            return None
        args = self._join_args
        if args is None:
            args = self._join_args = (self.s, self.wd) + _int_r2_args(self.s, self.lam)
        got = core.ring_join(t1, dr1, drp1, has_last, nw, horizon_t, first, floor, *args)
        if got is None or (got[0] and got[1] is None):
            return None
        if got[0]:
            _seen(has_last + got[0])          # (solve's count: its t, the carried time and k events)
        return got

    def peak_abs_r(self, c, dur):
        """Exact max |r| over each piece [0, dur): the larger of the start, the end and the
        first extremum inside (later extrema are smaller by exp(-s pi / wd) each, and |r| is
        monotonic between extrema)."""
        lam, wd = self.lam, self.wd
        fin = np.isfinite(dur)
        d = np.where(fin, dur, 0.0)
        best = np.abs(c.real)
        end = np.abs(np.real(c * np.exp(lam * d)))
        best = np.maximum(best, np.where(fin, end, 0.0))
        phi = np.angle(lam * c)
        tau = np.mod(0.5 * math.pi - phi, math.pi) / wd
        inside = (tau < d) | ~fin
        ext = np.abs(np.real(c * np.exp(lam * tau)))
        return np.maximum(best, np.where(inside, ext, 0.0))

    def max_abs_r(self, c, dur) -> float:
        """peak_abs_r(c, dur).max() (c not empty), the same number at a fraction of the cost:
        on a piece |r| <= |c| (it only decays), so a piece whose |c| is below the largest
        start |Re c| cannot hold the peak and is not solved (a 1e-9 margin covers rounding;
        a NaN is kept)."""
        lo = np.abs(c.real).max()
        keep = ~(np.abs(c) * (1.0 + 1e-9) < lo)
        return float(np.maximum(lo, self.peak_abs_r(c[keep], dur[keep]).max()))

    def evaluate(self, t_ev, c, t):
        """r at times t (exact), 0 before the first event."""
        if len(c) == 0:
            return np.zeros(np.shape(t))
        k = np.searchsorted(t_ev, t, side="right") - 1
        kk = np.maximum(k, 0)
        r = np.real(c[kk] * np.exp(self.lam * (t - t_ev[kk])))
        return np.where(k >= 0, r, 0.0)


def _real_quotient(y, q: complex):
    """np.real(y / q) for a complex array y and a nonzero complex q: Smith's division, the
    scalars it makes of q once, of y only the real part's operations."""
    qr, qi = q.real, q.imag
    if abs(qr) >= abs(qi):
        rat = qi / qr
        scl = 1.0 / (qr + qi * rat)
        return (y.real + y.imag * rat) * scl
    rat = qr / qi
    scl = 1.0 / (qi + qr * rat)
    return (y.real * rat + y.imag) * scl


class Response:
    """The ringing of one axis for one set of jumps: event times, amplitudes, pieces."""

    def __init__(self, osc: Oscillator, t_ev, dr, drp):
        order = np.argsort(t_ev, kind="stable")
        self.osc = osc
        self.t_ev = np.asarray(t_ev, float)[order]
        dc = osc.jump_amplitude(np.asarray(dr, float)[order], np.asarray(drp, float)[order])
        self.c = osc.amplitudes(self.t_ev, dc)
        self.dur = np.append(np.diff(self.t_ev), np.inf)    # the last rings down at rest

    def int_r2(self) -> float:
        return float(self.osc.integral_r2(self.c, self.dur).sum())

    def peak(self) -> float:
        return float(self.osc.peak_abs_r(self.c, self.dur).max()) if len(self.c) else 0.0

    def at(self, t):
        return self.osc.evaluate(self.t_ev, self.c, np.asarray(t, float))


def shaped_events(t_ev, jumps, a_pulse, t_pulse):
    """The events of the shaped command: each event repeated at t + T_i, jumps times A_i."""
    t = (t_ev[None, :] + t_pulse[:, None]).ravel()
    return t, [(a_pulse[:, None] * j[None, :]).ravel() for j in jumps]


# ---------------------------------------------------------------- path smoothing
SMOOTH_CHUNK = 1 << 18   # merged pieces evaluated at once (bounded memory on large files)


def smoothing(t0, x0, v0, a0, pulses, samples=4):
    """Distance between the shaped and the unshaped commanded XY position.

    The command is piecewise quadratic: piece k starts at t0[k] with position x0[k] (n x 2),
    velocity v0[k] and constant acceleration a0[k]; before t0[0] and after the last piece's
    start it must be at rest (callers add rest pieces at both ends).  pulses = ((A_x, T_x),
    (A_y, T_y)), each axis shaped by its own shaper.  Returns (rms_d, max_d): the RMS over
    [t0[0], t0[-1]] exact (the difference is a quadratic on every piece between the merged
    breakpoints, its square integrated in closed form), the max from `samples` points per
    merged piece (pieces last milliseconds)."""
    shifts = [t0 + ti for a_p, t_p in pulses for ti in t_p]
    brk = distinct(np.concatenate(shifts + [t0]))
    del shifts
    brk = brk[(brk >= t0[0]) & (brk <= t0[-1])]
    integral, total_t, mx = 0.0, float(brk[-1] - brk[0]) if len(brk) else 0.0, 0.0
    for c0 in range(0, max(len(brk) - 1, 0), SMOOTH_CHUNK):
        b = brk[c0:c0 + SMOOTH_CHUNK + 1]
        i, m = _smoothing_chunk(t0, x0, v0, a0, pulses, b, samples)
        integral += i
        mx = max(mx, m)
    rms = math.sqrt(max(integral, 0.0) / total_t) if total_t > 0 else 0.0
    return rms, mx


def _smoothing_chunk(t0, x0, v0, a0, pulses, brk, samples):
    T = np.diff(brk)
    s_m = brk[:-1]
    p = np.zeros((len(s_m), 2))
    q = np.zeros_like(p)
    acc = np.zeros_like(p)
    for ax, (a_p, t_p) in enumerate(pulses):
        for ai, ti in list(zip(a_p, t_p)) + [(-1.0, 0.0)]:
            tt = s_m - ti
            # the piece is found at the merged piece's middle: at its start, rounding of
            # (t0 + ti) - ti could pick the piece before and carry its velocity along
            k = np.clip(np.searchsorted(t0, tt + 0.5 * T, side="right") - 1, 0, len(t0) - 1)
            tau = tt - t0[k]
            p[:, ax] += ai * (x0[k, ax] + v0[k, ax] * tau + 0.5 * a0[k, ax] * tau * tau)
            q[:, ax] += ai * (v0[k, ax] + a0[k, ax] * tau)
            acc[:, ax] += ai * a0[k, ax]
    pp, pq, qq = (p * p).sum(1), (p * q).sum(1), (q * q).sum(1)
    ps, qs, ss = (p * acc).sum(1), (q * acc).sum(1), (acc * acc).sum(1)
    integral = (pp * T + pq * T ** 2 + (qq + ps) * T ** 3 / 3.0 + qs * T ** 4 / 4.0
                + ss * T ** 5 / 20.0)
    mx = 0.0
    for j in range(samples):
        tau = (T * j / samples)[:, None]
        d = p + q * tau + 0.5 * acc * tau * tau
        if len(d):
            mx = max(mx, float(np.sqrt((d * d).sum(1)).max()))
    return float(integral.sum()), mx
